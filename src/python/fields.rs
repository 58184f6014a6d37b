//! Fields of recorded states: positions of the rigid mechanism, bars' section forces and
//! continuum cells' stresses and energies.

use std::sync::Arc;

use numpy::{PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;

use super::convert::design;
use super::model::PyModel;
use super::signals::detached;
use crate::error::{Error, SettingsError};
use crate::mechanism::model::{Densities, Model};
use crate::mechanism::rigid::rigid_positions as rigid;

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
