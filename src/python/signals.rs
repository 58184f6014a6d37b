//! Engine work without the GIL that still hears Ctrl-C: the engine's interrupt checker
//! ([`crate::with_checker`]) runs Python's signal handlers, and an exception a handler
//! raises (`KeyboardInterrupt`) replaces the engine's `Interrupted`. A panic of the engine
//! (a broken invariant, never a user's input) reaches Python as a `SimulationError` that says
//! so, not as pyo3's `PanicException`.

use std::any::Any;
use std::cell::RefCell;
use std::panic::{self, AssertUnwindSafe};
use std::rc::Rc;

use pyo3::prelude::*;

use super::errors::SimulationError;
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
        let out = panic::catch_unwind(AssertUnwindSafe(|| crate::with_checker(stop, work)));
        match (out, raised.take()) {
            (Ok(Err(_)), Some(signal)) => Err(signal),
            (Ok(out), _) => out.map_err(PyErr::from),
            (Err(payload), _) => Err(SimulationError::new_err(format!(
                "internal error in the engine (a bug; please report it with the scene): {}",
                panic_message(&payload)
            ))),
        }
    })
}

/// The message a panic was raised with.
fn panic_message(payload: &Box<dyn Any + Send>) -> &str {
    payload
        .downcast_ref::<&str>()
        .copied()
        .or_else(|| payload.downcast_ref::<String>().map(String::as_str))
        .unwrap_or("no message")
}
