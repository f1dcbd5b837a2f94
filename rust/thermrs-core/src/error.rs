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
    /// A name that is not one of those known where it is used (a camera, a temperature, …).
    #[error("{0}")]
    UnknownName(UnknownName),
    /// A number outside what is allowed: `{name} is {value}, expected {allowed}`.
    #[error("{name} is {value}, expected {allowed}")]
    OutOfRange {
        /// What the number is, e.g. `alpha_per_k`, `joint_offset.joint`.
        name: String,
        value: f64,
        /// What it may be, e.g. `a finite number`, `0..=5 (0-based)`.
        allowed: String,
    },
    /// Arrays that do not fit together: `what` counts `got`, `expected` were needed.
    #[error("{what}: got {got}, expected {expected}")]
    Shape {
        /// What was counted, e.g. `temperature columns (the rig maps link2, link3)`.
        what: String,
        expected: usize,
        got: usize,
    },
    /// A flat array that is not a whole number of rows of `width` values.
    #[error("{what}: {len} values is not a whole number of {width}-value rows")]
    Ragged {
        what: String,
        len: usize,
        width: usize,
    },
    /// An effect (SPEC §6) whose values do not validate: the effect and the key.
    #[error("effect {effect}: {error}")]
    EffectValue {
        effect: &'static str,
        error: KeyError,
    },
    /// Effects given as JSON that do not parse (`what`: `effect` or `effects`).
    #[error("{what}: {source}")]
    EffectJson {
        what: &'static str,
        #[source]
        source: serde_json::Error,
    },
    /// The same effect twice (`key`: its name, with its length, joint or camera where several
    /// of one kind are distinct mechanisms).
    #[error("effect {key} is given twice")]
    DuplicateEffect { key: String },
    /// `unmodelled_length` on a length the rig's `[expansion]` already expands.
    #[error("unmodelled_length {length}: the rig already expands it (its [expansion] lists it)")]
    LengthAlreadyExpands { length: String },
    /// `unmodelled_length` on a DH length that is 0 mm.
    #[error("unmodelled_length {length}: it is 0 mm in robot.dh, so it cannot expand")]
    ZeroLength { length: String },
    /// A pose whose own camera the laser misses (`thermrs rig`).
    #[error("{0}")]
    LaserMisses(LaserMiss),
    /// The simulator needs a thermal camera the rig does not have.
    #[error("the rig has no [thermal] camera to simulate")]
    NoThermalCamera,
    /// A scenario's thermal node with neither or both of `rise_k` and `rise_saturating`.
    #[error("thermal node {node:?}: give exactly one of rise_k and rise_saturating")]
    NodeRise { node: String },
    /// A run whose cycle is too short for its moves and dwells.
    #[error(
        "run {run:?}: moves and dwells take {motion_s:.1} s, more than the {available_s:.1} s of \
         the cycle before the thermal frame (lengthen cycle_s or shorten motion.dwell_s)"
    )]
    CycleTooShort {
        run: String,
        motion_s: f64,
        available_s: f64,
    },
    /// A file that is not an MCAP recording (too short, or no MCAP magic at its start).
    #[error("{path}: not an MCAP file ({bytes} bytes, no MCAP magic at its start)")]
    NotMcap { path: String, bytes: u64 },
    /// A recording with none of the rig's topics (`present`: the topics it has).
    #[error(
        "{path}: none of the rig's topics ({}) is in the recording (it has: {})",
        topics.join(", "),
        if present.is_empty() { "no channels".to_string() } else { present.join(", ") }
    )]
    NoRigTopics {
        path: String,
        topics: Vec<String>,
        present: Vec<String>,
    },
    /// A chunk of a recording that cannot be decompressed (`reason`: the decoder's).
    #[error("{path}: {reason}")]
    BadChunk { path: String, reason: String },
    /// The caller asked to stop (Ctrl-C).
    #[error("interrupted")]
    Interrupted,
    /// A folder taken for a rosbag2 bag whose `metadata.yaml` is unreadable or wrong.
    #[error("bag {path}: {reason}")]
    BadBag { path: String, reason: String },
    /// A recording in a format thermrs does not read (`what`), with the conversion to use.
    #[error("{path}: {what}, which thermrs does not read; convert it to MCAP: {conversion}")]
    Refused {
        path: String,
        what: String,
        conversion: String,
    },
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Which kind of name an [`UnknownName`] is: each says where the name should have been.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NameKind {
    /// A camera of the rig.
    Camera,
    /// A temperature: a ROI of the rig's thermal camera, or `ambient`.
    Temperature,
    /// A joint of the rig: its name or `1`..`6`.
    Joint,
    /// A scenario's thermal node, which must be a ROI of the rig.
    ThermalNode,
    /// A temperature given its own α that no expanding length follows.
    ExpandingTemperature,
    /// A temperature the model needs that no simulated thermal node provides.
    SimulatedTemperature,
    /// A recording compression (`none`, `zstd`, `lz4`).
    Compression,
}

/// A name that is not among those `known` where it is used; `context` says where (e.g.
/// `effect joint_offset`; empty for none).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UnknownName {
    pub context: String,
    pub kind: NameKind,
    pub name: String,
    pub known: Vec<String>,
}

impl UnknownName {
    /// A `kind` name that is not one of `known`, used in `context`.
    pub fn new(
        context: impl Into<String>,
        kind: NameKind,
        name: impl Into<String>,
        known: Vec<String>,
    ) -> UnknownName {
        UnknownName {
            context: context.into(),
            kind,
            name: name.into(),
            known,
        }
    }
}

impl fmt::Display for UnknownName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if !self.context.is_empty() {
            write!(f, "{}: ", self.context)?;
        }
        let (name, known) = (&self.name, self.known.join(", "));
        match self.kind {
            NameKind::Camera => write!(f, "camera {name:?} is not in the rig (cameras: {known})"),
            NameKind::Temperature => write!(
                f,
                "temperature {name:?} is neither a ROI of the rig nor ambient (known: {known})"
            ),
            NameKind::Joint => write!(
                f,
                "joint {name:?} is not a joint of the rig (joints: {known}, or 1..6)"
            ),
            NameKind::ThermalNode => write!(
                f,
                "thermal node {name:?} is not a ROI of the rig (ROIs: {known})"
            ),
            NameKind::ExpandingTemperature => write!(
                f,
                "alpha for temperature {name:?}: no length expands with it (temperatures: {known})"
            ),
            NameKind::SimulatedTemperature => write!(
                f,
                "the model needs temperature {name:?} but no thermal node simulates it \
                 (nodes: {known})"
            ),
            NameKind::Compression => {
                write!(f, "compression {name:?} is not known (known: {known})")
            }
        }
    }
}

/// A pose whose own camera the laser misses: where the ray meets the chip plane (`hit_px`),
/// if it does, and the chip's size.
#[derive(Debug, Clone, PartialEq)]
pub struct LaserMiss {
    pub pose: String,
    pub camera: String,
    pub hit_px: Option<[f64; 2]>,
    pub chip_px: [usize; 2],
}

impl fmt::Display for LaserMiss {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "pose {:?}: the laser misses camera {:?}'s chip: ",
            self.pose, self.camera
        )?;
        match self.hit_px {
            Some([x, y]) => write!(
                f,
                "it meets the chip plane at x = {x:.1} px, y = {y:.1} px, off the {}x{} chip",
                self.chip_px[0], self.chip_px[1]
            ),
            None => f.write_str("the ray never meets the chip plane in front of the laser"),
        }
    }
}

impl serde::Serialize for LaserMiss {
    /// As its one line (the `problems` of `thermrs rig --json`).
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

impl From<UnknownName> for Error {
    fn from(e: UnknownName) -> Self {
        Error::UnknownName(e)
    }
}

impl From<RigError> for Error {
    fn from(e: RigError) -> Self {
        Error::Rig(e)
    }
}
