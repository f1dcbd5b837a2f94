//! rosbag2's SQLite storage (`.db3`): the `topics` table gives each topic's name, type and
//! serialization format, the `messages` table the messages (`topic_id`, `timestamp` (the
//! receive time, standing for MCAP's log time), `data`: the CDR bytes, or with rosbag2's
//! message compression a zstd frame of them, recognised by its magic). Read with SQLite
//! (`rusqlite`, the library bundled) in insertion order; the messages of the rig's topics go
//! to the same interpretation as an MCAP file's ([`Context::message`]) in batches run on the
//! rayon pool; other topics are counted without reading their bytes.
//!
//! A database damaged part way keeps every message read before the damage and reports the
//! rest as a loss; one whose tables cannot be read at all is an error.

use std::path::Path;

use mcap::records::MessageHeader;
use rayon::prelude::*;
use rusqlite::{Connection, OpenFlags};

use super::*;

/// Message bytes per batch, per thread of the pool: small enough that the batch's buffer,
/// filled and emptied batch after batch, stays in the caches and costs no page faults.
const BATCH_BYTES_PER_THREAD: usize = 4 << 20;
/// Messages per batch at most (small messages: joint states).
const BATCH_MESSAGES: usize = 1024;

/// Extract every table of the rosbag2 SQLite database at `path` (named `name` in messages).
pub(super) fn extract_sqlite(
    path: &Path,
    name: &str,
    rig: &Rig,
    opts: &ExtractOptions,
    progress: &ProgressFn<'_>,
) -> Result<(Tables, Report)> {
    let len = std::fs::metadata(path)
        .map_err(|source| Error::Io {
            path: name.to_string(),
            source,
        })?
        .len();
    let bad = |e: rusqlite::Error| Error::BadBag {
        path: name.to_string(),
        reason: format!("its SQLite database cannot be read as a rosbag2 bag: {e}"),
    };
    let conn = Connection::open_with_flags(
        path,
        OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX,
    )
    .map_err(bad)?;
    let mut ctx = Context::new(rig, opts.spot.clone(), None, None);
    ctx.verify_crc = opts.verify_crc;
    // Topics: SQLite ids (any integer) to the registry's dense ids.
    let mut reg = Registry::default();
    let mut ids: HashMap<i64, u16> = HashMap::new();
    let mut wanted: HashMap<i64, bool> = HashMap::new();
    {
        let mut st = conn
            .prepare("SELECT id, name, type, serialization_format FROM topics ORDER BY id")
            .map_err(bad)?;
        let rows = st
            .query_map([], |r| {
                Ok((
                    r.get::<_, i64>(0)?,
                    r.get::<_, String>(1)?,
                    r.get::<_, String>(2)?,
                    r.get::<_, String>(3)?,
                ))
            })
            .map_err(bad)?;
        for row in rows {
            let (id, topic, type_name, format) = row.map_err(bad)?;
            let k = u16::try_from(ids.len() + 1).map_err(|_| Error::BadBag {
                path: name.to_string(),
                reason: "more than 65535 topics".into(),
            })?;
            ids.insert(id, k);
            wanted.insert(id, ctx.roles.contains_key(topic.as_str()));
            reg.add_schema(k, &type_name);
            reg.add_channel(
                k,
                ChannelInfo {
                    topic,
                    schema_id: k,
                    encoding: format,
                },
            );
        }
    }
    let mut report = Report {
        file_bytes: len,
        ..Report::default()
    };
    let mut tables = Tables::default();
    let present: Vec<&str> = reg.channels.values().map(|c| c.topic.as_str()).collect();
    let rig_topics = ctx.rig_topics();
    if !rig_topics.iter().any(|t| present.contains(t)) {
        let mut have: Vec<String> = present.iter().map(|t| t.to_string()).collect();
        have.sort_unstable();
        return Err(Error::NoRigTopics {
            path: name.to_string(),
            topics: rig_topics.iter().map(|t| t.to_string()).collect(),
            present: have,
        });
    }
    let max_id: i64 = conn
        .query_row("SELECT COALESCE(MAX(id), 0) FROM messages", [], |r| {
            r.get(0)
        })
        .map_err(bad)?;
    let mut st = conn
        .prepare("SELECT id, topic_id, timestamp, length(data) FROM messages ORDER BY id")
        .map_err(bad)?;
    let mut rows = st.query([]).map_err(bad)?;
    // A batch's messages, their bytes one after another in `arena` (reused batch to batch:
    // no allocation per message, and the bytes copied once, by SQLite's blob reader).
    let mut batch: Vec<(MessageHeader, std::ops::Range<usize>)> = Vec::new();
    let mut arena: Vec<u8> = Vec::new();
    let threads = rayon::current_num_threads().max(1);
    let batch_bytes = (BATCH_BYTES_PER_THREAD * threads).min(opts.window_bytes);
    let mut frames_done = 0u64;
    let mut last_id = 0i64;
    let mut undefined = 0u64;
    loop {
        let row = match rows.next() {
            Ok(Some(r)) => r,
            Ok(None) => break,
            Err(e) => {
                report.losses.push(Loss::new(
                    "corrupt_database",
                    0,
                    0,
                    format!(
                        "the SQLite database is damaged after message id {last_id} of \
                         {max_id}: {e}; the messages before it were read, the rest are lost"
                    ),
                ));
                break;
            }
        };
        let got = (|| -> rusqlite::Result<Option<MessageHeader>> {
            let id: i64 = row.get(0)?;
            last_id = id;
            let topic_id: i64 = row.get(1)?;
            match wanted.get(&topic_id) {
                None => {
                    undefined += 1;
                    Ok(None)
                }
                Some(false) => {
                    report.other_messages += 1;
                    Ok(None)
                }
                Some(true) => {
                    let ts: i64 = row.get(2)?;
                    let n = usize::try_from(row.get::<_, i64>(3)?).unwrap_or(0);
                    let from = arena.len();
                    arena.resize(from + n, 0);
                    if n > 0 {
                        let blob = conn.blob_open("main", "messages", "data", id, true)?;
                        blob.read_at_exact(&mut arena[from..], 0)?;
                    }
                    let h = MessageHeader {
                        channel_id: ids[&topic_id],
                        sequence: 0,
                        log_time: ts as u64,
                        publish_time: ts as u64,
                    };
                    Ok(Some(h))
                }
            }
        })();
        match got {
            Ok(Some(h)) => {
                let from = batch.last().map_or(0, |b| b.1.end);
                batch.push((h, from..arena.len()));
            }
            Ok(None) => {}
            Err(e) => {
                report.losses.push(Loss::new(
                    "corrupt_database",
                    0,
                    0,
                    format!(
                        "message id {last_id} of the SQLite database cannot be read: {e}; \
                         the messages before it were read, the rest are lost"
                    ),
                ));
                break;
            }
        }
        if arena.len() >= batch_bytes || batch.len() >= BATCH_MESSAGES {
            frames_done += run_batch(&ctx, &reg, &batch, &arena, &mut tables, &mut report);
            batch.clear();
            arena.clear();
            let done = if max_id > 0 {
                (len as f64 * last_id as f64 / max_id as f64) as u64
            } else {
                len
            };
            if !progress(done.min(len), len, frames_done) {
                return Err(Error::Interrupted);
            }
        }
    }
    frames_done += run_batch(&ctx, &reg, &batch, &arena, &mut tables, &mut report);
    if undefined > 0 {
        report.losses.push(Loss::new(
            "undefined_channel",
            0,
            0,
            format!("{undefined} messages on topic ids the topics table does not define"),
        ));
    }
    if !progress(len, len, frames_done) {
        return Err(Error::Interrupted);
    }
    if opts.content_hash {
        report.content_hash = Some(crate::digest::content_hash(path)?);
    }
    Ok((tables, report))
}

/// Interpret a batch of messages on the pool (four units of work per thread), merged in order.
/// Returns the CCD frames it held.
fn run_batch(
    ctx: &Context<'_>,
    reg: &Registry,
    batch: &[(MessageHeader, std::ops::Range<usize>)],
    arena: &[u8],
    tables: &mut Tables,
    report: &mut Report,
) -> u64 {
    let unit = |msgs: &[(MessageHeader, std::ops::Range<usize>)]| {
        let mut part = Part::default();
        let local = Registry::default();
        for (h, d) in msgs {
            ctx.message(reg, &local, h, &arena[d.clone()], &mut part);
        }
        part
    };
    let threads = rayon::current_num_threads();
    let parts: Vec<Part> = if threads <= 1 {
        vec![unit(batch)]
    } else {
        let per = batch.len().div_ceil(4 * threads).max(1);
        batch.par_chunks(per).map(unit).collect()
    };
    let mut frames = 0;
    for p in &parts {
        frames += p.tables.frames.t_ns.len() as u64;
        tables.append(&p.tables);
        report.merge(&p.report);
    }
    frames
}
