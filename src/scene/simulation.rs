//! The scene's `[simulation]` table: default run settings, overridable per run.

use super::validate::{positive, Result};
use crate::error::SceneError;
use crate::options::RunOptions;

/// The scene's default run settings, checked like the scene's other values.
pub(super) fn defaults(s: &RunOptions) -> Result<RunOptions> {
    for (name, value) in [("t_end", s.t_end), ("h", s.h), ("tol", s.tol)] {
        if let Some(v) = value {
            positive(&format!("simulation.{name}"), v)?;
        }
    }
    if let Some(r) = s.rho_inf {
        if !(0.0..=1.0).contains(&r) {
            return Err(SceneError::new(
                "simulation.rho_inf",
                format!("must lie in [0, 1], got {r}"),
            ));
        }
    }
    for (name, value) in [("load_steps", s.load_steps), ("max_iter", s.max_iter)] {
        if value == Some(0) {
            return Err(SceneError::new(
                format!("simulation.{name}"),
                "must be at least 1",
            ));
        }
    }
    Ok(*s)
}
