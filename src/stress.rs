//! What breaks a bar, read at points of its elements: fibre stresses and Euler buckling
//! ratios, each with its derivative with respect to the element's DOFs.
//!
//! Both use the full-density section forces `[N, M₁, M₂]` of the co-rotational beam, so
//! they are the solid material's values: under SIMP a bar of density `x` carries `s(x) N`
//! with section `s(x) EA`, and the stress `s N / (s A)` does not depend on `s`. A relaxation
//! factor `x^q` multiplies them (Le et al. 2010: `q = ½`), so that vanishing bars, whose
//! strains stay finite, do not make a stress limit singular.
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

use crate::element::Vector6;
use crate::model::Element;

/// What an aggregate measures at its points.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Measure {
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
    /// The global state.
    pub q: &'a [f64],
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

impl Measure {
    /// Calls `f(w, v, ∂v/∂u)` at each point of the element, with weights `w` summing to 1.
    pub fn for_each_point(self, el: &ElementState, mut f: impl FnMut(f64, f64, &Vector6)) {
        match self {
            Self::Stress => {
                let fibre = FibreStress::of(el);
                for side in [1.0, -1.0] {
                    for &(s, w) in &LOBATTO {
                        let (sigma, d) = fibre.at(s, side);
                        f(0.5 * w, sigma, &d);
                    }
                }
            }
            Self::Shear => {
                let (tau, d) = shear(el);
                f(1.0, tau, &d);
            }
            Self::Buckling => {
                let (b, d) = buckling(el);
                f(1.0, b, &d);
            }
        }
    }

    /// The largest point value `|v|` of the element.
    pub fn peak(self, el: &ElementState) -> f64 {
        match self {
            Self::Stress => FibreStress::of(el).peak(),
            Self::Shear => shear(el).0.abs(),
            Self::Buckling => buckling(el).0,
        }
    }
}

/// The fibre stresses of an element, relaxed: the axial part `a = x^q N/A` and the bending
/// parts `b₁ = −x^q M₁ c/I`, `b₂ = x^q M₂ c/I` at its ends, with their derivatives.
struct FibreStress {
    axial: (f64, Vector6),
    bending: [(f64, Vector6); 2],
}

impl FibreStress {
    fn of(el: &ElementState) -> Self {
        let beam = &el.element.beam;
        let (forces, jacobian) = beam.section_forces_and_jacobian(&el.element.gather(el.q));
        // Per unit N and M; the response's parser guarantees the fibre distance.
        let (per_n, per_m) = beam.section.fibre_stress(1.0, 1.0).unwrap_or((0.0, 0.0));
        let part = |row: usize, factor: f64| {
            let f = el.relax * factor;
            (f * forces[row], jacobian.row(row).transpose() * f)
        };
        Self {
            axial: part(0, per_n),
            bending: [part(1, -per_m), part(2, per_m)],
        }
    }

    /// `σ = a ± ((1 − s) b₁ + s b₂)` and `∂σ/∂u` at `s ∈ [0, 1]` on fibre `side = ±1`.
    fn at(&self, s: f64, side: f64) -> (f64, Vector6) {
        let ([b1, b2], a) = (&self.bending, &self.axial);
        let (l1, l2) = (side * (1.0 - s), side * s);
        (a.0 + l1 * b1.0 + l2 * b2.0, a.1 + b1.1 * l1 + b2.1 * l2)
    }

    /// The largest `|σ|`: at an end, on the fibre where bending adds to the axial part.
    fn peak(&self) -> f64 {
        self.axial.0.abs() + self.bending[0].0.abs().max(self.bending[1].0.abs())
    }
}

/// `τ = −x^q k (M₁ + M₂)/(L A)` and `∂τ/∂u`.
fn shear(el: &ElementState) -> (f64, Vector6) {
    let beam = &el.element.beam;
    let (forces, jacobian) = beam.section_forces_and_jacobian(&el.element.gather(el.q));
    // The response's parser guarantees the factor.
    let k = beam.section.shear_factor.unwrap_or(0.0);
    let per_m = -el.relax * k / (beam.length * beam.section.area);
    (
        per_m * (forces[1] + forces[2]),
        (jacobian.row(1) + jacobian.row(2)).transpose() * per_m,
    )
}

/// `b = x^q max(−N, 0) L²/(π² EI)` and `∂b/∂u` (zero in tension).
fn buckling(el: &ElementState) -> (f64, Vector6) {
    let beam = &el.element.beam;
    let (forces, jacobian) = beam.section_forces_and_jacobian(&el.element.gather(el.q));
    if forces[0] >= 0.0 {
        return (0.0, Vector6::zeros());
    }
    let per_n = -el.relax * el.bar_length.powi(2) / (PI * PI * beam.section.ei);
    (per_n * forces[0], jacobian.row(0).transpose() * per_n)
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
