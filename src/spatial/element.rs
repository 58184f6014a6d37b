//! What the assembly reads of a structural element between two nodes — a beam
//! ([`crate::spatial::beam`]) or a truss bar ([`crate::spatial::truss`]): its forces and their
//! derivatives at a state, its mass, its strain energy.

use nalgebra::Vector3;

use crate::group::{six, NV};
use crate::spatial::force::Local;
use crate::spatial::pair::{Pair, Stiffness};

/// An element's terms at one state, on its twelve local unknowns.
pub(crate) struct Terms {
    /// Elastic and Kelvin–Voigt forces.
    pub internal: Local,
    /// Inertia, weight and `α M v`.
    pub inertia: Local,
    /// `∂f/∂q` (right-trivialized).
    pub stiffness: Stiffness,
    /// `∂f/∂v` but for the mass: Kelvin–Voigt's, `α M` and the gyroscopic matrix.
    pub damping: Stiffness,
}

/// A structural element between two nodes.
pub(crate) trait Element {
    /// Its two nodes, as a pair with no arms.
    fn pair(&self) -> &Pair;

    /// Its forces at `(q, v, v̇)` (`None`: at rest) under gravity `g`; their derivatives too
    /// where `tangent`, else zeros there.
    fn terms(
        &self,
        q: &[f64],
        v: &[f64],
        vdot: Option<&[f64]>,
        g: &Vector3<f64>,
        tangent: bool,
    ) -> Terms;

    /// Its mass matrix on the twelve local unknowns (constant).
    fn mass_matrix(&self) -> Stiffness;

    /// Its mass (kg).
    fn mass(&self) -> f64;

    /// Its strain energy at `q` (J).
    fn strain_energy(&self, q: &[f64]) -> f64;

    /// The strain energy's derivative in the nodes' algebra at `q`: the elastic forces.
    fn elastic_force(&self, q: &[f64]) -> Local;

    /// Its nodes.
    fn nodes(&self) -> [usize; 2] {
        self.pair()
            .nodes
            .map(|n| n.expect("an element's ends are nodes"))
    }

    /// Its twelve local numbers of a six-per-node vector.
    fn local(&self, x: &[f64]) -> Local {
        let mut out = Local::zeros();
        for (side, node) in self.nodes().into_iter().enumerate() {
            out.fixed_rows_mut::<NV>(NV * side)
                .copy_from_slice(&six(x, node));
        }
        out
    }

    /// Kinetic energy `½ vᵀ M v` at `v` (J).
    fn kinetic_energy(&self, v: &[f64]) -> f64 {
        let local = self.local(v);
        0.5 * local.dot(&(self.mass_matrix() * local))
    }

    /// Adds its shares of the nodes' momenta `M v` to `out` (six per node).
    fn add_momenta(&self, v: &[f64], out: &mut [f64]) {
        let p = self.mass_matrix() * self.local(v);
        for (side, node) in self.nodes().into_iter().enumerate() {
            out[NV * node..NV * node + NV]
                .iter_mut()
                .zip(p.fixed_rows::<NV>(NV * side).iter())
                .for_each(|(o, x)| *o += x);
        }
    }
}
