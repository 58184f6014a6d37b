//! Python bindings: the `flextop._core` extension module, registration only.
//!
//! One file per concept: [`errors`] maps engine errors to the classes of `flextop.errors`,
//! [`convert`] turns Python values into engine inputs and engine outputs into numpy arrays,
//! [`model`] is the built mechanism and its description, [`runs`] its runs, [`modes`] its
//! linearization and modes, [`refinement`] what a run to a tolerance asks of a pair of
//! models, [`fields`] fields of recorded states, [`spatial`] a spatial scene with its runs
//! (each releases the GIL, and [`signals`] keeps Ctrl-C working meanwhile). The logic lives
//! in the engine; these files only translate.

mod convert;
mod errors;
mod fields;
mod model;
mod modes;
mod refinement;
mod runs;
mod signals;
mod spatial;
mod spatial_runs;

use pyo3::prelude::*;

/// The extension module.
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // NumPy's C API, loaded now rather than on the first array returned: loaded then, a
    // Ctrl-C arriving during NumPy's import made rust-numpy panic (a `PanicException`)
    // instead of raising `KeyboardInterrupt`.
    numpy::PyArray1::<f64>::zeros(m.py(), 0, false);
    m.add_class::<model::PyModel>()?;
    m.add_class::<spatial::PySpatialModel>()?;
    m.add_function(wrap_pyfunction!(runs::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(runs::solve_static, m)?)?;
    m.add_function(wrap_pyfunction!(runs::run_with_sensitivities, m)?)?;
    m.add_function(wrap_pyfunction!(runs::evaluate_responses, m)?)?;
    m.add_function(wrap_pyfunction!(modes::linearize, m)?)?;
    m.add_function(wrap_pyfunction!(modes::natural_modes, m)?)?;
    m.add_function(wrap_pyfunction!(fields::rigid_positions, m)?)?;
    m.add_function(wrap_pyfunction!(refinement::prolong, m)?)?;
    m.add_function(wrap_pyfunction!(refinement::bar_shares, m)?)?;
    m.add_function(wrap_pyfunction!(refinement::time_errors, m)?)?;
    m.add_function(wrap_pyfunction!(fields::section_forces, m)?)?;
    m.add_function(wrap_pyfunction!(fields::cell_fields, m)?)?;
    m.add_function(wrap_pyfunction!(model::response_kinds, m)?)?;
    m.add_function(wrap_pyfunction!(model::size_limits, m)?)?;
    m.add_function(wrap_pyfunction!(signals::cancel_running, m)?)?;
    Ok(())
}
