//! Kinematic joints as algebraic constraints `Φ(q, t) = 0` with Lagrange multipliers
//! (paper Eq. 2–3).
//!
//! A joint acts at *anchors*: a node of the mesh, or a point of a rigid body (the body's
//! node with an arm `p`, the point's offset from the body's centre at the reference). In
//! displacement coordinates an anchor moves by `Δr = u + (R(φ) − I) p`. Every row of a
//! planar joint is one of two laws on at most two nodes `a`, `b` (`a` may be the ground):
//!
//! * **angle**: `φ_b − φ_a` (the rotation of a clamp, a weld or a slider, and drives);
//! * **separation**: `mᵀ (Δr_a − Δr_b)`, the relative displacement of two anchors that
//!   coincide at the reference, along a direction `m` fixed in space (`m = n`) or carried
//!   by `a` (`m = R(φ_a) n`, a slider's axis on a moving body); either may be the ground.
//!
//! Between beam nodes, and for directions fixed in space, these are linear in `q`, as all
//! joints were in the paper; an arm or a carried direction makes them nonlinear, and the
//! Hessian term `Σ λₖ ∂²Φₖ/∂q²` of [`ConstraintRow::add_hessian`] enters the iteration
//! matrix so that Newton stays quadratic.
//!
//! Sign convention: the residual is `r = M q̈ + f_int − f_ext + Φ_qᵀλ`, so the force a joint
//! applies to the structure is `−Φ_qᵀλ`; reactions and motor torques are reported that way.

use nalgebra::Vector2;

use crate::joint::motion::Motion;

/// Where a joint acts: a node, or a point of a rigid body at `arm` from its centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Anchor {
    /// The node (a beam's node or a rigid body's).
    pub node: usize,
    /// Offset of the point from the node at the reference (m); zero on a beam node.
    pub arm: Vector2<f64>,
}

impl Anchor {
    /// The node itself.
    pub fn at(node: usize) -> Self {
        Self {
            node,
            arm: Vector2::zeros(),
        }
    }
}

/// Which joint, at which anchors.
#[derive(Debug, Clone, PartialEq)]
pub enum JointKind {
    /// Anchor fixed in position and rotation.
    Clamp {
        /// The clamped anchor.
        at: Anchor,
    },
    /// Anchor fixed in position; its rotation is free or driven (absolute).
    Pin {
        /// The pinned anchor.
        at: Anchor,
    },
    /// Two coincident anchors kept together; relative rotation free or driven (revolute).
    Hinge {
        /// `[a, b]`; a drive prescribes `φ_b − φ_a`.
        at: [Anchor; 2],
    },
    /// Two coincident anchors kept together with their relative rotation locked.
    Weld {
        /// `[a, b]`.
        at: [Anchor; 2],
    },
    /// Anchor `slider` moves along `axis` through its reference position, fixed on the
    /// ground or carried by `carrier`; relative rotation locked; a drive prescribes the
    /// travel along the axis (m).
    Prismatic {
        /// The point of the body or node carrying the axis that coincides with the slider
        /// at the reference; `None` for the ground.
        carrier: Option<Anchor>,
        /// The sliding anchor.
        slider: Anchor,
        /// Unit direction of the axis at the reference.
        axis: Vector2<f64>,
    },
    /// Anchor moving along an axis fixed on the ground through its reference position, its
    /// rotation free (a roller support); a drive prescribes the travel along the axis (m).
    Roller {
        /// The rolling anchor.
        at: Anchor,
        /// Unit direction of the axis.
        axis: Vector2<f64>,
    },
}

/// A named joint, possibly driven.
#[derive(Debug, Clone, PartialEq)]
pub struct Joint {
    /// Name used in results and error messages.
    pub name: String,
    /// Kind and anchors.
    pub kind: JointKind,
    /// Motion law of the driven rotation (or travel of a slider), if any.
    pub drive: Option<Motion>,
}

/// The law of one constraint row (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Law {
    /// `φ_b − φ_a`.
    Angle,
    /// `mᵀ(Δr_a − Δr_b)` with `m = n` or, `carried`, `m = R(φ_a) n`.
    Separation {
        /// Arms `[p_a, p_b]` of the two anchors (m).
        arms: [Vector2<f64>; 2],
        /// The direction `n` at the reference (unit).
        direction: Vector2<f64>,
        /// Whether `a` carries the direction.
        carried: bool,
    },
}

/// One scalar constraint `Φ = h(q_a, q_b) − g(t)` on at most two nodes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConstraintRow {
    /// `[a, b]`; `None` is the ground.
    pub nodes: [Option<usize>; 2],
    /// `h`.
    pub law: Law,
    /// Index of the joint that owns the row.
    pub joint: usize,
    /// Whether `g(t) = θ(t) − θ(0)` of the joint's drive (otherwise `g = 0`).
    pub driven: bool,
}

/// Global DOF index of component `k` (0: x, 1: y, 2: φ) of `node`.
pub const fn dof(node: usize, k: usize) -> usize {
    3 * node + k
}

impl JointKind {
    /// The kind's name in a scene.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Clamp { .. } => "clamp",
            Self::Pin { .. } => "pin",
            Self::Hinge { .. } => "hinge",
            Self::Weld { .. } => "weld",
            Self::Prismatic { .. } => "prismatic",
            Self::Roller { .. } => "roller",
        }
    }
}

/// `(1, 0)` and `(0, 1)`.
const AXES: [Vector2<f64>; 2] = [Vector2::new(1.0, 0.0), Vector2::new(0.0, 1.0)];

impl Joint {
    /// The joint's constraint rows, the drive row last: its [`Joint::coordinate`] following
    /// the drive's law.
    pub fn rows(&self, joint: usize) -> Vec<ConstraintRow> {
        let row = |nodes, law| ConstraintRow {
            nodes,
            law,
            joint,
            driven: false,
        };
        let coincide = |nodes: [Option<usize>; 2], arms| {
            AXES.map(|direction| {
                let law = Law::Separation {
                    arms,
                    direction,
                    carried: false,
                };
                row(nodes, law)
            })
        };
        let mut rows = Vec::new();
        match self.kind {
            JointKind::Clamp { at } | JointKind::Pin { at } => {
                rows.extend(coincide([Some(at.node), None], [at.arm, Vector2::zeros()]));
            }
            JointKind::Hinge { at: [a, b] } | JointKind::Weld { at: [a, b] } => {
                rows.extend(coincide([Some(a.node), Some(b.node)], [a.arm, b.arm]));
            }
            JointKind::Prismatic {
                carrier,
                slider,
                axis,
            } => {
                let normal =
                    separation(joint, carrier, slider, Vector2::new(-axis.y, axis.x), false);
                rows.extend([normal, self.angle(joint)]);
            }
            JointKind::Roller { at, axis } => {
                rows.push(separation(
                    joint,
                    None,
                    at,
                    Vector2::new(-axis.y, axis.x),
                    false,
                ));
            }
        }
        match (&self.kind, self.coordinate(joint)) {
            (JointKind::Clamp { .. } | JointKind::Weld { .. }, _) => rows.push(self.angle(joint)),
            (_, Some(free)) if self.drive.is_some() => rows.push(ConstraintRow {
                driven: true,
                ..free
            }),
            _ => {}
        }
        rows
    }

    /// The joint's own coordinate as a row: the rotation of a pin, the relative rotation
    /// `φ_b − φ_a` of a hinge, a slider's travel along its axis; what a drive prescribes.
    /// `None` for a clamp or weld, which hold everything.
    pub fn coordinate(&self, joint: usize) -> Option<ConstraintRow> {
        match self.kind {
            JointKind::Clamp { .. } | JointKind::Weld { .. } => None,
            JointKind::Pin { .. } | JointKind::Hinge { .. } => Some(self.angle(joint)),
            // Along `−axis`: the slider's travel `axisᵀ(Δr_slider − Δr_carrier)`.
            JointKind::Prismatic {
                carrier,
                slider,
                axis,
            } => Some(separation(joint, carrier, slider, -axis, true)),
            // Read at the point: the rotation is free.
            JointKind::Roller { at, axis } => Some(separation(joint, None, at, -axis, false)),
        }
    }

    /// The row `φ_b − φ_a` of the joint's two nodes (`φ_b` alone on the ground).
    fn angle(&self, joint: usize) -> ConstraintRow {
        let nodes = match self.kind {
            JointKind::Clamp { at } | JointKind::Pin { at } | JointKind::Roller { at, .. } => {
                [None, Some(at.node)]
            }
            JointKind::Hinge { at: [a, b] } | JointKind::Weld { at: [a, b] } => {
                [Some(a.node), Some(b.node)]
            }
            JointKind::Prismatic {
                carrier, slider, ..
            } => [carrier.map(|c| c.node), Some(slider.node)],
        };
        ConstraintRow {
            nodes,
            law: Law::Angle,
            joint,
            driven: false,
        }
    }

    /// Nodes the joint acts on.
    pub fn nodes(&self) -> Vec<usize> {
        match self.kind {
            JointKind::Clamp { at } | JointKind::Pin { at } | JointKind::Roller { at, .. } => {
                vec![at.node]
            }
            JointKind::Hinge { at } | JointKind::Weld { at } => vec![at[0].node, at[1].node],
            JointKind::Prismatic {
                carrier, slider, ..
            } => carrier
                .into_iter()
                .map(|c| c.node)
                .chain([slider.node])
                .collect(),
        }
    }

    /// Whether the joint ties its node(s) to the ground.
    pub fn is_grounded(&self) -> bool {
        match self.kind {
            JointKind::Clamp { .. } | JointKind::Pin { .. } | JointKind::Roller { .. } => true,
            JointKind::Hinge { .. } | JointKind::Weld { .. } => false,
            JointKind::Prismatic { carrier, .. } => carrier.is_none(),
        }
    }

    /// Prescribed value `g(t)` and its derivatives for a driven row, zero otherwise.
    pub fn prescribed(&self, row: &ConstraintRow, t: f64) -> [f64; 3] {
        match (&self.drive, row.driven) {
            (Some(m), true) => {
                let (now, start) = (m.at(t), m.at(0.0));
                [now.angle - start.angle, now.velocity, now.acceleration]
            }
            _ => [0.0; 3],
        }
    }
}

/// The row of joint `joint` separating a slider from its carrier along `direction`
/// (carried by the carrier, fixed for the ground), read at the slider's point, or with
/// `centre` at its centre when the axis is on the ground: there the slider's rotation is
/// held at zero, so its centre travels as its point does, and the travel stays linear for
/// motors, dampers and springs.
fn separation(
    joint: usize,
    carrier: Option<Anchor>,
    slider: Anchor,
    direction: Vector2<f64>,
    centre: bool,
) -> ConstraintRow {
    let arm = if centre && carrier.is_none() {
        Vector2::zeros()
    } else {
        slider.arm
    };
    ConstraintRow {
        nodes: [carrier.map(|c| c.node), Some(slider.node)],
        law: Law::Separation {
            arms: [carrier.map_or(Vector2::zeros(), |c| c.arm), arm],
            direction,
            carried: carrier.is_some(),
        },
        joint,
        driven: false,
    }
}

/// `(sin φ, cos φ − 1)`, the latter without cancellation at small angles: the rotation
/// `R(φ) − I` a displacement formulation needs.
pub(crate) fn turn(phi: f64) -> (f64, f64) {
    let (s, c) = phi.sin_cos();
    (s, if c > 0.0 { -s * s / (1.0 + c) } else { c - 1.0 })
}

/// `(R(φ) − I) v` for `(s, c1) = turn(φ)`.
pub(crate) fn turned_minus(v: Vector2<f64>, (s, c1): (f64, f64)) -> Vector2<f64> {
    Vector2::new(c1 * v.x - s * v.y, s * v.x + c1 * v.y)
}

/// `J v`, the quarter turn.
pub(crate) fn perp(v: Vector2<f64>) -> Vector2<f64> {
    Vector2::new(-v.y, v.x)
}

/// `turn(φ) = (sin φ, cos φ − 1)` of each node a row turns, at one `q`: one sine and cosine per node for all the
/// rows that share it (the rows of a joint, the joints on a body), read by
/// [`ConstraintRow::evaluate_with`] and [`ConstraintRow::add_hessian_with`].
#[derive(Debug, Clone)]
pub struct Turns {
    /// The nodes some row turns.
    nodes: Vec<usize>,
    /// `turn(φ)` by node (`(0, 0)`, no turn, for the others).
    by_node: Vec<(f64, f64)>,
}

impl Turns {
    /// Room for the turns of `rows` on `n_nodes` nodes, all zero.
    pub fn new(rows: &[ConstraintRow], n_nodes: usize) -> Self {
        let mut nodes: Vec<usize> = rows
            .iter()
            .flat_map(|r| {
                let turning = r.turning();
                r.nodes
                    .into_iter()
                    .zip(turning)
                    .filter_map(|(n, on)| n.filter(|_| on))
            })
            .collect();
        nodes.sort_unstable();
        nodes.dedup();
        Self {
            nodes,
            by_node: vec![(0.0, 0.0); n_nodes],
        }
    }

    /// The turns of `rows` at `q`.
    pub fn at(rows: &[ConstraintRow], q: &[f64]) -> Self {
        let mut turns = Self::new(rows, q.len() / 3);
        turns.update(q);
        turns
    }

    /// Re-reads the rotations of `q`.
    pub fn update(&mut self, q: &[f64]) {
        for &n in &self.nodes {
            self.by_node[n] = turn(q[dof(n, 2)]);
        }
    }

    /// The turns of a row's two nodes (none on the ground).
    fn of(&self, nodes: [Option<usize>; 2]) -> [(f64, f64); 2] {
        nodes.map(|n| n.map_or((0.0, 0.0), |n| self.by_node[n]))
    }
}

impl ConstraintRow {
    /// The six DOFs `[x_a, y_a, φ_a, x_b, y_b, φ_b]` of the row (`None` on the ground).
    pub fn dofs(&self) -> [Option<usize>; 6] {
        std::array::from_fn(|i| self.nodes[i / 3].map(|n| dof(n, i % 3)))
    }

    /// Which of [`ConstraintRow::dofs`] the row can depend on: its structural nonzeros.
    pub fn active(&self) -> [bool; 6] {
        let present = self.dofs().map(|d| d.is_some());
        let depends = match self.law {
            Law::Angle => [false, false, true, false, false, true],
            Law::Separation {
                arms,
                direction,
                carried,
            } => {
                let moves = |k: usize| direction[k] != 0.0 || carried;
                [
                    moves(0),
                    moves(1),
                    carried || arms[0] != Vector2::zeros(),
                    moves(0),
                    moves(1),
                    arms[1] != Vector2::zeros(),
                ]
            }
        };
        std::array::from_fn(|i| present[i] && depends[i])
    }

    /// Whether `h` is linear in `q` (no Hessian).
    pub fn is_linear(&self) -> bool {
        match self.law {
            Law::Angle => true,
            Law::Separation { arms, carried, .. } => {
                !carried && arms.iter().all(|a| *a == Vector2::zeros())
            }
        }
    }

    /// The row's six coordinates of `q` (zero on the ground).
    fn local(&self, q: &[f64]) -> [f64; 6] {
        self.dofs().map(|d| d.map_or(0.0, |d| q[d]))
    }

    /// Which of the row's two nodes it turns: an arm, or `a` carrying the direction.
    fn turning(&self) -> [bool; 2] {
        match self.law {
            Law::Angle => [false; 2],
            Law::Separation { arms, carried, .. } => [
                carried || arms[0] != Vector2::zeros(),
                arms[1] != Vector2::zeros(),
            ],
        }
    }

    /// [`turn`] of the row's nodes at its own coordinates `l`.
    fn own_turns(&self, l: &[f64; 6]) -> [(f64, f64); 2] {
        let turning = self.turning();
        [0, 1].map(|k| {
            if turning[k] {
                turn(l[3 * k + 2])
            } else {
                (0.0, 0.0)
            }
        })
    }

    /// `h(q)` and its gradient on [`ConstraintRow::dofs`] (zero where inactive).
    pub fn evaluate(&self, q: &[f64]) -> (f64, [f64; 6]) {
        let l = self.local(q);
        self.evaluate_turned(&l, self.own_turns(&l))
    }

    /// [`ConstraintRow::evaluate`] with the nodes' turns at `q` read once for all rows.
    pub fn evaluate_with(&self, q: &[f64], turns: &Turns) -> (f64, [f64; 6]) {
        self.evaluate_turned(&self.local(q), turns.of(self.nodes))
    }

    fn evaluate_turned(&self, l: &[f64; 6], turns: [(f64, f64); 2]) -> (f64, [f64; 6]) {
        match self.law {
            Law::Angle => (l[5] - l[2], [0.0, 0.0, -1.0, 0.0, 0.0, 1.0]),
            Law::Separation {
                arms,
                direction,
                carried,
            } => {
                let s = Separation::at(l, arms, direction, carried, turns);
                let m = s.m;
                let carrying = if carried { perp(m).dot(&s.gap) } else { 0.0 };
                let d_phi_a = carrying + m.dot(&perp(s.turned[0]));
                let d_phi_b = -m.dot(&perp(s.turned[1]));
                let mut g = [m.x, m.y, d_phi_a, -m.x, -m.y, d_phi_b];
                let active = self.active();
                g.iter_mut()
                    .zip(active)
                    .for_each(|(v, on)| *v = if on { *v } else { 0.0 });
                (m.dot(&s.gap), g)
            }
        }
    }

    /// `∂h/∂q` on [`ConstraintRow::dofs`].
    pub fn gradient(&self, q: &[f64]) -> [f64; 6] {
        self.evaluate(q).1
    }

    /// Adds `weight · ∂²h/∂q²` on [`ConstraintRow::dofs`] to `out` (row-major 6 × 6).
    pub fn add_hessian(&self, q: &[f64], weight: f64, out: &mut [[f64; 6]; 6]) {
        let l = self.local(q);
        self.add_hessian_turned(&l, self.own_turns(&l), weight, out);
    }

    /// [`ConstraintRow::add_hessian`] with the nodes' turns at `q` read once for all rows.
    pub fn add_hessian_with(&self, q: &[f64], turns: &Turns, weight: f64, out: &mut [[f64; 6]; 6]) {
        self.add_hessian_turned(&self.local(q), turns.of(self.nodes), weight, out);
    }

    fn add_hessian_turned(
        &self,
        l: &[f64; 6],
        turns: [(f64, f64); 2],
        weight: f64,
        out: &mut [[f64; 6]; 6],
    ) {
        let Law::Separation {
            arms,
            direction,
            carried,
        } = self.law
        else {
            return;
        };
        let s = Separation::at(l, arms, direction, carried, turns);
        let m = s.m;
        let mut h = [[0.0; 6]; 6];
        h[2][2] = -m.dot(&s.turned[0]);
        h[5][5] = m.dot(&s.turned[1]);
        if carried {
            let jm = perp(m);
            for k in 0..2 {
                h[k][2] = jm[k];
                h[3 + k][2] = -jm[k];
                h[2][k] = jm[k];
                h[2][3 + k] = -jm[k];
            }
            h[2][2] += -m.dot(&s.gap) + 2.0 * m.dot(&s.turned[0]);
            h[2][5] = -m.dot(&s.turned[1]);
            h[5][2] = h[2][5];
        }
        let active = self.active();
        for i in 0..6 {
            for j in 0..6 {
                if active[i] && active[j] {
                    out[i][j] += weight * h[i][j];
                }
            }
        }
    }
}

/// The kinematics of a separation row at a state: the direction, the anchors' gap and
/// their turned arms `R(φ) p`.
struct Separation {
    /// `m`.
    m: Vector2<f64>,
    /// `Δr_a − Δr_b`.
    gap: Vector2<f64>,
    /// `[R(φ_a) p_a, R(φ_b) p_b]`.
    turned: [Vector2<f64>; 2],
}

impl Separation {
    /// At the row's coordinates `l`, with `turns` the [`turn`] of its nodes (only a turning
    /// arm or a carried direction reads its node's).
    fn at(
        l: &[f64; 6],
        arms: [Vector2<f64>; 2],
        n: Vector2<f64>,
        carried: bool,
        turns: [(f64, f64); 2],
    ) -> Self {
        let moved = |k: usize| turned_minus(arms[k], turns[k]);
        let shift = |k: usize| Vector2::new(l[3 * k], l[3 * k + 1]) + moved(k);
        Self {
            m: if carried {
                n + turned_minus(n, turns[0])
            } else {
                n
            },
            gap: shift(0) - shift(1),
            turned: [arms[0] + moved(0), arms[1] + moved(1)],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::joint::motion::Trapezoidal;

    #[test]
    fn driven_hinge_prescribes_relative_rotation_from_its_start() {
        let drive = Motion::Trapezoidal(Trapezoidal::new(1.0, 2.0, 2.0, 0.5, 0.0));
        let j = Joint {
            name: "elbow".into(),
            kind: JointKind::Hinge {
                at: [Anchor::at(3), Anchor::at(7)],
            },
            drive: Some(drive.clone()),
        };
        let rows = j.rows(0);
        assert_eq!(rows.len(), 3);
        let mut q = vec![0.0; 24];
        q[dof(7, 2)] = 0.4;
        q[dof(3, 2)] = 0.1;
        assert!((rows[2].evaluate(&q).0 - 0.3).abs() < 1e-15);
        let g = j.prescribed(&rows[2], 0.5);
        assert!((g[0] - (drive.at(0.5).angle - 1.0)).abs() < 1e-15);
        assert_eq!(j.prescribed(&rows[0], 0.5), [0.0; 3]);
    }

    /// Every row kind: the gradient is the central difference of the value and the
    /// Hessian that of the gradient, at a large rotation of both anchors.
    #[test]
    fn gradients_and_hessians_equal_central_differences() {
        let (a, b) = (
            Anchor {
                node: 0,
                arm: Vector2::new(0.3, -0.2),
            },
            Anchor {
                node: 1,
                arm: Vector2::new(-0.1, 0.4),
            },
        );
        let axis = Vector2::new(0.6, 0.8);
        let kinds = [
            JointKind::Pin { at: b },
            JointKind::Weld { at: [a, b] },
            JointKind::Prismatic {
                carrier: Some(a),
                slider: b,
                axis,
            },
            JointKind::Prismatic {
                carrier: None,
                slider: b,
                axis,
            },
            JointKind::Roller { at: b, axis },
        ];
        let q = [0.05, -0.02, 1.1, 0.3, 0.1, -0.7];
        for kind in kinds {
            let j = Joint {
                name: "j".into(),
                kind: kind.clone(),
                drive: Some(Motion::Trapezoidal(Trapezoidal::new(
                    0.0, 1.0, 1.0, 1.0, 0.0,
                ))),
            };
            for row in j.rows(0) {
                let g = row.gradient(&q);
                let mut h = [[0.0; 6]; 6];
                row.add_hessian(&q, 1.0, &mut h);
                let dofs = row.dofs();
                for (i, d) in dofs.iter().enumerate() {
                    let Some(d) = *d else { continue };
                    let eps = 1e-5;
                    let (mut qp, mut qm) = (q, q);
                    qp[d] += eps;
                    qm[d] -= eps;
                    let fd = (row.evaluate(&qp).0 - row.evaluate(&qm).0) / (2.0 * eps);
                    assert!(
                        (fd - g[i]).abs() < 1e-9,
                        "{kind:?} grad {i}: {} vs {fd}",
                        g[i]
                    );
                    let (gp, gm) = (row.gradient(&qp), row.gradient(&qm));
                    for k in 0..6 {
                        let fd = (gp[k] - gm[k]) / (2.0 * eps);
                        assert!(
                            (fd - h[k][i]).abs() < 1e-8,
                            "{kind:?} H[{k}][{i}]: {} vs {fd}",
                            h[k][i]
                        );
                    }
                }
            }
        }
    }
}
