//! CDR encoders of the four recorded message types: each writes into a caller-provided
//! `Vec<u8>` (cleared first), so a warm buffer is reused without allocating.

use crate::msg::{split_stamp, ImageFields, ENCAPSULATION_CDR_LE, ORIGIN};

/// Appends CDR primitives to a buffer that starts with the encapsulation
/// header.
struct Enc<'a> {
    out: &'a mut Vec<u8>,
}

impl<'a> Enc<'a> {
    /// Clears `out` and writes the encapsulation header.
    fn start(out: &'a mut Vec<u8>) -> Self {
        out.clear();
        out.extend_from_slice(&ENCAPSULATION_CDR_LE);
        Enc { out }
    }

    /// Zero padding up to a multiple of `a` (a power of two) from [`ORIGIN`].
    #[inline]
    fn align(&mut self, a: usize) {
        let rel = self.out.len() - ORIGIN;
        let pad = (a - (rel & (a - 1))) & (a - 1);
        self.out.resize(self.out.len() + pad, 0);
    }

    #[inline]
    fn u8(&mut self, v: u8) {
        self.out.push(v);
    }

    #[inline]
    fn u32(&mut self, v: u32) {
        self.align(4);
        self.out.extend_from_slice(&v.to_le_bytes());
    }

    #[inline]
    fn i32(&mut self, v: i32) {
        self.align(4);
        self.out.extend_from_slice(&v.to_le_bytes());
    }

    #[inline]
    fn f64(&mut self, v: f64) {
        self.align(8);
        self.out.extend_from_slice(&v.to_le_bytes());
    }

    /// A sequence count or string length.
    ///
    /// # Panics
    /// If `n` exceeds `u32::MAX`.
    #[inline]
    fn len(&mut self, n: usize, what: &str) {
        let n = u32::try_from(n).unwrap_or_else(|_| panic!("{what}: {n} exceeds u32::MAX"));
        self.u32(n);
    }

    fn string(&mut self, s: &str) {
        self.len(s.len() + 1, "string length");
        self.out.extend_from_slice(s.as_bytes());
        self.out.push(0);
    }

    fn bytes(&mut self, b: &[u8]) {
        self.len(b.len(), "byte sequence length");
        self.out.extend_from_slice(b);
    }

    fn f64_seq(&mut self, v: &[f64]) {
        self.len(v.len(), "float64 sequence length");
        if !v.is_empty() {
            self.align(8);
            for x in v {
                self.out.extend_from_slice(&x.to_le_bytes());
            }
        }
    }

    fn string_seq<S: AsRef<str>>(&mut self, v: &[S]) {
        self.len(v.len(), "string sequence length");
        for s in v {
            self.string(s.as_ref());
        }
    }

    /// `std_msgs/Header`.
    ///
    /// # Panics
    /// If the stamp is out of range (see [`split_stamp`]).
    fn header(&mut self, stamp_ns: i64, frame_id: &str) {
        let (sec, nanosec) = split_stamp(stamp_ns)
            .unwrap_or_else(|| panic!("stamp {stamp_ns} ns: seconds do not fit an int32"));
        self.i32(sec);
        self.u32(nanosec);
        self.string(frame_id);
    }
}

/// Encodes a `sensor_msgs/msg/Image` into `out` (cleared first).
///
/// # Panics
/// If the stamp is out of `int32` seconds (see [`split_stamp`]) or a string or
/// `data` is 4 GiB or longer. [`RecordingWriter`](super::RecordingWriter) checks these and returns
/// errors instead.
pub fn encode_image(out: &mut Vec<u8>, img: &ImageFields<'_>, data: &[u8]) {
    let mut e = image_prefix(out, img);
    e.bytes(data);
}

/// Encodes a `sensor_msgs/msg/Image` up to and including the `uint32` count
/// of `data` (which is `data_len`); the caller must then append exactly
/// `data_len` pixel bytes to `out` (e.g. `out.extend(...)` or render into
/// `out.spare_capacity_mut()` and grow it). The data needs no alignment: it
/// starts right after the count.
///
/// # Panics
/// As [`encode_image`].
pub fn encode_image_header(out: &mut Vec<u8>, img: &ImageFields<'_>, data_len: u32) {
    let mut e = image_prefix(out, img);
    e.u32(data_len);
}

/// Encodes a `sensor_msgs/msg/Image` whose `data_len` bytes of pixel data are
/// written in place by `fill` (given a zeroed slice inside `out`), so a
/// renderer needs no intermediate image buffer.
///
/// # Panics
/// As [`encode_image`].
pub fn encode_image_with<F: FnOnce(&mut [u8])>(
    out: &mut Vec<u8>,
    img: &ImageFields<'_>,
    data_len: usize,
    fill: F,
) {
    let mut e = image_prefix(out, img);
    e.len(data_len, "Image.data length");
    let start = out.len();
    out.resize(start + data_len, 0);
    fill(&mut out[start..]);
}

/// Everything of an `Image` before its `data` count.
fn image_prefix<'a>(out: &'a mut Vec<u8>, img: &ImageFields<'_>) -> Enc<'a> {
    let mut e = Enc::start(out);
    e.header(img.stamp_ns, img.frame_id);
    e.u32(img.height);
    e.u32(img.width);
    e.string(img.encoding);
    e.u8(u8::from(img.is_bigendian));
    e.u32(img.step);
    e
}

/// Encodes a `sensor_msgs/msg/CompressedImage` into `out` (cleared first).
/// `format` is e.g. `png`.
///
/// # Panics
/// As [`encode_image`].
pub fn encode_compressed_image(
    out: &mut Vec<u8>,
    stamp_ns: i64,
    frame_id: &str,
    format: &str,
    data: &[u8],
) {
    let mut e = Enc::start(out);
    e.header(stamp_ns, frame_id);
    e.string(format);
    e.bytes(data);
}

/// Encodes a `sensor_msgs/msg/JointState` with `name` and `position` (radians)
/// and empty `velocity` and `effort` into `out` (cleared first).
///
/// # Panics
/// As [`encode_image`].
pub fn encode_joint_state<S: AsRef<str>>(
    out: &mut Vec<u8>,
    stamp_ns: i64,
    frame_id: &str,
    names: &[S],
    positions: &[f64],
) {
    encode_joint_state_full(out, stamp_ns, frame_id, names, positions, &[], &[]);
}

/// Encodes a `sensor_msgs/msg/JointState` with all four arrays into `out`
/// (cleared first). ROS allows `velocity`/`effort` to be empty.
///
/// # Panics
/// As [`encode_image`].
pub fn encode_joint_state_full<S: AsRef<str>>(
    out: &mut Vec<u8>,
    stamp_ns: i64,
    frame_id: &str,
    names: &[S],
    positions: &[f64],
    velocities: &[f64],
    efforts: &[f64],
) {
    let mut e = Enc::start(out);
    e.header(stamp_ns, frame_id);
    e.string_seq(names);
    e.f64_seq(positions);
    e.f64_seq(velocities);
    e.f64_seq(efforts);
}

/// Encodes a `sensor_msgs/msg/Temperature` (°C, and its variance; 0 means
/// unknown) into `out` (cleared first).
///
/// # Panics
/// As [`encode_image`].
pub fn encode_temperature(
    out: &mut Vec<u8>,
    stamp_ns: i64,
    frame_id: &str,
    temperature: f64,
    variance: f64,
) {
    let mut e = Enc::start(out);
    e.header(stamp_ns, frame_id);
    e.f64(temperature);
    e.f64(variance);
}
