//! The discrete adjoint of the generalized-α scheme.
//!
//! The direct step (see [`super::direct`]) is linear in the previous sensitivities; its
//! transpose runs backwards. With adjoint variables `(q̄, q̄̇, ā, Ā)` of `(q', q̇', a', q̈')` at
//! step `n + 1` (one column per response) the sweep from `n + 1` to `n` is
//!
//! ```text
//! ā⁺ = ā + hγ q̄̇,   q̃ = q̄ + β' Ā + ā⁺/(h²β)               (total adjoint of q'ₙ₊₁)
//! S_t μ = [q̃; 0]                                          (S_t symmetric, at qₙ₊₁)
//! c̄ = Ā − M μ,     x̄ −= (∂r/∂x)ᵀ μ
//! P̄ = −ā⁺/(h²β) − β' c̄
//! q̄ₙ = P̄ + wₙ G_q,  q̄̇ₙ = q̄̇ + h P̄,  āₙ = h(1−γ) q̄̇ + α_m c̄/(1−α_f) + h²(½−β) P̄,  Āₙ = −α_f c̄/(1−α_f)
//! ```
//!
//! and at `t = 0` the initial-acceleration system takes `Ā₀ + ā₀`. The backward sweep
//! needs `qₙ` and `q̈ₙ` of every step: a `StateStore` keeps them all, or only full states
//! at checkpoints every `K ≈ √N` steps and replays one segment at a time (bitwise identical,
//! since the replay repeats the same arithmetic) — memory `O(√N)` states for one more
//! forward sweep. Either way the cost is one extra factorization and solve per step,
//! whatever the number of design variables.

use std::time::Instant;

use faer::dyn_stack::MemBuffer;

use super::{Memory, Method, Objectives, PseudoLoads, Sensitivities, Timings};
use crate::error::{Error, SolveError};
use crate::integrator::{AlphaParameters, Integrator, Settings, State};
use crate::linsolve::FactorError;
use crate::model::Model;
use crate::response::{Context, Response};

/// The `(qₙ, q̈ₙ)` of a run, for the backward sweep.
enum StateStore {
    /// Every step stored: row `n` of each.
    All { q: Vec<f64>, acc: Vec<f64> },
    /// Full states every `interval` steps; the segment last replayed, from step `first`.
    Checkpoints {
        interval: usize,
        states: Vec<State>,
        first: usize,
        q: Vec<f64>,
        acc: Vec<f64>,
    },
}

impl StateStore {
    /// Records state `n` of the forward sweep.
    fn record(&mut self, n: usize, s: &State) {
        match self {
            Self::All { q, acc } => {
                q.extend_from_slice(&s.q);
                acc.extend_from_slice(&s.acc);
            }
            Self::Checkpoints {
                interval, states, ..
            } => {
                if n.is_multiple_of(*interval) {
                    states.push(s.clone());
                }
            }
        }
    }

    /// `(qₙ, q̈ₙ)`, replaying the segment holding step `n` if needed (`prefer_below`: of two
    /// segments holding `n`, the one below, as the sweep from `n` to `n − 1` needs).
    fn get(
        &mut self,
        it: &mut Integrator,
        n: usize,
        last: usize,
        prefer_below: bool,
    ) -> Result<(&[f64], &[f64]), Error> {
        let n_q = it.newton.asm.model.n_dofs();
        let rows = |k: usize| k * n_q..(k + 1) * n_q;
        match self {
            Self::All { q, acc } => Ok((&q[rows(n)], &acc[rows(n)])),
            Self::Checkpoints {
                interval,
                states,
                first,
                q,
                acc,
            } => {
                let k = *interval;
                let held = n >= *first && n <= (*first + k).min(last) && !q.is_empty();
                if !held || (prefer_below && n == *first && n > 0) {
                    let segment = if prefer_below && n > 0 {
                        (n - 1) / k
                    } else {
                        n / k
                    };
                    let mut state = states[segment].clone();
                    *first = segment * k;
                    q.clear();
                    acc.clear();
                    q.extend_from_slice(&state.q);
                    acc.extend_from_slice(&state.acc);
                    for _ in *first + 1..=(*first + k).min(last) {
                        it.alpha_step(&mut state)?;
                        q.extend_from_slice(&state.q);
                        acc.extend_from_slice(&state.acc);
                    }
                }
                let r = rows(n - *first);
                Ok((&q[r.clone()], &acc[r]))
            }
        }
    }

    /// The checkpoint interval `memory` asks for with `n_q` DOFs over `steps` steps, if any.
    fn checkpoint_interval(memory: Memory, n_q: usize, steps: usize) -> Option<usize> {
        let interval = (steps as f64).sqrt().ceil() as usize;
        match memory {
            Memory::StoreAll => None,
            Memory::Checkpoints => Some(interval.max(1)),
            Memory::Auto { budget_bytes } => {
                (2 * n_q * (steps + 1) * 8 > budget_bytes).then_some(interval.max(1))
            }
        }
    }
}

/// Runs the simulation, keeping what the backward sweep needs, then the adjoint sweep.
pub(crate) fn run(
    model: &Model,
    x: &[f64],
    settings: &Settings,
    responses: &[Response],
    memory: Memory,
) -> Result<Sensitivities, Error> {
    let densities = model.densities(Some(x))?;
    let mut it = Integrator::new(model, densities, settings);
    let (n_q, n_x, n_r) = (model.n_dofs(), model.n_variables(), responses.len());
    let n = n_q + model.n_constraints();
    let last = settings.steps();
    let objectives = Objectives::new(model, responses, last, settings.step())?;
    let pseudo = PseudoLoads::new(model, settings.mass);
    let mut store = match StateStore::checkpoint_interval(memory, n_q, last) {
        None => StateStore::All {
            q: Vec::with_capacity(n_q * (last + 1)),
            acc: Vec::with_capacity(n_q * (last + 1)),
        },
        Some(interval) => StateStore::Checkpoints {
            interval,
            states: Vec::new(),
            first: 0,
            q: Vec::new(),
            acc: Vec::new(),
        },
    };

    // Forward sweep: the values, and the states (or checkpoints) of the backward sweep.
    let clock = Instant::now();
    let mut state = it.initial_state()?;
    let mut values = vec![0.0; n_r];
    for step in 0..=last {
        if step > 0 {
            it.alpha_step(&mut state)?;
        }
        let ctx = Context::dynamic(model, &it.newton.asm.densities, settings.mass);
        objectives.add_values(&ctx, step, &state.q, &mut values);
        store.record(step, &state);
    }
    let simulation = clock.elapsed().as_secs_f64();
    let clock = Instant::now();

    // Backward sweep, one column per response.
    let AlphaParameters {
        alpha_m,
        alpha_f,
        beta,
        gamma,
    } = it.params;
    let h = it.h;
    let bp = it.params.beta_prime(h);
    let (mut qb, mut vb, mut ab, mut acc_b) = (
        vec![0.0; n_q * n_r],
        vec![0.0; n_q * n_r],
        vec![0.0; n_q * n_r],
        vec![0.0; n_q * n_r],
    );
    let mut xb = vec![0.0; n_x * n_r];
    let mut rhs = vec![0.0; n * n_r];
    let mut c = vec![0.0; n_q];
    let mut scratch: MemBuffer = it.newton.ldlt.scratch_for(n_r);
    let singular =
        |t: f64| move |FactorError::Singular(detail)| SolveError::Singular { time: t, detail };
    let add_local = |it: &Integrator, step: usize, q: &[f64], qb: &mut [f64], xb: &mut [f64]| {
        let ctx = Context::dynamic(model, &it.newton.asm.densities, settings.mass);
        for k in 0..n_r {
            objectives.add_partials(
                &ctx,
                k,
                step,
                q,
                &mut qb[k * n_q..(k + 1) * n_q],
                &mut xb[k * n_x..(k + 1) * n_x],
            );
        }
    };
    let (q_last, _) = store.get(&mut it, last, last, true)?;
    add_local(&it, last, q_last, &mut qb, &mut xb);
    for step in (0..last).rev() {
        let (q1, acc1) = store.get(&mut it, step + 1, last, true)?;
        let t1 = (step + 1) as f64 * h;
        for k in 0..n_r {
            let r = k * n_q..(k + 1) * n_q;
            let out = &mut rhs[k * n..(k + 1) * n];
            for i in 0..n_q {
                let a_total = ab[r.start + i] + h * gamma * vb[r.start + i];
                out[i] = qb[r.start + i] + bp * acc_b[r.start + i] + a_total / (h * h * beta);
                ab[r.start + i] = a_total; // kept for P̄ below
            }
            out[n_q..].fill(0.0);
        }
        it.newton.factorize_at(Some(q1), bp, it.newton.scale, t1)?;
        it.newton
            .ldlt
            .solve_block(&mut rhs, n_r, &mut scratch)
            .map_err(singular(t1))?;
        let asm = &it.newton.asm;
        for k in 0..n_r {
            let r = k * n_q..(k + 1) * n_q;
            let mu = &rhs[k * n..k * n + n_q];
            pseudo.subtract_transposed(asm, q1, Some(acc1), mu, &mut xb[k * n_x..(k + 1) * n_x]);
            asm.mass_times(mu, &mut c);
            for i in 0..n_q {
                let j = r.start + i;
                let cbar = acc_b[j] - c[i];
                let pbar = -ab[j] / (h * h * beta) - bp * cbar;
                let vbar = vb[j];
                qb[j] = pbar;
                vb[j] = vbar + h * pbar;
                ab[j] = h * (1.0 - gamma) * vbar
                    + alpha_m * cbar / (1.0 - alpha_f)
                    + h * h * (0.5 - beta) * pbar;
                acc_b[j] = -alpha_f * cbar / (1.0 - alpha_f);
            }
        }
        let (q0, _) = store.get(&mut it, step, last, false)?;
        add_local(&it, step, q0, &mut qb, &mut xb);
    }
    // t = 0: q̈'₀ from [M, Φ_qᵀ; Φ_q, 0]; a'₀ = q̈'₀.
    for k in 0..n_r {
        let out = &mut rhs[k * n..(k + 1) * n];
        for i in 0..n_q {
            out[i] = acc_b[k * n_q + i] + ab[k * n_q + i];
        }
        out[n_q..].fill(0.0);
    }
    let (q0, acc0) = store.get(&mut it, 0, last, false)?;
    let s0 = it.newton.initial_scale();
    it.newton.factorize_at(None, 1.0, s0, 0.0)?;
    it.newton
        .ldlt
        .solve_block(&mut rhs, n_r, &mut scratch)
        .map_err(singular(0.0))?;
    for k in 0..n_r {
        pseudo.subtract_transposed(
            &it.newton.asm,
            q0,
            Some(acc0),
            &rhs[k * n..k * n + n_q],
            &mut xb[k * n_x..(k + 1) * n_x],
        );
    }
    Ok(Sensitivities {
        values,
        gradients: xb,
        method: Method::Adjoint,
        timings: Timings {
            simulation,
            gradients: clock.elapsed().as_secs_f64(),
        },
    })
}
