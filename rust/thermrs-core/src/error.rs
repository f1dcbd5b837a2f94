//! Error types of the core. Every message is one line and names what is wrong and where.

use std::fmt;

/// A rig (or scenario) file that is not valid: which file, which key, what is wrong.
#[derive(Debug, Clone, PartialEq)]
pub struct RigError {
    /// `rig` or `scenario`.
    pub kind: &'static str,
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

/// Every error the core reports.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A rig file that does not parse or does not validate.
    #[error("{0}")]
    Rig(RigError),
    /// A file that cannot be read.
    #[error("cannot read {path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
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
