//! Spatial scenes: a mechanism in space described in TOML (`dimension = 3`) or by the
//! Python `SpatialScene` builder, built into a [`SpatialModel`] with its run settings and
//! the names a user gives responses and parameters ([`names`]).
//!
//! ```toml
//! name = "hinged bar"
//! dimension = 3
//! gravity = [0.0, 0.0, -9.81]
//!
//! [[rigid_bodies]]
//! name = "bar"
//! mass = 1.0
//! inertia = [0.001, 0.0833, 0.0833]
//! position = [0.5, 0.0, 0.0]
//! points = { pivot = [-0.5, 0.0, 0.0] }
//!
//! [[joints]]
//! name = "hinge"
//! kind = "revolute"
//! a = "bar.pivot"        # b is the ground where a is
//! axis = [0.0, 1.0, 0.0]
//!
//! [simulation]
//! t_end = 1.0
//! h = 0.001
//! ```

mod build;
mod design;
pub mod lattice;
pub mod names;
mod orientation;
mod own_frequency;
pub mod spec;
mod split;

use std::collections::BTreeMap;

pub use build::build_spatial;
pub use orientation::ORTHONORMAL_TOLERANCE;
pub use spec::SpatialSceneSpec;

use crate::error::SceneError;
use crate::mechanism::model::{Analysis, Design};
use crate::settings::RunOptions;
use crate::spatial::model::SpatialModel;
use crate::spatial::section::Section;

/// A built spatial scene.
#[derive(Debug, Clone, PartialEq)]
pub struct SpatialScene {
    /// The scene's name.
    pub name: String,
    /// Dynamic or static.
    pub analysis: Analysis,
    /// The mechanism.
    pub model: SpatialModel,
    /// The scene's default run settings.
    pub options: RunOptions,
    /// The body or node whose final position is the default response.
    pub tip: Option<String>,
    /// Each beam of the scene by name: its elements in the model.
    pub beams: BTreeMap<String, BeamElements>,
    /// The design variables (each a beam's or a group's) and their laws.
    pub design: Design,
}

/// A scene's beam in the model: its elements, beams or one truss bar.
#[derive(Debug, Clone, PartialEq)]
pub struct BeamElements {
    /// Whether it is a truss bar (`model.trusses`) rather than beams (`model.beams`).
    pub truss: bool,
    /// The elements' indices.
    pub elements: Vec<usize>,
    /// Its material's Young's modulus (Pa) and density (kg/m³).
    pub material: [f64; 2],
    /// Its section at full density (its shape: what a size parameter moves).
    pub section: Section,
    /// Its design variable; `None` where it is fixed at full density.
    pub variable: Option<usize>,
}

/// Parses a spatial TOML scene.
///
/// # Errors
/// A [`SceneError`] with the path of the offending key (syntax, unknown key, wrong type).
pub fn parse_spatial_toml(text: &str) -> Result<SpatialSceneSpec, SceneError> {
    super::parse_with_paths(text)
}

#[cfg(test)]
pub(crate) mod tests;
