//! Error types of the core. Every message is one line and names what is wrong and where.

use std::fmt;

pub use crate::heat::HeatError;
pub use crate::record::RecordError;

/// Which kind of TOML file a [`RigError`] is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FileKind {
    /// A rig file (SPEC §3).
    Rig,
    /// A scenario file (`docs/scenarios.md`).
    Scenario,
}

impl fmt::Display for FileKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            FileKind::Rig => "rig",
            FileKind::Scenario => "scenario",
        })
    }
}

/// A rig (or scenario) file that is not valid: which file, which key, what is wrong.
#[derive(Debug, Clone, PartialEq)]
pub struct RigError {
    /// A rig or a scenario.
    pub kind: FileKind,
    /// The file (or `<string>`) the rig came from.
    pub source_name: String,
    /// 1-based line in the file, where the TOML parser could tell.
    pub line: Option<usize>,
    /// Dotted key path, e.g. `camera[1].x_axis` (empty for a syntax error).
    pub key: String,
    /// What is wrong, in one line.
    pub message: String,
}

impl fmt::Display for RigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {}", self.kind, self.source_name)?;
        if let Some(line) = self.line {
            write!(f, " line {line}")?;
        }
        if self.key.is_empty() {
            write!(f, ": {}", self.message)
        } else {
            write!(f, ": {}: {}", self.key, self.message)
        }
    }
}

/// A value that does not validate: the key (relative to what is validated) and what is wrong.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct KeyError {
    /// Dotted key, e.g. `rise_saturating.s0`, `poses[2].joints_deg`.
    pub key: String,
    /// What is wrong, in one line.
    pub message: String,
}

impl KeyError {
    /// A key and its problem.
    pub fn new(key: impl Into<String>, message: impl Into<String>) -> KeyError {
        KeyError {
            key: key.into(),
            message: message.into(),
        }
    }
}

impl fmt::Display for KeyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.key, self.message)
    }
}

/// Every error the core reports.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A rig or scenario file that does not parse or does not validate ([`RigError::kind`]).
    #[error("{0}")]
    Rig(RigError),
    /// A file that cannot be read.
    #[error("cannot read {path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    /// Output that cannot be written (a full disk, a closed pipe, no permission): `target`
    /// names the file, or what was being written when the core does not know the file.
    #[error("cannot write {target}: {source}")]
    Write {
        target: String,
        #[source]
        source: RecordError,
    },
    /// Thermal nodes or series that do not fit ([`crate::heat`]).
    #[error(transparent)]
    Heat(#[from] HeatError),
    /// Arguments that do not fit (shapes, names, values).
    #[error("{0}")]
    Input(String),
    /// A recording that cannot be used at all (not MCAP, none of the rig's topics).
    #[error("{0}")]
    Recording(String),
    /// The caller asked to stop (Ctrl-C).
    #[error("interrupted")]
    Interrupted,
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

impl From<RigError> for Error {
    fn from(e: RigError) -> Self {
        Error::Rig(e)
    }
}
