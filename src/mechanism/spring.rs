//! Springs and dampers: linear force elements on a measure `s` of the mechanism — the
//! distance between two points (a translational spring, `k` in N/m, rest length `s₀`), or a
//! joint's own coordinate ([`Joint::coordinate`]: a torsion spring at a pin or hinge in
//! N m/rad, a spring along a slider's travel in N/m).
//!
//! The spring has energy `U = ½ k (s(q) − s₀)²`, force `f = k (s − s₀) ∂s/∂q` and exact
//! tangent `k (∂s/∂q)(∂s/∂q)ᵀ + k (s − s₀) ∂²s/∂q²` on the six coordinates of the two nodes
//! involved, like a constraint row's. A damper `c` has force `c ṡ ∂s/∂q`. On a measure
//! linear in `q` (a pin's or hinge's rotation, a slider's travel on a ground axis) that is
//! `C q̇` with the constant, symmetric `C = c (∂s/∂q)(∂s/∂q)ᵀ`. On a distance or a carried
//! axis `C` follows the state, and `∂f/∂q = c ṡ ∂²s/∂q² + c (∂s/∂q)(∂²s/∂q² q̇)ᵀ` has a part
//! that is not symmetric, which the iteration matrix leaves out and the gradients' exact
//! solves take back ([`crate::mechanism::element::Damping`], as for the beams').
//!
//! [`Joint::coordinate`]: crate::joint::planar::Joint::coordinate

use nalgebra::Vector2;

use crate::joint::planar::{dof, perp, turn, turned_minus, Anchor, ConstraintRow};
use crate::mechanism::element::{Damping, Matrix6, Vector6};

/// What a spring measures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Measure {
    /// The distance between two anchors (m).
    Distance {
        /// `[a, b]`.
        at: [Anchor; 2],
        /// Their separation `(X_b + p_b) − (X_a + p_a)` at the reference (m).
        reference: Vector2<f64>,
    },
    /// A joint's own coordinate (rad or m), as a constraint row's law.
    Coordinate(ConstraintRow),
}

/// A named linear spring.
#[derive(Debug, Clone, PartialEq)]
pub struct Spring {
    /// Name, for messages.
    pub name: String,
    /// What it measures.
    pub measure: Measure,
    /// Stiffness `k` (N/m or N m/rad).
    pub stiffness: f64,
    /// Damping `c` (N s/m or N m s/rad), on a linear measure only.
    pub damping: f64,
    /// The measure at which it is unloaded, `s₀`.
    pub rest: f64,
}

/// A measure `s`, its gradient and Hessian on the six coordinates of its nodes.
pub struct Local {
    /// `s(q)`.
    pub value: f64,
    /// `∂s/∂q`.
    pub gradient: [f64; 6],
    /// `∂²s/∂q²` (row-major).
    pub hessian: [[f64; 6]; 6],
}

impl Spring {
    /// The six coordinates `[x_a, y_a, φ_a, x_b, y_b, φ_b]` of its nodes (`None` on the
    /// ground).
    pub fn dofs(&self) -> [Option<usize>; 6] {
        match self.measure {
            Measure::Distance { at, .. } => {
                std::array::from_fn(|i| Some(dof(at[i / 3].node, i % 3)))
            }
            Measure::Coordinate(row) => row.dofs(),
        }
    }

    /// The measure at `q` with its derivatives.
    pub fn measure(&self, q: &[f64]) -> Local {
        match self.measure {
            Measure::Distance { at, reference } => distance(at, reference, q),
            Measure::Coordinate(row) => {
                let (value, gradient) = row.evaluate(q);
                let mut hessian = [[0.0; 6]; 6];
                row.add_hessian(q, 1.0, &mut hessian);
                Local {
                    value,
                    gradient,
                    hessian,
                }
            }
        }
    }

    /// Force `f = k (s − s₀) ∂s/∂q` and tangent `K` on [`Spring::dofs`] at `q`.
    pub fn force_and_tangent(&self, q: &[f64]) -> ([f64; 6], [[f64; 6]; 6]) {
        let Local {
            value,
            gradient: g,
            hessian: h,
        } = self.measure(q);
        let tension = self.stiffness * (value - self.rest);
        let force = g.map(|gi| tension * gi);
        let tangent = std::array::from_fn(|i| {
            std::array::from_fn(|j| self.stiffness * g[i] * g[j] + tension * h[i][j])
        });
        (force, tangent)
    }

    /// Whether it damps a measure that is not linear in `q` (a distance, a carried axis):
    /// its `C` then follows the state.
    pub fn damps_nonlinearly(&self) -> bool {
        self.damping > 0.0 && !matches!(self.measure, Measure::Coordinate(row) if row.is_linear())
    }

    /// The damper on [`Spring::dofs`] at `(q, q̇)`: force `c ṡ g`, `∂f/∂q̇ = c g gᵀ`, the
    /// symmetric part `c ṡ H` of `∂f/∂q` and its rest `c g (H q̇)ᵀ` (`g`, `H` the measure's
    /// gradient and Hessian).
    pub fn damper(&self, q: &[f64], v: &[f64]) -> Damping {
        let Local {
            gradient: g,
            hessian: h,
            ..
        } = self.measure(q);
        let local = self.dofs().map(|d| d.map_or(0.0, |d| v[d]));
        let (g, local) = (Vector6::from(g), Vector6::from(local));
        let h = Matrix6::from_fn(|i, j| h[i][j]);
        let c = self.damping;
        let rate = g.dot(&local);
        Damping {
            force: g * (c * rate),
            rate: g * g.transpose() * c,
            symmetric: h * (c * rate),
            skew: g * (h * local).transpose() * c,
        }
    }

    /// The damper's `C = c (∂s/∂q)(∂s/∂q)ᵀ` on [`Spring::dofs`], at any `q`: constant, as
    /// its measure is linear.
    pub fn damping_matrix(&self, q: &[f64]) -> [[f64; 6]; 6] {
        let g = self.measure(q).gradient;
        std::array::from_fn(|i| std::array::from_fn(|j| self.damping * g[i] * g[j]))
    }

    /// For a spring between points, the vector from its first point to its second at `q`
    /// (m); `None` on a joint.
    pub fn separation(&self, q: &[f64]) -> Option<Vector2<f64>> {
        match self.measure {
            Measure::Distance { at, reference } => Some(gap(at, reference, q).0),
            Measure::Coordinate(_) => None,
        }
    }

    /// Elastic energy `½ k (s − s₀)²` at `q` (J).
    pub fn energy(&self, q: &[f64]) -> f64 {
        let stretch = self.measure(q).value - self.rest;
        0.5 * self.stiffness * stretch * stretch
    }
}

/// The separation `d = reference + Δr_b − Δr_a` of anchors `at` whose separation at the
/// reference is `reference`, and their turned arms `R(φ) p`.
fn gap(at: [Anchor; 2], reference: Vector2<f64>, q: &[f64]) -> (Vector2<f64>, [Vector2<f64>; 2]) {
    let moved = at.map(|a| {
        let shift = Vector2::new(q[dof(a.node, 0)], q[dof(a.node, 1)]);
        (shift, turned_minus(a.arm, turn(q[dof(a.node, 2)])))
    });
    let d = reference + (moved[1].0 + moved[1].1) - (moved[0].0 + moved[0].1);
    (d, [at[0].arm + moved[0].1, at[1].arm + moved[1].1])
}

/// The distance `ℓ = |d|` between anchors `at` ([`gap`]), with `∂ℓ/∂q = uᵀ d_q` and
/// `∂²ℓ/∂q² = (d_qᵀ d_q − ℓ_q ℓ_qᵀ)/ℓ + uᵀ d_qq` (`u = d/ℓ`).
fn distance(at: [Anchor; 2], reference: Vector2<f64>, q: &[f64]) -> Local {
    let (d, [ra, rb]) = gap(at, reference, q);
    let length = d.norm();
    let u = d / length;
    // Columns of d_q: ∂d/∂u_a = −I, ∂d/∂φ_a = −J R_a p_a, ∂d/∂u_b = I, ∂d/∂φ_b = J R_b p_b.
    let columns = [
        Vector2::new(-1.0, 0.0),
        Vector2::new(0.0, -1.0),
        -perp(ra),
        Vector2::new(1.0, 0.0),
        Vector2::new(0.0, 1.0),
        perp(rb),
    ];
    let gradient = columns.map(|c| u.dot(&c));
    let mut hessian: [[f64; 6]; 6] = std::array::from_fn(|i| {
        std::array::from_fn(|j| (columns[i].dot(&columns[j]) - gradient[i] * gradient[j]) / length)
    });
    // d_qq: ∂²d/∂φ_a² = R_a p_a, ∂²d/∂φ_b² = −R_b p_b.
    hessian[2][2] += u.dot(&ra);
    hessian[5][5] -= u.dot(&rb);
    Local {
        value: length,
        gradient,
        hessian,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::joint::planar::Law;

    /// A damper on a distance between arms: `∂f/∂q` (symmetric part and rest) and `∂f/∂q̇`
    /// against central differences of its force.
    #[test]
    fn a_damper_on_a_distance_has_exact_derivatives() {
        let damper = Spring {
            name: "d".into(),
            measure: Measure::Distance {
                at: [
                    Anchor {
                        node: 0,
                        arm: Vector2::new(0.2, -0.1),
                    },
                    Anchor {
                        node: 1,
                        arm: Vector2::new(-0.3, 0.25),
                    },
                ],
                reference: Vector2::new(0.7, 0.4),
            },
            stiffness: 0.0,
            damping: 40.0,
            rest: 0.0,
        };
        let q = [0.03, -0.05, 0.9, -0.02, 0.04, -1.3];
        let v = [0.4, -0.2, 1.5, -0.3, 0.6, -0.8];
        let d = damper.damper(&q, &v);
        let eps = 1e-6;
        for j in 0..6 {
            let (mut qp, mut qm, mut vp, mut vm) = (q, q, v, v);
            qp[j] += eps;
            qm[j] -= eps;
            vp[j] += eps;
            vm[j] -= eps;
            let fq = (damper.damper(&qp, &v).force - damper.damper(&qm, &v).force) / (2.0 * eps);
            let fv = (damper.damper(&q, &vp).force - damper.damper(&q, &vm).force) / (2.0 * eps);
            let exact = (d.symmetric + d.skew).column(j).into_owned();
            assert!(
                (exact - fq).norm() < 1e-6 * (d.symmetric + d.skew).norm(),
                "q {j}"
            );
            assert!(
                (d.rate.column(j) - fv).norm() < 1e-7 * d.rate.norm(),
                "v {j}"
            );
        }
        assert!((d.symmetric - d.symmetric.transpose()).norm() < 1e-12 * d.symmetric.norm());
        assert!(damper.damps_nonlinearly());
    }

    /// A distance between two arms and a hinge's relative rotation: the force is the
    /// central difference of the energy and the tangent that of the force.
    #[test]
    fn forces_and_tangents_equal_central_differences() {
        let at = [
            Anchor {
                node: 0,
                arm: Vector2::new(0.2, -0.1),
            },
            Anchor {
                node: 1,
                arm: Vector2::new(-0.3, 0.25),
            },
        ];
        let springs = [
            Measure::Distance {
                at,
                reference: Vector2::new(0.7, 0.4),
            },
            Measure::Coordinate(ConstraintRow {
                nodes: [Some(0), Some(1)],
                law: Law::Angle,
                joint: 0,
                driven: false,
            }),
        ]
        .map(|measure| Spring {
            name: "s".into(),
            measure,
            stiffness: 3.0e3,
            damping: 0.0,
            rest: 0.5,
        });
        let q = [0.03, -0.05, 0.9, -0.02, 0.04, -1.3];
        for spring in springs {
            let (f, k) = spring.force_and_tangent(&q);
            for i in 0..6 {
                let eps = 1e-6;
                let (mut qp, mut qm) = (q, q);
                qp[i] += eps;
                qm[i] -= eps;
                let fd = (spring.energy(&qp) - spring.energy(&qm)) / (2.0 * eps);
                assert!(
                    (fd - f[i]).abs() < 1e-6 * (1.0 + f[i].abs()),
                    "f[{i}] = {} vs {fd}",
                    f[i]
                );
                let (fp, fm) = (
                    spring.force_and_tangent(&qp).0,
                    spring.force_and_tangent(&qm).0,
                );
                for j in 0..6 {
                    let fd = (fp[j] - fm[j]) / (2.0 * eps);
                    assert!(
                        (fd - k[j][i]).abs() < 1e-5 * (1.0 + k[j][i].abs()),
                        "K[{j}][{i}] = {} vs {fd}",
                        k[j][i]
                    );
                }
            }
        }
    }
}
