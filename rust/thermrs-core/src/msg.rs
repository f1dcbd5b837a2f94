//! The four ROS 2 message types thermrs records and reads, in one place for the decoder
//! ([`crate::cdr`]) and the encoder ([`crate::record`]): their names and `ros2msg` schema
//! texts ([`MsgType`]), the CDR constants both sides count from, the stamp split and join,
//! the decoded messages (borrowing from the payload) and the image metadata the encoder
//! takes.

use std::fmt;

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

/// Offset of the first CDR body byte (after the 4-byte encapsulation header): alignment is
/// counted from here.
pub const ORIGIN: usize = 4;
/// The encapsulation header the encoder writes: CDR_LE (id 0x0001), options 0.
pub const ENCAPSULATION_CDR_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];
/// Nanoseconds per second.
pub const NS_PER_SEC: i64 = 1_000_000_000;

/// Splits a stamp in ns since the epoch into `builtin_interfaces/Time`
/// (`sec = floor(ns / 1e9)`, `nanosec = ns - sec * 1e9` in `0..1e9`), or
/// `None` if `sec` does not fit an `int32` (before 1901-12-13T20:45:52Z or
/// from 2038-01-19T03:14:08Z on).
pub fn split_stamp(stamp_ns: i64) -> Option<(i32, u32)> {
    let sec = i32::try_from(stamp_ns.div_euclid(NS_PER_SEC)).ok()?;
    // rem_euclid is in 0..1e9: fits u32.
    Some((sec, stamp_ns.rem_euclid(NS_PER_SEC) as u32))
}

/// Joins `builtin_interfaces/Time` into ns since the epoch (`sec·1e9 + nanosec`).
pub fn join_stamp(sec: i32, nanosec: u32) -> i64 {
    i64::from(sec) * NS_PER_SEC + i64::from(nanosec)
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

impl<'a> ImageMsg<'a> {
    /// The metadata of this image as the encoder takes it (everything but `data`).
    pub fn fields(&self) -> ImageFields<'a> {
        ImageFields {
            stamp_ns: self.stamp_ns,
            frame_id: self.frame_id,
            width: self.width,
            height: self.height,
            encoding: self.encoding,
            is_bigendian: self.is_bigendian,
            step: self.step,
        }
    }
}
