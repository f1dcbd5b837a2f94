//! ROS 1 bags (`#ROSBAG V2.0`) streamed in file order ([`super::ros1bag`]): the records are
//! walked with `pread`, chunks (uncompressed, bz2 or lz4) read into buffers reused window
//! after window and decompressed in parallel on the rayon pool, one buffer per chunk of the
//! window, so the resident set is bounded by the window whatever the file's size. Each
//! chunk's connection records define its topics (type `pkg/Name` taken as `pkg/msg/Name`,
//! serialization `ros1`), its messages go to the same interpretation as an MCAP file's
//! ([`Context::message`], ROS 1 serialization read by [`crate::ros1`]); index records are
//! not needed and are read only to count what a damaged chunk held.
//!
//! Nothing is lost silently: a bag cut short (its recorder killed: the last chunk partial,
//! no index section) yields every complete message before the cut, those of the cut chunk
//! included (as far as its data decompresses), and the cut is a `truncated` loss naming its
//! byte range; a chunk that does not decompress or parse is skipped and reported (with the
//! messages per topic its index records say it held), and reading goes on at the next record;
//! a record that cannot be read at all is skipped to the next intact one found by scanning.

use std::os::unix::fs::FileExt;
use std::path::Path;

use mcap::records::MessageHeader;
use rayon::prelude::*;

use super::ros1bag::{self, At, Bag1, Inner};
use super::*;

/// Bytes of chunks (compressed and decompressed) read per window, per thread of the pool.
const WINDOW_BYTES_PER_THREAD: usize = 8 << 20;

/// `pkg/Name` (ROS 1) as `pkg/msg/Name` (ROS 2, the rig's schemas).
pub fn ros2_type(tp: &str) -> String {
    match tp.split_once('/') {
        Some((pkg, name)) if !name.contains('/') => format!("{pkg}/msg/{name}"),
        _ => tp.to_string(),
    }
}

/// A chunk (or a message record outside any chunk) of the window, its buffers reused.
#[derive(Default)]
struct Slot {
    /// The record's offset and size in the file.
    at: u64,
    bytes: u64,
    compression: Vec<u8>,
    /// Bytes uncompressed, as the chunk says.
    size: u64,
    raw: Vec<u8>,
    plain: Vec<u8>,
    /// The file is cut inside it.
    partial: bool,
    err: Option<String>,
    /// What its index data records say it holds: connection, messages.
    index: Vec<(u32, u64)>,
}

impl Slot {
    fn data(&self) -> &[u8] {
        if self.compression == b"none" {
            &self.raw
        } else {
            &self.plain
        }
    }

    fn decompress(&mut self) {
        self.err = if self.compression == b"none" {
            (!self.partial && self.raw.len() as u64 != self.size).then(|| {
                format!(
                    "it holds {} bytes, not the {} it claims",
                    self.raw.len(),
                    self.size
                )
            })
        } else {
            ros1bag::decompress(
                &self.compression,
                &self.raw,
                self.size,
                &mut self.plain,
                self.partial,
            )
            .err()
        };
    }
}

/// The walk's state: what is known of the bag and what was read.
struct Reader<'a, 'r> {
    ctx: &'a Context<'r>,
    reg: Registry,
    /// Connection ids to the registry's dense ids.
    ids: HashMap<u32, u16>,
    topics: HashMap<u32, String>,
    tables: Tables,
    report: Report,
    /// Losses of chunks whose messages are counted from their index records: loss, counts.
    counted: Vec<(usize, Vec<(u32, u64)>)>,
    undefined: u64,
    frames: u64,
}

impl Reader<'_, '_> {
    fn connection(&mut self, c: ros1bag::Connection) {
        let n = self.ids.len();
        let k = *self
            .ids
            .entry(c.id)
            .or_insert_with(|| u16::try_from(n + 1).unwrap_or(u16::MAX));
        self.reg.add_schema(k, &ros2_type(&c.tp));
        self.reg.add_channel(
            k,
            ChannelInfo {
                topic: c.topic.clone(),
                schema_id: k,
                encoding: "ros1".into(),
            },
        );
        self.topics.insert(c.id, c.topic);
    }

    /// Decompress the window's chunks in parallel, then read their records in order and
    /// interpret their messages on the pool.
    fn flush(&mut self, slots: &mut [Slot]) {
        if slots.len() > 1 && rayon::current_num_threads() > 1 {
            slots.par_iter_mut().for_each(Slot::decompress);
        } else {
            slots.iter_mut().for_each(Slot::decompress);
        }
        let mut msgs: Vec<(MessageHeader, &[u8])> = Vec::new();
        for s in slots.iter() {
            let (from, to) = (s.at, s.at + s.bytes);
            if let Some(e) = &s.err {
                self.counted
                    .push((self.report.losses.len(), s.index.clone()));
                self.report.losses.push(Loss::new(
                    "corrupt_chunk",
                    from,
                    s.bytes,
                    format!(
                        "the chunk at bytes {from}..{to} cannot be read ({e}): its messages are \
                         lost; reading goes on at the next record"
                    ),
                ));
                continue;
            }
            let before = msgs.len();
            for rec in ros1bag::inner_records(s.data()) {
                match rec {
                    Ok((_, Inner::Connection(c))) => self.connection(c),
                    Ok((_, Inner::Message { conn, time, data })) => match self.ids.get(&conn) {
                        Some(&k) => msgs.push((
                            MessageHeader {
                                channel_id: k,
                                sequence: 0,
                                log_time: time,
                                publish_time: time,
                            },
                            data,
                        )),
                        None => self.undefined += 1,
                    },
                    Ok((_, Inner::Other)) => {}
                    Err((_, None)) if s.partial => {}
                    Err((off, why)) => {
                        let why = why.unwrap_or_else(|| "it runs past the chunk's data".into());
                        self.report.losses.push(Loss::new(
                            "corrupt_chunk",
                            from,
                            s.bytes,
                            format!(
                                "the chunk at bytes {from}..{to}: the record at byte {off} of \
                                 its data cannot be read ({why}); the chunk's records before it \
                                 were read, those after it are lost"
                            ),
                        ));
                        break;
                    }
                }
            }
            if s.partial {
                self.report.recovered_messages += (msgs.len() - before) as u64;
            }
        }
        let ctx = self.ctx;
        let reg = &self.reg;
        let unit = |m: &[(MessageHeader, &[u8])]| ctx.run(reg, &Work::Loose(m.to_vec()), None);
        let threads = rayon::current_num_threads();
        let parts: Vec<Part> = if threads <= 1 || msgs.len() < 2 {
            vec![unit(&msgs)]
        } else {
            let per = msgs.len().div_ceil(4 * threads).max(1);
            msgs.par_chunks(per).map(unit).collect()
        };
        for p in &parts {
            self.frames += p.tables.frames.t_ns.len() as u64;
            self.undefined += p.deferred.len() as u64;
            self.tables.append(&p.tables);
            self.report.merge(&p.report);
        }
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
    let bag = Bag1::open(path)
        .map_err(|source| Error::Io {
            path: name.to_string(),
            source,
        })?
        .map_err(|e| Error::BadBag {
            path: name.to_string(),
            reason: format!("not a readable ROS 1 bag: {e}"),
        })?;
    let len = bag.len;
    let ctx = Context::new(rig, opts.spot.clone(), None, None);
    let mut rd = Reader {
        ctx: &ctx,
        reg: Registry::default(),
        ids: HashMap::new(),
        topics: HashMap::new(),
        tables: Tables::default(),
        report: Report {
            file_bytes: len,
            ..Report::default()
        },
        counted: Vec::new(),
        undefined: 0,
        frames: 0,
    };
    let threads = rayon::current_num_threads().max(1);
    let budget = (WINDOW_BYTES_PER_THREAD * threads).min(opts.window_bytes.max(1));
    let mut slots: Vec<Slot> = Vec::new();
    let (mut used, mut held) = (0usize, 0usize);
    let mut hbuf = Vec::new();
    let mut at = bag.first;
    let mut cut = false;
    let read_err = |at: u64, source| Error::Io {
        path: format!("{name} (byte {at})"),
        source,
    };
    loop {
        match bag.record_at(at, &mut hbuf) {
            At::Record(r) => {
                match r.header.op {
                    Some(ros1bag::OP_CHUNK) | Some(ros1bag::OP_MSG_DATA) => {
                        // The window is run when full, before the next chunk: the index
                        // records after its last chunk have been read by then.
                        if held >= budget {
                            rd.flush(&mut slots[..used]);
                            (used, held) = (0, 0);
                            release(&mut slots, budget);
                            if !progress(r.at, len, rd.frames) {
                                return Err(Error::Interrupted);
                            }
                        }
                        let i = next_slot(&mut slots, &mut used);
                        let s = &mut slots[i];
                        s.at = r.at;
                        s.bytes = r.end() - r.at;
                        s.partial = false;
                        s.index.clear();
                        s.compression.clear();
                        if r.header.op == Some(ros1bag::OP_CHUNK) {
                            rd.report.chunks += 1;
                            s.compression.extend_from_slice(
                                r.header.compression.as_deref().unwrap_or(b"(none given)"),
                            );
                            s.size = r.header.size.map_or(u64::MAX, u64::from);
                            s.raw.resize(r.data_len as usize, 0);
                            bag.file
                                .read_exact_at(&mut s.raw, r.data_at)
                                .map_err(|e| read_err(r.data_at, e))?;
                        } else {
                            // A message outside any chunk: read as a chunk of one record.
                            s.compression.extend_from_slice(b"none");
                            s.raw.resize(s.bytes as usize, 0);
                            s.size = s.bytes;
                            bag.file
                                .read_exact_at(&mut s.raw, r.at)
                                .map_err(|e| read_err(r.at, e))?;
                        }
                        held += s.raw.len() + s.size.min(MAX_CHUNK_BYTES) as usize;
                    }
                    Some(ros1bag::OP_CONNECTION) => {
                        let mut data = vec![0u8; r.data_len as usize];
                        bag.file
                            .read_exact_at(&mut data, r.data_at)
                            .map_err(|e| read_err(r.data_at, e))?;
                        match ros1bag::Connection::parse(&r.header, &data) {
                            Ok(c) => rd.connection(c),
                            Err(e) => rd.report.losses.push(Loss::new(
                                "corrupt_record",
                                r.at,
                                r.end() - r.at,
                                format!(
                                    "the connection record at bytes {}..{} cannot be read: {e}",
                                    r.at,
                                    r.end()
                                ),
                            )),
                        }
                    }
                    Some(ros1bag::OP_INDEX_DATA) => {
                        if let (Some(s), Some(conn), Some(n)) = (
                            used.checked_sub(1).map(|i| &mut slots[i]),
                            r.header.conn,
                            r.header.count,
                        ) {
                            s.index.push((conn, u64::from(n)));
                        }
                    }
                    _ => {}
                }
                at = r.end();
            }
            At::Cut {
                header,
                data_at,
                data_len,
            } => {
                if at >= len {
                    break;
                }
                cut = true;
                let mut detail = format!(
                    "the bag is cut short (its recorder stopped before closing it): the record \
                     at byte {at} is incomplete ({} of its bytes present, bytes {at}..{len} lost)",
                    len - at
                );
                if let Some(h) = header.filter(|h| h.op == Some(ros1bag::OP_CHUNK)) {
                    if data_at < len {
                        rd.report.chunks += 1;
                        let i = next_slot(&mut slots, &mut used);
                        let s = &mut slots[i];
                        s.at = at;
                        s.bytes = len - at;
                        s.partial = true;
                        s.index.clear();
                        s.compression.clear();
                        s.compression
                            .extend_from_slice(h.compression.as_deref().unwrap_or(b""));
                        s.size = h.size.map_or(u64::MAX, u64::from);
                        s.raw.resize((len - data_at).min(data_len) as usize, 0);
                        bag.file
                            .read_exact_at(&mut s.raw, data_at)
                            .map_err(|e| read_err(data_at, e))?;
                        detail.push_str(
                            "; complete messages in the cut chunk are recovered, as far as its \
                             data decompresses",
                        );
                    }
                }
                rd.report
                    .losses
                    .push(Loss::new("truncated", at, len - at, detail));
                break;
            }
            At::Bad(why) => {
                let next = bag.resync(at + 1, &mut hbuf);
                let to = next.unwrap_or(len);
                rd.report.losses.push(Loss::new(
                    "corrupt_record",
                    at,
                    to - at,
                    format!(
                        "bytes {at}..{to} are not readable records ({why}): skipped{}",
                        if next.is_some() {
                            ", reading goes on at the next intact record"
                        } else {
                            ", no intact record after them"
                        }
                    ),
                ));
                match next {
                    Some(n) => at = n,
                    None => break,
                }
            }
        }
    }
    rd.flush(&mut slots[..used]);
    drop(slots);
    if !cut && !bag.indexed() {
        rd.report.losses.push(Loss::new(
            "truncated",
            len,
            0,
            format!(
                "the bag ends at byte {len} without its index section (its recorder stopped \
                 before closing it): every record before the end was read; what the recorder \
                 held after it is lost"
            ),
        ));
    }
    for (i, counts) in std::mem::take(&mut rd.counted) {
        for (conn, n) in counts {
            let topic = rd
                .topics
                .get(&conn)
                .cloned()
                .unwrap_or_else(|| format!("(connection {conn})"));
            *rd.report.losses[i].messages_lost.entry(topic).or_insert(0) += n;
        }
    }
    if rd.undefined > 0 {
        rd.report.losses.push(Loss::new(
            "undefined_channel",
            0,
            0,
            format!(
                "{} messages on connections the bag does not define",
                rd.undefined
            ),
        ));
    }
    let present: Vec<&str> = rd.reg.channels.values().map(|c| c.topic.as_str()).collect();
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
    if !progress(len, len, rd.frames) {
        return Err(Error::Interrupted);
    }
    let (tables, mut report) = (rd.tables, rd.report);
    if opts.content_hash {
        report.content_hash = Some(crate::digest::content_hash(path)?);
    }
    Ok((tables, report))
}

/// The next free slot of the window (a new one if every slot is in use).
fn next_slot(slots: &mut Vec<Slot>, used: &mut usize) -> usize {
    if *used == slots.len() {
        slots.push(Slot::default());
    }
    *used += 1;
    *used - 1
}

/// Free the window's buffers if they hold more than a few windows' worth (chunks of very
/// different sizes in turn could otherwise leave every slot as large as the largest chunk).
fn release(slots: &mut Vec<Slot>, budget: usize) {
    let held: usize = slots
        .iter()
        .map(|s| s.raw.capacity() + s.plain.capacity())
        .sum();
    if held > 4 * budget {
        slots.clear();
    }
}
