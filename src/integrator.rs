//! The generalized-α method on the index-3 equations of motion (paper §2.3, Algorithm 1).
//!
//! With pseudo-accelerations `a` (Eq. 9) and the Newmark formulae (Eq. 10–11),
//!
//! ```text
//! (1 − α_m) a_{n+1} + α_m a_n = (1 − α_f) q̈_{n+1} + α_f q̈_n,     a_0 = q̈_0
//! q_{n+1} = q_n + h q̇_n + h²(½ − β) a_n + h² β a_{n+1}
//! q̇_{n+1} = q̇_n + h(1 − γ) a_n + h γ a_{n+1}
//! ```
//!
//! each step solves the dynamic equilibrium `r = M(q̈ − ĝ) + f_int(q) − f_ext(t) + Φ_qᵀλ = 0`
//! and `Φ(q, t) = 0` at `t_{n+1}` by Newton's method with the exact iteration matrix
//! `[β'M + K_t, Φ_qᵀ; Φ_q, 0]` (Eq. 12–13), `β' = (1 − α_m)/(h² β (1 − α_f))`,
//! `γ' = γ/(h β)`. Parameters come from the spectral radius at infinite frequency `ρ∞`
//! (Chung & Hulbert 1993). Gravity `ĝ` enters as a DOF-wise acceleration, so `M ĝ` is
//! the consistent gravity load.

use crate::element::MassKind;
use crate::error::{SettingsError, SolveError};
use crate::model::{Densities, Model};
use crate::newton::{Newton, NewtonReport, Point};

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
}

/// Most steps a run may take.
pub const MAX_STEPS: usize = 100_000_000;

/// Settings of a time integration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
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
    /// Inertia discretization.
    pub mass: MassKind,
}

impl Settings {
    /// Checks ranges.
    ///
    /// # Errors
    /// A [`SettingsError`] naming the setting.
    pub fn validate(&self) -> Result<(), SettingsError> {
        let bad = |n: &str, m: String| Err(SettingsError::new(n, m));
        if !(self.h.is_finite() && self.h > 0.0) {
            return bad(
                "h",
                format!("step size must be positive and finite, got {}", self.h),
            );
        }
        if !(self.t_end.is_finite() && self.t_end > 0.0) {
            return bad(
                "t_end",
                format!("must be positive and finite, got {}", self.t_end),
            );
        }
        if self.h > self.t_end {
            return bad(
                "h",
                format!("step size {} exceeds t_end {}", self.h, self.t_end),
            );
        }
        if !(0.0..=1.0).contains(&self.rho_inf) {
            return bad(
                "rho_inf",
                format!("must lie in [0, 1], got {}", self.rho_inf),
            );
        }
        if !(self.tol.is_finite() && self.tol > 0.0 && self.tol < 1.0) {
            return bad("tol", format!("must lie in (0, 1), got {}", self.tol));
        }
        if self.max_iter == 0 {
            return bad("max_iter", "must be at least 1".into());
        }
        if self.t_end / self.h > MAX_STEPS as f64 {
            return bad(
                "h",
                format!(
                    "t_end / h = {:.3e} steps; at most {MAX_STEPS:.0e} are allowed",
                    self.t_end / self.h
                ),
            );
        }
        Ok(())
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

    /// The step size used: `h`, shortened if needed so that [`Settings::steps`] steps end
    /// exactly at `t_end`.
    pub fn step(&self) -> f64 {
        self.t_end / self.steps() as f64
    }
}

/// Dynamic state at one time.
#[derive(Debug, Clone, PartialEq)]
pub struct State {
    /// Time (s).
    pub t: f64,
    /// Nodal coordinates `q` (displacements and rotations).
    pub q: Vec<f64>,
    /// Velocities `q̇`.
    pub v: Vec<f64>,
    /// Accelerations `q̈`.
    pub acc: Vec<f64>,
    /// Pseudo-accelerations `a` (Eq. 9).
    pub a: Vec<f64>,
    /// Lagrange multipliers `λ`.
    pub lambda: Vec<f64>,
}

/// The generalized-α integrator of one design.
pub struct Integrator<'m> {
    /// Newton machinery.
    pub newton: Newton<'m>,
    /// Algorithmic parameters.
    pub params: AlphaParameters,
    /// Step size ([`Settings::step`]).
    pub h: f64,
}

impl<'m> Integrator<'m> {
    /// Integrator of `model` with element scalings `densities`.
    pub fn new(model: &'m Model, densities: Densities, settings: &Settings) -> Self {
        let mut newton = Newton::new(
            model,
            densities,
            settings.mass,
            settings.tol,
            settings.max_iter,
        );
        let params = AlphaParameters::chung_hulbert(settings.rho_inf);
        let q0 = vec![0.0; model.n_dofs()];
        let h = settings.step();
        newton.scale = params.beta_prime(h) * newton.asm.mean_mass_diagonal()
            + newton.asm.mean_stiffness_diagonal(&q0);
        Self { newton, params, h }
    }

    /// State at `t = 0`: undeformed, at rest, with consistent accelerations and multipliers
    /// from `[M, Φ_qᵀ; Φ_q, 0] [q̈₀; λ₀] = [M ĝ + f_ext(0) − f_int(q₀); g̈(0)]`.
    ///
    /// # Errors
    /// [`SolveError::Singular`] if the mass matrix is singular on the constraint manifold.
    pub fn initial_state(&mut self) -> Result<State, SolveError> {
        let model = self.newton.asm.model;
        let (n_q, n_c) = (model.n_dofs(), model.n_constraints());
        let q = vec![0.0; n_q];
        let (acc, lambda) = self.newton.initial_accelerations(&q, n_c)?;
        Ok(State {
            t: 0.0,
            q,
            v: vec![0.0; n_q],
            a: acc.clone(),
            acc,
            lambda,
        })
    }

    /// One step of Algorithm 1 from `s` (time `t_n`) to `t_{n+1} = t_n + h`, in place.
    ///
    /// # Errors
    /// [`SolveError::NewtonFailed`] with time, residual and iterations when Newton does not
    /// converge; [`SolveError::Singular`] for a singular iteration matrix.
    pub fn alpha_step(&mut self, s: &mut State) -> Result<NewtonReport, SolveError> {
        let AlphaParameters {
            alpha_m,
            alpha_f,
            beta,
            gamma,
        } = self.params;
        let h = self.h;
        let (bp, gp) = (self.params.beta_prime(h), self.params.gamma_prime(h));
        for i in 0..s.q.len() {
            let a_next = (alpha_f * s.acc[i] - alpha_m * s.a[i]) / (1.0 - alpha_m);
            s.q[i] += h * s.v[i] + h * h * ((0.5 - beta) * s.a[i] + beta * a_next);
            s.v[i] += h * ((1.0 - gamma) * s.a[i] + gamma * a_next);
            s.a[i] = a_next;
            s.acc[i] = 0.0;
        }
        s.lambda.fill(0.0);
        s.t += h;
        let point = Point {
            t: s.t,
            load: 1.0,
            mass_coefficient: bp,
            gamma_prime: gp,
        };
        let report = self.newton.solve_point(
            point,
            &mut s.q,
            &mut s.lambda,
            Some((&mut s.v, &mut s.acc)),
        )?;
        // Last line of Algorithm 1: a_{n+1} += (1 − α_f)/(1 − α_m) q̈_{n+1}.
        let w = (1.0 - alpha_f) / (1.0 - alpha_m);
        s.a.iter_mut()
            .zip(&s.acc)
            .for_each(|(a, acc)| *a += w * acc);
        Ok(report)
    }
}
