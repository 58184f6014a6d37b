//! **The joints' room**, both dimensions: joints as algebraic constraints with Lagrange
//! multipliers (paper Eq. 2–3) and the motion laws that drive them.
//!
//! * [`planar`] — a planar joint's rows on the nodes' `(x, y, φ)`: clamp, pin, hinge, weld,
//!   prismatic (slider), roller, each row an angle or a separation law, on nodes or on a
//!   rigid body's points;
//! * [`spatial`] — a spatial joint's rows on the Lie group: weld, spherical, revolute,
//!   prismatic, cylindrical, universal, each row the dot product of two measures of a pair
//!   of anchors, with its constraint-force stiffness;
//! * [`motion`] — the drives' motion laws (trapezoidal, a table) and their rates to a law's
//!   parameters, shared by both.
//!
//! The revolute joint is `planar`'s hinge (or pin) and `spatial`'s `JointKind::Revolute`; a
//! drive on either is a [`motion::Motion`].

pub mod motion;
pub mod planar;
pub mod spatial;
