//! Python values into engine inputs, engine outputs into numpy arrays.
//!
//! Dicts are read with `pythonize` through serde, unknown keys and wrong values rejected with
//! their path, so a scene dict and a settings dict get the same checks as a TOML file.

use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};
use serde::de::DeserializeOwned;

use crate::error::{Error, SceneError, SettingsError};
use crate::scene::SceneSpec;
use crate::settings::RunOptions;
use crate::solver::assembly::Csc;

/// Deepest nesting of dicts, lists and tuples read from Python: a scene has five levels;
/// serde's recursive descent would overflow the stack some thousands deep.
const MAX_NESTING: usize = 64;

/// Whether `value` nests dicts, lists and tuples at most `limit` deep (walked without
/// recursion).
fn nested_within(value: &Bound<'_, PyAny>, limit: usize) -> bool {
    let mut stack = vec![(value.clone(), 0usize)];
    while let Some((v, depth)) = stack.pop() {
        let items: Vec<Bound<'_, PyAny>> = if let Ok(d) = v.cast::<PyDict>() {
            d.values().iter().collect()
        } else if let Ok(l) = v.cast::<PyList>() {
            l.iter().collect()
        } else if let Ok(t) = v.cast::<PyTuple>() {
            t.iter().collect()
        } else {
            continue;
        };
        if depth == limit && !items.is_empty() {
            return false;
        }
        stack.extend(items.into_iter().map(|item| (item, depth + 1)));
    }
    true
}

/// Deserializes `value`, reporting a failure at its path (`whole` for the value itself).
fn from_python<T: DeserializeOwned>(
    value: &Bound<'_, PyAny>,
    whole: &str,
) -> Result<T, (String, String)> {
    if !nested_within(value, MAX_NESTING) {
        let msg = format!("nested more than {MAX_NESTING} levels deep");
        return Err((whole.into(), msg));
    }
    let mut de = pythonize::Depythonizer::from_object(value);
    serde_path_to_error::deserialize(&mut de).map_err(|e| {
        let path = e.path().to_string();
        let path = if path == "." { whole.into() } else { path };
        (path, in_users_words(&e.into_inner().to_string()))
    })
}

/// A deserialization message with serde's and Python's terms replaced by the user's.
fn in_users_words(msg: &str) -> String {
    if let Some(got) = msg.strip_prefix("TypeError: must be real number, not ") {
        return format!("expected a number, got {got}");
    }
    if msg.starts_with("OverflowError: can't convert negative int to unsigned") {
        return "expected a whole number ≥ 0".into();
    }
    if let Some(rest) = msg.strip_prefix("unexpected type: '") {
        if let Some((got, want)) = rest.split_once("' object is not an instance of '") {
            return format!("expected a {}, got {got}", want.trim_end_matches('\''));
        }
    }
    msg.replace("unknown variant", "unknown value")
}

/// A scene from a dict; a wrong entry is a `SceneError` naming it.
pub fn scene_spec(spec: &Bound<'_, PyAny>) -> PyResult<SceneSpec> {
    from_python(spec, "scene")
        .map_err(|(path, msg)| Error::Scene(SceneError::new(path, msg)).into())
}

/// Run options from a settings dict (`None`: none given); a wrong entry is a
/// `SettingsError` naming it.
pub fn run_options(settings: Option<&Bound<'_, PyAny>>) -> PyResult<RunOptions> {
    let Some(settings) = settings else {
        return Ok(RunOptions::default());
    };
    from_python(settings, "settings")
        .map_err(|(path, msg)| Error::Settings(SettingsError::new(path, msg)).into())
}

/// An optional design vector, copied out of numpy.
pub fn design(x: Option<PyReadonlyArray1<'_, f64>>) -> PyResult<Option<Vec<f64>>> {
    x.map(|a| Ok(a.as_slice()?.to_vec())).transpose()
}

/// A row-major `(rows, cols)` numpy array from a flat vector of `rows · cols` entries.
pub fn matrix<'py>(
    py: Python<'py>,
    data: Vec<f64>,
    rows: usize,
    cols: usize,
) -> PyResult<Bound<'py, PyAny>> {
    Ok(PyArray1::from_vec(py, data)
        .reshape([rows, cols])?
        .into_any())
}

/// A 1-D numpy array.
pub fn vector<'py>(py: Python<'py>, data: Vec<f64>) -> Bound<'py, PyAny> {
    PyArray1::from_vec(py, data).into_any()
}

/// A sparse matrix as the dict `data`, `indices`, `indptr`, `shape` of
/// `scipy.sparse.csc_matrix`.
pub fn csc<'py>(py: Python<'py>, m: Csc) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("data", vector(py, m.data))?;
    d.set_item("indices", m.indices)?;
    d.set_item("indptr", m.indptr)?;
    d.set_item("shape", m.shape)?;
    Ok(d)
}
