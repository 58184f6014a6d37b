//! The scene's `[simulation]` table: default run settings, overridable per run.

use super::spec::AnalysisSpec;
use super::validate::Result;
use crate::error::{SceneError, SettingsError};
use crate::settings::{linear_is_static, RunOptions, StaticAnalysis};

/// The scene's default run settings, checked by the same [`RunOptions::validate`] as a
/// caller's overrides; a bad value is a [`SceneError`] at `simulation.NAME`, and so is the
/// linear analysis of a dynamic scene.
pub(super) fn defaults(s: &RunOptions, analysis: AnalysisSpec) -> Result<RunOptions> {
    let named = |e: SettingsError| SceneError::new(format!("simulation.{}", e.name), e.message);
    s.validate().map_err(named)?;
    if analysis == AnalysisSpec::Dynamic && s.analysis == Some(StaticAnalysis::Linear) {
        return Err(named(linear_is_static()));
    }
    Ok(*s)
}
