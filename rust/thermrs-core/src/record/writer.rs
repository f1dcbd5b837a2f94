//! [`RecordingWriter`]: a thin wrapper of [`mcap::Writer`] with one schema per message type
//! and one channel per topic; its options and errors.

use std::collections::{BTreeMap, HashMap};
use std::fmt;
use std::io::{Seek, Write};

use mcap::records::{MessageHeader, Metadata};
use mcap::{Compression, McapError, WriteOptions, Writer};

use super::encode::*;
use crate::msg::{split_stamp, ImageFields, MsgType, MESSAGE_ENCODING, PROFILE, SCHEMA_ENCODING};

/// Chunk compression.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RecordCompression {
    None,
    #[default]
    Zstd,
    Lz4,
}

impl RecordCompression {
    /// Every compression, in the order they are named.
    pub const ALL: [RecordCompression; 3] = [
        RecordCompression::None,
        RecordCompression::Zstd,
        RecordCompression::Lz4,
    ];

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
    /// `name`, its first and last header stamps (`start_ns` ≤ `end_ns`) and, when given, the
    /// speed override it ran at (`speed_pct`, % of the robot's maximum joint rates).
    pub fn write_run_marker(
        &mut self,
        name: &str,
        start_ns: i64,
        end_ns: i64,
        speed_pct: Option<f64>,
    ) -> Result<(), RecordError> {
        check_stamp(RUN_METADATA, start_ns)?;
        check_stamp(RUN_METADATA, end_ns)?;
        check_len(RUN_METADATA, "name", name.len(), false)?;
        let mut metadata = BTreeMap::from([
            ("name".to_owned(), name.to_owned()),
            ("start_ns".to_owned(), start_ns.to_string()),
            ("end_ns".to_owned(), end_ns.max(start_ns).to_string()),
        ]);
        if let Some(v) = speed_pct.filter(|v| v.is_finite()) {
            metadata.insert("speed_pct".to_owned(), v.to_string());
        }
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
