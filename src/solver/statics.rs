//! Static equilibrium `f_int(q) + Φ_qᵀλ = Λ f_ext`, `Φ(q) = 0` by Newton's method with load
//! stepping: the load factor `Λ` climbs from 0 to 1 in steps of `1/load_steps` (loads,
//! gravity and prescribed rotations all scaled by `Λ`); a step whose Newton iteration fails
//! is halved, up to `max_cuts` times in a row, and grows back by doubling after each
//! success. A load step whose equilibrium turns a node by more than π/2 counts as failed
//! ([`Model::plausible_step`](crate::Model::plausible_step)): it has jumped to another
//! branch. The solve ends with [`SolveError::LoadStepping`] when the increment falls below
//! [`MIN_LOAD_INCREMENT`] or the iterations exceed [`iteration_budget`].

use crate::error::SolveError;
use crate::mechanism::element::MassKind;
use crate::mechanism::model::{Densities, Model};
use crate::settings::{NewtonMatrix, StaticSettings};
use crate::solver::linear::{explain, linear_step};
use crate::solver::newton::{Forecast, Newton, NewtonReport, Point};

/// Smallest load-factor increment tried before the solve gives up.
pub const MIN_LOAD_INCREMENT: f64 = 1e-6;

/// Newton iterations allowed over all load steps: `max_iter` for each nominal step and for
/// 64 halvings more.
pub fn iteration_budget(settings: &StaticSettings) -> usize {
    settings
        .max_iter
        .max(1)
        .saturating_mul(settings.load_steps.saturating_add(64))
}

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
) -> Result<Newton<'m>, SolveError> {
    let mut newton = Newton::new(
        model,
        densities,
        MassKind::Consistent,
        settings.tol,
        settings.max_iter,
    )?;
    newton.keep_matrix(settings.newton == NewtonMatrix::Modified);
    Ok(newton)
}

/// Solves for the equilibrium of `model` with element scalings `densities`.
///
/// # Errors
/// The last [`SolveError`] once a load step has been halved `max_cuts` times in a row,
/// [`SolveError::LargeLoad`] around it where the linear solution says the load is large
/// for the stiffness ([`crate::solver::linear::explain`]).
pub fn solve_static(
    model: &Model,
    densities: Densities,
    settings: &StaticSettings,
) -> Result<StaticSolution, SolveError> {
    let mut newton = static_newton(model, densities, settings)?;
    load_stepping(&mut newton, settings).map_err(|e| explain(&mut newton, settings.time, e))
}

/// Solves the linear static problem ([`crate::solver::linear`]) of `model` with element
/// scalings `densities`, the loads at [`StaticSettings::time`]: the small-displacement
/// problem `K₀ u = f` about the reference, at once.
///
/// # Errors
/// [`SolveError::Singular`] where `K₀` with the joints' rows is singular (a mechanism).
pub fn solve_linear(
    model: &Model,
    densities: Densities,
    settings: &StaticSettings,
) -> Result<StaticSolution, SolveError> {
    let mut newton = static_newton(model, densities, settings)?;
    let (q, lambda) = linear_step(&mut newton, settings.time)?;
    Ok(StaticSolution {
        q,
        lambda,
        iterations: 1,
        load_steps: 1,
    })
}

/// One Newton solve of an equilibrium at a load factor: what load stepping drives, for
/// planar and spatial mechanisms alike.
pub(crate) trait Equilibrium {
    /// Solves at load factor `load` from `(q, λ)` in place, and judges the result against
    /// the previous equilibrium `q_prev` (a jump to another branch is a failure).
    ///
    /// # Errors
    /// Newton's, or the judgement's.
    fn solve_at(
        &mut self,
        load: f64,
        q: &mut [f64],
        lambda: &mut [f64],
        q_prev: &[f64],
    ) -> Result<NewtonReport, SolveError>;
}

/// The planar Newton at [`StaticSettings::time`], its steps judged by
/// [`Model::plausible_step`].
struct Planar<'a, 'm> {
    newton: &'a mut Newton<'m>,
    time: f64,
}

impl Equilibrium for Planar<'_, '_> {
    fn solve_at(
        &mut self,
        load: f64,
        q: &mut [f64],
        lambda: &mut [f64],
        q_prev: &[f64],
    ) -> Result<NewtonReport, SolveError> {
        let point = Point {
            t: self.time,
            load,
            mass_coefficient: 0.0,
            gamma_prime: 0.0,
        };
        let report = self
            .newton
            .solve(point, q, lambda, None, &mut Forecast::default())?;
        let asm = self.newton.assembler();
        let at = || format!("load factor {load:.6}");
        (asm.model).plausible_step(&asm.densities, q_prev, q, at)?;
        Ok(report)
    }
}

/// Load-stepped Newton solve with the machinery of [`static_newton`].
///
/// # Errors
/// As [`solve_static`]; [`SolveError::LoadStepping`] at the limits of the module's doc.
pub(crate) fn load_stepping(
    newton: &mut Newton,
    settings: &StaticSettings,
) -> Result<StaticSolution, SolveError> {
    let model = newton.assembler().model;
    let (q, lambda) = (vec![0.0; model.n_dofs()], vec![0.0; model.n_constraints()]);
    let mut planar = Planar {
        newton,
        time: settings.time,
    };
    step_loads(&mut planar, q, lambda, settings)
}

/// Load stepping (module docs) of any [`Equilibrium`] from `(q, λ)` at no load.
///
/// # Errors
/// The last [`SolveError`] once a load step has been halved `max_cuts` times in a row;
/// [`SolveError::LoadStepping`] at the limits of the module's doc.
pub(crate) fn step_loads(
    equilibrium: &mut impl Equilibrium,
    mut q: Vec<f64>,
    mut lambda: Vec<f64>,
    settings: &StaticSettings,
) -> Result<StaticSolution, SolveError> {
    let (mut q_prev, mut l_prev) = (q.clone(), lambda.clone());
    let nominal = 1.0 / settings.load_steps as f64;
    let (mut load, mut step, mut cuts) = (0.0, nominal, 0);
    let (mut iterations, mut steps, budget) = (0, 0, iteration_budget(settings));
    while load < 1.0 {
        crate::interrupt::poll()?;
        let target = (load + step).min(1.0);
        q_prev.copy_from_slice(&q);
        l_prev.copy_from_slice(&lambda);
        let solved = equilibrium.solve_at(target, &mut q, &mut lambda, &q_prev);
        match solved {
            Ok(report) => {
                iterations += report.iterations;
                steps += 1;
                load = target;
                cuts = 0;
                step = (2.0 * step).min(nominal);
            }
            Err(e) => {
                iterations += settings.max_iter;
                let stop = |why: String| SolveError::LoadStepping {
                    load,
                    why,
                    last: e.to_string(),
                };
                if cuts == settings.max_cuts {
                    return Err(e);
                }
                if 0.5 * step < MIN_LOAD_INCREMENT {
                    return Err(stop(format!(
                        "the load increment fell below {MIN_LOAD_INCREMENT:e}"
                    )));
                }
                if iterations > budget {
                    return Err(stop(format!(
                        "{iterations} Newton iterations exceeded the budget of {budget} \
                         (max_iter × (load_steps + 64))"
                    )));
                }
                q.copy_from_slice(&q_prev);
                lambda.copy_from_slice(&l_prev);
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
