//! **The spatial wing**: mechanisms in space on the Lie group `(ℝ³ × SO(3))ⁿ` of
//! [`crate::group`]. Rigid bodies with a full inertia tensor ([`body`]), joints and drives as
//! index-3 constraints with their constraint-force stiffness ([`joint`]), the mechanism built entry by
//! entry and checked ([`model`]), its residual and non-symmetric iteration matrix on a fixed
//! pattern (`assembly`), and generalized-α on the group ([`integrator`]), factored by sparse
//! `LU`.
//!
//! This is the first part of the spatial engine: rigid bodies, the joints (spherical,
//! revolute, universal, cylindrical, prismatic, weld), drives, force elements (springs,
//! motors, loads, [`force`]) and their exact gradients ([`sensitivity`]). Beams, statics and
//! modes come next, on the same group.

pub mod body;
pub mod force;
pub mod integrator;
pub mod joint;
pub mod model;
pub mod sensitivity;

pub(crate) mod assembly;
pub(crate) mod pair;
