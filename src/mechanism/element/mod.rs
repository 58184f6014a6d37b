//! Finite elements of the flexible bodies, behind one interface ([`Kernel`]).
//!
//! Two kinds, both two-node and co-rotational on the DOFs `u = [u₁, v₁, φ₁, u₂, v₂, φ₂]`
//! (nodal displacements and rotations from the reference configuration):
//!
//! * the Timoshenko [`beam`] of a frame (axial force and end moments, exact static
//!   stiffness);
//! * the pin-jointed [`truss`] bar (axial force only; its rows and columns on `φ₁, φ₂`
//!   are zero, and a node that only truss bars meet has no rotation among the unknowns:
//!   [`crate::mechanism::model::Model::absent_rotations`]).
//!
//! Assembly, mass, damping, prolongation, stresses, parameter rates and the responses read
//! an element only through [`Kernel`]; [`Formulation`] holds either kind and dereferences
//! to it. Point masses are attached to nodes by the [`crate::mechanism::model::Model`].
//!
//! A continuum member's plane-stress quadrilateral ([`quad`]) is the other family: four
//! nodes, their translations only, a material and thickness instead of a section. It is
//! not a [`Kernel`] (no chord, section forces or criteria); assembly, the pseudo-loads, the
//! responses and the modes read its force, tangent, energy and mass beside the bars'.

pub mod beam;
pub mod enhanced;
pub mod quad;
pub mod truss;
pub mod void;

use std::ops::Deref;

use nalgebra::{SMatrix, Vector2, Vector3};

pub use crate::settings::MassKind;
pub use beam::{Beam, Damping, Matrix6, Vector6};
pub use truss::Truss;

use crate::mechanism::section::Section;

/// A two-node element at full density: what the solvers, the sensitivities and the
/// responses ask of it. Every quantity is at full density; the design scales stiffness by
/// `s(x)` and mass by `m(x)` outside (paper Eq. 33–34). `rate` is a section changing with
/// a scene parameter ([`Section::rate`]).
pub trait Kernel: std::fmt::Debug + Send + Sync {
    /// Reference length `L₀` (m).
    fn length(&self) -> f64;
    /// Section at full density.
    fn section(&self) -> &Section;
    /// Whether it acts on its nodes' rotations (a beam does, a truss bar does not).
    fn turns_nodes(&self) -> bool;
    /// Internal force `f(u)`.
    fn internal_force(&self, u: &Vector6) -> Vector6;
    /// Internal force `f(u)` and its exact tangent `K = ∂f/∂u`.
    fn internal_force_and_tangent(&self, u: &Vector6) -> (Vector6, Matrix6);
    /// Strain energy `U(u)` (J), paper Eq. 37; zero in any rigid motion.
    fn strain_energy(&self, u: &Vector6) -> f64;
    /// Section forces `[N, M₁, M₂]`: axial force (N, tension positive) and end moments of
    /// the chord frame (N m; zero on a truss bar).
    fn section_forces(&self, u: &Vector6) -> Vector3<f64>;
    /// Section forces and their Jacobian `∂[N, M₁, M₂]/∂u`.
    fn section_forces_and_jacobian(&self, u: &Vector6) -> (Vector3<f64>, SMatrix<f64, 3, 6>);
    /// Section forces and their rate to the section's change `rate`.
    fn section_forces_and_rate(&self, u: &Vector6, rate: &Section) -> (Vector3<f64>, Vector3<f64>);
    /// `∂f/∂p` for the section changing at `rate`.
    fn internal_force_rate(&self, u: &Vector6, rate: &Section) -> Vector6;
    /// `∂U/∂p` for the section changing at `rate`.
    fn strain_energy_rate(&self, u: &Vector6, rate: &Section) -> f64;
    /// Constant mass matrix.
    fn mass_matrix(&self, kind: MassKind) -> Matrix6;
    /// `∂M/∂p`: the mass matrix is linear in the section's `ρA` and `ρI`.
    fn mass_matrix_rate(&self, kind: MassKind, rate: &Section) -> Matrix6 {
        self.with_section(*rate).mass_matrix(kind)
    }
    /// The element with another section (same chord).
    fn with_section(&self, section: Section) -> Formulation;
    /// The stiffness-proportional (Kelvin–Voigt) damping at displacements `u` and
    /// velocities `v`, for `β` of the section: force and derivatives ([`Damping`]).
    fn damping(&self, u: &Vector6, v: &Vector6) -> Damping;
    /// `∂f_d/∂p` for `β` changing at `beta_rate` and the section at `rate`.
    fn damping_force_rate(
        &self,
        u: &Vector6,
        v: &Vector6,
        beta_rate: f64,
        rate: &Section,
    ) -> Vector6;
    /// `(u, v, φ)` at the element's middle: the guess for a node that splits it in two
    /// ([`crate::Prolongation`]).
    fn middle(&self, u: &Vector6) -> [f64; 3];
}

/// An element of either kind, read through [`Kernel`] (`element.kernel.mass_matrix(…)`).
#[derive(Debug, Clone, PartialEq)]
pub enum Formulation {
    /// A frame's Timoshenko beam.
    Beam(Beam),
    /// A pin-jointed truss bar.
    Truss(Truss),
}

impl Deref for Formulation {
    type Target = dyn Kernel;

    fn deref(&self) -> &Self::Target {
        match self {
            Self::Beam(beam) => beam,
            Self::Truss(truss) => truss,
        }
    }
}

/// The kind of the elements of a bar, as a scene names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Kind {
    /// Timoshenko beams, rigidly joined at nodes.
    #[default]
    Frame,
    /// One pin-jointed truss bar.
    Truss,
}

impl Kind {
    /// The element of this kind between reference positions `x1`, `x2`.
    pub fn element(self, x1: Vector2<f64>, x2: Vector2<f64>, section: Section) -> Formulation {
        match self {
            Self::Frame => Formulation::Beam(Beam::new(x1, x2, section)),
            Self::Truss => Formulation::Truss(Truss::new(x1, x2, section)),
        }
    }

    /// The kind's name in a scene.
    pub fn name(self) -> &'static str {
        match self {
            Self::Frame => "frame",
            Self::Truss => "truss",
        }
    }
}

/// The chord of a deformed two-node element: what both kinds measure in its co-rotated
/// frame.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Chord {
    /// Current chord `d = d₀ + (u₂ − u₁, v₂ − v₁)`.
    pub(crate) d: Vector2<f64>,
    /// Current length `l = |d|`.
    pub(crate) l: f64,
    /// Stretch `e = l − L₀`.
    pub(crate) stretch: f64,
    /// `∂l/∂u = [−c, −s, 0, c, s, 0]`.
    pub(crate) r: Vector6,
    /// `l ∂α/∂u = [s, −c, 0, −s, c, 0]`, `α` the chord's rotation.
    pub(crate) t: Vector6,
}

impl Chord {
    /// The chord of an element of reference chord `chord` (length `length`) at `u`.
    pub(crate) fn of(chord: &Vector2<f64>, length: f64, u: &Vector6) -> Self {
        let du = Vector2::new(u[3] - u[0], u[4] - u[1]);
        let d = chord + du;
        let l = d.norm();
        let (c, s) = (d.x / l, d.y / l);
        // l − L₀ without cancellation: (l² − L₀²)/(l + L₀), l² − L₀² = 2 d₀·Δu + |Δu|².
        let stretch = (2.0 * chord.dot(&du) + du.norm_squared()) / (l + length);
        Self {
            d,
            l,
            stretch,
            r: Vector6::from([-c, -s, 0.0, c, s, 0.0]),
            t: Vector6::from([s, -c, 0.0, -s, c, 0.0]),
        }
    }
}
