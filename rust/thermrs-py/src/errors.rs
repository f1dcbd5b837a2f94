//! The Python exceptions of thermrs and the one mapping of core errors onto them.
//!
//! The match in [`to_py`] names every core variant (no wildcard): a new variant does not
//! compile until it is given its Python class. Bad input is a `ThermrsError` subclass (the CLI
//! exits 2); a failed write is an `OSError` naming the file (the CLI exits 1); Ctrl-C is
//! `KeyboardInterrupt`; a panic is [`crate::guard::InternalError`].

use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyKeyboardInterrupt, PyOSError};
use pyo3::prelude::*;
use thermrs_core::error::{Error as CoreError, FileKind, RecordError};

create_exception!(
    thermrs._native,
    ThermrsError,
    PyException,
    "Base class of every error thermrs raises on purpose."
);
create_exception!(
    thermrs._native,
    RigError,
    ThermrsError,
    "A rig file that does not parse or does not validate; the message names the key."
);
create_exception!(
    thermrs._native,
    ScenarioError,
    ThermrsError,
    "A scenario file that does not parse or does not validate; the message names the key."
);
create_exception!(
    thermrs._native,
    RecordingError,
    ThermrsError,
    "A recording that cannot be used: not MCAP, or none of the rig's topics in it."
);
create_exception!(
    thermrs._native,
    InputError,
    ThermrsError,
    "Arguments or data that do not fit: shapes, names, values, unreadable files."
);

/// The Python exception for a core error.
pub fn to_py(e: CoreError) -> PyErr {
    match e {
        CoreError::Rig(r) => match r.kind {
            FileKind::Rig => RigError::new_err(r.to_string()),
            FileKind::Scenario => ScenarioError::new_err(r.to_string()),
        },
        e @ CoreError::LaserMisses(_) => RigError::new_err(e.to_string()),
        CoreError::Write { target, source } => write_error(&target, &source),
        e @ (CoreError::NotMcap { .. }
        | CoreError::NoRigTopics { .. }
        | CoreError::BadChunk { .. }
        | CoreError::BadBag { .. }
        | CoreError::Refused { .. }) => RecordingError::new_err(e.to_string()),
        e @ (CoreError::Io { .. }
        | CoreError::Heat(_)
        | CoreError::UnknownName(_)
        | CoreError::OutOfRange { .. }
        | CoreError::Shape { .. }
        | CoreError::Ragged { .. }
        | CoreError::EffectValue { .. }
        | CoreError::EffectJson { .. }
        | CoreError::DuplicateEffect { .. }
        | CoreError::LengthAlreadyExpands { .. }
        | CoreError::ZeroLength { .. }
        | CoreError::NoThermalCamera
        | CoreError::NodeRise { .. }
        | CoreError::CycleTooShort { .. }) => InputError::new_err(e.to_string()),
        CoreError::Interrupted => PyKeyboardInterrupt::new_err("interrupted"),
    }
}

/// A failed write as `OSError(errno, strerror, target)` (Python picks the subclass by errno:
/// `PermissionError`, …): one line naming the file; without an OS error, the writer's reason.
pub fn write_error(target: &str, source: &RecordError) -> PyErr {
    match source
        .io_error()
        .and_then(|e| e.raw_os_error().map(|n| (n, e)))
    {
        Some((errno, e)) => {
            let text = e.to_string();
            // std's Display appends " (os error N)"; Python's own strerror does not.
            let strerror = text.split(" (os error").next().unwrap_or(&text).to_string();
            PyOSError::new_err((errno, strerror, target.to_string()))
        }
        None => PyOSError::new_err(format!("cannot write {target}: {source}")),
    }
}

/// Add the exception classes to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("ThermrsError", py.get_type::<ThermrsError>())?;
    m.add("RigError", py.get_type::<RigError>())?;
    m.add("InputError", py.get_type::<InputError>())?;
    m.add("RecordingError", py.get_type::<RecordingError>())?;
    m.add("ScenarioError", py.get_type::<ScenarioError>())?;
    Ok(())
}
