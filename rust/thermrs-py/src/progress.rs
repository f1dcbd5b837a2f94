//! Long core calls run without the GIL and call back between chunks: to check for Ctrl-C and
//! to report progress. A Python error raised in such a callback (a `KeyboardInterrupt`, an
//! exception of the progress function) is kept in a [`Pending`] slot, the callback tells the
//! core to stop, and the error is raised once the call is back with the GIL.

use std::sync::Mutex;
use std::time::{Duration, Instant};

use pyo3::prelude::*;

/// How often a long call without chunks (the simulator) checks for signals.
pub const SIGNAL_EVERY: Duration = Duration::from_millis(20);

/// The Python error a callback raised, raised again after the call.
#[derive(Default)]
pub struct Pending(Mutex<Option<PyErr>>);

impl Pending {
    /// Run `f` with the GIL: `true` to go on; on an error, keep it and return `false` (stop).
    pub fn attach(&self, f: impl FnOnce(Python<'_>) -> PyResult<()>) -> bool {
        Python::attach(|py| match f(py) {
            Ok(()) => true,
            Err(e) => {
                *self.0.lock().expect("lock") = Some(e);
                false
            }
        })
    }

    /// The kept error, if a callback raised one.
    pub fn take(&self) -> Option<PyErr> {
        self.0.lock().expect("lock").take()
    }
}

/// A cancel callback for core loops that ask often: checks for signals at most every
/// [`SIGNAL_EVERY`], and asks `cancel` (a Python callable) too when one is given; `true`
/// (stop) once a signal raised, or once `cancel()` is true (then a `KeyboardInterrupt` is
/// pending). Signals reach only the main thread: `cancel` is how a call running in another
/// thread learns that it should stop.
pub fn signal_checker<'a>(
    pending: &'a Pending,
    cancel: Option<&'a Py<PyAny>>,
) -> impl Fn() -> bool + 'a {
    let last = std::cell::Cell::new(Instant::now());
    move || {
        if last.get().elapsed() < SIGNAL_EVERY {
            return false;
        }
        last.set(Instant::now());
        !pending.attach(|py| {
            py.check_signals()?;
            if let Some(c) = cancel {
                if c.bind(py).call0()?.is_truthy()? {
                    return Err(pyo3::exceptions::PyKeyboardInterrupt::new_err("cancelled"));
                }
            }
            Ok(())
        })
    }
}

/// Between chunks (with the GIL): check for signals, then call `progress(done, total)`.
pub fn report(
    py: Python<'_>,
    progress: Option<&Bound<'_, PyAny>>,
    done: usize,
    total: usize,
) -> PyResult<()> {
    py.check_signals()?;
    if let Some(cb) = progress {
        cb.call1((done, total))?;
    }
    Ok(())
}
