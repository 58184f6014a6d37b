//! Engine errors as the exception classes of `flextop.errors`.

use pyo3::import_exception;
use pyo3::PyErr;

use crate::error::Error;

import_exception!(flextop.errors, SceneError);
import_exception!(flextop.errors, DesignError);
import_exception!(flextop.errors, SettingsError);
import_exception!(flextop.errors, SimulationError);

impl From<Error> for PyErr {
    /// `SceneError`, `DesignError`, `SettingsError` (all `ValueError`) or `SimulationError`
    /// (`RuntimeError`), with the engine's message.
    fn from(e: Error) -> PyErr {
        let msg = e.to_string();
        match e {
            Error::Scene(_) => SceneError::new_err(msg),
            Error::Design(_) => DesignError::new_err(msg),
            Error::Settings(_) => SettingsError::new_err(msg),
            Error::Solve(_) => SimulationError::new_err(msg),
        }
    }
}
