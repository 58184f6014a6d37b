//! flextop: flexible multibody dynamics with exact design sensitivities, for topology
//! optimization of the structural parts of moving machines (Brüls, Lemaire, Duysinx &
//! Eberhard, *Optimization of multibody systems and their structural components*).
//!
//! The path from a scene to gradients, in wings (folders), each behind the re-exports
//! below:
//!
//! * [`scene`] — the scene as data (TOML or Python dict), validated into a [`model::Model`].
//! * `mechanism` — what a scene builds: nodes with absolute coordinates, co-rotational
//!   Timoshenko [`element::beam`]s grouped in bars with one density each
//!   ([`interpolation`]: SIMP or RAMP), point masses, [`load`]s, [`spring`]s, [`motor`]s,
//!   scene [`parameter`]s;
//!   its rigid clusters check the mechanism and give its rigid trajectory.
//! * `solver` — the residual and the iteration matrix on a fixed sparse pattern,
//!   factorized by a symbolic-once, numeric-per-iteration `LDLᵀ`; Newton, [`Integrator`]
//!   (generalized-α, Algorithm 1, on any [`TimeGrid`]), [`solve_static`] and [`simulate`],
//!   with run settings validated in one place ([`RunOptions`], [`DynamicSettings`],
//!   [`StaticSettings`]).
//! * `modal` — [`natural_modes`] by shift-invert Lanczos with a Sturm count, on a pencil the
//!   spatial engine's lowest modes share.
//! * `response` — [`Response`]s of paper Eq. 8, one file per family; stresses and buckling
//!   ratios ([`Criterion`]) condensed by the p-mean or KS mean of [`Aggregation`].
//! * `sensitivity` — [`of_motion`] / [`of_equilibrium`]: their exact gradients, by direct
//!   differentiation (Algorithm 2) or the discrete adjoint.
//! * [`body`] — the rigid bodies and point masses of both dimensions.
//! * [`joint`] — the joints of both dimensions as algebraic constraints (planar rows,
//!   the Lie group's spatial ones) and the [`motion`] laws that drive them.
//! * [`spatial`] on [`group`] — spatial mechanisms on the Lie group `(ℝ³ × SO(3))ⁿ`: rigid
//!   bodies, joints, drives, force elements, Lie-group generalized-α, statics and the exact
//!   gradients of the motion (the first part of the spatial engine; Rust only for now).
//!
//! The mechanism's data ([`scene`], [`model`], [`element`], [`constraint`], [`motion`],
//! [`load`], [`section`], [`interpolation`], [`spring`], [`motor`], [`parameter`]) are
//! public modules; the solvers are private behind the re-exports. Assembly, Newton and the
//! linear solver are internals. Errors, limits, interrupts, settings and the time grid sit
//! at the top, shared by every wing.
//!
//! SI units throughout: m, kg, s, N, Pa, rad. Errors are values ([`error`]), never panics on
//! user data. The Python bindings live behind the `python` feature.
#![warn(missing_docs)]

// The wings, each a folder behind the re-exports below.
pub mod body;
pub mod group;
pub mod joint;
mod mechanism;
mod modal;
mod response;
mod sensitivity;
mod solver;
pub mod spatial;

// Shared by every wing.
pub mod error;
mod interrupt;
mod limits;
mod settings;
mod time_grid;

pub mod scene;

#[doc(hidden)]
pub mod bench_support;

#[cfg(feature = "python")]
mod python;

pub use error::{DesignError, Error, SceneError, SettingsError, SolveError};
pub use interrupt::{poll, with_checker};
pub use joint::{motion, planar as constraint};
pub use limits::{MAX_ELEMENTS, MAX_GRID_NODES, MAX_LOAD_STEPS, MAX_NODES, MAX_SPLIT};
pub use mechanism::element::MassKind;
pub use mechanism::model::{Densities, Model};
pub use mechanism::rigid::rigid_positions;
pub use mechanism::{element, interpolation, load, model, motor, parameter, section, spring};
pub use modal::{natural_modes, Modes};
pub use response::aggregation::Aggregation;
pub use response::criterion::Criterion;
pub use response::{Kind as ResponseKind, Response};
pub use sensitivity::adjoint::{time_errors, Path};
pub use sensitivity::shares::{bar_shares, Shares};
pub use sensitivity::{
    evaluate, of_equilibrium, of_linear_equilibrium, of_motion, of_motion_about, of_motion_on,
    parse_parameters, parse_responses, Evaluated, Recorded, Sensitivities, Timings,
};
pub use settings::{
    DynamicSettings, Memory, Method, NewtonMatrix, RunOptions, SensitivitySettings, StaticAnalysis,
    StaticSettings, MAX_STEPS,
};
pub use solver::alpha::{AlphaParameters, State};
pub use solver::assembly::{linearize, Csc, Linearization};
pub use solver::integrator::Integrator;
pub use solver::linear::LARGE_DISPLACEMENT;
pub use solver::prolongation::Prolongation;
pub use solver::simulation::{
    simulate, simulate_adaptive, simulate_guided, simulate_on, Trajectory, MAX_TRAJECTORY_BYTES,
};
pub use solver::statics::{solve_linear, solve_static, StaticSolution};
pub use solver::step_control::StepControl;
pub use time_grid::TimeGrid;

#[cfg(test)]
mod tests;
