//! The scene's `[simulation]` table: default run settings, overridable per run.

use super::validate::Result;
use crate::error::SceneError;
use crate::settings::RunOptions;

/// The scene's default run settings, checked by the same [`RunOptions::validate`] as a
/// caller's overrides; a bad value is a [`SceneError`] at `simulation.NAME`.
pub(super) fn defaults(s: &RunOptions) -> Result<RunOptions> {
    s.validate()
        .map_err(|e| SceneError::new(format!("simulation.{}", e.name), e.message))?;
    Ok(*s)
}
