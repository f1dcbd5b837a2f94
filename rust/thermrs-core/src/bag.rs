//! rosbag2 bags: a folder holding `metadata.yaml` and the bag's files (`NAME_0.mcap`,
//! `NAME_1.mcap`, … or `NAME_0.db3`, …, each perhaps zstd-compressed whole as `….zstd`), read
//! as one recording: its files in the order `metadata.yaml` lists them. A folder without
//! `metadata.yaml` whose recordings all carry one stem numbered from 0 (`NAME_0`, `NAME_1`, …,
//! as `ros2 bag record` names a split bag's files) and follow each other (the same topics,
//! each file starting after the previous one ends, within [`SPLIT_GAP_NS`]) is offered as one
//! bag in that order, and says so.
//!
//! `metadata.yaml` is parsed with `serde_norway` (YAML), every version rosbag2 has written
//! (1 to 9, `rosbag2_storage/yaml.hpp`): the fields read are `version`,
//! `storage_identifier`, `relative_file_paths`, `compression_format` and `compression_mode`
//! (version 3 on), `message_count` and `topics_with_message_count`; the rest is ignored.
//!
//! A file's storage is recognised by its first bytes, never by its name: MCAP (`\x89MCAP0\r\n`),
//! SQLite (`SQLite format 3\0`, rosbag2's `sqlite3` storage), a zstd frame (a file
//! compressed whole: `compression_mode: FILE`), ROS 1 (`#ROSBAG V2.0`; `#ROSBAG V1.x`,
//! refused with the conversion to use).

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::error::{Error, Result};

/// The name of a bag's metadata file.
pub const METADATA: &str = "metadata.yaml";

pub(crate) const SQLITE_MAGIC: &[u8] = b"SQLite format 3\0";
const ZSTD_MAGIC: &[u8] = &[0x28, 0xb5, 0x2f, 0xfd];
const ROS1_MAGIC: &[u8] = b"#ROSBAG V2.0\n";
const OLD_ROS1_MAGIC: &[u8] = b"#ROSBAG V1.";

/// What a file holds, by its first bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Storage {
    /// An MCAP file.
    Mcap,
    /// A rosbag2 SQLite database (`.db3`).
    Sqlite,
    /// A file compressed whole with zstd (rosbag2's file compression).
    Zstd,
    /// A ROS 1 bag (format 2.0).
    Ros1,
    /// A ROS 1 bag of a format before 2.0.
    OldRos1,
    /// None of these.
    Unknown,
}

/// The storage of the file at `path`, from its first bytes.
///
/// # Errors
/// [`Error::Io`] if it cannot be opened or read.
pub fn storage_of(path: &Path) -> Result<Storage> {
    use std::io::Read;
    let io = |source| Error::Io {
        path: path.display().to_string(),
        source,
    };
    let mut f = std::fs::File::open(path).map_err(io)?;
    let mut head = [0u8; 16];
    let mut n = 0;
    while n < head.len() {
        match f.read(&mut head[n..]).map_err(io)? {
            0 => break,
            k => n += k,
        }
    }
    Ok(sniff(&head[..n]))
}

/// The storage of a file starting with `head`.
pub fn sniff(head: &[u8]) -> Storage {
    if head.starts_with(mcap::MAGIC) {
        Storage::Mcap
    } else if head.starts_with(SQLITE_MAGIC) {
        Storage::Sqlite
    } else if head.starts_with(ZSTD_MAGIC) {
        Storage::Zstd
    } else if head.starts_with(ROS1_MAGIC) {
        Storage::Ros1
    } else if head.starts_with(OLD_ROS1_MAGIC) {
        Storage::OldRos1
    } else {
        Storage::Unknown
    }
}

/// `metadata.yaml`, the fields thermrs reads.
#[derive(Debug, Clone, Deserialize)]
struct MetadataFile {
    rosbag2_bagfile_information: Metadata,
}

/// The bag's description in `metadata.yaml` (the fields thermrs reads).
#[derive(Debug, Clone, Default, Deserialize)]
pub struct Metadata {
    /// The metadata version (1 to 9 so far).
    pub version: u32,
    /// `sqlite3` or `mcap`.
    #[serde(default)]
    pub storage_identifier: String,
    /// The bag's files, relative to its folder, in order.
    #[serde(default)]
    pub relative_file_paths: Vec<String>,
    /// `zstd` or empty (version 3 on).
    #[serde(default)]
    pub compression_format: String,
    /// `FILE`, `MESSAGE` or empty (version 3 on).
    #[serde(default)]
    pub compression_mode: String,
    /// Messages in all, as the recorder counted them.
    #[serde(default)]
    pub message_count: u64,
    /// Per topic: its name, type and message count.
    #[serde(default)]
    pub topics_with_message_count: Vec<TopicCount>,
    /// Per file (version 5 on): its path and message count.
    #[serde(default)]
    pub files: Vec<FileInfo>,
}

/// One file of `metadata.yaml`'s `files` (version 5 on).
#[derive(Debug, Clone, Default, Deserialize)]
pub struct FileInfo {
    pub path: String,
    #[serde(default)]
    pub message_count: u64,
}

/// One topic of `metadata.yaml`.
#[derive(Debug, Clone, Default, Deserialize)]
pub struct TopicCount {
    pub topic_metadata: TopicMetadata,
    #[serde(default)]
    pub message_count: u64,
}

/// A topic's name and type in `metadata.yaml`.
#[derive(Debug, Clone, Default, Deserialize)]
pub struct TopicMetadata {
    pub name: String,
    #[serde(rename = "type", default)]
    pub type_name: String,
    #[serde(default)]
    pub serialization_format: String,
}

/// A bag: its folder, its metadata (if it has `metadata.yaml`) and its files in order.
#[derive(Debug, Clone)]
pub struct Bag {
    /// The bag's folder.
    pub dir: PathBuf,
    /// `metadata.yaml`, if the folder has one.
    pub metadata: Option<Metadata>,
    /// The bag's files in order (some may be missing: a stated loss when read).
    pub parts: Vec<PathBuf>,
    /// How the bag was recognised where that is worth saying (no `metadata.yaml`).
    pub notes: Vec<String>,
}

/// Whether `dir` is a bag: it holds `metadata.yaml`, or its recordings are the numbered files
/// of one split bag (see the module docs).
pub fn is_bag(dir: &Path) -> bool {
    dir.is_dir() && (dir.join(METADATA).is_file() || numbered_parts(dir).is_some())
}

/// The recordings of `dir` (`.mcap`, `.db3`, either `.zstd`), if they are `STEM_0`,
/// `STEM_1`, … with one stem and no number missing, in number order.
fn numbered_parts(dir: &Path) -> Option<Vec<PathBuf>> {
    let mut found: Vec<(String, u64, PathBuf)> = Vec::new();
    for e in std::fs::read_dir(dir).ok()?.flatten() {
        let p = e.path();
        let name = p.file_name()?.to_str()?.to_string();
        let base = name.strip_suffix(".zstd").unwrap_or(&name);
        let Some(stem) = base
            .strip_suffix(".mcap")
            .or_else(|| base.strip_suffix(".db3"))
        else {
            continue;
        };
        let (prefix, num) = stem.rsplit_once('_')?;
        let n: u64 = num.parse().ok()?;
        found.push((prefix.to_string(), n, p));
    }
    if found.len() < 2 || found.iter().any(|f| f.0 != found[0].0) {
        return None;
    }
    found.sort_by_key(|f| f.1);
    if found.iter().enumerate().any(|(i, f)| f.1 != i as u64) {
        return None;
    }
    let parts: Vec<PathBuf> = found.into_iter().map(|f| f.2).collect();
    follow_each_other(&parts).then_some(parts)
}

/// Files of one bag split by the recorder follow each other: the same topics, each file's
/// first message after the previous file's last, closer to it than [`SPLIT_GAP_NS`]. Read
/// from each file's inventory (its summary; no message decoded).
fn follow_each_other(parts: &[PathBuf]) -> bool {
    let mut prev: Option<(BTreeSet<String>, u64)> = None;
    for p in parts {
        let Ok(inv) = crate::inventory::inventory(p, &[]) else {
            return false;
        };
        let (Some(start), Some(end)) = (inv.start_ns, inv.end_ns) else {
            return false;
        };
        let topics: BTreeSet<String> = inv.channels.into_iter().map(|c| c.topic).collect();
        if let Some((t, last)) = &prev {
            if *t != topics || start < *last || start - last > SPLIT_GAP_NS {
                return false;
            }
        }
        prev = Some((topics, end));
    }
    true
}

/// The longest silence between two files of a bag without `metadata.yaml` for them to be
/// taken as one recording split: thermrs' shortest idle gap between runs (600 s), so that
/// files a run could not span stay separate recordings.
pub const SPLIT_GAP_NS: u64 = 600 * 1_000_000_000;

impl Bag {
    /// Open the bag in `dir` (see [`is_bag`]).
    ///
    /// # Errors
    /// [`Error::BadBag`] if `metadata.yaml` cannot be read or parsed, lists no file, or a file
    /// outside the folder; or the folder is not a bag.
    pub fn open(dir: &Path) -> Result<Bag> {
        let bad = |reason: String| Error::BadBag {
            path: dir.display().to_string(),
            reason,
        };
        let meta_path = dir.join(METADATA);
        if meta_path.is_file() {
            let text = std::fs::read_to_string(&meta_path)
                .map_err(|e| bad(format!("{METADATA} cannot be read: {e}")))?;
            let m = parse_metadata(&text).map_err(|e| bad(format!("{METADATA}: {e}")))?;
            if m.relative_file_paths.is_empty() {
                return Err(bad(format!("{METADATA} lists no file")));
            }
            let mut parts = Vec::new();
            for rel in &m.relative_file_paths {
                let r = Path::new(rel);
                // Older rosbag2 versions wrote paths with the bag's folder in front.
                let r = if r.components().count() > 1 {
                    Path::new(r.file_name().unwrap_or_default())
                } else {
                    r
                };
                if r.as_os_str().is_empty() || r.is_absolute() || rel.contains("..") {
                    return Err(bad(format!(
                        "{METADATA} lists {rel:?}, not a file of the bag"
                    )));
                }
                parts.push(dir.join(r));
            }
            return Ok(Bag {
                dir: dir.to_path_buf(),
                metadata: Some(m),
                parts,
                notes: Vec::new(),
            });
        }
        let parts = numbered_parts(dir).ok_or_else(|| {
            bad(format!(
                "no {METADATA}, and its recordings are not the numbered files of one bag"
            ))
        })?;
        let names: Vec<String> = parts
            .iter()
            .map(|p| {
                p.file_name()
                    .unwrap_or_default()
                    .to_string_lossy()
                    .into_owned()
            })
            .collect();
        Ok(Bag {
            dir: dir.to_path_buf(),
            metadata: None,
            notes: vec![format!(
                "no {METADATA}: its {} files ({}) hold the same topics and follow each other \
                 in time, so they are read as one bag in the order of their numbers",
                parts.len(),
                names.join(", ")
            )],
            parts,
        })
    }

    /// A part's name within the bag (its file name).
    pub fn part_name(p: &Path) -> String {
        p.file_name()
            .unwrap_or_default()
            .to_string_lossy()
            .into_owned()
    }
}

/// Parse the text of `metadata.yaml`.
///
/// # Errors
/// The YAML error, or a missing `rosbag2_bagfile_information`.
pub fn parse_metadata(text: &str) -> std::result::Result<Metadata, String> {
    let f: MetadataFile = serde_norway::from_str(text).map_err(|e| e.to_string())?;
    Ok(f.rosbag2_bagfile_information)
}

/// The content hash of a bag: BLAKE3 over one line per file in order, `NAME\tHASH\n` (each
/// file's own content hash, [`crate::digest::content_hash`]; `missing` for a file not there).
/// The same as an extraction's own pass gives.
///
/// # Errors
/// As [`Bag::open`]; [`Error::Io`] if a file present cannot be read.
pub fn content_hash(dir: &Path) -> Result<String> {
    let bag = Bag::open(dir)?;
    let mut parts = Vec::new();
    for p in &bag.parts {
        let h = if p.is_file() {
            Some(crate::digest::content_hash(p)?)
        } else {
            None
        };
        parts.push((Bag::part_name(p), h));
    }
    Ok(combine_hashes(&parts))
}

/// The bag's hash from its files' names and hashes (see [`content_hash`]).
pub fn combine_hashes(parts: &[(String, Option<String>)]) -> String {
    let mut h = blake3::Hasher::new();
    h.update(b"thermrs-bag\n");
    for (name, digest) in parts {
        h.update(name.as_bytes());
        h.update(b"\t");
        h.update(digest.as_deref().unwrap_or("missing").as_bytes());
        h.update(b"\n");
    }
    h.finalize().to_hex().to_string()
}

/// A file compressed whole with zstd, decompressed into a temporary file beside nothing the
/// user owns (the system's temporary folder), removed when dropped.
pub struct Decompressed {
    pub path: PathBuf,
}

impl Drop for Decompressed {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}

/// Decompress the zstd file at `path` into a temporary file (streamed: memory stays flat).
///
/// # Errors
/// [`Error::Io`] if it cannot be read or written; [`Error::BadChunk`] if it does not
/// decompress.
pub fn decompress_file(path: &Path) -> Result<Decompressed> {
    use std::sync::atomic::{AtomicU64, Ordering};
    static SEQ: AtomicU64 = AtomicU64::new(0);
    let io = |p: &Path, source| Error::Io {
        path: p.display().to_string(),
        source,
    };
    let src = std::fs::File::open(path).map_err(|e| io(path, e))?;
    let name = Bag::part_name(path);
    let out = Decompressed {
        path: std::env::temp_dir().join(format!(
            "thermrs-{}-{}-{}",
            std::process::id(),
            SEQ.fetch_add(1, Ordering::Relaxed),
            name.strip_suffix(".zstd").unwrap_or(&name)
        )),
    };
    let mut dst =
        std::io::BufWriter::new(std::fs::File::create(&out.path).map_err(|e| io(&out.path, e))?);
    zstd::stream::copy_decode(std::io::BufReader::new(src), &mut dst).map_err(|e| {
        Error::BadChunk {
            path: path.display().to_string(),
            reason: format!("the zstd-compressed file does not decompress: {e}"),
        }
    })?;
    use std::io::Write;
    dst.flush().map_err(|e| io(&out.path, e))?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The metadata of rosbag2's versions: 4 (Foxy, QoS as a string), 5 (files), 9 (Jazzy,
    /// QoS as a list), as `ros2 bag record` writes them.
    #[test]
    fn metadata_of_each_version_parses() {
        let v4 = "rosbag2_bagfile_information:\n  version: 4\n  storage_identifier: sqlite3\n  \
                  relative_file_paths:\n    - rec_0.db3\n    - rec_1.db3\n  duration:\n    \
                  nanoseconds: 5\n  starting_time:\n    nanoseconds_since_epoch: 1\n  \
                  message_count: 3\n  topics_with_message_count:\n    - topic_metadata:\n        \
                  name: /joint_states\n        type: sensor_msgs/msg/JointState\n        \
                  serialization_format: cdr\n        offered_qos_profiles: \"- history: 3\\n\"\n      \
                  message_count: 3\n  compression_format: \"\"\n  compression_mode: \"\"\n";
        let m = parse_metadata(v4).unwrap();
        assert_eq!(m.version, 4);
        assert_eq!(m.relative_file_paths, ["rec_0.db3", "rec_1.db3"]);
        assert_eq!(
            m.topics_with_message_count[0].topic_metadata.name,
            "/joint_states"
        );
        let v9 = "rosbag2_bagfile_information:\n  version: 9\n  storage_identifier: mcap\n  \
                  duration:\n    nanoseconds: 5\n  starting_time:\n    nanoseconds_since_epoch: 1\n  \
                  message_count: 0\n  topics_with_message_count:\n    - topic_metadata:\n        \
                  name: /a\n        type: std_msgs/msg/String\n        serialization_format: cdr\n        \
                  offered_qos_profiles:\n          - history: keep_last\n            depth: 10\n        \
                  type_description_hash: RIHS01_abc\n      message_count: 0\n  \
                  compression_format: zstd\n  compression_mode: FILE\n  relative_file_paths:\n    \
                  - b_0.mcap.zstd\n  files:\n    - path: b_0.mcap.zstd\n      starting_time:\n        \
                  nanoseconds_since_epoch: 1\n      duration:\n        nanoseconds: 5\n      \
                  message_count: 0\n  custom_data: ~\n  ros_distro: jazzy\n";
        let m = parse_metadata(v9).unwrap();
        assert_eq!((m.version, m.compression_mode.as_str()), (9, "FILE"));
        assert_eq!(m.relative_file_paths, ["b_0.mcap.zstd"]);
        assert!(parse_metadata("version: 9\n").is_err());
    }

    #[test]
    fn storage_is_recognised_by_its_first_bytes() {
        assert_eq!(sniff(b"\x89MCAP0\r\nxx"), Storage::Mcap);
        assert_eq!(sniff(b"SQLite format 3\0"), Storage::Sqlite);
        assert_eq!(sniff(&[0x28, 0xb5, 0x2f, 0xfd, 0]), Storage::Zstd);
        assert_eq!(sniff(b"#ROSBAG V2.0\n"), Storage::Ros1);
        assert_eq!(sniff(b"#ROSBAG V1.2\n"), Storage::OldRos1);
        assert_eq!(sniff(b"hello"), Storage::Unknown);
    }
}
