//! What a run to a tolerance asks of a model pair: states carried from a scene to the same
//! scene with twice the elements per bar, and each bar's share of the change between them;
//! of one model, its responses' time errors estimated by the adjoint.

use std::sync::Arc;

use numpy::{PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use super::convert::{matrix, run_options, vector};
use super::model::PyModel;
use super::runs::{grid, rows};
use super::signals::detached;
use crate::error::{Error, SettingsError};
use crate::sensitivity::adjoint::{time_errors as time_errors_of, Path};
use crate::sensitivity::parse_responses;
use crate::sensitivity::shares::bar_shares as bar_shares_of;
use crate::solver::prolongation::Prolongation;

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

/// The responses' `values` of `model`'s run at design `x` on `steps` and their time
/// `errors`, `f(h) − f` to leading order in the step, each (n_r,): the steps' local errors
/// weighted by the run's adjoint ([`crate::sensitivity::adjoint::time_errors`]).
#[pyfunction]
#[pyo3(signature = (model, x, responses, settings, steps))]
pub fn time_errors<'py>(
    py: Python<'py>,
    model: &PyModel,
    x: PyReadonlyArray1<'py, f64>,
    responses: Vec<String>,
    settings: Option<&Bound<'py, PyAny>>,
    steps: Vec<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let m = Arc::clone(&model.model);
    let parsed = parse_responses(&m, &responses).map_err(Error::from)?;
    let settings = run_options(settings)?
        .dynamic(&m.defaults)
        .map_err(Error::from)?;
    let grid = grid(steps)?;
    let x = x.as_slice()?.to_vec();
    let (values, errors) = detached(py, move || {
        time_errors_of(&m, m.densities(Some(&x))?, &settings, &grid, &parsed)
    })?;
    let d = PyDict::new(py);
    d.set_item("values", vector(py, values))?;
    d.set_item("errors", vector(py, errors))?;
    Ok(d)
}
