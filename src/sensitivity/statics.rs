//! Sensitivities of a static equilibrium `r(u, x) = f_int − F + Φ_qᵀλ = 0`:
//! `K_t u' = −∂r/∂x` (direct, one column per design variable) or `K_t μ = G_q`,
//! `f' = G_x − (∂r/∂x)ᵀ μ` (adjoint, one column per response), with `K_t` the augmented
//! stiffness at the equilibrium; for the linear analysis (`solver/linear.rs`) `K₀` at the
//! reference, the pseudo-loads and the responses on the linearized elements.

use std::time::Instant;

use super::{Method, Objectives, PseudoLoads, Sensitivities, Timings};
use crate::error::Error;
use crate::mechanism::element::MassKind;
use crate::mechanism::linear::Linearized;
use crate::mechanism::model::{Densities, Model};
use crate::mechanism::parameter::{At, Level, Parameter};
use crate::response::{Context, Response, Sample};
use crate::settings::{StaticAnalysis, StaticSettings};
use crate::solver::linear::{explain, linear_step};
use crate::solver::newton::Newton;
use crate::solver::statics::{load_stepping, static_newton};
use crate::time_grid::TimeGrid;

/// Solves the equilibrium (nonlinear or linear), then its sensitivities by `method` (direct
/// or adjoint, resolved).
pub(crate) fn differentiate_equilibrium(
    model: &Model,
    densities: Densities,
    settings: &StaticSettings,
    analysis: StaticAnalysis,
    responses: &[Response],
    parameters: &[Parameter],
    method: Method,
) -> Result<Sensitivities, Error> {
    let clock = Instant::now();
    let mut newton = static_newton(model, densities, settings)?;
    let ((q, lambda), linear) = match analysis {
        StaticAnalysis::Nonlinear => {
            let sol = load_stepping(&mut newton, settings)
                .map_err(|e| explain(&mut newton, settings.time, e))?;
            ((sol.q, sol.lambda), None)
        }
        StaticAnalysis::Linear => (
            linear_step(&mut newton, settings.time)?,
            Some(Linearized::new(model)),
        ),
    };
    let simulation = clock.elapsed().as_secs_f64();
    let clock = Instant::now();
    // The tangent at the equilibrium; the linear step's factors are already K₀'s.
    if linear.is_none() {
        newton.factorize(&q, Some(&lambda), None, 0.0, 0.0, settings.time)?;
    }
    let grid = TimeGrid::single();
    let at = Sample {
        q: &q,
        v: &[],
        lam: &lambda,
        t: settings.time,
    };
    let pseudo = PseudoLoads::new(model, MassKind::Consistent, parameters);
    let pseudo = match linear {
        Some(linear) => pseudo.of_linear(linear),
        None => pseudo,
    };
    let (local, objectives) = Local::at(&newton, settings.time, responses, &pseudo, &grid, at)?;
    let state = At {
        q: &q,
        rates: None,
        lam: &lambda,
        t: settings.time,
        level: Level::Position,
    };
    let (mut values, mut gradients) = match method {
        Method::Direct => direct(&newton, &state, &pseudo, local)?,
        _ => adjoint(&newton, &state, &pseudo, local)?,
    };
    objectives.finish(&mut values, &mut gradients);
    let peaks = objectives.peaks();
    let timings = Timings {
        simulation,
        gradients: clock.elapsed().as_secs_f64(),
    };
    Ok(Sensitivities::new(
        model, values, &gradients, method, timings, peaks,
    ))
}

/// The responses at the equilibrium and their partial derivatives: `G_q` (row-major
/// `n_r × n_q`), `G_λ` (`n_r × n_c`: a reaction's) and `G_x` (`n_r × (n_x + n_p)`, the
/// design variables' then the parameters').
struct Local {
    values: Vec<f64>,
    g_q: Vec<f64>,
    g_lam: Vec<f64>,
    g_x: Vec<f64>,
}

impl Local {
    /// The local partials, and the objectives that turn sums into aggregates' means.
    fn at<'a>(
        newton: &Newton,
        time: f64,
        responses: &'a [Response],
        pseudo: &'a PseudoLoads,
        grid: &'a TimeGrid,
        at: Sample,
    ) -> Result<(Self, Objectives<'a>), Error> {
        let asm = newton.assembler();
        let model = asm.model;
        let (n_q, n_x, n_r) = (model.n_dofs(), pseudo.columns(), responses.len());
        // The load of the compliance Fᵀu: applied loads and gravity M ĝ.
        let mut load = vec![0.0; n_q];
        asm.applied_loads(time, 1.0, &mut load);
        let ctx = Context {
            model,
            densities: &asm.densities,
            static_load: &load,
            mass_kind: MassKind::Consistent,
            linear: pseudo.linear.as_ref(),
        };
        let mut objectives = Objectives::new(model, responses, &pseudo.parameters, grid)?;
        let n_c = model.n_constraints();
        let mut local = Self {
            values: vec![0.0; n_r],
            g_q: vec![0.0; n_q * n_r],
            g_lam: vec![0.0; n_c * n_r],
            g_x: vec![0.0; n_x * n_r],
        };
        objectives.observe(&ctx, at, &mut local.values, &mut []);
        objectives.add_values(&ctx, 0, at, &mut local.values);
        for k in 0..n_r {
            objectives.add_partials(
                &ctx,
                k,
                0,
                at,
                &mut local.g_q[k * n_q..(k + 1) * n_q],
                &mut local.g_lam[k * n_c..(k + 1) * n_c],
                &mut local.g_x[k * n_x..(k + 1) * n_x],
                &mut [],
            );
        }
        Ok((local, objectives))
    }
}

/// Direct: `K_t [u'_j; μ'_j] = −∂r/∂x_j` for every design variable and parameter, then
/// `f' = G_x + G_q u' + G_λ λ'` with `λ' = s μ'`.
fn direct(
    newton: &Newton,
    at: &At,
    pseudo: &PseudoLoads,
    local: Local,
) -> Result<(Vec<f64>, Vec<f64>), Error> {
    let asm = newton.assembler();
    let (n_q, n_x) = (asm.model.n_dofs(), pseudo.columns());
    let n = n_q + asm.model.n_constraints();
    let Local {
        values,
        g_q,
        g_lam,
        mut g_x,
    } = local;
    let n_c = n - n_q;
    let mut rhs = vec![0.0; n * n_x];
    let scale = newton.multiplier_scale();
    pseudo.subtract_columns(asm, at, scale, &mut rhs, n, 0..n_x);
    if pseudo.moves_constraints() {
        newton.augment(&mut rhs);
    }
    newton.solve_block(&mut rhs, n_x, &mut newton.scratch(n_x.max(1)))?;
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(a, b)| a * b).sum::<f64>();
    for (k, g_x) in g_x.chunks_mut(n_x.max(1)).enumerate().take(values.len()) {
        let (g_q, g_lam) = (&g_q[k * n_q..(k + 1) * n_q], &g_lam[k * n_c..(k + 1) * n_c]);
        for (j, g) in g_x.iter_mut().enumerate() {
            let column = &rhs[j * n..(j + 1) * n];
            *g += dot(g_q, &column[..n_q]) + scale * dot(g_lam, &column[n_q..]);
        }
    }
    Ok((values, g_x))
}

/// Adjoint: `K_t μ_k = [G_q,k; s G_λ,k]` for every response (the direct method's
/// `λ' = s μ'` transposed), then `f' = G_x − (∂r/∂x)ᵀ μ`.
fn adjoint(
    newton: &Newton,
    at: &At,
    pseudo: &PseudoLoads,
    local: Local,
) -> Result<(Vec<f64>, Vec<f64>), Error> {
    let asm = newton.assembler();
    let (n_q, n_x) = (asm.model.n_dofs(), pseudo.columns());
    let n = n_q + asm.model.n_constraints();
    let n_r = local.values.len();
    let Local {
        values,
        g_q,
        g_lam,
        mut g_x,
    } = local;
    let n_c = n - n_q;
    let scale = newton.multiplier_scale();
    let mut rhs = vec![0.0; n * n_r];
    for k in 0..n_r {
        rhs[k * n..k * n + n_q].copy_from_slice(&g_q[k * n_q..(k + 1) * n_q]);
        for (o, l) in rhs[k * n + n_q..(k + 1) * n]
            .iter_mut()
            .zip(&g_lam[k * n_c..(k + 1) * n_c])
        {
            *o = scale * l;
        }
    }
    newton.solve_block(&mut rhs, n_r, &mut newton.scratch(n_r))?;
    newton.unaugment(&mut rhs);
    for k in 0..n_r {
        let mu = &rhs[k * n..(k + 1) * n];
        pseudo.subtract_transposed(asm, at, scale, mu, &mut g_x[k * n_x..(k + 1) * n_x]);
    }
    Ok((values, g_x))
}
