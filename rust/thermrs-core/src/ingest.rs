//! Streaming MCAP ingest: a recording (SPEC §2) to per-frame tables, in constant memory.
//!
//! The file is memory-mapped and walked record by record at the top level; message payloads
//! are never copied. Uncompressed chunks reach the detector by the faster of two routes,
//! chosen as the file is read (`RouteChooser`): in place from the mapping (the chunk's pages
//! mapped in with one `MADV_POPULATE_READ` and dropped right after), or copied with `pread`
//! into a per-thread buffer; which is faster depends on how the page cache holds the file
//! (large folios: mapping; 4 KB folios: the copy). Compressed chunks (zstd or lz4) are read
//! in place and decompressed into a per-thread buffer that is reused. Windows of chunks are
//! processed in parallel on the rayon pool; loose (unchunked) messages are batched likewise.
//! Record bodies are parsed with the `mcap` crate's `parse_record`; channels and schemas
//! come from the summary where the file has one, else from the records as they are met (a
//! chunk whose channels were defined in a chunk processed beside it is retried once the
//! window's channels are known).
//!
//! Nothing is lost silently: a file cut short yields every complete message before the cut,
//! including those in the intact part of a cut chunk, and the loss is reported; a chunk that
//! does not decompress, parse or match its checksum is skipped and reported; a frame whose
//! encoding, size or payload is wrong becomes a row with status `invalid` and is counted with
//! its reason.
//!
//! Nothing in the file is trusted: every length, size and count is checked against what
//! remains and against a limit before it is used (`recovery::MAX_CHUNK_BYTES`; PNG frames
//! are decoded with limits set from the rig's frame size). A record whose length or opcode
//! is bad does not end the walk: it resumes at the next chunk of the summary's chunk index,
//! or where there is no index at the next intact record found by scanning (`recovery`), so a
//! damaged stretch loses only itself; each loss names its byte range and, where the file
//! tells, how many messages of each topic it held.
//! Pages already processed are released from the mapping, so the resident set does not grow
//! with the file.

use std::collections::{BTreeMap, HashMap};
use std::io::Read;
use std::path::Path;

use mcap::records::{op, ChunkHeader, MessageHeader, Record};
use rayon::prelude::*;

use crate::cdr;
use crate::centroid::{self, FrameView, SpotParams, SpotStatus};
use crate::error::{Error, Result};
use crate::rig::Rig;
use crate::thermal::{roi_maxima, ThermalFormat, ThermalView};

mod png;
mod recovery;
pub use png::decode_png;
pub use recovery::MAX_CHUNK_BYTES;

const MAGIC: &[u8] = b"\x89MCAP0\r\n";
const IMAGE: &str = "sensor_msgs/msg/Image";
const COMPRESSED: &str = "sensor_msgs/msg/CompressedImage";
const JOINT_STATE: &str = "sensor_msgs/msg/JointState";
const TEMPERATURE: &str = "sensor_msgs/msg/Temperature";

/// Frame statuses in the order of their codes in [`FrameTable::status`].
pub const STATUS_NAMES: [&str; 7] = [
    "ok",
    "no_spot",
    "saturated",
    "at_border",
    "multiple",
    "streak",
    "invalid",
];
const STATUS_INVALID: u8 = 6;

fn status_code(s: SpotStatus) -> u8 {
    match s {
        SpotStatus::Ok => 0,
        SpotStatus::NoSpot => 1,
        SpotStatus::Saturated => 2,
        SpotStatus::AtBorder => 3,
        SpotStatus::Multiple => 4,
        SpotStatus::Streak => 5,
    }
}

/// Options of an extraction.
#[derive(Debug, Clone)]
pub struct ExtractOptions {
    /// Spot detection and centroid parameters.
    pub spot: SpotParams,
    /// Compressed bytes of chunks processed per parallel window (bounds memory).
    pub window_bytes: usize,
    /// Check each chunk's CRC-32 (where the writer stored one); a chunk that fails is skipped
    /// and reported.
    pub verify_crc: bool,
}

impl Default for ExtractOptions {
    fn default() -> Self {
        ExtractOptions {
            spot: SpotParams::default(),
            window_bytes: 64 << 20,
            verify_crc: true,
        }
    }
}

/// One row per CCD frame.
#[derive(Debug, Default, Clone)]
pub struct FrameTable {
    /// Index of the camera in the rig.
    pub camera: Vec<u32>,
    /// Header stamp (ns), or the log time where the stamp is zero.
    pub t_ns: Vec<i64>,
    pub x_px: Vec<f64>,
    pub y_px: Vec<f64>,
    pub peak: Vec<f64>,
    pub signal: Vec<f64>,
    pub size_px: Vec<f64>,
    pub background: Vec<f64>,
    pub noise: Vec<f64>,
    /// Index into [`STATUS_NAMES`].
    pub status: Vec<u8>,
}

/// One row per (thermal frame, ROI).
#[derive(Debug, Default, Clone)]
pub struct ThermalTable {
    pub t_ns: Vec<i64>,
    /// Index of the ROI in the rig.
    pub roi: Vec<u32>,
    pub max_c: Vec<f64>,
    pub peak_c: Vec<f64>,
    pub x_px: Vec<u32>,
    pub y_px: Vec<u32>,
}

/// One row per joint-state message, positions in the rig's joint order (radians).
#[derive(Debug, Default, Clone)]
pub struct JointTable {
    pub t_ns: Vec<i64>,
    /// N × 6, row-major.
    pub position: Vec<f64>,
}

/// One row per ambient reading.
#[derive(Debug, Default, Clone)]
pub struct AmbientTable {
    pub t_ns: Vec<i64>,
    pub temperature_c: Vec<f64>,
}

/// All tables of one recording.
#[derive(Debug, Default, Clone)]
pub struct Tables {
    pub frames: FrameTable,
    pub thermal: ThermalTable,
    pub joints: JointTable,
    pub ambient: AmbientTable,
}

macro_rules! append_all {
    ($dst:expr, $src:expr, $($f:ident),*) => { $( $dst.$f.extend_from_slice(&$src.$f); )* };
}

impl Tables {
    fn append(&mut self, o: &Tables) {
        append_all!(
            self.frames,
            o.frames,
            camera,
            t_ns,
            x_px,
            y_px,
            peak,
            signal,
            size_px,
            background,
            noise,
            status
        );
        append_all!(
            self.thermal,
            o.thermal,
            t_ns,
            roi,
            max_c,
            peak_c,
            x_px,
            y_px
        );
        append_all!(self.joints, o.joints, t_ns, position);
        append_all!(self.ambient, o.ambient, t_ns, temperature_c);
    }
}

/// Data that could not be read.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Loss {
    /// `truncated` (file cut short), `corrupt_chunk` (a chunk that does not decompress,
    /// parse or match its checksum) or `corrupt_record` (a stretch of bad records).
    pub kind: &'static str,
    /// Byte offset of the damaged record.
    pub offset: u64,
    /// Bytes not used: the lost range is `offset..offset + bytes`.
    pub bytes: u64,
    /// One line: what happened, the byte range, what was recovered and lost.
    pub detail: String,
    /// Messages lost per topic, where the file tells (message indexes, the summary's chunk
    /// index, or the damaged chunk's own records); empty where it does not.
    pub messages_lost: BTreeMap<String, u64>,
    /// The same by channel id, until the topics are known.
    #[serde(skip)]
    channels_lost: BTreeMap<u16, u64>,
}

impl Loss {
    fn new(kind: &'static str, offset: u64, bytes: u64, detail: String) -> Loss {
        Loss {
            kind,
            offset,
            bytes,
            detail,
            messages_lost: BTreeMap::new(),
            channels_lost: BTreeMap::new(),
        }
    }
}

/// What an extraction read, skipped and lost.
#[derive(Debug, Default, Clone, serde::Serialize)]
pub struct Report {
    pub file_bytes: u64,
    pub used_summary: bool,
    pub chunks: u64,
    /// Messages read per rig topic.
    pub messages: BTreeMap<String, u64>,
    /// Messages on topics the rig does not name.
    pub other_messages: u64,
    /// Skipped messages per reason ("topic: reason", numbers as `N`).
    pub skipped: BTreeMap<String, u64>,
    /// The first full reason of each group of `skipped`.
    pub skipped_examples: BTreeMap<String, String>,
    pub losses: Vec<Loss>,
    /// Complete messages recovered from a chunk the file was cut inside.
    pub recovered_messages: u64,
    /// The file's MCAP Metadata records, in file order (e.g. run markers, `thermrs.run`).
    pub metadata: Vec<MetadataRecord>,
    /// Chunks skipped because their CRC-32 did not match.
    pub crc_failures: u64,
    /// Messages lost per topic, summed over `losses` (where known).
    pub lost_messages: BTreeMap<String, u64>,
}

/// One MCAP Metadata record: its name and string map.
#[derive(Debug, Default, Clone, serde::Serialize)]
pub struct MetadataRecord {
    pub name: String,
    pub values: BTreeMap<String, String>,
}

impl Report {
    /// Count a skipped message. Reasons are grouped with their numbers replaced by `N` (byte
    /// counts and sizes vary frame to frame); the first full reason of each group is kept.
    fn skip(&mut self, topic: &str, reason: impl AsRef<str>) {
        let reason = reason.as_ref();
        let mut key = format!("{topic}: ");
        // A number is a digit run not glued to letters ("100x50" → "NxN"; "rgb8", "16UC1" stay).
        let c: Vec<char> = reason.chars().collect();
        let mut i = 0;
        while i < c.len() {
            if c[i].is_ascii_digit() {
                let mut j = i;
                while j < c.len() && c[j].is_ascii_digit() {
                    j += 1;
                }
                let glued_before = i > 0
                    && c[i - 1].is_alphabetic()
                    && !(c[i - 1] == 'x' && i > 1 && c[i - 2].is_ascii_digit());
                let glued_after = j < c.len()
                    && c[j].is_alphabetic()
                    && !(c[j] == 'x' && j + 1 < c.len() && c[j + 1].is_ascii_digit());
                if glued_before || glued_after {
                    key.extend(&c[i..j]);
                } else {
                    key.push('N');
                }
                i = j;
            } else {
                key.push(c[i]);
                i += 1;
            }
        }
        self.skipped_examples
            .entry(key.clone())
            .or_insert_with(|| format!("{topic}: {reason}"));
        *self.skipped.entry(key).or_insert(0) += 1;
    }

    fn merge(&mut self, o: &Report) {
        self.chunks += o.chunks;
        for (k, v) in &o.messages {
            *self.messages.entry(k.clone()).or_insert(0) += v;
        }
        self.other_messages += o.other_messages;
        for (k, v) in &o.skipped {
            *self.skipped.entry(k.clone()).or_insert(0) += v;
        }
        for (k, v) in &o.skipped_examples {
            self.skipped_examples
                .entry(k.clone())
                .or_insert_with(|| v.clone());
        }
        self.losses.extend(o.losses.iter().cloned());
        self.recovered_messages += o.recovered_messages;
        self.crc_failures += o.crc_failures;
    }
}

/// Progress: bytes of the file done, total bytes, CCD frames so far. Return `false` to stop.
pub type ProgressFn<'a> = dyn Fn(u64, u64, u64) -> bool + Sync + 'a;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Role {
    Camera(usize),
    Thermal,
    Joints,
    Ambient,
}

#[derive(Debug, Clone)]
struct ChannelInfo {
    topic: String,
    schema_id: u16,
    encoding: String,
}

/// Channels and schemas known so far, and the roles the rig gives their topics.
#[derive(Debug, Clone, Default)]
struct Registry {
    schemas: HashMap<u16, String>,
    channels: HashMap<u16, ChannelInfo>,
}

impl Registry {
    fn absorb(&mut self, record: &Record<'_>) {
        match record {
            Record::Schema { header, .. } => {
                self.schemas.insert(header.id, header.name.clone());
            }
            Record::Channel(c) => {
                self.channels.insert(
                    c.id,
                    ChannelInfo {
                        topic: c.topic.clone(),
                        schema_id: c.schema_id,
                        encoding: c.message_encoding.clone(),
                    },
                );
            }
            _ => {}
        }
    }

    fn merge(&mut self, o: &Registry) {
        self.schemas
            .extend(o.schemas.iter().map(|(k, v)| (*k, v.clone())));
        self.channels
            .extend(o.channels.iter().map(|(k, v)| (*k, v.clone())));
    }
}

/// What the rig needs to interpret messages.
struct Context<'r> {
    rig: &'r Rig,
    roles: HashMap<&'r str, Role>,
    rois: Vec<[i64; 4]>,
    spot: SpotParams,
    /// The mapped file the walked bytes come from, if any.
    source: Option<Source<'r>>,
    routes: RouteChooser,
    verify_crc: bool,
}

/// A file and its read-only memory map (whose bytes [`extract_bytes`] walks).
#[derive(Clone, Copy)]
pub struct Source<'a> {
    pub file: &'a std::fs::File,
    pub map: &'a memmap2::Mmap,
}

impl Source<'_> {
    /// Offset in the map and length of `data` (a slice of it).
    fn range(&self, data: &[u8]) -> (usize, usize) {
        let from = data.as_ptr() as usize - self.map.as_ptr() as usize;
        (from, data.len())
    }

    /// Map the pages of `data` in with one call (`MADV_POPULATE_READ`) rather than one
    /// fault per page.
    fn populate(&self, data: &[u8]) {
        let (from, len) = self.range(data);
        let _ = self
            .map
            .advise_range(memmap2::Advice::PopulateRead, from, len);
    }

    /// Drop the pages of the byte range `from..to` from the mapping (they stay in the page
    /// cache).
    fn release(&self, from: usize, to: usize) {
        if to > from {
            // SAFETY: a read-only file mapping: a later access faults the same bytes back
            // in from the file; DONTNEED only drops this process's view of the pages.
            let _ = unsafe {
                self.map
                    .unchecked_advise_range(memmap2::UncheckedAdvice::DontNeed, from, to - from)
            };
        }
    }
}

/// How the body of an uncompressed chunk reaches the detector.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Route {
    /// Read in place from the mapping (pages mapped in, then dropped): no copy, but the
    /// kernel pays per page cache folio to map and unmap it.
    Map,
    /// Copied with `pread` into a per-thread buffer: one copy, at a cost nearly independent
    /// of how the page cache holds the file.
    Read,
}

/// Picks the faster [`Route`] for uncompressed chunks as the file is read. Which one wins
/// depends on the page cache, not on the file: mapping costs next to nothing for pages held
/// in large folios (2 MB: one page-table entry each) and about 0.5 µs per page for 4 KB
/// folios, where the copy is 2–3× faster (measured in BENCHMARKS.md). Each chunk's
/// processing time per byte is recorded for its route (a running mean); chunks take the
/// faster route, and one in [`RouteChooser::PROBE`] the other, so that a change (the page
/// cache of a long file need not be uniform) is noticed. Outputs never depend on the route.
#[derive(Default)]
struct RouteChooser {
    /// Running mean of ns per KiB, per route (0: not measured yet).
    ns_per_kib: [std::sync::atomic::AtomicU64; 2],
    chunks: std::sync::atomic::AtomicU64,
    /// Always this route (tests).
    forced: Option<Route>,
}

impl RouteChooser {
    const PROBE: u64 = 16;

    fn pick(&self) -> Route {
        use std::sync::atomic::Ordering::Relaxed;
        if let Some(r) = self.forced {
            return r;
        }
        let n = self.chunks.fetch_add(1, Relaxed);
        let map = self.ns_per_kib[0].load(Relaxed);
        let read = self.ns_per_kib[1].load(Relaxed);
        let (best, other) = match (map, read) {
            (0, _) => return Route::Map,
            (_, 0) => return Route::Read,
            (m, r) if m <= r => (Route::Map, Route::Read),
            _ => (Route::Read, Route::Map),
        };
        if n % Self::PROBE == Self::PROBE - 1 {
            other
        } else {
            best
        }
    }

    fn record(&self, route: Route, elapsed: std::time::Duration, bytes: usize) {
        use std::sync::atomic::Ordering::Relaxed;
        let kib = (bytes as u64 / 1024).max(1);
        let x = (elapsed.as_nanos() as u64 / kib).max(1);
        let slot = &self.ns_per_kib[route as usize];
        let old = slot.load(Relaxed);
        slot.store(if old == 0 { x } else { (3 * old + x) / 4 }, Relaxed);
    }
}

impl<'r> Context<'r> {
    fn new(
        rig: &'r Rig,
        spot: SpotParams,
        source: Option<Source<'r>>,
        route: Option<Route>,
    ) -> Context<'r> {
        let mut roles = HashMap::new();
        for (i, c) in rig.camera.iter().enumerate() {
            roles.insert(c.topic.as_str(), Role::Camera(i));
        }
        if let Some(t) = &rig.thermal {
            roles.insert(t.topic.as_str(), Role::Thermal);
        }
        roles.insert(rig.robot.joint_states_topic.as_str(), Role::Joints);
        if let Some(a) = &rig.ambient {
            roles.insert(a.topic.as_str(), Role::Ambient);
        }
        let rois = rig
            .thermal
            .iter()
            .flat_map(|t| t.roi.iter().map(|r| r.rect_px))
            .collect();
        Context {
            rig,
            roles,
            rois,
            spot,
            source,
            routes: RouteChooser {
                forced: route,
                ..RouteChooser::default()
            },
            verify_crc: true,
        }
    }

    fn rig_topics(&self) -> Vec<&str> {
        let mut t: Vec<&str> = self.roles.keys().copied().collect();
        t.sort_unstable();
        t
    }
}

/// Output of one unit of work.
#[derive(Default)]
struct Part {
    tables: Tables,
    report: Report,
    registry: Registry,
    /// The chunk used a channel nobody had defined yet: run it again later.
    retry: bool,
}

/// A unit of parallel work.
enum Work<'a> {
    Chunk {
        offset: u64,
        /// Bytes of the whole chunk record (opcode and length included).
        bytes: u64,
        header: ChunkHeader,
        data: &'a [u8],
        /// The chunk was cut short: decode what is there.
        partial: bool,
    },
    Loose(Vec<(MessageHeader, &'a [u8])>),
}

thread_local! {
    static CHUNK_BUF: std::cell::RefCell<Vec<u8>> = const { std::cell::RefCell::new(Vec::new()) };
    static INPUT_BUF: std::cell::RefCell<Vec<u8>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Decompress a chunk's records into `out` (uncompressed chunks are walked in place and never
/// come here). For a cut chunk, decode as much as there is.
fn decompress(
    header: &ChunkHeader,
    data: &[u8],
    partial: bool,
    out: &mut Vec<u8>,
) -> std::result::Result<(), String> {
    out.clear();
    // The header's size is checked before anything is reserved for it, and no decoder may
    // write past it: memory follows what the data really holds, up to the limit.
    if header.uncompressed_size > MAX_CHUNK_BYTES {
        return Err(format!(
            "the chunk header claims {} uncompressed bytes, more than the {} MiB limit",
            header.uncompressed_size,
            MAX_CHUNK_BYTES >> 20
        ));
    }
    let want = header.uncompressed_size as usize;
    match header.compression.as_str() {
        "zstd" if !partial => {
            out.reserve(want);
            zstd::bulk::Decompressor::new()
                .and_then(|mut d| d.decompress_to_buffer(data, out))
                .map_err(|e| format!("zstd: {e}"))?;
        }
        "zstd" => {
            let dec =
                zstd::stream::read::Decoder::with_buffer(data).map_err(|e| format!("zstd: {e}"))?;
            read_until_error(dec, out, want);
        }
        "lz4" => {
            let dec = lz4::Decoder::new(data).map_err(|e| format!("lz4: {e}"))?;
            if partial {
                read_until_error(dec, out, want);
            } else {
                // One byte more than claimed tells a lying header from a true one.
                out.reserve(want);
                dec.take(want as u64 + 1)
                    .read_to_end(out)
                    .map_err(|e| format!("lz4: {e}"))?;
            }
        }
        other => return Err(format!("unsupported chunk compression {other:?}")),
    }
    if !partial && out.len() as u64 != header.uncompressed_size {
        return Err(format!(
            "decompressed to {} bytes, header says {}",
            out.len(),
            header.uncompressed_size
        ));
    }
    Ok(())
}

/// Read a stream until it ends or fails, keeping what came out.
fn read_until_error(mut r: impl Read, out: &mut Vec<u8>, limit: usize) {
    let mut buf = vec![0u8; 1 << 16];
    while out.len() < limit {
        let room = (limit - out.len()).min(buf.len());
        match r.read(&mut buf[..room]) {
            Ok(0) | Err(_) => break,
            Ok(n) => out.extend_from_slice(&buf[..n]),
        }
    }
}

/// Walk the records of a buffer: `(offset, opcode, body)`; stops at the first incomplete one,
/// returning its offset.
fn walk<'a>(buf: &'a [u8], mut f: impl FnMut(usize, u8, &'a [u8]) -> bool) -> Option<usize> {
    let mut pos = 0;
    while pos < buf.len() {
        if buf.len() - pos < 9 {
            return Some(pos);
        }
        let opcode = buf[pos];
        let len = u64::from_le_bytes(buf[pos + 1..pos + 9].try_into().expect("8 bytes"));
        let Some(end) = usize::try_from(len)
            .ok()
            .and_then(|l| (pos + 9).checked_add(l))
        else {
            return Some(pos);
        };
        if end > buf.len() {
            return Some(pos);
        }
        if !f(pos, opcode, &buf[pos + 9..end]) {
            return None;
        }
        pos = end;
    }
    None
}

impl<'r> Context<'r> {
    /// Interpret one message into `part`. Returns false if its channel is unknown.
    fn message(
        &self,
        reg: &Registry,
        local: &Registry,
        h: &MessageHeader,
        data: &[u8],
        part: &mut Part,
    ) -> bool {
        let Some(ch) = local
            .channels
            .get(&h.channel_id)
            .or_else(|| reg.channels.get(&h.channel_id))
        else {
            return false;
        };
        let Some(&role) = self.roles.get(ch.topic.as_str()) else {
            part.report.other_messages += 1;
            return true;
        };
        let topic = ch.topic.as_str();
        *part.report.messages.entry(topic.to_string()).or_insert(0) += 1;
        let schema = local
            .schemas
            .get(&ch.schema_id)
            .or_else(|| reg.schemas.get(&ch.schema_id))
            .map(String::as_str)
            .unwrap_or("");
        if ch.encoding != "cdr" {
            part.report.skip(
                topic,
                format!("message encoding {:?} is not cdr", ch.encoding),
            );
            if let Role::Camera(i) = role {
                invalid_frame(&mut part.tables.frames, i, h.log_time as i64);
            }
            return true;
        }
        let stamp = |ns: i64| if ns == 0 { h.log_time as i64 } else { ns };
        match role {
            Role::Camera(i) => self.camera_frame(i, topic, schema, data, h, part),
            Role::Thermal => self.thermal_frame(topic, schema, data, h, part),
            Role::Joints => match (schema, cdr::parse_joint_state(data)) {
                (JOINT_STATE, Ok(js)) => {
                    let mut row = [f64::NAN; 6];
                    for (k, name) in self.rig.robot.joint_names.iter().enumerate() {
                        match js.names.iter().position(|n| n == name) {
                            Some(j) if j < js.position.len() => row[k] = js.position[j],
                            _ => {
                                part.report.skip(topic, format!("joint {name:?} missing"));
                                return true;
                            }
                        }
                    }
                    part.tables.joints.t_ns.push(stamp(js.stamp_ns));
                    part.tables.joints.position.extend_from_slice(&row);
                }
                (JOINT_STATE, Err(e)) => part.report.skip(topic, format!("bad JointState: {e}")),
                (s, _) => part
                    .report
                    .skip(topic, format!("schema {s:?} is not {JOINT_STATE}")),
            },
            Role::Ambient => match (schema, cdr::parse_temperature(data)) {
                (TEMPERATURE, Ok(t)) => {
                    part.tables.ambient.t_ns.push(stamp(t.stamp_ns));
                    part.tables.ambient.temperature_c.push(t.temperature);
                }
                (TEMPERATURE, Err(e)) => part.report.skip(topic, format!("bad Temperature: {e}")),
                (s, _) => part
                    .report
                    .skip(topic, format!("schema {s:?} is not {TEMPERATURE}")),
            },
        }
        true
    }

    fn camera_frame(
        &self,
        cam: usize,
        topic: &str,
        schema: &str,
        data: &[u8],
        h: &MessageHeader,
        part: &mut Part,
    ) {
        let c = &self.rig.camera[cam];
        let (w, hgt) = (c.size_px[0] as usize, c.size_px[1] as usize);
        let log_t = h.log_time as i64;
        let res: std::result::Result<(i64, centroid::Spot), String> = match schema {
            IMAGE => cdr::parse_image(data)
                .map_err(|e| format!("bad Image: {e}"))
                .and_then(|im| {
                    let t = if im.stamp_ns == 0 { log_t } else { im.stamp_ns };
                    let bpp = match im.encoding {
                        "mono8" | "8UC1" => 1,
                        "mono16" | "16UC1" => 2,
                        e => return Err(format!("encoding {e:?} is not mono8/8UC1/mono16/16UC1")),
                    };
                    if (im.width as usize, im.height as usize) != (w, hgt) {
                        return Err(format!(
                            "frame is {}x{}, the rig says {w}x{hgt}",
                            im.width, im.height
                        ));
                    }
                    let view =
                        FrameView::new(im.data, w, hgt, im.step as usize, bpp, im.is_bigendian)?;
                    Ok((t, centroid::find_spot(&view, &self.spot)))
                }),
            COMPRESSED => cdr::parse_compressed_image(data)
                .map_err(|e| format!("bad CompressedImage: {e}"))
                .and_then(|im| {
                    let t = if im.stamp_ns == 0 { log_t } else { im.stamp_ns };
                    let (pixels, bpp) = decode_png(im.format, im.data, (w, hgt))?;
                    let view =
                        FrameView::new(&pixels, w, hgt, w * bpp, bpp, cfg!(target_endian = "big"))?;
                    Ok((t, centroid::find_spot(&view, &self.spot)))
                }),
            s => Err(format!("schema {s:?} is not an image")),
        };
        let f = &mut part.tables.frames;
        match res {
            Ok((t, s)) => {
                f.camera.push(cam as u32);
                f.t_ns.push(t);
                f.x_px.push(s.x_px);
                f.y_px.push(s.y_px);
                f.peak.push(s.peak);
                f.signal.push(s.signal);
                f.size_px.push(s.size_px);
                f.background.push(s.background);
                f.noise.push(s.noise);
                f.status.push(status_code(s.status));
            }
            Err(reason) => {
                part.report.skip(topic, reason);
                invalid_frame(f, cam, log_t);
            }
        }
    }

    fn thermal_frame(
        &self,
        topic: &str,
        schema: &str,
        data: &[u8],
        h: &MessageHeader,
        part: &mut Part,
    ) {
        let Some(th) = &self.rig.thermal else { return };
        let (w, hgt) = (th.size_px[0] as usize, th.size_px[1] as usize);
        let log_t = h.log_time as i64;
        let res: std::result::Result<(i64, Vec<crate::thermal::RoiMax>), String> = match schema {
            IMAGE => cdr::parse_image(data)
                .map_err(|e| format!("bad Image: {e}"))
                .and_then(|im| {
                    let t = if im.stamp_ns == 0 { log_t } else { im.stamp_ns };
                    let fmt = ThermalFormat::from_encoding(im.encoding).ok_or_else(|| {
                        format!("encoding {:?} is not 16UC1/mono16/32FC1", im.encoding)
                    })?;
                    if (im.width as usize, im.height as usize) != (w, hgt) {
                        return Err(format!(
                            "frame is {}x{}, the rig says {w}x{hgt}",
                            im.width, im.height
                        ));
                    }
                    let v =
                        ThermalView::new(im.data, w, hgt, im.step as usize, fmt, im.is_bigendian)?;
                    Ok((t, roi_maxima(&v, &self.rois, th.scale, th.offset_c)))
                }),
            COMPRESSED => cdr::parse_compressed_image(data)
                .map_err(|e| format!("bad CompressedImage: {e}"))
                .and_then(|im| {
                    let t = if im.stamp_ns == 0 { log_t } else { im.stamp_ns };
                    let (pixels, bpp) = decode_png(im.format, im.data, (w, hgt))?;
                    if bpp != 2 {
                        return Err("thermal PNG must be 16-bit grey".into());
                    }
                    let v = ThermalView::new(
                        &pixels,
                        w,
                        hgt,
                        w * 2,
                        ThermalFormat::U16,
                        cfg!(target_endian = "big"),
                    )?;
                    Ok((t, roi_maxima(&v, &self.rois, th.scale, th.offset_c)))
                }),
            s => Err(format!("schema {s:?} is not an image")),
        };
        match res {
            Ok((t, maxima)) => {
                let tt = &mut part.tables.thermal;
                for (i, m) in maxima.iter().enumerate() {
                    tt.t_ns.push(t);
                    tt.roi.push(i as u32);
                    tt.max_c.push(m.max_c);
                    tt.peak_c.push(m.peak_c);
                    tt.x_px.push(m.x_px);
                    tt.y_px.push(m.y_px);
                }
            }
            Err(reason) => part.report.skip(topic, reason),
        }
    }

    /// Process one unit of work.
    fn run(&self, reg: &Registry, work: &Work<'_>) -> Part {
        let mut part = Part::default();
        match work {
            Work::Loose(msgs) => {
                let local = Registry::default();
                for (h, d) in msgs {
                    if !self.message(reg, &local, h, d, &mut part) {
                        // Perhaps defined in a chunk of the same window: run again later.
                        part.retry = true;
                        part.report
                            .skip("?", format!("message on unknown channel {}", h.channel_id));
                    }
                }
            }
            Work::Chunk {
                offset,
                bytes,
                header,
                data,
                partial,
            } => {
                part.report.chunks = 1;
                let started = std::time::Instant::now();
                let mut timed = None;
                CHUNK_BUF.with(|cell| INPUT_BUF.with(|icell| {
                    let mut scratch = cell.borrow_mut();
                    let mut input = icell.borrow_mut();
                    let data: &[u8] = match self.source {
                        Some(src) if header.compression.is_empty() && !*partial => {
                            let route = self.routes.pick();
                            timed = Some(route);
                            match route {
                                Route::Map => {
                                    src.populate(data);
                                    data
                                }
                                Route::Read => {
                                    use std::os::unix::fs::FileExt;
                                    input.resize(data.len(), 0);
                                    let (at, _) = src.range(data);
                                    match src.file.read_exact_at(&mut input, at as u64) {
                                        Ok(()) => &input,
                                        Err(_) => data,
                                    }
                                }
                            }
                        }
                        Some(src) => {
                            src.populate(data);
                            data
                        }
                        None => data,
                    };
                    // Uncompressed chunks are walked in place.
                    let buf: &[u8] = if header.compression.is_empty() {
                        data
                    } else {
                        if let Err(e) = decompress(header, data, *partial, &mut scratch) {
                            part.report.losses.push(Loss::new(
                                "corrupt_chunk",
                                *offset,
                                *bytes,
                                format!("chunk at bytes {offset}..{} skipped: {e}", offset + bytes),
                            ));
                            return;
                        }
                        &scratch
                    };
                    // The CRC is taken record by record just before each is interpreted, so
                    // that its pass brings the frame into cache for the detector (one pass
                    // over memory, not two); a chunk that fails is dropped whole.
                    let check = self.verify_crc && !*partial && header.uncompressed_crc != 0;
                    let mut hasher = crc32fast::Hasher::new();
                    let mut hashed = 0usize;
                    let mut local = Registry::default();
                    let mut err: Option<String> = None;
                    let mut n = 0u64;
                    let stop = walk(buf, |at, opcode, body| {
                        if check {
                            let end = at + 9 + body.len();
                            hasher.update(&buf[hashed..end]);
                            hashed = end;
                        }
                        match opcode {
                        op::SCHEMA | op::CHANNEL => match mcap::read::parse_record(opcode, body) {
                            Ok(r) => {
                                local.absorb(&r);
                                true
                            }
                            Err(e) => {
                                err = Some(format!("bad record: {e}"));
                                false
                            }
                        },
                        op::MESSAGE => match mcap::read::parse_record(opcode, body) {
                            Ok(Record::Message { header, data }) => {
                                n += 1;
                                if self.message(reg, &local, &header, &data, &mut part) {
                                    true
                                } else {
                                    part.retry = true;
                                    false
                                }
                            }
                            Ok(_) => true,
                            Err(e) => {
                                err = Some(format!("bad message record: {e}"));
                                false
                            }
                        },
                        _ => true,
                    }});
                    if check && !part.retry {
                        hasher.update(&buf[hashed..]);
                        let crc = hasher.finalize();
                        if crc != header.uncompressed_crc {
                            part = Part::default();
                            part.report.chunks = 1;
                            part.report.crc_failures = 1;
                            let mut loss = Loss::new(
                                "corrupt_chunk",
                                *offset,
                                *bytes,
                                format!(
                                    "chunk at bytes {offset}..{} skipped: its CRC-32 is {crc:08x}, the header says {:08x}",
                                    offset + bytes,
                                    header.uncompressed_crc
                                ),
                            );
                            loss.channels_lost = recovery::count_messages(buf);
                            part.report.losses.push(loss);
                            return;
                        }
                    }
                    part.registry = local;
                    if part.retry {
                        return;
                    }
                    if let Some(e) = err {
                        part.report.losses.push(Loss::new(
                            "corrupt_chunk",
                            *offset,
                            *bytes,
                            format!("chunk at bytes {offset}..{}: {e}; {n} messages before it kept", offset + bytes),
                        ));
                    } else if stop.is_some() && !*partial {
                        part.report.losses.push(Loss::new(
                            "corrupt_chunk",
                            *offset,
                            *bytes,
                            format!("chunk at bytes {offset}..{} ends inside a record; {n} messages before it kept", offset + bytes),
                        ));
                    } else if *partial {
                        part.report.recovered_messages = n;
                    }
                }));
                if let (Some(route), Some(src)) = (timed, self.source) {
                    if route == Route::Map {
                        // Unmap the chunk's whole pages now, so that the cost is timed
                        // with its route (the window's ends are released by the walk).
                        let (from, len) = src.range(data);
                        let page = 4096;
                        src.release(from.div_ceil(page) * page, (from + len) / page * page);
                    }
                    self.routes.record(route, started.elapsed(), data.len());
                }
            }
        }
        part
    }
}

fn invalid_frame(f: &mut FrameTable, cam: usize, t: i64) {
    f.camera.push(cam as u32);
    f.t_ns.push(t);
    for col in [
        &mut f.x_px,
        &mut f.y_px,
        &mut f.peak,
        &mut f.signal,
        &mut f.size_px,
        &mut f.background,
        &mut f.noise,
    ] {
        col.push(f64::NAN);
    }
    f.status.push(STATUS_INVALID);
}

/// Parse the fixed part of a chunk record that was cut short: its header and whatever records
/// bytes are present.
fn partial_chunk(body: &[u8]) -> Option<(ChunkHeader, &[u8])> {
    let u64_at = |p: usize| {
        body.get(p..p + 8)
            .map(|b| u64::from_le_bytes(b.try_into().expect("8")))
    };
    let start = u64_at(0)?;
    let end = u64_at(8)?;
    let size = u64_at(16)?;
    let crc = u32::from_le_bytes(body.get(24..28)?.try_into().ok()?);
    let clen = u32::from_le_bytes(body.get(28..32)?.try_into().ok()?) as usize;
    let comp = std::str::from_utf8(body.get(32..32 + clen)?)
        .ok()?
        .to_string();
    let p = 32 + clen + 8; // skip records_length
    let data = body.get(p..)?;
    Some((
        ChunkHeader {
            message_start_time: start,
            message_end_time: end,
            uncompressed_size: size,
            uncompressed_crc: crc,
            compression: comp,
            compressed_size: data.len() as u64,
        },
        data,
    ))
}

/// Extract every table of a recording.
pub fn extract(
    path: &Path,
    rig: &Rig,
    opts: &ExtractOptions,
    progress: &ProgressFn<'_>,
) -> Result<(Tables, Report)> {
    extract_by(path, rig, opts, progress, None)
}

/// [`extract`], with every uncompressed chunk taking `route` if given.
fn extract_by(
    path: &Path,
    rig: &Rig,
    opts: &ExtractOptions,
    progress: &ProgressFn<'_>,
    route: Option<Route>,
) -> Result<(Tables, Report)> {
    let file = std::fs::File::open(path).map_err(|source| Error::Io {
        path: path.display().to_string(),
        source,
    })?;
    let len = file
        .metadata()
        .map_err(|source| Error::Io {
            path: path.display().to_string(),
            source,
        })?
        .len();
    if len < MAGIC.len() as u64 {
        return Err(Error::Recording(format!(
            "{}: not an MCAP file ({len} bytes)",
            path.display()
        )));
    }
    // SAFETY: the map is read-only; a file truncated by another process while mapped would
    // fault, which no safe API can prevent; recordings are not written while being read.
    let mmap = unsafe { memmap2::Mmap::map(&file) }.map_err(|source| Error::Io {
        path: path.display().to_string(),
        source,
    })?;
    let _ = mmap.advise(memmap2::Advice::Sequential);
    extract_in(
        &mmap,
        Some(Source {
            file: &file,
            map: &mmap,
        }),
        &path.display().to_string(),
        rig,
        opts,
        progress,
        route,
    )
}

/// [`extract`] over bytes already in memory: `buf`, or with `source`, the whole map of a
/// file (`source` is ignored unless `buf` is `source.map`). With a source, chunk bodies
/// reach the detector by the faster of reading them in place and copying them with `pread`
/// (see `RouteChooser`), and pages already processed are dropped from the mapping, so that
/// the resident set stays flat.
pub fn extract_bytes(
    buf: &[u8],
    source: Option<Source<'_>>,
    name: &str,
    rig: &Rig,
    opts: &ExtractOptions,
    progress: &ProgressFn<'_>,
) -> Result<(Tables, Report)> {
    extract_in(buf, source, name, rig, opts, progress, None)
}

fn extract_in(
    buf: &[u8],
    source: Option<Source<'_>>,
    name: &str,
    rig: &Rig,
    opts: &ExtractOptions,
    progress: &ProgressFn<'_>,
    route: Option<Route>,
) -> Result<(Tables, Report)> {
    let source =
        source.filter(|s| std::ptr::eq(s.map.as_ptr(), buf.as_ptr()) && s.map.len() == buf.len());
    if buf.len() < MAGIC.len() || &buf[..MAGIC.len()] != MAGIC {
        return Err(Error::Recording(format!(
            "{name}: not an MCAP file (no MCAP magic at the start)"
        )));
    }
    let mut ctx = Context::new(rig, opts.spot.clone(), source, route);
    ctx.verify_crc = opts.verify_crc;
    let ctx = ctx;
    let mut report = Report {
        file_bytes: buf.len() as u64,
        ..Report::default()
    };
    let mut reg = Registry::default();
    let mut chunk_index = Vec::new();
    if let Ok(Some(summary)) = mcap::read::Summary::read(buf) {
        report.used_summary = true;
        chunk_index = summary.chunk_indexes;
        for (id, s) in &summary.schemas {
            reg.schemas.insert(*id, s.name.clone());
        }
        for (id, c) in &summary.channels {
            reg.channels.insert(
                *id,
                ChannelInfo {
                    topic: c.topic.clone(),
                    schema_id: c.schema.as_ref().map(|s| s.id).unwrap_or(0),
                    encoding: c.message_encoding.clone(),
                },
            );
        }
    }
    let mut tables = Tables::default();
    let body = &buf[MAGIC.len()..];
    let mut window: Vec<Work<'_>> = Vec::new();
    let mut window_bytes = 0usize;
    let mut window_start = 0usize;
    let mut loose: Vec<(MessageHeader, &[u8])> = Vec::new();
    let mut frames_done = 0u64;
    // Where the summary's index says chunks start (offsets in `body`).
    let mut chunk_starts: Vec<usize> = chunk_index
        .iter()
        .filter_map(|c| {
            usize::try_from(c.chunk_start_offset)
                .ok()?
                .checked_sub(MAGIC.len())
        })
        .collect();
    chunk_starts.sort_unstable();
    chunk_starts.dedup();

    let mut flush = |window: &mut Vec<Work<'_>>,
                     reg: &mut Registry,
                     tables: &mut Tables,
                     report: &mut Report,
                     upto: usize|
     -> bool {
        let parts: Vec<Part> = window.par_iter().map(|w| ctx.run(reg, w)).collect();
        let mut retry = Vec::new();
        let mut done: Vec<Option<Part>> = Vec::with_capacity(parts.len());
        for (i, p) in parts.into_iter().enumerate() {
            reg.merge(&p.registry);
            if p.retry {
                retry.push(i);
                done.push(None);
            } else {
                done.push(Some(p));
            }
        }
        let again: Vec<(usize, Part)> = retry
            .par_iter()
            .map(|&i| (i, ctx.run(reg, &window[i])))
            .collect();
        for (i, mut p) in again {
            if p.retry {
                // Still unknown: count the chunk's messages as skipped rather than loop
                // (loose messages are counted one by one).
                if matches!(window[i], Work::Chunk { .. }) {
                    p.report
                        .skip("?", "message on a channel the file never defines");
                }
                p.retry = false;
            }
            done[i] = Some(p);
        }
        for p in done.into_iter().flatten() {
            frames_done += p.tables.frames.t_ns.len() as u64;
            tables.append(&p.tables);
            report.merge(&p.report);
        }
        window.clear();
        if let Some(src) = source {
            src.release(MAGIC.len() + window_start.min(upto), MAGIC.len() + upto);
        }
        window_start = upto;
        progress((upto + MAGIC.len()) as u64, buf.len() as u64, frames_done)
    };

    // Top-level walk. A damaged stretch (bad opcode, a length past the end of a complete
    // file, a chunk that does not parse) is skipped to the next intact record; a record
    // running past the end of a file without its closing magic is where the file was cut.
    let closed = recovery::closed(body);
    let mut pos = 0usize;
    let mut cut: Option<usize> = None;
    // Message index records follow their chunk: counted per chunk (file offset), so that a
    // lost chunk's messages can be told by topic where there is no summary.
    let mut last_chunk: Option<u64> = None;
    let mut indexed: HashMap<u64, BTreeMap<u16, u64>> = HashMap::new();
    while pos < body.len() {
        let at = (pos + MAGIC.len()) as u64;
        let rec = recovery::record_at(body, pos);
        let mut damage = match rec {
            None if body.len() - pos < 9 => Some("an incomplete record header".to_string()),
            None => Some(format!(
                "a record whose length ({} bytes) runs past the end of the file",
                u64::from_le_bytes(body[pos + 1..pos + 9].try_into().expect("8 bytes"))
            )),
            Some((o, _, _)) if !(recovery::valid_opcode(o) || o == op::HEADER && pos == 0) => {
                Some(format!("a record with the invalid opcode 0x{o:02x}"))
            }
            Some(_) => None,
        };
        if let Some((opcode, from, end)) = rec.filter(|_| damage.is_none()) {
            let rec = &body[from..end];
            match opcode {
                op::SCHEMA | op::CHANNEL => {
                    if let Ok(r) = mcap::read::parse_record(opcode, rec) {
                        reg.absorb(&r);
                    }
                }
                op::MESSAGE => {
                    last_chunk = None;
                    if let Ok(Record::Message {
                        header,
                        data: std::borrow::Cow::Borrowed(data),
                    }) = mcap::read::parse_record(opcode, rec)
                    {
                        window_bytes += data.len();
                        loose.push((header, data));
                        if loose.len() >= 256 {
                            window.push(Work::Loose(std::mem::take(&mut loose)));
                        }
                    }
                }
                op::CHUNK => match mcap::read::parse_record(opcode, rec) {
                    Ok(Record::Chunk {
                        header,
                        data: std::borrow::Cow::Borrowed(data),
                    }) => {
                        last_chunk = Some(at);
                        window_bytes += data.len();
                        window.push(Work::Chunk {
                            offset: at,
                            bytes: (end - pos) as u64,
                            header,
                            data,
                            partial: false,
                        });
                    }
                    Ok(_) => {}
                    Err(e) => damage = Some(format!("a chunk record that does not parse ({e})")),
                },
                op::METADATA => {
                    if let Ok(Record::Metadata(m)) = mcap::read::parse_record(opcode, rec) {
                        report.metadata.push(MetadataRecord {
                            name: m.name,
                            values: m.metadata,
                        });
                    }
                }
                op::MESSAGE_INDEX => {
                    if let (Some(c), Some((ch, n))) =
                        (last_chunk, recovery::message_index_count(rec))
                    {
                        *indexed.entry(c).or_default().entry(ch).or_insert(0) += n;
                    }
                }
                op::DATA_END | op::FOOTER => break,
                _ => {}
            }
            if damage.is_none() {
                pos = end;
            }
        }
        if let Some(why) = damage {
            let is_chunk = body[pos] == op::CHUNK;
            // A file cut inside a chunk: decode what is there (below), nothing follows.
            let cut_chunk = !closed
                && rec.is_none()
                && is_chunk
                && body.len() - pos > 9
                && partial_chunk(&body[pos + 9..]).is_some();
            let next = if cut_chunk {
                None
            } else {
                recovery::resync(body, pos, &chunk_starts)
            };
            match next {
                None if !closed && rec.is_none() => {
                    cut = Some(pos);
                    break;
                }
                next => {
                    let to = next.unwrap_or(body.len());
                    let to_at = (to + MAGIC.len()) as u64;
                    let mut loss = Loss::new(
                        if is_chunk {
                            "corrupt_chunk"
                        } else {
                            "corrupt_record"
                        },
                        at,
                        to_at - at,
                        format!(
                            "bytes {at}..{to_at} skipped: {why} at byte {at}; {}",
                            match next {
                                Some(_) if chunk_starts.binary_search(&to).is_ok() =>
                                    "reading resumed at the next chunk of the summary's index",
                                Some(_) => "reading resumed at the next intact record",
                                None => "nothing intact after it",
                            }
                        ),
                    );
                    loss.channels_lost = recovery::indexed_losses(buf, &chunk_index, at, to_at);
                    report.losses.push(loss);
                    last_chunk = Some(at);
                    match next {
                        Some(n) => pos = n,
                        None => break,
                    }
                }
            }
        }
        if window_bytes >= opts.window_bytes
            || window.len() >= 16 * rayon::current_num_threads().max(1)
        {
            if !loose.is_empty() {
                window.push(Work::Loose(std::mem::take(&mut loose)));
            }
            window_bytes = 0;
            if !flush(
                &mut window,
                &mut reg,
                &mut tables,
                &mut report,
                pos.min(body.len()),
            ) {
                return Err(Error::Interrupted);
            }
        }
    }
    if let Some(pos) = cut {
        let rest = &body[pos..];
        let offset = (pos + MAGIC.len()) as u64;
        let mut detail = format!(
            "the file is cut short: the record at byte {offset} is incomplete ({} of its bytes present, bytes {offset}..{} lost)",
            rest.len(),
            offset + rest.len() as u64
        );
        if rest.first() == Some(&op::CHUNK) && rest.len() > 9 {
            if let Some((header, data)) = partial_chunk(&rest[9..]) {
                window.push(Work::Chunk {
                    offset,
                    bytes: rest.len() as u64,
                    header,
                    data,
                    partial: true,
                });
                detail.push_str("; complete messages in the cut chunk are recovered");
            }
        }
        report
            .losses
            .push(Loss::new("truncated", offset, rest.len() as u64, detail));
    }
    if !loose.is_empty() {
        window.push(Work::Loose(std::mem::take(&mut loose)));
    }
    // Always: the last call reports the whole file done.
    if !flush(&mut window, &mut reg, &mut tables, &mut report, body.len()) {
        return Err(Error::Interrupted);
    }
    recovery::name_losses(&mut report, &indexed, &reg);
    // A recording with none of the rig's topics is an error naming them.
    let present: Vec<&str> = reg.channels.values().map(|c| c.topic.as_str()).collect();
    let wanted = ctx.rig_topics();
    if !wanted.iter().any(|t| present.contains(t)) {
        let mut have: Vec<&str> = present.clone();
        have.sort_unstable();
        have.dedup();
        return Err(Error::Recording(format!(
            "{name}: none of the rig's topics ({}) is in the recording (it has: {})",
            wanted.join(", "),
            if have.is_empty() {
                "no channels".to_string()
            } else {
                have.join(", ")
            }
        )));
    }
    Ok((tables, report))
}

/// What [`decompress_chunks`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ChunkScan {
    pub chunks: u64,
    pub compressed_bytes: u64,
    pub uncompressed_bytes: u64,
}

/// Decompress every chunk of a recording on the calling thread and do nothing else: the
/// decompressor's own speed, the floor any reader of the file pays (benchmarks compare
/// [`extract`] with it).
pub fn decompress_chunks(path: &Path) -> Result<ChunkScan> {
    let file = std::fs::File::open(path).map_err(|source| Error::Io {
        path: path.display().to_string(),
        source,
    })?;
    // SAFETY: read-only map of a file not being written (as in `extract`).
    let buf = unsafe { memmap2::Mmap::map(&file) }.map_err(|source| Error::Io {
        path: path.display().to_string(),
        source,
    })?;
    if buf.len() < MAGIC.len() || &buf[..MAGIC.len()] != MAGIC {
        return Err(Error::Recording(format!(
            "{}: not an MCAP file",
            path.display()
        )));
    }
    let mut scan = ChunkScan::default();
    let mut out = Vec::new();
    let mut err = None;
    let src = Source {
        file: &file,
        map: &buf,
    };
    let mut done = 0usize;
    walk(&buf[MAGIC.len()..], |_, opcode, rec| {
        if opcode == op::CHUNK {
            if let Ok(Record::Chunk { header, data }) = mcap::read::parse_record(opcode, rec) {
                scan.chunks += 1;
                scan.compressed_bytes += data.len() as u64;
                // Read the input as `extract` does a compressed chunk: in place, its pages
                // mapped in with one call and dropped afterwards.
                src.populate(&data);
                if header.compression.is_empty() {
                    scan.uncompressed_bytes += data.len() as u64;
                } else if let Err(e) = decompress(&header, &data, false, &mut out) {
                    err = Some(e);
                    return false;
                } else {
                    scan.uncompressed_bytes += out.len() as u64;
                }
                let (from, len) = src.range(&data);
                src.release(done, from + len);
                done = from + len;
            }
        }
        opcode != op::DATA_END
    });
    match err {
        Some(e) => Err(Error::Recording(format!("{}: {e}", path.display()))),
        None => Ok(scan),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::{ImageFields, MsgType, RecordCompression, RecordOptions, RecordingWriter};

    fn paper_rig() -> Rig {
        Rig::from_path(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../python/thermrs/data/kr15-paper.toml"
        ))
        .unwrap()
    }

    /// Every column of the frame table, NaN-aware, as bits.
    fn frame_bits(t: &FrameTable) -> Vec<Vec<u64>> {
        let f = |v: &Vec<f64>| v.iter().map(|x| x.to_bits()).collect::<Vec<u64>>();
        vec![
            t.camera.iter().map(|&c| c as u64).collect(),
            t.t_ns.iter().map(|&c| c as u64).collect(),
            f(&t.x_px),
            f(&t.y_px),
            f(&t.peak),
            f(&t.signal),
            f(&t.size_px),
            f(&t.background),
            f(&t.noise),
            t.status.iter().map(|&c| c as u64).collect(),
        ]
    }

    #[test]
    fn chunk_routes_give_the_same_tables_whole_or_cut() {
        let rig = paper_rig();
        let cam = &rig.camera[0];
        let (w, h) = (cam.size_px[0] as usize, cam.size_px[1] as usize);
        let path = std::env::temp_dir().join(format!("thermrs-routes-{}.mcap", std::process::id()));
        let opts = RecordOptions {
            compression: RecordCompression::None,
            chunk_size: 1 << 20,
            ..RecordOptions::default()
        };
        let f = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
        let mut wr = RecordingWriter::new(f, &opts).unwrap();
        wr.add_channel(&cam.topic, MsgType::Image).unwrap();
        for i in 0..40u32 {
            let fields = ImageFields {
                stamp_ns: 1_000_000 + i as i64,
                frame_id: "ccd",
                width: w as u32,
                height: h as u32,
                encoding: "mono8",
                is_bigendian: false,
                step: w as u32,
            };
            let (cx, cy) = (200.0 + 7.3 * i as f64, 150.0 + 5.1 * i as f64);
            wr.write_image_with(&cam.topic, 1_000 + i as u64, &fields, w * h, |px| {
                for (j, p) in px.iter_mut().enumerate() {
                    let (x, y) = ((j % w) as f64, (j / w) as f64);
                    let r2 = (x - cx).powi(2) + (y - cy).powi(2);
                    let spot = if i % 3 == 0 {
                        150.0 * (-r2 / 32.0).exp()
                    } else {
                        0.0
                    };
                    *p = (8.0 + ((j * 7919 + i as usize) % 5) as f64 + spot) as u8;
                }
            })
            .unwrap();
        }
        drop(wr.finish().unwrap());
        let full = std::fs::read(&path).unwrap();
        let run = |route: Option<Route>| {
            let (t, r) = extract_by(
                &path,
                &rig,
                &ExtractOptions::default(),
                &|_, _, _| true,
                route,
            )
            .unwrap();
            (
                frame_bits(&t.frames),
                r.chunks,
                r.losses.len(),
                r.recovered_messages,
            )
        };
        let cases = [
            (full.len(), 40),
            (full.len() * 2 / 3, 0), // cut inside a chunk
        ];
        for (len, frames) in cases {
            std::fs::write(&path, &full[..len]).unwrap();
            let map = run(Some(Route::Map));
            let read = run(Some(Route::Read));
            let auto = run(None);
            if frames > 0 {
                assert_eq!(map.0[0].len(), frames);
                assert_eq!(map.2, 0);
                let ok = map.0[9].iter().filter(|&&s| s == 0).count();
                assert_eq!(ok, 14, "spot frames found");
            } else {
                assert!(map.0[0].len() > 10 && map.0[0].len() < 40);
                assert_eq!(map.2, 1, "the cut is reported");
            }
            assert!(map.1 > 5, "several chunks");
            assert_eq!(map, read);
            assert_eq!(map, auto);
        }
        std::fs::remove_file(&path).unwrap();
    }
}
