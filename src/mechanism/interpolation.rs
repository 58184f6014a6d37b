//! Material interpolation of a bar with density `x ∈ [x_min, 1]`.
//!
//! Stiffness is scaled by `s(x)` (paper Eq. 34): SIMP `s = xᵖ`, or RAMP
//! `s = x / (1 + q(1 − x))` (Stolpe & Svanberg). Inertia is scaled by `m(x)`: linear,
//! `m = x` (paper Eq. 1, 33), or a law of the Du & Olhoff (2007) type: `m = x` above a
//! threshold `x_t`, and below it `m = x (c + (1 − c) r⁵(6 − 5r))`, `r = x/x_t`, C¹ at `x_t`
//! (with `c = 0` it is their sixth/seventh-order polynomial). The floor `c = 10⁻³` keeps the
//! mass of a near-void bar at least `c x`, so that the iteration matrix of a design at
//! extreme densities (x = 10⁻⁶) stays regular.
//!
//! Why the second: a thin bar's own bending frequencies scale as `√(s/m)` of a solid bar's.
//! Under the paper's law (`x³` against `x`) a bar at `x = 0.01` vibrates at 1 % of its solid
//! frequency — for bars of 0.25–1 m, inside the band a motion excites — and these spurious
//! local modes appear only when the bar is refined, so a design with near-void bars has no
//! limit in elements per bar (Pedersen 2000; Du & Olhoff 2007). Below `x_t` the Du–Olhoff
//! mass falls faster than the stiffness: with SIMP `p = 3` and `x_t = 0.1`, `√(s/m)` stays
//! above 0.09 of the solid frequency for `x ≥ 0.004` (0.31 at `x = 0.01`).

/// How stiffness is scaled with density.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Interpolation {
    /// Power law `s(x) = s_min + (1 − s_min) xᵖ` (`s_min = E_min/E`, 0 by default: `xᵖ`).
    Simp {
        /// Penalization exponent `p` (default 3).
        p: f64,
        /// The stiffness of void, `E_min/E` (0 by default; the 88-line code's 1e-9).
        e_min: f64,
    },
    /// Rational law `s(x) = x / (1 + q(1 − x))`.
    Ramp {
        /// Penalization parameter `q`.
        q: f64,
    },
}

/// Default floor `c` of the Du–Olhoff mass: `m(x) ≥ c x`.
pub const MASS_FLOOR: f64 = 1e-3;

/// How inertia is scaled with density.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MassLaw {
    /// `m(x) = x` (the paper's law, valid at one element per bar).
    Linear,
    /// `m(x) = x` for `x ≥ threshold`, `x (c + (1 − c) r⁵(6 − 5r))` with `r = x/threshold`
    /// and `c = floor` below.
    DuOlhoff {
        /// The density `x_t` below which the mass falls like `x⁶`.
        threshold: f64,
        /// The floor `c` (default [`MASS_FLOOR`]).
        floor: f64,
    },
}

impl MassLaw {
    /// Mass factor `m(x)`.
    pub fn mass(self, x: f64) -> f64 {
        match self {
            Self::DuOlhoff { threshold, floor } if x < threshold => {
                let r = x / threshold;
                x * (floor + (1.0 - floor) * r.powi(5) * (6.0 - 5.0 * r))
            }
            _ => x,
        }
    }

    /// Derivative `dm/dx`.
    pub fn mass_derivative(self, x: f64) -> f64 {
        match self {
            Self::DuOlhoff { threshold, floor } if x < threshold => {
                let r = x / threshold;
                floor + (1.0 - floor) * r.powi(5) * (36.0 - 35.0 * r)
            }
            _ => 1.0,
        }
    }
}

impl Interpolation {
    /// Stiffness factor `s(x)`.
    pub fn stiffness(self, x: f64) -> f64 {
        match self {
            Self::Simp { p, e_min } => e_min + (1.0 - e_min) * x.powf(p),
            Self::Ramp { q } => x / (1.0 + q * (1.0 - x)),
        }
    }

    /// Derivative `ds/dx`.
    pub fn stiffness_derivative(self, x: f64) -> f64 {
        match self {
            Self::Simp { p, e_min } => (1.0 - e_min) * p * x.powf(p - 1.0),
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
            Interpolation::Simp { p: 3.0, e_min: 0.0 },
            Interpolation::Simp {
                p: 3.0,
                e_min: 1e-9,
            },
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

    #[test]
    fn du_olhoff_mass_is_c1_at_the_threshold_and_its_derivative_exact() {
        let law = MassLaw::DuOlhoff {
            threshold: 0.1,
            floor: MASS_FLOOR,
        };
        let eps = 1e-7;
        for x in [0.01, 0.05, 0.0999, 0.1001, 0.5] {
            let fd = (law.mass(x + eps) - law.mass(x - eps)) / (2.0 * eps);
            assert!((fd - law.mass_derivative(x)).abs() < 1e-6, "x = {x}");
        }
        assert!((law.mass(0.1 - 1e-12) - 0.1).abs() < 1e-10);
        assert!((law.mass_derivative(0.1 - 1e-12) - 1.0).abs() < 1e-9);
        // A thin bar keeps its own frequencies: √(s/m) = √(x³/m(x)) is 0.31 of a solid bar's
        // at x = 0.01 (0.01 under the linear law) and stays above 0.09 for x ≥ 0.004.
        let simp = Interpolation::Simp { p: 3.0, e_min: 0.0 };
        let ratio = |x: f64| (simp.stiffness(x) / law.mass(x)).sqrt();
        assert!((ratio(0.01) - 0.31).abs() < 0.01);
        assert!((4..=100).all(|k| ratio(k as f64 * 1e-3) > 0.09));
        assert!(law.mass(1e-6) >= MASS_FLOOR * 1e-6);
        assert_eq!(MassLaw::Linear.mass(0.01), 0.01);
    }
}
