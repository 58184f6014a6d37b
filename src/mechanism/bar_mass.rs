//! The coupling of a bar's end nodes that `mass = "bar_lumped"` adds to its lumped mass.
//!
//! Lumped on the nodes of a bar of `m` elements, a bar of mass `m_b = ρA L` carries the
//! exact kinetic energy of a translation, but in a rigid rotation `ω` about its middle it
//! carries `½ (m_b L²/12)(1 + 2/m²) ω²`, too much by `m_b L² ω²/(12 m²)` (three times the
//! exact value on one element). Coupling its end nodes `a`, `b` by
//!
//! ```text
//! T_c = −½ c |q̇_b − q̇_a|²,   c = m_b / (6 m²)
//! ```
//!
//! removes that excess, and as exactly in a uniform stretch; a translation is untouched.
//! On one element the lumped mass plus the coupling is the consistent mass of linear
//! interpolation in translation (rotary inertia stays lumped). On a split bar the interior
//! stays lumped, whose bending modes converge at fourth order with the beams' exact static
//! stiffness (a clamped bar's first frequency against 256 elements: 3.3e-3, 1.4e-4,
//! 1.2e-5 at 4, 8, 16 elements) where the consistent mass of linear interpolation
//! converges at second order (5.4e-2, 1.5e-2, 3.9e-3; `benches/bar_mass.py`): the bars
//! whose own modes fall in a motion's band need several times fewer elements. The matrix
//! is constant (it acts on translations only, the same in every direction), so the
//! integrator and the sensitivities keep their form; `c` scales with the bar's mass law
//! like the rest of its mass.

use nalgebra::Matrix4;

use crate::mechanism::section::Section;

/// The coupling of one bar's end nodes (module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BarMass {
    /// The bar's end nodes `a` (of its first element) and `b` (of its last).
    pub nodes: [usize; 2],
    /// Its first element: the bar's density is read there.
    pub element: usize,
    /// `c = ρA L / (6 m²)` at full density (kg).
    pub coupling: f64,
    /// `c` per unit of `ρA` (m), for the rate of a section's change.
    per_rho_a: f64,
}

impl BarMass {
    /// The coupling of a bar from end node `a` to `b` of `m` elements, the first at index
    /// `element`, of total `length` (m) and mass per length `rho_a` (kg/m) at full density.
    pub fn new(nodes: [usize; 2], element: usize, m: usize, length: f64, rho_a: f64) -> Self {
        let per_rho_a = length / (6.0 * (m * m) as f64);
        Self {
            nodes,
            element,
            coupling: rho_a * per_rho_a,
            per_rho_a,
        }
    }

    /// Its DOFs: the translations `[x_a, y_a, x_b, y_b]`.
    pub fn dofs(&self) -> [usize; 4] {
        let [a, b] = self.nodes;
        [3 * a, 3 * a + 1, 3 * b, 3 * b + 1]
    }

    /// Its mass matrix at full density, `c [−I, I; I, −I]` on [`BarMass::dofs`].
    pub fn matrix(&self) -> Matrix4<f64> {
        Self::shape() * self.coupling
    }

    /// `∂M_c/∂p` for the section changing at `rate`.
    pub fn matrix_rate(&self, rate: &Section) -> Matrix4<f64> {
        Self::shape() * (rate.rho_a * self.per_rho_a)
    }

    /// `M_c v` at full density, on [`BarMass::dofs`], of the global vector `v`.
    pub fn times(&self, v: &[f64]) -> [f64; 4] {
        let d = self.dofs();
        let relative = [v[d[2]] - v[d[0]], v[d[3]] - v[d[1]]];
        let c = self.coupling;
        [
            c * relative[0],
            c * relative[1],
            -c * relative[0],
            -c * relative[1],
        ]
    }

    /// `[−I, I; I, −I]`.
    fn shape() -> Matrix4<f64> {
        Matrix4::new(
            -1.0, 0.0, 1.0, 0.0, //
            0.0, -1.0, 0.0, 1.0, //
            1.0, 0.0, -1.0, 0.0, //
            0.0, 1.0, 0.0, -1.0,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::element::{Kind, MassKind};
    use nalgebra::Vector2;

    /// On one element, the lumped mass plus the coupling is the consistent mass in the
    /// translations, and the coupling leaves a translation without force.
    #[test]
    fn one_element_is_consistent_in_translation_and_a_translation_is_free() {
        let section = Section::new(70e9, 26.5e9, 3.1e-4, 7.9e-9, 0.89, 2700.0);
        let beam = Kind::Frame.element(Vector2::new(0.0, 0.0), Vector2::new(0.6, 0.8), section);
        let coupling = BarMass {
            nodes: [0, 1],
            element: 0,
            coupling: section.rho_a * beam.length() / 6.0,
            per_rho_a: beam.length() / 6.0,
        };
        let (lumped, consistent) = (
            beam.mass_matrix(MassKind::BarLumped),
            beam.mass_matrix(MassKind::Consistent),
        );
        let c = coupling.matrix();
        let at = [0, 1, 3, 4];
        for (i, &r) in at.iter().enumerate() {
            for (j, &s) in at.iter().enumerate() {
                let sum = lumped[(r, s)] + c[(i, j)];
                assert!((sum - consistent[(r, s)]).abs() <= 1e-15 * consistent.amax());
            }
        }
        let v = [0.3, -0.2, 0.0, 0.3, -0.2, 0.0];
        assert!(coupling.times(&v).iter().all(|&f| f == 0.0));
    }
}
