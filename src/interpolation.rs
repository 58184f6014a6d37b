//! Material interpolation of a bar with density `x ∈ [x_min, 1]`.
//!
//! Inertia is linear in `x` (paper Eq. 1, 33); stiffness is scaled by `s(x)`
//! (Eq. 34): SIMP `s = xᵖ`, or RAMP `s = x / (1 + q(1 − x))` (Stolpe & Svanberg).

/// How stiffness is scaled with density.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Interpolation {
    /// Power law `s(x) = xᵖ`.
    Simp {
        /// Penalization exponent `p` (default 3).
        p: f64,
    },
    /// Rational law `s(x) = x / (1 + q(1 − x))`.
    Ramp {
        /// Penalization parameter `q`.
        q: f64,
    },
}

impl Interpolation {
    /// Stiffness factor `s(x)`.
    pub fn stiffness(self, x: f64) -> f64 {
        match self {
            Self::Simp { p } => x.powf(p),
            Self::Ramp { q } => x / (1.0 + q * (1.0 - x)),
        }
    }

    /// Derivative `ds/dx`.
    pub fn stiffness_derivative(self, x: f64) -> f64 {
        match self {
            Self::Simp { p } => p * x.powf(p - 1.0),
            Self::Ramp { q } => (1.0 + q) / (1.0 + q * (1.0 - x)).powi(2),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derivatives_match_central_differences() {
        for law in [
            Interpolation::Simp { p: 3.0 },
            Interpolation::Ramp { q: 8.0 },
        ] {
            for x in [0.01, 0.3, 0.9] {
                let eps = 1e-6;
                let fd = (law.stiffness(x + eps) - law.stiffness(x - eps)) / (2.0 * eps);
                assert!((fd - law.stiffness_derivative(x)).abs() < 1e-7 * (1.0 + fd.abs()));
            }
            assert!((law.stiffness(1.0) - 1.0).abs() < 1e-15);
        }
    }
}
