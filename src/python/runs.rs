//! Runs of a model: time integration (uniform, on given steps, guided, adaptive), static
//! equilibrium, responses with their gradients and response values on recorded states. Each
//! takes run settings as a dict (the keys of [`crate::settings::RunOptions`]), releases the
//! GIL while the engine works, and returns numpy arrays in a dict.

use std::sync::Arc;

use numpy::{PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use super::convert::{design, matrix, run_options, vector};
use super::model::PyModel;
use super::signals::{detached, reporting};
use crate::error::{Error, SettingsError};
use crate::mechanism::element::MassKind;
use crate::mechanism::model::Analysis;
use crate::sensitivity::adjoint::Path;
use crate::sensitivity::{self, parse_parameters, parse_responses};
use crate::settings::{Method, StaticAnalysis};
use crate::solver::simulation::{
    simulate as integrate, simulate_adaptive, simulate_guided, simulate_on,
};
use crate::solver::statics::{solve_linear, solve_static as equilibrium};
use crate::solver::step_control::StepControl;
use crate::time_grid::TimeGrid;

/// Time integration of a dynamic scene: `time`, `q`, `qdot`, `qddot`, `lam`, Newton
/// `iterations` and the size of each step (`steps`, 0 first), the energies, and the step
/// `h` (the first step for an adaptive run) and `rho_inf` used. The steps are uniform
/// (`h` of the settings), the given `steps`, or chosen by local error control to
/// `local_tol` starting from `h`. With a `guide` (`q` of a nearby run at each time of
/// the uniform steps, `t = 0` first) each step's Newton iterations start from it
/// ([`crate::simulate_guided`]). `progress`, if given, is called with the time reached (s)
/// every 50 ms or so.
#[pyfunction]
#[pyo3(signature = (model, x=None, settings=None, local_tol=None, steps=None, guide=None, progress=None))]
#[allow(clippy::too_many_arguments)] // the Python signature: each a keyword there
pub fn simulate<'py>(
    py: Python<'py>,
    model: &PyModel,
    x: Option<PyReadonlyArray1<'py, f64>>,
    settings: Option<&Bound<'py, PyAny>>,
    local_tol: Option<f64>,
    steps: Option<Vec<f64>>,
    guide: Option<PyReadonlyArray2<'py, f64>>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let m = Arc::clone(&model.model);
    let settings = run_options(settings)?
        .dynamic(&m.defaults)
        .map_err(Error::from)?;
    let x = design(x)?;
    let guide = guide.map(|g| g.as_array().iter().copied().collect::<Vec<f64>>());
    let traj = reporting(py, progress, move || match (local_tol, steps, guide) {
        (Some(_), _, Some(_)) => Err(SettingsError::new(
            "guide",
            "applies to uniform steps, not to local error control",
        )
        .into()),
        (Some(tol), _, None) => simulate_adaptive(
            &m,
            x.as_deref(),
            &settings,
            &StepControl::new(tol, settings.step()),
        ),
        (None, Some(steps), None) => simulate_on(&m, x.as_deref(), &settings, &grid(steps)?),
        (None, Some(steps), Some(guide)) => {
            simulate_guided(&m, x.as_deref(), &settings, &grid(steps)?, &guide)
        }
        (None, None, Some(guide)) => {
            settings.validate()?;
            simulate_guided(&m, x.as_deref(), &settings, &settings.grid(), &guide)
        }
        (None, None, None) => integrate(&m, x.as_deref(), &settings),
    })?;
    let d = PyDict::new(py);
    let (n_q, n_c, states) = (traj.n_q, traj.n_c, traj.time.len());
    d.set_item("time", vector(py, traj.time))?;
    d.set_item("q", matrix(py, traj.q, states, n_q)?)?;
    d.set_item("qdot", matrix(py, traj.qdot, states, n_q)?)?;
    d.set_item("qddot", matrix(py, traj.qddot, states, n_q)?)?;
    d.set_item("lam", matrix(py, traj.lam, states, n_c)?)?;
    d.set_item("iterations", traj.iterations)?;
    d.set_item("steps", vector(py, traj.steps))?;
    d.set_item("kinetic", vector(py, traj.kinetic))?;
    d.set_item("strain", vector(py, traj.strain))?;
    d.set_item("drive_work", vector(py, traj.drive_work))?;
    d.set_item("external_work", vector(py, traj.external_work))?;
    d.set_item("damping_work", vector(py, traj.damping_work))?;
    d.set_item("h", settings.step())?;
    d.set_item("rho_inf", settings.rho_inf)?;
    Ok(d)
}

/// A run's states as the bindings receive them, one row per time: `q`, `qdot`, `qddot`,
/// `lam`.
pub(super) type States<'py> = [PyReadonlyArray2<'py, f64>; 4];

/// A 2-d array's entries, row by row.
pub(super) fn rows(a: &PyReadonlyArray2<'_, f64>) -> Vec<f64> {
    a.as_array().iter().copied().collect()
}

/// The grid of the given step sizes, or a [`SettingsError`] naming `steps` if one is not
/// positive and finite or there are none.
pub(super) fn grid(steps: Vec<f64>) -> Result<TimeGrid, Error> {
    if steps.is_empty() || steps.iter().any(|h| !(h.is_finite() && *h > 0.0)) {
        return Err(SettingsError::new(
            "steps",
            "must be a non-empty list of positive, finite step sizes",
        )
        .into());
    }
    Ok(TimeGrid::from_steps(steps))
}

/// Static equilibrium of any scene: `q`, `lam`, Newton `iterations`, `load_steps` taken and
/// the load `time`.
#[pyfunction]
#[pyo3(signature = (model, x=None, settings=None))]
pub fn solve_static<'py>(
    py: Python<'py>,
    model: &PyModel,
    x: Option<PyReadonlyArray1<'py, f64>>,
    settings: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let m = Arc::clone(&model.model);
    let (analysis, settings) = run_options(settings)?
        .equilibrium(&m.defaults)
        .map_err(Error::from)?;
    let x = design(x)?;
    let sol = detached(py, move || -> Result<_, Error> {
        let densities = m.densities(x.as_deref())?;
        Ok(match analysis {
            StaticAnalysis::Nonlinear => equilibrium(&m, densities, &settings)?,
            StaticAnalysis::Linear => solve_linear(&m, densities, &settings)?,
        })
    })?;
    let d = PyDict::new(py);
    d.set_item("q", vector(py, sol.q))?;
    d.set_item("lam", vector(py, sol.lambda))?;
    d.set_item("iterations", sol.iterations)?;
    d.set_item("load_steps", sol.load_steps)?;
    d.set_item("time", settings.time)?;
    Ok(d)
}

/// Responses and their gradients: `values` (n_r,), `gradients` (n_r, n_x),
/// `parameter_gradients` (n_r, n_p) of the scene `parameters` named, `peaks` (the
/// largest point value of each aggregate, `None` for other responses), `time_errors` (each
/// response's `f(h) − f` estimated by the adjoint sweep of a motion, `None` for the direct
/// method and an equilibrium), the `method` used, `simulation_seconds` and
/// `gradient_seconds`. `settings` may also hold `method`
/// and `memory`; `steps`, the step sizes of a dynamic run (default: uniform steps `h`).
/// With `path`, the states `(q, qdot, qddot, lam)` that [`simulate`] returned for this
/// design and these settings, the adjoint sweeps about them and the run is not made again
/// ([`crate::of_motion_about`]).
#[pyfunction]
#[pyo3(signature = (model, x, responses, settings=None, steps=None, parameters=Vec::new(), path=None))]
#[allow(clippy::too_many_arguments)] // the Python signature: each a keyword there
pub fn run_with_sensitivities<'py>(
    py: Python<'py>,
    model: &PyModel,
    x: PyReadonlyArray1<'py, f64>,
    responses: Vec<String>,
    settings: Option<&Bound<'py, PyAny>>,
    steps: Option<Vec<f64>>,
    parameters: Vec<String>,
    path: Option<States<'py>>,
) -> PyResult<Bound<'py, PyDict>> {
    let m = Arc::clone(&model.model);
    let parsed = parse_responses(&m, &responses).map_err(Error::from)?;
    let wanted = parse_parameters(&m, &parameters, &parsed).map_err(Error::from)?;
    let options = run_options(settings)?;
    let how = options.sensitivity(&m.defaults);
    let x = x.as_slice()?.to_vec();
    if path.is_some() && (m.analysis == Analysis::Static || how.method == Method::Direct) {
        let msg = "is a dynamic run's, differentiated by the adjoint method (not method='direct')";
        return Err(Error::Settings(SettingsError::new("path", msg)).into());
    }
    let result = match m.analysis {
        Analysis::Dynamic => {
            let settings = options.dynamic(&m.defaults).map_err(Error::from)?;
            let grid = steps.map(grid).transpose()?;
            let path = path.map(|states| states.map(|a| rows(&a)));
            detached(py, move || match (grid, path) {
                (grid, Some([q, qdot, qddot, lam])) => {
                    let grid = match grid {
                        Some(grid) => grid,
                        None => settings.validate().map(|()| settings.grid())?,
                    };
                    let path = Path {
                        q: &q,
                        qdot: &qdot,
                        qddot: &qddot,
                        lam: &lam,
                    };
                    sensitivity::of_motion_about(&m, &x, &settings, &grid, &parsed, &wanted, path)
                }
                (Some(grid), None) => {
                    sensitivity::of_motion_on(&m, &x, &settings, &grid, &parsed, &wanted, how)
                }
                (None, None) => sensitivity::of_motion(&m, &x, &settings, &parsed, &wanted, how),
            })?
        }
        Analysis::Static => {
            let (analysis, settings) = options.equilibrium(&m.defaults).map_err(Error::from)?;
            let solve = match analysis {
                StaticAnalysis::Nonlinear => sensitivity::of_equilibrium,
                StaticAnalysis::Linear => sensitivity::of_linear_equilibrium,
            };
            detached(py, move || {
                solve(&m, &x, &settings, &parsed, &wanted, how.method)
            })?
        }
    };
    let d = PyDict::new(py);
    d.set_item("values", vector(py, result.values))?;
    d.set_item(
        "gradients",
        matrix(
            py,
            result.gradients,
            responses.len(),
            model.model.n_variables(),
        )?,
    )?;
    d.set_item(
        "parameter_gradients",
        matrix(
            py,
            result.parameter_gradients,
            responses.len(),
            parameters.len(),
        )?,
    )?;
    d.set_item("peaks", result.peaks)?;
    d.set_item("time_errors", result.time_errors.map(|e| vector(py, e)))?;
    d.set_item("method", result.method.name())?;
    d.set_item("simulation_seconds", result.timings.simulation)?;
    d.set_item("gradient_seconds", result.timings.gradients)?;
    Ok(d)
}

/// `values` of `responses` on recorded coordinates `q` (shape `(n_states, n_dofs)`) and
/// multipliers `lam` (`(n_states, n_constraints)`) at `times`, for design `x`, and the
/// aggregates' `peaks` (`None` for the others); a static state's loads act at `load_time`.
/// `qdot` (as `q`) for the responses that read velocities; `settings` may hold `mass`.
#[pyfunction]
#[pyo3(signature = (model, x, q, lam, times, load_time, responses, qdot=None, settings=None))]
#[allow(clippy::too_many_arguments)]
pub fn evaluate_responses<'py>(
    py: Python<'py>,
    model: &PyModel,
    x: Option<PyReadonlyArray1<'py, f64>>,
    q: PyReadonlyArray2<'py, f64>,
    lam: PyReadonlyArray2<'py, f64>,
    times: Vec<f64>,
    load_time: f64,
    responses: Vec<String>,
    qdot: Option<PyReadonlyArray2<'py, f64>>,
    settings: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let m = Arc::clone(&model.model);
    let parsed = parse_responses(&m, &responses).map_err(Error::from)?;
    let (q, lam) = (q.as_slice()?.to_vec(), lam.as_slice()?.to_vec());
    let qdot = qdot
        .map(|v| v.as_slice().map(<[f64]>::to_vec))
        .transpose()?;
    let options = run_options(settings)?;
    let mass = options.mass.unwrap_or(MassKind::Consistent);
    let analysis = options.over(&m.defaults).analysis.unwrap_or_default();
    let x = design(x)?;
    let out = detached(py, move || {
        let recorded = sensitivity::Recorded {
            q: &q,
            qdot: qdot.as_deref(),
            lam: &lam,
            times: &times,
            load_time,
            mass,
            analysis,
        };
        sensitivity::evaluate(&m, x.as_deref(), &recorded, &parsed)
    })?;
    let d = PyDict::new(py);
    d.set_item("values", vector(py, out.values))?;
    d.set_item("peaks", out.peaks)?;
    Ok(d.into_any())
}
