//! Scenes: the description of a mechanism (TOML file or Python builder) and its validated
//! build into a [`crate::mechanism::model::Model`].
//!
//! A scene file is TOML; see `examples/*.toml` and the README for the keys. Parsing rejects
//! unknown keys with their path; [`build()`] checks every value and the mechanism.

mod body;
pub mod build;
mod design;
pub mod ground_structure;
mod joint;
mod load;
mod member;
mod mesh;
mod motor;
mod ring;
mod section;
mod simulation;
pub mod spatial;
pub mod spec;
mod spring;
pub(crate) mod validate;

pub use build::build;
pub use spec::SceneSpec;

use crate::error::SceneError;

/// Parses a TOML scene.
///
/// # Errors
/// A [`SceneError`] with the path of the offending key (syntax, unknown key, wrong type).
pub fn parse_toml(text: &str) -> Result<SceneSpec, SceneError> {
    parse_with_paths(text)
}

/// Parses TOML text into `T`, an error naming the key's path.
fn parse_with_paths<T: serde::de::DeserializeOwned>(text: &str) -> Result<T, SceneError> {
    let de = toml::de::Deserializer::parse(text)
        .map_err(|e| SceneError::new("scene file", e.to_string().trim().to_string()))?;
    serde_path_to_error::deserialize(de).map_err(|e| {
        let path = e.path().to_string();
        SceneError::new(
            if path == "." { "scene".into() } else { path },
            e.into_inner().to_string().trim().to_string(),
        )
    })
}

#[cfg(test)]
mod tests;
