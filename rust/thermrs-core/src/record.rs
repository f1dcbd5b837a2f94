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

use std::collections::{BTreeMap, HashMap};
use std::fmt;
use std::io::{Seek, Write};

use mcap::records::{MessageHeader, Metadata};
use mcap::{Compression, McapError, WriteOptions, Writer};

// ---------------------------------------------------------------------------
// Schemas
// ---------------------------------------------------------------------------

/// The MCAP schema encoding of the schemas below.
pub const SCHEMA_ENCODING: &str = "ros2msg";
/// The MCAP message encoding of every channel.
pub const MESSAGE_ENCODING: &str = "cdr";
/// The MCAP profile written to the file header.
pub const PROFILE: &str = "ros2";

/// The dependencies shared by all four types: `std_msgs/Header` and
/// `builtin_interfaces/Time`, each after a line of 80 `=` and a `MSG:` line.
macro_rules! header_deps {
    () => {
        concat!(
            "================================================================================\n",
            "MSG: std_msgs/Header\n",
            "builtin_interfaces/Time stamp\n",
            "string frame_id\n",
            "================================================================================\n",
            "MSG: builtin_interfaces/Time\n",
            "int32 sec\n",
            "uint32 nanosec\n",
        )
    };
}

/// `ros2msg` schema of `sensor_msgs/msg/Image`: the `.msg` fields (comments
/// omitted), then its dependencies in the standard concatenated form.
pub const IMAGE_SCHEMA: &str = concat!(
    "std_msgs/Header header\n",
    "uint32 height\n",
    "uint32 width\n",
    "string encoding\n",
    "uint8 is_bigendian\n",
    "uint32 step\n",
    "uint8[] data\n",
    header_deps!()
);

/// `ros2msg` schema of `sensor_msgs/msg/CompressedImage` (see [`IMAGE_SCHEMA`]).
pub const COMPRESSED_IMAGE_SCHEMA: &str = concat!(
    "std_msgs/Header header\n",
    "string format\n",
    "uint8[] data\n",
    header_deps!()
);

/// `ros2msg` schema of `sensor_msgs/msg/JointState` (see [`IMAGE_SCHEMA`]).
pub const JOINT_STATE_SCHEMA: &str = concat!(
    "std_msgs/Header header\n",
    "string[] name\n",
    "float64[] position\n",
    "float64[] velocity\n",
    "float64[] effort\n",
    header_deps!()
);

/// `ros2msg` schema of `sensor_msgs/msg/Temperature` (see [`IMAGE_SCHEMA`]).
pub const TEMPERATURE_SCHEMA: &str = concat!(
    "std_msgs/Header header\n",
    "float64 temperature\n",
    "float64 variance\n",
    header_deps!()
);

/// One of the four recorded message types.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum MsgType {
    Image,
    CompressedImage,
    JointState,
    Temperature,
}

impl MsgType {
    /// All four, in a fixed order.
    pub const ALL: [MsgType; 4] = [
        MsgType::Image,
        MsgType::CompressedImage,
        MsgType::JointState,
        MsgType::Temperature,
    ];

    /// The MCAP schema name, e.g. `sensor_msgs/msg/Image`.
    pub fn schema_name(self) -> &'static str {
        match self {
            MsgType::Image => "sensor_msgs/msg/Image",
            MsgType::CompressedImage => "sensor_msgs/msg/CompressedImage",
            MsgType::JointState => "sensor_msgs/msg/JointState",
            MsgType::Temperature => "sensor_msgs/msg/Temperature",
        }
    }

    /// The `ros2msg` schema text, e.g. [`IMAGE_SCHEMA`].
    pub fn schema_text(self) -> &'static str {
        match self {
            MsgType::Image => IMAGE_SCHEMA,
            MsgType::CompressedImage => COMPRESSED_IMAGE_SCHEMA,
            MsgType::JointState => JOINT_STATE_SCHEMA,
            MsgType::Temperature => TEMPERATURE_SCHEMA,
        }
    }
}

impl fmt::Display for MsgType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.schema_name())
    }
}

// ---------------------------------------------------------------------------
// CDR encoders
// ---------------------------------------------------------------------------

/// The encapsulation header: CDR_LE (id 0x0001), options 0.
const ENCAPSULATION: [u8; 4] = [0x00, 0x01, 0x00, 0x00];
/// Offset of the first body byte: alignment is counted from here.
const ORIGIN: usize = 4;
const NS_PER_SEC: i64 = 1_000_000_000;

/// Splits a stamp in ns since the epoch into `builtin_interfaces/Time`
/// (`sec = floor(ns / 1e9)`, `nanosec = ns - sec * 1e9` in `0..1e9`), or
/// `None` if `sec` does not fit an `int32` (before 1901-12-13T20:45:52Z or
/// from 2038-01-19T03:14:08Z on).
pub fn split_stamp(stamp_ns: i64) -> Option<(i32, u32)> {
    let sec = i32::try_from(stamp_ns.div_euclid(NS_PER_SEC)).ok()?;
    // rem_euclid is in 0..1e9: fits u32.
    Some((sec, stamp_ns.rem_euclid(NS_PER_SEC) as u32))
}

/// The metadata of a `sensor_msgs/msg/Image` (everything but `data`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImageFields<'a> {
    /// `header.stamp`, ns since the epoch (see [`split_stamp`]).
    pub stamp_ns: i64,
    pub frame_id: &'a str,
    pub width: u32,
    pub height: u32,
    /// e.g. `mono8`, `8UC1`, `mono16`, `16UC1`, `32FC1`.
    pub encoding: &'a str,
    pub is_bigendian: bool,
    /// Row length in bytes (written as given, not checked).
    pub step: u32,
}

/// Appends CDR primitives to a buffer that starts with the encapsulation
/// header.
struct Enc<'a> {
    out: &'a mut Vec<u8>,
}

impl<'a> Enc<'a> {
    /// Clears `out` and writes the encapsulation header.
    fn start(out: &'a mut Vec<u8>) -> Self {
        out.clear();
        out.extend_from_slice(&ENCAPSULATION);
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
/// `data` is 4 GiB or longer. [`RecordingWriter`] checks these and returns
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

// ---------------------------------------------------------------------------
// Writer
// ---------------------------------------------------------------------------

/// Chunk compression.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RecordCompression {
    None,
    #[default]
    Zstd,
    Lz4,
}

impl RecordCompression {
    /// `"none"`, `"zstd"` or `"lz4"`.
    pub fn as_str(self) -> &'static str {
        match self {
            RecordCompression::None => "none",
            RecordCompression::Zstd => "zstd",
            RecordCompression::Lz4 => "lz4",
        }
    }
}

impl std::str::FromStr for RecordCompression {
    type Err = RecordError;

    /// Parses `"none"`, `"zstd"` or `"lz4"` (exactly).
    fn from_str(s: &str) -> Result<Self, RecordError> {
        match s {
            "none" => Ok(RecordCompression::None),
            "zstd" => Ok(RecordCompression::Zstd),
            "lz4" => Ok(RecordCompression::Lz4),
            _ => Err(RecordError::UnknownCompression(s.to_owned())),
        }
    }
}

impl fmt::Display for RecordCompression {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// How a recording is laid out.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RecordOptions {
    /// Compression of chunks (ignored when `use_chunks` is false).
    pub compression: RecordCompression,
    /// Target uncompressed chunk size in bytes: a chunk is closed once it
    /// exceeds this (so a chunk holds at least one message).
    pub chunk_size: u64,
    /// Group messages into (compressed, indexed) chunks. Without chunks,
    /// messages are plain records in the data section and there is no
    /// compression and no index.
    pub use_chunks: bool,
    /// Write the summary section (schemas, channels, statistics, chunk
    /// indexes) and summary offsets, and message indexes after each chunk.
    /// Without it the file is still complete and readable front to back.
    pub summary: bool,
    /// The `library` field of the MCAP header.
    pub library: String,
    /// Compression level; 0 is the compressor's default.
    pub compression_level: u32,
}

impl Default for RecordOptions {
    /// zstd, 1 MiB chunks, with summary, library `thermrs`.
    fn default() -> Self {
        RecordOptions {
            compression: RecordCompression::Zstd,
            chunk_size: WriteOptions::DEFAULT_CHUNK_SIZE,
            use_chunks: true,
            summary: true,
            library: "thermrs".to_owned(),
            compression_level: 0,
        }
    }
}

impl RecordOptions {
    /// The `mcap` write options these stand for (profile `ros2`,
    /// single-threaded compression).
    pub fn to_mcap(&self) -> WriteOptions {
        let compression = match self.compression {
            RecordCompression::None => None,
            RecordCompression::Zstd => Some(Compression::Zstd),
            RecordCompression::Lz4 => Some(Compression::Lz4),
        };
        WriteOptions::new()
            .profile(PROFILE)
            .library(self.library.clone())
            .compression(compression)
            .compression_level(self.compression_level)
            .compression_threads(0)
            .chunk_size(Some(self.chunk_size))
            .use_chunks(self.use_chunks)
            .emit_summary_records(self.summary)
            .emit_summary_offsets(self.summary)
            .emit_message_indexes(self.summary)
    }
}

/// Why a recording could not be written.
#[derive(Debug)]
pub enum RecordError {
    /// The `mcap` writer failed (including I/O errors).
    Mcap(McapError),
    /// A message for a topic that [`RecordingWriter::add_channel`] did not add.
    UnknownTopic(String),
    /// A topic added, or written to, with another message type than it has.
    WrongType {
        topic: String,
        channel: MsgType,
        requested: MsgType,
    },
    /// A header stamp whose seconds do not fit an `int32`.
    StampOutOfRange { topic: String, stamp_ns: i64 },
    /// A string or sequence of 4 GiB or more.
    TooLong {
        topic: String,
        field: &'static str,
        len: usize,
    },
    /// A compression name other than `none`, `zstd`, `lz4`.
    UnknownCompression(String),
}

impl fmt::Display for RecordError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RecordError::Mcap(e) => write!(f, "writing MCAP: {e}"),
            RecordError::UnknownTopic(t) => {
                write!(f, "topic {t:?} has no channel: add it first")
            }
            RecordError::WrongType {
                topic,
                channel,
                requested,
            } => write!(f, "topic {topic:?} carries {channel}, not {requested}"),
            RecordError::StampOutOfRange { topic, stamp_ns } => write!(
                f,
                "stamp {stamp_ns} ns on topic {topic:?}: seconds do not fit an int32"
            ),
            RecordError::TooLong { topic, field, len } => write!(
                f,
                "{field} on topic {topic:?} has {len} elements/bytes, more than a CDR length holds"
            ),
            RecordError::UnknownCompression(s) => {
                write!(f, "unknown compression {s:?} (expected none, zstd or lz4)")
            }
        }
    }
}

impl RecordError {
    /// The operating system's error behind a failed write, if that is what it was.
    pub fn io_error(&self) -> Option<&std::io::Error> {
        match self {
            RecordError::Mcap(McapError::Io(e)) => Some(e),
            _ => None,
        }
    }
}

impl std::error::Error for RecordError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            RecordError::Mcap(e) => Some(e),
            _ => None,
        }
    }
}

impl From<McapError> for RecordError {
    fn from(e: McapError) -> Self {
        RecordError::Mcap(e)
    }
}

impl From<std::io::Error> for RecordError {
    fn from(e: std::io::Error) -> Self {
        RecordError::Mcap(McapError::Io(e))
    }
}

/// Name of the MCAP Metadata record that marks one run of a recording (a thermrs extension of
/// SPEC §2; recordings of other writers do not carry it). Its keys: `name` (the run's name),
/// `start_ns` and `end_ns` (header stamps, decimal nanoseconds since the epoch, inclusive).
pub const RUN_METADATA: &str = "thermrs.run";

/// One channel: its MCAP id, type and next sequence number.
#[derive(Debug, Clone, Copy)]
struct ChannelInfo {
    id: u16,
    ty: MsgType,
    sequence: u32,
}

/// Streaming writer of a ROS 2 MCAP recording (profile `ros2`, schema
/// encoding `ros2msg`, message encoding `cdr`).
///
/// Add each topic with [`add_channel`](Self::add_channel), then write
/// messages in any order (MCAP readers order by log time); each is encoded
/// into one reused buffer and handed to the `mcap` writer, which streams
/// chunks to `W` (seeking back only to patch each chunk's header). Call
/// [`finish`](Self::finish) at the end: dropping the writer without it also
/// finishes the file, but ignores errors.
///
/// Each message's MCAP `log_time` and `publish_time` are the `log_time_ns`
/// given (the simulator passes header stamp + transport delay); its
/// `sequence` counts messages per channel from 0.
pub struct RecordingWriter<W: Write + Seek> {
    writer: Writer<W>,
    schemas: BTreeMap<MsgType, u16>,
    channels: HashMap<String, ChannelInfo>,
    buf: Vec<u8>,
}

impl<W: Write + Seek> fmt::Debug for RecordingWriter<W> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("RecordingWriter")
            .field("schemas", &self.schemas)
            .field("channels", &self.channels)
            .finish_non_exhaustive()
    }
}

/// Checks a header stamp; the error names the topic.
fn check_stamp(topic: &str, stamp_ns: i64) -> Result<(), RecordError> {
    match split_stamp(stamp_ns) {
        Some(_) => Ok(()),
        None => Err(RecordError::StampOutOfRange {
            topic: topic.to_owned(),
            stamp_ns,
        }),
    }
}

/// Checks that a string (`len` bytes + NUL) or sequence fits a CDR `uint32`.
fn check_len(topic: &str, field: &'static str, len: usize, nul: bool) -> Result<(), RecordError> {
    let n = len as u64 + u64::from(nul);
    if n > u64::from(u32::MAX) {
        return Err(RecordError::TooLong {
            topic: topic.to_owned(),
            field,
            len,
        });
    }
    Ok(())
}

fn check_image(topic: &str, img: &ImageFields<'_>, data_len: usize) -> Result<(), RecordError> {
    check_stamp(topic, img.stamp_ns)?;
    check_len(topic, "Image.header.frame_id", img.frame_id.len(), true)?;
    check_len(topic, "Image.encoding", img.encoding.len(), true)?;
    check_len(topic, "Image.data", data_len, false)
}

impl<W: Write + Seek> RecordingWriter<W> {
    /// Starts a recording on `w` (writes the magic and header at once).
    pub fn new(w: W, options: &RecordOptions) -> Result<Self, RecordError> {
        Ok(RecordingWriter {
            writer: options.to_mcap().create(w)?,
            schemas: BTreeMap::new(),
            channels: HashMap::new(),
            buf: Vec::new(),
        })
    }

    /// Adds a channel for `topic` carrying `ty` (registering `ty`'s schema on
    /// first use) and returns its MCAP channel id. Adding the same topic again
    /// with the same type returns the same id; with another type it is a
    /// [`RecordError::WrongType`].
    pub fn add_channel(&mut self, topic: &str, ty: MsgType) -> Result<u16, RecordError> {
        if let Some(c) = self.channels.get(topic) {
            return if c.ty == ty {
                Ok(c.id)
            } else {
                Err(RecordError::WrongType {
                    topic: topic.to_owned(),
                    channel: c.ty,
                    requested: ty,
                })
            };
        }
        let schema_id = match self.schemas.get(&ty) {
            Some(&id) => id,
            None => {
                let id = self.writer.add_schema(
                    ty.schema_name(),
                    SCHEMA_ENCODING,
                    ty.schema_text().as_bytes(),
                )?;
                self.schemas.insert(ty, id);
                id
            }
        };
        let id = self
            .writer
            .add_channel(schema_id, topic, MESSAGE_ENCODING, &BTreeMap::new())?;
        self.channels.insert(
            topic.to_owned(),
            ChannelInfo {
                id,
                ty,
                sequence: 0,
            },
        );
        Ok(id)
    }

    /// The channel of `topic`, checked to carry `ty`.
    fn channel(&mut self, topic: &str, ty: MsgType) -> Result<&mut ChannelInfo, RecordError> {
        let c = self
            .channels
            .get_mut(topic)
            .ok_or_else(|| RecordError::UnknownTopic(topic.to_owned()))?;
        if c.ty != ty {
            return Err(RecordError::WrongType {
                topic: topic.to_owned(),
                channel: c.ty,
                requested: ty,
            });
        }
        Ok(c)
    }

    /// Writes the message encoded in `self.buf` to the channel of `topic`.
    fn emit(&mut self, topic: &str, ty: MsgType, log_time_ns: u64) -> Result<(), RecordError> {
        let c = self.channel(topic, ty)?;
        let header = MessageHeader {
            channel_id: c.id,
            sequence: c.sequence,
            log_time: log_time_ns,
            publish_time: log_time_ns,
        };
        c.sequence = c.sequence.wrapping_add(1);
        self.writer.write_to_known_channel(&header, &self.buf)?;
        Ok(())
    }

    /// Writes a `sensor_msgs/msg/Image` with `data` to `topic`.
    pub fn write_image(
        &mut self,
        topic: &str,
        log_time_ns: u64,
        img: &ImageFields<'_>,
        data: &[u8],
    ) -> Result<(), RecordError> {
        self.channel(topic, MsgType::Image)?;
        check_image(topic, img, data.len())?;
        encode_image(&mut self.buf, img, data);
        self.emit(topic, MsgType::Image, log_time_ns)
    }

    /// Writes a `sensor_msgs/msg/Image` of `data_len` pixel bytes that `fill`
    /// renders in place (into a zeroed slice of the reused message buffer):
    /// no intermediate image buffer, no allocation once warm.
    pub fn write_image_with<F: FnOnce(&mut [u8])>(
        &mut self,
        topic: &str,
        log_time_ns: u64,
        img: &ImageFields<'_>,
        data_len: usize,
        fill: F,
    ) -> Result<(), RecordError> {
        self.channel(topic, MsgType::Image)?;
        check_image(topic, img, data_len)?;
        encode_image_with(&mut self.buf, img, data_len, fill);
        self.emit(topic, MsgType::Image, log_time_ns)
    }

    /// Writes a `sensor_msgs/msg/CompressedImage` to `topic`.
    pub fn write_compressed_image(
        &mut self,
        topic: &str,
        log_time_ns: u64,
        stamp_ns: i64,
        frame_id: &str,
        format: &str,
        data: &[u8],
    ) -> Result<(), RecordError> {
        const T: MsgType = MsgType::CompressedImage;
        self.channel(topic, T)?;
        check_stamp(topic, stamp_ns)?;
        check_len(
            topic,
            "CompressedImage.header.frame_id",
            frame_id.len(),
            true,
        )?;
        check_len(topic, "CompressedImage.format", format.len(), true)?;
        check_len(topic, "CompressedImage.data", data.len(), false)?;
        encode_compressed_image(&mut self.buf, stamp_ns, frame_id, format, data);
        self.emit(topic, T, log_time_ns)
    }

    /// Writes a `sensor_msgs/msg/JointState` (names, positions in radians;
    /// empty velocity and effort) to `topic`.
    pub fn write_joint_state<S: AsRef<str>>(
        &mut self,
        topic: &str,
        log_time_ns: u64,
        stamp_ns: i64,
        frame_id: &str,
        names: &[S],
        positions: &[f64],
    ) -> Result<(), RecordError> {
        const T: MsgType = MsgType::JointState;
        self.channel(topic, T)?;
        check_stamp(topic, stamp_ns)?;
        check_len(topic, "JointState.header.frame_id", frame_id.len(), true)?;
        check_len(topic, "JointState.name", names.len(), false)?;
        for n in names {
            check_len(topic, "JointState.name", n.as_ref().len(), true)?;
        }
        check_len(topic, "JointState.position", positions.len(), false)?;
        encode_joint_state(&mut self.buf, stamp_ns, frame_id, names, positions);
        self.emit(topic, T, log_time_ns)
    }

    /// Writes a `sensor_msgs/msg/Temperature` (°C; `variance` 0 = unknown)
    /// to `topic`.
    pub fn write_temperature(
        &mut self,
        topic: &str,
        log_time_ns: u64,
        stamp_ns: i64,
        frame_id: &str,
        temperature: f64,
        variance: f64,
    ) -> Result<(), RecordError> {
        const T: MsgType = MsgType::Temperature;
        self.channel(topic, T)?;
        check_stamp(topic, stamp_ns)?;
        check_len(topic, "Temperature.header.frame_id", frame_id.len(), true)?;
        encode_temperature(&mut self.buf, stamp_ns, frame_id, temperature, variance);
        self.emit(topic, T, log_time_ns)
    }

    /// Writes a run marker: an MCAP Metadata record named [`RUN_METADATA`] with the run's
    /// `name` and its first and last header stamps (`start_ns` ≤ `end_ns`).
    pub fn write_run_marker(
        &mut self,
        name: &str,
        start_ns: i64,
        end_ns: i64,
    ) -> Result<(), RecordError> {
        check_stamp(RUN_METADATA, start_ns)?;
        check_stamp(RUN_METADATA, end_ns)?;
        check_len(RUN_METADATA, "name", name.len(), false)?;
        let metadata = BTreeMap::from([
            ("name".to_owned(), name.to_owned()),
            ("start_ns".to_owned(), start_ns.to_string()),
            ("end_ns".to_owned(), end_ns.max(start_ns).to_string()),
        ]);
        self.writer.write_metadata(&Metadata {
            name: RUN_METADATA.to_owned(),
            metadata,
        })?;
        Ok(())
    }

    /// Closes the current chunk, writes the data-end record, the summary (if
    /// enabled) and the footer, flushes `W` and returns it.
    pub fn finish(mut self) -> Result<W, RecordError> {
        self.writer.finish()?;
        let mut w = self.writer.into_inner();
        w.flush()?;
        Ok(w)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cdr::{
        parse_compressed_image, parse_image, parse_joint_state, parse_temperature, ImageMsg,
    };
    use std::io::Cursor;

    fn hex(s: &str) -> Vec<u8> {
        assert_eq!(s.len() % 2, 0);
        (0..s.len())
            .step_by(2)
            .map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap())
            .collect()
    }

    fn bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    /// The frame_id of any of the four types (it is always at byte 12).
    fn frame_id_of(buf: &[u8]) -> &str {
        let n = u32::from_le_bytes(buf[12..16].try_into().unwrap()) as usize;
        std::str::from_utf8(&buf[16..16 + n - 1]).unwrap()
    }

    // ---- reference cases, shared with the Python script ----

    /// One reference message (inputs to an encoder).
    enum Case {
        Image(ImageFields<'static>, Vec<u8>),
        Compressed(i64, &'static str, &'static str, Vec<u8>),
        Joint(
            i64,
            &'static str,
            Vec<&'static str>,
            Vec<f64>,
            Vec<f64>,
            Vec<f64>,
        ),
        Temp(i64, &'static str, f64, f64),
    }

    fn img(
        stamp_ns: i64,
        frame_id: &'static str,
        width: u32,
        height: u32,
        encoding: &'static str,
        is_bigendian: bool,
        step: u32,
    ) -> ImageFields<'static> {
        ImageFields {
            stamp_ns,
            frame_id,
            width,
            height,
            encoding,
            is_bigendian,
            step,
        }
    }

    /// The cases of `make_reference.py` (mcap-ros2-support 0.6.0,
    /// `mcap_ros2._dynamic.serialize_dynamic` on the schema texts of this
    /// module), with the bytes it produced.
    fn reference_cases() -> Vec<(&'static str, Case, &'static str)> {
        let f32s: Vec<u8> = [21.5f32, -3.25]
            .iter()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        vec![
            (
                "image_mono8",
                Case::Image(
                    img(1_700_000_000_123_456_789, "ccd_a", 3, 2, "mono8", false, 3),
                    vec![0, 1, 2, 253, 254, 255],
                ),
                "0001000000f1536515cd5b07060000006363645f610000000200000003000000060000006d6f6e6f380000000300000006000000000102fdfeff",
            ),
            (
                "image_mono16_be_padded",
                Case::Image(
                    img(1_700_000_001_999_999_999, "cam", 3, 2, "mono16", true, 8),
                    (0..16).collect(),
                ),
                "0001000001f15365ffc99a3b0400000063616d000200000003000000070000006d6f6e6f313600010800000010000000000102030405060708090a0b0c0d0e0f",
            ),
            (
                "image_empty_negative",
                Case::Image(img(-1_500_000_000, "", 0, 0, "8UC1", false, 0), vec![]),
                "00010000feffffff0065cd1d010000000000000000000000000000000500000038554331000000000000000000000000",
            ),
            (
                "image_32fc1",
                Case::Image(img(0, "thermal_cam", 2, 1, "32FC1", false, 8), f32s),
                "0001000000000000000000000c000000746865726d616c5f63616d00010000000200000006000000333246433100000008000000080000000000ac41000050c0",
            ),
            (
                "compressed_png",
                Case::Compressed(
                    1_700_000_002_000_000_005,
                    "ccd_b1",
                    "png",
                    vec![137, 80, 78, 71, 13, 10, 26, 10, 0, 255, 127],
                ),
                "0001000002f1536505000000070000006363645f6231000004000000706e67000b00000089504e470d0a1a0a00ff7f",
            ),
            (
                "compressed_empty_negative",
                Case::Compressed(-1, "x", "jpeg", vec![]),
                "00010000ffffffffffc99a3b0200000078000000050000006a7065670000000000000000",
            ),
            (
                "joint_six",
                Case::Joint(
                    1_700_000_003_250_000_000,
                    "robot",
                    vec!["joint_1", "j2", "shoulder_pan", "a", "elbow", "wrist_3x"],
                    vec![
                        0.0,
                        -std::f64::consts::FRAC_PI_2,
                        std::f64::consts::PI,
                        1e-9,
                        -0.0,
                        2.5,
                    ],
                    vec![],
                    vec![],
                ),
                "0001000003f1536580b2e60e06000000726f626f7400000006000000080000006a6f696e745f3100030000006a3200000d00000073686f756c6465725f70616e00000000020000006100000006000000656c626f770000000900000077726973745f337800000000060000000000000000000000182d4454fb21f9bf182d4454fb21094095d626e80b2e113e000000000000008000000000000004400000000000000000",
            ),
            (
                "joint_empty_negative",
                Case::Joint(-999_999_999_999, "", vec![], vec![], vec![], vec![]),
                "0001000018fcffff01000000010000000000000000000000000000000000000000000000",
            ),
            (
                "joint_odd",
                Case::Joint(7, "abc", vec!["x"], vec![0.25], vec![], vec![]),
                "000100000000000007000000040000006162630001000000020000007800000001000000000000000000d03f0000000000000000",
            ),
            (
                "joint_full",
                Case::Joint(
                    -1_999_999_999,
                    "base_link",
                    vec!["a", "bc"],
                    vec![1.0, -2.0],
                    vec![0.5, 1e300],
                    vec![-0.001, 7.0],
                ),
                "00010000feffffff010000000a000000626173655f6c696e6b000000020000000200000061000000030000006263000002000000000000000000f03f00000000000000c00200000000000000000000000000e03f9c7500883ce4377e0200000000000000fca9f1d24d6250bf0000000000001c40",
            ),
            (
                "temperature",
                Case::Temp(1_700_000_004_000_000_042, "ambient", 21.375, 0.0025),
                "0001000004f153652a00000008000000616d6269656e74000000000000000000006035407b14ae47e17a643f",
            ),
            (
                "temperature_negative",
                Case::Temp(-1, "t", -40.5, 0.0),
                "00010000ffffffffffc99a3b020000007400000000000000004044c00000000000000000",
            ),
            (
                "temperature_empty_frame",
                Case::Temp(5, "", 0.1, 1e-6),
                "00010000000000000500000001000000000000009a9999999999b93f8dedb5a0f7c6b03e",
            ),
        ]
    }

    /// Encodes a case with this module's encoders.
    fn encode_case(case: &Case, out: &mut Vec<u8>) {
        match case {
            Case::Image(m, data) => encode_image(out, m, data),
            Case::Compressed(t, frame, format, data) => {
                encode_compressed_image(out, *t, frame, format, data)
            }
            Case::Joint(t, frame, names, p, v, e) => {
                if v.is_empty() && e.is_empty() {
                    encode_joint_state(out, *t, frame, names, p)
                } else {
                    encode_joint_state_full(out, *t, frame, names, p, v, e)
                }
            }
            Case::Temp(t, frame, temp, var) => encode_temperature(out, *t, frame, *temp, *var),
        }
    }

    /// Decodes `buf` with `crate::cdr` and checks every field against `case`.
    fn check_decodes(case: &Case, buf: &[u8]) {
        match case {
            Case::Image(m, data) => {
                let d = parse_image(buf).unwrap();
                assert_eq!(
                    d,
                    ImageMsg {
                        stamp_ns: m.stamp_ns,
                        frame_id: m.frame_id,
                        height: m.height,
                        width: m.width,
                        encoding: m.encoding,
                        is_bigendian: m.is_bigendian,
                        step: m.step,
                        data,
                    }
                );
            }
            Case::Compressed(t, frame, format, data) => {
                let d = parse_compressed_image(buf).unwrap();
                assert_eq!(
                    (d.stamp_ns, d.frame_id, d.format, d.data),
                    (*t, *frame, *format, &data[..])
                );
            }
            Case::Joint(t, frame, names, p, v, e) => {
                let d = parse_joint_state(buf).unwrap();
                assert_eq!((d.stamp_ns, d.frame_id), (*t, *frame));
                assert_eq!(&d.names, names);
                assert_eq!(bits(&d.position), bits(p));
                assert_eq!(bits(&d.velocity), bits(v));
                assert_eq!(bits(&d.effort), bits(e));
            }
            Case::Temp(t, frame, temp, var) => {
                let d = parse_temperature(buf).unwrap();
                assert_eq!(d.stamp_ns, *t);
                assert_eq!(d.temperature.to_bits(), temp.to_bits());
                assert_eq!(d.variance.to_bits(), var.to_bits());
                assert_eq!(frame_id_of(buf), *frame);
            }
        }
    }

    #[test]
    fn encoders_match_python_reference_bytes() {
        let mut out = Vec::new();
        for (name, case, want) in reference_cases() {
            encode_case(&case, &mut out);
            assert_eq!(out, hex(want), "{name}");
        }
    }

    /// Compares with the JSON that `make_reference.py` writes, when present
    /// (so the literals above can be checked against a fresh Python run).
    #[test]
    fn encoders_match_python_reference_file() {
        let path = "/tmp/dev-record/cdr_reference.json";
        let Ok(text) = std::fs::read_to_string(path) else {
            eprintln!("skipped: {path} absent");
            return;
        };
        // A flat {"name": "hex", ...} object: the quoted strings alternate.
        let quoted: Vec<&str> = text.split('"').skip(1).step_by(2).collect();
        let file: HashMap<&str, &str> = quoted.chunks_exact(2).map(|p| (p[0], p[1])).collect();
        let cases = reference_cases();
        assert_eq!(file.len(), cases.len());
        let mut out = Vec::new();
        for (name, case, _) in cases {
            encode_case(&case, &mut out);
            assert_eq!(out, hex(file[name]), "{name}");
        }
    }

    #[test]
    fn encoders_round_trip_through_cdr_reader() {
        let mut out = Vec::new();
        for (_, case, _) in reference_cases() {
            encode_case(&case, &mut out);
            check_decodes(&case, &out);
        }
        // Odd string lengths 0..9 in every string position, odd data sizes.
        for n in 0..9usize {
            let s: &'static str = &"abcdefghi"[..n];
            let data: Vec<u8> = (0..n as u8 * 3).collect();
            let stamp = -(n as i64) * 333_333_333 - 1;
            let cases = [
                Case::Image(img(stamp, s, 1, 2, s, n % 2 == 1, 7), data.clone()),
                Case::Compressed(stamp, s, s, data.clone()),
                Case::Joint(
                    stamp,
                    s,
                    vec![s; n],
                    (0..n).map(|i| i as f64 * -0.1).collect(),
                    vec![],
                    vec![],
                ),
                Case::Joint(
                    stamp,
                    s,
                    vec![s, "q"],
                    vec![1.0, 2.0],
                    vec![3.0; n],
                    vec![-4.0; n % 3],
                ),
                Case::Temp(stamp, s, n as f64 - 0.5, f64::NAN),
            ];
            for case in &cases {
                encode_case(case, &mut out);
                check_decodes(case, &out); // floats compare by bits: NaN too
            }
        }
    }

    #[test]
    fn stamps_split_like_ros() {
        assert_eq!(split_stamp(0), Some((0, 0)));
        assert_eq!(split_stamp(-1), Some((-1, 999_999_999)));
        assert_eq!(split_stamp(-1_000_000_000), Some((-1, 0)));
        assert_eq!(split_stamp(-1_000_000_001), Some((-2, 999_999_999)));
        assert_eq!(split_stamp(1_999_999_999), Some((1, 999_999_999)));
        let max = i64::from(i32::MAX) * NS_PER_SEC + 999_999_999;
        assert_eq!(split_stamp(max), Some((i32::MAX, 999_999_999)));
        assert_eq!(split_stamp(max + 1), None);
        let min = i64::from(i32::MIN) * NS_PER_SEC;
        assert_eq!(split_stamp(min), Some((i32::MIN, 0)));
        assert_eq!(split_stamp(min - 1), None);
        let mut out = Vec::new();
        for t in [min, max, -1, 0, 1] {
            encode_temperature(&mut out, t, "f", 1.0, 0.0);
            assert_eq!(parse_temperature(&out).unwrap().stamp_ns, t);
        }
    }

    #[test]
    fn image_in_place_variants_agree() {
        let m = img(
            1_700_000_000_000_000_001,
            "ccd_a",
            5,
            3,
            "mono16",
            false,
            11,
        );
        let data: Vec<u8> = (0..33).map(|i| (i * 7) as u8).collect();
        let mut a = Vec::new();
        encode_image(&mut a, &m, &data);
        let mut b = vec![0xaa; 7]; // stale content is cleared
        encode_image_with(&mut b, &m, data.len(), |px| px.copy_from_slice(&data));
        let mut c = Vec::new();
        encode_image_header(&mut c, &m, data.len() as u32);
        c.extend_from_slice(&data);
        assert_eq!(a, b);
        assert_eq!(a, c);
        check_decodes(&Case::Image(m, data), &a);
        // Once warm, encoding a same-sized frame does not reallocate.
        let cap = b.capacity();
        let ptr = b.as_ptr();
        encode_image_with(&mut b, &m, 33, |px| px.fill(1));
        assert_eq!((b.capacity(), b.as_ptr()), (cap, ptr));
    }

    #[test]
    fn schema_texts() {
        for ty in MsgType::ALL {
            let text = ty.schema_text();
            assert!(text.starts_with("std_msgs/Header header\n"), "{ty}");
            let sep = format!("\n{}\n", "=".repeat(80));
            let parts: Vec<&str> = text.split(&sep).collect();
            assert_eq!(parts.len(), 3, "{ty}");
            assert_eq!(
                parts[1],
                "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id"
            );
            assert_eq!(
                parts[2],
                "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n"
            );
        }
        assert_eq!(
            IMAGE_SCHEMA.lines().take(7).collect::<Vec<_>>(),
            [
                "std_msgs/Header header",
                "uint32 height",
                "uint32 width",
                "string encoding",
                "uint8 is_bigendian",
                "uint32 step",
                "uint8[] data"
            ]
        );
        assert_eq!(
            MsgType::JointState.to_string(),
            "sensor_msgs/msg/JointState"
        );
    }

    // ---- recordings ----

    const JOINTS: [&str; 3] = ["joint_1", "joint_2", "joint_3"];

    /// A frame of `w * h` 16-bit pixels whose values depend on `k`.
    fn frame16(k: u64, w: usize, h: usize) -> Vec<u8> {
        (0..w * h)
            .flat_map(|i| ((i as u64 * 31 + k * 1009) as u16 & 0x0fff).to_le_bytes())
            .collect()
    }

    /// The expected messages: (topic, log time, payload) in write order.
    type Expected = Vec<(String, u64, Vec<u8>)>;

    /// Writes a small recording with every message type; returns the file
    /// and what each message should be.
    fn write_sample(options: &RecordOptions) -> (Vec<u8>, Expected) {
        let mut w = RecordingWriter::new(Cursor::new(Vec::new()), options).unwrap();
        assert_eq!(w.add_channel("/ccd_a/image", MsgType::Image).unwrap(), 1);
        assert_eq!(w.add_channel("/thermal/image", MsgType::Image).unwrap(), 2);
        assert_eq!(w.add_channel("/joints", MsgType::JointState).unwrap(), 3);
        assert_eq!(w.add_channel("/ambient", MsgType::Temperature).unwrap(), 4);
        assert_eq!(
            w.add_channel("/ccd_a/png", MsgType::CompressedImage)
                .unwrap(),
            5
        );
        assert_eq!(w.add_channel("/joints", MsgType::JointState).unwrap(), 3);
        let mut expected = Vec::new();
        let mut buf = Vec::new();
        let t0: i64 = 1_700_000_000_000_000_000;
        for k in 0..12u64 {
            let stamp = t0 + k as i64 * 100_000_000;
            let log = stamp as u64 + 2_000_000;
            // CCD: odd width, padded step, written in place.
            let (cw, ch) = (75, 58);
            let m = img(stamp, "ccd_a", cw, ch, "mono8", false, 76);
            w.write_image_with("/ccd_a/image", log, &m, 76 * 58, |px| {
                for (i, p) in px.iter_mut().enumerate() {
                    *p = (i as u64 + k) as u8;
                }
            })
            .unwrap();
            encode_image_with(&mut buf, &m, 76 * 58, |px| {
                for (i, p) in px.iter_mut().enumerate() {
                    *p = (i as u64 + k) as u8;
                }
            });
            expected.push(("/ccd_a/image".to_owned(), log, buf.clone()));
            // Thermal: 16UC1 from a slice.
            let data = frame16(k, 32, 24);
            let m = img(stamp + 1, "thermal", 32, 24, "16UC1", false, 64);
            w.write_image("/thermal/image", log + 1, &m, &data).unwrap();
            encode_image(&mut buf, &m, &data);
            expected.push(("/thermal/image".to_owned(), log + 1, buf.clone()));
            // Joints.
            let pos: Vec<f64> = (0..3).map(|j| (k as f64 * 0.1 + j as f64).sin()).collect();
            w.write_joint_state("/joints", log, stamp, "base", &JOINTS, &pos)
                .unwrap();
            encode_joint_state(&mut buf, stamp, "base", &JOINTS, &pos);
            expected.push(("/joints".to_owned(), log, buf.clone()));
            // Ambient, every third frame; a compressed frame every fourth.
            if k % 3 == 0 {
                let t = 21.0 + k as f64 * 0.125;
                w.write_temperature("/ambient", log, stamp, "room", t, 0.01)
                    .unwrap();
                encode_temperature(&mut buf, stamp, "room", t, 0.01);
                expected.push(("/ambient".to_owned(), log, buf.clone()));
            }
            if k % 4 == 1 {
                let png = [137u8, 80, 78, 71, 13, 10, 26, 10, k as u8];
                w.write_compressed_image("/ccd_a/png", log, stamp, "ccd_a", "png", &png)
                    .unwrap();
                encode_compressed_image(&mut buf, stamp, "ccd_a", "png", &png);
                expected.push(("/ccd_a/png".to_owned(), log, buf.clone()));
            }
        }
        (w.finish().unwrap().into_inner(), expected)
    }

    fn all_layouts() -> Vec<RecordOptions> {
        let mut v = Vec::new();
        for compression in [
            RecordCompression::None,
            RecordCompression::Zstd,
            RecordCompression::Lz4,
        ] {
            for summary in [true, false] {
                v.push(RecordOptions {
                    compression,
                    chunk_size: 16 * 1024,
                    summary,
                    ..RecordOptions::default()
                });
            }
        }
        v.push(RecordOptions {
            use_chunks: false,
            ..RecordOptions::default()
        });
        v.push(RecordOptions {
            use_chunks: false,
            summary: false,
            ..RecordOptions::default()
        });
        v
    }

    /// Reads `file` back with `mcap::MessageStream` and checks every message,
    /// its channel and schema.
    fn check_read_back(file: &[u8], expected: &Expected, options: &RecordOptions) {
        let msgs: Vec<mcap::Message> = mcap::MessageStream::new(file)
            .unwrap()
            .collect::<Result<_, _>>()
            .unwrap();
        assert_eq!(msgs.len(), expected.len());
        let mut seq: HashMap<&str, u32> = HashMap::new();
        for (m, (topic, log, payload)) in msgs.iter().zip(expected) {
            assert_eq!(&m.channel.topic, topic);
            assert_eq!(m.channel.message_encoding, "cdr");
            let schema = m.channel.schema.as_ref().unwrap();
            assert_eq!(schema.encoding, "ros2msg");
            let ty = MsgType::ALL
                .into_iter()
                .find(|t| t.schema_name() == schema.name)
                .unwrap();
            assert_eq!(&schema.data[..], ty.schema_text().as_bytes());
            assert_eq!((m.log_time, m.publish_time), (*log, *log));
            let s = seq.entry(topic).or_insert(0);
            assert_eq!(m.sequence, *s);
            *s += 1;
            assert_eq!(&m.data[..], &payload[..]);
            // And the payload decodes as its schema says.
            match ty {
                MsgType::Image => {
                    let d = parse_image(&m.data).unwrap();
                    assert_eq!(d.data.len(), (d.step * d.height) as usize);
                    assert_eq!(d.stamp_ns + 2_000_000, *log as i64);
                }
                MsgType::CompressedImage => {
                    assert_eq!(parse_compressed_image(&m.data).unwrap().format, "png");
                }
                MsgType::JointState => {
                    assert_eq!(parse_joint_state(&m.data).unwrap().names, JOINTS);
                }
                MsgType::Temperature => {
                    assert_eq!(parse_temperature(&m.data).unwrap().variance, 0.01);
                }
            }
        }
        // The header and the summary.
        assert_eq!(&file[..8], mcap::MAGIC);
        let summary = mcap::Summary::read(file).unwrap();
        if options.summary {
            let s = summary.expect("summary");
            let st = s.stats.unwrap();
            assert_eq!(st.message_count, expected.len() as u64);
            assert_eq!((st.schema_count, st.channel_count), (4, 5));
            assert_eq!(s.chunk_indexes.is_empty(), !options.use_chunks);
            if options.use_chunks {
                assert!(s.chunk_indexes.len() > 1, "{}", s.chunk_indexes.len());
                let want = match options.compression {
                    RecordCompression::None => "",
                    c => c.as_str(),
                };
                assert!(s.chunk_indexes.iter().all(|c| c.compression == want));
            }
        } else {
            assert!(summary.is_none());
        }
    }

    #[test]
    fn write_read_round_trip_every_layout() {
        for options in all_layouts() {
            let (file, expected) = write_sample(&options);
            check_read_back(&file, &expected, &options);
        }
    }

    #[test]
    fn deterministic_bytes() {
        for options in all_layouts() {
            let (a, _) = write_sample(&options);
            let (b, _) = write_sample(&options);
            assert!(a == b, "{options:?}");
        }
        // And through a real file.
        let dir = std::env::temp_dir();
        let files: Vec<Vec<u8>> = (0..2)
            .map(|i| {
                let path = dir.join(format!(
                    "thermrs-record-det-{}-{i}.mcap",
                    std::process::id()
                ));
                let f = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
                let mut w = RecordingWriter::new(f, &RecordOptions::default()).unwrap();
                w.add_channel("/t", MsgType::Temperature).unwrap();
                for k in 0..100 {
                    w.write_temperature("/t", 10 + k, k as i64, "room", 20.0, 0.0)
                        .unwrap();
                }
                drop(w.finish().unwrap());
                let bytes = std::fs::read(&path).unwrap();
                std::fs::remove_file(&path).unwrap();
                bytes
            })
            .collect();
        assert_eq!(files[0], files[1]);
    }

    /// Writes `thermrs-record-python-check.mcap` to the temp directory for
    /// the manual Python-reader check (`check_python_reader.py`).
    #[test]
    fn file_for_python_reader() {
        let (file, expected) = write_sample(&RecordOptions {
            chunk_size: 16 * 1024,
            ..RecordOptions::default()
        });
        assert_eq!(expected.len(), 12 * 3 + 4 + 3);
        let path = std::env::temp_dir().join("thermrs-record-python-check.mcap");
        std::fs::write(path, file).unwrap();
    }

    #[test]
    fn errors() {
        let mut w =
            RecordingWriter::new(Cursor::new(Vec::new()), &RecordOptions::default()).unwrap();
        w.add_channel("/t", MsgType::Temperature).unwrap();
        let e = w
            .write_joint_state("/nope", 0, 0, "", &JOINTS, &[0.0; 3])
            .unwrap_err();
        assert!(
            matches!(e, RecordError::UnknownTopic(ref t) if t == "/nope"),
            "{e}"
        );
        let e = w.add_channel("/t", MsgType::Image).unwrap_err();
        assert_eq!(
            e.to_string(),
            "topic \"/t\" carries sensor_msgs/msg/Temperature, not sensor_msgs/msg/Image"
        );
        let m = img(0, "", 1, 1, "mono8", false, 1);
        assert!(matches!(
            w.write_image("/t", 0, &m, &[0]),
            Err(RecordError::WrongType { .. })
        ));
        let e = w
            .write_temperature("/t", 0, i64::MAX, "", 0.0, 0.0)
            .unwrap_err();
        assert!(
            matches!(e, RecordError::StampOutOfRange { stamp_ns, .. } if stamp_ns == i64::MAX),
            "{e}"
        );
        // Nothing bad was written: the file holds no message.
        let file = w.finish().unwrap().into_inner();
        assert_eq!(mcap::MessageStream::new(&file).unwrap().count(), 0);
        assert_eq!(
            "lz4".parse::<RecordCompression>().unwrap(),
            RecordCompression::Lz4
        );
        assert!("gzip".parse::<RecordCompression>().is_err());
        assert_eq!(RecordCompression::Zstd.to_string(), "zstd");
    }

    #[test]
    fn run_marker_is_a_metadata_record_other_readers_see() {
        let mut w =
            RecordingWriter::new(Cursor::new(Vec::new()), &RecordOptions::default()).unwrap();
        w.write_run_marker("run2", 1_750_000_000_000_000_000, 1_750_000_060_000_000_000)
            .unwrap();
        assert!(matches!(
            w.write_run_marker("bad", i64::MAX, i64::MAX),
            Err(RecordError::StampOutOfRange { .. })
        ));
        let file = w.finish().unwrap().into_inner();
        // Read back with the mcap crate's own linear reader, record by record.
        let found: Vec<_> = mcap::read::LinearReader::new(&file)
            .unwrap()
            .filter_map(|r| match r {
                Ok(mcap::records::Record::Metadata(m)) => Some(m),
                _ => None,
            })
            .collect();
        assert_eq!(found.len(), 1);
        assert_eq!(found[0].name, RUN_METADATA);
        let v = &found[0].metadata;
        assert_eq!(v["name"], "run2");
        assert_eq!(v["start_ns"], "1750000000000000000");
        assert_eq!(v["end_ns"], "1750000060000000000");
    }
}
