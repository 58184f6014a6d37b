//! Run options: a scene's `[simulation]` table and a caller's overrides are both
//! [`RunOptions`]; a run merges the two over the engine's defaults: `ρ∞ = 0.8` (the
//! paper's choice), relative Newton tolerance `1e-10`, 20
//! Newton iterations per step, consistent mass, one load step.

use serde::Deserialize;

use crate::element::MassKind;
use crate::error::SettingsError;
use crate::integrator::Settings;
use crate::statics::StaticSettings;

/// Default spectral radius at infinite frequency.
pub const RHO_INF: f64 = 0.8;
/// Default relative Newton tolerance.
pub const TOL: f64 = 1e-10;
/// Default Newton iterations per step.
pub const MAX_ITER: usize = 20;
/// Consecutive halvings of a failed static load step.
pub const MAX_CUTS: usize = 8;

/// Optional overrides of the run settings (unknown keys rejected when deserialized).
#[derive(Debug, Clone, Copy, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunOptions {
    /// End time (s); a static analysis evaluates loads at this time (default 0).
    pub t_end: Option<f64>,
    /// Step size (s).
    pub h: Option<f64>,
    /// Spectral radius at infinite frequency.
    pub rho_inf: Option<f64>,
    /// Relative Newton tolerance.
    pub tol: Option<f64>,
    /// Newton iterations per step.
    pub max_iter: Option<usize>,
    /// Inertia discretization: `"consistent"` or `"lumped"`.
    pub mass: Option<MassKind>,
    /// Initial load steps of a static analysis.
    pub load_steps: Option<usize>,
}

impl RunOptions {
    /// Settings of a dynamic run (whose step is [`Settings::step`]).
    ///
    /// # Errors
    /// A [`SettingsError`] if `t_end` or `h` is given nowhere, or a value is out of range.
    pub fn dynamic(&self, d: &RunOptions) -> Result<Settings, SettingsError> {
        let missing = |n: &str| {
            SettingsError::new(
                n,
                "not given, and the scene's [simulation] table has no default",
            )
        };
        let s = Settings {
            t_end: self.t_end.or(d.t_end).ok_or_else(|| missing("t_end"))?,
            h: self.h.or(d.h).ok_or_else(|| missing("h"))?,
            rho_inf: self.rho_inf.or(d.rho_inf).unwrap_or(RHO_INF),
            tol: self.tol.or(d.tol).unwrap_or(TOL),
            max_iter: self.max_iter.or(d.max_iter).unwrap_or(MAX_ITER),
            mass: self.mass.or(d.mass).unwrap_or(MassKind::Consistent),
        };
        s.validate()?;
        Ok(s)
    }

    /// Settings of a static solve.
    ///
    /// # Errors
    /// A [`SettingsError`] for a value out of range.
    pub fn statics(&self, d: &RunOptions) -> Result<StaticSettings, SettingsError> {
        let s = StaticSettings {
            load_steps: self.load_steps.or(d.load_steps).unwrap_or(1),
            time: self.t_end.or(d.t_end).unwrap_or(0.0),
            tol: self.tol.or(d.tol).unwrap_or(TOL),
            max_iter: self.max_iter.or(d.max_iter).unwrap_or(MAX_ITER),
            max_cuts: MAX_CUTS,
        };
        s.validate()?;
        Ok(s)
    }
}
