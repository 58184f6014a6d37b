//! Python values into engine inputs, engine outputs into numpy arrays.
//!
//! Dicts are read through serde, unknown keys and wrong values rejected with their path, so a
//! scene dict and a settings dict get the same checks as a TOML file. They are first copied
//! into TOML values with Python's types kept as they are (a `bool` is not a number, a string
//! is not a `bool`): no value is taken by its truthiness.

use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use serde::de::DeserializeOwned;

use crate::error::{Error, SceneError, SettingsError, SolveError};
use crate::scene::spatial::SpatialSceneSpec;
use crate::scene::SceneSpec;
use crate::settings::RunOptions;
use crate::solver::assembly::Csc;

/// Deepest nesting of dicts, lists and tuples read from Python: a scene has five levels;
/// serde's recursive descent would overflow the stack some thousands deep.
const MAX_NESTING: usize = 64;

/// Whether `value` nests dicts, lists and tuples at most `limit` deep (walked without
/// recursion, with [`crate::poll`] at each value).
fn nested_within(value: &Bound<'_, PyAny>, limit: usize) -> Result<bool, SolveError> {
    let mut stack = vec![(value.clone(), 0usize)];
    while let Some((v, depth)) = stack.pop() {
        crate::poll()?;
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
            return Ok(false);
        }
        stack.extend(items.into_iter().map(|item| (item, depth + 1)));
    }
    Ok(true)
}

/// Deserializes `value`, reporting a failure at its path (`whole` for the value itself).
fn from_python<T: DeserializeOwned>(
    value: &Bound<'_, PyAny>,
    whole: &str,
) -> Result<T, (String, String)> {
    deserialized(python_value(value, whole)?, whole)
}

/// `value` as a TOML value ([`toml_value`]), refused at its path (`whole` for the value
/// itself) where it nests too deep or holds what TOML cannot.
fn python_value(value: &Bound<'_, PyAny>, whole: &str) -> Result<toml::Value, (String, String)> {
    let interrupted = |e: SolveError| (whole.to_string(), e.to_string());
    if !nested_within(value, MAX_NESTING).map_err(interrupted)? {
        let msg = format!("nested more than {MAX_NESTING} levels deep");
        return Err((whole.into(), msg));
    }
    toml_value(value, "").map_err(|(path, msg)| {
        let path = if path.is_empty() { whole.into() } else { path };
        (path, msg)
    })
}

/// Deserializes the TOML value `value`, reporting a failure at its path (`whole` for the
/// value itself), in the user's words.
fn deserialized<T: DeserializeOwned>(
    value: toml::Value,
    whole: &str,
) -> Result<T, (String, String)> {
    serde_path_to_error::deserialize(value).map_err(|e| {
        let path = e.path().to_string();
        let path = if path == "." { whole.into() } else { path };
        (path, in_users_words(e.into_inner().message()))
    })
}

/// `value` as a TOML value of the same type: `bool` (numpy's too) a boolean, an integer
/// an integer, a float a float, `str` a string, a mapping a table (`None` entries left
/// out, as if not given), a list, tuple or array an array. Anything else is refused
/// at its `path`, and so is every value once the caller asks to stop ([`crate::poll`]).
fn toml_value(value: &Bound<'_, PyAny>, path: &str) -> Result<toml::Value, (String, String)> {
    let at = |key: &str| {
        if path.is_empty() {
            key.to_string()
        } else {
            format!("{path}.{key}")
        }
    };
    let kind = || {
        value
            .get_type()
            .name()
            .map_or("?".into(), |n| n.to_string_lossy().into_owned())
    };
    crate::poll().map_err(|e| (path.to_string(), e.to_string()))?;
    // Python's own types first, one check each, and only then the look-ups (`__index__`,
    // `tolist`), which fail for them at a cost: most of the time of reading a large scene.
    // Text is read as it is, not through `str()`, which would run Python's signal handlers
    // and lose a Ctrl-C to pyo3's formatting (a key read as "<unprintable str object>").
    if value.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(value.is_truthy().unwrap_or(false)));
    }
    if let Ok(s) = value.cast::<PyString>() {
        return Ok(toml::Value::String(s.to_string_lossy().into_owned()));
    }
    if value.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(
            value.extract::<f64>().unwrap_or(f64::NAN),
        ));
    }
    if let Ok(d) = value.cast::<PyDict>() {
        let mut table = toml::Table::new();
        for (k, v) in d.iter() {
            let Ok(key) = k
                .cast::<PyString>()
                .map(|k| k.to_string_lossy().into_owned())
            else {
                discard(table);
                return Err((path.into(), format!("keys must be strings, got {k}")));
            };
            if !v.is_none() {
                match toml_value(&v, &at(&key)) {
                    Ok(item) => table.insert(key, item),
                    Err(e) => {
                        discard(table);
                        return Err(e);
                    }
                };
            }
        }
        return Ok(toml::Value::Table(table));
    }
    let items: Option<Vec<Bound<'_, PyAny>>> = if let Ok(l) = value.cast::<PyList>() {
        Some(l.iter().collect())
    } else {
        value.cast::<PyTuple>().ok().map(|t| t.iter().collect())
    };
    if let Some(items) = items {
        let mut array = Vec::with_capacity(items.len());
        for (k, item) in items.iter().enumerate() {
            match toml_value(item, &format!("{path}[{k}]")) {
                Ok(v) => array.push(v),
                Err(e) => {
                    discard(array);
                    return Err(e);
                }
            }
        }
        return Ok(toml::Value::Array(array));
    }
    if kind().starts_with("bool") {
        return Ok(toml::Value::Boolean(value.is_truthy().unwrap_or(false)));
    }
    // An array (numpy's scalars too) as its Python values: an array has `__index__` as well.
    if value.hasattr("tolist").unwrap_or(false) && value.hasattr("ndim").unwrap_or(false) {
        let list = value
            .call_method0("tolist")
            .map_err(|e| (path.into(), e.to_string()))?;
        return toml_value(&list, path);
    }
    if value.is_instance_of::<PyInt>() || value.hasattr("__index__").unwrap_or(false) {
        return value
            .extract::<i64>()
            .map(toml::Value::Integer)
            .map_err(|_| {
                (
                    path.into(),
                    format!("the whole number {value} is too large"),
                )
            });
    }
    if value.hasattr("__float__").unwrap_or(false) {
        return value
            .extract::<f64>()
            .map(toml::Value::Float)
            .map_err(|e| (path.into(), e.to_string()));
    }
    Err((
        path.into(),
        format!("expected a number, text, list or table, got {}", kind()),
    ))
}

/// Frees `value` on a thread of its own: the part of a large scene read before a refusal
/// takes a while to free, which a Ctrl-C that stopped the reading should not wait for.
fn discard<T: Send + 'static>(value: T) {
    std::thread::spawn(move || drop(value));
}

/// A deserialization message in the user's words: `invalid type: string "false", expected
/// a boolean` becomes `expected true or false, got the string "false"`.
fn in_users_words(msg: &str) -> String {
    if msg == "invalid type: unit variant, expected string only" {
        return "expected a name (text)".into();
    }
    if let Some(rest) = msg.strip_prefix("invalid type: ") {
        if let Some((got, want)) = rest.split_once(", expected ") {
            let want = match want {
                "a boolean" => "true or false",
                "f64" => "a number",
                w if w.starts_with('u') && w[1..].chars().all(|c| c.is_ascii_digit())
                    || w == "usize" =>
                {
                    "a whole number ≥ 0"
                }
                w => w,
            };
            let got = got
                .replace("boolean `", "`")
                .replace("integer `", "the whole number `")
                .replace("floating point `", "the number `")
                .replace("string \"", "the text \"");
            return format!("expected {want}, got {got}");
        }
    }
    if let Some(rest) = msg.strip_prefix("invalid value: integer `") {
        if let Some((got, want)) = rest.split_once("`, expected ") {
            let want = if want == "usize" || want.starts_with('u') {
                "a whole number ≥ 0"
            } else {
                want
            };
            return format!("expected {want}, got {got}");
        }
    }
    msg.replace("unknown variant", "unknown value")
}

/// A scene dict as a TOML value, the GIL held; a wrong entry is a `SceneError` naming it.
pub fn scene_value(spec: &Bound<'_, PyAny>) -> Result<toml::Value, Error> {
    python_value(spec, "scene").map_err(|(path, msg)| SceneError::new(path, msg).into())
}

/// The scene of a [`scene_value`], read without Python; a wrong entry is a `SceneError`
/// naming it.
pub fn scene_spec(value: toml::Value) -> Result<SceneSpec, Error> {
    deserialized(value, "scene").map_err(|(path, msg)| SceneError::new(path, msg).into())
}

/// The spatial scene of a [`scene_value`], read without Python; a wrong entry is a
/// `SceneError` naming it.
pub fn spatial_scene_spec(value: toml::Value) -> Result<SpatialSceneSpec, Error> {
    deserialized(value, "scene").map_err(|(path, msg)| SceneError::new(path, msg).into())
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
