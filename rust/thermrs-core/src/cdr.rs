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

/// Offset of the first body byte: alignment is counted from here.
const ORIGIN: usize = 4;

/// Decoded `sensor_msgs/msg/Image`; `data` borrows from the payload.
#[derive(Debug, Clone, PartialEq)]
pub struct ImageMsg<'a> {
    /// `header.stamp` as `sec * 1e9 + nanosec`.
    pub stamp_ns: i64,
    pub frame_id: &'a str,
    pub height: u32,
    pub width: u32,
    pub encoding: &'a str,
    pub is_bigendian: bool,
    /// Row length in bytes. Not checked against `width`, `height` or `data`.
    pub step: u32,
    pub data: &'a [u8],
}

/// Decoded `sensor_msgs/msg/CompressedImage`; `data` borrows from the payload.
#[derive(Debug, Clone, PartialEq)]
pub struct CompressedImageMsg<'a> {
    /// `header.stamp` as `sec * 1e9 + nanosec`.
    pub stamp_ns: i64,
    pub frame_id: &'a str,
    pub format: &'a str,
    pub data: &'a [u8],
}

/// Decoded `sensor_msgs/msg/JointState`.
#[derive(Debug, Clone, PartialEq)]
pub struct JointStateMsg<'a> {
    /// `header.stamp` as `sec * 1e9 + nanosec`.
    pub stamp_ns: i64,
    pub frame_id: &'a str,
    pub names: Vec<&'a str>,
    pub position: Vec<f64>,
    /// Often empty.
    pub velocity: Vec<f64>,
    /// Often empty.
    pub effort: Vec<f64>,
}

/// Decoded `sensor_msgs/msg/Temperature`.
#[derive(Debug, Clone, PartialEq)]
pub struct TemperatureMsg {
    /// `header.stamp` as `sec * 1e9 + nanosec`.
    pub stamp_ns: i64,
    pub temperature: f64,
    pub variance: f64,
}

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

/// Field names of a `std_msgs/Header` inside one message type.
struct HeaderFields {
    header: &'static str,
    stamp: &'static str,
    sec: &'static str,
    nanosec: &'static str,
    frame_id: &'static str,
}

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

/// A DHEADER-delimited region: body start and end (exclusive).
#[derive(Clone, Copy)]
struct Delimited {
    start: usize,
    end: usize,
    declared: u32,
}

/// Cursor over one payload. Invariant: `ORIGIN <= pos <= buf.len()`.
struct Reader<'a> {
    buf: &'a [u8],
    pos: usize,
    little_endian: bool,
    /// Largest alignment: 8 in XCDR1, 4 in XCDR2.
    max_align: usize,
    delimited: bool,
}

impl<'a> Reader<'a> {
    fn new(buf: &'a [u8]) -> Result<Self, CdrError> {
        let enc = encapsulation(buf)?;
        Ok(Reader {
            buf,
            pos: ORIGIN,
            little_endian: enc.little_endian,
            max_align: if enc.xcdr2 { 4 } else { 8 },
            delimited: enc.delimited,
        })
    }

    /// Position of the next item of `size` bytes after alignment padding
    /// (may lie past the end; the caller's bounds check catches that).
    #[inline]
    fn aligned(&self, size: usize) -> usize {
        let a = size.min(self.max_align); // 1, 2, 4 or 8
        let rel = self.pos - ORIGIN;
        self.pos + ((a - (rel & (a - 1))) & (a - 1))
    }

    #[inline]
    fn truncated(&self, field: &'static str, offset: usize, needed: u64) -> CdrError {
        CdrError::Truncated {
            field,
            offset,
            needed,
            remaining: self.buf.len().saturating_sub(offset),
        }
    }

    /// Reads one primitive of `N` bytes, aligned to `N`.
    #[inline]
    fn array<const N: usize>(&mut self, field: &'static str) -> Result<[u8; N], CdrError> {
        let start = self.aligned(N);
        match self.buf.get(start..).and_then(<[u8]>::first_chunk::<N>) {
            Some(bytes) => {
                self.pos = start + N;
                Ok(*bytes)
            }
            None => Err(self.truncated(field, start, N as u64)),
        }
    }

    #[inline]
    fn u8(&mut self, field: &'static str) -> Result<u8, CdrError> {
        let [b] = self.array::<1>(field)?;
        Ok(b)
    }

    #[inline]
    fn u32(&mut self, field: &'static str) -> Result<u32, CdrError> {
        let b = self.array::<4>(field)?;
        Ok(if self.little_endian {
            u32::from_le_bytes(b)
        } else {
            u32::from_be_bytes(b)
        })
    }

    #[inline]
    fn i32(&mut self, field: &'static str) -> Result<i32, CdrError> {
        let b = self.array::<4>(field)?;
        Ok(if self.little_endian {
            i32::from_le_bytes(b)
        } else {
            i32::from_be_bytes(b)
        })
    }

    #[inline]
    fn f64(&mut self, field: &'static str) -> Result<f64, CdrError> {
        let b = self.array::<8>(field)?;
        Ok(self.decode_f64(b))
    }

    #[inline]
    fn decode_f64(&self, b: [u8; 8]) -> f64 {
        if self.little_endian {
            f64::from_le_bytes(b)
        } else {
            f64::from_be_bytes(b)
        }
    }

    /// Borrows `n` bytes starting at the current position (no alignment).
    #[inline]
    fn bytes(&mut self, n: usize, field: &'static str) -> Result<&'a [u8], CdrError> {
        let start = self.pos;
        match start
            .checked_add(n)
            .and_then(|end| self.buf.get(start..end))
        {
            Some(s) => {
                self.pos = start + n;
                Ok(s)
            }
            None => Err(self.truncated(field, start, n as u64)),
        }
    }

    /// A CDR string, borrowed and UTF-8 checked.
    fn string(&mut self, field: &'static str) -> Result<&'a str, CdrError> {
        let len = self.u32(field)? as usize;
        if len == 0 {
            return Ok("");
        }
        let start = self.pos;
        let raw = self.bytes(len, field)?;
        let Some((&0, text)) = raw.split_last() else {
            return Err(CdrError::MissingNul {
                field,
                offset: start,
            });
        };
        std::str::from_utf8(text).map_err(|e| CdrError::InvalidUtf8 {
            field,
            offset: start + e.valid_up_to(),
        })
    }

    /// A sequence count, checked so that `count * min_elem_size` bytes fit
    /// in what is left (so no allocation can exceed the payload).
    fn count(&mut self, field: &'static str, min_elem_size: usize) -> Result<usize, CdrError> {
        let count = self.u32(field)?;
        let needed = u64::from(count) * min_elem_size as u64;
        let remaining = self.buf.len() - self.pos;
        if needed > remaining as u64 {
            return Err(self.truncated(field, self.pos, needed));
        }
        Ok(count as usize)
    }

    /// A `uint8[]`, borrowed.
    #[inline]
    fn byte_seq(&mut self, field: &'static str) -> Result<&'a [u8], CdrError> {
        let n = self.u32(field)? as usize;
        self.bytes(n, field)
    }

    /// A `float64[]`.
    fn f64_seq(&mut self, field: &'static str) -> Result<Vec<f64>, CdrError> {
        let n = self.count(field, 8)?;
        if n == 0 {
            return Ok(Vec::new());
        }
        self.pos = self.aligned(8);
        let raw = self.bytes(n * 8, field)?; // n * 8 <= remaining: no overflow
        Ok(raw
            .chunks_exact(8)
            .filter_map(|c| c.first_chunk::<8>())
            .map(|b| self.decode_f64(*b))
            .collect())
    }

    /// A `string[]` (DHEADER first in delimited XCDR2).
    fn string_seq(&mut self, field: &'static str) -> Result<Vec<&'a str>, CdrError> {
        let d = self.begin(field)?;
        let n = self.count(field, 4)?;
        let mut out = Vec::with_capacity(n);
        for _ in 0..n {
            out.push(self.string(field)?);
        }
        self.end(d, field)?;
        Ok(out)
    }

    /// Reads the DHEADER of a struct or non-primitive sequence, if this
    /// encoding has them.
    fn begin(&mut self, field: &'static str) -> Result<Option<Delimited>, CdrError> {
        if !self.delimited {
            return Ok(None);
        }
        let declared = self.u32(field)?;
        let start = self.pos;
        if u64::from(declared) > (self.buf.len() - start) as u64 {
            return Err(self.truncated(field, start, u64::from(declared)));
        }
        Ok(Some(Delimited {
            start,
            end: start + declared as usize,
            declared,
        }))
    }

    /// Closes a region opened by [`Reader::begin`]: checks the members fit
    /// and skips any appended members this reader does not know.
    fn end(&mut self, d: Option<Delimited>, field: &'static str) -> Result<(), CdrError> {
        if let Some(d) = d {
            if self.pos > d.end {
                return Err(CdrError::DelimiterOverrun {
                    field,
                    offset: d.start,
                    declared: d.declared,
                    used: self.pos - d.start,
                });
            }
            self.pos = d.end;
        }
        Ok(())
    }

    /// A `std_msgs/Header`: returns (`stamp_ns`, `frame_id`).
    fn header(&mut self, f: &HeaderFields) -> Result<(i64, &'a str), CdrError> {
        let h = self.begin(f.header)?;
        let t = self.begin(f.stamp)?;
        let sec = self.i32(f.sec)?;
        let nanosec = self.u32(f.nanosec)?;
        self.end(t, f.stamp)?;
        let frame_id = self.string(f.frame_id)?;
        self.end(h, f.header)?;
        // |sec| * 1e9 + nanosec < 2.2e18 < i64::MAX: cannot overflow.
        Ok((
            i64::from(sec) * 1_000_000_000 + i64::from(nanosec),
            frame_id,
        ))
    }
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
mod tests {
    use super::*;

    // Written by fixtures/cdr/make_cdr_fixtures.py: `*_le` by mcap_ros2's
    // serializer, the others by hand (see the script for their layouts).
    macro_rules! fixture {
        ($name:literal) => {
            include_bytes!(concat!("../../../fixtures/cdr/", $name))
        };
    }

    const IMAGE_MONO8_LE: &[u8] = fixture!("image_mono8_le.cdr");
    const IMAGE_MONO8_BE: &[u8] = fixture!("image_mono8_be.cdr");
    const IMAGE_MONO8_CDR2: &[u8] = fixture!("image_mono8_cdr2.cdr");
    const IMAGE_MONO8_DCDR2: &[u8] = fixture!("image_mono8_dcdr2.cdr");
    const IMAGE_MONO16_LE: &[u8] = fixture!("image_mono16_le.cdr");
    const COMPRESSED_LE: &[u8] = fixture!("compressed_image_le.cdr");
    const JOINT_LE: &[u8] = fixture!("joint_state_le.cdr");
    const JOINT_BE: &[u8] = fixture!("joint_state_be.cdr");
    const JOINT_CDR2: &[u8] = fixture!("joint_state_cdr2.cdr");
    const JOINT_DCDR2: &[u8] = fixture!("joint_state_dcdr2.cdr");
    const JOINT_FULL_LE: &[u8] = fixture!("joint_state_full_le.cdr");
    const TEMP_LE: &[u8] = fixture!("temperature_le.cdr");
    const TEMP_BE: &[u8] = fixture!("temperature_be.cdr");
    const TEMP_CDR2: &[u8] = fixture!("temperature_cdr2.cdr");
    const TEMP_DCDR2: &[u8] = fixture!("temperature_dcdr2.cdr");

    const ALL: &[&[u8]] = &[
        IMAGE_MONO8_LE,
        IMAGE_MONO8_BE,
        IMAGE_MONO8_CDR2,
        IMAGE_MONO8_DCDR2,
        IMAGE_MONO16_LE,
        COMPRESSED_LE,
        JOINT_LE,
        JOINT_BE,
        JOINT_CDR2,
        JOINT_DCDR2,
        JOINT_FULL_LE,
        TEMP_LE,
        TEMP_BE,
        TEMP_CDR2,
        TEMP_DCDR2,
    ];

    // Known truth, from fixtures/cdr/expected.json.
    const MONO8_PIXELS: [u8; 24] = [
        1, 2, 3, 4, 5, 238, 238, 238, 11, 12, 13, 14, 15, 238, 238, 238, 21, 22, 23, 24, 25, 238,
        238, 238,
    ];
    const NAMES: [&str; 6] = [
        "joint_a1", "joint_a2", "joint_a3", "joint_a4", "joint_a5", "joint_a6",
    ];
    const POSITIONS: [f64; 6] = [
        0.0,
        // Python's repr of -pi/2 and pi/2 (clippy wants the named constant).
        -std::f64::consts::FRAC_PI_2,
        std::f64::consts::FRAC_PI_2,
        0.1,
        -0.25,
        3.0,
    ];

    fn bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    /// `data` must point into `buf` (zero copy).
    fn borrowed_from(data: &[u8], buf: &[u8]) -> bool {
        let r = buf.as_ptr_range();
        data.is_empty() || (r.contains(&data.as_ptr()) && data.as_ptr_range().end <= r.end)
    }

    fn check_mono8(buf: &[u8]) {
        let m = parse_image(buf).expect("valid image");
        assert_eq!(m.stamp_ns, 1_700_000_000_123_456_789);
        assert_eq!(m.frame_id, "ccd_a");
        assert_eq!(m.height, 3);
        assert_eq!(m.width, 5);
        assert_eq!(m.encoding, "mono8");
        assert!(!m.is_bigendian);
        assert_eq!(m.step, 8);
        assert_eq!(m.data, &MONO8_PIXELS[..]);
        assert!(borrowed_from(m.data, buf));
        assert_eq!(m.data.as_ptr_range().end, buf.as_ptr_range().end);
    }

    #[test]
    fn image_mono8_all_encodings() {
        assert_eq!(IMAGE_MONO8_LE[..4], [0, 1, 0, 0]);
        assert_eq!(IMAGE_MONO8_BE[..4], [0, 0, 0, 0]);
        assert_eq!(IMAGE_MONO8_CDR2[..4], [0, 7, 0, 0]);
        assert_eq!(IMAGE_MONO8_DCDR2[..4], [0, 9, 0, 0]);
        for buf in [
            IMAGE_MONO8_LE,
            IMAGE_MONO8_BE,
            IMAGE_MONO8_CDR2,
            IMAGE_MONO8_DCDR2,
        ] {
            check_mono8(buf);
        }
        // Reference layout: data count at 48, data from 52.
        let m = parse_image(IMAGE_MONO8_LE).unwrap();
        assert_eq!(m.data.as_ptr(), IMAGE_MONO8_LE[52..].as_ptr());
    }

    #[test]
    fn image_mono16() {
        let m = parse_image(IMAGE_MONO16_LE).unwrap();
        assert_eq!(m.stamp_ns, 1_700_000_001_999_999_999);
        assert_eq!(m.frame_id, "ccd_b");
        assert_eq!((m.height, m.width, m.step), (2, 3, 6));
        assert_eq!(m.encoding, "mono16");
        assert!(!m.is_bigendian);
        assert_eq!(m.data, &[2, 1, 232, 3, 255, 255, 0, 0, 0, 1, 255, 15][..]);
        let px: Vec<u16> = m
            .data
            .chunks_exact(2)
            .map(|c| u16::from_le_bytes([c[0], c[1]]))
            .collect();
        assert_eq!(px, [0x0102, 1000, 65535, 0, 256, 4095]);
        assert!(borrowed_from(m.data, IMAGE_MONO16_LE));
    }

    #[test]
    fn compressed_image() {
        let m = parse_compressed_image(COMPRESSED_LE).unwrap();
        assert_eq!(m.stamp_ns, 1_700_000_002_000_000_005);
        assert_eq!(m.frame_id, "ccd_a");
        assert_eq!(m.format, "png");
        assert_eq!(m.data, &[137, 80, 78, 71, 13, 10, 26, 10, 0, 255, 127][..]);
        assert!(borrowed_from(m.data, COMPRESSED_LE));
    }

    #[test]
    fn joint_state_all_encodings() {
        assert_eq!(JOINT_LE.len(), 188);
        for buf in [JOINT_LE, JOINT_BE, JOINT_CDR2, JOINT_DCDR2] {
            let m = parse_joint_state(buf).unwrap();
            assert_eq!(m.stamp_ns, 1_700_000_003_250_000_000);
            assert_eq!(m.frame_id, "robot");
            assert_eq!(m.names, NAMES);
            assert_eq!(bits(&m.position), bits(&POSITIONS));
            assert!(m.velocity.is_empty());
            assert!(m.effort.is_empty());
        }
    }

    #[test]
    fn joint_state_with_velocity_and_effort() {
        let m = parse_joint_state(JOINT_FULL_LE).unwrap();
        assert_eq!(m.stamp_ns, -1_999_999_999); // sec -2, nanosec 1
        assert_eq!(m.frame_id, "base_link");
        assert_eq!(m.names, NAMES);
        assert_eq!(bits(&m.position), bits(&POSITIONS));
        assert_eq!(
            bits(&m.velocity),
            bits(&[0.5, -0.5, 1e-300, -0.0, 2.5, 1e300])
        );
        assert_eq!(
            bits(&m.effort),
            bits(&[10.0, 20.0, -30.0, 0.125, 7.0, -0.001])
        );
    }

    #[test]
    fn temperature_all_encodings() {
        assert_eq!(TEMP_LE.len(), 44);
        for buf in [TEMP_LE, TEMP_BE, TEMP_CDR2, TEMP_DCDR2] {
            let m = parse_temperature(buf).unwrap();
            assert_eq!(m.stamp_ns, 1_700_000_004_000_000_042);
            assert_eq!(m.temperature.to_bits(), 21.375f64.to_bits());
            assert_eq!(m.variance.to_bits(), 0.0025f64.to_bits());
        }
    }

    #[test]
    fn xtypes_enc_header_aliases() {
        // 0x11 = PLAIN_CDR2 LE, 0x15 = DELIMIT_CDR2 LE: same body rules.
        let mut b = IMAGE_MONO8_CDR2.to_vec();
        b[1] = 0x11;
        check_mono8(&b);
        let mut b = IMAGE_MONO8_DCDR2.to_vec();
        b[1] = 0x15;
        check_mono8(&b);
        let mut b = JOINT_CDR2.to_vec();
        b[1] = 0x06; // big-endian id on a little-endian body: wrong, but no panic
        assert!(parse_joint_state(&b).is_err());
        let e = encapsulation(&[0, 0x14, 0, 0]).unwrap();
        assert!(!e.little_endian && e.xcdr2 && e.delimited);
        let e = encapsulation(&[0, 0x07, 0, 0]).unwrap();
        assert!(e.little_endian && e.xcdr2 && !e.delimited);
        let e = encapsulation(&[0, 0x00, 0xff, 0xff]).unwrap();
        assert!(!e.little_endian && !e.xcdr2 && !e.delimited);
    }

    #[test]
    fn every_prefix_is_an_error() {
        for buf in ALL {
            for n in 0..buf.len() {
                let p = &buf[..n];
                // The data of an image ends the payload; every parser must
                // reject every strict prefix of a payload of its own type.
                let _ = parse_compressed_image(p);
                let _ = parse_image(p);
                let _ = parse_joint_state(p);
                let _ = parse_temperature(p);
            }
        }
        for (buf, f) in [
            (IMAGE_MONO8_LE, 0),
            (IMAGE_MONO8_BE, 0),
            (IMAGE_MONO8_CDR2, 0),
            (IMAGE_MONO8_DCDR2, 0),
            (IMAGE_MONO16_LE, 0),
            (COMPRESSED_LE, 1),
            (JOINT_LE, 2),
            (JOINT_BE, 2),
            (JOINT_CDR2, 2),
            (JOINT_DCDR2, 2),
            (JOINT_FULL_LE, 2),
            (TEMP_LE, 3),
            (TEMP_BE, 3),
            (TEMP_CDR2, 3),
            (TEMP_DCDR2, 3),
        ] {
            for n in 0..buf.len() {
                let p = &buf[..n];
                let err = match f {
                    0 => parse_image(p).err(),
                    1 => parse_compressed_image(p).err(),
                    2 => parse_joint_state(p).err(),
                    _ => parse_temperature(p).err(),
                };
                let err = err.unwrap_or_else(|| panic!("prefix {n} of {} parsed", buf.len()));
                let msg = err.to_string();
                assert!(!msg.contains('\n'), "{msg}");
                assert!(msg.contains("byte"), "{msg}");
            }
        }
    }

    #[test]
    fn truncated_image_data_message() {
        let p = &IMAGE_MONO8_LE[..60];
        let e = parse_image(p).unwrap_err();
        assert_eq!(
            e,
            CdrError::Truncated {
                field: "Image.data",
                offset: 52,
                needed: 24,
                remaining: 8
            }
        );
        assert_eq!(
            e.to_string(),
            "truncated at byte 52 reading Image.data (needs 24 bytes, 8 left)"
        );
        let e = parse_image(&IMAGE_MONO8_LE[..3]).unwrap_err();
        assert_eq!(e, CdrError::MissingHeader { len: 3 });
    }

    #[test]
    fn wrong_encapsulation_id() {
        let mut b = TEMP_LE.to_vec();
        b[1] = 0x03;
        let e = parse_temperature(&b).unwrap_err();
        assert_eq!(e, CdrError::ParameterList { id: 3 });
        assert!(e.to_string().contains("0x0003"));
        for id in [0x02u8, 0x0a, 0x0b, 0x12, 0x13] {
            b[1] = id;
            assert_eq!(
                parse_temperature(&b),
                Err(CdrError::ParameterList { id: id.into() })
            );
        }
        b[1] = 0x05;
        assert_eq!(
            parse_temperature(&b),
            Err(CdrError::UnknownEncapsulation { id: 5 })
        );
        b[0] = 0x01;
        b[1] = 0x01;
        let e = parse_temperature(&b).unwrap_err();
        assert_eq!(e, CdrError::UnknownEncapsulation { id: 0x0101 });
        assert_eq!(
            e.to_string(),
            "unknown CDR encapsulation id 0x0101 at byte 0"
        );
    }

    fn put_u32_le(b: &mut [u8], at: usize, v: u32) {
        b[at..at + 4].copy_from_slice(&v.to_le_bytes());
    }

    #[test]
    fn string_length_past_end() {
        let mut b = IMAGE_MONO8_LE.to_vec();
        put_u32_le(&mut b, 12, 1000); // frame_id length
        let e = parse_image(&b).unwrap_err();
        assert_eq!(
            e,
            CdrError::Truncated {
                field: "Image.header.frame_id",
                offset: 16,
                needed: 1000,
                remaining: 60
            }
        );
        put_u32_le(&mut b, 12, u32::MAX);
        assert!(parse_image(&b).is_err());
    }

    #[test]
    fn string_errors() {
        let mut b = IMAGE_MONO8_LE.to_vec();
        b[37] = 0xff; // inside "mono8"
        let e = parse_image(&b).unwrap_err();
        assert_eq!(
            e,
            CdrError::InvalidUtf8 {
                field: "Image.encoding",
                offset: 37
            }
        );
        assert_eq!(e.to_string(), "invalid UTF-8 at byte 37 in Image.encoding");
        let mut b = IMAGE_MONO8_LE.to_vec();
        b[41] = b'x'; // the NUL after "mono8"
        assert_eq!(
            parse_image(&b),
            Err(CdrError::MissingNul {
                field: "Image.encoding",
                offset: 36
            })
        );
        // Length 0 reads as "" (frame_id of the temperature: 8 bytes -> 0).
        let mut t = Vec::from(&TEMP_LE[..12]);
        t.extend_from_slice(&0u32.to_le_bytes()); // frame_id len 0 at 12, pad to 20
        t.extend_from_slice(&[0; 4]);
        t.extend_from_slice(&TEMP_LE[28..]);
        let m = parse_temperature(&t).unwrap();
        assert_eq!(m.temperature, 21.375);
    }

    #[test]
    fn huge_counts_do_not_allocate() {
        let mut b = JOINT_LE.to_vec();
        put_u32_le(&mut b, 24, u32::MAX); // name count
        let e = parse_joint_state(&b).unwrap_err();
        assert_eq!(
            e,
            CdrError::Truncated {
                field: "JointState.name",
                offset: 28,
                needed: u64::from(u32::MAX) * 4,
                remaining: 160
            }
        );
        let mut b = JOINT_LE.to_vec();
        put_u32_le(&mut b, 124, u32::MAX); // position count
        let e = parse_joint_state(&b).unwrap_err();
        assert!(
            matches!(
                e,
                CdrError::Truncated {
                    field: "JointState.position",
                    ..
                }
            ),
            "{e}"
        );
        let mut b = IMAGE_MONO8_LE.to_vec();
        put_u32_le(&mut b, 48, u32::MAX); // data count
        let e = parse_image(&b).unwrap_err();
        assert_eq!(
            e.to_string(),
            "truncated at byte 52 reading Image.data (needs 4294967295 bytes, 24 left)"
        );
    }

    #[test]
    fn dheader_rules() {
        // Extra appended bytes declared by the top-level DHEADER are skipped.
        let mut b = TEMP_DCDR2.to_vec();
        let top = u32::from_le_bytes([b[4], b[5], b[6], b[7]]);
        assert_eq!(top as usize, b.len() - 8);
        put_u32_le(&mut b, 4, top + 4);
        b.extend_from_slice(&[1, 2, 3, 4]);
        assert_eq!(parse_temperature(&b).unwrap().temperature, 21.375);
        // So are bytes appended to a nested struct (a newer Header version):
        // header body is 12..36, temperature follows at 36.
        let mut b = TEMP_DCDR2.to_vec();
        let hdr = u32::from_le_bytes([b[8], b[9], b[10], b[11]]);
        assert_eq!(hdr, 24);
        put_u32_le(&mut b, 4, top + 4);
        put_u32_le(&mut b, 8, hdr + 4);
        b.splice(36..36, [0xde, 0xad, 0xbe, 0xef]);
        let m = parse_temperature(&b).unwrap();
        assert_eq!(m.stamp_ns, 1_700_000_004_000_000_042);
        assert_eq!(m.temperature, 21.375);
        assert_eq!(m.variance, 0.0025);
        // A DHEADER larger than the payload is a truncation.
        let mut b = TEMP_DCDR2.to_vec();
        put_u32_le(&mut b, 4, top + 4);
        assert!(matches!(
            parse_temperature(&b),
            Err(CdrError::Truncated {
                field: "Temperature",
                offset: 8,
                ..
            })
        ));
        // A header DHEADER too small for its members is an overrun.
        let mut b = TEMP_DCDR2.to_vec();
        let hdr = u32::from_le_bytes([b[8], b[9], b[10], b[11]]);
        put_u32_le(&mut b, 8, hdr - 1);
        let e = parse_temperature(&b).unwrap_err();
        assert_eq!(
            e,
            CdrError::DelimiterOverrun {
                field: "Temperature.header",
                offset: 12,
                declared: hdr - 1,
                used: hdr as usize
            }
        );
        assert!(!e.to_string().contains('\n'));
    }

    /// xorshift64*: deterministic, no crates.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
        }
        fn below(&mut self, n: usize) -> usize {
            (self.next() % n as u64) as usize
        }
    }

    #[test]
    fn fuzz_mutations_never_panic() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let mut parsed = 0usize;
        for buf in ALL {
            for _ in 0..3000 {
                let mut b = buf.to_vec();
                for _ in 0..1 + rng.below(4) {
                    let i = rng.below(b.len());
                    b[i] = match rng.below(4) {
                        0 => 0xff,
                        1 => 0,
                        2 => b[i] ^ (1 << rng.below(8)),
                        _ => rng.next() as u8,
                    };
                }
                if rng.below(4) == 0 {
                    b.truncate(rng.below(b.len() + 1));
                }
                parsed += usize::from(parse_image(&b).is_ok());
                parsed += usize::from(parse_compressed_image(&b).is_ok());
                parsed += usize::from(parse_joint_state(&b).is_ok());
                parsed += usize::from(parse_temperature(&b).is_ok());
            }
        }
        // Sanity: many single-byte changes (pixel values, stamps) still parse.
        assert!(parsed > 1000, "{parsed}");
    }
}
