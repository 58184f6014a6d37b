//! What breaks a bar, read at points of its elements: fibre stresses and Euler buckling
//! ratios, each with its derivative with respect to the element's DOFs.
//!
//! Both use the full-density section forces `[N, M₁, M₂]` of the co-rotational beam, so
//! they are the solid material's values: under SIMP a bar of density `x` carries `s(x) N`
//! with section `s(x) EA`, and the stress `s N / (s A)` does not depend on `s`. A relaxation
//! factor `x^q` multiplies them (Le et al. 2010: `q = ½`), so that vanishing bars, whose
//! strains stay finite, do not make a stress limit singular.
//!
//! Each is a linear form of the section forces at a point (zero in tension for buckling),
//! so one set of coefficients gives the value and, through the forces' Jacobian, its
//! derivative.
//!
//! * Fibre stress `σ = x^q (N/A ± M c/I)` on both outer fibres. No load acts inside an
//!   element, so the bending moment runs linearly from `−M₁` to `M₂` and `σ` is linear along
//!   the element; six Gauss–Lobatto points integrate `|σ|^p` exactly for even `p ≤ 8`, and
//!   the ends, where the largest `|σ|` is, are among them.
//! * Shear stress `τ = x^q k V/A`, the largest over the section (`k = 4/3` for a solid
//!   circle), with `V = −(M₁ + M₂)/L` constant along the element (moment equilibrium): one
//!   point per element.
//! * Buckling ratio `b = x^q P L²/(π² EI)`, `P = max(−N, 0)` the compression and `L` the
//!   bar's length: the compressive force over the Euler load `π² EI/L²` of the pin-ended bar
//!   (a bar clamped at its ends is stronger, so this is the safe side). One point per
//!   element, whose `N` is constant.

use std::f64::consts::PI;

use nalgebra::Vector3;

use crate::mechanism::model::Element;
use crate::mechanism::section::Section;

/// What an aggregate measures at its points: the criterion a bar is judged by.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Criterion {
    /// Fibre stresses (Pa).
    Stress,
    /// The largest shear stress of the section (Pa).
    Shear,
    /// Compression over the Euler load of the bar (dimensionless).
    Buckling,
}

/// An element at a state, as a measure reads it.
pub struct ElementState<'a> {
    /// The element.
    pub element: &'a Element,
    /// Length of its bar (m), for the Euler load.
    pub bar_length: f64,
    /// The relaxation factor `x^q` of its density.
    pub relax: f64,
    /// Its full-density section forces `[N, M₁, M₂]`.
    pub forces: Vector3<f64>,
}

/// Six-point Gauss–Lobatto rule on `[0, 1]` (abscissa, weight; weights sum to 1): exact for
/// polynomials of degree 9.
const LOBATTO: [(f64, f64); 6] = [
    (0.0, 1.0 / 30.0),
    (0.117_472_338_035_267_74, 0.189_237_478_148_923_55),
    (0.357_384_241_759_677_2, 0.277_429_188_517_743_1),
    (0.642_615_758_240_322_6, 0.277_429_188_517_743_1),
    (0.882_527_661_964_732_4, 0.189_237_478_148_923_55),
    (1.0, 1.0 / 30.0),
];

impl Criterion {
    /// Calls `f(w, c)` at each point of the element, with weights `w` summing to 1 and `c`
    /// the point's value as a linear form of the section forces: `v = c · [N, M₁, M₂]`,
    /// so `∂v/∂u = Jᵀ c` with `J` their Jacobian.
    pub fn for_each_point(self, el: &ElementState, mut f: impl FnMut(f64, Vector3<f64>)) {
        self.for_each_point_and_rate(el, None, |w, c, _| f(w, c));
    }

    /// [`Criterion::for_each_point`] with `f(w, c, ∂c/∂p)`, the section changing at `rate`
    /// ([`Section::rate`]; zero without one). Each coefficient is a power product of `A`,
    /// `EA`, `EI` and `c`, so its rate is itself times a sum of logarithmic rates; the
    /// relaxation and the bar's length do not move.
    pub fn for_each_point_and_rate(
        self,
        el: &ElementState,
        rate: Option<&Section>,
        mut f: impl FnMut(f64, Vector3<f64>, Vector3<f64>),
    ) {
        let section = el.element.kernel.section();
        // `∂ ln(value)/∂p` of a section quantity, read from the same field of `rate`.
        let log = |value: f64, field: fn(&Section) -> f64| rate.map_or(0.0, |r| field(r) / value);
        let area = log(section.area, |s| s.area);
        match self {
            Self::Stress => {
                // The response's parser guarantees the fibre distance.
                let per_m = section.fibre_per_moment().unwrap_or(0.0);
                let fibre = section.fibre.unwrap_or(f64::INFINITY);
                let d_per_m = per_m
                    * (log(fibre, |s| s.fibre.unwrap_or(0.0)) + log(section.ea, |s| s.ea)
                        - area
                        - log(section.ei, |s| s.ei));
                let axial = el.relax / section.area;
                for side in [1.0, -1.0] {
                    for &(s, w) in &LOBATTO {
                        let at = |per_m: f64, axial: f64| {
                            let bending = el.relax * side * per_m;
                            Vector3::new(axial, -bending * (1.0 - s), bending * s)
                        };
                        f(0.5 * w, at(per_m, axial), at(d_per_m, -axial * area));
                    }
                }
            }
            Self::Shear => {
                // V = −(M₁ + M₂)/L; the parser guarantees the factor.
                let k = section.shear_factor.unwrap_or(0.0);
                let per_m = -el.relax * k / (el.element.kernel.length() * section.area);
                let c = Vector3::new(0.0, per_m, per_m);
                f(1.0, c, -c * area);
            }
            Self::Buckling => {
                let per_n = if el.forces[0] < 0.0 {
                    -el.relax * el.bar_length.powi(2) / (PI * PI * section.ei)
                } else {
                    0.0
                };
                let c = Vector3::new(per_n, 0.0, 0.0);
                f(1.0, c, -c * log(section.ei, |s| s.ei));
            }
        }
    }

    /// The largest point value `|v|` of the element (for stresses, at an end, which is a
    /// point of the rule).
    pub fn peak(self, el: &ElementState) -> f64 {
        let mut peak = 0.0_f64;
        self.for_each_point(el, |_, c| peak = peak.max(c.dot(&el.forces).abs()));
        peak
    }
}

#[cfg(test)]
mod tests {
    use super::LOBATTO;

    #[test]
    fn lobatto_rule_integrates_degree_nine_exactly() {
        for k in 0..=9 {
            let sum: f64 = LOBATTO.iter().map(|&(s, w)| w * s.powi(k)).sum();
            assert!((sum - 1.0 / f64::from(k + 1)).abs() < 1e-15, "degree {k}");
        }
    }
}
