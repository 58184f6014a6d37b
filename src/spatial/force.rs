//! Force elements of a spatial mechanism, each on two anchors (`pair.rs`) and
//! their nodes' twelve local unknowns, with the residual terms `f` (internal forces
//! positive, applied ones negative), the exact stiffness `K = ∂f/∂q` (right-trivialized)
//! and damping `C = ∂f/∂v`:
//!
//! - a **spring-damper** between two points, `N = k (l − l₀) + c l̇` along their line
//!   (`d = p_B − p_A`, `l = |d|`, `n = d/l`): `f = Jᵀ n N`,
//!   `K = H_d[nN] + Jᵀ (N/l (I − nnᵀ) + k nnᵀ + (c/l) n ḋᵀ(I − nnᵀ)) J + c Jᵀ n nᵀ D`
//!   (`D = ∂(J v)/∂q`), `C = c Jᵀ n nᵀ J`; energy `½ k (l − l₀)²`;
//! - a **torsion spring-damper** on a revolute or cylindrical joint, `τ = k (φ − φ₀) + c φ̇`
//!   about its axis, `φ = atan2(s, c)` with `c = (R_A e₁)·(R_B b₁)`, `s = (R_A e₂)·(R_B b₁)`
//!   the joint's angle from where it was built (within half a turn either way): `f = ∇φ τ`,
//!   `K = ∇φ (k ∇φ + c ∂φ̇/∂q)ᵀ + τ ∇²φ`, `C = c ∇φ ∇φᵀ`; energy `½ k (φ − φ₀)²`;
//! - a **motor** on a revolute joint: a torque `τ g(t)` about the joint's axis, carried by A,
//!   on B (its opposite on A): `f_B = −τ Rᵦᵀ R_A n`, `f_A = τ n`;
//! - a **load** at a body's point `a`: a force `F g(t)` and a moment `M g(t)`, dead (fixed in
//!   space: `f = −[F; ã RᵀF + RᵀM]`) or follower (fixed in the body: `f = −[R F; ã F + M]`).
//!
//! Units SI: N/m, N s/m, N m, N.

use nalgebra::{Matrix3, SVector, Vector3};

use crate::error::SolveError;
use crate::group::pair::{Measure, Pair, Side, Stiffness, LOCAL};
use crate::group::so3::hat;
use crate::mechanism::load::TimeFunction;

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
    /// A torsion spring-damper on a revolute or cylindrical joint's angle.
    Torsion {
        /// Stiffness `k` (N m/rad).
        stiffness: f64,
        /// Damping `c` (N m s/rad).
        damping: f64,
        /// Rest angle `φ₀` from where the joint was built (rad).
        rest: f64,
        /// The joint's angle axes ([`crate::joint::spatial::Joint::angle_axes`]).
        axes: [Vector3<f64>; 3],
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
    /// A spring's rest length `l₀` (a torsion spring's rest angle `φ₀`).
    Rest,
    /// A motor's torque.
    Torque,
}

impl Force {
    /// Its terms at `(q, v, t)`, motors and loads scaled by the load factor `load` (1 in
    /// motion, climbing to 1 in a static solve).
    ///
    /// # Errors
    /// [`SolveError::SpringCollapsed`] where a spring's points meet (its line has no
    /// direction), [`SolveError::SpringWound`] where a torsion spring's joint turned half a
    /// turn.
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
            ForceKind::Torsion {
                stiffness: k,
                damping: c,
                rest,
                axes,
            } => {
                let angle = Angle::new(&self.pair, &sides, axes);
                if angle.value.abs() > WOUND {
                    return Err(SolveError::SpringWound {
                        at: format!("t = {t:.6} s"),
                        spring: self.name.clone(),
                        angle: angle.value,
                    });
                }
                let tau = k * (angle.value - rest) + c * angle.rate;
                terms.force = angle.gradient * tau;
                terms.stiffness = angle.gradient
                    * (angle.gradient * *k + angle.rate_gradient * *c).transpose()
                    + angle.hessian * tau;
                terms.damping = angle.gradient * angle.gradient.transpose() * *c;
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
                ForceKind::Spring {
                    stiffness, rest, ..
                },
                ForceParameter::Stiffness | ForceParameter::Damping | ForceParameter::Rest,
            ) => {
                let d = self.pair.evaluate(&Measure::Gap, &sides);
                let l = d.value.norm();
                let n = d.value / l;
                // ∂(tension)/∂p of `k (l − l₀) + c l̇`.
                let factor = match p {
                    ForceParameter::Stiffness => l - rest,
                    ForceParameter::Damping => n.dot(&d.rate),
                    _ => -stiffness,
                };
                d.jacobian.transpose() * n * factor
            }
            (
                ForceKind::Torsion {
                    stiffness,
                    rest,
                    axes,
                    ..
                },
                ForceParameter::Stiffness | ForceParameter::Damping | ForceParameter::Rest,
            ) => {
                let angle = Angle::new(&self.pair, &sides, axes);
                let factor = match p {
                    ForceParameter::Stiffness => angle.value - rest,
                    ForceParameter::Damping => angle.rate,
                    _ => -stiffness,
                };
                angle.gradient * factor
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
            ForceKind::Torsion {
                stiffness,
                rest,
                axes,
                ..
            } => 0.5 * stiffness * (Angle::new(&self.pair, &sides, axes).value - rest).powi(2),
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

/// How far a torsion spring's joint may turn from where it was built (rad): short of half
/// a turn, where `atan2` jumps.
const WOUND: f64 = 0.999 * std::f64::consts::PI;

/// A joint's angle `φ = atan2(s, c)` (module docs) at a state: its value, gradient `∇φ`,
/// rate `φ̇ = ∇φ · v`, `∂φ̇/∂q` at fixed `v`, and `∇²φ = ∂(∇φ)/∂q`, on the pair's local
/// unknowns.
struct Angle {
    value: f64,
    gradient: Local,
    rate: f64,
    rate_gradient: Local,
    hessian: Stiffness,
}

impl Angle {
    fn new(pair: &Pair, sides: &[Side; 2], axes: &[Vector3<f64>; 3]) -> Self {
        let [e1, e2, b1] = *axes;
        let (mc, ms, mb) = (
            Measure::Axis(0, e1),
            Measure::Axis(0, e2),
            Measure::Axis(1, b1),
        );
        let (pc, ps) = (pair.product(&mc, &mb, sides), pair.product(&ms, &mb, sides));
        let (c, s) = (pc.value, ps.value);
        let r2 = c * c + s * s;
        let gradient = (ps.gradient * c - pc.gradient * s) / r2;
        let r2_gradient = (ps.gradient * s + pc.gradient * c) * 2.0;
        let numerator = c * ps.rate - s * pc.rate;
        let (dc, ds) = (
            product_rate_gradient(pair, &mc, &mb, sides),
            product_rate_gradient(pair, &ms, &mb, sides),
        );
        let rate_gradient = (pc.gradient * ps.rate + ds * c - ps.gradient * pc.rate - dc * s) / r2
            - r2_gradient * (numerator / (r2 * r2));
        let mut hessian = Stiffness::zeros();
        pair.add_product_hessian(&ms, &mb, sides, c / r2, &mut hessian);
        pair.add_product_hessian(&mc, &mb, sides, -s / r2, &mut hessian);
        hessian += (ps.gradient * pc.gradient.transpose() - pc.gradient * ps.gradient.transpose())
            / r2
            - gradient * r2_gradient.transpose() / r2;
        Self {
            value: s.atan2(c),
            gradient,
            rate: numerator / r2,
            rate_gradient,
            hessian,
        }
    }
}

/// `∂(α̇·β + α·β̇)/∂q` at fixed `v` of two axes: `J̇_αᵀβ + J_αᵀβ̇ + J̇_βᵀα + J_βᵀα̇`, an
/// axis `R u`'s rate `R (Ω × u)` varying as `−R (Ω × u)~` with its node's rotation.
fn product_rate_gradient(pair: &Pair, alpha: &Measure, beta: &Measure, sides: &[Side; 2]) -> Local {
    let (a, b) = (pair.evaluate(alpha, sides), pair.evaluate(beta, sides));
    let rate_jacobian = |m: &Measure| {
        let mut j = crate::group::pair::Jacobian::zeros();
        if let Measure::Axis(s, u) = m {
            if pair.nodes[*s].is_some() {
                let side = &sides[*s];
                j.fixed_view_mut::<3, 3>(0, 6 * s + 3)
                    .copy_from(&(-side.r * hat(&side.omega.cross(u))));
            }
        }
        j
    };
    rate_jacobian(alpha).transpose() * b.value
        + a.jacobian.transpose() * b.rate
        + rate_jacobian(beta).transpose() * a.value
        + b.jacobian.transpose() * a.rate
}

#[cfg(test)]
mod tests {
    use nalgebra::{Matrix3, UnitQuaternion};

    use super::*;
    use crate::group::{Frame, NV};
    use crate::joint::spatial::{Anchor, JointKind};
    use crate::spatial::model::SpatialModel;

    /// A torsion spring-damper's `K` and `C` against central differences of its force, its
    /// joint turned and both bodies tumbling, the joint's axis kept only approximately (the
    /// state off the constraint, where `∇²φ`'s every term counts); its energy's derivative
    /// along a motion against its force.
    #[test]
    fn a_torsion_springs_derivatives_match_differences() {
        let mut m = SpatialModel::new(Vector3::zeros()).unwrap();
        let r = |v: [f64; 3]| UnitQuaternion::from_scaled_axis(Vector3::from(v));
        let a = m
            .add_body(
                "a",
                Frame::new(Vector3::zeros(), r([0.0; 3])),
                1.0,
                Matrix3::identity(),
            )
            .unwrap();
        let b = m
            .add_body(
                "b",
                Frame::new(Vector3::x(), r([0.0; 3])),
                1.0,
                Matrix3::identity(),
            )
            .unwrap();
        let hinge = m
            .add_joint(
                "hinge",
                JointKind::Revolute {
                    axis: Vector3::new(0.2, 1.0, 0.4),
                },
                Anchor::Body {
                    body: a,
                    point: Vector3::new(0.5, 0.0, 0.0),
                },
                Anchor::Body {
                    body: b,
                    point: Vector3::new(-0.5, 0.0, 0.0),
                },
            )
            .unwrap();
        let coil = m.add_torsion("coil", hinge, 7.0, 0.3, Some(-0.2)).unwrap();
        let spring = &m.forces[coil];
        let mut q = m.initial_configuration();
        let turn = [
            0.01, 0.02, -0.03, 0.2, -0.7, 0.9, 0.0, -0.01, 0.02, 0.1, 0.8, -0.3,
        ];
        for node in 0..2 {
            Frame::read(&q.clone(), node)
                .retract(&turn[NV * node..NV * node + NV])
                .write(&mut q, node);
        }
        let v = [
            0.1, -0.2, 0.3, 1.2, -0.4, 0.7, -0.3, 0.2, 0.1, 0.5, 0.9, -1.1,
        ];
        let force = |q: &[f64], v: &[f64]| spring.terms(q, v, 0.0, 1.0).unwrap().force;
        let terms = spring.terms(&q, &v, 0.0, 1.0).unwrap();
        let (k_max, c_max) = (terms.stiffness.amax(), terms.damping.amax());
        assert!(k_max > 1.0 && c_max > 0.1);
        for k in 0..12 {
            let moved = |e: f64| {
                let mut inc = [0.0; 12];
                inc[k] = e;
                let mut p = q.clone();
                for node in 0..2 {
                    Frame::read(&q, node)
                        .retract(&inc[NV * node..NV * node + NV])
                        .write(&mut p, node);
                }
                p
            };
            let fd = (force(&moved(1e-7), &v) - force(&moved(-1e-7), &v)) / 2e-7;
            let err = (fd - terms.stiffness.column(k)).amax();
            assert!(err < 1e-7 * k_max, "K column {k}: {err:e} of {k_max:e}");
            let mut w = v;
            w[k] += 1e-4;
            let fd = (force(&q, &w) - terms.force) / 1e-4;
            let err = (fd - terms.damping.column(k)).amax();
            assert!(err < 1e-7 * c_max, "C column {k}: {err:e} of {c_max:e}");
            // The potential's derivative is the elastic part of the force.
            let elastic = |q: &[f64]| spring.potential(q);
            let fd = (elastic(&moved(1e-6)) - elastic(&moved(-1e-6))) / 2e-6;
            let still = spring.terms(&q, &[0.0; 12], 0.0, 1.0).unwrap().force[k];
            assert!(
                (fd - still).abs() < 1e-7 * k_max,
                "energy {k}: {fd} vs {still}"
            );
        }
    }
}
