//! Panics never reach Python as `PanicException` (a `BaseException` a caller's `except
//! Exception` does not catch): a core call runs under [`guard`], which turns a panic into
//! [`InternalError`], a `ThermrsError` with a one-line message. The panic hook is silenced
//! (it would print the panic's location to stderr) unless `THERMRS_DEBUG` is set.

use std::panic::{self, AssertUnwindSafe};

use pyo3::create_exception;
use pyo3::prelude::*;

use crate::errors::{to_py as core_to_py, ThermrsError};
use thermrs_core::error::Error as CoreError;

create_exception!(
    thermrs._native,
    InternalError,
    ThermrsError,
    "A bug in thermrs (a panic in the core), reported as one line instead of a crash."
);

/// Run `f`, turning a panic into a one-line message naming `what` was being done.
pub fn guard<R>(what: &str, f: impl FnOnce() -> R) -> Result<R, String> {
    panic::catch_unwind(AssertUnwindSafe(f)).map_err(|payload| {
        let msg = payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown panic".to_string());
        let line = msg.lines().next().unwrap_or("").trim();
        format!("internal error while {what}: {line} (a bug in thermrs; please report it)")
    })
}

/// The Python exception for a message from [`guard`].
pub fn to_py(msg: String) -> PyErr {
    InternalError::new_err(msg)
}

/// Run the core call `f` under [`guard`] and map its error: a panic becomes
/// [`InternalError`], a core error its Python class ([`crate::errors::to_py`]).
pub fn call<T>(what: &str, f: impl FnOnce() -> Result<T, CoreError>) -> PyResult<T> {
    guard(what, f).map_err(to_py)?.map_err(core_to_py)
}

/// Print panics only with `THERMRS_DEBUG` set; they surface as [`InternalError`] anyway.
pub fn install_hook() {
    let default = panic::take_hook();
    panic::set_hook(Box::new(move |info| {
        if std::env::var_os("THERMRS_DEBUG").is_some_and(|v| !v.is_empty() && v != "0") {
            default(info);
        }
    }));
}

/// A panic on purpose, under [`guard`] or not (`guarded = False`: what a panic outside it
/// would do), so that tests can check both ends.
#[pyfunction]
#[pyo3(signature = (*, guarded = true))]
fn _panic_for_tests(guarded: bool) -> PyResult<()> {
    let boom = || -> () { panic!("deliberate panic for a test\nsecond line") };
    if guarded {
        guard("testing the panic guard", boom).map_err(to_py)
    } else {
        boom();
        Ok(())
    }
}

/// Add [`InternalError`] and the test entry to the module; install the hook.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("InternalError", m.py().get_type::<InternalError>())?;
    m.add_function(wrap_pyfunction!(_panic_for_tests, m)?)?;
    install_hook();
    Ok(())
}
