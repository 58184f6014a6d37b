//! The rotation group SO(3): the exponential and logarithm, and the tangent operator of the
//! exponential (Brüls, Cardona & Arnold, *Mech. Mach. Theory* 48, 2012, §2).
//!
//! Rotations are unit quaternions (four numbers, never three angles that can lock). An
//! increment `θ ∈ ℝ³` of the algebra acts on the right, `R ∘ exp(θ̃)`, the body-fixed
//! convention of the Lie-group generalized-α method: velocities are body angular velocities
//! `Ω`, `Ṙ = R Ω̃`.
//!
//! The tangent operator `T(θ)` relates a change of the increment to the rotation it causes,
//! `exp((θ + δ)~) = exp(θ̃) exp((T(θ) δ)~) + O(δ²)`:
//!
//! ```text
//! T(θ)  = I − (1 − cos φ)/φ² θ̃ + (φ − sin φ)/φ³ θ̃²,          φ = |θ|
//! T⁻¹(θ) = I + ½ θ̃ + (1 − (φ/2) cot(φ/2))/φ² θ̃²
//! ```
//!
//! Each coefficient switches to its Taylor series near `φ = 0`, where the closed forms lose
//! their digits; `T` is regular for every `|θ| < 2π`, so an increment may cross `π`.

use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};

/// Below this angle (rad) `T⁻¹`'s coefficient is evaluated by its Taylor series (truncation
/// about 1e-15 relative there), where its closed form cancels.
const SERIES_ANGLE: f64 = 1e-3;

/// The skew matrix `ṽ` with `ṽ w = v × w`.
pub fn hat(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// `exp(θ̃)`: the rotation by `|θ|` about `θ/|θ|` (Rodrigues), as a unit quaternion.
pub fn exp(theta: &Vector3<f64>) -> UnitQuaternion<f64> {
    let phi = theta.norm();
    // sin(φ/2)/φ and cos(φ/2).
    let (s, c) = if phi < SERIES_ANGLE {
        let p2 = phi * phi;
        (0.5 - p2 / 48.0, 1.0 - p2 / 8.0 + p2 * p2 / 384.0)
    } else {
        ((0.5 * phi).sin() / phi, (0.5 * phi).cos())
    };
    UnitQuaternion::new_unchecked(Quaternion::new(c, s * theta.x, s * theta.y, s * theta.z))
}

/// `log(R)`: the rotation vector `θ`, `|θ| ≤ π`, with `exp(θ̃) = R`.
pub fn log(r: &UnitQuaternion<f64>) -> Vector3<f64> {
    // q and −q are the same rotation: take the one with w ≥ 0, so that φ ≤ π.
    let q = if r.w < 0.0 {
        -r.into_inner()
    } else {
        r.into_inner()
    };
    let v = q.imag();
    let s = v.norm();
    // φ/s = 2 atan2(s, w)/s, without cancellation for any s > 0; 2/w at s = 0.
    let ratio = if s > 0.0 {
        2.0 * s.atan2(q.w) / s
    } else {
        2.0 / q.w
    };
    v * ratio
}

/// The coefficients `(a, b)` of `T(θ) = I − a θ̃ + b θ̃²`: `a = (1 − cos φ)/φ² =
/// ½ (sin(φ/2)/(φ/2))²`, without cancellation; `b = (φ − sin φ)/φ³`, by its series below
/// 0.1 rad (four terms: truncation under 1e-16 relative) where the closed form cancels.
fn tangent_coefficients(phi: f64) -> (f64, f64) {
    let half = 0.5 * phi;
    let sinc = if half > 0.0 { half.sin() / half } else { 1.0 };
    let p2 = phi * phi;
    let b = if phi < 0.1 {
        1.0 / 6.0 - p2 / 120.0 + p2 * p2 / 5040.0 - p2 * p2 * p2 / 362_880.0
    } else {
        (phi - phi.sin()) / (p2 * phi)
    };
    (0.5 * sinc * sinc, b)
}

/// The tangent operator `T(θ)` of the exponential (module docs).
pub fn tangent(theta: &Vector3<f64>) -> Matrix3<f64> {
    let (a, b) = tangent_coefficients(theta.norm());
    let t = hat(theta);
    Matrix3::identity() - t * a + t * t * b
}

/// `T⁻¹(θ)` (module docs), for `|θ| < 2π`.
pub fn tangent_inverse(theta: &Vector3<f64>) -> Matrix3<f64> {
    InverseTangent::new(theta).at(1.0)
}

/// `T⁻¹(±θ)` and their derivatives at one rotation vector `θ`, `|θ| < 2π`: the
/// coefficients' trigonometry evaluated once for both signs (a beam reads `T⁻¹(ψ)` and
/// `T⁻¹(−ψ)`, and their derivatives in its tangent).
#[derive(Debug, Clone, Copy)]
pub struct InverseTangent {
    theta: Vector3<f64>,
    /// `c(|θ|)`.
    c: f64,
    /// `c'(|θ|)/|θ|`.
    rate: f64,
}

impl InverseTangent {
    /// The coefficients at `θ`.
    pub fn new(theta: &Vector3<f64>) -> Self {
        let phi = theta.norm();
        Self {
            theta: *theta,
            c: inverse_coefficient(phi),
            rate: inverse_coefficient_rate(phi),
        }
    }

    /// `T⁻¹(sθ)`, `s = ±1`.
    pub fn at(&self, s: f64) -> Matrix3<f64> {
        let t = hat(&(self.theta * s));
        Matrix3::identity() + t * 0.5 + t * t * self.c
    }

    /// `∂(T⁻¹(θ') w)/∂θ'` at `θ' = sθ`, `s = ±1` ([`tangent_inverse_derivative`]).
    pub fn derivative(&self, s: f64, w: &Vector3<f64>) -> Matrix3<f64> {
        let theta = self.theta * s;
        let t2w = theta.cross(&theta.cross(w));
        -hat(w) * 0.5
            + (Matrix3::identity() * theta.dot(w) + theta * w.transpose()
                - w * theta.transpose() * 2.0)
                * self.c
            + t2w * theta.transpose() * self.rate
    }
}

/// `c(φ) = (1 − (φ/2) cot(φ/2))/φ²` of `T⁻¹`, by its series below [`SERIES_ANGLE`].
fn inverse_coefficient(phi: f64) -> f64 {
    if phi < SERIES_ANGLE {
        1.0 / 12.0 + phi * phi / 720.0
    } else {
        let half = 0.5 * phi;
        (1.0 - half / half.tan()) / (phi * phi)
    }
}

/// `c'(φ)/φ`, by its series `Σ 2(k−1) |B₂ₖ|/(2k)! φ^(2k−4)` (Bernoulli numbers; eleven
/// terms, truncation under 1e-17 relative) below 1 rad, where the closed form
/// `(u'/φ − 2u/φ²)/φ²`, `u = 1 − (φ/2) cot(φ/2)`, cancels (by 1e-11 at 0.25 rad).
fn inverse_coefficient_rate(phi: f64) -> f64 {
    let p2 = phi * phi;
    if phi < 1.0 {
        const SERIES: [f64; 11] = [
            0.002777777777777778,
            0.00013227513227513228,
            4.96031746031746e-06,
            1.670140559029448e-07,
            5.2841901386874934e-09,
            1.6059043836821613e-10,
            4.745552414851616e-12,
            1.3737699290044552e-13,
            3.914763657404511e-15,
            1.1018005656720459e-16,
            3.069982230878755e-18,
        ];
        SERIES.iter().rev().fold(0.0, |acc, c| acc * p2 + c)
    } else {
        let half = 0.5 * phi;
        let u = 1.0 - half / half.tan();
        let du = -0.5 / half.tan() + 0.25 * phi / half.sin().powi(2);
        (du / phi - 2.0 * u / p2) / p2
    }
}

/// The derivative `∂(T⁻¹(θ) w)/∂θ`, for `|θ| < 2π`:
///
/// ```text
/// −½ w̃ + c (θ·w I + θ wᵀ − 2 w θᵀ) + (c'/φ) (θ̃² w) θᵀ
/// ```
///
/// with `T⁻¹(θ) = I + ½ θ̃ + c(φ) θ̃²` (module docs).
pub fn tangent_inverse_derivative(theta: &Vector3<f64>, w: &Vector3<f64>) -> Matrix3<f64> {
    InverseTangent::new(theta).derivative(1.0, w)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rotation vectors of every size that matters: tiny, around the series switch, large,
    /// near and at π.
    fn samples() -> Vec<Vector3<f64>> {
        let axes = [
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(0.3, -0.8, 0.52).normalize(),
            Vector3::new(-0.2, 0.1, 0.97).normalize(),
        ];
        let angles = [
            1e-09,
            0.0001,
            0.00099,
            0.00101,
            0.1,
            1.0,
            2.5,
            3.1,
            std::f64::consts::PI - 1e-7,
        ];
        axes.iter()
            .flat_map(|a| angles.iter().map(move |&p| a * p))
            .collect()
    }

    #[test]
    fn log_inverts_exp_up_to_pi() {
        for theta in samples() {
            let back = log(&exp(&theta));
            assert!(
                (back - theta).norm() <= 1e-14 * (1.0 + theta.norm()),
                "{theta:?} → {back:?}"
            );
        }
    }

    #[test]
    fn exp_is_the_rotation_of_rodrigues() {
        for theta in samples() {
            let expected = nalgebra::Rotation3::new(theta);
            let got = exp(&theta).to_rotation_matrix();
            assert!((got.matrix() - expected.matrix()).norm() < 1e-15);
        }
    }

    /// Beyond π the logarithm returns the equivalent rotation of the other sense: many turns
    /// are a sum of increments, never one logarithm.
    #[test]
    fn log_wraps_beyond_pi() {
        let axis = Vector3::new(0.0, 0.0, 1.0);
        let back = log(&exp(&(axis * 4.0)));
        assert!((back - axis * (4.0 - 2.0 * std::f64::consts::PI)).norm() < 1e-14);
    }

    #[test]
    fn tangent_is_the_derivative_of_exp() {
        // exp(θ + εδ) ≈ exp(θ) exp(ε T(θ)δ): the logarithm of exp(θ)⁻¹ exp(θ + εδ), by
        // central differences, against T(θ)δ.
        let delta = Vector3::new(0.4, -0.7, 0.2);
        let eps = 1e-6;
        for theta in samples() {
            let back = |e: f64| log(&(exp(&theta).inverse() * exp(&(theta + delta * e))));
            let fd = (back(eps) - back(-eps)) / (2.0 * eps);
            let exact = tangent(&theta) * delta;
            assert!(
                (fd - exact).norm() < 1e-8,
                "{theta:?}: {fd:?} against {exact:?}"
            );
        }
    }

    #[test]
    fn tangent_inverse_inverts_up_to_two_pi() {
        let mut thetas = samples();
        thetas.push(Vector3::new(0.0, 5.0, -3.0));
        for theta in thetas {
            let product = tangent(&theta) * tangent_inverse(&theta);
            assert!((product - Matrix3::identity()).norm() < 1e-12, "{theta:?}");
        }
    }

    /// `∂(T⁻¹(θ) w)/∂θ` against central differences, at every size of angle.
    #[test]
    fn tangent_inverse_derivative_against_differences() {
        let w = Vector3::new(0.7, -1.3, 0.4);
        for theta in samples().into_iter().filter(|t| t.norm() < 3.0) {
            let exact = tangent_inverse_derivative(&theta, &w);
            let eps = 1e-6;
            for k in 0..3 {
                let mut e = Vector3::zeros();
                e[k] = eps;
                let fd = (tangent_inverse(&(theta + e)) * w - tangent_inverse(&(theta - e)) * w)
                    / (2.0 * eps);
                let err = (fd - exact.column(k)).norm();
                assert!(err < 1e-8, "|θ| = {}: {err}", theta.norm());
            }
        }
        // The rate's series and closed form meet at the switch.
        let (below, above) = (
            inverse_coefficient_rate(1.0 - 1e-12),
            inverse_coefficient_rate(1.0),
        );
        assert!((below / above - 1.0).abs() < 1e-12, "{below} {above}");
    }
}
