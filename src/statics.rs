//! Static equilibrium `f_int(q) + Φ_qᵀλ = Λ f_ext`, `Φ(q) = 0` by Newton's method with load
//! stepping: the load factor `Λ` climbs from 0 to 1 in equal steps (loads, gravity and
//! prescribed rotations all scaled by `Λ`); a step whose Newton iteration fails is halved,
//! up to `max_cuts` times in a row.

use crate::element::MassKind;
use crate::error::SolveError;
use crate::model::{Densities, Model};
use crate::newton::{Newton, Point};
use crate::settings::StaticSettings;

/// A static equilibrium.
#[derive(Debug, Clone, PartialEq)]
pub struct StaticSolution {
    /// Nodal coordinates.
    pub q: Vec<f64>,
    /// Multipliers.
    pub lambda: Vec<f64>,
    /// Newton iterations over all load steps.
    pub iterations: usize,
    /// Load steps taken.
    pub load_steps: usize,
}

/// The Newton machinery of a static solve (no inertia: stiffness-scaled constraint rows).
pub(crate) fn static_newton<'m>(
    model: &'m Model,
    densities: Densities,
    settings: &StaticSettings,
) -> Newton<'m> {
    Newton::new(
        model,
        densities,
        MassKind::Consistent,
        settings.tol,
        settings.max_iter,
    )
}

/// Solves for the equilibrium of `model` with element scalings `densities`.
///
/// # Errors
/// The last [`SolveError`] once a load step has been halved `max_cuts` times in a row.
pub fn solve_static(
    model: &Model,
    densities: Densities,
    settings: &StaticSettings,
) -> Result<StaticSolution, SolveError> {
    load_stepping(&mut static_newton(model, densities, settings), settings)
}

/// Load-stepped Newton solve with the machinery of [`static_newton`].
///
/// # Errors
/// As [`solve_static`].
pub(crate) fn load_stepping(
    newton: &mut Newton,
    settings: &StaticSettings,
) -> Result<StaticSolution, SolveError> {
    let model = newton.assembler().model;
    let mut q = vec![0.0; model.n_dofs()];
    let mut lambda = vec![0.0; model.n_constraints()];
    let (mut load, mut step, mut cuts) = (0.0, 1.0 / settings.load_steps as f64, 0);
    let (mut iterations, mut steps) = (0, 0);
    while load < 1.0 {
        let target = (load + step).min(1.0);
        let (q_prev, l_prev) = (q.clone(), lambda.clone());
        let point = Point {
            t: settings.time,
            load: target,
            mass_coefficient: 0.0,
            gamma_prime: 0.0,
        };
        match newton.solve(point, &mut q, &mut lambda, None) {
            Ok(report) => {
                iterations += report.iterations;
                steps += 1;
                load = target;
                cuts = 0;
            }
            Err(e) => {
                if cuts == settings.max_cuts {
                    return Err(e);
                }
                q = q_prev;
                lambda = l_prev;
                step *= 0.5;
                cuts += 1;
            }
        }
    }
    Ok(StaticSolution {
        q,
        lambda,
        iterations,
        load_steps: steps,
    })
}
