//! Generalized-α on the Lie group `(ℝ³ × SO(3))ⁿ` (Brüls, Cardona & Arnold, *Mech. Mach.
//! Theory* 48, 2012, Algorithm 1 there), index-3 constraints with Lagrange multipliers.
//!
//! The vector-space scheme of the paper (§2.3, [`crate::Integrator`]) with the update of
//! positions replaced by a motion on the group: with velocities `v` and accelerations `v̇` in
//! the algebra and the same parameters `α_m, α_f, β, γ` ([`AlphaParameters`]),
//!
//! ```text
//! Δₙ   = h vₙ + h²(½ − β) aₙ + h² β aₙ₊₁            (the step's increment)
//! qₙ₊₁ = qₙ ∘ exp(Δₙ)                               (node by node, [`Frame::retract`])
//! vₙ₊₁ = vₙ + h(1 − γ) aₙ + h γ aₙ₊₁
//! (1 − α_m) aₙ₊₁ + α_m aₙ = (1 − α_f) v̇ₙ₊₁ + α_f v̇ₙ
//! ```
//!
//! Newton solves `f_inertia(v, v̇) + f_forces(q, v, t) + Bᵀλ = 0`, `Φ(qₙ₊₁) = 0` for the correction `δ` of `Δₙ`:
//! `Δ += δ`, `v += γ' δ`, `v̇ += β' δ` (`β'`, `γ'` as in the vector-space scheme), with the
//! iteration matrix of `assembly.rs` factored ([`Unsymmetric`]: `LU` by the nodes' and
//! joints' blocks) at every iteration or, with the
//! modified Newton matrix, at a step's first and then only where the held factors contract the
//! residual less than tenfold ([`crate::solver::newton::KEPT_CONTRACTION`]; 1.7 times faster on the paper's arm). On `ℝ³` (and the
//! planar engine's additive angle) `T = I` and this is the vector-space step.
//!
//! The start is consistent: `M v̇₀ + Bᵀλ₀ = −f(q₀, v₀)`, `B v̇₀ = −b(q₀, v₀)`, and `a₀ = v̇₀`.
//! A step that begins on a kink of a drive's law, where its acceleration jumps, first
//! restarts the scheme there as the planar engine does.

use crate::error::{short, Error, SettingsError, SolveError};
use crate::group::{ConfigurationSpace, Frames, NV};
use crate::settings::{DynamicSettings, NewtonMatrix, RunOptions};
use crate::solver::alpha::{self, AlphaParameters, Equations, Predictor, State};
use crate::solver::kink::{jumps, Kinks};
use crate::solver::linsolve::FactorError;
use crate::solver::newton::{self, at_round_off, Forecast, NewtonReport, Residual, System};
use crate::solver::unsymmetric::Unsymmetric;
use crate::spatial::assembly::{analysed, Assembler, Coefficients};
use crate::spatial::element::Element;
use crate::spatial::model::SpatialModel;
use crate::TimeGrid;

/// The largest rotation one step may give a node (rad): beyond it the step is too large for
/// the motion (the tangent operator is singular at 2π).
pub const MAX_STEP_ROTATION: f64 = std::f64::consts::PI;

/// A bar at this share of its Euler load or more (compression over the pin-ended Euler
/// load of its bar, [`Element::buckling`]) when a step whose Newton fails began is named
/// in the failure ([`SolveError::Buckled`]): on the spatial robot arm at uniform 0.2 its
/// one-element bars pass 1.0 at t ≈ 0.125 s and Newton diverges from 0.135 s on, at
/// every step size.
pub const BUCKLING_HINT: f64 = 0.9;

/// The kinks of `model`'s drives.
pub(crate) fn kinks(model: &SpatialModel) -> Kinks {
    Kinks::from_times(model.joints.iter().flat_map(|j| j.drive_kinks()))
}

/// The restart's jump at state `s` on `kink`: the rows' `b` read on either side of it into
/// `jump`, and `[M, sBᵀ; sB, 0][Δv̇; Δν] = [0; −s Δb]` solved into `rhs` (`s` the mean mass,
/// the matrix factored into `solver`); `false` where no row's `b` jumps.
///
/// # Errors
/// [`SolveError::Singular`] if the mass matrix is singular on the constraint manifold.
pub(crate) fn kink_jump(
    asm: &mut Assembler<'_>,
    solver: &mut Unsymmetric,
    s: &State,
    kink: f64,
    jump: &mut [Vec<f64>; 2],
    rhs: &mut [f64],
) -> Result<bool, SolveError> {
    let model = asm.model;
    let mut row = 0;
    for j in &model.joints {
        let n = j.n_rows();
        // The law's two pieces, read on either side of the kink itself (the state's time
        // may lie a rounding off it, on either side).
        for (side, t) in [kink.next_down(), kink.next_up()].into_iter().enumerate() {
            j.acceleration_terms(&s.q, &s.qdot, t, &mut jump[side][row..row + n]);
        }
        row += n;
    }
    let n_v = model.n_v();
    let scale = asm.mean_mass();
    let [before, after] = &*jump;
    let mut any = false;
    for (r, (b, a)) in rhs[n_v..].iter_mut().zip(before.iter().zip(after)) {
        let jumped = jumps(*b, *a);
        *r = if jumped { -scale * (a - b) } else { 0.0 };
        any |= jumped;
    }
    if !any {
        return Ok(false);
    }
    rhs[..n_v].fill(0.0);
    let c = Coefficients {
        beta_prime: 1.0,
        gamma_prime: 0.0,
        scale,
        tangent: None,
    };
    asm.matrix(&s.q, &s.qdot, s.t, c)?;
    let singular = |e: FactorError| SolveError::Singular {
        time: s.t,
        detail: format!("{e:?}"),
    };
    solver.factorize(&asm.values).map_err(singular)?;
    solver.solve_in_place(rhs, false).map_err(singular)?;
    Ok(true)
}

/// The Lie-group generalized-α integrator of a spatial mechanism.
pub struct SpatialIntegrator<'m> {
    asm: Assembler<'m>,
    lu: Unsymmetric,
    /// Algorithmic parameters.
    pub params: AlphaParameters,
    tol: f64,
    max_iter: usize,
    /// Whether a step's first factorization is kept while it contracts (modified Newton).
    keep: bool,
    /// `qₙ` of the step under way.
    start: Vec<f64>,
    /// The step's increment `Δ`.
    increment: Vec<f64>,
    /// Residual, then Newton's correction.
    rhs: Vec<f64>,
    /// Where the drives' laws are not smooth.
    kinks: Kinks,
    /// The drives' acceleration terms `b` just before and just after a kink.
    jump: [Vec<f64>; 2],
    /// How many steps began with a restart at a kink.
    restarts: usize,
    /// Whether the last residual's pass assembled the iteration matrix at its iterate.
    assembled: bool,
}

/// What a step's iteration matrix is made of ([`Coefficients`]): `β'`, `γ'`, the row
/// scaling and `K_t T(Δ)` at the increment `Δ` and multipliers `λ`.
fn coefficients<'a>(
    bp: f64,
    gp: f64,
    scale: f64,
    increment: &'a [f64],
    lambda: &'a [f64],
) -> Coefficients<'a> {
    Coefficients {
        beta_prime: bp,
        gamma_prime: gp,
        scale,
        tangent: Some((increment, lambda)),
    }
}

impl<'m> SpatialIntegrator<'m> {
    /// The integrator of `model` with `settings` (`t_end` and `h` are the caller's: any grid
    /// runs step by step).
    ///
    /// # Errors
    /// [`SettingsError`] for `ρ∞` outside `[0, 1]`, a tolerance or iteration limit out of
    /// range; the model's initial rates that the joints forbid ([`SpatialModel::check_rates`]);
    /// [`SolveError::Setup`] if the pattern cannot be analysed.
    pub fn new(model: &'m SpatialModel, settings: &DynamicSettings) -> Result<Self, Error> {
        RunOptions {
            rho_inf: Some(settings.rho_inf),
            tol: Some(settings.tol),
            max_iter: Some(settings.max_iter),
            ..RunOptions::default()
        }
        .validate()?;
        model.check_nodes()?;
        model.check_rates()?;
        let (asm, lu) = analysed(model)?;
        let n = asm.pattern.n;
        Ok(Self {
            asm,
            lu,
            params: AlphaParameters::chung_hulbert(settings.rho_inf),
            tol: settings.tol,
            keep: settings.newton == NewtonMatrix::Modified,
            max_iter: settings.max_iter,
            start: vec![0.0; model.n_q()],
            increment: vec![0.0; model.n_v()],
            rhs: vec![0.0; n],
            kinks: kinks(model),
            jump: [vec![0.0; model.n_rows()], vec![0.0; model.n_rows()]],
            restarts: 0,
            assembled: false,
        })
    }

    /// Restarts the scheme where a step begins on a kink of a drive's law (reached by a
    /// step, not at `t = 0`): the prescribed acceleration jumps there by `Δg̈`, and with it
    /// the rows' `b` by `Δb`; positions, velocities and forces are continuous, so
    /// `[M, sBᵀ; sB, 0][Δv̇; Δν] = [0; −s Δb]` and `v̇ += Δv̇`, `a += Δv̇` (the planar
    /// engine's `solver/kink.rs`, on the group). Returns whether it restarted.
    ///
    /// # Errors
    /// [`SolveError::Singular`] if the mass matrix is singular on the constraint manifold.
    fn restart(&mut self, s: &mut State) -> Result<bool, SolveError> {
        let Some(kink) = self.kinks.at(s.t, s.h) else {
            return Ok(false);
        };
        let (asm, lu) = (&mut self.asm, &mut self.lu);
        if !kink_jump(asm, lu, s, kink, &mut self.jump, &mut self.rhs)? {
            return Ok(false);
        }
        let n_v = asm.model.n_v();
        for ((acc, a), d) in s.qddot.iter_mut().zip(s.a.iter_mut()).zip(&self.rhs[..n_v]) {
            *acc += d;
            *a += d;
        }
        self.restarts += 1;
        Ok(true)
    }

    fn singular(time: f64) -> impl Fn(FactorError) -> SolveError {
        move |e| SolveError::Singular {
            time,
            detail: format!("{e:?}"),
        }
    }

    /// The model's initial configuration and rates with consistent accelerations and
    /// multipliers (module docs).
    ///
    /// # Errors
    /// [`SolveError::Singular`] if the mass matrix is singular on the constraint manifold.
    pub fn initial_state(&mut self) -> Result<State, SolveError> {
        let model = self.asm.model;
        let (q, v) = (model.initial_configuration(), model.initial_velocity());
        let scale = self.asm.mean_mass();
        self.asm.matrix(
            &q,
            &v,
            0.0,
            Coefficients {
                beta_prime: 1.0,
                gamma_prime: 0.0,
                scale,
                tangent: None,
            },
        )?;
        self.lu
            .factorize(&self.asm.values)
            .map_err(Self::singular(0.0))?;
        self.asm
            .acceleration_rhs(&q, &v, 0.0, scale, &mut self.rhs)?;
        self.lu
            .solve_in_place(&mut self.rhs, false)
            .map_err(Self::singular(0.0))?;
        let n_v = model.n_v();
        let vdot = self.rhs[..n_v].to_vec();
        let lam = self.rhs[n_v..].iter().map(|x| x * scale).collect();
        Ok(State {
            t: 0.0,
            q,
            qdot: v,
            a: vdot.clone(),
            qddot: vdot,
            lam,
            h: 0.0,
            forecast: Forecast::default(),
        })
    }

    /// One Lie-group generalized-α step of size `h` from `s`, in place (module docs).
    ///
    /// # Errors
    /// [`SolveError::NewtonFailed`] when Newton does not converge; [`SolveError::Diverged`]
    /// when a node turns by more than [`MAX_STEP_ROTATION`] in the step;
    /// [`SolveError::Singular`] for a singular iteration matrix; [`SolveError::Interrupted`].
    pub fn alpha_step(&mut self, s: &mut State, h: f64) -> Result<NewtonReport, SolveError> {
        alpha::step(self, s, h).map_err(|e| self.explained(e))
    }

    /// Newton's failure `e` with the bar nearest its Euler load named, where one was at
    /// [`BUCKLING_HINT`] of it or more when the step began (its `qₙ`).
    fn explained(&self, e: SolveError) -> SolveError {
        if !matches!(e, SolveError::NewtonFailed { .. }) {
            return e;
        }
        let model = self.asm.model;
        let beams = model
            .beams
            .iter()
            .map(|b| (&b.name, b.buckling(&self.start).0));
        let bars = model
            .trusses
            .iter()
            .map(|t| (&t.name, t.buckling(&self.start).0));
        match beams.chain(bars).max_by(|a, b| a.1.total_cmp(&b.1)) {
            Some((bar, ratio)) if ratio >= BUCKLING_HINT => SolveError::Buckled {
                failure: Box::new(e),
                bar: bar.clone(),
                ratio,
            },
            _ => e,
        }
    }

    /// The configuration space of the model's nodes.
    fn space(&self) -> Frames {
        Frames {
            nodes: self.asm.model.nodes.len(),
        }
    }

    /// The iteration matrix at the state `s`, factored; assembled here unless the
    /// residual's pass assembled it at `s` already (`assembled`).
    fn factorize(&mut self, s: &State, bp: f64, gp: f64, scale: f64) -> Result<(), SolveError> {
        if !std::mem::take(&mut self.assembled) {
            let c = coefficients(bp, gp, scale, &self.increment, &s.lam);
            self.asm.matrix(&s.q, &s.qdot, s.t, c)?;
        }
        self.lu
            .factorize(&self.asm.values)
            .map_err(Self::singular(s.t))
    }

    fn check_rotations(&self, t: f64) -> Result<(), SolveError> {
        for (node, inc) in self.increment.chunks(NV).enumerate() {
            let rotation = (inc[3] * inc[3] + inc[4] * inc[4] + inc[5] * inc[5]).sqrt();
            if rotation > MAX_STEP_ROTATION {
                return Err(SolveError::Diverged {
                    at: format!("t = {t:.6} s"),
                    rotation,
                    node: self.asm.model.nodes[node].name.clone(),
                });
            }
        }
        Ok(())
    }
}

impl Equations for SpatialIntegrator<'_> {
    fn parameters(&self) -> AlphaParameters {
        self.params
    }

    fn restart_at_kink(&mut self, s: &mut State) -> Result<(), SolveError> {
        self.restart(s).map(|_| ())
    }

    /// Every velocity coordinate's `v̇ₙ₊₁` starts at `v̇ₙ` (rigid bodies' accelerations are
    /// smooth).
    fn begin(&mut self, q: &[f64]) -> Predictor<'_> {
        self.start.copy_from_slice(q);
        Predictor {
            increment: &mut self.increment,
            smooth: None,
        }
    }

    fn retract(&self, q: &mut [f64]) {
        self.space().retract(&self.start, &self.increment, q);
    }

    fn correct(&mut self, s: &mut State, bp: f64, gp: f64) -> Result<NewtonReport, SolveError> {
        let scale = bp * self.asm.mean_mass();
        let (tol, max_iter, keep) = (self.tol, self.max_iter, self.keep);
        let mut forecast = s.forecast;
        let mut step = Step {
            it: self,
            s,
            bp,
            gp,
            scale,
        };
        let report = newton::iterate(&mut step, tol, max_iter, keep, &mut forecast);
        s.forecast = forecast;
        report
    }

    fn check_step(&self, s: &State) -> Result<(), SolveError> {
        self.check_rotations(s.t)
    }
}

/// A step's system for Newton: the correction `δ` of the increment `Δ`, `Δ += δ`,
/// `v += γ'δ`, `v̇ += β'δ`, `λ += s δν` (module docs), `s` the multipliers' scale.
struct Step<'a, 'm> {
    it: &'a mut SpatialIntegrator<'m>,
    s: &'a mut State,
    bp: f64,
    gp: f64,
    scale: f64,
}

impl System for Step<'_, '_> {
    /// The residual at the iterate; with the matrix too (one pass over the elements) where
    /// Newton will factor one here.
    fn residual(&mut self, with_matrix: bool) -> Result<Residual, SolveError> {
        let (it, s) = (&mut *self.it, &*self.s);
        let force = if with_matrix {
            let c = coefficients(self.bp, self.gp, self.scale, &it.increment, &s.lam);
            let states = (&s.q[..], &s.qdot[..], &s.qddot[..]);
            it.assembled = true;
            (it.asm).residual_and_matrix(states, &s.lam, s.t, &mut it.rhs, c)?
        } else {
            it.assembled = false;
            (it.asm).residual(&s.q, &s.qdot, &s.qddot, &s.lam, s.t, &mut it.rhs)?
        };
        Ok(it.asm.measure(&it.rhs, force))
    }

    fn solve(&mut self, refactor: bool) -> Result<(), SolveError> {
        if refactor {
            (self.it).factorize(self.s, self.bp, self.gp, self.scale)?;
        }
        let n_v = self.it.asm.model.n_v();
        let rhs = &mut self.it.rhs;
        rhs.iter_mut().for_each(|x| *x = -*x);
        rhs[n_v..].iter_mut().for_each(|x| *x *= self.scale);
        (self.it.lu)
            .solve_in_place(rhs, false)
            .map_err(SpatialIntegrator::singular(self.s.t))
    }

    fn update(&mut self) -> bool {
        let (it, s) = (&mut *self.it, &mut *self.s);
        let (delta, dnu) = it.rhs.split_at(it.asm.model.n_v());
        for (i, d) in delta.iter().enumerate() {
            it.increment[i] += d;
            s.qdot[i] += self.gp * d;
            s.qddot[i] += self.bp * d;
        }
        s.lam
            .iter_mut()
            .zip(dnu)
            .for_each(|(l, d)| *l += self.scale * d);
        it.retract(&mut s.q);
        at_round_off(delta, &it.increment, it.asm.model.size())
    }

    fn correction_at_round_off(&self) -> bool {
        let it = &*self.it;
        let delta = &it.rhs[..it.asm.model.n_v()];
        at_round_off(delta, &it.increment, it.asm.model.size())
    }

    fn at(&self) -> String {
        format!("t = {:.6} s", self.s.t)
    }
}

/// The motion of `model` over `grid` from its consistent start: every state.
///
/// # Errors
/// [`SettingsError`] for a step of the grid that is not positive and finite; as
/// [`SpatialIntegrator::new`], [`SpatialIntegrator::initial_state`] and
/// [`SpatialIntegrator::alpha_step`].
pub fn simulate_spatial(
    model: &SpatialModel,
    settings: &DynamicSettings,
    grid: &TimeGrid,
) -> Result<Vec<State>, Error> {
    Ok(run(model, settings, grid)?.0)
}

/// [`simulate_spatial`], and whether each step (into state `n`, `n ≥ 1`; `false` at 0)
/// began with a restart at a drive's kink.
pub(crate) fn run(
    model: &SpatialModel,
    settings: &DynamicSettings,
    grid: &TimeGrid,
) -> Result<(Vec<State>, Vec<bool>), Error> {
    if let Some((n, h)) = grid
        .steps()
        .iter()
        .enumerate()
        .find(|(_, h)| !(h.is_finite() && **h > 0.0))
    {
        return Err(SettingsError::new(
            "grid",
            format!(
                "step {n} is {}: steps must be positive and finite",
                short(*h)
            ),
        )
        .into());
    }
    let mut integrator = SpatialIntegrator::new(model, settings)?;
    let mut state = integrator.initial_state()?;
    let mut states = Vec::with_capacity(grid.steps().len() + 1);
    let mut restarted = Vec::with_capacity(grid.steps().len() + 1);
    states.push(state.clone());
    restarted.push(false);
    for &h in grid.steps() {
        let before = integrator.restarts;
        integrator.alpha_step(&mut state, h)?;
        states.push(state.clone());
        restarted.push(integrator.restarts > before);
    }
    Ok((states, restarted))
}
