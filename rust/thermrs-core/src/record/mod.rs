//! Streaming writer of ROS 2 MCAP recordings (SPEC §2), the inverse of
//! [`crate::cdr`] and [`crate::ingest`]: for the simulator.
//!
//! Two layers:
//!
//! * CDR **encoders** for the four recorded message types
//!   (`sensor_msgs/msg/Image`, `CompressedImage`, `JointState`,
//!   `Temperature`), and their `ros2msg` **schema texts**. Every encoder
//!   writes into a caller-provided `Vec<u8>` (cleared first), so a warm buffer
//!   is reused without allocating. [`encode_image_with`] and
//!   [`encode_image_header`] let a renderer write pixels straight into that
//!   buffer.
//! * [`RecordingWriter`], a thin wrapper of [`mcap::Writer`] that registers
//!   one schema per message type and one channel per topic, then appends
//!   messages as they come. Memory does not grow with the number of messages
//!   (beyond a ~100-byte index entry per chunk, kept for the summary).
//!
//! # Encoding
//! Exactly what ROS 2 (Fast-CDR) and the Python `mcap-ros2-support` writer
//! produce: encapsulation header `00 01 00 00` (little-endian plain CDR,
//! XCDR1), then the fields in order, each primitive aligned to its size
//! counted from the byte after the header; a `string` is a `uint32` length
//! including the terminating NUL, the UTF-8 bytes and the NUL (so `""` is
//! length 1); a sequence is a `uint32` count followed by its elements; no
//! trailing padding. `builtin_interfaces/Time` is `int32 sec`,
//! `uint32 nanosec` with `sec = floor(ns / 1e9)` and `nanosec` the
//! non-negative remainder (also for negative times, as ROS 2 does: −1 ns is
//! `sec = -1, nanosec = 999_999_999`). See [`split_stamp`].
//!
//! # Determinism
//! The same calls produce byte-identical files: the `mcap` writer embeds no
//! wall-clock time or randomness, writes summary records in id order, and zstd
//! runs single-threaded here (multi-threaded zstd output would depend on the
//! worker count). The `library` string of the MCAP header is
//! [`RecordOptions::library`].
//!
//! # Example
//! ```ignore
//! use thermrs_core::record::*;
//! let file = std::io::BufWriter::new(std::fs::File::create("sim.mcap")?);
//! let mut w = RecordingWriter::new(file, &RecordOptions::default())?;
//! w.add_channel("/ccd_a/image_raw", MsgType::Image)?;
//! let meta = ImageFields {
//!     stamp_ns: 1_700_000_000_000_000_000,
//!     frame_id: "ccd_a",
//!     width: 752,
//!     height: 582,
//!     encoding: "mono8",
//!     is_bigendian: false,
//!     step: 752,
//! };
//! w.write_image_with("/ccd_a/image_raw", 1_700_000_000_002_000_000, &meta, 752 * 582, |px| {
//!     px.fill(0) // render here
//! })?;
//! w.finish()?;
//! ```

mod encode;
mod writer;

pub use crate::msg::{
    split_stamp, ImageFields, MsgType, COMPRESSED_IMAGE_SCHEMA, IMAGE_SCHEMA, JOINT_STATE_SCHEMA,
    MESSAGE_ENCODING, PROFILE, SCHEMA_ENCODING, TEMPERATURE_SCHEMA,
};
pub use encode::*;
pub use writer::*;

#[cfg(test)]
mod tests;
