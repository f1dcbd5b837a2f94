//! ROS 1 bags (`#ROSBAG V2.0`): read with the `rosbag` crate (chunks uncompressed, bz2 or
//! lz4, decompressed by it one at a time); each chunk's connection records define its
//! topics (type `pkg/Name` taken as `pkg/msg/Name`, serialization `ros1`), its messages go to
//! the same interpretation as an MCAP file's ([`Context::message`], ROS 1 serialization read
//! by [`crate::ros1`]) on the rayon pool. A chunk that cannot be read is a loss; the walk
//! stops there (the crate's iterator cannot resume past it).

use std::path::Path;

use mcap::records::MessageHeader;
use rayon::prelude::*;
use rosbag::{ChunkRecord, MessageRecord, RosBag};

use super::*;

/// `pkg/Name` (ROS 1) as `pkg/msg/Name` (ROS 2, the rig's schemas).
pub fn ros2_type(tp: &str) -> String {
    match tp.split_once('/') {
        Some((pkg, name)) if !name.contains('/') => format!("{pkg}/msg/{name}"),
        _ => tp.to_string(),
    }
}

/// Extract every table of the ROS 1 bag at `path` (named `name` in messages).
pub(super) fn extract_ros1(
    path: &Path,
    name: &str,
    rig: &Rig,
    opts: &ExtractOptions,
    progress: &ProgressFn<'_>,
) -> Result<(Tables, Report)> {
    let bag = RosBag::new(path).map_err(|e| Error::BadBag {
        path: name.to_string(),
        reason: format!("not a readable ROS 1 bag (its header or index): {e}"),
    })?;
    let len = std::fs::metadata(path)
        .map_err(|source| Error::Io {
            path: name.to_string(),
            source,
        })?
        .len();
    let n_chunks = u64::from(bag.get_chunk_count()).max(1);
    let ctx = Context::new(rig, opts.spot.clone(), None, None);
    let mut reg = Registry::default();
    let mut ids: HashMap<u32, u16> = HashMap::new();
    let mut report = Report {
        file_bytes: len,
        ..Report::default()
    };
    let mut tables = Tables::default();
    let (mut frames_done, mut undefined) = (0u64, 0u64);
    for rec in bag.chunk_records() {
        let chunk = match rec {
            Ok(ChunkRecord::Chunk(c)) => c,
            Ok(ChunkRecord::IndexData(_)) => continue,
            Err(e) => {
                report.losses.push(Loss::new(
                    "corrupt_chunk",
                    0,
                    0,
                    format!(
                        "chunk {} of {n_chunks} cannot be read ({e}): it and the chunks after \
                         it are lost",
                        report.chunks + 1
                    ),
                ));
                break;
            }
        };
        report.chunks += 1;
        let mut msgs: Vec<(MessageHeader, &[u8])> = Vec::new();
        for m in chunk.messages() {
            match m {
                Ok(MessageRecord::Connection(c)) => {
                    let k = match ids.get(&c.id) {
                        Some(&k) => k,
                        None => {
                            let k = u16::try_from(ids.len() + 1).unwrap_or(u16::MAX);
                            ids.insert(c.id, k);
                            k
                        }
                    };
                    reg.add_schema(k, &ros2_type(c.tp));
                    reg.add_channel(
                        k,
                        ChannelInfo {
                            topic: c.topic.to_string(),
                            schema_id: k,
                            encoding: "ros1".into(),
                        },
                    );
                }
                Ok(MessageRecord::MessageData(d)) => match ids.get(&d.conn_id) {
                    Some(&k) => msgs.push((
                        MessageHeader {
                            channel_id: k,
                            sequence: 0,
                            log_time: d.time,
                            publish_time: d.time,
                        },
                        d.data,
                    )),
                    None => undefined += 1,
                },
                Err(e) => {
                    report.losses.push(Loss::new(
                        "corrupt_chunk",
                        0,
                        0,
                        format!(
                            "chunk {} of {n_chunks}: a record cannot be read ({e}); the \
                             chunk's records after it are lost",
                            report.chunks
                        ),
                    ));
                    break;
                }
            }
        }
        let threads = rayon::current_num_threads();
        let unit = |m: &[(MessageHeader, &[u8])]| ctx.run(&reg, &Work::Loose(m.to_vec()), None);
        let parts: Vec<Part> = if threads <= 1 || msgs.len() < 2 {
            vec![unit(&msgs)]
        } else {
            let per = msgs.len().div_ceil(4 * threads).max(1);
            msgs.par_chunks(per).map(unit).collect()
        };
        for p in &parts {
            frames_done += p.tables.frames.t_ns.len() as u64;
            undefined += p.deferred.len() as u64;
            tables.append(&p.tables);
            report.merge(&p.report);
        }
        if !progress(
            len * report.chunks.min(n_chunks) / n_chunks,
            len,
            frames_done,
        ) {
            return Err(Error::Interrupted);
        }
    }
    if undefined > 0 {
        report.losses.push(Loss::new(
            "undefined_channel",
            0,
            0,
            format!("{undefined} messages on connections the bag does not define"),
        ));
    }
    let present: Vec<&str> = reg.channels.values().map(|c| c.topic.as_str()).collect();
    let wanted = ctx.rig_topics();
    if !wanted.iter().any(|t| present.contains(t)) {
        let mut have: Vec<String> = present.iter().map(|t| t.to_string()).collect();
        have.sort_unstable();
        have.dedup();
        return Err(Error::NoRigTopics {
            path: name.to_string(),
            topics: wanted.iter().map(|t| t.to_string()).collect(),
            present: have,
        });
    }
    if opts.content_hash {
        report.content_hash = Some(crate::digest::content_hash(path)?);
    }
    Ok((tables, report))
}
