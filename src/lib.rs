//! flextop: flexible multibody dynamics with exact design sensitivities.
#![warn(missing_docs)]

pub mod element;
pub mod error;
pub mod interpolation;
pub mod section;
pub mod constraint;
pub mod load;
pub mod model;
pub mod motion;
pub mod rigid;
pub mod scene;
pub mod assembly;
pub mod integrator;
pub mod linsolve;
pub mod newton;
pub mod simulation;
pub mod statics;
pub mod options;
#[cfg(feature = "python")]
mod python;
pub mod response;
pub mod sensitivity;
