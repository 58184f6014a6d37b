//! The mechanism's elements linearized about the reference configuration, as the linear
//! static analysis ([`crate::solve_linear`]) and its sensitivities read them: each beam's,
//! truss bar's and cell's force `f_L(u) = f₀ + K₀ u` and energy `Ψ_L(u) = f₀ᵀu + ½ uᵀK₀u`,
//! `f₀` and `K₀` the element's force and tangent at no displacement at full density, scaled
//! by `s(x)` as the nonlinear element is (paper Eq. 34). A cell is unstrained at the
//! reference (`f₀ = 0`) and its `K₀` is the small-strain stiffness it keeps; its energy
//! blended for a void cell (`element/void.rs`) has that `K₀` at every blend `γ`
//! (`γ²K₀ − γ²K₀ + K₀`), so the linear analysis does not read the blend.

use crate::mechanism::element::quad::{Matrix8, Vector8};
use crate::mechanism::element::{Matrix6, Vector6};
use crate::mechanism::model::Model;

/// The reference force and tangent of every element of a model (its cells read theirs).
#[derive(Debug, Clone)]
pub struct Linearized {
    /// `(f₀, K₀)` of each element, at full density.
    elements: Vec<(Vector6, Matrix6)>,
}

impl Linearized {
    /// The elements of `model` at no displacement.
    pub fn new(model: &Model) -> Self {
        let elements = model
            .elements
            .iter()
            .map(|e| e.kernel.internal_force_and_tangent(&Vector6::zeros()))
            .collect();
        Self { elements }
    }

    /// `f₀ + K₀ u` of element `e` at its displacements `u`, at full density.
    pub fn element_force(&self, e: usize, u: &Vector6) -> Vector6 {
        let (f0, k0) = &self.elements[e];
        f0 + k0 * u
    }

    /// `f₀ᵀu + ½ uᵀK₀u` of element `e`, at full density.
    pub fn element_energy(&self, e: usize, u: &Vector6) -> f64 {
        let (f0, k0) = &self.elements[e];
        f0.dot(u) + 0.5 * u.dot(&(k0 * u))
    }

    /// `K₀ u` of a cell of small-strain stiffness `k0`, at full density.
    pub fn cell_force(k0: &Matrix8, u: &Vector8) -> Vector8 {
        k0 * u
    }

    /// `½ uᵀK₀u` of a cell of small-strain stiffness `k0`, at full density.
    pub fn cell_energy(k0: &Matrix8, u: &Vector8) -> f64 {
        0.5 * u.dot(&(k0 * u))
    }
}
