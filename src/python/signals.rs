//! Engine work without the GIL that still hears Ctrl-C: the engine's interrupt checker
//! ([`crate::with_checker`]) runs Python's signal handlers, and an exception a handler
//! raises (`KeyboardInterrupt`) replaces the engine's `Interrupted`; work that holds the GIL
//! (reading a scene dict) hears them the same way ([`heard`]). A model is built on a thread
//! of its own ([`abandonable`]): Ctrl-C returns at once, and the build frees what it made
//! behind. Python runs signal
//! handlers in its main thread only, so work on other threads (a thread pool's tasks) also
//! stops when [`cancel_running`] is called after it started: the main thread calls it when
//! Ctrl-C reaches it while it waits for them. A panic of the engine
//! (a broken invariant, never a user's input) reaches Python as a `SimulationError` that says
//! so, not as pyo3's `PanicException`.

use std::any::Any;
use std::cell::RefCell;
use std::panic::{self, AssertUnwindSafe};
use std::rc::Rc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::sync::Arc;
use std::thread;

use pyo3::exceptions::PyKeyboardInterrupt;
use pyo3::prelude::*;

use super::errors::SimulationError;
use crate::error::Error;
use crate::interrupt::INTERVAL;

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
    py.detach(move || heard(progress, work))
}

/// Runs `work` on this thread, GIL held or not, polled for Python signals and for
/// [`cancel_running`], calling `progress` (if given) with the time the work reached (s)
/// at each poll: an exception a signal handler or `progress` raises replaces the error
/// `work` stopped with.
pub fn heard<T>(
    progress: Option<Py<PyAny>>,
    work: impl FnOnce() -> Result<T, Error>,
) -> PyResult<T> {
    let started = CANCELLATIONS.load(Ordering::SeqCst);
    let raised: Rc<RefCell<Option<PyErr>>> = Rc::default();
    let held = Rc::clone(&raised);
    let stop = move || {
        let heard = Python::attach(|py| {
            signal(py, started)?;
            let t = crate::interrupt::reached();
            match &progress {
                Some(report) if t.is_finite() => report.call1(py, (t,)).map(drop),
                _ => Ok(()),
            }
        });
        match heard {
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
        (Err(payload), _) => Err(internal(panic_message(&payload))),
    }
}

/// Runs `work` on a thread of its own while this one waits, the GIL released, hearing
/// Python's signals and [`cancel_running`] every [`INTERVAL`]. On Ctrl-C it returns at
/// once and leaves `work` to stop at its next poll and free what it made on its own
/// thread: a model of many thousand bodies takes a second to free.
pub fn abandonable<T: Send + 'static>(
    py: Python<'_>,
    work: impl FnOnce() -> Result<T, Error> + Send + 'static,
) -> PyResult<T> {
    let started = CANCELLATIONS.load(Ordering::SeqCst);
    let abandoned = Arc::new(AtomicBool::new(false));
    let stop = Arc::clone(&abandoned);
    let (done, mut outcome) = mpsc::channel();
    thread::spawn(move || {
        let checker = move || stop.load(Ordering::SeqCst);
        let out = panic::catch_unwind(AssertUnwindSafe(|| crate::with_checker(checker, work)));
        // Sent to no one once abandoned: then `out` is freed here.
        let _ = done.send(out);
    });
    loop {
        let (receiver, out) = py.detach(move || {
            let out = outcome.recv_timeout(INTERVAL);
            (outcome, out)
        });
        outcome = receiver;
        match out {
            Ok(Ok(out)) => return out.map_err(PyErr::from),
            Ok(Err(payload)) => return Err(internal(panic_message(&payload))),
            Err(RecvTimeoutError::Timeout) => {
                if let Err(e) = signal(py, started) {
                    abandoned.store(true, Ordering::SeqCst);
                    return Err(e);
                }
            }
            Err(RecvTimeoutError::Disconnected) => {
                return Err(internal("its thread ended without a result"))
            }
        }
    }
}

/// `KeyboardInterrupt` when [`cancel_running`] was called since `started`, or what
/// Python's signal handlers raise.
fn signal(py: Python<'_>, started: u64) -> PyResult<()> {
    if CANCELLATIONS.load(Ordering::SeqCst) != started {
        Err(PyKeyboardInterrupt::new_err(
            "cancelled: Ctrl-C in the main thread",
        ))
    } else {
        py.check_signals()
    }
}

/// A panic of the engine, `what` it said, as a `SimulationError` that says so.
fn internal(what: &str) -> PyErr {
    SimulationError::new_err(format!(
        "internal error in the engine (a bug; please report it with the scene): {what}"
    ))
}

/// The message a panic was raised with.
fn panic_message(payload: &Box<dyn Any + Send>) -> &str {
    payload
        .downcast_ref::<&str>()
        .copied()
        .or_else(|| payload.downcast_ref::<String>().map(String::as_str))
        .unwrap_or("no message")
}
