//! Engine work without the GIL that still hears Ctrl-C: the engine's interrupt checker
//! ([`crate::with_checker`]) runs Python's signal handlers, and an exception a handler
//! raises (`KeyboardInterrupt`) replaces the engine's `Interrupted`. Python runs signal
//! handlers in its main thread only, so work on other threads (a thread pool's tasks) also
//! stops when [`cancel_running`] is called after it started: the main thread calls it when
//! Ctrl-C reaches it while it waits for them. A panic of the engine
//! (a broken invariant, never a user's input) reaches Python as a `SimulationError` that says
//! so, not as pyo3's `PanicException`.

use std::any::Any;
use std::cell::RefCell;
use std::panic::{self, AssertUnwindSafe};
use std::rc::Rc;
use std::sync::atomic::{AtomicU64, Ordering};

use pyo3::exceptions::PyKeyboardInterrupt;
use pyo3::prelude::*;

use super::errors::SimulationError;
use crate::error::Error;

/// How many times [`cancel_running`] was called: work started before the last call stops.
static CANCELLATIONS: AtomicU64 = AtomicU64::new(0);

/// Stops, at their next poll, the engine's runs that started before this call, on every
/// thread (each raises `KeyboardInterrupt`); runs started after it are not affected.
#[pyfunction]
pub fn cancel_running() {
    CANCELLATIONS.fetch_add(1, Ordering::SeqCst);
}

/// Runs `work` with the GIL released, polled for Python signals and for [`cancel_running`].
pub fn detached<T: Send>(
    py: Python<'_>,
    work: impl FnOnce() -> Result<T, Error> + Send,
) -> PyResult<T> {
    reporting(py, None, work)
}

/// [`detached`], calling `progress` (if given) with the time the work reached (s) at each
/// poll: an exception it raises stops the work as Ctrl-C does.
pub fn reporting<T: Send>(
    py: Python<'_>,
    progress: Option<Py<PyAny>>,
    work: impl FnOnce() -> Result<T, Error> + Send,
) -> PyResult<T> {
    let started = CANCELLATIONS.load(Ordering::SeqCst);
    py.detach(move || {
        let raised: Rc<RefCell<Option<PyErr>>> = Rc::default();
        let held = Rc::clone(&raised);
        let stop = move || {
            let signal = if CANCELLATIONS.load(Ordering::SeqCst) != started {
                Err(PyKeyboardInterrupt::new_err(
                    "cancelled: Ctrl-C in the main thread",
                ))
            } else {
                Python::attach(|py| {
                    py.check_signals()?;
                    let t = crate::interrupt::reached();
                    match &progress {
                        Some(report) if t.is_finite() => report.call1(py, (t,)).map(drop),
                        _ => Ok(()),
                    }
                })
            };
            match signal {
                Ok(()) => false,
                Err(e) => {
                    *held.borrow_mut() = Some(e);
                    true
                }
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
