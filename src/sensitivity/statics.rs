//! Sensitivities of a static equilibrium `r(u, x) = f_int − F + Φ_qᵀλ = 0`:
//! `K_t u' = −∂r/∂x` (direct, one column per design variable) or `K_t μ = G_q`,
//! `f' = G_x − (∂r/∂x)ᵀ μ` (adjoint, one column per response), with `K_t` the augmented
//! stiffness at the equilibrium.

use std::time::Instant;

use super::{Method, Objectives, PseudoLoads, Sensitivities, Timings};
use crate::element::MassKind;
use crate::error::Error;
use crate::model::{Densities, Model};
use crate::response::{Context, Response};
use crate::settings::StaticSettings;
use crate::statics::{load_stepping, static_newton};
use crate::time_grid::TimeGrid;

/// Solves the equilibrium, then its sensitivities by `method` (direct or adjoint).
pub(crate) fn run(
    model: &Model,
    densities: Densities,
    settings: &StaticSettings,
    responses: &[Response],
    method: Method,
) -> Result<Sensitivities, Error> {
    let clock = Instant::now();
    let mut newton = static_newton(model, densities, settings);
    let sol = load_stepping(&mut newton, settings)?;
    let simulation = clock.elapsed().as_secs_f64();
    let clock = Instant::now();
    let (n_q, n_x, n_r) = (model.n_dofs(), model.n_variables(), responses.len());
    let n = n_q + model.n_constraints();
    newton.factorize(Some(&sol.q), 0.0, settings.time)?;
    let asm = newton.assembler();
    // The load of the compliance Fᵀu: applied loads and gravity M ĝ.
    let mut load = vec![0.0; n_q];
    asm.applied_loads(settings.time, 1.0, &mut load);
    let ctx = Context {
        model,
        densities: &asm.densities,
        static_load: &load,
        mass_kind: MassKind::Consistent,
    };
    let grid = TimeGrid::single();
    let objectives = Objectives::new(model, responses, &grid)?;
    let pseudo = PseudoLoads::new(model, MassKind::Consistent);
    let mut values = vec![0.0; n_r];
    objectives.add_values(&ctx, 0, &sol.q, &mut values);
    let (mut g_q, mut g_x) = (vec![0.0; n_q * n_r], vec![0.0; n_x * n_r]);
    for k in 0..n_r {
        objectives.add_partials(
            &ctx,
            k,
            0,
            &sol.q,
            &mut g_q[k * n_q..(k + 1) * n_q],
            &mut g_x[k * n_x..(k + 1) * n_x],
        );
    }
    match method {
        Method::Direct => {
            let mut rhs = vec![0.0; n * n_x];
            pseudo.subtract_columns(asm, &sol.q, None, &mut rhs, n, 0..n_x);
            let mut scratch = newton.scratch(n_x.max(1));
            newton.solve_block(&mut rhs, n_x, &mut scratch)?;
            for k in 0..n_r {
                for j in 0..n_x {
                    let du = &rhs[j * n..j * n + n_q];
                    g_x[k * n_x + j] += g_q[k * n_q..(k + 1) * n_q]
                        .iter()
                        .zip(du)
                        .map(|(a, b)| a * b)
                        .sum::<f64>();
                }
            }
            Ok(Sensitivities {
                values,
                gradients: g_x,
                method,
                timings: Timings {
                    simulation,
                    gradients: clock.elapsed().as_secs_f64(),
                },
            })
        }
        _ => {
            let mut rhs = vec![0.0; n * n_r];
            for k in 0..n_r {
                rhs[k * n..k * n + n_q].copy_from_slice(&g_q[k * n_q..(k + 1) * n_q]);
            }
            let mut scratch = newton.scratch(n_r);
            newton.solve_block(&mut rhs, n_r, &mut scratch)?;
            for k in 0..n_r {
                pseudo.subtract_transposed(
                    asm,
                    &sol.q,
                    None,
                    &rhs[k * n..k * n + n_q],
                    &mut g_x[k * n_x..(k + 1) * n_x],
                );
            }
            Ok(Sensitivities {
                values,
                gradients: g_x,
                method: Method::Adjoint,
                timings: Timings {
                    simulation,
                    gradients: clock.elapsed().as_secs_f64(),
                },
            })
        }
    }
}
