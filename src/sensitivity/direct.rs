//! Direct differentiation of the generalized-α scheme (paper Algorithm 2, Eq. 20–24).
//!
//! For each design variable `j` the sensitivities `(q', q̇', q̈', a')` follow the linear
//! step (primes are `∂/∂x_j`):
//!
//! ```text
//! Pₙ  = q'ₙ + h q̇'ₙ + h²(½ − β) a'ₙ
//! cₙ  = −β' Pₙ + (α_m a'ₙ − α_f q̈'ₙ)/(1 − α_f)
//! S_t [q'ₙ₊₁; λ'ₙ₊₁] = [−(M cₙ + ∂r/∂x_j); 0]           (S_t at the converged state)
//! q̈'ₙ₊₁ = β' q'ₙ₊₁ + cₙ,  a'ₙ₊₁ = (q'ₙ₊₁ − Pₙ)/(h²β),  q̇'ₙ₊₁ = q̇'ₙ + h(1 − γ) a'ₙ + hγ a'ₙ₊₁
//! ```
//!
//! starting from `q'₀ = q̇'₀ = 0` (the initial state does not depend on `x`) and `q̈'₀`
//! from the initial-acceleration system. The factorization of `S_t` is shared by all
//! columns, which are solved in blocks in parallel (rayon).

use faer::dyn_stack::MemBuffer;
use rayon::prelude::*;

use std::time::Instant;

use super::{Method, Objectives, PseudoLoads, Sensitivities, Timings};
use crate::error::{Error, SolveError};
use crate::integrator::{AlphaParameters, Integrator, Settings};
use crate::linsolve::FactorError;
use crate::model::Model;
use crate::response::{Context, Response};

/// Columns per parallel block.
fn block_width(n_x: usize) -> usize {
    n_x.div_ceil(4 * rayon::current_num_threads()).clamp(1, 64)
}

/// Runs the simulation and its direct sensitivity analysis.
pub(crate) fn run(
    model: &Model,
    x: &[f64],
    settings: &Settings,
    responses: &[Response],
) -> Result<Sensitivities, Error> {
    let densities = model.densities(Some(x))?;
    let mut it = Integrator::new(model, densities, settings);
    let (n_q, n_x) = (model.n_dofs(), model.n_variables());
    let n = n_q + model.n_constraints();
    let last = settings.steps();
    let objectives = Objectives::new(model, responses, last, settings.step())?;
    let pseudo = PseudoLoads::new(model, settings.mass);
    let AlphaParameters {
        alpha_m,
        alpha_f,
        beta,
        gamma,
    } = it.params;
    let h = it.h;
    let (bp, gp) = (it.params.beta_prime(h), it.params.gamma_prime(h));
    let width = block_width(n_x);
    let mut scratch: Vec<MemBuffer> = (0..n_x.div_ceil(width))
        .map(|_| it.newton.ldlt.scratch_for(width))
        .collect();
    // Sensitivity states, column-major n_q × n_x: q', q̇', q̈', a'.
    let (mut dq, mut dv, mut dacc, mut da) = (
        vec![0.0; n_q * n_x],
        vec![0.0; n_q * n_x],
        vec![0.0; n_q * n_x],
        vec![0.0; n_q * n_x],
    );
    let mut rhs = vec![0.0; n * n_x];
    let mut timings = Timings::default();
    let clock = Instant::now();
    let mut state = it.initial_state()?;
    timings.simulation += clock.elapsed().as_secs_f64();
    let clock = Instant::now();
    let singular =
        |t: f64| move |FactorError::Singular(detail)| SolveError::Singular { time: t, detail };

    // t = 0: [M, Φ_qᵀ; Φ_q, 0] [q̈'₀; λ'₀] = [−∂r/∂x; 0].
    let s0 = it.newton.initial_scale();
    it.newton.factorize_at(None, 1.0, s0, 0.0)?;
    pseudo.subtract_columns(
        &it.newton.asm,
        &state.q,
        Some(&state.acc),
        &mut rhs,
        n,
        0..n_x,
    );
    let ldlt = &it.newton.ldlt;
    rhs.par_chunks_mut(n * width)
        .zip(scratch.par_iter_mut())
        .try_for_each(|(block, buf)| ldlt.solve_block(block, block.len() / n, buf))
        .map_err(singular(0.0))?;
    for j in 0..n_x {
        dacc[j * n_q..(j + 1) * n_q].copy_from_slice(&rhs[j * n..j * n + n_q]);
    }
    da.copy_from_slice(&dacc);

    let mut values = vec![0.0; responses.len()];
    let mut gradients = vec![0.0; responses.len() * n_x];
    let (mut g_q, mut g_x) = (vec![0.0; n_q], vec![0.0; n_x]);
    let mut accumulate = |it: &Integrator, step: usize, q: &[f64], dq: &[f64]| {
        let ctx = Context::dynamic(model, &it.newton.asm.densities, settings.mass);
        objectives.add_values(&ctx, step, q, &mut values);
        for k in 0..responses.len() {
            g_q.fill(0.0);
            g_x.fill(0.0);
            objectives.add_partials(&ctx, k, step, q, &mut g_q, &mut g_x);
            let row = &mut gradients[k * n_x..(k + 1) * n_x];
            row.par_iter_mut()
                .enumerate()
                .for_each(|(j, g)| *g += g_x[j] + dot(&g_q, &dq[j * n_q..(j + 1) * n_q]));
        }
    };
    accumulate(&it, 0, &state.q, &dq);
    timings.gradients += clock.elapsed().as_secs_f64();

    for step in 1..=last {
        let clock = Instant::now();
        it.alpha_step(&mut state)?;
        timings.simulation += clock.elapsed().as_secs_f64();
        let clock = Instant::now();
        it.newton
            .factorize_at(Some(&state.q), bp, it.newton.scale, state.t)?;
        let (asm, ldlt) = (&it.newton.asm, &it.newton.ldlt);
        let (q, acc) = (&state.q, &state.acc);
        rhs.par_chunks_mut(n * width)
            .zip(dq.par_chunks_mut(n_q * width))
            .zip(dv.par_chunks_mut(n_q * width))
            .zip(dacc.par_chunks_mut(n_q * width))
            .zip(da.par_chunks_mut(n_q * width))
            .zip(scratch.par_iter_mut())
            .enumerate()
            .try_for_each(|(block, (((((rhs, dq), dv), dacc), da), buf))| {
                let cols = rhs.len() / n;
                for col in 0..cols {
                    let r = col * n_q..(col + 1) * n_q;
                    let (dq, dv, dacc, da) = (
                        &dq[r.clone()],
                        &mut dv[r.clone()],
                        &mut dacc[r.clone()],
                        &mut da[r],
                    );
                    // The parts of the update that do not depend on q'ₙ₊₁; q̈' holds cₙ.
                    for i in 0..n_q {
                        let p = dq[i] + h * dv[i] + h * h * (0.5 - beta) * da[i];
                        dacc[i] = -bp * p + (alpha_m * da[i] - alpha_f * dacc[i]) / (1.0 - alpha_f);
                        dv[i] += h * (1.0 - gamma) * da[i] - gp * p;
                        da[i] = -p / (h * h * beta);
                    }
                    let out = &mut rhs[col * n..(col + 1) * n];
                    asm.mass_times(dacc, out);
                    out[..n_q].iter_mut().for_each(|v| *v = -*v);
                    out[n_q..].fill(0.0);
                }
                let first = block * width;
                pseudo.subtract_columns(asm, q, Some(acc), rhs, n, first..first + cols);
                ldlt.solve_block(rhs, cols, buf)?;
                for col in 0..cols {
                    let r = col * n_q..(col + 1) * n_q;
                    let new = &rhs[col * n..col * n + n_q];
                    dq[r.clone()].copy_from_slice(new);
                    for (i, &d) in new.iter().enumerate() {
                        dv[r.start + i] += gp * d;
                        da[r.start + i] += d / (h * h * beta);
                        dacc[r.start + i] += bp * d;
                    }
                }
                Ok(())
            })
            .map_err(singular(state.t))?;
        accumulate(&it, step, &state.q, &dq);
        timings.gradients += clock.elapsed().as_secs_f64();
    }
    Ok(Sensitivities {
        values,
        gradients,
        method: Method::Direct,
        timings,
    })
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}
