//! **The spatial wing**: mechanisms in space on the Lie group `(ℝ³ × SO(3))ⁿ` of
//! [`crate::group`]. Rigid bodies with a full inertia tensor ([`body`], in the bodies' room
//! [`crate::body`]), geometrically exact
//! beams and truss bars between nodes ([`beam`], [`truss`], their sections in [`section`],
//! one `Element` interface for both), joints and drives as
//! index-3 constraints with their constraint-force stiffness ([`joint`], in the joints' room
//! [`crate::joint`]), the mechanism built
//! entry by entry and checked ([`model`]), its residual and non-symmetric iteration matrix on
//! a fixed pattern (`assembly`), and generalized-α on the group ([`integrator`]), solved on
//! its `LU` by the nodes' and joints' blocks (`solver/block_lu.rs`).
//!
//! Built so far: rigid bodies, beams, truss bars, the joints (spherical, revolute, universal,
//! cylindrical, prismatic, weld), drives, force elements (springs, motors, loads,
//! [`force`]), static equilibria ([`statics`]), natural modes about them ([`modal`]) with their rates
//! to the parameters ([`modal_rates`]) and
//! the exact gradients of the motion and of equilibria ([`sensitivity`]) to bodies', force
//! elements', beams' and bars' parameters; scenes in [`crate::scene::spatial`], the
//! Python front in `flextop.spatial`.
//!
//! The heavy top of Brüls, Cardona & Arnold (a body pinned at a point off its centre of
//! mass, spinning under gravity) reads as a first example: `top_of` in
//! `src/tests/engine/spatial.rs` builds it entry by entry (`SpatialModel::new` with gravity,
//! `add_body` with its frame, mass and inertia, a spherical `add_joint` to the ground,
//! `set_rates`), `run` integrates it with `simulate_spatial`, and the tests beside them hold
//! it to its invariants, its order of convergence and its closed-form precession.

pub mod beam;
pub mod force;
pub mod integrator;
pub mod modal;
pub mod modal_rates;
pub mod model;
pub mod rigid;
pub mod section;
pub mod sensitivity;
pub mod shares;
pub mod statics;
pub mod truss;

/// The spatial bodies, in the bodies' room ([`crate::body::spatial`]).
pub use crate::body::spatial as body;
/// The spatial joints, in the joints' room ([`crate::joint::spatial`]).
pub use crate::joint::spatial as joint;

pub(crate) mod assembly;
pub(crate) mod element;

pub(crate) mod stress;

/// What a stress-like response reads at an element's points.
pub use stress::Criterion;
