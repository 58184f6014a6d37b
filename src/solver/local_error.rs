//! Generalized-α's local errors, and what they add up to in a response: the time error
//! `f(h) − f` estimated from one run and its adjoint sweep ([`crate::solver::backward`]),
//! for both engines.
//!
//! With `aₙ ≈ q̈(tₙ + Δ_α h) + κh² q⁗` (`Δ_α = α_m − α_f`, `κ = (1 − α_f)/2 −
//! (1 − α_m)(½ + Δ_α)`, what makes the recurrence of `a` exact to `O(h³)`), a step from the
//! exact state makes
//!
//! ```text
//! l_q = (β − γ/2 + 1/12) h³ q⃛ ≈ c_q h² (q̈ₙ₊₁ − q̈ₙ)          (the position update's error)
//! l_v = (κ + γ/2 + γΔ_α − 1/6) h³ q⁗ ≈ c_v h³ Δq⃛ / h̄     (the velocity update's)
//! ```
//!
//! (`q̈ₙ` after a restart's jump, `q⃛` of a step `(q̈ₙ₊₁ − q̈ₙ)/h`, its change to the next
//! step's over their mean size; none on the last step). On the rotation group the position
//! update is the increment `Δ` of `qₙ₊₁ = qₙ ∘ exp(Δ)`, whose exact value has the further
//! term `(h³/12) ω × ω̇` (Magnus), so there `l_Δ = c_q h³ ω̈ − (h³/12) ω × ω̇`.
//!
//! The step's equilibrium then has the residual `τ = −(β'M + γ'C) l_q + C l_v` on the exact
//! motion, and a response moves by `q̄ᵀ l_q + q̄̇ᵀ l_v − q̃ᵀ l_q − μᵀτ` (the adjoint variables
//! of the state after the step, `q̃` the total adjoint of its positions, `μ` the
//! equilibrium's): each engine's sweep adds that up ([`LocalErrors::errors`]); summed over
//! the steps, with the trapezoidal rule's own error on a time sum
//! ([`LocalErrors::add_quadrature`]), it is `f(h) − f` to leading order.

use crate::solver::alpha::AlphaParameters;

/// The local errors of one step at a time in a backward sweep, and each response's sum.
pub(crate) struct LocalErrors {
    c_q: f64,
    c_v: f64,
    /// `q̈ₙ₊₁` and `q̈ₙ` of the step.
    pub next: Vec<f64>,
    pub now: Vec<f64>,
    /// `q⃛` of the step and of the step after it.
    jerk: Vec<f64>,
    jerk_after: Vec<f64>,
    /// The step's `l_q` and `l_v`.
    pub lq: Vec<f64>,
    pub lv: Vec<f64>,
    /// Each response's estimated time error so far.
    pub errors: Vec<f64>,
    /// Each response's integrand `G` at the states `N`, `N − 1`, `1` and `0` (`None` for a
    /// response that is not a time sum).
    pub ends: Vec<[Option<f64>; 4]>,
}

impl LocalErrors {
    /// For a scheme of `params`, `n` unknowns of velocity and `n_r` responses.
    pub fn new(params: &AlphaParameters, n: usize, n_r: usize) -> Self {
        let AlphaParameters {
            alpha_m,
            alpha_f,
            beta,
            gamma,
        } = *params;
        let lag = alpha_m - alpha_f;
        let kappa = 0.5 * (1.0 - alpha_f) - (1.0 - alpha_m) * (0.5 + lag);
        Self {
            c_q: beta - 0.5 * gamma + 1.0 / 12.0,
            c_v: kappa + 0.5 * gamma + gamma * lag - 1.0 / 6.0,
            next: vec![0.0; n],
            now: vec![0.0; n],
            jerk: vec![0.0; n],
            jerk_after: vec![0.0; n],
            lq: vec![0.0; n],
            lv: vec![0.0; n],
            errors: vec![0.0; n_r],
            ends: vec![[None; 4]; n_r],
        }
    }

    /// `l_q` and `l_v` of a step of size `h` from `now` to `next`, the step after it of
    /// size `after` (`None` on the last). Called for the steps in reverse.
    pub fn of_step(&mut self, h: f64, after: Option<f64>) {
        let h3 = h * h * h;
        for i in 0..self.lq.len() {
            self.jerk[i] = (self.next[i] - self.now[i]) / h;
            self.lq[i] = self.c_q * h3 * self.jerk[i];
            self.lv[i] = after.map_or(0.0, |h1| {
                self.c_v * h3 * (self.jerk_after[i] - self.jerk[i]) / (0.5 * (h + h1))
            });
        }
        std::mem::swap(&mut self.jerk, &mut self.jerk_after);
    }

    /// Where state `n` of a run of `last` steps is one of the ends the trapezoidal rule's
    /// error reads: its place in [`LocalErrors::ends`].
    pub fn end_of(n: usize, last: usize) -> Option<usize> {
        let ends = [Some(last), last.checked_sub(1), Some(1), Some(0)];
        ends.iter().position(|&m| m == Some(n))
    }

    /// Adds the trapezoidal rule's own error to each time sum's: the rule over `[0, t_f]`
    /// exceeds the integral by `(h²/12)(G'(t_f) − G'(0))` to leading order (Euler–Maclaurin),
    /// read off the integrands at the ends, `(1/12)(h_{N−1}(G_N − G_{N−1}) − h₀(G₁ − G₀))`
    /// (`first` and `last` the run's first and last step).
    pub fn add_quadrature(&mut self, first: f64, last: f64) {
        for (e, ends) in self.errors.iter_mut().zip(&self.ends) {
            if let [Some(g_n), Some(g_before), Some(g_1), Some(g_0)] = *ends {
                *e += (last * (g_n - g_before) - first * (g_1 - g_0)) / 12.0;
            }
        }
    }
}
