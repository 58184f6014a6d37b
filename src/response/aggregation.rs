//! Aggregates of many point values into one smooth response: the p-mean and the
//! Kreisselmeier–Steinhauser (KS) mean.
//!
//! A stress response condenses values `σ_k` at quadrature points (states in time × points
//! along the structure) with weights `w_k > 0`, `Σ w_k = 1`:
//!
//! * p-mean `P = (Σ w_k |σ_k|^p)^{1/p}`;
//! * KS mean `K = (s/ρ) ln Σ w_k cosh(ρ σ_k / s)`, with `s` a stress scale.
//!
//! Both are means: they never exceed `max |σ_k|` and grow towards it with `p` or `ρ`. Being
//! quadratures of integrals over the motion and the structure, they converge as the time
//! step and the elements per bar are refined, which sums over a point set (the classical
//! p-norm and KS functions, growing with the number of points) do not. The gap to the
//! maximum is closed where a limit is imposed, by the adaptive normalization of Le, Norato,
//! Bruns, Ha and Tortorelli (Struct. Multidisc. Optim. 41, 2010), from the peak reported
//! beside the mean.
//!
//! Sums are kept relative to a reference `r ≥ max |σ_k|` seen so far, so that no term
//! overflows: `S = Σ w_k φ(σ_k; r)` with `φ = (|σ|/r)^p`, or for KS, with `k = ρ/s`,
//! `φ = e^{−kr}(cosh kσ − 1)` and `K = log(1 + e^{kr} S)/k` (`= r + log(S + e^{−kr})/k`,
//! the form used once `kr ≥ 1`): the `− 1` keeps the digits of a KS mean far below `s/ρ`,
//! which `log Σ w cosh` would cancel away. When `r` grows, `S` is rescaled exactly.

use super::arguments::{only, option, Options};

/// How point values are condensed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Aggregation {
    /// `(Σ w |σ|^p)^{1/p}`, `p ≥ 2` (differentiable at `σ = 0`).
    PMean {
        /// Exponent.
        p: f64,
    },
    /// `(s/ρ) ln Σ w cosh(ρσ/s)`.
    KsMean {
        /// Aggregation parameter.
        rho: f64,
        /// Stress scale `s` (Pa).
        scale: f64,
    },
}

/// Largest p-mean exponent or KS parameter accepted.
pub const MAX_PARAMETER: f64 = 1000.0;

impl Aggregation {
    /// `φ(σ; r)` and `dφ/dσ` of a point value relative to the reference `r ≥ |σ|`.
    pub fn point(&self, sigma: f64, r: f64) -> (f64, f64) {
        match *self {
            Self::PMean { .. } if r == 0.0 => (0.0, 0.0),
            Self::PMean { p } => {
                let t = sigma.abs() / r;
                (t.powf(p), p * t.powf(p - 1.0) * sigma.signum() / r)
            }
            Self::KsMean { rho, scale } => {
                let k = rho / scale;
                let (a, b) = ((k * (sigma - r)).exp(), (k * (-sigma - r)).exp());
                let z = k * sigma.abs();
                // e^{−kr}(cosh z − 1), without cancellation for small z.
                let value = if z < 1.0 {
                    2.0 * (0.5 * z).sinh().powi(2) * (-k * r).exp()
                } else {
                    0.5 * (a + b) - (-k * r).exp()
                };
                (value, 0.5 * k * (a - b))
            }
        }
    }

    /// The factor that carries a sum from reference `r` to `r_new ≥ r`.
    pub fn rescale(&self, r: f64, r_new: f64) -> f64 {
        match *self {
            Self::PMean { p } => (r / r_new).powf(p),
            Self::KsMean { rho, scale } => (rho / scale * (r - r_new)).exp(),
        }
    }

    /// The mean of a sum `S` at reference `r`, and its derivative `d mean / dS`. A p-mean of
    /// values all zero is zero, with gradient zero (the norm's subgradient at the origin).
    pub fn mean(&self, sum: f64, r: f64) -> (f64, f64) {
        match *self {
            Self::PMean { .. } if sum == 0.0 => (0.0, 0.0),
            Self::PMean { p } => {
                let root = sum.powf(1.0 / p);
                (r * root, r * root / (p * sum))
            }
            Self::KsMean { rho, scale } => {
                let (k, floor) = (rho / scale, (-rho / scale * r).exp());
                let mean = if k * r < 1.0 {
                    (sum / floor).ln_1p() / k
                } else {
                    r + (sum + floor).ln() / k
                };
                (mean, 1.0 / (k * (sum + floor)))
            }
        }
    }

    /// The mean a response's options `p=P` or `ks=RHO,scale=S` name (none: a p-mean at the
    /// default exponent), no other option accepted.
    pub(crate) fn from_options(options: &Options) -> Result<Self, String> {
        only(options, &["p", "ks", "scale"])?;
        Self::parse(
            option(options, "p"),
            option(options, "ks"),
            option(options, "scale"),
        )
    }

    /// Parses `p=P` or `ks=RHO` with `scale=S` from `key=value` options.
    ///
    /// # Errors
    /// A message naming the option.
    pub fn parse(p: Option<f64>, ks: Option<f64>, scale: Option<f64>) -> Result<Self, String> {
        let within = |name: &str, v: f64, low: f64| {
            if v.is_finite() && v >= low && v <= MAX_PARAMETER {
                Ok(v)
            } else {
                Err(format!("{name}={v} must lie in [{low}, {MAX_PARAMETER}]"))
            }
        };
        match (p, ks, scale) {
            (Some(_), Some(_), _) => Err("give one of p= (p-mean) and ks= (KS mean)".into()),
            (_, None, Some(_)) => Err("scale= goes with ks=".into()),
            (p, None, None) => Ok(Self::PMean {
                p: within("p", p.unwrap_or(DEFAULT_P), 2.0)?,
            }),
            (None, Some(rho), scale) => {
                let scale = scale
                    .ok_or("ks= needs scale=S, the value it normalizes by (Pa for a stress)")?;
                let rho = within("ks", rho, f64::MIN_POSITIVE)?;
                let k = rho / scale;
                if !(scale.is_finite() && scale > 0.0 && k.is_normal()) {
                    return Err(format!(
                        "scale={scale} must be positive, with ks/scale a normal number"
                    ));
                }
                Ok(Self::KsMean { rho, scale })
            }
        }
    }
}

/// The p-mean's default exponent (Le et al. 2010 use 8).
pub const DEFAULT_P: f64 = 8.0;

#[cfg(test)]
mod tests {
    use super::*;

    /// Streams values through the reference as a response does, returns the mean.
    fn stream(a: &Aggregation, values: &[f64]) -> f64 {
        let w = 1.0 / values.len() as f64;
        let (mut r, mut sum) = (0.0_f64, 0.0);
        for &v in values {
            if v.abs() > r {
                sum *= a.rescale(r, v.abs());
                r = v.abs();
            }
            sum += w * a.point(v, r).0;
        }
        a.mean(sum, r).0
    }

    #[test]
    fn means_match_their_definitions_and_stay_below_the_maximum() {
        let v = [3.0e8, -5.0e8, 1.0e7, 4.9e8, 0.0, -2.0e8];
        let n = v.len() as f64;
        let p = 8.0;
        let direct = (v.iter().map(|x: &f64| x.abs().powf(p)).sum::<f64>() / n).powf(1.0 / p);
        let pm = stream(&Aggregation::PMean { p }, &v);
        assert!((pm - direct).abs() < 1e-12 * direct);
        let (rho, s) = (20.0, 1.0e8);
        let direct = s / rho * (v.iter().map(|x| (rho * x / s).cosh()).sum::<f64>() / n).ln();
        let ks = stream(&Aggregation::KsMean { rho, scale: s }, &v);
        assert!((ks - direct).abs() < 1e-12 * direct);
        for a in [pm, ks] {
            assert!(a < 5.0e8 && a > 3.0e8, "{a}");
        }
    }

    #[test]
    fn a_ks_mean_far_below_its_scale_keeps_its_digits() {
        // ρσ/s = 1e-6: K ≈ k Σw σ²/2, which ln Σ w cosh would lose to cancellation.
        let v = [3.0e8, -5.0e8, 1.0e7];
        let a = Aggregation::KsMean {
            rho: 1e-6,
            scale: 1e8,
        };
        let k = 1e-14;
        let exact = v.iter().map(|x| x * x).sum::<f64>() / 3.0 * k / 2.0;
        assert!((stream(&a, &v) / exact - 1.0).abs() < 1e-9);
        let big = Aggregation::KsMean {
            rho: 1.0,
            scale: 1e300,
        };
        assert!(stream(&big, &v) >= 0.0 && stream(&big, &v) <= 5.0e8);
    }

    #[test]
    fn means_grow_to_the_maximum_with_the_parameter() {
        let v = [3.0e8, -5.0e8, 1.0e7, 4.9e8];
        let mut last = 0.0;
        for p in [2.0, 8.0, 32.0, 128.0, 512.0] {
            let m = stream(&Aggregation::PMean { p }, &v);
            assert!(m > last && m <= 5.0e8);
            last = m;
        }
        assert!(5.0e8 - last < 1e-2 * 5.0e8);
    }

    #[test]
    fn point_derivatives_match_central_differences() {
        for a in [
            Aggregation::PMean { p: 8.0 },
            Aggregation::KsMean {
                rho: 30.0,
                scale: 2.0,
            },
        ] {
            for s in [-1.5, -0.3, 0.7, 1.9] {
                let h = 1e-6;
                let fd = (a.point(s + h, 2.0).0 - a.point(s - h, 2.0).0) / (2.0 * h);
                let d = a.point(s, 2.0).1;
                assert!((fd - d).abs() < 1e-7 * d.abs().max(1.0), "{a:?} at {s}");
            }
        }
    }

    #[test]
    fn options_are_checked() {
        assert_eq!(
            Aggregation::parse(None, None, None),
            Ok(Aggregation::PMean { p: DEFAULT_P })
        );
        assert!(Aggregation::parse(Some(1.0), None, None).is_err());
        assert!(Aggregation::parse(None, Some(50.0), None).is_err());
        assert!(Aggregation::parse(Some(8.0), Some(50.0), Some(1.0)).is_err());
        assert!(Aggregation::parse(None, Some(50.0), Some(-1.0)).is_err());
        assert!(Aggregation::parse(None, Some(f64::NAN), Some(1.0)).is_err());
    }
}
