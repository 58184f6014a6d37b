//! **The bodies' room**, both dimensions: rigid bodies and point masses.
//!
//! * [`planar`] — a planar body, its node at the centre of mass with its mass and rotary
//!   inertia, its named points; point masses on nodes;
//! * [`spatial`] — a spatial body, its node at the centre of mass with its mass and full
//!   inertia tensor, and its inertia forces on the Lie group (Newton–Euler).

pub mod planar;
pub mod spatial;
