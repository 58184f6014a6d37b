//! Interrupting long work. The loops of the engine — time steps (every generalized-α step,
//! so forward runs, sensitivity sweeps and their replays), load steps, the adjoint's
//! backward steps, and a scene's build (reading and building its lists of entries, the
//! rank analysis of its joints) — call [`poll`]. It asks the checker the caller installed on this thread
//! with [`with_checker`], at most once per [`INTERVAL`], and turns a request to stop into
//! [`SolveError::Interrupted`]. Without a checker it costs a thread-local read.
//!
//! The Python bindings install a checker that runs Python's signal handlers, so Ctrl-C
//! raises `KeyboardInterrupt` within an interval and a step. The time loop polls through
//! [`poll_at`], which also records the time reached: the checker reads it ([`reached`]) to
//! report a run's progress.

use std::cell::{Cell, RefCell};
use std::time::{Duration, Instant};

use crate::error::SolveError;

/// Least time between two calls of the checker.
pub const INTERVAL: Duration = Duration::from_millis(50);

struct Checker {
    stop: Box<dyn FnMut() -> bool>,
    next: Instant,
}

thread_local! {
    static CHECKER: RefCell<Option<Checker>> = const { RefCell::new(None) };
    static REACHED: Cell<f64> = const { Cell::new(f64::NAN) };
}

/// Restores the checker a [`with_checker`] replaced, also when its body unwinds.
struct Restore(Option<Checker>);

impl Drop for Restore {
    fn drop(&mut self) {
        let previous = self.0.take();
        CHECKER.with(|c| *c.borrow_mut() = previous);
    }
}

/// Runs `body` with `stop` as this thread's checker: [`poll`] inside `body` fails once
/// `stop` returns `true`.
pub fn with_checker<R>(stop: impl FnMut() -> bool + 'static, body: impl FnOnce() -> R) -> R {
    let checker = Checker {
        stop: Box::new(stop),
        next: Instant::now() + INTERVAL,
    };
    let _restore = Restore(CHECKER.with(|c| c.borrow_mut().replace(checker)));
    REACHED.with(|r| r.set(f64::NAN));
    body()
}

/// `Err(SolveError::Interrupted)` when this thread's checker, asked at most once per
/// [`INTERVAL`], wants the work to stop.
///
/// # Errors
/// [`SolveError::Interrupted`].
pub fn poll() -> Result<(), SolveError> {
    CHECKER.with(|c| match c.borrow_mut().as_mut() {
        Some(checker) if Instant::now() >= checker.next => {
            checker.next = Instant::now() + INTERVAL;
            if (checker.stop)() {
                Err(SolveError::Interrupted)
            } else {
                Ok(())
            }
        }
        _ => Ok(()),
    })
}

/// [`poll`], having recorded that the work on this thread reached time `t` (s).
///
/// # Errors
/// [`SolveError::Interrupted`].
pub fn poll_at(t: f64) -> Result<(), SolveError> {
    REACHED.with(|r| r.set(t));
    poll()
}

/// The time the work on this thread last reported to [`poll_at`] (NaN before any);
/// [`with_checker`] starts from NaN.
#[cfg_attr(not(feature = "python"), allow(dead_code))] // read by the bindings' checker
pub fn reached() -> f64 {
    REACHED.with(Cell::get)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::Cell;
    use std::rc::Rc;

    #[test]
    fn polls_at_most_once_per_interval_and_stops_when_asked() {
        let calls = Rc::new(Cell::new(0));
        let counted = Rc::clone(&calls);
        let started = Instant::now();
        let result = with_checker(
            move || {
                counted.set(counted.get() + 1);
                counted.get() == 3
            },
            || -> Result<(), SolveError> {
                loop {
                    poll()?;
                    std::hint::spin_loop();
                }
            },
        );
        assert_eq!(result, Err(SolveError::Interrupted));
        assert_eq!(calls.get(), 3);
        assert!(started.elapsed() >= 3 * INTERVAL);
        assert_eq!(poll(), Ok(()), "the checker is gone after with_checker");
    }

    #[test]
    fn the_checker_reads_the_time_the_work_reached() {
        let seen = Rc::new(Cell::new(f64::NAN));
        let read = Rc::clone(&seen);
        with_checker(
            move || {
                read.set(reached());
                false
            },
            || {
                assert!(reached().is_nan(), "nothing reached yet");
                std::thread::sleep(INTERVAL);
                poll_at(0.25).unwrap();
            },
        );
        assert_eq!(seen.get(), 0.25);
    }
}
