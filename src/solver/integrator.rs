//! The planar engine's generalized-α integrator (paper §2.3, Algorithm 1, whose phases are
//! [`crate::solver::alpha::step`]'s) on the index-3 equations of motion.
//!
//! Each step solves the dynamic equilibrium `r = M(q̈ − ĝ) + f_int(q) − f_ext(t) + Φ_qᵀλ = 0`
//! and `Φ(q, t) = 0` at `tₙ₊₁` by Newton's method with the exact iteration matrix
//! `[β'M + K_t, Φ_qᵀ; Φ_q, 0]` (Eq. 12–13) on the additive configuration space
//! ([`crate::group::Additive`]). Gravity `ĝ` enters as a DOF-wise acceleration, so `M ĝ` is
//! the consistent gravity load.
//!
//! A step that starts on a kink of a drive's law first restarts the scheme there: the
//! accelerations and pseudo-accelerations take the jump the new law's acceleration causes
//! ([`crate::solver::kink`]).
//!
//! Newton starts each step from `λₙ₊₁ = λₙ`, and a rigid body's from `q̈ₙ₊₁ = q̈ₙ`,
//! where Algorithm 1 starts from zero: the same solution, in fewer iterations (1.5 instead
//! of 2.4 per step on the rigid four-bar of BENCHMARKS.md, "Mechanisms"). A beam node's
//! accelerations carry the mesh's high frequencies: extrapolated over a large step they sent
//! the robot arm to another branch, so they start from zero. A continuum member's nodes
//! (those no beam reaches) start from `q̈ₙ` too (4.8–5.2 iterations per step instead of
//! 5.6–6.9 on the continuum arm's uniform, random and solid designs, BENCHMARKS.md
//! "Continuum links"); a step that fails so — Newton, or the step's plausibility — is taken
//! again with them from zero, as before (a void and solid mix stalled at 1.5 times the
//! tolerance with them extrapolated), its report counting both attempts' iterations.

use crate::error::SolveError;
use crate::group::{Additive, ConfigurationSpace};
use crate::mechanism::model::{Densities, Initial, Model};
use crate::settings::{DynamicSettings, NewtonMatrix, StaticSettings, MAX_CUTS};
use crate::solver::alpha::{self, AlphaParameters, Equations, Predictor, State};
use crate::solver::kink::{Jump, Kinks};
use crate::solver::newton::{Forecast, Newton, NewtonReport, Point};
use crate::solver::statics::{solve_static, StaticSolution};

/// The generalized-α integrator of one design. The step size is an argument of each step,
/// so a run may follow any [`crate::time_grid::TimeGrid`].
pub struct Integrator<'m> {
    /// Newton machinery.
    pub(crate) newton: Newton<'m>,
    /// Algorithmic parameters.
    pub params: AlphaParameters,
    /// `qₙ` of the step under way, to judge its rotations.
    start: Vec<f64>,
    /// The step's increment `qₙ₊₁ − qₙ` as predicted.
    increment: Vec<f64>,
    /// The DOFs whose Newton iterations start from `q̈ₙ`: the rigid bodies' and the
    /// continuum members' nodes'.
    smooth: Vec<bool>,
    /// The rigid bodies' alone: a failed step's second start.
    rigid: Vec<bool>,
    /// Whether a step can start two ways: the model has members' nodes in `smooth`.
    two_starts: bool,
    /// The state a step starts from, kept for its second start (none without members'
    /// nodes to start two ways).
    before: Option<State>,
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
        let (smooth, rigid) = (smooth_dofs(model), rigid_dofs(model));
        Ok(Self {
            newton,
            params,
            start: vec![0.0; model.n_dofs()],
            increment: vec![0.0; model.n_dofs()],
            two_starts: smooth != rigid,
            smooth,
            rigid,
            before: None,
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
            forecast: Forecast::default(),
        })
    }

    /// One step of Algorithm 1 from `s` (time `t_n`) to `t_{n+1} = t_n + h`, in place.
    /// `β'` and `γ'`, and with them the constraint scaling, follow `h`; after a change of
    /// step size `a` is first carried to the new step ([`crate::solver::alpha::rescale_pseudo_accelerations`]).
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
        if !self.two_starts {
            return alpha::step(&mut Guided::new(self, guess, false), s, h);
        }
        let mut before = self.before.take().unwrap_or_else(|| s.clone());
        before.assign(s);
        let first = alpha::step(&mut Guided::new(self, guess, false), s, h);
        let result = match first {
            Err(e) if again(&e) => {
                s.assign(&before);
                let spent = match e {
                    SolveError::NewtonFailed { iterations, .. } => iterations,
                    _ => 0,
                };
                let second = alpha::step(&mut Guided::new(self, guess, true), s, h);
                second.map(|r| NewtonReport {
                    iterations: r.iterations + spent,
                    ..r
                })
            }
            first => first,
        };
        self.before = Some(before);
        result
    }
}

/// A planar step's equations, Newton started from a guess where one is given, and the
/// members' nodes' accelerations from zero where `cautious`.
struct Guided<'a, 'm> {
    it: &'a mut Integrator<'m>,
    guess: Option<&'a [f64]>,
    cautious: bool,
}

impl<'a, 'm> Guided<'a, 'm> {
    fn new(it: &'a mut Integrator<'m>, guess: Option<&'a [f64]>, cautious: bool) -> Self {
        Self {
            it,
            guess,
            cautious,
        }
    }
}

impl Equations for Guided<'_, '_> {
    fn parameters(&self) -> AlphaParameters {
        self.it.params
    }

    fn restart_at_kink(&mut self, s: &mut State) -> Result<(), SolveError> {
        self.it.restart = self.it.jump_at(&s.q, s.t, s.h)?;
        if let Some(jump) = &self.it.restart {
            jump.apply(&mut s.qddot, &mut s.a);
        }
        Ok(())
    }

    fn begin(&mut self, q: &[f64]) -> Predictor<'_> {
        self.it.start.copy_from_slice(q);
        let smooth = if self.cautious {
            &self.it.rigid
        } else {
            &self.it.smooth
        };
        Predictor {
            increment: &mut self.it.increment,
            smooth: Some(smooth),
        }
    }

    fn retract(&self, q: &mut [f64]) {
        Additive.retract(&self.it.start, &self.it.increment, q);
    }

    fn correct(&mut self, s: &mut State, bp: f64, gp: f64) -> Result<NewtonReport, SolveError> {
        if let Some(guess) = self.guess {
            for (i, (q, g)) in s.q.iter_mut().zip(guess).enumerate() {
                s.qdot[i] += gp * (g - *q);
                s.qddot[i] += bp * (g - *q);
                *q = *g;
            }
        }
        let point = Point {
            t: s.t,
            load: 1.0,
            mass_coefficient: bp,
            gamma_prime: gp,
        };
        let velocities = Some((&mut s.qdot[..], &mut s.qddot[..]));
        (self.it.newton).solve(point, &mut s.q, &mut s.lam, velocities, &mut s.forecast)
    }

    fn check_step(&self, s: &State) -> Result<(), SolveError> {
        let asm = self.it.newton.assembler();
        let at = || format!("t = {:.6} s", s.t);
        (asm.model).plausible_step(&asm.densities, &self.it.start, &s.q, at)
    }
}

/// Whether a step that failed with `e` is taken again with the members' nodes' accelerations
/// from zero: where Newton failed or its solution was not plausible.
fn again(e: &SolveError) -> bool {
    matches!(
        e,
        SolveError::NewtonFailed { .. }
            | SolveError::Diverged { .. }
            | SolveError::SpringCollapsed { .. }
            | SolveError::CellInverted { .. }
    )
}

/// Which DOFs belong to a rigid body or to a continuum member's node that no beam reaches.
fn smooth_dofs(model: &Model) -> Vec<bool> {
    let mut smooth = vec![false; model.n_dofs()];
    for d in model.cells.iter().flat_map(|c| c.dofs()) {
        smooth[d] = true;
    }
    for d in model.elements.iter().flat_map(|e| e.dofs()) {
        smooth[d] = false;
    }
    for b in &model.bodies {
        smooth[3 * b.node..3 * b.node + 3].fill(true);
    }
    smooth
}

/// Which DOFs belong to a rigid body.
fn rigid_dofs(model: &Model) -> Vec<bool> {
    let mut rigid = vec![false; model.n_dofs()];
    for b in &model.bodies {
        rigid[3 * b.node..3 * b.node + 3].fill(true);
    }
    rigid
}
