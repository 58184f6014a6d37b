//! The discrete adjoint of the generalized-α scheme.
//!
//! The direct step (see [`super::direct`]) is linear in the previous sensitivities; its
//! transpose runs backwards. With adjoint variables `(q̄, q̄̇, ā, Ā)` of `(q', q̇', a', q̈')` at
//! step `n + 1` (one column per response) the sweep from `n + 1` to `n` is
//!
//! ```text
//! ā⁺ = ā + hγ q̄̇,   q̃ = q̄ + β' Ā + ā⁺/(h²β)               (total adjoint of q'ₙ₊₁)
//! S_t μ = [q̃; s λ̄]                                        (S_t symmetric, at qₙ₊₁;
//!                                                          λ̄ = wₙ₊₁ G_λ, λ' = s μ')
//! c̄ = Ā − M μ,     x̄ −= (∂r/∂x)ᵀ μ
//! P̄ = −ā⁺/(h²β) − β' c̄
//! q̄ₙ = P̄ + wₙ G_q,  q̄̇ₙ = q̄̇ + h P̄,  āₙ = h(1−γ) q̄̇ + α_m c̄/(1−α_f) + h²(½−β) P̄,  Āₙ = −α_f c̄/(1−α_f)
//! ```
//!
//! and at `t = 0` the initial-acceleration system takes `Ā₀ + ā₀`; at a kink where the
//! forward step restarted, the restart's jump system takes `Āₙ + āₙ` ([`super::kink`]).
//! The backward sweep needs `qₙ` and `q̈ₙ` of every step: a `StateStore` keeps them all,
//! or only full states at checkpoints every `K ≈ √N` steps and replays one segment at a
//! time (bitwise identical, since the replay repeats the same arithmetic, restarts too) —
//! memory `O(√N)` states for one more forward sweep. Either way the cost is one extra factorization and solve per step,
//! whatever the number of design variables.

use std::time::Instant;

use faer::dyn_stack::MemBuffer;

use super::{Method, Objectives, PseudoLoads, Sensitivities, Timings};
use crate::error::{Error, SettingsError, SolveError};
use crate::mechanism::model::{Densities, Model};
use crate::mechanism::parameter::{At, Level, Parameter};
use crate::response::{Context, Response, Sample};
use crate::settings::{DynamicSettings, Memory};
use crate::solver::alpha::{step_ratio, AlphaParameters, State};
use crate::solver::backward::{self, Transposed};
use crate::solver::integrator::Integrator;
use crate::solver::kink::Jump;
use crate::solver::local_error::LocalErrors;
use crate::time_grid::TimeGrid;

/// Rows of the states a backward sweep reads: `qₙ`, `q̈ₙ`, `λₙ`, and `q̇ₙ` if a
/// parameter's pseudo-load reads velocities (else empty).
#[derive(Default)]
struct Rows {
    q: Vec<f64>,
    v: Vec<f64>,
    acc: Vec<f64>,
    lam: Vec<f64>,
    velocities: bool,
}

impl Rows {
    fn push(&mut self, s: &State) {
        self.push_row(&s.q, &s.qdot, &s.qddot, &s.lam);
    }

    fn push_row(&mut self, q: &[f64], v: &[f64], acc: &[f64], lam: &[f64]) {
        self.q.extend_from_slice(q);
        if self.velocities {
            self.v.extend_from_slice(v);
        }
        self.acc.extend_from_slice(acc);
        self.lam.extend_from_slice(lam);
    }

    fn clear(&mut self) {
        self.q.clear();
        self.v.clear();
        self.acc.clear();
        self.lam.clear();
    }

    /// Row `k` (of `n_q` coordinates and `n_c` multipliers).
    fn row(&self, k: usize, n_q: usize, n_c: usize) -> Stored<'_> {
        let r = k * n_q..(k + 1) * n_q;
        Stored {
            q: &self.q[r.clone()],
            v: if self.velocities {
                &self.v[r.clone()]
            } else {
                &[]
            },
            acc: &self.acc[r],
            lam: &self.lam[k * n_c..(k + 1) * n_c],
        }
    }
}

/// The states of a run, for the backward sweep.
enum StateStore {
    /// Every step stored: row `n` of each.
    All(Rows),
    /// Full states every `interval` steps; the segment last replayed, from step `first`.
    Checkpoints {
        interval: usize,
        states: Vec<State>,
        first: usize,
        rows: Rows,
    },
}

/// A stored state: `qₙ`, `q̇ₙ` (empty unless kept), `q̈ₙ`, `λₙ`.
#[derive(Clone, Copy)]
struct Stored<'a> {
    q: &'a [f64],
    v: &'a [f64],
    acc: &'a [f64],
    lam: &'a [f64],
}

impl<'a> Stored<'a> {
    /// The state as the responses read it at time `t`.
    fn sample(self, t: f64) -> Sample<'a> {
        Sample {
            q: self.q,
            v: self.v,
            lam: self.lam,
            t,
        }
    }

    /// The state as the pseudo-loads read it at time `t`, its constraints at `level`.
    fn at(self, t: f64, level: Level) -> At<'a> {
        At {
            q: self.q,
            rates: Some((self.v, self.acc)),
            lam: self.lam,
            t,
            level,
        }
    }
}

impl StateStore {
    /// Records state `n` of the forward sweep.
    fn record(&mut self, n: usize, s: &State) {
        match self {
            Self::All(rows) => rows.push(s),
            Self::Checkpoints {
                interval, states, ..
            } => {
                if n.is_multiple_of(*interval) {
                    states.push(s.clone());
                }
            }
        }
    }

    /// `(qₙ, q̈ₙ, λₙ)`, replaying the segment holding step `n` if needed (`prefer_below`: of
    /// two segments holding `n`, the one below, as the sweep from `n` to `n − 1` needs).
    fn get(
        &mut self,
        it: &mut Integrator,
        grid: &TimeGrid,
        n: usize,
        prefer_below: bool,
    ) -> Result<Stored<'_>, Error> {
        let last = grid.len();
        let model = it.assembler().model;
        let (n_q, n_c) = (model.n_dofs(), model.n_constraints());
        match self {
            Self::All(rows) => Ok(rows.row(n, n_q, n_c)),
            Self::Checkpoints {
                interval,
                states,
                first,
                rows,
            } => {
                let k = *interval;
                let held = n >= *first && n <= (*first + k).min(last) && !rows.q.is_empty();
                if !held || (prefer_below && n == *first && n > 0) {
                    let segment = if prefer_below && n > 0 {
                        (n - 1) / k
                    } else {
                        n / k
                    };
                    let mut state = states[segment].clone();
                    *first = segment * k;
                    rows.clear();
                    rows.push(&state);
                    for step in *first..(*first + k).min(last) {
                        it.alpha_step(&mut state, grid.step(step))?;
                        rows.push(&state);
                    }
                }
                Ok(rows.row(n - *first, n_q, n_c))
            }
        }
    }

    /// What `memory` asks for with `n_q` DOFs over `steps` steps, with `velocities` or
    /// not: every state, or full states every `⌈√steps⌉` steps.
    fn new(memory: Memory, n_q: usize, n_c: usize, steps: usize, velocities: bool) -> Self {
        let interval = ((steps as f64).sqrt().ceil() as usize).max(1);
        let rows_per_state = 2 + usize::from(velocities);
        let checkpoints = match memory {
            Memory::StoreAll => false,
            Memory::Checkpoints => true,
            Memory::Auto { budget_bytes } => rows_per_state * n_q * (steps + 1) * 8 > budget_bytes,
        };
        let rows = Rows {
            velocities,
            ..Rows::default()
        };
        if checkpoints {
            Self::Checkpoints {
                interval,
                states: Vec::new(),
                first: 0,
                rows,
            }
        } else {
            let states = steps + 1;
            Self::All(Rows {
                q: Vec::with_capacity(n_q * states),
                v: Vec::with_capacity(if velocities { n_q * states } else { 0 }),
                acc: Vec::with_capacity(n_q * states),
                lam: Vec::with_capacity(n_c * states),
                velocities,
            })
        }
    }
}

/// What a backward sweep linearizes about.
#[derive(Debug, Clone, Copy)]
pub(crate) enum About<'a> {
    /// The model's own run on the grid, made first and kept as `Memory` says (every state,
    /// or checkpoints).
    Run(Memory),
    /// The model's own run given (the states of [`crate::simulate_on`] with the same
    /// settings, checked by the caller), every state stored: the same values and gradients,
    /// the run not made again — the gradients of a run judged on its values first. Or, for
    /// [`dual_weights`], another trajectory.
    Path(Path<'a>),
}

impl About<'_> {
    /// The model's own run, checkpointed past [`crate::settings::STORE_BUDGET_BYTES`].
    const AUTO: Self = About::Run(Memory::Auto {
        budget_bytes: crate::settings::STORE_BUDGET_BYTES,
    });
}

/// The adjoint sweep about `about` on `grid`: the responses and their gradients.
pub(crate) fn differentiate_backward(
    model: &Model,
    densities: Densities,
    settings: &DynamicSettings,
    grid: &TimeGrid,
    responses: &[Response],
    parameters: &[Parameter],
    about: About<'_>,
) -> Result<Sensitivities, Error> {
    let run = Backward {
        model,
        settings,
        grid,
        responses,
        parameters,
    };
    run.sweep_about(densities, about, None)
}

/// A trajectory given at every time of a grid, one row of the model's coordinates (or
/// multipliers) per time: what a backward sweep may linearize about instead of its own run.
#[derive(Debug, Clone, Copy)]
pub struct Path<'a> {
    /// `qₙ`.
    pub q: &'a [f64],
    /// `q̇ₙ`.
    pub qdot: &'a [f64],
    /// `q̈ₙ`.
    pub qddot: &'a [f64],
    /// `λₙ`.
    pub lam: &'a [f64],
}

impl Path<'_> {
    /// A [`SettingsError`] naming `what` unless the path has `times` finite rows of `n_q`
    /// coordinates and `n_c` multipliers.
    pub(crate) fn check(
        &self,
        what: &str,
        n_q: usize,
        n_c: usize,
        times: usize,
    ) -> Result<(), SettingsError> {
        let finite =
            |v: &[f64], width: usize| v.len() == times * width && v.iter().all(|x| x.is_finite());
        if [self.q, self.qdot, self.qddot]
            .iter()
            .all(|v| finite(v, n_q))
            && finite(self.lam, n_c)
        {
            return Ok(());
        }
        let rows = format!("{times} finite rows of {n_q} coordinates in q, qdot and qddot and of {n_c} multipliers in lam");
        Err(SettingsError::new(what, format!("needs {rows}")))
    }
}

/// The adjoint variables `μₙ` of the equilibrium residual at every time `tₙ` of `grid`
/// (`μ₀` that of the initial accelerations), one column of `n_q` per response: row-major
/// `[(N + 1) × n_r × n_q]`, linearized about the model's own run on `grid`, or about the
/// trajectory `about`. A residual `δrₙ` added at `tₙ` changes response `k` by `μₙ,ₖᵀ δrₙ`
/// to first order (the dual weights of [`super::shares`]). Returned with the responses'
/// values on that trajectory.
///
/// # Errors
/// As [`differentiate_backward`].
pub(crate) fn dual_weights(
    model: &Model,
    densities: Densities,
    settings: &DynamicSettings,
    grid: &TimeGrid,
    responses: &[Response],
    about: Option<Path<'_>>,
) -> Result<(Vec<f64>, Vec<f64>), Error> {
    let run = Backward::of_values(model, settings, grid, responses);
    let about = about.map_or(About::AUTO, About::Path);
    let mut weights = vec![0.0; (grid.len() + 1) * responses.len() * model.n_dofs()];
    let sensitivities = run.sweep_about(densities, about, Some(&mut weights))?;
    Ok((sensitivities.values, weights))
}

/// Each response's time error on `grid`, `f(h) − f` to leading order in the step, with
/// the responses' values: the steps' local errors weighted by the adjoint of the run
/// ([`crate::solver::local_error`]), one backward sweep and no other run.
///
/// # Errors
/// As [`differentiate_backward`].
pub fn time_errors(
    model: &Model,
    densities: Densities,
    settings: &DynamicSettings,
    grid: &TimeGrid,
    responses: &[Response],
) -> Result<(Vec<f64>, Vec<f64>), Error> {
    let run = Backward::of_values(model, settings, grid, responses);
    let sensitivities = run.sweep_about(densities, About::AUTO, None)?;
    let errors = sensitivities.time_errors.unwrap_or_default();
    Ok((sensitivities.values, errors))
}

/// What one adjoint analysis reads.
struct Backward<'a> {
    model: &'a Model,
    settings: &'a DynamicSettings,
    grid: &'a TimeGrid,
    responses: &'a [Response],
    parameters: &'a [Parameter],
}

impl<'a> Backward<'a> {
    /// An analysis of `responses` on `grid` without gradients.
    fn of_values(
        model: &'a Model,
        settings: &'a DynamicSettings,
        grid: &'a TimeGrid,
        responses: &'a [Response],
    ) -> Self {
        Self {
            model,
            settings,
            grid,
            responses,
            parameters: &[],
        }
    }

    /// The forward run, or the trajectory given (every state stored), as `about` says; then
    /// the backward sweep; with `weights`, each time's `μ` kept there (see [`dual_weights`]);
    /// without, each response's estimated time error too (see [`time_errors`]: its local
    /// errors cost no measurable time beside the sweep's).
    fn sweep_about(
        &self,
        densities: Densities,
        about: About<'_>,
        weights: Option<&mut [f64]>,
    ) -> Result<Sensitivities, Error> {
        let Self {
            model,
            settings,
            grid,
            responses,
            parameters,
        } = *self;
        let mut it = Integrator::new(model, densities, settings)?;
        let mut objectives = Objectives::new(model, responses, parameters, grid)?;
        let pseudo = PseudoLoads::new(model, settings.mass, parameters);
        let (n_q, n_c) = (model.n_dofs(), model.n_constraints());
        let velocities = pseudo.reads_velocities() || objectives.read_velocities();
        let memory = match about {
            About::Run(memory) => memory,
            About::Path(_) => Memory::StoreAll,
        };
        let mut store = StateStore::new(memory, n_q, n_c, grid.len(), velocities);
        let clock = Instant::now();
        let mut values = match about {
            About::Path(path) => replay(&it, grid, &mut objectives, settings, path, &mut store),
            About::Run(_) => forward(&mut it, grid, &mut objectives, settings, &mut store)?,
        };
        let simulation = clock.elapsed().as_secs_f64();
        let clock = Instant::now();
        let mut sweep = Sweep::new(model, &it, settings, pseudo, responses.len());
        if weights.is_none() {
            sweep.local = Some(LocalErrors::new(&it.params, n_q, responses.len()));
        }
        sweep.weights = weights;
        let mut reverse = Reverse {
            it: &mut it,
            store: &mut store,
            grid,
            objectives: &objectives,
            sweep: &mut sweep,
        };
        backward::sweep(&mut reverse, grid.len())?;
        let time_errors = sweep.local.as_mut().map(|local| {
            local.add_quadrature(grid.step(0), grid.step(grid.len() - 1));
            objectives.finish(&mut values.clone(), &mut local.errors);
            std::mem::take(&mut local.errors)
        });
        objectives.finish(&mut values, &mut sweep.xb);
        let peaks = objectives.peaks();
        let timings = Timings {
            simulation,
            gradients: clock.elapsed().as_secs_f64(),
        };
        Ok(Sensitivities {
            time_errors,
            ..Sensitivities::new(model, values, &sweep.xb, Method::Adjoint, timings, peaks)
        })
    }
}

/// The planar run transposed ([`backward::sweep`]): the states read from `store` (replayed
/// from a checkpoint where needed) into the [`Sweep`]'s columns.
struct Reverse<'r, 'a> {
    it: &'r mut Integrator<'a>,
    store: &'r mut StateStore,
    grid: &'r TimeGrid,
    objectives: &'r Objectives<'a>,
    sweep: &'r mut Sweep<'a>,
}

impl Reverse<'_, '_> {
    /// The local errors of the step from state `n` ([`LocalErrors`]) from the stored
    /// accelerations: `q̈ₙ₊₁`, and `q̈ₙ` with the jump of a restart at a kink on it.
    fn local_errors(&mut self, n: usize) -> Result<(), Error> {
        let grid = self.grid;
        let Some(local) = self.sweep.local.as_mut() else {
            return Ok(());
        };
        let s1 = self.store.get(self.it, grid, n + 1, true)?;
        local.next.copy_from_slice(s1.acc);
        let s = self.store.get(self.it, grid, n, false)?;
        local.now.copy_from_slice(s.acc);
        if n > 0 {
            if let Some(jump) = self.it.jump_at(s.q, grid.times()[n], grid.step(n - 1))? {
                local
                    .now
                    .iter_mut()
                    .zip(&jump.dacc)
                    .for_each(|(a, d)| *a += d);
            }
        }
        let after = (n + 1 < grid.len()).then(|| grid.step(n + 1));
        local.of_step(grid.step(n), after);
        Ok(())
    }
}

impl Transposed for Reverse<'_, '_> {
    fn seed(&mut self, n: usize) -> Result<(), Error> {
        let last = self.grid.len();
        let s = self.store.get(self.it, self.grid, n, n == last)?;
        let at = s.sample(self.grid.times()[n]);
        self.sweep.add_local(self.it, self.objectives, n, at);
        if let Some(local) = self.sweep.local.as_mut() {
            // The trapezoidal rule's own error reads the integrands of the first two and
            // the last two states.
            if let Some(end) = LocalErrors::end_of(n, last) {
                let densities = &self.it.assembler().densities;
                let ctx = Context::dynamic(self.sweep.model, densities, self.sweep.mass);
                for (k, g) in local.ends.iter_mut().enumerate() {
                    g[end] = self.objectives.integrand(&ctx, k, n, at);
                }
            }
        }
        Ok(())
    }

    fn step(&mut self, n: usize) -> Result<(), Error> {
        let grid = self.grid;
        if self.sweep.local.is_some() {
            self.local_errors(n)?;
        }
        let s1 = self.store.get(self.it, grid, n + 1, true)?;
        let previous = if n > 0 { grid.step(n - 1) } else { 0.0 };
        let at1 = s1.at(grid.times()[n + 1], Level::Position);
        self.sweep.step(self.it, at1, grid.step(n), previous)?;
        self.sweep.keep_weights(n + 1);
        Ok(())
    }

    fn restart(&mut self, n: usize) -> Result<(), Error> {
        if n == 0 {
            return Ok(());
        }
        let grid = self.grid;
        let s = self.store.get(self.it, grid, n, false)?;
        if let Some(jump) = self.it.jump_at(s.q, grid.times()[n], grid.step(n - 1))? {
            self.sweep.restart(self.it, &jump)?;
        }
        Ok(())
    }

    fn initial(&mut self) -> Result<(), Error> {
        let s0 = self.store.get(self.it, self.grid, 0, false)?;
        let at0 = s0.at(0.0, Level::Acceleration);
        Ok(self.sweep.initial(self.it, at0)?)
    }
}

/// Forward sweep: the response values, and the states (or checkpoints) of the backward
/// sweep.
fn forward(
    it: &mut Integrator,
    grid: &TimeGrid,
    objectives: &mut Objectives,
    settings: &DynamicSettings,
    store: &mut StateStore,
) -> Result<Vec<f64>, Error> {
    let model = it.assembler().model;
    let mut state = it.initial_state()?;
    let mut values = vec![0.0; objectives.len()];
    for n in 0..=grid.len() {
        if n > 0 {
            it.alpha_step(&mut state, grid.step(n - 1))?;
        }
        let ctx = Context::dynamic(model, &it.assembler().densities, settings.mass);
        let at = Sample {
            q: &state.q,
            v: &state.qdot,
            lam: &state.lam,
            t: state.t,
        };
        objectives.observe(&ctx, at, &mut values, &mut []);
        objectives.add_values(&ctx, n, at, &mut values);
        store.record(n, &state);
    }
    Ok(values)
}

/// [`forward`] on a given trajectory: its response values, its states stored.
fn replay(
    it: &Integrator,
    grid: &TimeGrid,
    objectives: &mut Objectives,
    settings: &DynamicSettings,
    path: Path<'_>,
    store: &mut StateStore,
) -> Vec<f64> {
    let model = it.assembler().model;
    let (n_q, n_c) = (model.n_dofs(), model.n_constraints());
    let mut values = vec![0.0; objectives.len()];
    for (n, &t) in grid.times().iter().enumerate() {
        let (r, c) = (n * n_q..(n + 1) * n_q, n * n_c..(n + 1) * n_c);
        let (q, v, lam) = (&path.q[r.clone()], &path.qdot[r.clone()], &path.lam[c]);
        let ctx = Context::dynamic(model, &it.assembler().densities, settings.mass);
        let at = Sample { q, v, lam, t };
        objectives.observe(&ctx, at, &mut values, &mut []);
        objectives.add_values(&ctx, n, at, &mut values);
        if let StateStore::All(rows) = store {
            rows.push_row(q, v, &path.qddot[r], lam);
        }
    }
    values
}

/// The adjoint variables of every response (column-major, one column each) and the
/// gradients accumulated so far.
struct Sweep<'a> {
    model: &'a Model,
    pseudo: PseudoLoads,
    mass: crate::mechanism::element::MassKind,
    n_q: usize,
    n: usize,
    n_x: usize,
    n_r: usize,
    /// `q̄`, `q̄̇`, `ā`, `Ā`, each `n_q × n_r`.
    qb: Vec<f64>,
    vb: Vec<f64>,
    ab: Vec<f64>,
    acc_b: Vec<f64>,
    /// `λ̄`, `n_c × n_r`: the responses' `wₙ G_λ` at the state the next transposed solve
    /// starts from.
    lb: Vec<f64>,
    /// `x̄`, row-major `n_r × n_x`: the gradients.
    xb: Vec<f64>,
    rhs: Vec<f64>,
    /// `M μ` and `C μ` of the current column.
    c: Vec<f64>,
    damped: Vec<f64>,
    scratch: MemBuffer,
    /// Work space of the exact solves with damping ([`crate::solver::newton::Newton::solve_exact`]).
    work: Vec<f64>,
    /// Where each time's `μ` is kept, if asked ([`dual_weights`]).
    weights: Option<&'a mut [f64]>,
    /// The steps' local errors and the responses' time errors, if asked ([`time_errors`]).
    local: Option<LocalErrors>,
}

impl<'a> Sweep<'a> {
    fn new(
        model: &'a Model,
        it: &Integrator,
        settings: &DynamicSettings,
        pseudo: PseudoLoads,
        n_r: usize,
    ) -> Self {
        let (n_q, n_x) = (model.n_dofs(), pseudo.columns());
        let n = n_q + model.n_constraints();
        Self {
            model,
            pseudo,
            mass: settings.mass,
            n_q,
            n,
            n_x,
            n_r,
            qb: vec![0.0; n_q * n_r],
            vb: vec![0.0; n_q * n_r],
            ab: vec![0.0; n_q * n_r],
            acc_b: vec![0.0; n_q * n_r],
            lb: vec![0.0; (n - n_q) * n_r],
            xb: vec![0.0; n_x * n_r],
            rhs: vec![0.0; n * n_r],
            c: vec![0.0; n_q],
            damped: vec![0.0; n_q],
            scratch: it.newton.scratch(n_r),
            work: Vec::new(),
            weights: None,
            local: None,
        }
    }

    /// Adds `wₙ G_q` of state `n` to `q̄`, `wₙ G_λ` to `λ̄` and `wₙ G_x` to `x̄`.
    fn add_local(&mut self, it: &Integrator, objectives: &Objectives, n: usize, at: Sample) {
        let ctx = Context::dynamic(self.model, &it.assembler().densities, self.mass);
        let (n_q, n_c, n_x) = (self.n_q, self.n - self.n_q, self.n_x);
        for k in 0..self.n_r {
            objectives.add_partials(
                &ctx,
                k,
                n,
                at,
                &mut self.qb[k * n_q..(k + 1) * n_q],
                &mut self.lb[k * n_c..(k + 1) * n_c],
                &mut self.xb[k * n_x..(k + 1) * n_x],
                // A response's G_q̇ joins the adjoint of q̇'.
                &mut self.vb[k * n_q..(k + 1) * n_q],
            );
        }
    }

    /// Keeps the force rows `μ` of the solution columns in `rhs` as the weights of `t_time`.
    fn keep_weights(&mut self, time: usize) {
        let (n_q, n, n_r) = (self.n_q, self.n, self.n_r);
        if let Some(weights) = self.weights.as_deref_mut() {
            let out = &mut weights[time * n_r * n_q..(time + 1) * n_r * n_q];
            for (o, column) in out.chunks_mut(n_q).zip(self.rhs.chunks(n)) {
                o.copy_from_slice(&column[..n_q]);
            }
        }
    }

    /// Moves `s λ̄` into the multiplier rows of the right-hand sides and clears `λ̄`: the
    /// direct method's `λ' = s μ'` read off a solve, transposed (the solve is symmetric).
    fn seed_multipliers(&mut self, scale: f64) {
        let (n, n_q) = (self.n, self.n_q);
        for (out, lb) in self.rhs.chunks_mut(n).zip(self.lb.chunks_mut(n - n_q)) {
            out[n_q..].iter_mut().zip(lb.iter_mut()).for_each(|(o, l)| {
                *o = scale * *l;
                *l = 0.0;
            });
        }
    }

    /// The transposed step from `n + 1` (state `at1`) back to `n`, for a step of size `h`
    /// after one of size `previous`: the transposed Newmark step, then the transposed
    /// carrying of `a` to the new step size (`ā ← ρ ā`, `Ā += (1 − ρ) ā`).
    fn step(
        &mut self,
        it: &mut Integrator,
        at1: At<'_>,
        h: f64,
        previous: f64,
    ) -> Result<(), SolveError> {
        let AlphaParameters {
            alpha_m,
            alpha_f,
            beta,
            gamma,
        } = it.params;
        let bp = it.params.beta_prime(h);
        let (n_q, n, n_x) = (self.n_q, self.n, self.n_x);
        if let Some(local) = self.local.as_mut() {
            // The local errors' share through the state after the step: q̄ᵀ l_q + q̄̇ᵀ l_v,
            // less the total adjoint q̃ of its positions on l_q, which the equilibrium's
            // solve gives back below.
            for k in 0..self.n_r {
                let r = k * n_q..(k + 1) * n_q;
                let mut share = 0.0;
                for (i, j) in r.enumerate() {
                    let a_total = self.ab[j] + h * gamma * self.vb[j];
                    let beyond = bp * self.acc_b[j] + a_total / (h * h * beta);
                    share += self.vb[j] * local.lv[i] - beyond * local.lq[i];
                }
                local.errors[k] += share;
            }
        }
        for k in 0..self.n_r {
            let r = k * n_q..(k + 1) * n_q;
            let out = &mut self.rhs[k * n..(k + 1) * n];
            for (i, o) in out[..n_q].iter_mut().enumerate() {
                let j = r.start + i;
                let a_total = self.ab[j] + h * gamma * self.vb[j];
                *o = self.qb[j] + bp * self.acc_b[j] + a_total / (h * h * beta);
                self.ab[j] = a_total; // kept for P̄ below
            }
        }
        // Velocities are stored when damping or a parameter reads them.
        let velocity = at1.rates.map(|(v, _)| v).filter(|v| !v.is_empty());
        it.newton.factorize(
            at1.q,
            Some(at1.lam),
            velocity,
            bp,
            it.params.gamma_prime(h),
            at1.t,
        )?;
        let scale = it.newton.multiplier_scale();
        self.seed_multipliers(scale);
        let (rhs, scratch, work) = (&mut self.rhs, &mut self.scratch, &mut self.work);
        it.newton.solve_exact(rhs, self.n_r, scratch, true, work)?;
        if self.pseudo.moves_constraints() {
            it.newton.unaugment(&mut self.rhs);
        }
        let asm = it.assembler();
        for k in 0..self.n_r {
            let r = k * n_q..(k + 1) * n_q;
            let column = &self.rhs[k * n..(k + 1) * n];
            let xb = &mut self.xb[k * n_x..(k + 1) * n_x];
            self.pseudo
                .subtract_transposed(asm, &at1, scale, column, xb);
            let mu = &column[..n_q];
            asm.mass_times(mu, &mut self.c);
            self.damped.fill(0.0);
            it.newton.add_damping_times(mu, &mut self.damped);
            let gp = it.params.gamma_prime(h);
            if let Some(local) = self.local.as_mut() {
                // −μᵀτ, τ = −(β'M + γ'C) l_q + C l_v the step's residual on the exact motion.
                local.errors[k] += (0..n_q)
                    .map(|i| {
                        (bp * self.c[i] + gp * self.damped[i]) * local.lq[i]
                            - self.damped[i] * local.lv[i]
                    })
                    .sum::<f64>();
            }
            for i in 0..n_q {
                let j = r.start + i;
                let cbar = self.acc_b[j] - self.c[i];
                // The residual's C q̇ₙ₊₁: q̇ₙ₊₁'s adjoint loses C μ, reaching the predictor
                // through q̇ₙ₊₁ = q̇ + hγ aₙ₊₁ and aₙ₊₁ = (qₙ₊₁ − q̂)/(h²β).
                let pbar = -self.ab[j] / (h * h * beta) - bp * cbar + gp * self.damped[i];
                let vbar = self.vb[j] - self.damped[i];
                self.qb[j] = pbar;
                self.vb[j] = vbar + h * pbar;
                self.ab[j] = h * (1.0 - gamma) * vbar
                    + alpha_m * cbar / (1.0 - alpha_f)
                    + h * h * (0.5 - beta) * pbar;
                self.acc_b[j] = -alpha_f * cbar / (1.0 - alpha_f);
            }
        }
        if let Some(ratio) = step_ratio(previous, h) {
            for (ab, acc_b) in self.ab.iter_mut().zip(self.acc_b.iter_mut()) {
                *acc_b += (1.0 - ratio) * *ab;
                *ab *= ratio;
            }
        }
        Ok(())
    }

    /// The transposed restart at a kink the step from state `n` began with: its `Δq̈`
    /// reached `aₙ` and `q̈ₙ`, so `[ā + Ā; 0]` is its adjoint's right-hand side
    /// ([`super::kink::adjoint`]).
    fn restart(&mut self, it: &mut Integrator, jump: &Jump) -> Result<(), SolveError> {
        let (n, n_q) = (self.n, self.n_q);
        for (k, out) in self.rhs.chunks_mut(n).enumerate() {
            let r = k * n_q..(k + 1) * n_q;
            for ((o, ab), acc_b) in out[..n_q]
                .iter_mut()
                .zip(&self.ab[r.clone()])
                .zip(&self.acc_b[r])
            {
                *o = ab + acc_b;
            }
            out[n_q..].fill(0.0);
        }
        super::kink::adjoint(
            it,
            jump,
            &self.pseudo,
            &mut self.rhs,
            &mut self.qb,
            &mut self.xb,
        )
    }

    /// `t = 0`: `q̈'₀` from `[M, Φ_qᵀ; Φ_q, 0]`, `a'₀ = q̈'₀`, so the initial-acceleration
    /// system takes `Ā₀ + ā₀`; from the static equilibrium, `q̄₀` then reaches `x` through
    /// it ([`super::start`]).
    fn initial(&mut self, it: &mut Integrator, at0: At<'_>) -> Result<(), SolveError> {
        let (n_q, n, n_x) = (self.n_q, self.n, self.n_x);
        for k in 0..self.n_r {
            let out = &mut self.rhs[k * n..(k + 1) * n];
            let r = k * n_q..(k + 1) * n_q;
            for ((o, acc_b), ab) in out[..n_q]
                .iter_mut()
                .zip(&self.acc_b[r.clone()])
                .zip(&self.ab[r])
            {
                *o = acc_b + ab;
            }
        }
        it.newton.factorize(at0.q, None, None, 1.0, 0.0, 0.0)?;
        let scale = it.newton.multiplier_scale();
        self.seed_multipliers(scale);
        it.newton
            .solve_block(&mut self.rhs, self.n_r, &mut self.scratch)?;
        it.newton.unaugment(&mut self.rhs);
        for k in 0..self.n_r {
            self.pseudo.subtract_transposed(
                it.assembler(),
                &at0,
                scale,
                &self.rhs[k * n..(k + 1) * n],
                &mut self.xb[k * n_x..(k + 1) * n_x],
            );
        }
        self.keep_weights(0);
        if let Some(eq) = it.equilibrium.clone() {
            let start = (at0.q, at0.rates.map_or(&[][..], |r| r.1), at0.lam);
            let (pseudo, rhs, qb, xb) = (&self.pseudo, &mut self.rhs, &mut self.qb, &mut self.xb);
            super::start::adjoint(it, &eq, start, pseudo, rhs, qb, xb)?;
        }
        Ok(())
    }
}
