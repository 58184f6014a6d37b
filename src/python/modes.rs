//! A model linearized at a state (`M`, `K_t`, `Φ_q` as sparse matrices) and its lowest
//! natural modes with their gradients.

use std::sync::Arc;

use numpy::PyReadonlyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use super::convert::{csc, design, matrix, run_options, vector};
use super::model::PyModel;
use super::signals::detached;
use crate::error::{Error, SettingsError};
use crate::mechanism::element::MassKind;

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
