//! Computations on a model: time integration, static equilibrium, responses with their
//! gradients, response values on recorded states, linearization, rigid kinematics. Each
//! takes run settings as a dict (the keys of [`crate::settings::RunOptions`]), releases the
//! GIL while the engine works, and returns numpy arrays in a dict.

use std::sync::Arc;

use numpy::{PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use super::convert::{csc, design, matrix, run_options, vector};
use super::model::PyModel;
use super::signals::{detached, reporting};
use crate::error::{Error, SettingsError};
use crate::mechanism::element::MassKind;
use crate::mechanism::model::{Analysis, Densities, Model};
use crate::mechanism::rigid::rigid_positions as rigid;
use crate::sensitivity::adjoint::Path;
use crate::sensitivity::shares::bar_shares as bar_shares_of;
use crate::sensitivity::{self, parse_parameters, parse_responses};
use crate::settings::Method;
use crate::solver::prolongation::Prolongation;
use crate::solver::simulation::{
    simulate as integrate, simulate_adaptive, simulate_guided, simulate_on,
};
use crate::solver::statics::solve_static as equilibrium;
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

/// The grid of the given step sizes, or a [`SettingsError`] naming `steps` if one is not
/// positive and finite or there are none.
/// States `q` of `coarse` (one row per state) carried to `fine`, the same scene with twice
/// the elements per bar ([`crate::Prolongation`]).
#[pyfunction]
pub fn prolong<'py>(
    py: Python<'py>,
    coarse: &PyModel,
    fine: &PyModel,
    q: PyReadonlyArray2<'py, f64>,
) -> PyResult<Bound<'py, PyAny>> {
    let (c, f) = (&coarse.model, &fine.model);
    let map = Prolongation::between(c, f).map_err(Error::from)?;
    let (rows, n_c, n_f) = (q.shape()[0], c.n_dofs(), f.n_dofs());
    if q.shape()[1] != n_c {
        let msg = format!(
            "has rows of {} coordinates, the coarse model has {n_c}",
            q.shape()[1]
        );
        return Err(Error::Settings(SettingsError::new("q", msg)).into());
    }
    let q = q.as_array().iter().copied().collect::<Vec<f64>>();
    let mut out = vec![0.0; rows * n_f];
    for (row, fine_row) in q.chunks(n_c).zip(out.chunks_mut(n_f)) {
        map.apply(c, row, fine_row);
    }
    matrix(py, out, rows, n_f)
}

/// Each frame bar's share of the change of `responses` from a run of `coarse` to the run
/// of `fine` (`coarse` with every frame bar's elements split in two) on the same `steps`,
/// whose states are `q`, `qdot` and `qddot` (one row per time): `values` (n_r,) on
/// `coarse` and `shares` (n_r, n_bars), dual-weighted residuals
/// ([`crate::sensitivity::shares`]).
#[pyfunction]
#[pyo3(signature = (coarse, fine, x, responses, settings, steps, q, qdot, qddot, lam))]
#[allow(clippy::too_many_arguments)]
pub fn bar_shares<'py>(
    py: Python<'py>,
    coarse: &PyModel,
    fine: &PyModel,
    x: PyReadonlyArray1<'py, f64>,
    responses: Vec<String>,
    settings: Option<&Bound<'py, PyAny>>,
    steps: Vec<f64>,
    q: PyReadonlyArray2<'py, f64>,
    qdot: PyReadonlyArray2<'py, f64>,
    qddot: PyReadonlyArray2<'py, f64>,
    lam: PyReadonlyArray2<'py, f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let (c, f) = (Arc::clone(&coarse.model), Arc::clone(&fine.model));
    let parsed = parse_responses(&c, &responses).map_err(Error::from)?;
    let settings = run_options(settings)?
        .dynamic(&c.defaults)
        .map_err(Error::from)?;
    let grid = grid(steps)?;
    let x = x.as_slice()?.to_vec();
    let (q, qdot, qddot, lam) = (rows(&q), rows(&qdot), rows(&qddot), rows(&lam));
    let n_b = c.bars.len();
    let out = detached(py, move || {
        let states = Path {
            q: &q,
            qdot: &qdot,
            qddot: &qddot,
            lam: &lam,
        };
        bar_shares_of(&c, &f, &x, &settings, &grid, &parsed, states)
    })?;
    let d = PyDict::new(py);
    d.set_item("values", vector(py, out.values))?;
    d.set_item("shares", matrix(py, out.shares, responses.len(), n_b)?)?;
    d.set_item(
        "first_order",
        matrix(py, out.first_order, responses.len(), n_b)?,
    )?;
    Ok(d)
}

/// A run's states as the bindings receive them, one row per time: `q`, `qdot`, `qddot`,
/// `lam`.
type States<'py> = [PyReadonlyArray2<'py, f64>; 4];

/// A 2-d array's entries, row by row.
fn rows(a: &PyReadonlyArray2<'_, f64>) -> Vec<f64> {
    a.as_array().iter().copied().collect()
}

fn grid(steps: Vec<f64>) -> Result<TimeGrid, Error> {
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
    let settings = run_options(settings)?
        .statics(&m.defaults)
        .map_err(Error::from)?;
    let x = design(x)?;
    let sol = detached(py, move || -> Result<_, Error> {
        Ok(equilibrium(&m, m.densities(x.as_deref())?, &settings)?)
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
/// largest point value of each aggregate, `None` for other responses), the `method` used,
/// `simulation_seconds` and `gradient_seconds`. `settings` may also hold `method`
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
            let settings = options.statics(&m.defaults).map_err(Error::from)?;
            detached(py, move || {
                sensitivity::of_equilibrium(&m, &x, &settings, &parsed, &wanted, how.method)
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
    let mass = run_options(settings)?.mass.unwrap_or(MassKind::Consistent);
    let x = design(x)?;
    let out = detached(py, move || {
        let recorded = sensitivity::Recorded {
            q: &q,
            qdot: qdot.as_deref(),
            lam: &lam,
            times: &times,
            load_time,
            mass,
        };
        sensitivity::evaluate(&m, x.as_deref(), &recorded, &parsed)
    })?;
    let d = PyDict::new(py);
    d.set_item("values", vector(py, out.values))?;
    d.set_item("peaks", out.peaks)?;
    Ok(d.into_any())
}

/// Mass `M`, tangent stiffness `K_t(q)` (at the reference state by default) and constraint
/// Jacobian `G = Φ_q`, each as the dict of a `scipy.sparse.csc_matrix`.
#[pyfunction]
#[pyo3(signature = (model, x=None, q=None, settings=None))]
pub fn linearize<'py>(
    py: Python<'py>,
    model: &PyModel,
    x: Option<PyReadonlyArray1<'py, f64>>,
    q: Option<PyReadonlyArray1<'py, f64>>,
    settings: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let m = &model.model;
    let options = run_options(settings)?;
    options.validate().map_err(Error::from)?;
    let mass = options.mass.unwrap_or(MassKind::Consistent);
    let densities = m.densities(design(x)?.as_deref()).map_err(Error::from)?;
    let n = m.n_dofs();
    let q = design(q)?.unwrap_or_else(|| vec![0.0; n]);
    if q.len() != n {
        let msg = format!("has {} entries, the model has {n} DOFs", q.len());
        return Err(Error::Settings(SettingsError::new("q", msg)).into());
    }
    let lin = crate::solver::assembly::linearize(m, densities, mass, &q).map_err(Error::from)?;
    let d = PyDict::new(py);
    d.set_item("M", csc(py, lin.mass)?)?;
    d.set_item("K", csc(py, lin.stiffness)?)?;
    d.set_item("G", csc(py, lin.jacobian)?)?;
    Ok(d)
}

/// The `count` lowest natural modes at state `q` (the reference state by default), the
/// drives locked: `frequencies` (Hz), mass-normalized `shapes` (`count × n_q`), the Sturm
/// `bound` (Hz) and the count `below` it, and `gradients` `∂f/∂x` (`count × n_variables`).
#[pyfunction]
#[pyo3(signature = (model, count, x=None, q=None, settings=None))]
pub fn natural_modes<'py>(
    py: Python<'py>,
    model: &PyModel,
    count: usize,
    x: Option<PyReadonlyArray1<'py, f64>>,
    q: Option<PyReadonlyArray1<'py, f64>>,
    settings: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let m = Arc::clone(&model.model);
    let options = run_options(settings)?;
    options.validate().map_err(Error::from)?;
    let mass = options.mass.unwrap_or(MassKind::Consistent);
    let (x, q) = (design(x)?, design(q)?);
    let modes = detached(py, move || {
        let densities = m.densities(x.as_deref())?;
        let q = q.unwrap_or_else(|| vec![0.0; m.n_dofs()]);
        crate::modal::natural_modes(&m, densities, mass, &q, count)
    })?;
    let (n_q, n_var, found) = (
        model.model.n_dofs(),
        model.model.n_variables(),
        modes.frequencies.len(),
    );
    let d = PyDict::new(py);
    d.set_item("frequencies", vector(py, modes.frequencies))?;
    d.set_item("shapes", matrix(py, modes.shapes.concat(), found, n_q)?)?;
    d.set_item("bound", modes.bound)?;
    d.set_item("below", modes.below)?;
    d.set_item("gradients", matrix(py, modes.gradients, found, n_var)?)?;
    Ok(d)
}

/// Positions of every node at `times` when every frame is rigid and the joints follow
/// their drives, shape `(len, n_nodes, 2)`.
#[pyfunction]
pub fn rigid_positions<'py>(
    py: Python<'py>,
    model: &PyModel,
    times: Vec<f64>,
) -> PyResult<Bound<'py, PyAny>> {
    let m = Arc::clone(&model.model);
    let (len, n) = (times.len(), m.nodes.len());
    let flat = detached(py, move || rigid(&m, &times).map_err(Error::from))?;
    Ok(numpy::PyArray1::from_vec(py, flat)
        .reshape([len, n, 2])?
        .into_any())
}

/// Section forces `[N, M₁, M₂]` (N, N m) of every element at each state of `q` (one row per
/// state), scaled by the design's stiffness law, shape `(n_states, n_elements, 3)`.
#[pyfunction]
#[pyo3(signature = (model, x, q))]
pub fn section_forces<'py>(
    py: Python<'py>,
    model: &PyModel,
    x: Option<PyReadonlyArray1<'py, f64>>,
    q: PyReadonlyArray2<'py, f64>,
) -> PyResult<Bound<'py, PyAny>> {
    let m = &model.model;
    per_state(
        py,
        m,
        x,
        &q,
        [m.elements.len(), 3],
        |densities, row, out| {
            for (el, &s) in m.elements.iter().zip(&densities.stiffness) {
                out.extend(el.section_forces(s, row));
            }
        },
    )
}

/// The von Mises stress (Pa) and the strain energy (J) of every continuum cell at each state
/// of `q` (one row per state), with the design's stiffness
/// ([`Cell::stress_and_energy`](crate::model::Cell::stress_and_energy)), shape
/// `(n_states, n_cells, 2)`.
#[pyfunction]
#[pyo3(signature = (model, x, q))]
pub fn cell_fields<'py>(
    py: Python<'py>,
    model: &PyModel,
    x: Option<PyReadonlyArray1<'py, f64>>,
    q: PyReadonlyArray2<'py, f64>,
) -> PyResult<Bound<'py, PyAny>> {
    let m = &model.model;
    per_state(py, m, x, &q, [m.cells.len(), 2], |densities, row, out| {
        let n_e = m.elements.len();
        for (k, cell) in m.cells.iter().enumerate() {
            let (s, blend) = (densities.stiffness[n_e + k], densities.blend[n_e + k]);
            out.extend(cell.stress_and_energy(s, blend, row));
        }
    })
}

/// `fill(stiffness, row, out)` at each state (row) of `q`, with the stiffness factors of
/// design `x`, as an array of shape `(n_states, shape[0], shape[1])`.
fn per_state<'py>(
    py: Python<'py>,
    m: &Model,
    x: Option<PyReadonlyArray1<'py, f64>>,
    q: &PyReadonlyArray2<'py, f64>,
    shape: [usize; 2],
    fill: impl Fn(&Densities, &[f64], &mut Vec<f64>),
) -> PyResult<Bound<'py, PyAny>> {
    let densities = m.densities(design(x)?.as_deref()).map_err(Error::from)?;
    let (states, n) = (q.shape()[0], m.n_dofs());
    if q.shape()[1] != n {
        let msg = format!(
            "has rows of {} entries, the model has {n} DOFs",
            q.shape()[1]
        );
        return Err(Error::Settings(SettingsError::new("q", msg)).into());
    }
    let mut flat = Vec::with_capacity(states * shape[0] * shape[1]);
    for row in q.as_slice()?.chunks(n.max(1)) {
        fill(&densities, row, &mut flat);
    }
    Ok(numpy::PyArray1::from_vec(py, flat)
        .reshape([states, shape[0], shape[1]])?
        .into_any())
}
