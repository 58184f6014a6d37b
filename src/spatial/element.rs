//! What the assembly reads of a structural element between two nodes — a beam
//! ([`crate::spatial::beam`]) or a truss bar ([`crate::spatial::truss`]): its forces and their
//! derivatives at a state, its mass, its strain energy.

use nalgebra::{Matrix3, Vector3};

use crate::group::pair::{Pair, Stiffness};
use crate::group::{six, NV};
use crate::spatial::force::Local;
use crate::spatial::section::MAX_FIBRES;

/// An element's forces at one state, on its twelve local unknowns.
pub(crate) struct Terms {
    /// Elastic and Kelvin–Voigt forces.
    pub internal: Local,
    /// Inertia, weight and `α M v`.
    pub inertia: Local,
}

/// An element's force derivatives at one state, on its twelve local unknowns: what the
/// iteration matrix and the sensitivities read (written in place, where the assembly keeps
/// them).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Derivatives {
    /// `∂f/∂q` (right-trivialized).
    pub stiffness: Stiffness,
    /// `∂f/∂v` but for the mass: Kelvin–Voigt's, `α M` and the gyroscopic matrix.
    pub damping: Stiffness,
}

impl Derivatives {
    pub(crate) fn zeros() -> Self {
        Self {
            stiffness: Stiffness::zeros(),
            damping: Stiffness::zeros(),
        }
    }
}

/// A structural element between two nodes.
pub(crate) trait Element {
    /// Its two nodes, as a pair with no arms.
    fn pair(&self) -> &Pair;

    /// Its forces at `(q, v, v̇)` (`None`: at rest) under gravity `g`; their derivatives
    /// written into `tangent` where given.
    fn terms(
        &self,
        q: &[f64],
        v: &[f64],
        vdot: Option<&[f64]>,
        g: &Vector3<f64>,
        tangent: Option<&mut Derivatives>,
    ) -> Terms;

    /// Its mass matrix on the twelve local unknowns (constant).
    fn mass_matrix(&self) -> Stiffness;

    /// Its mass (kg).
    fn mass(&self) -> f64;

    /// Its strain energy at `q` (J).
    fn strain_energy(&self, q: &[f64]) -> f64;

    /// The strain energy's derivative in the nodes' algebra at `q`: the elastic forces.
    fn elastic_force(&self, q: &[f64]) -> Local;

    /// Its length at the start (m).
    fn length(&self) -> f64;

    /// The density its design variable gives it (1 where none does): what a stress
    /// criterion's relaxation `x^q` reads ([`crate::spatial::stress`]).
    fn density(&self) -> f64;

    /// The solid material's stresses at its fibres at `q` (Pa) — a beam's von Mises
    /// stresses, a bar's axial stress — into `out`; how many there are.
    fn stresses(&self, q: &[f64], out: &mut [f64; MAX_FIBRES]) -> usize;

    /// `Σ_k w_k ∂σ_k/∂q` in the nodes' algebra at `q`, a weight `w_k` per fibre.
    fn stress_gradient(&self, q: &[f64], weights: &[f64]) -> Local;

    /// Its buckling ratio at `q`, the compression over the Euler load `π² E I_min / L_b²`
    /// of its bar pin-ended, of the solid section (`L_b` the bar's length, `I_min` its
    /// section's smaller second moment; a bar clamped at its ends is stronger, so this is the
    /// safe side): `max(−ε, 0)/ε_E`, `ε` its axial strain and `ε_E = π² I_min/(A L_b²)`. With
    /// its derivative in the nodes' algebra (zero in tension).
    fn buckling(&self, q: &[f64]) -> (f64, Local);

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

    /// Adds its shares of the nodes' momenta `M v`, scaled by `w`, to `out` (six per node).
    fn add_momenta(&self, v: &[f64], w: f64, out: &mut [f64]) {
        let p = self.mass_matrix() * self.local(v);
        for (side, node) in self.nodes().into_iter().enumerate() {
            out[NV * node..NV * node + NV]
                .iter_mut()
                .zip(p.fixed_rows::<NV>(NV * side).iter())
                .for_each(|(o, x)| *o += w * x);
        }
    }
}

/// The translational mass of `mass` consistent with linear interpolation between the two
/// nodes, `m/6 [2I I; I 2I]` on their positions (rotations left zero).
pub(crate) fn consistent_mass(mass: f64) -> Stiffness {
    let mut out = Stiffness::zeros();
    for (r, c, w) in [(0, 0, 2.0), (0, 6, 1.0), (6, 0, 1.0), (6, 6, 2.0)] {
        out.fixed_view_mut::<3, 3>(r, c)
            .copy_from(&(Matrix3::identity() * (mass * w / 6.0)));
    }
    out
}

/// Checks an element's `K = ∂f/∂q` (right-trivialized) and `C = ∂f/∂v` against central
/// differences at `(q, v, v̇)` on nodes 0 and 1, to `tolerance` of their largest entries.
#[cfg(test)]
pub(crate) fn check_derivatives(
    element: &dyn Element,
    q: &[f64],
    v: &[f64],
    vdot: &[f64],
    tolerance: f64,
) {
    use crate::group::Frame;
    let g = Vector3::new(0.0, 0.0, -9.81);
    let force = |q: &[f64], v: &[f64]| {
        let t = element.terms(q, v, Some(vdot), &g, None);
        t.internal + t.inertia
    };
    let mut terms = Derivatives::zeros();
    element.terms(q, v, Some(vdot), &g, Some(&mut terms));
    let (k_max, c_max) = (terms.stiffness.amax(), terms.damping.amax());
    for k in 0..12 {
        let moved = |e: f64| {
            let mut inc = [0.0; 12];
            inc[k] = e;
            let mut p = q.to_vec();
            for node in 0..2 {
                Frame::read(q, node)
                    .retract(&inc[NV * node..NV * node + NV])
                    .write(&mut p, node);
            }
            force(&p, v)
        };
        let fd = (moved(1e-7) - moved(-1e-7)) / 2e-7;
        let err = (fd - terms.stiffness.column(k)).amax();
        assert!(
            err < tolerance * k_max,
            "K column {k}: {err:e} of {k_max:e}"
        );
        let rate = |e: f64| {
            let mut w = v.to_vec();
            w[k] += e;
            force(q, &w)
        };
        let fd = (rate(1e-4) - rate(-1e-4)) / 2e-4;
        let err = (fd - terms.damping.column(k)).amax();
        assert!(err < 1e-7 * c_max, "C column {k}: {err:e} of {c_max:e}");
    }
}
