//! The checks every scene value goes through, and the errors they raise.
//!
//! A value is accepted only when it is finite, and where the physics asks for it, positive
//! or non-negative; sampled time histories must have strictly increasing times. Every
//! error carries the path of the entry at fault (`sections.al.E`, `loads[0].table.t[2]`).

use std::collections::HashMap;

use crate::error::{short, Error, SceneError};
use crate::interrupt::poll;

/// The scene build's result: a value, or the error of the first entry at fault.
pub(super) type Result<T> = std::result::Result<T, SceneError>;

/// The values of a list of entries ([`each`]), the first entry's error, or
/// [`SolveError::Interrupted`](crate::error::SolveError::Interrupted).
pub(super) type Listed<T> = std::result::Result<Vec<T>, Error>;

/// `entry(k, spec)` for each of `specs` in order, with [`poll`] before each: a build of
/// many thousand entries stops soon after the caller asks ([`crate::with_checker`]).
pub(super) fn each<S, T>(specs: &[S], mut entry: impl FnMut(usize, &S) -> Result<T>) -> Listed<T> {
    specs
        .iter()
        .enumerate()
        .map(|(k, spec)| {
            poll()?;
            Ok(entry(k, spec)?)
        })
        .collect()
}

/// `v` when it is finite.
pub(super) fn finite(path: &str, v: f64) -> Result<f64> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(SceneError::new(path, format!("must be finite, got {v}")))
    }
}

/// An error at the second of two entries of the list `what` (`joints`, `springs`, …) that
/// share a name: results are read by name, and one would hide the other.
pub(super) fn unique<'a>(what: &str, names: impl IntoIterator<Item = &'a str>) -> Result<()> {
    let mut seen = HashMap::new();
    for (k, name) in names.into_iter().enumerate() {
        if let Some(first) = seen.insert(name, k) {
            return Err(SceneError::new(
                format!("{what}[{k}] ({name})"),
                format!(
                    "duplicate name: {what}[{first}] is called '{name}' too; give each its own"
                ),
            ));
        }
    }
    Ok(())
}

/// `v` when it is finite and `v > 0`, and not so small that it underflows (subnormal).
pub(super) fn positive(path: &str, v: f64) -> Result<f64> {
    if v.is_normal() && v > 0.0 {
        Ok(v)
    } else {
        Err(SceneError::new(
            path,
            format!("must be positive and finite, got {}", short(v)),
        ))
    }
}

/// `v` when it is finite and `v ≥ 0`.
pub(super) fn non_negative(path: &str, v: f64) -> Result<f64> {
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(SceneError::new(
            path,
            format!("must be non-negative and finite, got {}", short(v)),
        ))
    }
}

/// An angle given in radians (`path.angle`) or degrees (`path.angle_deg`), 0 if neither,
/// in radians.
pub(super) fn angle(path: &str, rad: Option<f64>, deg: Option<f64>) -> Result<f64> {
    match (rad, deg) {
        (Some(_), Some(_)) => {
            let message = "give `angle` (rad) or `angle_deg`, not both";
            Err(SceneError::new(format!("{path}.angle_deg"), message))
        }
        (_, Some(deg)) => Ok(finite(&format!("{path}.angle_deg"), deg)?.to_radians()),
        (rad, None) => finite(&format!("{path}.angle"), rad.unwrap_or(0.0)),
    }
}

pub(crate) use crate::mechanism::load::samples;

/// The error of a name that refers to no `what` (`node`, `section`) of the scene.
pub(super) fn unknown(path: impl Into<String>, what: &str, name: &str) -> SceneError {
    SceneError::new(path, format!("unknown {what} '{name}'"))
}
