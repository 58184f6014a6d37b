//! A dynamic run from `t = 0` to `t_end`: the time loop of Algorithm 1 with the recorded
//! trajectory, energies and Newton statistics.
//!
//! Energies: kinetic `T = ½ q̇ᵀ M q̇`, strain `U = Σ s(x_e) U_e`, the work of the drives
//! (motor torque times joint rotation) `W_d = Σₙ −½(λₙ + λₙ₊₁)_d (gₙ₊₁ − gₙ)_d` over the
//! prescribed angles `g = θ(t) − θ(0)`, and of applied loads and gravity
//! `W_e = ∫ (f_ext + M ĝ)ᵀ q̇ dt` by the trapezoidal rule. For an exact solution
//! `T + U − W_d − W_e` is constant. The drive work uses the prescribed angle increments —
//! which the index-3 constraints enforce exactly — rather than discrete velocities: those
//! are not constrained, and with ρ∞ = 1 their error at a held joint never decays, which
//! would show as work done by a motor that does not move.

use crate::error::{Error, SettingsError};

/// Largest trajectory a run records (bytes).
pub const MAX_TRAJECTORY_BYTES: f64 = 8.0 * (1u64 << 30) as f64;
use crate::integrator::{Integrator, Settings, State};
use crate::model::Model;

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
    pub v: Vec<f64>,
    /// `q̈_n`.
    pub acc: Vec<f64>,
    /// `λ_n`.
    pub lambda: Vec<f64>,
    /// Newton iterations of each step (0 for `t = 0`).
    pub iterations: Vec<usize>,
    /// Kinetic energy (J).
    pub kinetic: Vec<f64>,
    /// Strain energy (J).
    pub strain: Vec<f64>,
    /// Work done by the drives since `t = 0` (J).
    pub drive_work: Vec<f64>,
    /// Work done by loads and gravity since `t = 0` (J).
    pub external_work: Vec<f64>,
}

impl Trajectory {
    fn record(&mut self, s: &State, iterations: usize) {
        self.time.push(s.t);
        self.q.extend_from_slice(&s.q);
        self.v.extend_from_slice(&s.v);
        self.acc.extend_from_slice(&s.acc);
        self.lambda.extend_from_slice(&s.lambda);
        self.iterations.push(iterations);
    }
}

/// Runs `model` with element scalings from design `x` (`None`: all bars at full density).
///
/// # Errors
/// Design, settings and solve errors ([`Error`]); a failed Newton step reports its time; a
/// trajectory larger than [`MAX_TRAJECTORY_BYTES`] is refused before the run.
pub fn simulate(
    model: &Model,
    x: Option<&[f64]>,
    settings: &Settings,
) -> Result<Trajectory, Error> {
    settings.validate()?;
    let bytes = (settings.steps() + 1) as f64
        * (3 * model.n_dofs() + model.n_constraints() + 6) as f64
        * 8.0;
    if bytes > MAX_TRAJECTORY_BYTES {
        return Err(SettingsError::new(
            "h",
            format!("{} steps of {} coordinates would record {:.1} GiB of trajectory (at most {:.0} GiB); increase h or shorten t_end", settings.steps(), model.n_dofs(), bytes / (1u64 << 30) as f64, MAX_TRAJECTORY_BYTES / (1u64 << 30) as f64),
        )
        .into());
    }
    let densities = model.densities(x)?;
    let mut integrator = Integrator::new(model, densities, settings);
    let mut state = integrator.initial_state()?;
    let mut traj = Trajectory {
        n_q: model.n_dofs(),
        n_c: model.n_constraints(),
        ..Default::default()
    };
    let mut scratch = EnergyScratch::new(model);
    traj.record(&state, 0);
    let mut last = scratch.external_power(&integrator, &state);
    let driven: Vec<usize> = (0..model.n_constraints())
        .filter(|&k| model.rows[k].driven)
        .collect();
    let angle =
        |k: usize, t: f64| model.joints[model.rows[k].joint].prescribed(&model.rows[k], t)[0];
    traj.kinetic.push(scratch.kinetic(&integrator, &state));
    traj.strain
        .push(integrator.newton.asm.strain_energy(&state.q));
    traj.drive_work.push(0.0);
    traj.external_work.push(0.0);
    let mut lambda0 = state.lambda.clone();
    for _ in 0..settings.steps() {
        let t0 = state.t;
        lambda0.copy_from_slice(&state.lambda);
        let report = integrator.alpha_step(&mut state)?;
        traj.record(&state, report.iterations);
        let now = scratch.external_power(&integrator, &state);
        let drives: f64 = driven
            .iter()
            .map(|&k| -0.5 * (lambda0[k] + state.lambda[k]) * (angle(k, state.t) - angle(k, t0)))
            .sum();
        traj.drive_work
            .push(traj.drive_work.last().unwrap() + drives);
        traj.external_work
            .push(traj.external_work.last().unwrap() + 0.5 * integrator.h * (last + now));
        traj.kinetic.push(scratch.kinetic(&integrator, &state));
        traj.strain
            .push(integrator.newton.asm.strain_energy(&state.q));
        last = now;
    }
    Ok(traj)
}

/// Work vectors for the energy bookkeeping.
struct EnergyScratch {
    force: Vec<f64>,
    mv: Vec<f64>,
}

impl EnergyScratch {
    fn new(model: &Model) -> Self {
        Self {
            force: vec![0.0; model.n_dofs()],
            mv: vec![0.0; model.n_dofs()],
        }
    }

    fn kinetic(&mut self, it: &Integrator, s: &State) -> f64 {
        it.newton.asm.mass_times(&s.v, &mut self.mv);
        0.5 * dot(&s.v, &self.mv)
    }

    /// Power `(f_ext + M ĝ)ᵀ q̇` of loads and gravity.
    fn external_power(&mut self, it: &Integrator, s: &State) -> f64 {
        it.newton.asm.applied_loads(s.t, 1.0, &mut self.force);
        dot(&self.force, &s.v)
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}
