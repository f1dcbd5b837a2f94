//! Zero-copy reader of ROS 2 CDR message payloads, as stored in MCAP messages
//! whose message encoding is `cdr`, for exactly four message types:
//! `sensor_msgs/msg/Image`, `sensor_msgs/msg/CompressedImage`,
//! `sensor_msgs/msg/JointState` and `sensor_msgs/msg/Temperature`.
//!
//! Strings and byte sequences are borrowed from the payload; nothing is
//! copied except the `float64[]` and `string[]` of a `JointState` (into small
//! `Vec`s). [`parse_image`] is O(1) in the image size.
//!
//! # Encapsulation
//! A payload starts with a 4-byte encapsulation header: bytes 0–1 are a
//! big-endian id, bytes 2–3 options (ignored). The body is little-endian iff
//! `id & 1 == 1`. Supported ids:
//!
//! | id | name | rules |
//! | --- | --- | --- |
//! | `0x0000`/`0x0001` | CDR_BE/CDR_LE (XCDR1) | primitives aligned to their size (2, 4, 8) |
//! | `0x0006`/`0x0007`, `0x0010`/`0x0011` | CDR2_BE/LE (plain XCDR2, final types) | as XCDR1, but 8-byte primitives align to 4 |
//! | `0x0008`/`0x0009`, `0x0014`/`0x0015` | D_CDR2_BE/LE (delimited XCDR2, appendable types) | as plain XCDR2, plus a uint32 DHEADER (byte size of what follows) before every struct and before every sequence of non-primitive elements (`string[]`) |
//!
//! `0x06`–`0x0b` are the RTPS ids of XTypes 1.3 §7.6.3.1.2, `0x10`–`0x15` the
//! `ENC_HEADER` ids of §7.4.3.4 (the same as `@foxglove/cdr`'s
//! `EncapsulationKind`). The parameter-list (mutable) encodings `0x0002`/`0x0003`
//! (PL_CDR), `0x000a`/`0x000b` and `0x0012`/`0x0013` (PL_CDR2) are rejected
//! with [`CdrError::ParameterList`]; any other id with
//! [`CdrError::UnknownEncapsulation`].
//!
//! A DHEADER is honoured as the appendable rule says: a struct's members
//! must fit within it, and any bytes it declares beyond the known members
//! (fields appended by a newer type version) are skipped.
//!
//! # Layout rules
//! Alignment is counted from byte 4 (the byte after the encapsulation
//! header). A `string` is a uint32 length that counts the terminating NUL,
//! the UTF-8 bytes, then the NUL (a length of 0 is read as `""`). A sequence
//! is a uint32 count, then its elements, each aligned to its own size (an
//! empty sequence has no padding). `builtin_interfaces/Time` is int32 `sec`,
//! uint32 `nanosec`; `std_msgs/Header` is `stamp` then `frame_id`.
//!
//! Reference layout, little-endian XCDR1 `Image` with frame_id `"ccd_a"` and
//! encoding `"mono8"`: `0: 00 01 00 00`; 4 sec; 8 nanosec; 12 frame_id
//! length 6; 16..22 `"ccd_a\0"`; pad to 24; 24 height; 28 width; 32 encoding
//! length 6; 36..42 `"mono8\0"`; 42 is_bigendian; pad to 44; 44 step; 48 data
//! count; 52.. data.
//!
//! # Errors
//! Parsing untrusted bytes never panics and never allocates more than the
//! payload can hold: every [`CdrError`] names the field (`Image.data`,
//! `JointState.name`, ...) and the byte offset where reading failed.

use std::fmt;

/// The field names of a message's `std_msgs/Header` (for errors naming the field).
macro_rules! header_fields {
    ($msg:literal) => {
        HeaderFields {
            header: concat!($msg, ".header"),
            stamp: concat!($msg, ".header.stamp"),
            sec: concat!($msg, ".header.stamp.sec"),
            nanosec: concat!($msg, ".header.stamp.nanosec"),
            frame_id: concat!($msg, ".header.frame_id"),
        }
    };
}

mod reader;

pub use crate::msg::{CompressedImageMsg, ImageMsg, JointStateMsg, TemperatureMsg};
use reader::*;

/// What a payload's 4-byte encapsulation header says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Encapsulation {
    /// The raw id (bytes 0–1, big-endian).
    pub id: u16,
    pub little_endian: bool,
    /// XCDR2: 8-byte primitives align to 4.
    pub xcdr2: bool,
    /// Delimited XCDR2: DHEADERs before structs and non-primitive sequences.
    pub delimited: bool,
}

/// Why a payload could not be read. `Display` is one line naming the field
/// and byte offset.
#[derive(Debug, Clone, PartialEq)]
pub enum CdrError {
    /// Fewer than the 4 bytes of the encapsulation header.
    MissingHeader { len: usize },
    /// A parameter-list (mutable-type) encapsulation: PL_CDR or PL_CDR2.
    ParameterList { id: u16 },
    /// An encapsulation id that is not CDR at all (or not known).
    UnknownEncapsulation { id: u16 },
    /// The payload ends before `field` is complete.
    Truncated {
        field: &'static str,
        /// Where the missing bytes start.
        offset: usize,
        needed: u64,
        remaining: usize,
    },
    /// The string `field`, whose bytes start at `offset`, is not UTF-8.
    InvalidUtf8 { field: &'static str, offset: usize },
    /// The string `field`, whose bytes start at `offset`, does not end in NUL.
    MissingNul { field: &'static str, offset: usize },
    /// The members of `field` (whose body starts at `offset`) run past the
    /// size its DHEADER declares.
    DelimiterOverrun {
        field: &'static str,
        offset: usize,
        declared: u32,
        used: usize,
    },
}

impl fmt::Display for CdrError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CdrError::MissingHeader { len } => write!(
                f,
                "truncated at byte 0 reading the CDR encapsulation header (needs 4 bytes, {len} left)"
            ),
            CdrError::ParameterList { id } => write!(
                f,
                "unsupported CDR encapsulation 0x{id:04x} at byte 0: parameter-list (mutable) encodings are not supported"
            ),
            CdrError::UnknownEncapsulation { id } => {
                write!(f, "unknown CDR encapsulation id 0x{id:04x} at byte 0")
            }
            CdrError::Truncated {
                field,
                offset,
                needed,
                remaining,
            } => write!(
                f,
                "truncated at byte {offset} reading {field} (needs {needed} bytes, {remaining} left)"
            ),
            CdrError::InvalidUtf8 { field, offset } => {
                write!(f, "invalid UTF-8 at byte {offset} in {field}")
            }
            CdrError::MissingNul { field, offset } => write!(
                f,
                "string {field} starting at byte {offset} lacks its terminating NUL"
            ),
            CdrError::DelimiterOverrun {
                field,
                offset,
                declared,
                used,
            } => write!(
                f,
                "{field} starting at byte {offset} overruns its DHEADER ({used} bytes read, {declared} declared)"
            ),
        }
    }
}

impl std::error::Error for CdrError {}

/// Reads and classifies the encapsulation header of `buf`.
pub fn encapsulation(buf: &[u8]) -> Result<Encapsulation, CdrError> {
    let Some(&[hi, lo, _, _]) = buf.first_chunk::<4>() else {
        return Err(CdrError::MissingHeader { len: buf.len() });
    };
    let id = u16::from_be_bytes([hi, lo]);
    let (xcdr2, delimited) = match id {
        0x00 | 0x01 => (false, false),
        0x06 | 0x07 | 0x10 | 0x11 => (true, false),
        0x08 | 0x09 | 0x14 | 0x15 => (true, true),
        0x02 | 0x03 | 0x0a | 0x0b | 0x12 | 0x13 => return Err(CdrError::ParameterList { id }),
        _ => return Err(CdrError::UnknownEncapsulation { id }),
    };
    Ok(Encapsulation {
        id,
        little_endian: id & 1 == 1,
        xcdr2,
        delimited,
    })
}

/// Parses a `sensor_msgs/msg/Image` payload. `data` borrows from `buf`; its
/// length is checked against the payload only (not against `step * height`).
pub fn parse_image(buf: &[u8]) -> Result<ImageMsg<'_>, CdrError> {
    const H: HeaderFields = header_fields!("Image");
    let mut r = Reader::new(buf)?;
    let d = r.begin("Image")?;
    let (stamp_ns, frame_id) = r.header(&H)?;
    let height = r.u32("Image.height")?;
    let width = r.u32("Image.width")?;
    let encoding = r.string("Image.encoding")?;
    let is_bigendian = r.u8("Image.is_bigendian")? != 0;
    let step = r.u32("Image.step")?;
    let data = r.byte_seq("Image.data")?;
    r.end(d, "Image")?;
    Ok(ImageMsg {
        stamp_ns,
        frame_id,
        height,
        width,
        encoding,
        is_bigendian,
        step,
        data,
    })
}

/// Parses a `sensor_msgs/msg/CompressedImage` payload. `data` borrows from `buf`.
pub fn parse_compressed_image(buf: &[u8]) -> Result<CompressedImageMsg<'_>, CdrError> {
    const H: HeaderFields = header_fields!("CompressedImage");
    let mut r = Reader::new(buf)?;
    let d = r.begin("CompressedImage")?;
    let (stamp_ns, frame_id) = r.header(&H)?;
    let format = r.string("CompressedImage.format")?;
    let data = r.byte_seq("CompressedImage.data")?;
    r.end(d, "CompressedImage")?;
    Ok(CompressedImageMsg {
        stamp_ns,
        frame_id,
        format,
        data,
    })
}

/// Parses a `sensor_msgs/msg/JointState` payload.
pub fn parse_joint_state(buf: &[u8]) -> Result<JointStateMsg<'_>, CdrError> {
    const H: HeaderFields = header_fields!("JointState");
    let mut r = Reader::new(buf)?;
    let d = r.begin("JointState")?;
    let (stamp_ns, frame_id) = r.header(&H)?;
    let names = r.string_seq("JointState.name")?;
    let position = r.f64_seq("JointState.position")?;
    let velocity = r.f64_seq("JointState.velocity")?;
    let effort = r.f64_seq("JointState.effort")?;
    r.end(d, "JointState")?;
    Ok(JointStateMsg {
        stamp_ns,
        frame_id,
        names,
        position,
        velocity,
        effort,
    })
}

/// Parses a `sensor_msgs/msg/Temperature` payload.
pub fn parse_temperature(buf: &[u8]) -> Result<TemperatureMsg, CdrError> {
    const H: HeaderFields = header_fields!("Temperature");
    let mut r = Reader::new(buf)?;
    let d = r.begin("Temperature")?;
    let (stamp_ns, _frame_id) = r.header(&H)?;
    let temperature = r.f64("Temperature.temperature")?;
    let variance = r.f64("Temperature.variance")?;
    r.end(d, "Temperature")?;
    Ok(TemperatureMsg {
        stamp_ns,
        temperature,
        variance,
    })
}

#[cfg(test)]
mod tests;
