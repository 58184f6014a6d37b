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
//!
//! A step that starts on a kink of a drive's law first restarts the scheme there: the
//! accelerations and pseudo-accelerations take the jump the new law's acceleration causes
//! ([`crate::solver::kink`]).
//!
//! Newton starts each step from `λ_{n+1} = λₙ`, and a rigid body's from `q̈_{n+1} = q̈ₙ`,
//! where Algorithm 1 starts from zero: the same solution, in fewer iterations (1.5 instead
//! of 2.4 per step on the rigid four-bar of BENCHMARKS.md, "Mechanisms"). A beam node's
//! accelerations carry the mesh's high frequencies: extrapolated over a large step they sent
//! the robot arm to another branch, so they start from zero.

use crate::error::SolveError;
use crate::mechanism::model::{Densities, Initial, Model};
use crate::settings::{DynamicSettings, NewtonMatrix, StaticSettings, MAX_CUTS};
use crate::solver::kink::{Jump, Kinks};
use crate::solver::newton::{Newton, NewtonReport, Point};
use crate::solver::statics::{solve_static, StaticSolution};

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
}

/// The generalized-α integrator of one design. The step size is an argument of each step,
/// so a run may follow any [`crate::time_grid::TimeGrid`].
pub struct Integrator<'m> {
    /// Newton machinery.
    pub(crate) newton: Newton<'m>,
    /// Algorithmic parameters.
    pub params: AlphaParameters,
    /// `qₙ` of the step under way, to judge its rotations.
    start: Vec<f64>,
    /// The DOFs whose Newton iterations start from `q̈ₙ`: the rigid bodies'.
    smooth: Vec<bool>,
    /// How the static equilibrium of an [`Initial::Equilibrium`] start is solved.
    statics: Option<StaticSettings>,
    /// That equilibrium, once [`Integrator::initial_state`] has solved it: the start `q₀(x)`
    /// of the gradients.
    pub(crate) equilibrium: Option<StaticSolution>,
    /// Where the drives' accelerations jump.
    kinks: Kinks,
    /// The restart the last step began with, if it began on a kink.
    pub(crate) restart: Option<Jump>,
}

impl<'m> Integrator<'m> {
    /// Integrator of `model` with element scalings `densities`.
    ///
    /// # Errors
    /// As [`Newton::new`].
    pub fn new(
        model: &'m Model,
        densities: Densities,
        settings: &DynamicSettings,
    ) -> Result<Self, SolveError> {
        let mut newton = Newton::new(
            model,
            densities,
            settings.mass,
            settings.tol,
            settings.max_iter,
        )?;
        newton.keep_matrix(settings.newton == NewtonMatrix::Modified);
        let params = AlphaParameters::chung_hulbert(settings.rho_inf);
        let statics = (model.initial == Initial::Equilibrium).then(|| StaticSettings {
            load_steps: model.defaults.load_steps.unwrap_or(1),
            time: 0.0,
            tol: settings.tol,
            max_iter: settings.max_iter,
            newton: settings.newton,
            max_cuts: MAX_CUTS,
        });
        Ok(Self {
            newton,
            params,
            start: vec![0.0; model.n_dofs()],
            smooth: rigid_dofs(model),
            statics,
            equilibrium: None,
            kinks: Kinks::of(model),
            restart: None,
        })
    }

    /// The jump of accelerations at `q`, time `t` reached by a step of size `h`, if a
    /// drive's acceleration jumps there ([`Kinks::jump_at`], [`Jump::solve`]).
    ///
    /// # Errors
    /// [`SolveError::Singular`] if `M` is singular on the constraint manifold.
    pub(crate) fn jump_at(
        &mut self,
        q: &[f64],
        t: f64,
        h: f64,
    ) -> Result<Option<Jump>, SolveError> {
        let model = self.newton.assembler().model;
        match self.kinks.jump_at(model, t, h) {
            Some((kink, dg)) => Jump::solve(&mut self.newton, q, kink, &dg).map(Some),
            None => Ok(None),
        }
    }

    /// The assembler of the design: forces, matrices, the model and its densities.
    pub fn assembler(&self) -> &crate::solver::assembly::Assembler<'m> {
        self.newton.assembler()
    }

    /// State at `t = 0`: undeformed or in the static equilibrium of `t = 0` with the drives
    /// held (the model's [`Initial`]), at rest or in the rigid motion of the scene's initial
    /// rates, with consistent accelerations and multipliers
    /// ([`Newton::initial_accelerations`]).
    ///
    /// # Errors
    /// [`SolveError::Singular`] if the mass matrix is singular on the constraint manifold;
    /// the static solve's errors for an equilibrium start.
    pub fn initial_state(&mut self) -> Result<State, SolveError> {
        let asm = self.newton.assembler();
        let n_q = asm.model.n_dofs();
        self.equilibrium = match &self.statics {
            Some(settings) => Some(solve_static(asm.model, asm.densities.clone(), settings)?),
            None => None,
        };
        let q = self
            .equilibrium
            .as_ref()
            .map_or_else(|| vec![0.0; n_q], |e| e.q.clone());
        let model = self.newton.assembler().model;
        let qdot = if model.initial_velocity.is_empty() {
            vec![0.0; n_q]
        } else {
            model.initial_velocity.clone()
        };
        let (qddot, lam) = self.newton.initial_accelerations(&q, &qdot)?;
        Ok(State {
            t: 0.0,
            q,
            qdot,
            a: qddot.clone(),
            qddot,
            lam,
            h: 0.0,
        })
    }

    /// One step of Algorithm 1 from `s` (time `t_n`) to `t_{n+1} = t_n + h`, in place.
    /// `β'` and `γ'`, and with them the constraint scaling, follow `h`; after a change of
    /// step size `a` is first carried to the new step ([`rescale_pseudo_accelerations`]).
    ///
    /// # Errors
    /// [`SolveError::NewtonFailed`] with time, residual and iterations when Newton does not
    /// converge; [`SolveError::Diverged`] when the step turns a node by more than π/2;
    /// [`SolveError::Singular`] for a singular iteration matrix;
    /// [`SolveError::Interrupted`] when the caller asked to stop ([`crate::with_checker`]).
    pub fn alpha_step(&mut self, s: &mut State, h: f64) -> Result<NewtonReport, SolveError> {
        self.alpha_step_from(s, h, None)
    }

    /// [`Integrator::alpha_step`] with Newton started from `guess` for `q_{n+1}` instead
    /// of the predictor, `q̇` and `q̈` moved with it as a Newton increment moves them
    /// (`γ'Δq`, `β'Δq`): the same step to Newton's tolerance, in fewer iterations when the
    /// guess is close (a nearby run's state, [`crate::simulate_guided`]).
    ///
    /// # Errors
    /// As [`Integrator::alpha_step`].
    pub fn alpha_step_from(
        &mut self,
        s: &mut State,
        h: f64,
        guess: Option<&[f64]>,
    ) -> Result<NewtonReport, SolveError> {
        crate::interrupt::poll_at(s.t)?;
        let AlphaParameters {
            alpha_m, alpha_f, ..
        } = self.params;
        let (bp, gp) = (self.params.beta_prime(h), self.params.gamma_prime(h));
        self.restart = self.jump_at(&s.q, s.t, s.h)?;
        if let Some(jump) = &self.restart {
            jump.apply(&mut s.qddot, &mut s.a);
        }
        if let Some(ratio) = step_ratio(s.h, h) {
            rescale_pseudo_accelerations(&mut s.a, &s.qddot, ratio);
        }
        s.h = h;
        self.start.copy_from_slice(&s.q);
        for i in 0..s.q.len() {
            let predicted = if self.smooth[i] { s.qddot[i] } else { 0.0 };
            let p = self
                .params
                .predict(h, s.qdot[i], s.qddot[i], s.a[i], predicted);
            s.q[i] += p.increment;
            s.qdot[i] = p.qdot;
            s.a[i] = p.a_next;
            s.qddot[i] = predicted;
        }
        s.t += h;
        let point = Point {
            t: s.t,
            load: 1.0,
            mass_coefficient: bp,
            gamma_prime: gp,
        };
        if let Some(guess) = guess {
            for (i, (q, g)) in s.q.iter_mut().zip(guess).enumerate() {
                s.qdot[i] += gp * (g - *q);
                s.qddot[i] += bp * (g - *q);
                *q = *g;
            }
        }
        let report = self.newton.solve(
            point,
            &mut s.q,
            &mut s.lam,
            Some((&mut s.qdot, &mut s.qddot)),
        )?;
        let asm = self.newton.assembler();
        let at = || format!("t = {:.6} s", s.t);
        (asm.model).plausible_step(&asm.densities, &self.start, &s.q, at)?;
        // Last line of Algorithm 1: a_{n+1} += (1 − α_f)/(1 − α_m) q̈_{n+1}.
        let w = (1.0 - alpha_f) / (1.0 - alpha_m);
        s.a.iter_mut()
            .zip(&s.qddot)
            .for_each(|(a, acc)| *a += w * acc);
        Ok(report)
    }
}

/// Which DOFs belong to a rigid body.
fn rigid_dofs(model: &Model) -> Vec<bool> {
    let mut rigid = vec![false; model.n_dofs()];
    for b in &model.bodies {
        rigid[3 * b.node..3 * b.node + 3].fill(true);
    }
    rigid
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
