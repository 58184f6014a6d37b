//! A spatial scene's runs as Python sees them (the run methods of `flextop._core.SpatialModel`,
//! `super::spatial`): its motion, rigid trajectory, static equilibrium, natural modes, exact
//! gradients, time errors and beams' shares, each with the GIL released and Ctrl-C heard,
//! returned as numpy arrays in a dict.

use std::sync::Arc;

use pyo3::prelude::*;
use pyo3::types::PyDict;

use super::convert::{matrix, run_options, vector};
use super::signals::{detached, reporting};
use crate::error::{Error, SettingsError};
use crate::scene::spatial::names::Named;
use crate::scene::spatial::SpatialScene;
use crate::spatial::integrator::simulate_spatial;
use crate::spatial::modal::natural_modes_spatial;
use crate::spatial::modal_rates::omega_squared_rates;
use crate::spatial::rigid::rigid_trajectories;
use crate::spatial::sensitivity::{self, static_sensitivities};
use crate::spatial::shares;
use crate::spatial::statics::solve_static_spatial;

/// `SpatialModel.simulate` (documented on the class) of the scene `shared`.
pub(super) fn simulate<'py>(
    py: Python<'py>,
    shared: &Arc<SpatialScene>,
    settings: Option<&Bound<'py, PyAny>>,
    progress: Option<Py<PyAny>>,
    x: Option<Vec<f64>>,
) -> PyResult<Bound<'py, PyDict>> {
    let scene = Arc::clone(shared);
    let settings = run_options(settings)?
        .dynamic(&scene.options)
        .map_err(Error::from)?;
    let design = x.clone();
    let states = reporting(py, progress, move || {
        settings.validate()?;
        let model = scene.model_at(x.as_deref())?;
        simulate_spatial(&model, &settings, &settings.grid())
    })?;
    // The energies of the mechanism at the design it ran at.
    let model = shared.model_at(design.as_deref()).map_err(Error::from)?;
    let m = &*model;
    let d = PyDict::new(py);
    let column = |f: &dyn Fn(&crate::solver::alpha::State) -> f64| {
        vector(py, states.iter().map(f).collect())
    };
    d.set_item("time", column(&|s| s.t))?;
    d.set_item("kinetic", column(&|s| m.kinetic_energy(&s.qdot)))?;
    d.set_item("potential", column(&|s| m.potential_energy(&s.q)))?;
    d.set_item("strain", column(&|s| m.strain_energy(&s.q)))?;
    let n = states.len();
    let flat = |f: &dyn Fn(&crate::solver::alpha::State) -> &Vec<f64>| {
        states
            .iter()
            .flat_map(|s| f(s).iter().copied())
            .collect::<Vec<_>>()
    };
    d.set_item("q", matrix(py, flat(&|s| &s.q), n, m.n_q())?)?;
    d.set_item("v", matrix(py, flat(&|s| &s.qdot), n, m.n_v())?)?;
    d.set_item("lam", matrix(py, flat(&|s| &s.lam), n, m.n_rows())?)?;
    Ok(d)
}

/// `SpatialModel.rigid_trajectory` (documented on the class) of the scene `shared`.
pub(super) fn rigid_trajectory<'py>(
    py: Python<'py>,
    shared: &Arc<SpatialScene>,
    node: usize,
    settings: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let scene = Arc::clone(shared);
    let settings = run_options(settings)?
        .dynamic(&scene.options)
        .map_err(Error::from)?;
    if node >= scene.model.nodes.len() {
        return Err(Error::from(SettingsError::new(
            "node",
            format!("no node {node} (the scene has {})", scene.model.nodes.len()),
        ))
        .into());
    }
    let path = detached(py, move || {
        settings.validate()?;
        let grid = settings.grid();
        Ok(rigid_trajectories(&scene.model, &settings, &grid, &[node])?.remove(0))
    })?;
    let n = path.len();
    matrix(
        py,
        path.iter().flat_map(|p| p.iter().copied()).collect(),
        n,
        3,
    )
}

/// `SpatialModel.solve_static` (documented on the class) of the scene `shared`.
pub(super) fn solve_static<'py>(
    py: Python<'py>,
    shared: &Arc<SpatialScene>,
    settings: Option<&Bound<'py, PyAny>>,
    x: Option<Vec<f64>>,
) -> PyResult<Bound<'py, PyDict>> {
    let scene = Arc::clone(shared);
    let settings = run_options(settings)?
        .statics(&scene.options)
        .map_err(Error::from)?;
    let design = x.clone();
    let eq = detached(py, move || {
        let model = scene.model_at(x.as_deref())?;
        solve_static_spatial(&model, &settings)
    })?;
    let model = shared.model_at(design.as_deref()).map_err(Error::from)?;
    let d = PyDict::new(py);
    d.set_item("strain", model.strain_energy(&eq.q))?;
    d.set_item("q", vector(py, eq.q))?;
    d.set_item("lam", vector(py, eq.lambda))?;
    d.set_item("iterations", eq.iterations)?;
    d.set_item("load_steps", eq.load_steps)?;
    Ok(d)
}

/// `SpatialModel.natural_modes` (documented on the class) of the scene `shared`.
pub(super) fn natural_modes<'py>(
    py: Python<'py>,
    shared: &Arc<SpatialScene>,
    (q, lam, t): (Option<Vec<f64>>, Option<Vec<f64>>, f64),
    x: Option<Vec<f64>>,
    count: Option<usize>,
    parameters: Option<Vec<String>>,
) -> PyResult<Bound<'py, PyDict>> {
    let scene = Arc::clone(shared);
    let (modes, rates) = detached(py, move || {
        let mut model = scene.model_at(x.as_deref())?;
        let (q, lam) = match (q, lam) {
            (Some(q), Some(lam)) => (q, lam),
            (None, None) => {
                model = std::borrow::Cow::Owned(model.at_rest());
                (model.initial_configuration(), vec![0.0; model.n_rows()])
            }
            _ => {
                return Err(Error::from(SettingsError::new(
                    "natural_modes",
                    "give both q and lam (a configuration), or neither (at rest)",
                )))
            }
        };
        let modes = natural_modes_spatial(&model, &q, &lam, t, count)?;
        let rates = match parameters {
            None => None,
            Some(names) => {
                let (named, ps) = scene.named_and_densities(&names, x.as_deref())?;
                let rates =
                    omega_squared_rates(&model, &q, &modes.omega_squared, &modes.shapes, &ps)?;
                Some(combined(&named, &rates))
            }
        };
        Ok::<_, Error>((modes, rates))
    })?;
    let d = PyDict::new(py);
    let n_v = shared.model.n_v();
    let n_p = rates.as_ref().and_then(|r| r.first()).map_or(0, Vec::len);
    let rates = rates.map(|r| rows(py, r, n_p)).transpose()?;
    d.set_item("omega_squared_rates", rates)?;
    let frequencies = modes.frequencies().map(|f| vector(py, f));
    d.set_item("frequencies", frequencies)?;
    d.set_item("shapes", rows(py, modes.shapes, n_v)?)?;
    d.set_item("omega_squared", vector(py, modes.omega_squared))?;
    d.set_item("bound", modes.sturm.map(|s| s.bound))?;
    d.set_item("below", modes.sturm.map(|s| s.below))?;
    Ok(d)
}

/// `SpatialModel.sensitivities` (documented on the class) of the scene `shared`.
pub(super) fn sensitivities<'py>(
    py: Python<'py>,
    shared: &Arc<SpatialScene>,
    responses: Vec<String>,
    parameters: Vec<String>,
    settings: Option<&Bound<'py, PyAny>>,
    equilibrium: bool,
    x: Option<Vec<f64>>,
) -> PyResult<Bound<'py, PyDict>> {
    let scene = Arc::clone(shared);
    let options = run_options(settings)?;
    let method = options.sensitivity(&scene.options).method;
    let found = detached(py, move || {
        let rs = (responses.iter())
            .map(|r| scene.response(r))
            .collect::<Result<Vec<_>, _>>()?;
        let (named, ps) = scene.named_and_densities(&parameters, x.as_deref())?;
        let model = scene.model_at(x.as_deref())?;
        let g = if equilibrium {
            let settings = options.statics(&scene.options)?;
            static_sensitivities(&model, &settings, &rs, &ps, method)?
        } else {
            let settings = options.dynamic(&scene.options)?;
            settings.validate()?;
            sensitivity::sensitivities(&model, &settings, &settings.grid(), &rs, &ps, method)?
        };
        let gradient = combined(&named, &g.gradient);
        Ok::<_, Error>((g.values, gradient, g.peaks, g.time_errors))
    })?;
    let (values, gradient, peaks, time_errors) = found;
    let d = PyDict::new(py);
    let n_p = gradient.first().map_or(0, Vec::len);
    d.set_item("values", vector(py, values))?;
    d.set_item("gradient", rows(py, gradient, n_p)?)?;
    d.set_item("peaks", peaks)?;
    d.set_item("time_errors", time_errors.map(|e| vector(py, e)))?;
    Ok(d)
}

/// `SpatialModel.time_errors` (documented on the class) of the scene `shared`.
pub(super) fn time_errors<'py>(
    py: Python<'py>,
    shared: &Arc<SpatialScene>,
    responses: Vec<String>,
    settings: Option<&Bound<'py, PyAny>>,
    x: Option<Vec<f64>>,
) -> PyResult<Bound<'py, PyDict>> {
    let scene = Arc::clone(shared);
    let options = run_options(settings)?;
    let (values, errors) = detached(py, move || {
        let rs = (responses.iter())
            .map(|r| scene.response(r))
            .collect::<Result<Vec<_>, _>>()?;
        let model = scene.model_at(x.as_deref())?;
        let settings = options.dynamic(&scene.options)?;
        settings.validate()?;
        sensitivity::time_errors(&model, &settings, &settings.grid(), &rs)
    })?;
    let d = PyDict::new(py);
    d.set_item("values", vector(py, values))?;
    d.set_item("errors", vector(py, errors))?;
    Ok(d)
}

/// `SpatialModel.beam_shares` (documented on the class) of the scene `shared`.
pub(super) fn beam_shares<'py>(
    py: Python<'py>,
    shared: &Arc<SpatialScene>,
    fine: &Arc<SpatialScene>,
    responses: Vec<String>,
    fine_responses: Vec<String>,
    settings: Option<&Bound<'py, PyAny>>,
    x: Option<Vec<f64>>,
) -> PyResult<Bound<'py, PyDict>> {
    let (scene, fine) = (Arc::clone(shared), Arc::clone(fine));
    let options = run_options(settings)?;
    let out = detached(py, move || {
        let named = |s: &SpatialScene, names: &[String]| {
            (names.iter())
                .map(|r| s.response(r))
                .collect::<Result<Vec<_>, _>>()
        };
        let (rs, fs) = (named(&scene, &responses)?, named(&fine, &fine_responses)?);
        let settings = options.dynamic(&scene.options)?;
        settings.validate()?;
        let beams = scene.split_beams(&fine)?;
        let models = (scene.model_at(x.as_deref())?, fine.model_at(x.as_deref())?);
        let grid = settings.grid();
        shares::beam_shares((&models.0, &models.1), &beams, &settings, &grid, &rs, &fs)
    })?;
    let (n_r, n_b) = (out.values.len(), shared.beams.len());
    let d = PyDict::new(py);
    d.set_item("values", vector(py, out.values))?;
    d.set_item("fine_values", vector(py, out.fine_values))?;
    d.set_item("shares", matrix(py, out.shares, n_r, n_b)?)?;
    d.set_item("first_order", matrix(py, out.first_order, n_r, n_b)?)?;
    Ok(d)
}

/// A list of `(rows, cols)` entries as a numpy matrix.
fn rows<'py>(py: Python<'py>, rows: Vec<Vec<f64>>, cols: usize) -> PyResult<Bound<'py, PyAny>> {
    let n = rows.len();
    matrix(py, rows.concat(), n, cols)
}

/// Gradients to the engine's parameters combined into those to the named ones (each named
/// one a sum of engine parameters times factors, in order).
fn combined(named: &[Named], gradient: &[Vec<f64>]) -> Vec<Vec<f64>> {
    (gradient.iter())
        .map(|row| {
            let mut parts = row.iter();
            (named.iter())
                .map(|n| n.iter().zip(&mut parts).map(|((_, f), d)| f * d).sum())
                .collect()
        })
        .collect()
}
