//! flextop: flexible multibody dynamics with exact design sensitivities, for topology
//! optimization of the structural parts of moving machines (Brüls, Lemaire, Duysinx &
//! Eberhard, *Optimization of multibody systems and their structural components*).
//!
//! The path from a scene to gradients, one module per concept:
//!
//! * [`scene`] — the scene as data (TOML or Python dict), validated into a [`model::Model`]:
//!   nodes with absolute coordinates, co-rotational Timoshenko [`element::beam`]s grouped in
//!   bars with one density each ([`interpolation`]: SIMP or RAMP), point masses, [`load`]s,
//!   and joints as algebraic [`constraint`]s driven by [`motion`] laws; `rigid` checks the
//!   mechanism and gives its rigid trajectory.
//! * `assembly` and `linsolve` — the residual and the iteration matrix on a fixed sparse
//!   pattern, factorized by a symbolic-once, numeric-per-iteration `LDLᵀ` (its factors
//!   stored dense where sparse ones would fill half the triangle).
//! * `newton`, [`Integrator`] (generalized-α, Algorithm 1, on any [`TimeGrid`]),
//!   [`solve_static`] and [`simulate`] — the solves, with run settings validated in one
//!   place ([`RunOptions`], [`DynamicSettings`], [`StaticSettings`]).
//! * [`Response`] and [`of_motion`] / [`of_equilibrium`] — responses of paper Eq. 8 and
//!   their exact gradients, by direct differentiation (Algorithm 2) or the discrete adjoint;
//!   stresses and buckling ratios ([`Criterion`]) condensed by the p-mean or KS mean of
//!   [`Aggregation`].
//!
//! The mechanism's data ([`scene`], [`model`], [`element`], [`constraint`], [`motion`],
//! [`load`], [`section`], [`interpolation`]) are public modules; the solvers are private
//! modules behind the re-exports below. Assembly, Newton and the linear solver are
//! internals.
//!
//! SI units throughout: m, kg, s, N, Pa, rad. Errors are values ([`error`]), never panics on
//! user data. The Python bindings live behind the `python` feature.
#![warn(missing_docs)]

pub mod constraint;
pub mod element;
pub mod error;
pub mod interpolation;
pub mod load;
pub mod model;
pub mod motion;
pub mod motor;
pub mod parameter;
pub mod scene;
pub mod section;
pub mod spring;

#[doc(hidden)]
pub mod bench_support;

mod aggregate;
mod assembly;
mod integrator;
mod interrupt;
mod lanczos;
mod limits;
mod linsolve;
mod modal;
mod newton;
mod prolongation;
mod response;
mod rigid;
mod sensitivity;
mod settings;
mod simulation;
mod statics;
mod step_control;
mod stress;
mod time_grid;

#[cfg(feature = "python")]
mod python;

pub use aggregate::Aggregation;
pub use assembly::{linearize, Csc, Linearization};
pub use element::MassKind;
pub use error::{DesignError, Error, SceneError, SettingsError, SolveError};
pub use integrator::{AlphaParameters, Integrator, State};
pub use interrupt::{poll, with_checker};
pub use limits::{MAX_ELEMENTS, MAX_GRID_NODES, MAX_LOAD_STEPS, MAX_NODES, MAX_SPLIT};
pub use modal::{natural_modes, Modes};
pub use model::{Densities, Model};
pub use prolongation::Prolongation;
pub use response::{Kind as ResponseKind, Response};
pub use rigid::rigid_positions;
pub use sensitivity::{
    evaluate, of_equilibrium, of_motion, of_motion_on, parse_parameters, parse_responses,
    Evaluated, Recorded, Sensitivities, Timings,
};
pub use settings::{
    DynamicSettings, Memory, Method, NewtonMatrix, RunOptions, SensitivitySettings, StaticSettings,
    MAX_STEPS,
};
pub use simulation::{
    simulate, simulate_adaptive, simulate_guided, simulate_on, Trajectory, MAX_TRAJECTORY_BYTES,
};
pub use statics::{solve_static, StaticSolution};
pub use step_control::StepControl;
pub use stress::Criterion;
pub use time_grid::TimeGrid;
