//! Finite elements of the flexible bodies.
//!
//! The only structural element is the co-rotational Timoshenko [`beam`]; point masses are
//! attached to nodes by the [`crate::mechanism::model::Model`].

pub mod beam;

pub use crate::settings::MassKind;
pub use beam::{Beam, Damping, Matrix6, Vector6};
