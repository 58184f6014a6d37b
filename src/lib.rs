//! flextop: flexible multibody dynamics with exact design sensitivities, for topology
//! optimization of the structural parts of moving machines (Brüls, Lemaire, Duysinx &
//! Eberhard, *Optimization of multibody systems and their structural components*).
//!
//! The path from a scene to gradients, one module per concept:
//!
//! * [`scene`] — the scene as data (TOML or Python dict), validated into a [`model::Model`]:
//!   nodes with absolute coordinates, co-rotational Timoshenko [`element::beam`]s grouped in
//!   bars with one density each ([`interpolation`]: SIMP or RAMP), point masses, [`load`]s,
//!   and joints as algebraic [`constraint`]s driven by [`motion`] laws; [`rigid`] checks the
//!   mechanism and gives its rigid trajectory.
//! * [`assembly`] and [`linsolve`] — the residual and the iteration matrix on a fixed sparse
//!   pattern, factorized by a symbolic-once, numeric-per-iteration `LDLᵀ`.
//! * [`newton`], [`integrator`] (generalized-α, Algorithm 1), [`statics`] and
//!   [`simulation`] — the solves, with run settings from [`options`].
//! * [`response`] and [`sensitivity`] — responses of paper Eq. 8 and their exact gradients,
//!   by direct differentiation (Algorithm 2) or the discrete adjoint.
//!
//! SI units throughout: m, kg, s, N, Pa, rad. Errors are values ([`error`]), never panics on
//! user data. The Python bindings live behind the `python` feature.
#![warn(missing_docs)]

pub mod assembly;
pub mod constraint;
pub mod element;
pub mod error;
pub mod integrator;
pub mod interpolation;
pub mod linsolve;
pub mod load;
pub mod model;
pub mod motion;
pub mod newton;
pub mod options;
pub mod response;
pub mod rigid;
pub mod scene;
pub mod section;
pub mod sensitivity;
pub mod simulation;
pub mod statics;

#[cfg(feature = "python")]
mod python;
