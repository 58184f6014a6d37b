//! **The spatial wing**: mechanisms in space on the Lie group `(ℝ³ × SO(3))ⁿ` of
//! [`crate::group`]. Rigid bodies with a full inertia tensor ([`body`], in the bodies' room
//! [`crate::body`]), geometrically exact
//! beams and truss bars between nodes ([`beam`], [`truss`], their sections in [`section`],
//! one `Element` interface for both), joints and drives as
//! index-3 constraints with their constraint-force stiffness ([`joint`], in the joints' room
//! [`crate::joint`]), the mechanism built
//! entry by entry and checked ([`model`]), its residual and non-symmetric iteration matrix on
//! a fixed pattern (`assembly`), and generalized-α on the group ([`integrator`]), solved on
//! the `LDLᵀ` of its symmetric part with refinement, sparse `LU` where that stalls.
//!
//! Built so far: rigid bodies, beams, truss bars, the joints (spherical, revolute, universal,
//! cylindrical, prismatic, weld), drives, force elements (springs, motors, loads,
//! [`force`]), static equilibria ([`statics`]), natural modes about them ([`modal`]) with their rates
//! to the parameters ([`modal_rates`]) and
//! the exact gradients of the motion and of equilibria ([`sensitivity`]) to bodies', force
//! elements', beams' and bars' parameters; scenes in [`crate::scene::spatial`], the
//! Python front in `flextop.spatial`.
//!
//! The heavy top of Brüls, Cardona & Arnold: a body pinned at a point off its centre of mass,
//! spinning under gravity.
//!
//! ```
//! use flextop::group::Frame;
//! use flextop::spatial::integrator::simulate_spatial;
//! use flextop::spatial::joint::{Anchor, JointKind};
//! use flextop::spatial::model::SpatialModel;
//! use flextop::{DynamicSettings, MassKind, NewtonMatrix, TimeGrid};
//! use nalgebra::{Matrix3, UnitQuaternion, Vector3};
//!
//! # fn main() -> Result<(), flextop::Error> {
//! let mut m = SpatialModel::new(Vector3::new(0.0, 0.0, -9.81))?;
//! let arm = Vector3::new(0.0, 1.0, 0.0);
//! let inertia = Matrix3::from_diagonal(&Vector3::new(0.25, 0.46875, 0.25));
//! let top = m.add_body("top", Frame::new(arm, UnitQuaternion::identity()), 15.0, inertia)?;
//! let pivot = Anchor::Body { body: top, point: -arm };
//! m.add_joint("pivot", JointKind::Spherical, pivot, Anchor::Ground(Vector3::zeros()))?;
//! let spin = Vector3::new(0.0, 150.0, -4.6);
//! m.set_rates(top, spin.cross(&arm), spin)?;
//! let settings = DynamicSettings {
//!     t_end: 1.0,
//!     h: 1e-3,
//!     rho_inf: 0.9,
//!     tol: 1e-10,
//!     max_iter: 20,
//!     newton: NewtonMatrix::Full,
//!     mass: MassKind::Consistent,
//! };
//! let states = simulate_spatial(&m, &settings, &TimeGrid::uniform(1e-3, 1000))?;
//! // The pivot holds: the centre of mass stays at 1 m from it.
//! let centre = Frame::read(&states[1000].q, 0).x;
//! assert!((centre.norm() - 1.0).abs() < 1e-9);
//! # Ok(())
//! # }
//! ```

pub mod beam;
pub mod force;
pub mod integrator;
pub mod modal;
pub mod modal_rates;
pub mod model;
pub mod rigid;
pub mod section;
pub mod sensitivity;
pub mod statics;
pub mod truss;

/// The spatial bodies, in the bodies' room ([`crate::body::spatial`]).
pub use crate::body::spatial as body;
/// The spatial joints, in the joints' room ([`crate::joint::spatial`]).
pub use crate::joint::spatial as joint;

pub(crate) mod assembly;
pub(crate) mod element;

pub(crate) mod stress;
