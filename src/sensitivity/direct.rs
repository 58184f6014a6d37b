//! Direct differentiation of the generalized-α scheme (paper Algorithm 2, Eq. 20–24).
//!
//! For each design variable `j` the sensitivities `(q', q̇', q̈', a')` follow the linear
//! step (primes are `∂/∂x_j`; `h`, `β'`, `γ'` of the step taken):
//!
//! ```text
//! Pₙ  = q'ₙ + h q̇'ₙ + h²(½ − β) a'ₙ
//! cₙ  = −β' Pₙ + (α_m a'ₙ − α_f q̈'ₙ)/(1 − α_f)
//! S_t [q'ₙ₊₁; μ'ₙ₊₁] = [−(M cₙ + ∂r/∂x_j); 0]           (S_t at the converged state,
//!                                                      λ'ₙ₊₁ = s μ'ₙ₊₁)
//! q̈'ₙ₊₁ = β' q'ₙ₊₁ + cₙ,  a'ₙ₊₁ = (q'ₙ₊₁ − Pₙ)/(h²β),  q̇'ₙ₊₁ = q̇'ₙ + h(1 − γ) a'ₙ + hγ a'ₙ₊₁
//! ```
//!
//! starting from `q'₀ = q̇'₀ = 0` (the initial state does not depend on `x`) and `q̈'₀`
//! from the initial-acceleration system. A step that began with a restart at a kink first
//! adds that restart's `Δq̈'` to `q̈'` and `a'` ([`super::kink`]). Where the step size
//! changes, `a'` is carried to the new step as `a` is: `a' ← q̈' + (hₙ/hₙ₋₁)(a' − q̈')`.
//! The factorization of `S_t` is shared by all columns, which are solved in blocks in
//! parallel (rayon).

use std::time::Instant;

use faer::dyn_stack::MemBuffer;
use rayon::prelude::*;

use super::{Method, Objectives, PseudoLoads, Sensitivities, Timings};
use crate::error::{Error, SolveError};
use crate::mechanism::element::MassKind;
use crate::mechanism::model::{Densities, Model};
use crate::mechanism::parameter::{At, Level, Parameter};
use crate::response::{Context, Response, Sample};
use crate::settings::DynamicSettings;
use crate::solver::alpha::{rescale_pseudo_accelerations, step_ratio, AlphaParameters, State};
use crate::solver::integrator::Integrator;
use crate::solver::kink::Jump;
use crate::time_grid::TimeGrid;

/// Columns per parallel block.
fn block_width(n_x: usize) -> usize {
    n_x.div_ceil(4 * rayon::current_num_threads()).clamp(1, 64)
}

/// Runs the simulation on `grid` and its direct sensitivity analysis.
pub(crate) fn differentiate_forward(
    model: &Model,
    densities: Densities,
    settings: &DynamicSettings,
    grid: &TimeGrid,
    responses: &[Response],
    parameters: &[Parameter],
) -> Result<Sensitivities, Error> {
    let mut it = Integrator::new(model, densities, settings)?;
    let mut objectives = Objectives::new(model, responses, parameters, grid)?;
    let pseudo = PseudoLoads::new(model, settings.mass, parameters);
    let mut sweep = Sweep::new(model, &it, settings, pseudo, responses.len());
    let mut timings = Timings::default();
    let clock = Instant::now();
    let mut state = it.initial_state()?;
    timings.simulation += clock.elapsed().as_secs_f64();
    let clock = Instant::now();
    sweep.initial(&mut it, &state)?;
    sweep.accumulate(&it, &mut objectives, 0, &state);
    timings.gradients += clock.elapsed().as_secs_f64();
    for (n, &h) in grid.steps().iter().enumerate() {
        let clock = Instant::now();
        it.alpha_step(&mut state, h)?;
        timings.simulation += clock.elapsed().as_secs_f64();
        let clock = Instant::now();
        sweep.step(&mut it, &state, h)?;
        sweep.accumulate(&it, &mut objectives, n + 1, &state);
        timings.gradients += clock.elapsed().as_secs_f64();
    }
    objectives.finish(&mut sweep.values, &mut sweep.gradients);
    let peaks = objectives.peaks();
    Ok(Sensitivities::new(
        model,
        sweep.values,
        &sweep.gradients,
        Method::Direct,
        timings,
        peaks,
    ))
}

/// The sensitivity states of every design variable and the responses accumulated so far.
struct Sweep<'a> {
    pseudo: PseudoLoads,
    mass: MassKind,
    /// `n_q`, `n_q + n_c`, design variables and parameters, columns per parallel block.
    n_q: usize,
    n: usize,
    n_x: usize,
    width: usize,
    /// Column-major `n_q × n_x`: `q'`, `q̇'`, `q̈'`, `a'`.
    dq: Vec<f64>,
    dv: Vec<f64>,
    dacc: Vec<f64>,
    da: Vec<f64>,
    /// Right-hand sides / solutions, column-major `n × n_x`.
    rhs: Vec<f64>,
    /// Size of the last step (0 before the first).
    previous: f64,
    scratch: Vec<MemBuffer>,
    /// Per block, work space of the exact solves with damping.
    work: Vec<Vec<f64>>,
    values: Vec<f64>,
    /// Row-major `n_responses × n_x`.
    gradients: Vec<f64>,
    g_q: Vec<f64>,
    g_lam: Vec<f64>,
    g_x: Vec<f64>,
    g_v: Vec<f64>,
    model: &'a Model,
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
        let width = block_width(n_x);
        Self {
            pseudo,
            mass: settings.mass,
            n_q,
            n,
            n_x,
            width,
            dq: vec![0.0; n_q * n_x],
            dv: vec![0.0; n_q * n_x],
            dacc: vec![0.0; n_q * n_x],
            da: vec![0.0; n_q * n_x],
            rhs: vec![0.0; n * n_x],
            previous: 0.0,
            scratch: (0..n_x.div_ceil(width))
                .map(|_| it.newton.scratch(width))
                .collect(),
            work: vec![Vec::new(); n_x.div_ceil(width)],
            values: vec![0.0; n_r],
            gradients: vec![0.0; n_r * n_x],
            g_q: vec![0.0; n_q],
            g_lam: vec![0.0; n - n_q],
            g_x: vec![0.0; n_x],
            g_v: vec![0.0; n_q],
            model,
        }
    }

    /// `t = 0`: `[M, Φ_qᵀ; Φ_q, 0] [q̈'₀; λ'₀] = [−∂r/∂x; 0]`, `a'₀ = q̈'₀`; from the
    /// static equilibrium, `q'₀` first and its terms in that system ([`super::start`]).
    fn initial(&mut self, it: &mut Integrator, s: &State) -> Result<(), SolveError> {
        let (n, n_q, n_x, width) = (self.n, self.n_q, self.n_x, self.width);
        let equilibrium = it.equilibrium.clone();
        if let Some(eq) = &equilibrium {
            self.dq = super::start::direct(it, eq, &self.pseudo)?;
        }
        it.newton.factorize(&s.q, None, None, 1.0, 0.0, 0.0)?;
        let scale = it.newton.multiplier_scale();
        self.rhs.fill(0.0);
        let at = At {
            q: &s.q,
            rates: Some((&s.qdot, &s.qddot)),
            lam: &s.lam,
            t: s.t,
            level: Level::Acceleration,
        };
        let asm = it.newton.assembler();
        self.pseudo
            .subtract_columns(asm, &at, scale, &mut self.rhs, n, 0..n_x);
        if equilibrium.is_some() {
            super::start::add_initial_terms(it, s, &self.dq, scale, &mut self.rhs);
        }
        if equilibrium.is_some() || self.pseudo.moves_constraints() {
            it.newton.augment(&mut self.rhs);
        }
        let newton = &it.newton;
        self.rhs
            .par_chunks_mut(n * width)
            .zip(self.scratch.par_iter_mut())
            .try_for_each(|(block, buf)| newton.solve_block(block, block.len() / n, buf))?;
        for j in 0..n_x {
            self.dacc[j * n_q..(j + 1) * n_q].copy_from_slice(&self.rhs[j * n..j * n + n_q]);
        }
        self.da.copy_from_slice(&self.dacc);
        Ok(())
    }

    /// The linear sensitivity step to the converged state `s`, taken with step size `h`:
    /// predict the parts independent of `q'ₙ₊₁`, solve for it, correct.
    fn step(&mut self, it: &mut Integrator, s: &State, h: f64) -> Result<(), SolveError> {
        if let Some(jump) = it.restart.clone() {
            self.restart(it, &jump)?;
        }
        let p = it.params;
        let bp = p.beta_prime(h);
        let ratio = step_ratio(self.previous, h);
        self.previous = h;
        it.newton
            .factorize(&s.q, Some(&s.lam), Some(&s.qdot), bp, p.gamma_prime(h), s.t)?;
        let newton = &it.newton;
        let (n, n_q, width, pseudo) = (self.n, self.n_q, self.width, &self.pseudo);
        let (scale, augmented) = (newton.multiplier_scale(), pseudo.moves_constraints());
        let at = At {
            q: &s.q,
            rates: Some((&s.qdot, &s.qddot)),
            lam: &s.lam,
            t: s.t,
            level: Level::Position,
        };
        self.rhs
            .par_chunks_mut(n * width)
            .zip(self.dq.par_chunks_mut(n_q * width))
            .zip(self.dv.par_chunks_mut(n_q * width))
            .zip(self.dacc.par_chunks_mut(n_q * width))
            .zip(self.da.par_chunks_mut(n_q * width))
            .zip(self.scratch.par_iter_mut().zip(self.work.par_iter_mut()))
            .enumerate()
            .try_for_each(|(block, (((((rhs, dq), dv), dacc), da), (buf, work)))| {
                let cols = rhs.len() / n;
                for col in 0..cols {
                    let r = col * n_q..(col + 1) * n_q;
                    if let Some(ratio) = ratio {
                        rescale_pseudo_accelerations(&mut da[r.clone()], &dacc[r.clone()], ratio);
                    }
                    predict(
                        &p,
                        h,
                        &dq[r.clone()],
                        &mut dv[r.clone()],
                        &mut dacc[r.clone()],
                        &mut da[r],
                    );
                    let out = &mut rhs[col * n..(col + 1) * n];
                    let asm = newton.assembler();
                    asm.mass_times(&dacc[col * n_q..(col + 1) * n_q], out);
                    newton.add_damping_times(&dv[col * n_q..(col + 1) * n_q], out);
                    out[..n_q].iter_mut().for_each(|v| *v = -*v);
                    out[n_q..].fill(0.0);
                }
                let first = block * width;
                let asm = newton.assembler();
                pseudo.subtract_columns(asm, &at, scale, rhs, n, first..first + cols);
                if augmented {
                    newton.augment(rhs);
                }
                newton.solve_exact(rhs, cols, buf, false, work)?;
                for col in 0..cols {
                    let r = col * n_q..(col + 1) * n_q;
                    let new = &rhs[col * n..col * n + n_q];
                    correct(
                        &p,
                        h,
                        new,
                        &mut dq[r.clone()],
                        &mut dv[r.clone()],
                        &mut dacc[r.clone()],
                        &mut da[r],
                    );
                }
                Ok(())
            })
    }

    /// The restart the step began with, at a kink: `q̈'ₖ` and `a'ₖ` gain `Δq̈'`
    /// ([`super::kink::direct`]).
    fn restart(&mut self, it: &mut Integrator, jump: &Jump) -> Result<(), SolveError> {
        super::kink::direct(it, jump, &self.pseudo, &self.dq, &mut self.rhs)?;
        let (n, n_q) = (self.n, self.n_q);
        for (j, solution) in self.rhs.chunks(n).enumerate() {
            let r = j * n_q..(j + 1) * n_q;
            for ((acc, a), d) in self.dacc[r.clone()]
                .iter_mut()
                .zip(&mut self.da[r])
                .zip(&solution[..n_q])
            {
                *acc += d;
                *a += d;
            }
        }
        Ok(())
    }

    /// Adds state `n`'s share of the responses and of their gradients
    /// `G_x + G_q q' + G_λ λ'`, with `λ' = s μ'` from the solutions of the step (or of the
    /// initial system) just solved.
    fn accumulate(&mut self, it: &Integrator, objectives: &mut Objectives, n: usize, s: &State) {
        let ctx = Context::dynamic(self.model, &it.assembler().densities, self.mass);
        let at = Sample {
            q: &s.q,
            v: &s.qdot,
            lam: &s.lam,
            t: s.t,
        };
        objectives.observe(&ctx, at, &mut self.values, &mut self.gradients);
        objectives.add_values(&ctx, n, at, &mut self.values);
        let (size, n_q, n_x, scale) = (self.n, self.n_q, self.n_x, it.newton.multiplier_scale());
        // `max(1)`: a model without design variables has no gradient rows to visit.
        for (k, row) in self.gradients.chunks_mut(n_x.max(1)).enumerate() {
            self.g_q.fill(0.0);
            self.g_lam.fill(0.0);
            self.g_x.fill(0.0);
            self.g_v.fill(0.0);
            objectives.add_partials(
                &ctx,
                k,
                n,
                at,
                &mut self.g_q,
                &mut self.g_lam,
                &mut self.g_x,
                &mut self.g_v,
            );
            let (g_q, g_lam, g_x, dq, rhs) =
                (&self.g_q, &self.g_lam, &self.g_x, &self.dq, &self.rhs);
            let multipliers = g_lam.iter().any(|&g| g != 0.0);
            let rates = objectives.read_velocities();
            let (g_v, dv) = (&self.g_v, &self.dv);
            row.par_iter_mut().enumerate().for_each(|(j, g)| {
                *g += g_x[j] + dot(g_q, &dq[j * n_q..(j + 1) * n_q]);
                if multipliers {
                    *g += scale * dot(g_lam, &rhs[j * size + n_q..(j + 1) * size]);
                }
                if rates {
                    *g += dot(g_v, &dv[j * n_q..(j + 1) * n_q]);
                }
            });
        }
    }
}

/// The parts of the sensitivity update that do not depend on `q'ₙ₊₁`: with
/// `Pₙ = q'ₙ + h q̇'ₙ + h²(½ − β) a'ₙ`, `q̈'` becomes `cₙ`, `q̇'` and `a'` their predictors.
fn predict(
    p: &AlphaParameters,
    h: f64,
    dq: &[f64],
    dv: &mut [f64],
    dacc: &mut [f64],
    da: &mut [f64],
) {
    let AlphaParameters {
        alpha_m,
        alpha_f,
        beta,
        gamma,
    } = *p;
    let (bp, gp) = (p.beta_prime(h), p.gamma_prime(h));
    for i in 0..dq.len() {
        let pn = dq[i] + h * dv[i] + h * h * (0.5 - beta) * da[i];
        dacc[i] = -bp * pn + (alpha_m * da[i] - alpha_f * dacc[i]) / (1.0 - alpha_f);
        dv[i] += h * (1.0 - gamma) * da[i] - gp * pn;
        da[i] = -pn / (h * h * beta);
    }
}

/// Completes the update with the solved `q'ₙ₊₁`: `q̇' += γ' q'ₙ₊₁`,
/// `a' += q'ₙ₊₁/(h²β)`, `q̈' += β' q'ₙ₊₁`.
fn correct(
    p: &AlphaParameters,
    h: f64,
    new: &[f64],
    dq: &mut [f64],
    dv: &mut [f64],
    dacc: &mut [f64],
    da: &mut [f64],
) {
    let (bp, gp) = (p.beta_prime(h), p.gamma_prime(h));
    dq.copy_from_slice(new);
    for (i, &d) in new.iter().enumerate() {
        dv[i] += gp * d;
        da[i] += d / (h * h * p.beta);
        dacc[i] += bp * d;
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}
