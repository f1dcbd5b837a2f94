//! Streaming MCAP ingest: a recording (SPEC §2) to per-frame tables, in constant memory.
//!
//! The file is memory-mapped and walked record by record at the top level; message payloads
//! are never copied. Uncompressed chunks reach the detector by the faster of two routes,
//! chosen as the file is read (`RouteChooser`): in place from the mapping (the chunk's pages
//! mapped in by the walk's own page faults and dropped right after), or copied with `pread`
//! record by record through a cache-sized per-thread buffer, each record checksummed and
//! interpreted right after its copy; which is faster depends on how the page cache holds the
//! file (large folios: mapping; 4 KB folios: the copy). Compressed chunks (zstd or lz4) are read
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

use std::collections::HashMap;
use std::path::Path;

use mcap::records::{op, ChunkHeader, MessageHeader, Record};

use crate::cdr;
use crate::centroid::{self, FrameView, SpotParams};
use crate::error::{Error, Result};
use crate::rig::Rig;
use crate::thermal::{roi_maxima, ThermalFormat, ThermalView};

mod bagread;
mod chunk;
mod dispatch;
mod floor;
mod follow;
mod png;
mod recovery;
mod report;
pub(crate) mod ros1bag;
mod rosbag1;
mod source;
mod sqlite;
mod tables;
mod walk;
mod work;
use chunk::{decompress, walk, walk_read, CHUNK_BUF, INPUT_BUF};
pub use floor::{checksum_chunks, ChecksumScan};
pub use follow::{Follow, FollowState, FollowStep};
pub use png::decode_png;
pub use recovery::{record_at, summary_crc, MAX_CHUNK_BYTES};
pub use report::{Loss, MetadataRecord, PartInfo, Report};
pub use rosbag1::ros2_type;
pub use source::Source;
use source::{Route, RouteChooser};
use tables::{invalid_frame, status_code};
pub use tables::{AmbientTable, FrameTable, JointTable, Tables, ThermalTable, STATUS_NAMES};
use walk::Walk;

const MAGIC: &[u8] = b"\x89MCAP0\r\n";
/// A zstd frame's first bytes (rosbag2's message compression).
const ZSTD_MAGIC: &[u8] = &[0x28, 0xb5, 0x2f, 0xfd];
const IMAGE: &str = "sensor_msgs/msg/Image";
const COMPRESSED: &str = "sensor_msgs/msg/CompressedImage";
const JOINT_STATE: &str = "sensor_msgs/msg/JointState";
const TEMPERATURE: &str = "sensor_msgs/msg/Temperature";

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
    /// Also hash the whole file (BLAKE3, [`Report::content_hash`]) in the same pass, window by
    /// window as the walk goes, so that the file is read once for both.
    pub content_hash: bool,
}

impl Default for ExtractOptions {
    fn default() -> Self {
        ExtractOptions {
            spot: SpotParams::default(),
            window_bytes: 64 << 20,
            verify_crc: true,
            content_hash: false,
        }
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

#[derive(Debug, Clone, PartialEq)]
struct ChannelInfo {
    topic: String,
    schema_id: u16,
    encoding: String,
}

/// Channels and schemas known so far (the latest definition of each id).
#[derive(Debug, Clone, Default)]
struct Registry {
    schemas: HashMap<u16, String>,
    channels: HashMap<u16, ChannelInfo>,
    /// An id was defined twice with different contents (MCAP forbids it; a writer that
    /// reused ids did it): which definition a message means then depends on where it is in
    /// the file, so the file is read again in file order ([`Walk`] in exact order).
    conflict: bool,
}

impl Registry {
    fn absorb(&mut self, record: &Record<'_>) {
        match record {
            Record::Schema { header, .. } => self.add_schema(header.id, &header.name),
            Record::Channel(c) => self.add_channel(
                c.id,
                ChannelInfo {
                    topic: c.topic.clone(),
                    schema_id: c.schema_id,
                    encoding: c.message_encoding.clone(),
                },
            ),
            _ => {}
        }
    }

    fn add_schema(&mut self, id: u16, name: &str) {
        if let Some(old) = self.schemas.insert(id, name.to_string()) {
            self.conflict |= old != name;
        }
    }

    fn add_channel(&mut self, id: u16, info: ChannelInfo) {
        if let Some(old) = self.channels.get(&id) {
            self.conflict |= *old != info;
        }
        self.channels.insert(id, info);
    }

    /// Take in what a unit later in the file defined (its definitions win).
    fn merge(&mut self, o: &Registry) {
        self.conflict |= o.conflict;
        for (k, v) in &o.schemas {
            self.add_schema(*k, v);
        }
        for (k, v) in &o.channels {
            self.add_channel(*k, v.clone());
        }
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
            routes: RouteChooser::new(route),
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
    /// Messages on a channel nobody had defined yet (as the unit saw the file): where they
    /// are in the unit (a chunk's record offset, a loose batch's index) and their channel.
    /// The rest of the unit is read; these are read again once the channel is known.
    deferred: Vec<(usize, u16)>,
}

/// A unit of parallel work.
#[derive(Clone)]
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

/// Extract every table of a recording: an MCAP file, a rosbag2 SQLite database (`.db3`),
/// either compressed whole with zstd, a ROS 1 bag (format 2.0), or a rosbag2 bag folder (its files in order, as one
/// recording; see [`crate::bag`]). The storage is recognised by the file's first bytes.
///
/// # Errors
/// [`Error::Refused`] for a ROS 1 bag older than format 2.0 (with the conversion to use); [`Error::NotMcap`] for a
/// file none of these; [`Error::BadBag`] for a folder that is not a readable bag.
pub fn extract(
    path: &Path,
    rig: &Rig,
    opts: &ExtractOptions,
    progress: &ProgressFn<'_>,
) -> Result<(Tables, Report)> {
    use crate::bag::Storage;
    if path.is_dir() {
        return bagread::extract_bag(path, rig, opts, progress);
    }
    let name = path.display().to_string();
    match crate::bag::storage_of(path)? {
        Storage::Sqlite => sqlite::extract_sqlite(path, &name, rig, opts, progress),
        Storage::Zstd => {
            let plain = crate::bag::decompress_file(path)?;
            let inner = ExtractOptions {
                content_hash: false,
                ..opts.clone()
            };
            let tmp = plain.path.display().to_string();
            let (t, mut r) = match extract(&plain.path, rig, &inner, progress) {
                Err(Error::NoRigTopics {
                    topics, present, ..
                }) => {
                    return Err(Error::NoRigTopics {
                        path: name,
                        topics,
                        present,
                    })
                }
                other => other?,
            };
            for l in &mut r.losses {
                l.detail = l.detail.replace(&tmp, &name);
            }
            r.file_bytes = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
            r.notes.push(format!(
                "compressed whole with zstd: decompressed into a temporary file ({} bytes) \
                 and read from there",
                std::fs::metadata(&plain.path).map(|m| m.len()).unwrap_or(0)
            ));
            if opts.content_hash {
                r.content_hash = Some(crate::digest::content_hash(path)?);
            }
            Ok((t, r))
        }
        Storage::Ros1 => rosbag1::extract_ros1(path, &name, rig, opts, progress),
        Storage::OldRos1 => Err(refused_old_ros1(path)),
        Storage::Mcap | Storage::Unknown => extract_by(path, rig, opts, progress, None),
    }
}

/// The error for a ROS 1 bag of a format before 2.0 (`#ROSBAG V1.x`), which thermrs does not
/// read: how to write it again as 2.0.
pub fn refused_old_ros1(path: &Path) -> Error {
    Error::Refused {
        path: path.display().to_string(),
        what: "a ROS 1 bag of a format before 2.0 (#ROSBAG V1.x)".into(),
        conversion: format!(
            "write it again with ROS 1's rosbag, which writes format 2.0: `rosbag filter {} \
             NEW.bag True`",
            path.display()
        ),
    }
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
        return Err(Error::NotMcap {
            path: path.display().to_string(),
            bytes: len,
        });
    }
    // A hole at the end (space a crashed writer pre-allocated and never filled) is neither
    // mapped nor read: it holds no record, only zeros, and is reported as what it is.
    let (holes, data_end) = crate::holes::layout(&file, len);
    let data_end = data_end.max(MAGIC.len() as u64);
    // SAFETY: the map is read-only; a file truncated by another process while mapped would
    // fault, which no safe API can prevent; recordings are not written while being read.
    let mmap = usize::try_from(data_end)
        .ok()
        .map(|n| unsafe { memmap2::MmapOptions::new().len(n).map(&file) })
        .unwrap_or_else(|| {
            Err(std::io::Error::other(
                "the file is larger than the address space",
            ))
        })
        .map_err(|source| Error::Io {
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
        Extent { len, holes },
        &path.display().to_string(),
        rig,
        opts,
        progress,
        route,
    )
}

/// The file a walked buffer comes from: its whole length (the buffer may stop where a
/// trailing hole starts) and its holes (file offsets).
pub(crate) struct Extent {
    pub(crate) len: u64,
    pub(crate) holes: Vec<(u64, u64)>,
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
    let extent = Extent {
        len: buf.len() as u64,
        holes: Vec::new(),
    };
    extract_in(buf, source, extent, name, rig, opts, progress, None)
}

#[allow(clippy::too_many_arguments)]
fn extract_in(
    buf: &[u8],
    source: Option<Source<'_>>,
    extent: Extent,
    name: &str,
    rig: &Rig,
    opts: &ExtractOptions,
    progress: &ProgressFn<'_>,
    route: Option<Route>,
) -> Result<(Tables, Report)> {
    let source =
        source.filter(|s| std::ptr::eq(s.map.as_ptr(), buf.as_ptr()) && s.map.len() == buf.len());
    if buf.len() < MAGIC.len() || &buf[..MAGIC.len()] != MAGIC {
        return Err(Error::NotMcap {
            path: name.to_string(),
            bytes: buf.len() as u64,
        });
    }
    let mut ctx = Context::new(rig, opts.spot.clone(), source, route);
    ctx.verify_crc = opts.verify_crc;
    let holes = extent.holes.clone();
    let mut walk = Walk::new(buf, extent, &ctx, opts.window_bytes, progress);
    if opts.content_hash {
        walk.hash_content();
    }
    if !walk.run() {
        return Err(Error::Interrupted);
    }
    if walk.reg.conflict {
        // An id defined twice with different contents: read again in file order, one unit
        // at a time, each message taking the definition before it (as a streamed reader does).
        let extent = Extent {
            len: walk.report.file_bytes,
            holes,
        };
        let hash = walk.report.content_hash.take();
        walk = Walk::new(buf, extent, &ctx, opts.window_bytes, progress);
        walk.exact_order();
        if !walk.run() {
            return Err(Error::Interrupted);
        }
        walk.report.content_hash = hash;
    }
    // A recording with none of the rig's topics is an error naming them.
    let present: Vec<&str> = walk
        .reg
        .channels
        .values()
        .map(|c| c.topic.as_str())
        .collect();
    let wanted = ctx.rig_topics();
    if !wanted.iter().any(|t| present.contains(t)) {
        let mut have: Vec<&str> = present.clone();
        have.sort_unstable();
        have.dedup();
        return Err(Error::NoRigTopics {
            path: name.to_string(),
            topics: wanted.iter().map(|t| t.to_string()).collect(),
            present: have.iter().map(|t| t.to_string()).collect(),
        });
    }
    Ok((walk.tables, walk.report))
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
        return Err(Error::NotMcap {
            path: path.display().to_string(),
            bytes: buf.len() as u64,
        });
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
        Some(reason) => Err(Error::BadChunk {
            path: path.display().to_string(),
            reason,
        }),
        None => Ok(scan),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::{ImageFields, MsgType, RecordCompression, RecordOptions, RecordingWriter};

    pub(super) fn paper_rig() -> Rig {
        Rig::from_path(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../python/thermrs/data/kr15-paper.toml"
        ))
        .unwrap()
    }

    /// Every column of the frame table, NaN-aware, as bits.
    pub(super) fn frame_bits(t: &FrameTable) -> Vec<Vec<u64>> {
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

    /// 40 uncompressed frames of camera A in 1 MiB chunks, a spot in every third.
    pub(super) fn write_spots(path: &std::path::Path, rig: &Rig) {
        let cam = &rig.camera[0];
        let (w, h) = (cam.size_px[0] as usize, cam.size_px[1] as usize);
        let opts = RecordOptions {
            compression: RecordCompression::None,
            chunk_size: 1 << 20,
            ..RecordOptions::default()
        };
        let f = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
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
    }

    #[test]
    fn chunk_routes_give_the_same_tables_whole_or_cut() {
        let rig = paper_rig();
        let path = std::env::temp_dir().join(format!("thermrs-routes-{}.mcap", std::process::id()));
        write_spots(&path, &rig);
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
            // The content hash taken window by window (windows of ~1 chunk here) is the
            // hash of the file's bytes taken at once, whole or cut.
            let opts = ExtractOptions {
                content_hash: true,
                window_bytes: 1 << 20,
                ..ExtractOptions::default()
            };
            let (_, r) = extract(&path, &rig, &opts, &|_, _, _| true).unwrap();
            let want = blake3::hash(&full[..len]).to_hex().to_string();
            assert_eq!(r.content_hash.as_deref(), Some(want.as_str()));
        }
        std::fs::remove_file(&path).unwrap();
    }
}
