//! thermrs-core: the pure-Rust heart of thermrs.
//!
//! It knows nothing of Python. Modules, one idea each:
//! - [`rig`]: rig files (SPEC §3), parsed and validated with errors naming the key;
//! - [`config`]: strict TOML parsing shared by rig and scenario files;
//! - [`kinematics`]: standard Denavit–Hartenberg forward kinematics with per-sample link lengths;
//! - [`optics`]: the laser ray and its intersection with a CCD chip, in pixels (SPEC §4);
//! - [`model`]: the thermal-expansion forward model (SPEC §4), vectorised over time series;
//! - [`effects`]: the unmodelled effects of SPEC §6, their parameters, validation and action;
//! - [`explain`]: a rig checked and explained pose by pose (`thermrs rig`);
//! - [`error`]: every error of the core, typed by cause;
//! - [`msg`]: the ROS 2 message types, shared by the decoder and the encoder;
//! - [`cdr`]: zero-copy ROS 2 CDR decoding of the recorded message types;
//! - [`centroid`]: laser-spot detection and sub-pixel centroids on CCD frames;
//! - [`thermal`]: thermal ROI maxima in °C;
//! - [`ingest`]: streaming, chunk-parallel MCAP extraction into tables;
//! - [`inventory`]: what a recording holds, from its summary and indexes (`thermrs info`);
//! - [`heat`]: the lumped thermal model of the links (warm-up, cool-down, lag);
//! - [`scenario`]: scenario files, what the simulator makes a rig do;
//! - [`record`]: a streaming writer of recordings (CDR encoders, MCAP);
//! - [`simulate`]: the simulator, a rig at work written as a recording with its truth.

pub mod bag;
pub mod cdr;
pub mod centroid;
pub mod config;
pub mod digest;
pub mod effects;
pub mod error;
pub mod explain;
pub mod heat;
pub mod holes;
pub mod ingest;
pub mod inventory;
pub mod kinematics;
pub mod model;
pub mod msg;
pub mod optics;
pub mod record;
pub mod rig;
pub mod ros1;
pub mod scenario;
pub mod simulate;
pub mod thermal;

pub use error::{Error, Result};
