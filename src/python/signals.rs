//! Engine work without the GIL that still hears Ctrl-C: the engine's interrupt checker
//! ([`crate::with_checker`]) runs Python's signal handlers, and an exception a handler
//! raises (`KeyboardInterrupt`) replaces the engine's `Interrupted`.

use std::cell::RefCell;
use std::rc::Rc;

use pyo3::prelude::*;

use crate::error::Error;

/// Runs `work` with the GIL released, polled for Python signals.
pub fn detached<T: Send>(
    py: Python<'_>,
    work: impl FnOnce() -> Result<T, Error> + Send,
) -> PyResult<T> {
    py.detach(move || {
        let raised: Rc<RefCell<Option<PyErr>>> = Rc::default();
        let held = Rc::clone(&raised);
        let stop = move || match Python::attach(|py| py.check_signals()) {
            Ok(()) => false,
            Err(e) => {
                *held.borrow_mut() = Some(e);
                true
            }
        };
        let out = crate::with_checker(stop, work);
        match (out, raised.take()) {
            (Err(_), Some(signal)) => Err(signal),
            (out, _) => out.map_err(PyErr::from),
        }
    })
}
