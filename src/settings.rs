//! Run settings, validated in one place.
//!
//! A scene's `[simulation]` table and a caller's overrides are both [`RunOptions`], checked
//! by the same [`RunOptions::validate`]. A run merges the two over the engine's defaults
//! into [`DynamicSettings`] (time integration), [`StaticSettings`] (equilibrium, of the
//! [`StaticAnalysis`] asked for) and [`SensitivitySettings`] (how gradients are computed).
//! Defaults: `ρ∞ = 0.8` (the paper's choice), relative Newton tolerance `1e-10`, 20 Newton
//! iterations per step, consistent mass, one load step, the nonlinear static analysis,
//! gradients by the method that suits the problem. Times in s.

use std::str::FromStr;

use serde::Deserialize;

use crate::error::{short, SettingsError};
use crate::limits::MAX_LOAD_STEPS;
use crate::time_grid::TimeGrid;

/// How the elements' inertia is discretized: a run setting (`mass`), read by the elements.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MassKind {
    /// Consistent with linear interpolation of displacements and rotation.
    Consistent,
    /// Row-sum lumped: half of the element's mass and rotary inertia on each node.
    Lumped,
    /// A bar's mass lumped on its nodes, and its end nodes coupled so that the bar's rigid
    /// motion and uniform stretch carry their exact kinetic energy
    /// ([`crate::mechanism::bar_mass::BarMass`]; rotary inertia lumped): consistent in
    /// translation on a bar of one element, and on a
    /// split bar the lumped mass's fourth-order convergence of the bar's own bending modes
    /// (against the second order of the consistent mass of linear interpolation). A
    /// continuum member's cells take their consistent mass.
    BarLumped,
}

/// Default spectral radius at infinite frequency.
pub const RHO_INF: f64 = 0.8;
/// Default relative Newton tolerance.
pub const TOL: f64 = 1e-10;
/// Default Newton iterations per step.
pub const MAX_ITER: usize = 20;
/// Consecutive halvings of a failed static load step.
pub const MAX_CUTS: usize = 8;
/// Most steps a run may take.
pub const MAX_STEPS: usize = 100_000_000;
/// Memory the adjoint may use for stored states before it switches to checkpoints (bytes).
pub const STORE_BUDGET_BYTES: usize = 512 << 20;

/// How to compute gradients.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Method {
    /// Direct differentiation (Algorithm 2).
    Direct,
    /// Discrete adjoint.
    Adjoint,
    /// Adjoint when there are fewer state-dependent responses than design variables.
    #[default]
    Auto,
}

/// What the adjoint keeps of the forward sweep.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Memory {
    /// Every step's positions and accelerations.
    StoreAll,
    /// Full states every `⌈√N⌉` steps, segments replayed backwards (one more forward sweep).
    Checkpoints,
    /// Checkpoints when storing everything would exceed `budget_bytes` (named `"auto"`:
    /// [`STORE_BUDGET_BYTES`]).
    Auto {
        /// Memory allowed for the stored states, in bytes.
        budget_bytes: usize,
    },
}

/// How often Newton's iteration matrix is refactorized.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum NewtonMatrix {
    /// At every iteration: Newton's method, quadratic convergence.
    #[default]
    Full,
    /// At the first iteration of each step, then kept while the residual falls at least
    /// tenfold per iteration (modified Newton): each kept iteration costs a residual and a
    /// solve instead of a tangent and a factorization. The same solution to `tol`.
    Modified,
}

/// Which static problem a run solves (`analysis`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StaticAnalysis {
    /// The geometrically nonlinear equilibrium, by Newton's method with load stepping.
    #[default]
    Nonlinear,
    /// The small-displacement problem about the reference configuration, `K₀ u = f`, the
    /// joints' constraints linear about it and the load applied at once
    /// ([`crate::solve_linear`]): the 88-line code's analysis.
    Linear,
}

/// Parses a lowercase name among `allowed`, for the `FromStr` of the setting enums.
fn parse_name<T: Copy>(
    setting: &str,
    name: &str,
    allowed: &[(&str, T)],
) -> Result<T, SettingsError> {
    allowed
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, v)| *v)
        .ok_or_else(|| {
            let names: Vec<String> = allowed.iter().map(|(n, _)| format!("'{n}'")).collect();
            SettingsError::new(
                setting,
                format!("must be one of {}, got '{name}'", names.join(", ")),
            )
        })
}

impl FromStr for Method {
    type Err = SettingsError;
    fn from_str(s: &str) -> Result<Self, SettingsError> {
        use Method::*;
        parse_name(
            "method",
            s,
            &[("auto", Auto), ("direct", Direct), ("adjoint", Adjoint)],
        )
    }
}

impl FromStr for StaticAnalysis {
    type Err = SettingsError;
    fn from_str(s: &str) -> Result<Self, SettingsError> {
        use StaticAnalysis::*;
        parse_name(
            "analysis",
            s,
            &[("nonlinear", Nonlinear), ("linear", Linear)],
        )
    }
}

impl FromStr for NewtonMatrix {
    type Err = SettingsError;
    fn from_str(s: &str) -> Result<Self, SettingsError> {
        use NewtonMatrix::*;
        parse_name("newton", s, &[("full", Full), ("modified", Modified)])
    }
}

impl FromStr for Memory {
    type Err = SettingsError;
    fn from_str(s: &str) -> Result<Self, SettingsError> {
        let auto = Memory::Auto {
            budget_bytes: STORE_BUDGET_BYTES,
        };
        parse_name(
            "memory",
            s,
            &[
                ("auto", auto),
                ("store", Memory::StoreAll),
                ("checkpoints", Memory::Checkpoints),
            ],
        )
    }
}

/// Deserializes a setting enum from its name through its `FromStr`, so that a scene file, a
/// settings dict and a string argument get the same message listing the allowed names.
macro_rules! deserialize_by_name {
    ($t:ty) => {
        impl<'de> Deserialize<'de> for $t {
            fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                let name = String::deserialize(d)?;
                name.parse()
                    .map_err(|e: SettingsError| serde::de::Error::custom(e.message))
            }
        }
    };
}
deserialize_by_name!(Method);
deserialize_by_name!(Memory);
deserialize_by_name!(NewtonMatrix);
deserialize_by_name!(StaticAnalysis);

impl Method {
    /// The lowercase name, as parsed.
    pub fn name(self) -> &'static str {
        match self {
            Self::Direct => "direct",
            Self::Adjoint => "adjoint",
            Self::Auto => "auto",
        }
    }
}

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
    /// Newton's matrix: `"full"` (every iteration) or `"modified"` (kept while it contracts).
    pub newton: Option<NewtonMatrix>,
    /// Inertia discretization: `"consistent"`, `"lumped"` or `"bar_lumped"`.
    pub mass: Option<MassKind>,
    /// Initial load steps of a static analysis.
    pub load_steps: Option<usize>,
    /// The static problem: `"nonlinear"` (the default) or `"linear"`.
    pub analysis: Option<StaticAnalysis>,
    /// Gradient method: `"auto"`, `"direct"` or `"adjoint"`.
    pub method: Option<Method>,
    /// What the adjoint stores: `"auto"`, `"store"` or `"checkpoints"`.
    pub memory: Option<Memory>,
}

/// Settings of a time integration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DynamicSettings {
    /// End time (s).
    pub t_end: f64,
    /// Step size (s).
    pub h: f64,
    /// Spectral radius at infinite frequency.
    pub rho_inf: f64,
    /// Relative Newton tolerance on the residual (forces) and the constraints (lengths).
    pub tol: f64,
    /// Newton iterations allowed per step.
    pub max_iter: usize,
    /// How often Newton's matrix is refactorized.
    pub newton: NewtonMatrix,
    /// Inertia discretization.
    pub mass: MassKind,
}

/// Settings of a static solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StaticSettings {
    /// Initial number of equal load steps.
    pub load_steps: usize,
    /// Time at which loads and prescribed motions are evaluated (s).
    pub time: f64,
    /// Relative Newton tolerance.
    pub tol: f64,
    /// Newton iterations per load step.
    pub max_iter: usize,
    /// How often Newton's matrix is refactorized.
    pub newton: NewtonMatrix,
    /// Consecutive step halvings allowed.
    pub max_cuts: usize,
}

/// How a sensitivity analysis runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SensitivitySettings {
    /// Gradient method.
    pub method: Method,
    /// What the adjoint stores.
    pub memory: Memory,
}

impl Default for Memory {
    /// Checkpoints past [`STORE_BUDGET_BYTES`] of stored states.
    fn default() -> Self {
        Self::Auto {
            budget_bytes: STORE_BUDGET_BYTES,
        }
    }
}

impl RunOptions {
    /// Checks every given value and the relations between them; the error names the setting.
    ///
    /// # Errors
    /// A [`SettingsError`] for a value out of range.
    pub fn validate(&self) -> Result<(), SettingsError> {
        let bad = |n: &str, m: String| Err(SettingsError::new(n, m));
        if let Some(h) = self.h.filter(|h| !(h.is_finite() && *h > 0.0)) {
            return bad(
                "h",
                format!("step size must be positive and finite, got {}", short(h)),
            );
        }
        if let Some(t) = self.t_end.filter(|t| !(t.is_finite() && *t > 0.0)) {
            return bad(
                "t_end",
                format!("must be positive and finite, got {}", short(t)),
            );
        }
        if let (Some(h), Some(t_end)) = (self.h, self.t_end) {
            if h > t_end {
                return bad("h", format!("step size {h} exceeds t_end {t_end}"));
            }
            if t_end / h > MAX_STEPS as f64 {
                return bad(
                    "h",
                    format!(
                        "t_end / h = {:.3e} steps; at most {MAX_STEPS:.0e} are allowed",
                        t_end / h
                    ),
                );
            }
        }
        if let Some(r) = self.rho_inf.filter(|r| !(0.0..=1.0).contains(r)) {
            return bad("rho_inf", format!("must lie in [0, 1], got {}", short(r)));
        }
        if let Some(tol) = self
            .tol
            .filter(|t| !(t.is_finite() && *t > 0.0 && *t < 1.0))
        {
            return bad("tol", format!("must lie in (0, 1), got {}", short(tol)));
        }
        for (name, value) in [("max_iter", self.max_iter), ("load_steps", self.load_steps)] {
            if value == Some(0) {
                return bad(name, "must be at least 1".into());
            }
        }
        if let Some(n) = self.load_steps.filter(|&n| n > MAX_LOAD_STEPS) {
            return bad(
                "load_steps",
                format!("{n}: at most {MAX_LOAD_STEPS} are allowed"),
            );
        }
        Ok(())
    }

    /// `self` over `defaults`: each setting given here wins.
    pub fn over(&self, d: &RunOptions) -> RunOptions {
        RunOptions {
            t_end: self.t_end.or(d.t_end),
            h: self.h.or(d.h),
            rho_inf: self.rho_inf.or(d.rho_inf),
            tol: self.tol.or(d.tol),
            max_iter: self.max_iter.or(d.max_iter),
            newton: self.newton.or(d.newton),
            mass: self.mass.or(d.mass),
            load_steps: self.load_steps.or(d.load_steps),
            analysis: self.analysis.or(d.analysis),
            method: self.method.or(d.method),
            memory: self.memory.or(d.memory),
        }
    }

    /// Settings of a dynamic run, `self` over the scene's `defaults`.
    ///
    /// # Errors
    /// A [`SettingsError`] if `t_end` or `h` is given nowhere, or a value is out of range.
    pub fn dynamic(&self, defaults: &RunOptions) -> Result<DynamicSettings, SettingsError> {
        let o = self.over(defaults);
        o.validate()?;
        if o.analysis == Some(StaticAnalysis::Linear) {
            return Err(linear_is_static());
        }
        let missing = |n: &str| {
            SettingsError::new(
                n,
                "not given, and the scene's [simulation] table has no default",
            )
        };
        Ok(DynamicSettings {
            t_end: o.t_end.ok_or_else(|| missing("t_end"))?,
            h: o.h.ok_or_else(|| missing("h"))?,
            rho_inf: o.rho_inf.unwrap_or(RHO_INF),
            tol: o.tol.unwrap_or(TOL),
            max_iter: o.max_iter.unwrap_or(MAX_ITER),
            newton: o.newton.unwrap_or_default(),
            mass: o.mass.unwrap_or(MassKind::Consistent),
        })
    }

    /// Settings of a nonlinear static solve, `self` over the scene's `defaults`, for a
    /// solver that offers no other ([`RunOptions::equilibrium`] where the linear analysis is
    /// built).
    ///
    /// # Errors
    /// A [`SettingsError`] for a value out of range, or for `analysis = "linear"`.
    pub fn statics(&self, defaults: &RunOptions) -> Result<StaticSettings, SettingsError> {
        match self.equilibrium(defaults)? {
            (StaticAnalysis::Nonlinear, settings) => Ok(settings),
            (StaticAnalysis::Linear, _) => Err(SettingsError::new(
                "analysis",
                "the linear analysis is built for planar scenes; this solver is nonlinear",
            )),
        }
    }

    /// The static problem and the settings of its solve, `self` over the scene's
    /// `defaults`.
    ///
    /// # Errors
    /// A [`SettingsError`] for a value out of range.
    pub fn equilibrium(
        &self,
        defaults: &RunOptions,
    ) -> Result<(StaticAnalysis, StaticSettings), SettingsError> {
        let o = self.over(defaults);
        o.validate()?;
        Ok((
            o.analysis.unwrap_or_default(),
            StaticSettings {
                load_steps: o.load_steps.unwrap_or(1),
                time: o.t_end.unwrap_or(0.0),
                tol: o.tol.unwrap_or(TOL),
                max_iter: o.max_iter.unwrap_or(MAX_ITER),
                newton: o.newton.unwrap_or_default(),
                max_cuts: MAX_CUTS,
            },
        ))
    }

    /// How gradients are computed, `self` over the scene's `defaults`.
    pub fn sensitivity(&self, defaults: &RunOptions) -> SensitivitySettings {
        let o = self.over(defaults);
        SensitivitySettings {
            method: o.method.unwrap_or_default(),
            memory: o.memory.unwrap_or_default(),
        }
    }
}

/// The error of a linear analysis asked of a dynamic run.
pub(crate) fn linear_is_static() -> SettingsError {
    SettingsError::new(
        "analysis",
        "'linear' is a static analysis (K₀u = f about the reference configuration); a \
         dynamic run follows the motion's large rotations, geometrically nonlinear: drop \
         it, or make the scene static (analysis = \"static\")",
    )
}

impl DynamicSettings {
    /// Checks ranges, as [`RunOptions::validate`] does for settings built by hand.
    ///
    /// # Errors
    /// A [`SettingsError`] naming the setting.
    pub fn validate(&self) -> Result<(), SettingsError> {
        RunOptions {
            t_end: Some(self.t_end),
            h: Some(self.h),
            rho_inf: Some(self.rho_inf),
            tol: Some(self.tol),
            max_iter: Some(self.max_iter),
            ..RunOptions::default()
        }
        .validate()
    }

    /// Number of steps to `t_end`: `t_end / h`, rounded up unless it is within 1e-9 of an
    /// integer (at least one).
    pub fn steps(&self) -> usize {
        let ratio = self.t_end / self.h;
        let steps = if (ratio - ratio.round()).abs() <= 1e-9 * ratio.max(1.0) {
            ratio.round()
        } else {
            ratio.ceil()
        };
        (steps as usize).max(1)
    }

    /// The step size used: `h`, shortened if needed so that [`DynamicSettings::steps`]
    /// steps end exactly at `t_end`.
    pub fn step(&self) -> f64 {
        self.t_end / self.steps() as f64
    }

    /// The fixed-step grid of this run: [`DynamicSettings::steps`] steps of
    /// [`DynamicSettings::step`].
    pub fn grid(&self) -> TimeGrid {
        TimeGrid::uniform(self.step(), self.steps())
    }
}

impl StaticSettings {
    /// Checks ranges, as [`RunOptions::validate`] does for settings built by hand.
    ///
    /// # Errors
    /// A [`SettingsError`] naming the setting.
    pub fn validate(&self) -> Result<(), SettingsError> {
        if !self.time.is_finite() {
            return Err(SettingsError::new("t_end", "must be finite"));
        }
        RunOptions {
            load_steps: Some(self.load_steps),
            tol: Some(self.tol),
            max_iter: Some(self.max_iter),
            ..RunOptions::default()
        }
        .validate()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_once_and_errors_list_the_allowed_values() {
        assert_eq!("adjoint".parse::<Method>(), Ok(Method::Adjoint));
        assert_eq!("checkpoints".parse::<Memory>(), Ok(Memory::Checkpoints));
        let e = "bogus".parse::<Method>().unwrap_err();
        assert_eq!(e.name, "method");
        assert!(e.message.contains("'auto', 'direct', 'adjoint'"), "{e}");
    }

    #[test]
    fn the_linear_analysis_is_static_and_offered_where_it_is_built() {
        let linear = RunOptions {
            analysis: Some(StaticAnalysis::Linear),
            ..Default::default()
        };
        let timed = RunOptions {
            t_end: Some(1.0),
            h: Some(0.1),
            ..Default::default()
        };
        assert_eq!(linear.dynamic(&timed).unwrap_err().name, "analysis");
        assert_eq!(timed.dynamic(&linear).unwrap_err().name, "analysis");
        assert_eq!(linear.statics(&timed).unwrap_err().name, "analysis");
        let (analysis, settings) = linear.equilibrium(&timed).unwrap();
        assert_eq!((analysis, settings.time), (StaticAnalysis::Linear, 1.0));
        assert_eq!(
            timed.equilibrium(&timed).unwrap().0,
            StaticAnalysis::Nonlinear
        );
        let e = "Linear".parse::<StaticAnalysis>().unwrap_err();
        assert_eq!(e.name, "analysis");
        assert!(e.message.contains("'nonlinear', 'linear'"), "{e}");
    }

    #[test]
    fn overrides_win_and_pass_the_same_validation_as_defaults() {
        let scene = RunOptions {
            t_end: Some(1.0),
            h: Some(0.01),
            ..Default::default()
        };
        let mine = RunOptions {
            h: Some(0.1),
            ..Default::default()
        };
        let s = mine.dynamic(&scene).unwrap();
        assert_eq!((s.t_end, s.h, s.rho_inf), (1.0, 0.1, RHO_INF));
        let bad = RunOptions {
            h: Some(2.0),
            ..Default::default()
        };
        assert_eq!(bad.dynamic(&scene).unwrap_err().name, "h");
        assert_eq!(bad.validate(), Ok(()), "alone, h = 2 is a valid default");
        let zero = RunOptions {
            max_iter: Some(0),
            ..Default::default()
        };
        assert_eq!(zero.validate().unwrap_err().name, "max_iter");
    }
}
