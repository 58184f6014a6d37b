//! Generalized-α (paper §2.3, Algorithm 1): the scheme both engines step with.
//!
//! With pseudo-accelerations `a` (Eq. 9) and the Newmark formulae (Eq. 10–11),
//!
//! ```text
//! (1 − α_m) aₙ₊₁ + α_m aₙ = (1 − α_f) q̈ₙ₊₁ + α_f q̈ₙ,     a₀ = q̈₀
//! Δₙ   = h q̇ₙ + h²(½ − β) aₙ + h² β aₙ₊₁                  (the step's increment)
//! qₙ₊₁ = qₙ ⊕ Δₙ
//! q̇ₙ₊₁ = q̇ₙ + h(1 − γ) aₙ + h γ aₙ₊₁
//! ```
//!
//! each step solves the dynamic equilibrium and the constraints at `tₙ₊₁` by Newton's method
//! (Eq. 12–13), `β' = (1 − α_m)/(h² β (1 − α_f))`, `γ' = γ/(h β)`. Parameters come from the
//! spectral radius at infinite frequency `ρ∞` (Chung & Hulbert 1993).
//!
//! `⊕` is the configuration space's ([`crate::group::ConfigurationSpace`]): `qₙ + Δₙ` for the
//! planar engine's nodes (`x, y` and an additive angle: `SO(2)` is abelian), `qₙ ∘ exp(Δₙ)`
//! node by node on `(ℝ³ × SO(3))ⁿ` for the spatial engine's (Brüls, Cardona & Arnold, *Mech.
//! Mach. Theory* 48, 2012), where velocities and increments live in the algebra. [`step`] is
//! the algorithm's phases in order; what differs between the engines — the restart at a
//! drive's kink, Newton's start and its iterations, what makes a step implausible — is
//! [`Equations`]'s, which [`crate::Integrator`] and the spatial engine's
//! `SpatialIntegrator` implement.

use crate::error::SolveError;
use crate::solver::newton::{Forecast, NewtonReport};

/// Algorithmic parameters `α_m, α_f, β, γ`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AlphaParameters {
    /// `α_m`.
    pub alpha_m: f64,
    /// `α_f`.
    pub alpha_f: f64,
    /// `β`.
    pub beta: f64,
    /// `γ`.
    pub gamma: f64,
}

impl AlphaParameters {
    /// Chung–Hulbert parameters for spectral radius `ρ∞ ∈ [0, 1]`:
    /// `α_m = (2ρ∞ − 1)/(ρ∞ + 1)`, `α_f = ρ∞/(ρ∞ + 1)`, `γ = ½ + α_f − α_m`, `β = ¼(γ + ½)²`.
    /// Second order, unconditionally stable for linear problems, with maximal
    /// high-frequency dissipation for the given `ρ∞`.
    pub fn chung_hulbert(rho_inf: f64) -> Self {
        let alpha_m = (2.0 * rho_inf - 1.0) / (rho_inf + 1.0);
        let alpha_f = rho_inf / (rho_inf + 1.0);
        let gamma = 0.5 + alpha_f - alpha_m;
        Self {
            alpha_m,
            alpha_f,
            beta: 0.25 * (gamma + 0.5).powi(2),
            gamma,
        }
    }

    /// `β' = (1 − α_m)/(h² β (1 − α_f))`, the derivative `∂q̈_{n+1}/∂q_{n+1}`.
    pub fn beta_prime(&self, h: f64) -> f64 {
        (1.0 - self.alpha_m) / (h * h * self.beta * (1.0 - self.alpha_f))
    }

    /// `γ' = γ/(h β)`, the derivative `∂q̇_{n+1}/∂q_{n+1}`.
    pub fn gamma_prime(&self, h: f64) -> f64 {
        self.gamma / (h * self.beta)
    }

    /// The predictor of one unknown for a step of size `h` from `(q̇ₙ, q̈ₙ, aₙ)` with `q̈ₙ₊₁`
    /// guessed as `predicted` (Eq. 9–11): the increment `h q̇ₙ + h²((½ − β)aₙ + β aₙ₊₁)`,
    /// `q̇ₙ₊₁` and `aₙ₊₁` without its part `(1 − α_f)/(1 − α_m) q̈ₙ₊₁`, which the converged
    /// `q̈ₙ₊₁` adds at the end. Shared by the vector-space and the Lie-group steps and by
    /// their sensitivities (with `predicted = 0`: the unknown `q̈'ₙ₊₁` is all correction).
    pub(crate) fn predict(
        &self,
        h: f64,
        qdot: f64,
        qddot: f64,
        a: f64,
        predicted: f64,
    ) -> Predicted {
        let Self {
            alpha_m,
            alpha_f,
            beta,
            gamma,
        } = *self;
        let a_next = (alpha_f * qddot - alpha_m * a) / (1.0 - alpha_m);
        let a_predicted = a_next + (1.0 - alpha_f) / (1.0 - alpha_m) * predicted;
        Predicted {
            increment: h * qdot + h * h * ((0.5 - beta) * a + beta * a_predicted),
            qdot: qdot + h * ((1.0 - gamma) * a + gamma * a_predicted),
            a_next,
        }
    }
}

/// What [`AlphaParameters::predict`] gives for one unknown.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Predicted {
    /// `h q̇ₙ + h²((½ − β)aₙ + β aₙ₊₁)`: `qₙ₊₁ − qₙ`, or the Lie-group step's `Δ`.
    pub increment: f64,
    /// `q̇ₙ₊₁`.
    pub qdot: f64,
    /// `aₙ₊₁` without its part in `q̈ₙ₊₁`.
    pub a_next: f64,
}

/// Dynamic state at one time.
#[derive(Debug, Clone, PartialEq)]
pub struct State {
    /// Time (s).
    pub t: f64,
    /// Nodal coordinates `q` (displacements and rotations).
    pub q: Vec<f64>,
    /// Velocities `q̇`.
    pub qdot: Vec<f64>,
    /// Accelerations `q̈`.
    pub qddot: Vec<f64>,
    /// Pseudo-accelerations `a` (Eq. 9).
    pub a: Vec<f64>,
    /// Lagrange multipliers `λ`.
    pub lam: Vec<f64>,
    /// Size of the step that reached this state (0 at `t = 0`).
    pub h: f64,
    /// Where the Newton iterations of the step that reached this state ended (nowhere at
    /// the start): the next step's forecast, carried with the state so that a run replayed
    /// from any stored state, or a step taken again, iterates as it did.
    pub(crate) forecast: Forecast,
}

impl State {
    /// Takes `other`'s values, into this state's own storage (the same lengths): no
    /// allocation.
    pub(crate) fn assign(&mut self, other: &State) {
        (self.t, self.h, self.forecast) = (other.t, other.h, other.forecast);
        self.q.copy_from_slice(&other.q);
        self.qdot.copy_from_slice(&other.qdot);
        self.qddot.copy_from_slice(&other.qddot);
        self.a.copy_from_slice(&other.a);
        self.lam.copy_from_slice(&other.lam);
    }
}

/// What the predictor fills and reads: the step's increment `Δ` (one per velocity
/// coordinate), and which coordinates' accelerations start Newton at `q̈ₙ` — the others at
/// zero; `None`: every one at `q̈ₙ`.
pub(crate) struct Predictor<'a> {
    /// `Δ`.
    pub increment: &'a mut [f64],
    /// Where `q̈ₙ₊₁` starts at `q̈ₙ`.
    pub smooth: Option<&'a [bool]>,
}

/// What a step of Algorithm 1 asks of a mechanism's equations (either engine's).
pub(crate) trait Equations {
    /// The scheme's parameters.
    fn parameters(&self) -> AlphaParameters;

    /// Where the step from `s` begins on a kink of a drive's law: the restart there,
    /// `q̈ += Δq̈` and `a += Δq̈` ([`crate::solver::kink`]).
    ///
    /// # Errors
    /// [`SolveError::Singular`] if the mass matrix is singular on the constraint manifold.
    fn restart_at_kink(&mut self, s: &mut State) -> Result<(), SolveError>;

    /// Keeps `qₙ` and lends what the predictor fills and reads.
    fn begin(&mut self, q: &[f64]) -> Predictor<'_>;

    /// `q = qₙ ⊕ Δ` on the configuration space.
    fn retract(&self, q: &mut [f64]);

    /// Newton on Eq. 12–13 from the predicted state at `s.t`, with `β'` and `γ'`.
    ///
    /// # Errors
    /// [`SolveError`] when Newton does not converge or a matrix is singular.
    fn correct(
        &mut self,
        s: &mut State,
        beta_prime: f64,
        gamma_prime: f64,
    ) -> Result<NewtonReport, SolveError>;

    /// Whether the step from `qₙ` to `s` is one the scheme can follow (no node turned
    /// too far, no cell inside out).
    ///
    /// # Errors
    /// [`SolveError`] naming what is implausible and where.
    fn check_step(&self, s: &State) -> Result<(), SolveError>;
}

/// One step of size `h` from `s`, in place (Algorithm 1): the restart at a kink, the
/// pseudo-accelerations carried to the new step size, the predictor, Newton's corrections,
/// the step's plausibility and the last line, `aₙ₊₁ += (1 − α_f)/(1 − α_m) q̈ₙ₊₁`.
///
/// # Errors
/// [`SolveError::Interrupted`], and as the phases of [`Equations`].
pub(crate) fn step<E: Equations>(
    eq: &mut E,
    s: &mut State,
    h: f64,
) -> Result<NewtonReport, SolveError> {
    crate::interrupt::poll_at(s.t)?;
    let params = eq.parameters();
    eq.restart_at_kink(s)?;
    if let Some(ratio) = step_ratio(s.h, h) {
        rescale_pseudo_accelerations(&mut s.a, &s.qddot, ratio);
    }
    s.h = h;
    predict(eq, &params, s, h);
    s.t += h;
    let report = eq.correct(s, params.beta_prime(h), params.gamma_prime(h))?;
    eq.check_step(s)?;
    let w = (1.0 - params.alpha_f) / (1.0 - params.alpha_m);
    s.a.iter_mut()
        .zip(&s.qddot)
        .for_each(|(a, acc)| *a += w * acc);
    Ok(report)
}

/// The predictor (Eq. 9–11) from `qₙ` with `q̈ₙ₊₁` at Newton's start: `Δ`, `q̇ₙ₊₁`, `aₙ₊₁`
/// without its part in `q̈ₙ₊₁`, and `qₙ₊₁ = qₙ ⊕ Δ`.
fn predict<E: Equations>(eq: &mut E, params: &AlphaParameters, s: &mut State, h: f64) {
    let Predictor { increment, smooth } = eq.begin(&s.q);
    for (i, inc) in increment.iter_mut().enumerate() {
        let kept = smooth.is_none_or(|smooth| smooth[i]);
        let predicted = if kept { s.qddot[i] } else { 0.0 };
        let p = params.predict(h, s.qdot[i], s.qddot[i], s.a[i], predicted);
        *inc = p.increment;
        s.qdot[i] = p.qdot;
        s.a[i] = p.a_next;
        s.qddot[i] = predicted;
    }
    eq.retract(&mut s.q);
}

/// `hₙ/hₙ₋₁` when the step size changes (`None` for the first step or an unchanged one).
pub(crate) fn step_ratio(previous: f64, h: f64) -> Option<f64> {
    (previous > 0.0 && h != previous).then(|| h / previous)
}

/// Carries the pseudo-accelerations to a new step size: `aₙ ← q̈ₙ + (hₙ/hₙ₋₁)(aₙ − q̈ₙ)`.
///
/// `aₙ` approximates `q̈(tₙ + Δ_α hₙ₋₁)`, `Δ_α = α_m − α_f`, so `aₙ − q̈ₙ ≈ Δ_α hₙ₋₁ q⃛`;
/// the next step needs `q̈(tₙ + Δ_α hₙ)`. Without this the scheme drops to first order
/// wherever the step size changes by a finite ratio (for `Δ_α ≠ 0`, i.e. `ρ∞ < 1`).
pub(crate) fn rescale_pseudo_accelerations(a: &mut [f64], qddot: &[f64], ratio: f64) {
    a.iter_mut()
        .zip(qddot)
        .for_each(|(a, acc)| *a = acc + ratio * (*a - acc));
}
