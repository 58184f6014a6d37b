//! Force elements of a spatial mechanism, each on two anchors (`pair.rs`) and
//! their nodes' twelve local unknowns, with the residual terms `f` (internal forces
//! positive, applied ones negative), the exact stiffness `K = ∂f/∂q` (right-trivialized)
//! and damping `C = ∂f/∂v`:
//!
//! - a **spring-damper** between two points, `N = k (l − l₀) + c l̇` along their line
//!   (`d = p_B − p_A`, `l = |d|`, `n = d/l`): `f = Jᵀ n N`,
//!   `K = H_d[nN] + Jᵀ (N/l (I − nnᵀ) + k nnᵀ + (c/l) n ḋᵀ(I − nnᵀ)) J + c Jᵀ n nᵀ D`
//!   (`D = ∂(J v)/∂q`), `C = c Jᵀ n nᵀ J`; energy `½ k (l − l₀)²`;
//! - a **motor** on a revolute joint: a torque `τ g(t)` about the joint's axis, carried by A,
//!   on B (its opposite on A): `f_B = −τ Rᵦᵀ R_A n`, `f_A = τ n`;
//! - a **load** at a body's point `a`: a force `F g(t)` and a moment `M g(t)`, dead (fixed in
//!   space: `f = −[F; ã RᵀF + RᵀM]`) or follower (fixed in the body: `f = −[R F; ã F + M]`).
//!
//! Units SI: N/m, N s/m, N m, N.

use nalgebra::{Matrix3, SVector, Vector3};

use crate::error::SolveError;
use crate::group::so3::hat;
use crate::mechanism::load::TimeFunction;
use crate::spatial::pair::{Measure, Pair, Side, Stiffness, LOCAL};

/// Generalized forces on a force element's twelve local unknowns.
pub(crate) type Local = SVector<f64, LOCAL>;

/// What a force element is.
#[derive(Debug, Clone, PartialEq)]
pub enum ForceKind {
    /// A spring-damper between the anchors' points.
    Spring {
        /// Stiffness `k` (N/m).
        stiffness: f64,
        /// Damping `c` (N s/m).
        damping: f64,
        /// Rest length `l₀` (m).
        rest: f64,
    },
    /// A torque about a revolute joint's axis, on B.
    Motor {
        /// Torque at `g = 1` (N m).
        torque: f64,
        /// `g(t)`.
        time: TimeFunction,
        /// The axis in A's frame (the inertial one for the ground).
        axis: Vector3<f64>,
    },
    /// A force and a moment at a body's point.
    Load {
        /// Force at `g = 1` (N), in space (dead) or in the body's frame (follower).
        force: Vector3<f64>,
        /// Moment at `g = 1` (N m), likewise.
        moment: Vector3<f64>,
        /// `g(t)`.
        time: TimeFunction,
        /// Whether it turns with the body.
        follower: bool,
    },
}

/// A named force element.
#[derive(Debug, Clone, PartialEq)]
pub struct Force {
    /// Its name in the scene.
    pub name: String,
    /// What it is.
    pub kind: ForceKind,
    pub(crate) pair: Pair,
}

/// A force element's terms at one state.
pub(crate) struct Terms {
    /// `f`.
    pub force: Local,
    /// `∂f/∂q`.
    pub stiffness: Stiffness,
    /// `∂f/∂v`.
    pub damping: Stiffness,
}

/// A parameter of a force element.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum ForceParameter {
    /// A spring's `k`.
    Stiffness,
    /// A spring's `c`.
    Damping,
    /// A motor's torque.
    Torque,
}

impl Force {
    /// Its terms at `(q, v, t)`, motors and loads scaled by the load factor `load` (1 in
    /// motion, climbing to 1 in a static solve).
    ///
    /// # Errors
    /// [`SolveError::SpringCollapsed`] where a spring's points meet (its line has no
    /// direction).
    pub(crate) fn terms(
        &self,
        q: &[f64],
        v: &[f64],
        t: f64,
        load: f64,
    ) -> Result<Terms, SolveError> {
        let sides = self.pair.sides(q, Some(v));
        let mut terms = Terms {
            force: Local::zeros(),
            stiffness: Stiffness::zeros(),
            damping: Stiffness::zeros(),
        };
        match &self.kind {
            ForceKind::Spring {
                stiffness: k,
                damping: c,
                rest,
            } => {
                let d = self.pair.evaluate(&Measure::Gap, &sides);
                let l = d.value.norm();
                if l.is_nan() || l <= f64::EPSILON * (1.0 + rest) {
                    return Err(SolveError::SpringCollapsed {
                        at: format!("t = {t:.6} s"),
                        spring: self.name.clone(),
                        length: l,
                    });
                }
                let n = d.value / l;
                let rate = n.dot(&d.rate);
                let tension = k * (l - rest) + c * rate;
                let across = Matrix3::identity() - n * n.transpose();
                let dn = across * (tension / l)
                    + n * n.transpose() * *k
                    + n * (d.rate.transpose() * across) * (c / l);
                terms.force = d.jacobian.transpose() * n * tension;
                self.pair.add_hessian(
                    &Measure::Gap,
                    &sides,
                    &(n * tension),
                    1.0,
                    &mut terms.stiffness,
                );
                terms.stiffness += d.jacobian.transpose() * dn * d.jacobian;
                let along = d.jacobian.transpose() * n;
                terms.stiffness +=
                    along * (n.transpose() * self.pair.gap_rate_jacobian(&sides)) * *c;
                terms.damping = along * along.transpose() * *c;
            }
            ForceKind::Motor { torque, time, axis } => {
                self.motor(&sides, axis, torque * time.at(t) * load, &mut terms);
            }
            ForceKind::Load {
                force,
                moment,
                time,
                follower,
            } => {
                let g = time.at(t) * load;
                let (side, a) = (&sides[0], &self.pair.arms[0]);
                let (f, m) = (force * g, moment * g);
                if *follower {
                    terms.force.fixed_rows_mut::<3>(0).copy_from(&(-side.r * f));
                    terms
                        .force
                        .fixed_rows_mut::<3>(3)
                        .copy_from(&(-(a.cross(&f) + m)));
                    terms
                        .stiffness
                        .fixed_view_mut::<3, 3>(0, 3)
                        .copy_from(&(side.r * hat(&f)));
                } else {
                    let (fb, mb) = (side.r.transpose() * f, side.r.transpose() * m);
                    terms.force.fixed_rows_mut::<3>(0).copy_from(&(-f));
                    terms
                        .force
                        .fixed_rows_mut::<3>(3)
                        .copy_from(&(-(a.cross(&fb) + mb)));
                    terms
                        .stiffness
                        .fixed_view_mut::<3, 3>(3, 3)
                        .copy_from(&(-(hat(a) * hat(&fb) + hat(&mb))));
                }
            }
        }
        Ok(terms)
    }

    /// A motor's terms for the torque `tau` about `axis` (module docs).
    fn motor(&self, sides: &[Side; 2], axis: &Vector3<f64>, tau: f64, terms: &mut Terms) {
        let [a, b] = sides;
        let y = b.r.transpose() * a.r * axis;
        if self.pair.nodes[1].is_some() {
            terms.force.fixed_rows_mut::<3>(9).copy_from(&(-y * tau));
            terms
                .stiffness
                .fixed_view_mut::<3, 3>(9, 9)
                .copy_from(&(-hat(&y) * tau));
            if self.pair.nodes[0].is_some() {
                let cross = b.r.transpose() * a.r * hat(axis) * tau;
                terms
                    .stiffness
                    .fixed_view_mut::<3, 3>(9, 3)
                    .copy_from(&cross);
            }
        }
        if self.pair.nodes[0].is_some() {
            terms.force.fixed_rows_mut::<3>(3).copy_from(&(axis * tau));
        }
    }

    /// `∂f/∂p` of one of its parameters at `(q, v, t)` (zero where it has none such).
    pub(crate) fn parameter_rate(&self, p: ForceParameter, q: &[f64], v: &[f64], t: f64) -> Local {
        let sides = self.pair.sides(q, Some(v));
        match (&self.kind, p) {
            (
                ForceKind::Spring { rest, .. },
                ForceParameter::Stiffness | ForceParameter::Damping,
            ) => {
                let d = self.pair.evaluate(&Measure::Gap, &sides);
                let l = d.value.norm();
                let n = d.value / l;
                let factor = if p == ForceParameter::Stiffness {
                    l - rest
                } else {
                    n.dot(&d.rate)
                };
                d.jacobian.transpose() * n * factor
            }
            (ForceKind::Motor { time, axis, .. }, ForceParameter::Torque) => {
                let mut terms = Terms {
                    force: Local::zeros(),
                    stiffness: Stiffness::zeros(),
                    damping: Stiffness::zeros(),
                };
                self.motor(&sides, axis, time.at(t), &mut terms);
                terms.force
            }
            _ => Local::zeros(),
        }
    }

    /// Potential energy (J): a spring's `½ k (l − l₀)²`, a constant dead force's `−F·p`;
    /// zero for motors, follower loads and loads that vary in time (not conservative).
    pub fn potential(&self, q: &[f64]) -> f64 {
        let sides = self.pair.sides(q, None);
        match &self.kind {
            ForceKind::Spring {
                stiffness, rest, ..
            } => {
                let l = self.pair.evaluate(&Measure::Gap, &sides).value.norm();
                0.5 * stiffness * (l - rest).powi(2)
            }
            ForceKind::Load {
                force,
                moment,
                time: TimeFunction::Constant,
                follower: false,
            } if moment.norm() == 0.0 => {
                let p = self.pair.point(&sides, 0).value;
                -force.dot(&p)
            }
            _ => 0.0,
        }
    }
}
