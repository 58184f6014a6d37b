//! Local error control of generalized-α: the estimate of a step's local error on the
//! positions, and the controller that chooses the next step size.
//!
//! **Estimate.** The pseudo-accelerations lag the accelerations, `aₙ ≈ q̈(tₙ + Δ_α h)` with
//! `Δ_α = α_m − α_f = ½ − γ`, so the position update `qₙ₊₁ = qₙ + h q̇ₙ + h²((½ − β)aₙ + βaₙ₊₁)`
//! has the local error `(β − γ/2 + 1/12) h³ q⃛ + O(h⁴)`, estimated from the accelerations
//! of the two ends as `eₙ = (β − γ/2 + 1/12) h² (q̈ₙ₊₁ − q̈ₙ)`. Its size is measured in the
//! max norm against `tol · L` for translations (`L` the model's size, m) and `tol` for
//! rotations (rad). The multipliers are left out: on the index-3 equations they carry
//! the step-change transients of the constraint forces, not an error of the motion.
//!
//! **Controller.** A step whose error exceeds 1 is rejected and retried with
//! `h · max(0.2, 0.9 e^(−1/3))`; a Newton failure retries with `h/4`. An accepted step
//! proposes `h · min(2, 0.9 e^(−1/3))`, taken only when it grows the step by at least
//! 1.5× after at least four steps at the present size (or shrinks it below 0.8×): the
//! hysteresis keeps the step from alternating, which the index-3 scheme tolerates badly
//! (a sustained ×5 alternation diverges for ρ∞ < 1). Steps end exactly at every kink of
//! the motion laws and at `t_end`; a remainder shorter than two steps is split evenly.

use crate::error::SettingsError;
use crate::mechanism::model::Model;
use crate::solver::alpha::AlphaParameters;

/// Safety factor on the proposed step.
const SAFETY: f64 = 0.9;
/// Largest growth of the step in one change.
const GROW_MAX: f64 = 2.0;
/// Smallest factor of a rejected step.
const SHRINK_MIN: f64 = 0.2;
/// A proposed growth smaller than this is not taken (hysteresis).
const GROW_AT_LEAST: f64 = 1.5;
/// A proposed shrink of an accepted step larger than this is not taken.
const SHRINK_AT_MOST: f64 = 0.8;
/// Accepted steps at one size before the step may grow.
const HOLD: usize = 4;
/// Step factor after a Newton failure.
const NEWTON_CUT: f64 = 0.25;

/// Local error control: `tol` relative to the model's size and 1 rad, the first step
/// `h_first` and the smallest step `h_min` (s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepControl {
    /// Local error tolerance (dimensionless).
    pub tol: f64,
    /// First step size (s).
    pub h_first: f64,
    /// Smallest step size (s): below it the run stops with [`crate::SolveError::StepTooSmall`].
    pub h_min: f64,
}

impl StepControl {
    /// Control with tolerance `tol`, starting at `h_first`, down to `h_first · 1e-6`.
    pub fn new(tol: f64, h_first: f64) -> Self {
        Self {
            tol,
            h_first,
            h_min: h_first * 1e-6,
        }
    }

    /// A [`SettingsError`] naming `local_tol` or `h` when a value is not positive and finite.
    pub fn validate(&self) -> Result<(), SettingsError> {
        if !(self.tol.is_finite() && self.tol > 0.0 && self.tol < 1.0) {
            return Err(SettingsError::new(
                "local_tol",
                format!("must lie in (0, 1), got {}", self.tol),
            ));
        }
        if !(self.h_first.is_finite() && self.h_first > 0.0) {
            return Err(SettingsError::new(
                "h",
                format!(
                    "the first step must be positive and finite, got {}",
                    self.h_first
                ),
            ));
        }
        Ok(())
    }
}

/// The error scale of each coordinate: the model's size (m, its nodes' and rigid bodies'
/// points') for translations, 1 rad for rotations.
pub fn error_scales(model: &Model) -> Vec<f64> {
    let size = model.size();
    (0..model.n_dofs())
        .map(|i| if i % 3 == 2 { 1.0 } else { size })
        .collect()
}

/// `C = β − γ/2 + 1/12`, the local error constant of the position update.
pub fn local_error_constant(p: &AlphaParameters) -> f64 {
    p.beta - 0.5 * p.gamma + 1.0 / 12.0
}

/// The local error of a step of size `h` from `q̈ₙ` to `q̈ₙ₊₁`, in units of the tolerance:
/// `max_i |C h² (q̈ₙ₊₁ − q̈ₙ)_i| / (tol · scaleᵢ)`.
pub fn local_error(c: f64, h: f64, before: &[f64], after: &[f64], scales: &[f64], tol: f64) -> f64 {
    before
        .iter()
        .zip(after)
        .zip(scales)
        .map(|((b, a), s)| (c * h * h * (a - b)).abs() / (tol * s))
        .fold(0.0, f64::max)
}

/// The step-size decisions of one run.
#[derive(Debug, Clone)]
pub struct Controller {
    /// The step the controller wants (before landing on a stop).
    wanted: f64,
    /// Accepted steps since the last change of `wanted`.
    held: usize,
    h_min: f64,
}

/// What to do after a step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Verdict {
    /// Keep the step and go on.
    Accept,
    /// Undo the step and retry with the (smaller) wanted step.
    Reject,
}

impl Controller {
    /// A controller starting at `control.h_first`.
    pub fn new(control: &StepControl) -> Self {
        Self {
            wanted: control.h_first,
            held: 0,
            h_min: control.h_min,
        }
    }

    /// The step to take from `t`: the wanted one, ending exactly at `stop` if it reaches
    /// it, and split evenly if less than two steps would remain.
    pub fn step(&self, t: f64, stop: f64) -> f64 {
        let remaining = stop - t;
        if remaining <= self.wanted * (1.0 + 1e-9) {
            remaining
        } else if remaining < 2.0 * self.wanted {
            0.5 * remaining
        } else {
            self.wanted
        }
    }

    /// Judges a step of size `h` with local error `error` (in units of the tolerance) and
    /// updates the wanted step.
    pub fn judge(&mut self, h: f64, error: f64) -> Verdict {
        let factor = if error > 0.0 {
            SAFETY * error.powf(-1.0 / 3.0)
        } else {
            GROW_MAX
        };
        if error > 1.0 {
            self.change(h * factor.max(SHRINK_MIN));
            return Verdict::Reject;
        }
        self.held += 1;
        let proposed = h * factor.min(GROW_MAX);
        if (proposed >= GROW_AT_LEAST * self.wanted && self.held >= HOLD)
            || proposed < SHRINK_AT_MOST * self.wanted
        {
            self.change(proposed);
        }
        Verdict::Accept
    }

    /// A Newton failure at step `h`: the wanted step becomes `h/4`.
    pub fn newton_failed(&mut self, h: f64) {
        self.change(h * NEWTON_CUT);
    }

    /// Whether the wanted step has fallen below the smallest allowed.
    pub fn too_small(&self) -> bool {
        self.wanted < self.h_min
    }

    fn change(&mut self, h: f64) {
        self.wanted = h;
        self.held = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_constant_vanishes_nowhere_and_is_one_twelfth_without_dissipation() {
        let c = |rho| local_error_constant(&AlphaParameters::chung_hulbert(rho));
        assert!((c(1.0) - 1.0 / 12.0).abs() < 1e-15);
        for rho in [0.0, 0.3, 0.5, 0.8, 0.9] {
            assert!(c(rho) > 1.0 / 12.0, "dissipation adds to the error ({rho})");
        }
    }

    #[test]
    fn the_controller_holds_rejects_and_lands_on_stops() {
        let control = StepControl::new(1e-3, 0.1);
        let mut c = Controller::new(&control);
        // A small error does not grow the step until it has been held four times.
        for k in 0..HOLD {
            assert_eq!(c.judge(0.1, 0.01), Verdict::Accept);
            let expected = if k + 1 < HOLD { 0.1 } else { 0.2 };
            assert!(
                (c.wanted - expected).abs() < 1e-12,
                "step {k}: {}",
                c.wanted
            );
        }
        // An error of 8 is rejected and the step cut to 0.9/2 of itself.
        assert_eq!(c.judge(0.2, 8.0), Verdict::Reject);
        assert!((c.wanted - 0.09).abs() < 1e-12);
        // Moderate growth proposals are ignored (hysteresis).
        for _ in 0..10 {
            c.judge(0.09, 0.5);
        }
        assert!((c.wanted - 0.09).abs() < 1e-12);
        // The step lands on a stop, and a short remainder is split evenly.
        assert!((c.step(0.0, 0.05) - 0.05).abs() < 1e-15);
        assert!((c.step(0.0, 0.15) - 0.075).abs() < 1e-15);
        assert!((c.step(0.0, 1.0) - 0.09).abs() < 1e-15);
        c.newton_failed(0.09);
        assert!((c.wanted - 0.0225).abs() < 1e-15);
    }
}
