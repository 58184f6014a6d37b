//! Spatial joints as index-3 constraints `Φ(q) = 0` with Lagrange multipliers, in the
//! Lie-group form: the gradient `B` acts on the nodes' increments `(u, θ)`, and the
//! constraint-force stiffness `∂(Bᵀλ)/∂q` — which Newton can do without but an exact
//! adjoint cannot — is part of the iteration matrix.
//!
//! A joint holds two anchors, each a point of a body (`p = x + R a`, `a` in the body's
//! frame from its centre of mass) or of the ground (`pair.rs`). Every kind is
//! a list of rows of one shape, the dot product of two of the pair's *measures*
//! `Φ = α · β` (as Chrono and MBDyn build theirs from primitives), so that a row's gradient
//! is `J_αᵀβ + J_βᵀα`, its Hessian contracted with its multiplier
//! `λ (H_α[β] + H_β[α] + J_αᵀJ_β + J_βᵀJ_α)`, and `Φ̈ = B v̇ + b` with
//! `b = (α̈ − J_α v̇)·β + 2 α̇·β̇ + α·(β̈ − J_β v̇)`. The kinds:
//!
//! | kind | rows |
//! |---|---|
//! | spherical | the gap's three components: the points coincide |
//! | universal | spherical, and A's axis ⟂ B's axis |
//! | revolute | spherical, and two axes of A normal to the hinge ⟂ the hinge in B |
//! | cylindrical | the hinge kept parallel (two rows), B's point on A's hinge line (the gap ⟂ A's two normals) |
//! | prismatic | cylindrical, and A's first normal ⟂ B's second: no turning about the axis |
//! | weld | spherical, and three pairs of A's and B's axes kept normal: no relative rotation |
//!
//! Axes are given in the inertial frame in the initial configuration and carried by each
//! body from there. Local unknowns are A's node's six then B's.

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

pub(crate) use crate::group::pair::Stiffness;
use crate::group::pair::{Measure, Pair, Product, Side, LOCAL};

use crate::group::six;
use crate::joint::motion::{LawParameter, Motion};

/// The most rows a joint has (the weld's).
pub const MAX_ROWS: usize = 6;

/// A joint's rows' gradients on its local unknowns.
pub(crate) type Gradient = SMatrix<f64, MAX_ROWS, LOCAL>;

/// A point a joint holds: of a body (by its index, the point in the body's frame from its
/// centre of mass) or fixed in space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Anchor {
    /// A point of the ground, in the inertial frame (m).
    Ground(Vector3<f64>),
    /// A body's point.
    Body {
        /// The body's index in the model.
        body: usize,
        /// The point in the body's frame, from its centre of mass (m).
        point: Vector3<f64>,
    },
    /// A point of a node's frame: a beam's end (`SpatialModel::add_node`).
    Node {
        /// The node's index in the model.
        node: usize,
        /// The point in the node's frame, from its origin (m).
        point: Vector3<f64>,
    },
}

/// What a joint constrains, its axes in the inertial frame in the initial configuration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum JointKind {
    /// The points coincide; every rotation free (3 rows).
    Spherical,
    /// The points coincide; one rotation about `axis` free (5 rows).
    Revolute {
        /// The hinge's axis.
        axis: Vector3<f64>,
    },
    /// The points coincide; rotations about A's `axis_a` and B's `axis_b`, at right angles,
    /// free: a Cardan joint (4 rows).
    Universal {
        /// The axis carried by A.
        axis_a: Vector3<f64>,
        /// The axis carried by B, normal to `axis_a`.
        axis_b: Vector3<f64>,
    },
    /// B slides along and turns about A's `axis` through A's point (4 rows).
    Cylindrical {
        /// The axis.
        axis: Vector3<f64>,
    },
    /// B slides along A's `axis` through A's point, without turning (5 rows).
    Prismatic {
        /// The axis.
        axis: Vector3<f64>,
    },
    /// The points coincide and the bodies do not turn relative to each other (6 rows).
    Weld,
}

impl JointKind {
    /// The kind as a scene names it.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Spherical => "spherical",
            Self::Revolute { .. } => "revolute",
            Self::Universal { .. } => "universal",
            Self::Cylindrical { .. } => "cylindrical",
            Self::Prismatic { .. } => "prismatic",
            Self::Weld => "weld",
        }
    }
}

/// A row `Φ = α · β` and what its breaking means, for errors.
#[derive(Debug, Clone, PartialEq)]
struct Row {
    alpha: Measure,
    beta: Measure,
    what: &'static str,
}

/// A joint between two anchors.
#[derive(Debug, Clone, PartialEq)]
pub struct Joint {
    /// Its name in the scene.
    pub name: String,
    /// What it constrains.
    pub kind: JointKind,
    /// Its anchors.
    pub(crate) pair: Pair,
    rows: Vec<Row>,
    /// The nodes' rotations in the initial configuration.
    initial: [Matrix3<f64>; 2],
    /// The motion imposed on its free coordinate, if driven.
    drive: Option<Drive>,
}

/// A motion law imposed on a joint's coordinate.
#[derive(Debug, Clone, PartialEq)]
struct Drive {
    law: Motion,
    coordinate: Coordinate,
}

/// A joint's free coordinate.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Coordinate {
    /// A revolute joint's angle `φ` about its axis, from the initial configuration:
    /// `cos φ = e₁·b₁`, `sin φ = e₂·b₁`, with `e₁, e₂` normals of the axis carried by A
    /// and `b₁` the first carried by B.
    Angle {
        e1: Vector3<f64>,
        e2: Vector3<f64>,
        b1: Vector3<f64>,
    },
    /// A prismatic joint's travel `n·(p_B − p_A)` along A's axis `n`, `start` initially.
    Slide { axis: Vector3<f64>, start: f64 },
}

/// Two unit vectors normal to `n` and to each other.
fn normals(n: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let pick = if n.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let e1 = n.cross(&pick).normalize();
    (e1, n.cross(&e1).normalize())
}

impl Joint {
    /// The joint `kind` between the points `arms` of the nodes `nodes`, whose rotations in
    /// the initial configuration are `initial`.
    ///
    /// # Errors
    /// What is wrong with the axes, as a message: zero or non-finite, not at right angles.
    pub(crate) fn new(
        name: &str,
        kind: JointKind,
        nodes: [Option<usize>; 2],
        arms: [Vector3<f64>; 2],
        initial: [Matrix3<f64>; 2],
    ) -> Result<Self, String> {
        let unit = |v: &Vector3<f64>, which: &str| {
            let n = v.norm();
            if v.iter().all(|x| x.is_finite()) && n > 0.0 {
                Ok(v / n)
            } else {
                Err(format!(
                    "{which} ({}, {}, {}) must be finite and not zero",
                    v.x, v.y, v.z
                ))
            }
        };
        // An inertial vector in side s's frame.
        let body = |s: usize, v: &Vector3<f64>| initial[s].transpose() * v;
        let coincide = || {
            [Vector3::x(), Vector3::y(), Vector3::z()].map(|e| Row {
                alpha: Measure::Gap,
                beta: Measure::Constant(e),
                what: "its points are apart",
            })
        };
        let normal = |a: Vector3<f64>, b: Vector3<f64>, what| Row {
            alpha: Measure::Axis(0, body(0, &a)),
            beta: Measure::Axis(1, body(1, &b)),
            what,
        };
        let parallel = |n: &Vector3<f64>| {
            let (e1, e2) = normals(n);
            [e1, e2].map(|e| normal(e, *n, "its axis is not the same in both bodies"))
        };
        let on_line = |n: &Vector3<f64>| {
            let (e1, e2) = normals(n);
            [e1, e2].map(|e| Row {
                alpha: Measure::Axis(0, body(0, &e)),
                beta: Measure::Gap,
                what: "B's point is off A's axis",
            })
        };
        let mut rows = Vec::new();
        match kind {
            JointKind::Spherical => rows.extend(coincide()),
            JointKind::Revolute { axis } => {
                let n = unit(&axis, "axis")?;
                rows.extend(coincide());
                rows.extend(parallel(&n));
            }
            JointKind::Universal { axis_a, axis_b } => {
                let (a, b) = (unit(&axis_a, "axis_a")?, unit(&axis_b, "axis_b")?);
                if a.dot(&b).abs() > 1e-9 {
                    return Err(format!(
                        "axis_a and axis_b must be at right angles (their cosine is {:.3e})",
                        a.dot(&b)
                    ));
                }
                rows.extend(coincide());
                rows.push(normal(a, b, "its axes are not at right angles"));
            }
            JointKind::Cylindrical { axis } => {
                let n = unit(&axis, "axis")?;
                rows.extend(parallel(&n));
                rows.extend(on_line(&n));
            }
            JointKind::Prismatic { axis } => {
                let n = unit(&axis, "axis")?;
                let (e1, e2) = normals(&n);
                rows.extend(parallel(&n));
                rows.extend(on_line(&n));
                rows.push(normal(e1, e2, "the bodies are turned about the axis"));
            }
            JointKind::Weld => {
                rows.extend(coincide());
                let [x, y, z] = [Vector3::x(), Vector3::y(), Vector3::z()];
                let what = "the bodies are turned relative to each other";
                rows.extend([normal(x, y, what), normal(y, z, what), normal(z, x, what)]);
            }
        }
        Ok(Self {
            name: name.to_string(),
            kind,
            pair: Pair { nodes, arms },
            rows,
            drive: None,
            initial,
        })
    }

    /// Whether a drive imposes its free coordinate (its last row).
    pub fn is_driven(&self) -> bool {
        self.drive.is_some()
    }

    /// A revolute or cylindrical joint's angle axes: `e₁, e₂` normal to the axis in A's
    /// frame and `b₁` the first in B's, so that `cos φ = e₁·b₁`, `sin φ = e₂·b₁` (A's and
    /// B's axes in space) with `φ = 0` as built; `None` for a joint of another kind.
    pub(crate) fn angle_axes(&self) -> Option<[Vector3<f64>; 3]> {
        let (JointKind::Revolute { axis } | JointKind::Cylindrical { axis }) = self.kind else {
            return None;
        };
        let (e1, e2) = normals(&axis.normalize());
        let body = |s: usize, v: &Vector3<f64>| self.initial[s].transpose() * v;
        Some([body(0, &e1), body(0, &e2), body(1, &e1)])
    }

    /// Imposes `law` on the joint's free coordinate from the initial configuration `q`:
    /// the angle of a revolute joint, the travel of a prismatic one, `f(t) − f(0)` from
    /// where they start.
    ///
    /// # Errors
    /// What is wrong, as a message: another kind of joint, a joint driven already.
    pub(crate) fn drive(&mut self, law: Motion, q: &[f64]) -> Result<(), String> {
        if self.drive.is_some() {
            return Err("is driven already".into());
        }
        let body = |s: usize, v: &Vector3<f64>| self.initial[s].transpose() * v;
        let coordinate = match self.kind {
            JointKind::Revolute { axis } => {
                let (e1, e2) = normals(&axis.normalize());
                Coordinate::Angle {
                    e1: body(0, &e1),
                    e2: body(0, &e2),
                    b1: body(1, &e1),
                }
            }
            JointKind::Prismatic { axis } => {
                let axis = body(0, &axis.normalize());
                let sides = self.pair.sides(q, None);
                let start = self
                    .pair
                    .product(&Measure::Axis(0, axis), &Measure::Gap, &sides)
                    .value;
                Coordinate::Slide { axis, start }
            }
            _ => {
                return Err(format!(
                    "is {}: only revolute and prismatic joints are driven",
                    self.kind.name()
                ))
            }
        };
        self.drive = Some(Drive { law, coordinate });
        Ok(())
    }

    /// `cos(φ − ψ(t))` of an angle drive at `q`: 1 on its law, negative where its row
    /// `sin(φ − ψ) = 0` holds half a turn away (the other root, which a long step can reach);
    /// `None` without an angle drive.
    pub(crate) fn drive_alignment(&self, q: &[f64], t: f64) -> Option<f64> {
        let drive = self.drive.as_ref()?;
        let Coordinate::Angle { e1, e2, b1 } = drive.coordinate else {
            return None;
        };
        let psi = drive.law.at(t).angle - drive.law.at(0.0).angle;
        let sides = self.pair.sides(q, None);
        let along = |e| {
            let p = self
                .pair
                .product(&Measure::Axis(0, e), &Measure::Axis(1, b1), &sides);
            p.value
        };
        let (cos_phi, sin_phi) = (along(e1), along(e2));
        Some(cos_phi * psi.cos() + sin_phi * psi.sin())
    }

    /// The drive's law, if driven.
    pub(crate) fn drive_law(&self) -> Option<&Motion> {
        self.drive.as_ref().map(|d| &d.law)
    }

    /// Where the drive's law is not smooth (none without a drive).
    pub(crate) fn drive_kinks(&self) -> Vec<f64> {
        self.drive.as_ref().map_or_else(Vec::new, |d| d.law.kinks())
    }

    /// The rows that hold the points together, whose multipliers are the components of the
    /// force the joint transmits (N) along orthonormal directions — the gap's three
    /// components, or its two normal to a sliding joint's axis — not a locked rotation's
    /// moments or the drive's row.
    pub(crate) fn force_rows(&self) -> impl Iterator<Item = usize> + '_ {
        (self.rows.iter().enumerate())
            .filter(|(_, row)| row.alpha == Measure::Gap || row.beta == Measure::Gap)
            .map(|(k, _)| k)
    }

    /// The drive's row among the joint's (the last), if driven.
    pub fn drive_row_index(&self) -> Option<usize> {
        self.drive.as_ref().map(|_| self.rows.len())
    }

    /// Constraint rows, the drive's last.
    pub fn n_rows(&self) -> usize {
        self.rows.len() + usize::from(self.drive.is_some())
    }

    /// The nodes the joint acts on, with their place (0: A, 1: B) among its local unknowns.
    pub(crate) fn local_nodes(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.pair.local_nodes()
    }

    /// The drive's row as a combination of products `Σ cₖ (αₖ · βₖ) − g(t)` at time `t`:
    /// its terms, and `(g, ġ, g̈)`. For an angle, `Φ = cos ψ (e₂·b₁) − sin ψ (e₁·b₁) =
    /// sin(φ − ψ)`, `ψ(t)` the law's angle since `t = 0`, whose coefficients move with time;
    /// for a slide, `Φ = n·(p_B − p_A) − d₀ − (f(t) − f(0))`.
    fn drive_row(&self, drive: &Drive, t: f64) -> (Vec2<Term>, [f64; 3]) {
        let law = drive.law.at(t);
        let psi = law.angle - drive.law.at(0.0).angle;
        drive_terms(
            drive.coordinate,
            [psi, law.velocity, law.acceleration],
            None,
        )
    }

    /// The drive row's derivatives to a parameter `p` of its trapezoidal law at `(q, v, t)`
    /// (with `v = None`, `b` at rest): `∂Φ/∂p`, `∂B/∂p` and `∂b/∂p` as a row's value,
    /// gradient and term, and the row's index among the joint's; `None` without a
    /// trapezoidal drive.
    pub(crate) fn drive_rate(
        &self,
        q: &[f64],
        v: Option<&[f64]>,
        t: f64,
        p: LawParameter,
    ) -> Option<(usize, DriveRate)> {
        let drive = self.drive.as_ref()?;
        let Motion::Trapezoidal(law) = &drive.law else {
            return None;
        };
        let state = drive.law.at(t);
        let (rate, rate0) = (law.rate(t, p), law.rate(0.0, p));
        let psi = state.angle - drive.law.at(0.0).angle;
        let (products, g) = drive_terms(
            drive.coordinate,
            [psi, state.velocity, state.acceleration],
            Some([rate.angle - rate0.angle, rate.velocity, rate.acceleration]),
        );
        let row = self.drive_value(&products, g, &self.pair.sides(q, v), None);
        Some((
            self.rows.len(),
            DriveRate {
                value: row.value,
                gradient: row.gradient,
                term: row.term,
            },
        ))
    }

    /// The drive's row from its terms and `(g, ġ, g̈)` at the nodes' `sides`; with
    /// `hessian = Some((λ, k))` its Hessian times `λ` added into `k`.
    fn drive_value(
        &self,
        products: &Vec2<Term>,
        g: [f64; 3],
        sides: &[Side; 2],
        mut hessian: Option<(f64, &mut Stiffness)>,
    ) -> RowValue {
        let [g, gd, gdd] = g;
        let mut row = RowValue {
            value: -g,
            gradient: SVector::zeros(),
            time_rate: -gd,
            term: -gdd,
        };
        for Term {
            c: [c, cd, cdd],
            alpha,
            beta,
        } in products.iter().flatten()
        {
            let h = hessian.as_mut().map(|(l, k)| (c * *l, &mut **k));
            let p = self.pair.product_and_hessian(alpha, beta, sides, h);
            row.value += c * p.value;
            row.gradient += p.gradient * *c;
            row.time_rate += cd * p.value;
            row.term += c * p.term + 2.0 * cd * p.rate + cdd * p.value;
        }
        row
    }

    /// Every row at `(q, v, t)`: its value, gradient, `∂Φ/∂t` and `b` of
    /// `Φ̈ = B v̇ + b` (with `v = None`, rates and `b` at rest), handed to `f` in order;
    /// with `hessian = Some((λ, k))` also `∂(Bᵀλ)/∂q` added into `k`, from the same
    /// evaluation of each row.
    fn for_each_row(
        &self,
        q: &[f64],
        v: Option<&[f64]>,
        t: f64,
        mut hessian: Option<(&[f64], &mut Stiffness)>,
        mut f: impl FnMut(usize, RowValue),
    ) {
        let sides = self.pair.sides(q, v);
        for (k, row) in self.rows.iter().enumerate() {
            let h = hessian
                .as_mut()
                .map(|(l, stiffness)| (l[k], &mut **stiffness));
            let p = self
                .pair
                .product_and_hessian(&row.alpha, &row.beta, &sides, h);
            f(
                k,
                RowValue {
                    value: p.value,
                    gradient: p.gradient,
                    time_rate: 0.0,
                    term: p.term,
                },
            );
        }
        if let Some(drive) = &self.drive {
            let (products, g) = self.drive_row(drive, t);
            let h = hessian.map(|(l, stiffness)| (l[self.rows.len()], stiffness));
            let row = self.drive_value(&products, g, &sides, h);
            f(self.rows.len(), row);
        }
    }

    /// The anchors' points' rates in their sides' frames when the joint's place moves by a
    /// unit along `e` (inertial, in the initial configuration): `R₀ᵀ e` on a node, `e` on
    /// the ground. Both points move together, so the initial configuration still meets.
    pub(crate) fn arm_rates(&self, e: &Vector3<f64>) -> [Vector3<f64>; 2] {
        [0, 1].map(|s| match self.pair.nodes[s] {
            Some(_) => self.initial[s].transpose() * e,
            None => *e,
        })
    }

    /// Every row's derivative to the joint's place along `e` ([`Joint::arm_rates`]) at
    /// `(q, v, t)` (with `v = None`, `b`'s at rest): `∂Φ/∂p`, `∂B/∂p` and `∂b/∂p`, row by
    /// row, the drive's last.
    pub(crate) fn position_rate(
        &self,
        q: &[f64],
        v: Option<&[f64]>,
        t: f64,
        e: &Vector3<f64>,
    ) -> RowsRate {
        let (sides, arms) = (self.pair.sides(q, v), self.arm_rates(e));
        let mut out = RowsRate {
            value: SVector::zeros(),
            gradient: Gradient::zeros(),
            rate: SVector::zeros(),
            term: SVector::zeros(),
        };
        let mut put = |k: usize, p: &Product, [c, cd, cdd]: [f64; 3]| {
            out.value[k] += c * p.value;
            let mut row = out.gradient.row_mut(k);
            row += p.gradient.transpose() * c;
            out.rate[k] += c * p.rate + cd * p.value;
            out.term[k] += c * p.term + 2.0 * cd * p.rate + cdd * p.value;
        };
        for (k, row) in self.rows.iter().enumerate() {
            let p = self.pair.product_rate(&row.alpha, &row.beta, &sides, &arms);
            put(k, &p, [1.0, 0.0, 0.0]);
        }
        if let Some(drive) = &self.drive {
            for Term { c, alpha, beta } in self.drive_row(drive, t).0.iter().flatten() {
                let p = self.pair.product_rate(alpha, beta, &sides, &arms);
                put(self.rows.len(), &p, *c);
            }
        }
        out
    }

    /// `Φ(q, t)` into `out` (its first [`Joint::n_rows`] entries).
    pub fn values(&self, q: &[f64], t: f64, out: &mut [f64]) {
        self.for_each_row(q, None, t, None, |k, r| out[k] = r.value);
    }

    /// The first row that the initial configuration `q` breaks by more than `tolerance`
    /// (lengths relative to `size`), with its value and what it means.
    pub(crate) fn broken(
        &self,
        q: &[f64],
        size: f64,
        tolerance: f64,
    ) -> Option<(f64, &'static str)> {
        let mut out = [0.0; MAX_ROWS];
        self.values(q, 0.0, &mut out);
        self.rows.iter().zip(out).find_map(|(row, value)| {
            let lengths = [row.alpha, row.beta]
                .iter()
                .filter(|m| **m == Measure::Gap)
                .count();
            (value.abs() > tolerance * size.powi(lengths as i32)).then_some((value, row.what))
        })
    }

    /// `B` on the local unknowns at `(q, t)`.
    pub(crate) fn gradient(&self, q: &[f64], t: f64) -> Gradient {
        self.values_and_gradient(q, t).1
    }

    /// `Φ` (its first [`Joint::n_rows`] entries) and `B` at `(q, t)`, from one evaluation of
    /// each row.
    pub(crate) fn values_and_gradient(
        &self,
        q: &[f64],
        t: f64,
    ) -> (SVector<f64, MAX_ROWS>, Gradient) {
        let (mut values, mut g) = (SVector::zeros(), Gradient::zeros());
        self.rows_into(q, t, None, (&mut values, &mut g));
        (values, g)
    }

    /// `Φ` and `B` at `(q, t)` into `rows`, and with `stiffness = Some((λ, k))`
    /// [`Joint::stiffness`] into `k`, from one evaluation of each row.
    pub(crate) fn rows_into(
        &self,
        q: &[f64],
        t: f64,
        stiffness: Option<(&[f64], &mut Stiffness)>,
        (values, g): (&mut SVector<f64, MAX_ROWS>, &mut Gradient),
    ) {
        let stiffness = stiffness.map(|(lambda, k)| {
            k.fill(0.0);
            (lambda, k)
        });
        self.for_each_row(q, None, t, stiffness, |k, r| {
            values[k] = r.value;
            g.set_row(k, &r.gradient.transpose());
        });
    }

    /// `∂(Bᵀλ)/∂q` on the local unknowns at `(q, t)`: `Σ λₖ ∂²Φₖ/∂q²`.
    pub(crate) fn stiffness(&self, q: &[f64], t: f64, lambda: &[f64]) -> Stiffness {
        let mut k = Stiffness::zeros();
        self.for_each_row(q, None, t, Some((lambda, &mut k)), |_, _| {});
        k
    }

    /// `b` of `Φ̈ = B v̇ + b` at `(q, v, t)` into `out`.
    pub fn acceleration_terms(&self, q: &[f64], v: &[f64], t: f64, out: &mut [f64]) {
        self.for_each_row(q, Some(v), t, None, |k, r| out[k] = r.term);
    }

    /// `Φ̇ = B v + ∂Φ/∂t` at `(q, v, t)`: the rows' rates.
    pub(crate) fn rates(&self, q: &[f64], v: &[f64], t: f64) -> SVector<f64, MAX_ROWS> {
        let mut local = SVector::<f64, LOCAL>::zeros();
        for (s, n) in self.local_nodes() {
            local.fixed_rows_mut::<6>(6 * s).copy_from_slice(&six(v, n));
        }
        let mut rates = SVector::zeros();
        self.for_each_row(q, None, t, None, |k, r| {
            rates[k] = r.gradient.dot(&local) + r.time_rate
        });
        rates
    }
}

/// Up to two of a kind.
type Vec2<T> = [Option<T>; 2];

/// A drive row's terms and `(g, ġ, g̈)` at its law's state `(ψ, ψ̇, ψ̈)` ([`Joint::drive_row`]),
/// or with `rate = Some((ψ', ψ̇', ψ̈'))` their derivatives to a parameter that moves the
/// state so: an angle's coefficients turn with `ψ` (`∂(cos ψ, −sin ψ)/∂ψ = (−sin ψ,
/// −cos ψ)`, the sine term's), a slide's `g` is the state itself.
fn drive_terms(
    coordinate: Coordinate,
    [psi, w, acc]: [f64; 3],
    rate: Option<[f64; 3]>,
) -> (Vec2<Term>, [f64; 3]) {
    match coordinate {
        Coordinate::Angle { e1, e2, b1 } => {
            let (sn, cs) = psi.sin_cos();
            // `c(cs, sn)` of the cosine term; the sine term's is `c(−sn, cs)`.
            let c = |cs: f64, sn: f64| match rate {
                None => [cs, -sn * w, -cs * w * w - sn * acc],
                Some([dpsi, dw, dacc]) => [
                    -sn * dpsi,
                    -cs * w * dpsi - sn * dw,
                    (sn * w * w - cs * acc) * dpsi - 2.0 * cs * w * dw - sn * dacc,
                ],
            };
            let term = |c, e| Term {
                c,
                alpha: Measure::Axis(0, e),
                beta: Measure::Axis(1, b1),
            };
            (
                [Some(term(c(cs, sn), e2)), Some(term(c(-sn, cs), e1))],
                [0.0; 3],
            )
        }
        Coordinate::Slide { axis, start } => {
            let travel = Term {
                c: [f64::from(u8::from(rate.is_none())), 0.0, 0.0],
                alpha: Measure::Axis(0, axis),
                beta: Measure::Gap,
            };
            let g = rate.unwrap_or([start + psi, w, acc]);
            ([Some(travel), None], g)
        }
    }
}

/// A drive row's derivatives to a parameter of its law ([`Joint::drive_rate`]).
pub(crate) struct DriveRate {
    /// `∂Φ/∂p` at the state.
    pub value: f64,
    /// `∂B/∂p` on the joint's local unknowns.
    pub gradient: SVector<f64, LOCAL>,
    /// `∂b/∂p` of `Φ̈ = B v̇ + b`.
    pub term: f64,
}

/// A term `c(t) (α · β)` of a drive's row: the coefficient with its first two time
/// derivatives, and the product's measures.
struct Term {
    c: [f64; 3],
    alpha: Measure,
    beta: Measure,
}

/// The rows' derivatives to a parameter at one state ([`Joint::position_rate`]), row by
/// row in the joint's order.
pub(crate) struct RowsRate {
    /// `∂Φ/∂p`.
    pub value: SVector<f64, MAX_ROWS>,
    /// `∂B/∂p` on the joint's local unknowns.
    pub gradient: Gradient,
    /// `∂Φ̇/∂p` at the state's velocities.
    pub rate: SVector<f64, MAX_ROWS>,
    /// `∂b/∂p` of `Φ̈ = B v̇ + b`.
    pub term: SVector<f64, MAX_ROWS>,
}

/// A row's value and derivatives at one state.
struct RowValue {
    value: f64,
    gradient: SVector<f64, LOCAL>,
    /// `∂Φ/∂t`.
    time_rate: f64,
    /// `b` of `Φ̈ = B v̇ + b`.
    term: f64,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::group::{so3, Frame, NQ, NV};
    use crate::joint::motion::Table;

    /// The time at which rows are differentiated: inside the law's table, where its speed
    /// and acceleration are not zero.
    const T: f64 = 0.37;

    /// Every kind, and the revolute and prismatic joints driven.
    fn joints(ground_b: bool) -> Vec<(Joint, Vec<f64>)> {
        let axis = Vector3::new(0.3, -0.5, 0.8);
        let kinds = [
            JointKind::Spherical,
            JointKind::Revolute { axis },
            JointKind::Universal {
                axis_a: axis,
                axis_b: normals(&axis).0,
            },
            JointKind::Cylindrical { axis },
            JointKind::Prismatic { axis },
            JointKind::Weld,
        ];
        let law = Motion::Table(Table::new(
            vec![0.0, 0.5, 1.0],
            vec![0.2, 1.4, 0.5],
            [0.3, 0.0],
        ));
        let mut out = Vec::new();
        for kind in kinds {
            let (joint, q) = setup(kind, ground_b);
            if matches!(
                kind,
                JointKind::Revolute { .. } | JointKind::Prismatic { .. }
            ) {
                let (mut driven, q0) = setup_initial(kind, ground_b);
                driven.drive(law.clone(), &q0).unwrap();
                out.push((driven, q.clone()));
            }
            out.push((joint, q));
        }
        out
    }

    fn initial_configuration() -> Vec<f64> {
        let mut q = vec![0.0; 2 * NQ];
        Frame::new(
            Vector3::new(0.1, 0.2, 0.3),
            so3::exp(&Vector3::new(0.4, -1.2, 2.0)),
        )
        .write(&mut q, 0);
        Frame::new(
            Vector3::new(-0.5, 0.0, 1.0),
            so3::exp(&Vector3::new(-2.5, 0.3, 0.1)),
        )
        .write(&mut q, 1);
        q
    }

    fn setup_initial(kind: JointKind, ground_b: bool) -> (Joint, Vec<f64>) {
        let q = initial_configuration();
        let initial = [Frame::read(&q, 0).rotation(), Frame::read(&q, 1).rotation()];
        let nodes = [Some(0), (!ground_b).then_some(1)];
        let arms = [Vector3::new(0.3, -0.2, 0.5), Vector3::new(-0.1, 0.4, 0.2)];
        (Joint::new("j", kind, nodes, arms, initial).unwrap(), q)
    }

    /// The joint built on two frames as its initial configuration; then the configuration
    /// moved away, so that no row is at its rest value.
    fn setup(kind: JointKind, ground_b: bool) -> (Joint, Vec<f64>) {
        let (joint, mut q) = setup_initial(kind, ground_b);
        for n in 0..2 {
            let moved = Frame::read(&q, n).retract(&[0.05, -0.1, 0.2, 0.3, -0.2, 0.4]);
            moved.write(&mut q, n);
        }
        (joint, q)
    }

    /// A trapezoidal drive's row moves with its law's end, acceleration and speed as
    /// `drive_rate` says: the row's value, gradient and `b` against central differences of
    /// the row under laws with the parameter moved, in each phase of the law (accelerating,
    /// at speed, braking, done) and on a triangular profile, angles and slides.
    #[test]
    fn drive_rates_against_differences() {
        use crate::joint::motion::Trapezoidal;
        let v: Vec<f64> = (0..2 * NV).map(|i| 0.3 - 0.1 * i as f64).collect();
        let laws = [[0.3, 1.5, 4.0, 1.2], [0.0, -0.4, 3.0, 5.0]]; // trapezoid, triangle
        let param = [
            LawParameter::End,
            LawParameter::Acceleration,
            LawParameter::Speed,
        ];
        // How many rates the differences saw move: the laws' phases must move them.
        let mut moving = 0;
        for kind in [
            JointKind::Revolute {
                axis: Vector3::new(0.3, -0.5, 0.8),
            },
            JointKind::Prismatic {
                axis: Vector3::new(0.3, -0.5, 0.8),
            },
        ] {
            for [start, end, acc, speed] in laws {
                let build = |d: [f64; 3]| {
                    let (mut joint, q0) = setup_initial(kind, false);
                    let law = Trapezoidal::new(start, end + d[0], acc + d[1], speed + d[2], 0.1);
                    joint.drive(Motion::Trapezoidal(law), &q0).unwrap();
                    joint
                };
                let joint = build([0.0; 3]);
                let (_, q) = setup(kind, false);
                let law = joint.drive_law().cloned().unwrap();
                let Motion::Trapezoidal(trapezoid) = &law else {
                    unreachable!()
                };
                let duration = trapezoid.duration();
                for t in [
                    0.05,
                    0.15,
                    0.1 + 0.4 * duration,
                    0.1 + 0.97 * duration,
                    0.2 + duration,
                ] {
                    for (k, &p) in param.iter().enumerate() {
                        let (row, rate) = joint.drive_rate(&q, Some(&v), t, p).unwrap();
                        let eps = 1e-6;
                        let mut d = [0.0; 3];
                        d[k] = eps;
                        let (jp, jm) = (build(d), build(d.map(|x| -x)));
                        let fd = |f: &dyn Fn(&Joint) -> f64| (f(&jp) - f(&jm)) / (2.0 * eps);
                        let value = fd(&|j: &Joint| {
                            let mut out = [0.0; MAX_ROWS];
                            j.values(&q, t, &mut out);
                            out[row]
                        });
                        let term = fd(&|j: &Joint| {
                            let mut out = [0.0; MAX_ROWS];
                            j.acceleration_terms(&q, &v, t, &mut out);
                            out[row]
                        });
                        moving += usize::from(value.abs() > 1e-3 && term.abs() > 1e-3);
                        let what = (kind.name(), start, t, p);
                        assert!(
                            (value - rate.value).abs() < 1e-7,
                            "{what:?}: value {} against {value}",
                            rate.value
                        );
                        assert!(
                            (term - rate.term).abs() < 1e-6 * (1.0 + term.abs()),
                            "{what:?}: b {} against {term}",
                            rate.term
                        );
                        for c in 0..LOCAL {
                            let g = fd(&|j: &Joint| j.gradient(&q, t)[(row, c)]);
                            assert!(
                                (g - rate.gradient[c]).abs() < 1e-7,
                                "{what:?}: B[{c}] {} against {g}",
                                rate.gradient[c]
                            );
                        }
                    }
                }
            }
        }
        assert!(moving >= 12, "{moving} rates moved");
    }

    fn perturbed(q: &[f64], node: usize, k: usize, e: f64) -> Vec<f64> {
        let mut inc = [0.0; NV];
        inc[k] = e;
        let mut out = q.to_vec();
        Frame::read(q, node).retract(&inc).write(&mut out, node);
        out
    }

    /// Gradient and constraint-force stiffness of every kind, driven or not, on two bodies
    /// and on a body and the ground, against central differences.
    #[test]
    fn gradient_and_stiffness_against_differences() {
        let eps = 1e-6;
        for ground_b in [false, true] {
            for (joint, q) in joints(ground_b) {
                let name = (joint.kind.name(), joint.drive.is_some(), ground_b);
                let n = joint.n_rows();
                let lambda: Vec<f64> = (0..n)
                    .map(|k| 1.0 + k as f64 * 0.7 - 0.3 * (k % 2) as f64 * 5.0)
                    .collect();
                let g = joint.gradient(&q, T);
                let k = joint.stiffness(&q, T, &lambda);
                for (s, node) in joint.local_nodes() {
                    for c in 0..NV {
                        let (p, m) = (perturbed(&q, node, c, eps), perturbed(&q, node, c, -eps));
                        let (mut vp, mut vm) = ([0.0; MAX_ROWS], [0.0; MAX_ROWS]);
                        joint.values(&p, T, &mut vp);
                        joint.values(&m, T, &mut vm);
                        for r in 0..n {
                            let fd = (vp[r] - vm[r]) / (2.0 * eps);
                            assert!(
                                (fd - g[(r, 6 * s + c)]).abs() < 1e-8,
                                "{name:?}: B[{r}, {}]",
                                6 * s + c
                            );
                        }
                        let force = |qq: &[f64]| {
                            joint.gradient(qq, T).rows(0, n).transpose()
                                * nalgebra::DVector::from_column_slice(&lambda)
                        };
                        let fd = (force(&p) - force(&m)) / (2.0 * eps);
                        for (s2, _) in joint.local_nodes() {
                            for r in 0..NV {
                                let i = 6 * s2 + r;
                                let exact = k[(i, 6 * s + c)];
                                assert!(
                                    (fd[i] - exact).abs() < 1e-7,
                                    "{name:?}: K[{i}, {}] {} against {exact}",
                                    6 * s + c,
                                    fd[i]
                                );
                            }
                        }
                    }
                }
            }
        }
    }

    /// Along a motion `q(τ)` with known rates and accelerations, `Φ(q(τ), T + τ)`'s first
    /// and second differences in `τ` against `B v + ∂Φ/∂t` and `B v̇ + b`, every kind, driven
    /// or not.
    #[test]
    fn rates_and_acceleration_terms_against_differences() {
        let v = [
            0.3, -0.1, 0.2, 1.5, -0.7, 2.0, -0.2, 0.4, 0.1, -1.0, 0.5, 0.3,
        ];
        // Rotational accelerations along the rates: exp(τΩ + ½τ²Ω̇) turns about a fixed
        // body axis, whose body rates are exactly Ω + τΩ̇, only when Ω̇ ∥ Ω.
        let mut acc = [0.5, 0.2, -0.4, 0.0, 0.0, 0.0, 0.1, -0.3, 0.2, 0.0, 0.0, 0.0];
        for node in 0..2 {
            for k in 0..3 {
                acc[6 * node + 3 + k] = 0.4 * v[6 * node + 3 + k];
            }
        }
        for (joint, q) in joints(false) {
            let name = (joint.kind.name(), joint.drive.is_some());
            let n = joint.n_rows();
            let at = |tau: f64| {
                let mut out = q.clone();
                for node in 0..2 {
                    let inc: Vec<f64> = (0..NV)
                        .map(|k| tau * v[6 * node + k] + 0.5 * tau * tau * acc[6 * node + k])
                        .collect();
                    Frame::read(&q, node).retract(&inc).write(&mut out, node);
                }
                let mut values = [0.0; MAX_ROWS];
                joint.values(&out, T + tau, &mut values);
                values
            };
            let h = 1e-4;
            let (p, z, m) = (at(h), at(0.0), at(-h));
            let bvdot = joint.gradient(&q, T) * SVector::<f64, LOCAL>::from_column_slice(&acc);
            let mut b = [0.0; MAX_ROWS];
            joint.acceleration_terms(&q, &v, T, &mut b);
            let rates = joint.rates(&q, &v, T);
            for r in 0..n {
                let first = (p[r] - m[r]) / (2.0 * h);
                assert!(
                    (first - rates[r]).abs() < 1e-6 * rates[r].abs().max(1.0),
                    "{name:?}, row {r}: rate {first} against {}",
                    rates[r]
                );
                let second = (p[r] - 2.0 * z[r] + m[r]) / (h * h);
                let expected = bvdot[r] + b[r];
                assert!(
                    (second - expected).abs() < 1e-5 * expected.abs().max(1.0),
                    "{name:?}, row {r}: {second} against {expected}"
                );
            }
        }
    }

    /// The rows' value, gradient, rate and `b` against central differences of the same joint with
    /// both anchors moved along each axis, grounded or not, driven or not.
    #[test]
    fn position_rates_against_differences() {
        let v = [
            0.3, -0.1, 0.2, 1.5, -0.7, 2.0, -0.2, 0.4, 0.1, -1.0, 0.5, 0.3,
        ];
        for ground_b in [false, true] {
            for (joint, q) in joints(ground_b) {
                let name = (joint.kind.name(), joint.drive.is_some(), ground_b);
                let n = joint.n_rows();
                for axis in 0..3 {
                    let e = Vector3::ith(axis, 1.0);
                    let rate = joint.position_rate(&q, Some(&v), T, &e);
                    let moved = |d: f64| {
                        let mut j = joint.clone();
                        let arms = joint.arm_rates(&e);
                        (0..2).for_each(|s| j.pair.arms[s] += arms[s] * d);
                        let (mut value, mut b) = ([0.0; MAX_ROWS], [0.0; MAX_ROWS]);
                        j.values(&q, T, &mut value);
                        j.acceleration_terms(&q, &v, T, &mut b);
                        (value, j.gradient(&q, T), b, j.rates(&q, &v, T))
                    };
                    let h = 1e-6;
                    let ((vp, gp, bp, rp), (vm, gm, bm, rm)) = (moved(h), moved(-h));
                    for r in 0..n {
                        let close =
                            |fd: f64, exact: f64| (fd - exact).abs() < 1e-7 * exact.abs().max(1.0);
                        let fd = (vp[r] - vm[r]) / (2.0 * h);
                        assert!(
                            close(fd, rate.value[r]),
                            "{name:?} {axis} row {r}: {fd} against {}",
                            rate.value[r]
                        );
                        let fd = (bp[r] - bm[r]) / (2.0 * h);
                        assert!(
                            close(fd, rate.term[r]),
                            "{name:?} {axis} row {r}: b' {fd} against {}",
                            rate.term[r]
                        );
                        let fd = (rp[r] - rm[r]) / (2.0 * h);
                        assert!(
                            close(fd, rate.rate[r]),
                            "{name:?} {axis} row {r}: rate' {fd} against {}",
                            rate.rate[r]
                        );
                        for c in 0..LOCAL {
                            let fd = (gp[(r, c)] - gm[(r, c)]) / (2.0 * h);
                            let exact = rate.gradient[(r, c)];
                            assert!(
                                close(fd, exact),
                                "{name:?} {axis} row {r} column {c}: {fd} against {exact}"
                            );
                        }
                    }
                }
            }
        }
    }

    /// A drive holds at the start, whatever its law's value there.
    #[test]
    fn a_drive_starts_where_its_joint_is() {
        for kind in [
            JointKind::Revolute { axis: Vector3::z() },
            JointKind::Prismatic { axis: Vector3::x() },
        ] {
            let (mut joint, q) = setup_initial(kind, false);
            let law = Motion::Table(Table::new(vec![0.0, 1.0], vec![2.0, 3.0], [1.0, 1.0]));
            joint.drive(law.clone(), &q).unwrap();
            let mut values = [1.0; MAX_ROWS];
            joint.values(&q, 0.0, &mut values);
            // The drive's row (the others hold where the anchors are placed to meet).
            assert!(values[joint.n_rows() - 1].abs() < 1e-15, "{values:?}");
            assert!(joint.drive(law, &q).unwrap_err().contains("driven already"));
        }
        let (mut joint, q) = setup_initial(JointKind::Spherical, false);
        let law = Motion::Table(Table::new(vec![0.0, 1.0], vec![0.0, 1.0], [0.0, 0.0]));
        assert!(joint.drive(law, &q).unwrap_err().contains("is spherical"));
    }

    #[test]
    fn bad_axes_are_named() {
        let i = Matrix3::identity();
        let build = |kind| Joint::new("j", kind, [Some(0), None], [Vector3::zeros(); 2], [i, i]);
        assert!(build(JointKind::Revolute {
            axis: Vector3::zeros()
        })
        .unwrap_err()
        .contains("axis"));
        let err = build(JointKind::Universal {
            axis_a: Vector3::x(),
            axis_b: Vector3::new(1.0, 1.0, 0.0),
        })
        .unwrap_err();
        assert!(err.contains("right angles"), "{err}");
    }
}
