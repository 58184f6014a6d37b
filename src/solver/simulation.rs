//! A dynamic run from `t = 0` to `t_end`: the time loop of Algorithm 1 with the recorded
//! trajectory, energies and Newton statistics.
//!
//! Energies: kinetic `T = ½ q̇ᵀ M q̇`, strain `U = Σ s(x_e) U_e`, the work of the drives
//! (motor torque times joint rotation) `W_d = Σₙ −½(λₙ + λₙ₊₁)_d (gₙ₊₁ − gₙ)_d` over the
//! prescribed angles `g = θ(t) − θ(0)`, and of applied loads and gravity
//! `W_e = ∫ (f_ext + M ĝ)ᵀ q̇ dt` and of the dampers `W_c = −∫ q̇ᵀ C q̇ dt` by the
//! trapezoidal rule. For an exact solution `T + U − W_d − W_e − W_c` is constant. The drive work uses the prescribed angle increments —
//! which the index-3 constraints enforce exactly — rather than discrete velocities: those
//! are not constrained, and with ρ∞ = 1 their error at a held joint never decays, which
//! would show as work done by a motor that does not move.

use crate::error::{Error, SettingsError, SolveError};
use crate::mechanism::model::Model;
use crate::settings::DynamicSettings;
use crate::solver::alpha::State;
use crate::solver::integrator::Integrator;
use crate::solver::step_control::{self, Controller, StepControl, Verdict};
use crate::time_grid::TimeGrid;

/// Largest trajectory a run records (bytes).
pub const MAX_TRAJECTORY_BYTES: f64 = 8.0 * (1u64 << 30) as f64;

/// Time histories of a dynamic run, each matrix row-major with one row per time.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Trajectory {
    /// Nodal DOFs per row.
    pub n_q: usize,
    /// Multipliers per row.
    pub n_c: usize,
    /// Times `t_n` (s).
    pub time: Vec<f64>,
    /// `q_n`.
    pub q: Vec<f64>,
    /// `q̇_n`.
    pub qdot: Vec<f64>,
    /// `q̈_n`.
    pub qddot: Vec<f64>,
    /// `λ_n`.
    pub lam: Vec<f64>,
    /// Newton iterations of each step (0 for `t = 0`).
    pub iterations: Vec<usize>,
    /// The step that reached each state (0 for `t = 0`): the grid a replay must follow.
    pub steps: Vec<f64>,
    /// Kinetic energy (J).
    pub kinetic: Vec<f64>,
    /// Strain energy (J).
    pub strain: Vec<f64>,
    /// Work done by the drives since `t = 0` (J).
    pub drive_work: Vec<f64>,
    /// Work done by loads and gravity since `t = 0` (J).
    pub external_work: Vec<f64>,
    /// Work done by the dampers since `t = 0`, `−∫ q̇ᵀ C q̇ dt` (J, never positive).
    pub damping_work: Vec<f64>,
}

impl Trajectory {
    fn record(&mut self, s: &State, iterations: usize) {
        self.time.push(s.t);
        self.q.extend_from_slice(&s.q);
        self.qdot.extend_from_slice(&s.qdot);
        self.qddot.extend_from_slice(&s.qddot);
        self.lam.extend_from_slice(&s.lam);
        self.iterations.push(iterations);
        self.steps.push(s.h);
    }

    /// The steps that ran, as a grid that replays them bitwise.
    pub fn grid(&self) -> TimeGrid {
        TimeGrid::from_steps(self.steps[1..].to_vec())
    }
}

/// Runs `model` with element scalings from design `x` (`None`: all bars at full density)
/// on the fixed-step grid of `settings`.
///
/// # Errors
/// Design, settings and solve errors ([`Error`]); a failed Newton step reports its time; a
/// trajectory larger than [`MAX_TRAJECTORY_BYTES`] is refused before the run.
pub fn simulate(
    model: &Model,
    x: Option<&[f64]>,
    settings: &DynamicSettings,
) -> Result<Trajectory, Error> {
    settings.validate()?;
    simulate_on(model, x, settings, &settings.grid())
}

/// Runs `model` for design `x` on the steps of `grid` (`settings.h` and `t_end` unused).
///
/// # Errors
/// As [`simulate`].
pub fn simulate_on(
    model: &Model,
    x: Option<&[f64]>,
    settings: &DynamicSettings,
    grid: &TimeGrid,
) -> Result<Trajectory, Error> {
    run_on(model, x, settings, grid, None)
}

/// [`simulate_on`] with each step's Newton iterations started from a nearby run's states:
/// `guide` holds `q` at the grid's times (`t₀` first, one row of the model's coordinates
/// per time), e.g. a coarser mesh's run carried over by [`crate::Prolongation`]. Step
/// `n + 1` starts from `guideₙ₊₁ + (qₙ − guideₙ)`: the guide's motion over the step plus
/// the difference the runs already have. The result is the same to Newton's tolerance; on
/// the x = 0.4 arm at twice the elements per bar, guided by the prolonged run at one,
/// Newton takes 75 iterations instead of 102.
///
/// # Errors
/// As [`simulate`]; a [`SettingsError`] when `guide` has not one finite row per time.
pub fn simulate_guided(
    model: &Model,
    x: Option<&[f64]>,
    settings: &DynamicSettings,
    grid: &TimeGrid,
    guide: &[f64],
) -> Result<Trajectory, Error> {
    let n_q = model.n_dofs();
    if guide.len() != (grid.len() + 1) * n_q || !guide.iter().all(|g| g.is_finite()) {
        let rows = format!("{} finite rows of {n_q} coordinates", grid.len() + 1);
        return Err(SettingsError::new(
            "guide",
            format!("needs {rows}, got {} values", guide.len()),
        )
        .into());
    }
    run_on(model, x, settings, grid, Some(guide))
}

/// The time loop over `grid`, each step from the predictor or, with a `guide`, from
/// `guideₙ₊₁ + (qₙ − guideₙ)`.
fn run_on(
    model: &Model,
    x: Option<&[f64]>,
    settings: &DynamicSettings,
    grid: &TimeGrid,
    guide: Option<&[f64]>,
) -> Result<Trajectory, Error> {
    check_size(model, grid.len() + 1)?;
    let mut run = Run::start(model, x, settings)?;
    let n_q = model.n_dofs();
    let mut guess = vec![0.0; if guide.is_some() { n_q } else { 0 }];
    for (n, &h) in grid.steps().iter().enumerate() {
        if let Some(guide) = guide {
            let (now, next) = (&guide[n * n_q..], &guide[(n + 1) * n_q..]);
            for (i, g) in guess.iter_mut().enumerate() {
                *g = next[i] + run.state.q[i] - now[i];
            }
        }
        run.energy.start_step(&run.state, h);
        let start = guide.map(|_| &guess[..]);
        let report = run.integrator.alpha_step_from(&mut run.state, h, start)?;
        run.record(report.iterations);
    }
    Ok(run.traj)
}

/// Runs `model` for design `x` with step sizes chosen by local error control
/// ([`crate::solver::step_control`]): steps rejected and retried where the local error on the
/// positions exceeds `control.tol`, cut to a quarter where Newton fails or its solution is
/// implausible (a cell turned inside out, a spring collapsed: often a step long enough to
/// reach another solution branch), ending exactly at the kinks of the motion laws and at
/// `settings.t_end`. The recorded [`Trajectory::grid`] replays the run (for its gradients,
/// [`crate::of_motion_on`]).
///
/// # Errors
/// As [`simulate`]; [`SolveError::StepTooSmall`] when the step falls below `control.h_min`
/// (the implausible state's own error where that was the last failure); a
/// [`SettingsError`] when the trajectory outgrows [`MAX_TRAJECTORY_BYTES`].
pub fn simulate_adaptive(
    model: &Model,
    x: Option<&[f64]>,
    settings: &DynamicSettings,
    control: &StepControl,
) -> Result<Trajectory, Error> {
    settings.validate()?;
    control.validate()?;
    let mut run = Run::start(model, x, settings)?;
    let mut stops = model.kinks(settings.t_end);
    stops.push(settings.t_end);
    let (scales, c) = (
        step_control::error_scales(model),
        step_control::local_error_constant(&run.integrator.params),
    );
    let mut controller = Controller::new(control);
    let mut before = run.state.clone();
    for stop in stops {
        // Until the stop, less the round-off of landing on it.
        while stop - run.state.t > 1e-12 * stop {
            let h = controller.step(run.state.t, stop);
            before.clone_from(&run.state);
            run.energy.start_step(&run.state, h);
            // The step's failure, where it was a state no material takes.
            let implausible = match run.integrator.alpha_step(&mut run.state, h) {
                Ok(report) => {
                    let error = step_control::local_error(
                        c,
                        h,
                        &before.qddot,
                        &run.state.qddot,
                        &scales,
                        control.tol,
                    );
                    if controller.judge(h, error) == Verdict::Reject {
                        run.state.clone_from(&before);
                    } else {
                        run.record(report.iterations);
                        check_size(model, run.traj.time.len())?;
                    }
                    None
                }
                Err(
                    e @ (SolveError::NewtonFailed { .. }
                    | SolveError::Diverged { .. }
                    | SolveError::CellInverted { .. }
                    | SolveError::SpringCollapsed { .. }),
                ) => {
                    run.state.clone_from(&before);
                    controller.newton_failed(h);
                    matches!(
                        e,
                        SolveError::CellInverted { .. } | SolveError::SpringCollapsed { .. }
                    )
                    .then_some(e)
                }
                Err(other) => return Err(other.into()),
            };
            if controller.too_small() {
                // A state no material takes, at every step down to the smallest: its error.
                return Err(implausible
                    .unwrap_or(SolveError::StepTooSmall {
                        time: run.state.t,
                        h_min: control.h_min,
                    })
                    .into());
            }
        }
    }
    Ok(run.traj)
}

/// A run under way: the integrator, the current state, the trajectory and energies
/// recorded so far (the initial state already).
struct Run<'m> {
    integrator: Integrator<'m>,
    state: State,
    traj: Trajectory,
    energy: EnergyBook,
}

impl<'m> Run<'m> {
    fn start(
        model: &'m Model,
        x: Option<&[f64]>,
        settings: &DynamicSettings,
    ) -> Result<Self, Error> {
        let mut integrator = Integrator::new(model, model.densities(x)?, settings)?;
        let state = integrator.initial_state()?;
        let traj = Trajectory {
            n_q: model.n_dofs(),
            n_c: model.n_constraints(),
            ..Default::default()
        };
        let energy = EnergyBook::new(model, &integrator, &state);
        let mut run = Self {
            integrator,
            state,
            traj,
            energy,
        };
        run.record(0);
        Ok(run)
    }

    /// Records the current state, reached with `iterations` Newton iterations.
    fn record(&mut self, iterations: usize) {
        self.traj.record(&self.state, iterations);
        self.energy
            .record(&self.integrator, &self.state, &mut self.traj);
    }
}

/// Bytes recorded per state: `q`, `q̇`, `q̈`, `λ` and six scalars.
fn bytes_per_state(model: &Model) -> f64 {
    (3 * model.n_dofs() + model.n_constraints() + 6) as f64 * 8.0
}

/// Refuses a run whose trajectory of `states` would exceed [`MAX_TRAJECTORY_BYTES`].
fn check_size(model: &Model, states: usize) -> Result<(), SettingsError> {
    let bytes = states as f64 * bytes_per_state(model);
    if bytes > MAX_TRAJECTORY_BYTES {
        return Err(SettingsError::new(
            "h",
            format!("{} steps of {} coordinates would record {:.1} GiB of trajectory (at most {:.0} GiB); increase h or shorten t_end", states - 1, model.n_dofs(), bytes / (1u64 << 30) as f64, MAX_TRAJECTORY_BYTES / (1u64 << 30) as f64),
        ));
    }
    Ok(())
}

/// The energy bookkeeping of a run: kinetic and strain energy at each state, the work of
/// the drives and of the loads accumulated step by step.
struct EnergyBook {
    /// Driven constraint rows.
    driven: Vec<usize>,
    /// `λₙ`, `tₙ` and `hₙ` of the current step.
    lambda0: Vec<f64>,
    t0: f64,
    h: f64,
    /// External power and the dampers' power at the start of the current step.
    power0: f64,
    damping0: f64,
    force: Vec<f64>,
    mv: Vec<f64>,
}

impl EnergyBook {
    fn new(model: &Model, it: &Integrator, s: &State) -> Self {
        let mut book = Self {
            driven: (0..model.n_constraints())
                .filter(|&k| model.constraints().driven(k))
                .collect(),
            lambda0: s.lam.clone(),
            t0: s.t,
            h: 0.0,
            power0: 0.0,
            damping0: 0.0,
            force: vec![0.0; model.n_dofs()],
            mv: vec![0.0; model.n_dofs()],
        };
        book.power0 = book.external_power(it, s);
        book
    }

    /// Remembers the state at the start of a step of size `h`.
    fn start_step(&mut self, s: &State, h: f64) {
        self.lambda0.copy_from_slice(&s.lam);
        self.t0 = s.t;
        self.h = h;
    }

    /// Records the energies of state `s`, with the work done since the step started.
    fn record(&mut self, it: &Integrator, s: &State, traj: &mut Trajectory) {
        traj.kinetic.push(self.kinetic(it, s));
        traj.strain.push(it.assembler().strain_energy(&s.q));
        let Some(&drive_work) = traj.drive_work.last() else {
            traj.drive_work.push(0.0);
            traj.external_work.push(0.0);
            traj.damping_work.push(0.0);
            return;
        };
        let model = it.assembler().model;
        let angle =
            |k: usize, t: f64| model.joints[model.rows[k].joint].prescribed(&model.rows[k], t)[0];
        let drives: f64 = self
            .driven
            .iter()
            .map(|&k| -0.5 * (self.lambda0[k] + s.lam[k]) * (angle(k, s.t) - angle(k, self.t0)))
            .sum();
        traj.drive_work.push(drive_work + drives);
        let power = self.external_power(it, s);
        let external = traj.external_work.last().copied().unwrap_or(0.0);
        traj.external_work
            .push(external + 0.5 * self.h * (self.power0 + power));
        self.power0 = power;
        let damping = self.damping_power(it, s);
        let dissipated = traj.damping_work.last().copied().unwrap_or(0.0);
        traj.damping_work
            .push(dissipated + 0.5 * self.h * (self.damping0 + damping));
        self.damping0 = damping;
    }

    /// Power `−q̇ᵀ f_d` of the dampers and the beams' Rayleigh damping.
    fn damping_power(&mut self, it: &Integrator, s: &State) -> f64 {
        self.mv.fill(0.0);
        let asm = it.assembler();
        asm.add_damping_times(&s.qdot, &mut self.mv);
        asm.add_structural_damping(&s.q, &s.qdot, &mut self.mv, None, None);
        -dot(&s.qdot, &self.mv)
    }

    fn kinetic(&mut self, it: &Integrator, s: &State) -> f64 {
        it.assembler().mass_times(&s.qdot, &mut self.mv);
        0.5 * dot(&s.qdot, &self.mv)
    }

    /// Power `(f_ext + M ĝ)ᵀ q̇` of loads and gravity.
    fn external_power(&mut self, it: &Integrator, s: &State) -> f64 {
        it.assembler().applied_loads(s.t, 1.0, &mut self.force);
        dot(&self.force, &s.qdot)
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}
