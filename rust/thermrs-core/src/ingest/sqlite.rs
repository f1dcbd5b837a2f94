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
    let conn = open(path, &bad)?;
    let mut ctx = Context::new(rig, opts.spot.clone(), None, None);
    ctx.verify_crc = opts.verify_crc;
    // Topics: SQLite ids (any integer) to the registry's dense ids.
    let mut reg = Registry::default();
    let mut cur = Cursor::default();
    let dense = |_: i64, known: usize| u16::try_from(known + 1).ok();
    read_topics(&conn, name, &ctx, &mut reg, &mut cur, &dense, &bad)?;
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
    let read = read_messages(
        &conn,
        &ctx,
        &reg,
        &mut cur,
        opts,
        (len, max_id),
        progress,
        &bad,
    )?;
    let mut report = read.report;
    report.file_bytes = len;
    if opts.content_hash {
        report.content_hash = Some(crate::digest::content_hash(path)?);
    }
    Ok((read.tables, report))
}

/// Where a read of a database's messages stands: the registry of its topics (rosbag2's topic
/// ids to the registry's ids) and the last message row read.
#[derive(Debug, Clone, Default)]
pub(super) struct Cursor {
    /// Registry ids by rosbag2 topic id.
    pub ids: HashMap<i64, u16>,
    /// Whether each topic is one of the rig's.
    pub wanted: HashMap<i64, bool>,
    /// The `id` of the last message row read (0: none).
    pub last_id: i64,
}

/// What [`read_messages`] read.
pub(super) struct Read {
    pub tables: Tables,
    pub report: Report,
    /// Bytes of the `data` column of the rows read (every topic's).
    pub data_bytes: u64,
}

/// Open the database at `path` read-only, leaving a writer undisturbed: no lock is taken
/// beyond the shared lock of each batch's query, and a lock held by a writer committing is
/// waited for (up to a few seconds) instead of failing.
pub(super) fn open(path: &Path, bad: &dyn Fn(rusqlite::Error) -> Error) -> Result<Connection> {
    let conn = Connection::open_with_flags(
        path,
        OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX,
    )
    .map_err(bad)?;
    conn.busy_timeout(std::time::Duration::from_secs(5))
        .map_err(bad)?;
    Ok(conn)
}

/// Add the topics of the `topics` table not in `cur` yet to `reg`. `id_of` gives a new
/// topic's registry id from its rosbag2 id and the number of topics known.
pub(super) fn read_topics(
    conn: &Connection,
    name: &str,
    ctx: &Context<'_>,
    reg: &mut Registry,
    cur: &mut Cursor,
    id_of: &dyn Fn(i64, usize) -> Option<u16>,
    bad: &dyn Fn(rusqlite::Error) -> Error,
) -> Result<()> {
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
        if cur.ids.contains_key(&id) {
            continue;
        }
        let k = id_of(id, cur.ids.len()).ok_or_else(|| Error::BadBag {
            path: name.to_string(),
            reason: format!("topic id {id}: more than 65535 topics, or an id out of 1..=65535"),
        })?;
        cur.ids.insert(id, k);
        cur.wanted
            .insert(id, ctx.roles.contains_key(topic.as_str()));
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
    Ok(())
}

/// Read the message rows whose `id` is above `cur.last_id`, in `id` order, in batches: each
/// batch's rows are fetched by a query of its own (its shared lock released before the batch
/// is interpreted, so that a writer is held up no longer than a fetch), their messages
/// interpreted on the pool. `progress` is given the fraction of `len` that the ids read stand
/// for, of the ids up to `max_id`. A row that cannot be read ends the read with a loss
/// (`cur.last_id`: the last row read before it).
#[allow(clippy::too_many_arguments)]
pub(super) fn read_messages(
    conn: &Connection,
    ctx: &Context<'_>,
    reg: &Registry,
    cur: &mut Cursor,
    opts: &ExtractOptions,
    (len, max_id): (u64, i64),
    progress: &ProgressFn<'_>,
    bad: &dyn Fn(rusqlite::Error) -> Error,
) -> Result<Read> {
    let mut st = conn
        .prepare(
            "SELECT id, topic_id, timestamp, length(data) FROM messages WHERE id > ?1 \
             ORDER BY id LIMIT ?2",
        )
        .map_err(bad)?;
    let mut out = Read {
        tables: Tables::default(),
        report: Report::default(),
        data_bytes: 0,
    };
    // A batch's messages, their bytes one after another in `arena` (reused batch to batch:
    // no allocation per message, and the bytes copied once, by SQLite's blob reader).
    let mut batch: Vec<(MessageHeader, std::ops::Range<usize>)> = Vec::new();
    let mut arena: Vec<u8> = Vec::new();
    let threads = rayon::current_num_threads().max(1);
    let batch_bytes = (BATCH_BYTES_PER_THREAD * threads).min(opts.window_bytes);
    let mut frames_done = 0u64;
    let mut undefined = 0u64;
    let start_id = cur.last_id;
    loop {
        let mut rows = st
            .query(rusqlite::params![cur.last_id, BATCH_MESSAGES as i64])
            .map_err(bad)?;
        let mut fetched = 0usize;
        let mut failed = None;
        loop {
            let row = match rows.next() {
                Ok(Some(r)) => r,
                Ok(None) => break,
                Err(e) => {
                    failed = Some(e);
                    break;
                }
            };
            fetched += 1;
            let got = (|| -> rusqlite::Result<(i64, u64, Option<MessageHeader>)> {
                let id: i64 = row.get(0)?;
                let topic_id: i64 = row.get(1)?;
                let n = u64::try_from(row.get::<_, Option<i64>>(3)?.unwrap_or(0)).unwrap_or(0);
                match cur.wanted.get(&topic_id) {
                    None => {
                        undefined += 1;
                        Ok((id, n, None))
                    }
                    Some(false) => {
                        out.report.other_messages += 1;
                        Ok((id, n, None))
                    }
                    Some(true) => {
                        let ts: i64 = row.get(2)?;
                        let from = arena.len();
                        arena.resize(from + n as usize, 0);
                        if n > 0 {
                            let blob = conn.blob_open("main", "messages", "data", id, true)?;
                            if let Err(e) = blob.read_at_exact(&mut arena[from..], 0) {
                                arena.truncate(from);
                                return Err(e);
                            }
                        }
                        let h = MessageHeader {
                            channel_id: cur.ids[&topic_id],
                            sequence: 0,
                            log_time: ts as u64,
                            publish_time: ts as u64,
                        };
                        Ok((id, n, Some(h)))
                    }
                }
            })();
            match got {
                Ok((id, n, h)) => {
                    cur.last_id = id;
                    out.data_bytes += n;
                    if let Some(h) = h {
                        let from = batch.last().map_or(0, |b| b.1.end);
                        batch.push((h, from..arena.len()));
                    }
                }
                Err(e) => {
                    failed = Some(e);
                    break;
                }
            }
            if arena.len() >= batch_bytes {
                break;
            }
        }
        drop(rows);
        frames_done += run_batch(ctx, reg, &batch, &arena, &mut out.tables, &mut out.report);
        batch.clear();
        arena.clear();
        if let Some(e) = failed {
            let last = cur.last_id;
            out.report.losses.push(Loss::new(
                "corrupt_database",
                0,
                0,
                format!(
                    "the SQLite database cannot be read after message id {last} (of {max_id}): \
                     {e}; the messages up to it were read, the rest are lost"
                ),
            ));
            break;
        }
        if fetched == 0 {
            break;
        }
        let done = if max_id > start_id {
            (len as f64 * (cur.last_id - start_id) as f64 / (max_id - start_id) as f64) as u64
        } else {
            len
        };
        if !progress(done.min(len), len, frames_done) {
            return Err(Error::Interrupted);
        }
    }
    if undefined > 0 {
        out.report.losses.push(Loss::new(
            "undefined_channel",
            0,
            0,
            format!("{undefined} messages on topic ids the topics table does not define"),
        ));
    }
    if !progress(len, len, frames_done) {
        return Err(Error::Interrupted);
    }
    Ok(out)
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
