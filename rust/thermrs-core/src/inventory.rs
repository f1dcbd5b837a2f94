//! What a recording holds, read from its summary and indexes without decoding a message:
//! channels (topic, schema, encoding, message count), the time span, chunks and their
//! compression, Metadata records (run markers among them), and the log times of the topics
//! asked for (from the message indexes, so runs can be split at idle gaps), with what could
//! not be read.
//!
//! A file with a summary section is read from its footer, summary and message indexes: a
//! few reads whatever the file's size. A file without one (cut short, or written without a
//! summary) is walked record by record; its chunks stay compressed unless they lack message
//! indexes or hold a channel not yet seen (then that chunk alone is decompressed for its
//! channel records or its messages' times).

use std::borrow::Cow;
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use mcap::read::{ChunkReader, LinearReader, Summary};
use mcap::records::{self, Record};

use crate::error::{Error, Result};

/// One channel of a recording.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelInfo {
    /// The channel id.
    pub id: u16,
    /// The topic, e.g. `/ccd_a/image_raw`.
    pub topic: String,
    /// The schema name (`sensor_msgs/msg/Image`), empty without a schema.
    pub schema: String,
    /// The message encoding (`cdr`).
    pub encoding: String,
    /// How many messages the file holds on it.
    pub messages: u64,
}

/// What a recording holds (see the module docs).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Inventory {
    /// How it is stored: `mcap`, `sqlite3` (rosbag2's SQLite), either with ` (zstd file)`
    /// when compressed whole, or `bag of N files (…)` for a bag folder.
    pub storage: String,
    /// The file's size in bytes.
    pub bytes: u64,
    /// Whether it was read from its summary section (false: walked record by record).
    pub from_summary: bool,
    /// The MCAP header's profile and library.
    pub profile: String,
    pub library: String,
    /// Log time of the first and last message (ns), if any.
    pub start_ns: Option<u64>,
    pub end_ns: Option<u64>,
    /// Chunks, and the compressions they use.
    pub chunks: u64,
    pub compression: BTreeSet<String>,
    /// Messages in all.
    pub messages: u64,
    /// Every channel, by id.
    pub channels: Vec<ChannelInfo>,
    /// Metadata records: name and key/value pairs, in file order.
    pub metadata: Vec<(String, BTreeMap<String, String>)>,
    /// Attachments (name, bytes).
    pub attachments: Vec<(String, u64)>,
    /// Log times (ns) of the messages on each topic asked for, in time order.
    pub log_times: BTreeMap<String, Vec<u64>>,
    /// What could not be read, one line each (a file cut short, an index past its end).
    pub losses: Vec<String>,
    /// Chunks decompressed to learn channels or message times (0 on a summarised file).
    pub chunks_decompressed: u64,
    /// How the file was read where that is worth saying (a summary unreadable or leaving
    /// something out, so the data section was read instead); nothing was lost.
    pub notes: Vec<String>,
}

/// Read what the recording at `path` holds; `topics` are those whose messages' log times
/// are wanted (from the message indexes).
///
/// # Errors
/// [`Error::Io`] if the file cannot be opened or mapped; [`Error::NotMcap`] if it is not
/// an MCAP file.
pub fn inventory(path: &Path, topics: &[String]) -> Result<Inventory> {
    use crate::bag::Storage;
    if path.is_dir() {
        return bag_inventory(path, topics);
    }
    match crate::bag::storage_of(path)? {
        Storage::Sqlite => sqlite_inventory(path, topics),
        Storage::Zstd => {
            let plain = crate::bag::decompress_file(path)?;
            let mut inv = inventory(&plain.path, topics)?;
            inv.bytes = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
            inv.storage.push_str(" (zstd file)");
            let tmp = plain.path.display().to_string();
            for l in &mut inv.losses {
                *l = l.replace(&tmp, &path.display().to_string());
            }
            Ok(inv)
        }
        Storage::Ros1 => ros1_inventory(path, topics),
        Storage::OldRos1 => Err(crate::ingest::refused_old_ros1(path)),
        Storage::Mcap | Storage::Unknown => mcap_inventory(path, topics),
    }
}

/// [`inventory`] of a rosbag2 SQLite database: its `topics` table, and one pass over the
/// `messages` table's ids, topics and times (the message bytes are not read).
fn sqlite_inventory(path: &Path, topics: &[String]) -> Result<Inventory> {
    use rusqlite::{Connection, OpenFlags};
    let name = path.display().to_string();
    let bad = |e: rusqlite::Error| Error::BadBag {
        path: name.clone(),
        reason: format!("its SQLite database cannot be read as a rosbag2 bag: {e}"),
    };
    let len = std::fs::metadata(path)
        .map_err(|source| Error::Io {
            path: name.clone(),
            source,
        })?
        .len();
    let conn = Connection::open_with_flags(
        path,
        OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX,
    )
    .map_err(bad)?;
    let mut inv = Inventory {
        storage: "sqlite3".into(),
        bytes: len,
        profile: "ros2".into(),
        library: "rosbag2 sqlite3 storage".into(),
        ..Inventory::default()
    };
    let mut by_id: BTreeMap<i64, usize> = BTreeMap::new();
    {
        let mut st = conn
            .prepare("SELECT id, name, type, serialization_format FROM topics ORDER BY id")
            .map_err(bad)?;
        let mut rows = st.query([]).map_err(bad)?;
        while let Some(r) = rows.next().map_err(bad)? {
            let id: i64 = r.get(0).map_err(bad)?;
            by_id.insert(id, inv.channels.len());
            inv.channels.push(ChannelInfo {
                id: u16::try_from(inv.channels.len() + 1).unwrap_or(u16::MAX),
                topic: r.get(1).map_err(bad)?,
                schema: r.get(2).map_err(bad)?,
                encoding: r.get(3).map_err(bad)?,
                messages: 0,
            });
        }
    }
    let wanted: Vec<bool> = inv
        .channels
        .iter()
        .map(|c| topics.contains(&c.topic))
        .collect();
    let mut st = conn
        .prepare("SELECT topic_id, timestamp FROM messages")
        .map_err(bad)?;
    let mut rows = st.query([]).map_err(bad)?;
    loop {
        let r = match rows.next() {
            Ok(Some(r)) => r,
            Ok(None) => break,
            Err(e) => {
                inv.losses.push(format!(
                    "the SQLite database is damaged after {} messages: {e}",
                    inv.messages
                ));
                break;
            }
        };
        let (Ok(tid), Ok(ts)) = (r.get::<_, i64>(0), r.get::<_, i64>(1)) else {
            continue;
        };
        let ts = ts as u64;
        inv.messages += 1;
        inv.start_ns = Some(inv.start_ns.map_or(ts, |s| s.min(ts)));
        inv.end_ns = Some(inv.end_ns.map_or(ts, |e| e.max(ts)));
        if let Some(&k) = by_id.get(&tid) {
            inv.channels[k].messages += 1;
            if wanted[k] {
                inv.log_times
                    .entry(inv.channels[k].topic.clone())
                    .or_default()
                    .push(ts);
            }
        }
    }
    for times in inv.log_times.values_mut() {
        times.sort_unstable();
    }
    Ok(inv)
}

/// [`inventory`] of a ROS 1 bag: connections, counts and time span from its index section
/// (no chunk decompressed); the log times of `topics` from the index data records beside
/// each chunk ([`ros1_index_times`]). A bag without its index section (its recorder killed
/// before closing it) is walked whole instead ([`ros1_walk`]).
fn ros1_inventory(path: &Path, topics: &[String]) -> Result<Inventory> {
    use crate::ingest::ros1bag::{self, At, Bag1};
    let name = path.display().to_string();
    let bag = Bag1::open(path)
        .map_err(|source| Error::Io {
            path: name.clone(),
            source,
        })?
        .map_err(|e| Error::BadBag {
            path: name.clone(),
            reason: format!("not a readable ROS 1 bag: {e}"),
        })?;
    let mut inv = Inventory {
        storage: "ros1".into(),
        bytes: bag.len,
        from_summary: true,
        profile: "ros1".into(),
        library: "ROS 1 bag (#ROSBAG V2.0)".into(),
        ..Inventory::default()
    };
    if !bag.indexed() {
        inv.from_summary = false;
        ros1_walk(&bag, topics, &mut inv);
        return Ok(inv);
    }
    let mut by_conn: BTreeMap<u32, usize> = BTreeMap::new();
    let mut at = bag.index_pos;
    let mut buf = Vec::new();
    let mut data = Vec::new();
    let base = inv.clone();
    let mut failed = None;
    while at < bag.len {
        let r = match bag.record_at(at, &mut buf) {
            At::Record(r) => r,
            At::Cut { .. } => {
                failed = Some(format!("the record at byte {at} is cut"));
                break;
            }
            At::Bad(e) => {
                failed = Some(e);
                break;
            }
        };
        at = r.end();
        let op = r.header.op;
        if op != Some(ros1bag::OP_CONNECTION) && op != Some(ros1bag::OP_CHUNK_INFO) {
            continue;
        }
        data.resize(r.data_len as usize, 0);
        std::os::unix::fs::FileExt::read_exact_at(&bag.file, &mut data, r.data_at).map_err(
            |source| Error::Io {
                path: name.clone(),
                source,
            },
        )?;
        if op == Some(ros1bag::OP_CONNECTION) {
            let c = match ros1bag::Connection::parse(&r.header, &data) {
                Ok(c) => c,
                Err(e) => {
                    failed = Some(e);
                    break;
                }
            };
            if by_conn.contains_key(&c.id) {
                continue;
            }
            by_conn.insert(c.id, inv.channels.len());
            inv.channels.push(ChannelInfo {
                id: u16::try_from(inv.channels.len() + 1).unwrap_or(u16::MAX),
                topic: c.topic,
                schema: crate::ingest::ros2_type(&c.tp),
                encoding: "ros1".into(),
                messages: 0,
            });
        } else {
            inv.chunks += 1;
            if let (Some(s), Some(e)) = (r.header.start_time, r.header.end_time) {
                inv.start_ns = Some(inv.start_ns.map_or(s, |x| x.min(s)));
                inv.end_ns = Some(inv.end_ns.map_or(e, |x| x.max(e)));
            }
            for e in data.chunks_exact(8) {
                let conn = u32::from_le_bytes(e[..4].try_into().expect("4 bytes"));
                let n = u64::from(u32::from_le_bytes(e[4..].try_into().expect("4 bytes")));
                if let Some(&k) = by_conn.get(&conn) {
                    inv.channels[k].messages += n;
                }
                inv.messages += n;
            }
        }
    }
    if let Some(e) = failed {
        // Its messages may all be there: read them record by record.
        let mut inv = base;
        inv.from_summary = false;
        inv.notes.push(format!(
            "its index section cannot be read ({e}): the bag was read record by record"
        ));
        ros1_walk(&bag, topics, &mut inv);
        return Ok(inv);
    }
    let wanted: BTreeMap<u32, String> = by_conn
        .iter()
        .filter(|(_, &k)| topics.contains(&inv.channels[k].topic))
        .map(|(&id, &k)| (id, inv.channels[k].topic.clone()))
        .collect();
    if !wanted.is_empty() {
        match ros1_index_times(path, &wanted) {
            Ok(times) => inv.log_times = times,
            Err(e) => inv.losses.push(format!(
                "the index records beside the chunks cannot be read ({e}): the times of the \
                 camera messages are not known"
            )),
        }
        for times in inv.log_times.values_mut() {
            times.sort_unstable();
        }
    }
    Ok(inv)
}

/// [`ros1_inventory`] of a bag without its index section: every record walked and every
/// chunk decompressed (one at a time, into reused buffers) for its connections and its
/// messages' times; a cut or a chunk that cannot be read is a loss line.
fn ros1_walk(bag: &crate::ingest::ros1bag::Bag1, topics: &[String], inv: &mut Inventory) {
    use crate::ingest::ros1bag::{self, At, Inner};
    use std::os::unix::fs::FileExt;
    let mut by_conn: BTreeMap<u32, usize> = BTreeMap::new();
    let (mut buf, mut raw, mut plain) = (Vec::new(), Vec::new(), Vec::new());
    let mut at = bag.first;
    let mut chunk = |inv: &mut Inventory, data: &[u8], partial: bool| {
        for rec in ros1bag::inner_records(data) {
            match rec {
                Ok((_, Inner::Connection(c))) => {
                    if let std::collections::btree_map::Entry::Vacant(v) = by_conn.entry(c.id) {
                        v.insert(inv.channels.len());
                        inv.channels.push(ChannelInfo {
                            id: u16::try_from(inv.channels.len() + 1).unwrap_or(u16::MAX),
                            topic: c.topic,
                            schema: crate::ingest::ros2_type(&c.tp),
                            encoding: "ros1".into(),
                            messages: 0,
                        });
                    }
                }
                Ok((_, Inner::Message { conn, time, .. })) => {
                    inv.messages += 1;
                    inv.start_ns = Some(inv.start_ns.map_or(time, |x| x.min(time)));
                    inv.end_ns = Some(inv.end_ns.map_or(time, |x| x.max(time)));
                    if let Some(&k) = by_conn.get(&conn) {
                        inv.channels[k].messages += 1;
                        if topics.contains(&inv.channels[k].topic) {
                            let t = inv.channels[k].topic.clone();
                            inv.log_times.entry(t).or_default().push(time);
                        }
                    }
                }
                Ok((_, Inner::Other)) | Err((_, None)) if partial => {}
                Ok((_, Inner::Other)) => {}
                Err((off, why)) => {
                    inv.losses.push(format!(
                        "a chunk's record at byte {off} of its data cannot be read ({}): the \
                         chunk's records after it are lost",
                        why.unwrap_or_else(|| "it runs past the chunk's data".into())
                    ));
                    break;
                }
            }
        }
    };
    loop {
        match bag.record_at(at, &mut buf) {
            At::Record(r) => {
                if r.header.op == Some(ros1bag::OP_CHUNK) {
                    inv.chunks += 1;
                    raw.resize(r.data_len as usize, 0);
                    let comp = r.header.compression.clone().unwrap_or_default();
                    let size = r.header.size.map_or(u64::MAX, u64::from);
                    let got = bag
                        .file
                        .read_exact_at(&mut raw, r.data_at)
                        .map_err(|e| e.to_string())
                        .and_then(|()| ros1bag::decompress(&comp, &raw, size, &mut plain, false));
                    inv.compression
                        .insert(String::from_utf8_lossy(&comp).into_owned());
                    match got {
                        Ok(()) if comp == b"none" => chunk(inv, &raw, false),
                        Ok(()) => chunk(inv, &plain, false),
                        Err(e) => inv.losses.push(format!(
                            "the chunk at bytes {}..{} cannot be read: {e}",
                            r.at,
                            r.end()
                        )),
                    }
                }
                at = r.end();
            }
            At::Cut {
                header,
                data_at,
                data_len,
            } => {
                if at < bag.len {
                    inv.losses.push(format!(
                        "the bag is cut short: the record at byte {at} is incomplete (bytes \
                         {at}..{} lost)",
                        bag.len
                    ));
                    if let Some(h) = header.filter(|h| h.op == Some(ros1bag::OP_CHUNK)) {
                        if data_at < bag.len {
                            inv.chunks += 1;
                            raw.resize((bag.len - data_at).min(data_len) as usize, 0);
                            let comp = h.compression.unwrap_or_default();
                            let size = h.size.map_or(u64::MAX, u64::from);
                            if bag.file.read_exact_at(&mut raw, data_at).is_ok()
                                && ros1bag::decompress(&comp, &raw, size, &mut plain, true).is_ok()
                            {
                                let data = if comp == b"none" { &raw } else { &plain };
                                chunk(inv, data, true);
                            }
                        }
                    }
                } else {
                    inv.losses.push(format!(
                        "the bag ends at byte {at} without its index section (its recorder \
                         stopped before closing it)"
                    ));
                }
                break;
            }
            At::Bad(e) => {
                let next = bag.resync(at + 1, &mut buf);
                inv.losses.push(format!(
                    "bytes {at}..{} are not readable records: {e}",
                    next.unwrap_or(bag.len)
                ));
                match next {
                    Some(n) => at = n,
                    None => break,
                }
            }
        }
    }
    for times in inv.log_times.values_mut() {
        times.sort_unstable();
    }
}

/// The times of the messages of the connections in `wanted` (id → topic), by topic, from a ROS
/// 1 bag's index data records (op 0x04: per chunk and connection, each message's time), the
/// records' headers walked from the file's start and every chunk skipped unread (the
/// `rosbag` crate reaches these records only by decompressing each chunk before them).
fn ros1_index_times(
    path: &Path,
    wanted: &BTreeMap<u32, String>,
) -> std::result::Result<BTreeMap<String, Vec<u64>>, String> {
    use std::os::unix::fs::FileExt;
    let f = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let len = f.metadata().map_err(|e| e.to_string())?.len();
    let u32_at = |at: u64| -> std::result::Result<u32, String> {
        let mut b = [0u8; 4];
        f.read_exact_at(&mut b, at)
            .map_err(|e| format!("byte {at}: {e}"))?;
        Ok(u32::from_le_bytes(b))
    };
    let mut out: BTreeMap<String, Vec<u64>> = BTreeMap::new();
    let mut at = 13u64; // "#ROSBAG V2.0\n"
    while at + 4 <= len {
        let hlen = u64::from(u32_at(at)?);
        if at + 4 + hlen + 4 > len {
            return Err(format!("the record at byte {at} runs past the end"));
        }
        let mut header = vec![0u8; usize::try_from(hlen).map_err(|e| e.to_string())?];
        f.read_exact_at(&mut header, at + 4)
            .map_err(|e| format!("byte {at}: {e}"))?;
        let dlen = u64::from(u32_at(at + 4 + hlen)?);
        let data_at = at + 8 + hlen;
        if data_at + dlen > len {
            return Err(format!("the record at byte {at} runs past the end"));
        }
        // Header fields: u32 length, then `name=value`.
        let (mut op, mut conn) = (None, None);
        let mut i = 0usize;
        while i + 4 <= header.len() {
            let n = u32::from_le_bytes(header[i..i + 4].try_into().expect("4 bytes")) as usize;
            let Some(field) = header.get(i + 4..i + 4 + n) else {
                return Err(format!("the record header at byte {at} is cut"));
            };
            if let Some(eq) = field.iter().position(|&c| c == b'=') {
                let (name, value) = (&field[..eq], &field[eq + 1..]);
                match (name, value.len()) {
                    (b"op", 1) => op = Some(value[0]),
                    (b"conn", 4) => conn = Some(u32::from_le_bytes(value.try_into().expect("4"))),
                    _ => {}
                }
            }
            i += 4 + n;
        }
        if op == Some(0x04) {
            if let Some(topic) = conn.and_then(|c| wanted.get(&c)) {
                let mut data = vec![0u8; usize::try_from(dlen).map_err(|e| e.to_string())?];
                f.read_exact_at(&mut data, data_at)
                    .map_err(|e| format!("byte {data_at}: {e}"))?;
                let times = out.entry(topic.clone()).or_default();
                for e in data.chunks_exact(12) {
                    let secs = u32::from_le_bytes(e[0..4].try_into().expect("4 bytes"));
                    let nsecs = u32::from_le_bytes(e[4..8].try_into().expect("4 bytes"));
                    times.push(u64::from(secs) * 1_000_000_000 + u64::from(nsecs));
                }
            }
        }
        at = data_at + dlen;
    }
    Ok(out)
}

/// [`inventory`] of a bag folder: its files' inventories in order, summed (channels by topic).
fn bag_inventory(dir: &Path, topics: &[String]) -> Result<Inventory> {
    let bag = crate::bag::Bag::open(dir)?;
    let n = bag.parts.len();
    let mut inv = Inventory {
        from_summary: true,
        ..Inventory::default()
    };
    inv.notes.extend(bag.notes.iter().cloned());
    let mut storages: BTreeSet<String> = BTreeSet::new();
    for (i, p) in bag.parts.iter().enumerate() {
        let name = crate::bag::Bag::part_name(p);
        let whose = format!("file {} of {n} of the bag ({name})", i + 1);
        if !p.is_file() {
            inv.losses
                .push(format!("{whose} is missing: its messages are lost"));
            continue;
        }
        let part = match inventory(p, topics) {
            Ok(x) => x,
            Err(e) => {
                inv.bytes += std::fs::metadata(p).map(|m| m.len()).unwrap_or(0);
                inv.losses.push(format!("{whose} cannot be read: {e}"));
                continue;
            }
        };
        storages.insert(part.storage.clone());
        if inv.profile.is_empty() {
            inv.profile = part.profile.clone();
            inv.library = part.library.clone();
        }
        inv.bytes += part.bytes;
        inv.from_summary &= part.from_summary;
        inv.start_ns = match (inv.start_ns, part.start_ns) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        };
        inv.end_ns = match (inv.end_ns, part.end_ns) {
            (Some(a), Some(b)) => Some(a.max(b)),
            (a, b) => a.or(b),
        };
        inv.chunks += part.chunks;
        inv.chunks_decompressed += part.chunks_decompressed;
        inv.compression.extend(part.compression);
        inv.messages += part.messages;
        for c in part.channels {
            match inv.channels.iter_mut().find(|x| x.topic == c.topic) {
                Some(x) => x.messages += c.messages,
                None => {
                    let id = u16::try_from(inv.channels.len() + 1).unwrap_or(u16::MAX);
                    inv.channels.push(ChannelInfo { id, ..c });
                }
            }
        }
        inv.metadata.extend(part.metadata);
        inv.attachments.extend(part.attachments);
        for (k, v) in part.log_times {
            inv.log_times.entry(k).or_default().extend(v);
        }
        inv.losses
            .extend(part.losses.into_iter().map(|l| format!("{name}: {l}")));
        inv.notes
            .extend(part.notes.into_iter().map(|l| format!("{name}: {l}")));
    }
    let kinds: Vec<String> = storages.into_iter().collect();
    inv.storage = format!("bag of {n} files ({})", kinds.join(", "));
    for times in inv.log_times.values_mut() {
        times.sort_unstable();
    }
    Ok(inv)
}

/// [`inventory`] of an MCAP file.
fn mcap_inventory(path: &Path, topics: &[String]) -> Result<Inventory> {
    let io = |source| Error::Io {
        path: path.display().to_string(),
        source,
    };
    let file = std::fs::File::open(path).map_err(io)?;
    let len = file.metadata().map_err(io)?.len();
    // A hole at the end (space a crashed writer reserved) is not mapped: it holds no record.
    let (_, data_end) = crate::holes::layout(&file, len);
    let data_end = data_end.max(8.min(len));
    let n = usize::try_from(data_end).map_err(|_| {
        io(std::io::Error::other(
            "the file is larger than the address space",
        ))
    })?;
    // SAFETY: read-only map of a file nobody is expected to change while it is read; a
    // change would at worst give wrong counts, never unsafety in this code (bytes only).
    let map = unsafe { memmap2::MmapOptions::new().len(n).map(&file) }.map_err(io)?;
    let buf: &[u8] = &map;
    if buf.len() < 8 || !buf.starts_with(mcap::MAGIC) {
        return Err(Error::NotMcap {
            path: path.display().to_string(),
            bytes: len,
        });
    }
    let mut inv = Inventory {
        storage: "mcap".into(),
        bytes: len,
        ..Inventory::default()
    };
    read_header(buf, &mut inv);
    let bad_crc = crate::ingest::summary_crc(buf).filter(|(a, b)| a != b);
    if let Some((stored, got)) = bad_crc {
        inv.notes.push(format!(
            "the summary section's CRC-32 is {got:08x}, the footer says {stored:08x}: the \
             summary was not used; the file was read record by record"
        ));
    }
    let summary = if buf.ends_with(mcap::MAGIC) && bad_crc.is_none() {
        match Summary::read(buf) {
            Ok(s) => s,
            // Channels repeated without their schemas: valid, read from the data section.
            Err(mcap::McapError::UnknownSchema(..)) => None,
            Err(e) => {
                inv.notes.push(format!(
                    "the summary section is unreadable ({e}): the file was read record by record"
                ));
                None
            }
        }
    } else {
        None
    };
    match summary {
        Some(s) if summary_is_whole(&s) && indexes_times(&s, topics) => {
            from_summary(buf, &s, topics, &mut inv)
        }
        Some(_) => {
            inv.notes.push(
                "the summary leaves out channels, counts, metadata or attachments the file \
                 holds: the file was read record by record"
                    .to_string(),
            );
            walk(buf, topics, &mut inv)
        }
        None => walk(buf, topics, &mut inv),
    }
    if data_end < len {
        inv.losses.push(format!(
            "bytes {data_end}..{len} are a hole: space the writer reserved and never filled \
             (the file system holds no data there), not read"
        ));
    }
    for times in inv.log_times.values_mut() {
        times.sort_unstable();
    }
    inv.channels.sort_by_key(|c| c.id);
    Ok(inv)
}

/// Whether a summary tells everything an inventory reports: statistics (message counts per
/// channel, metadata and attachment counts), every counted channel's definition, and an
/// index for every metadata record and attachment. A writer may leave any of these out;
/// what it leaves out is read from the data section instead, never printed as zero.
fn summary_is_whole(s: &Summary) -> bool {
    let Some(st) = &s.stats else {
        return false;
    };
    st.channel_message_counts
        .iter()
        .all(|(id, &n)| n == 0 || s.channels.contains_key(id))
        && (st.message_count == 0 || !st.channel_message_counts.is_empty())
        && u64::from(st.metadata_count) == s.metadata_indexes.len() as u64
        && u64::from(st.attachment_count) == s.attachment_indexes.len() as u64
}

/// Whether the summary's chunk index points at a message index for every channel of the
/// `topics` whose log times are wanted (an unchunked file, or one written without message
/// indexes, has none: its times are read from the data section).
fn indexes_times(s: &Summary, topics: &[String]) -> bool {
    let counted = s.stats.as_ref().map(|st| &st.channel_message_counts);
    s.channels
        .values()
        .filter(|c| topics.contains(&c.topic))
        .filter(|c| counted.is_none_or(|n| n.get(&c.id).copied().unwrap_or(0) > 0))
        .all(|c| {
            s.chunk_indexes
                .iter()
                .any(|ci| ci.message_index_offsets.contains_key(&c.id))
        })
}

fn read_header(buf: &[u8], inv: &mut Inventory) {
    let mut r = LinearReader::sans_magic(&buf[mcap::MAGIC.len()..]);
    if let Some(Ok(Record::Header(h))) = r.next() {
        inv.profile = h.profile;
        inv.library = h.library;
    }
}

fn channel_info(c: &mcap::Channel<'_>, messages: u64) -> ChannelInfo {
    ChannelInfo {
        id: c.id,
        topic: c.topic.clone(),
        schema: c
            .schema
            .as_ref()
            .map(|s| s.name.clone())
            .unwrap_or_default(),
        encoding: c.message_encoding.clone(),
        messages,
    }
}

/// The message index record at `offset`, if it is one.
fn message_index(buf: &[u8], offset: u64) -> Option<records::MessageIndex> {
    let start = usize::try_from(offset).ok()?;
    if start >= buf.len() {
        return None;
    }
    match LinearReader::sans_magic(&buf[start..]).next() {
        Some(Ok(Record::MessageIndex(i))) => Some(i),
        _ => None,
    }
}

fn from_summary(buf: &[u8], s: &Summary, topics: &[String], inv: &mut Inventory) {
    inv.from_summary = true;
    let wanted: BTreeSet<u16> = s
        .channels
        .values()
        .filter(|c| topics.contains(&c.topic))
        .map(|c| c.id)
        .collect();
    let counted = s.stats.as_ref().map(|st| &st.channel_message_counts);
    // Without statistics the message indexes give every channel's count.
    let mut counts: BTreeMap<u16, u64> = BTreeMap::new();
    for ci in &s.chunk_indexes {
        inv.chunks += 1;
        inv.compression.insert(if ci.compression.is_empty() {
            "none".to_string()
        } else {
            ci.compression.clone()
        });
        let end = ci.chunk_start_offset.saturating_add(ci.chunk_length);
        if end > inv.bytes {
            inv.losses.push(format!(
                "chunk at byte {} ends past the end of the file ({} bytes)",
                ci.chunk_start_offset, inv.bytes
            ));
            continue;
        }
        for (&id, &off) in &ci.message_index_offsets {
            if !wanted.contains(&id) && counted.is_some() {
                continue;
            }
            let Some(mi) = message_index(buf, off) else {
                inv.losses.push(format!(
                    "message index of channel {id} at byte {off} is unreadable"
                ));
                continue;
            };
            *counts.entry(id).or_default() += mi.records.len() as u64;
            if wanted.contains(&id) {
                let topic = &s.channels[&id].topic;
                let times = inv.log_times.entry(topic.clone()).or_default();
                times.extend(mi.records.iter().map(|e| e.log_time));
            }
        }
    }
    if let Some(st) = &s.stats {
        counts.clone_from(&st.channel_message_counts);
        inv.messages = st.message_count;
        if st.message_count > 0 {
            inv.start_ns = Some(st.message_start_time);
            inv.end_ns = Some(st.message_end_time);
        }
        inv.chunks = inv.chunks.max(u64::from(st.chunk_count));
    } else {
        inv.messages = counts.values().sum();
        inv.start_ns = s.chunk_indexes.iter().map(|c| c.message_start_time).min();
        inv.end_ns = s.chunk_indexes.iter().map(|c| c.message_end_time).max();
    }
    for c in s.channels.values() {
        inv.channels
            .push(channel_info(c, counts.get(&c.id).copied().unwrap_or(0)));
    }
    for mi in &s.metadata_indexes {
        match mcap::read::metadata(buf, mi) {
            Ok(m) => inv.metadata.push((m.name, m.metadata)),
            Err(e) => inv.losses.push(format!(
                "metadata record {:?} at byte {} is unreadable: {e}",
                mi.name, mi.offset
            )),
        }
    }
    for a in &s.attachment_indexes {
        inv.attachments.push((a.name.clone(), a.data_size));
    }
}

/// Per channel id: (channel, message count); what the walk has learnt so far.
#[derive(Default)]
struct Walk<'a> {
    channels: BTreeMap<u16, ChannelInfo>,
    schemas: BTreeMap<u16, String>,
    /// Messages met on ids not defined yet (a definition may come later in a file without a
    /// summary): their count and log times, given to the channel once it is defined.
    early: BTreeMap<u16, (u64, Vec<u64>)>,
    /// The last chunk seen, not yet decompressed: (header, compressed data).
    pending: Option<(records::ChunkHeader, Cow<'a, [u8]>)>,
    pending_indexed: bool,
}

impl Walk<'_> {
    fn add_channel(&mut self, c: &records::Channel) {
        let schema = self.schemas.get(&c.schema_id).cloned().unwrap_or_default();
        self.channels.entry(c.id).or_insert_with(|| ChannelInfo {
            id: c.id,
            topic: c.topic.clone(),
            schema,
            encoding: c.message_encoding.clone(),
            messages: 0,
        });
    }

    fn message(&mut self, id: u16, log_time: u64, topics: &[String], inv: &mut Inventory) {
        inv.messages += 1;
        inv.start_ns = Some(inv.start_ns.map_or(log_time, |t| t.min(log_time)));
        inv.end_ns = Some(inv.end_ns.map_or(log_time, |t| t.max(log_time)));
        if let Some(c) = self.channels.get_mut(&id) {
            c.messages += 1;
            if topics.contains(&c.topic) {
                inv.log_times
                    .entry(c.topic.clone())
                    .or_default()
                    .push(log_time);
            }
        } else {
            let e = self.early.entry(id).or_default();
            e.0 += 1;
            e.1.push(log_time);
        }
    }

    /// At the end: messages met before their channel's definition counted on it; those on
    /// ids the file never defines reported.
    fn settle(&mut self, topics: &[String], inv: &mut Inventory) {
        for (id, (n, times)) in std::mem::take(&mut self.early) {
            match self.channels.get_mut(&id) {
                Some(c) => {
                    c.messages += n;
                    if topics.contains(&c.topic) {
                        inv.log_times
                            .entry(c.topic.clone())
                            .or_default()
                            .extend(times);
                    }
                }
                None => inv.losses.push(format!(
                    "{n} message{} on channel {id}, which the file never defines",
                    if n == 1 { "" } else { "s" }
                )),
            }
        }
    }

    /// Decompress the pending chunk: learn its schemas and channels and, when `messages`,
    /// count its messages (a chunk without message indexes).
    fn open_pending(&mut self, messages: bool, topics: &[String], inv: &mut Inventory) {
        let Some((header, data)) = self.pending.take() else {
            return;
        };
        inv.chunks_decompressed += 1;
        let reader = match ChunkReader::new(header, &data) {
            Ok(r) => r,
            Err(e) => {
                inv.losses
                    .push(format!("a chunk cannot be decompressed: {e}"));
                return;
            }
        };
        for rec in reader {
            match rec {
                Ok(Record::Schema { header, .. }) => {
                    self.schemas.insert(header.id, header.name);
                }
                Ok(Record::Channel(c)) => self.add_channel(&c),
                Ok(Record::Message { header, .. }) if messages => {
                    self.message(header.channel_id, header.log_time, topics, inv);
                }
                Ok(_) => {}
                Err(e) => {
                    inv.losses.push(format!("a chunk is corrupt: {e}"));
                    return;
                }
            }
        }
    }
}

/// The records of `buf` (a whole MCAP file) after its magic, in file order, parsed in place
/// (a chunk's data is borrowed from the map, never copied or read unless it is opened), or
/// where the walk must stop and why.
fn records(buf: &[u8]) -> impl Iterator<Item = std::result::Result<Record<'_>, String>> {
    let body = &buf[mcap::MAGIC.len()..];
    let mut pos = 0usize;
    let mut done = false;
    std::iter::from_fn(move || {
        if done || pos >= body.len() {
            return None;
        }
        let at = pos + mcap::MAGIC.len();
        let Some((opcode, from, end)) = crate::ingest::record_at(body, pos) else {
            done = true;
            return Some(Err(format!(
                "the file is cut short: the record at byte {at} is incomplete"
            )));
        };
        pos = end;
        match mcap::read::parse_record(opcode, &body[from..end]) {
            Ok(r) => Some(Ok(r)),
            Err(e) => {
                done = true;
                Some(Err(format!("the record at byte {at} is corrupt: {e}")))
            }
        }
    })
}

fn walk(buf: &[u8], topics: &[String], inv: &mut Inventory) {
    let mut w = Walk::default();
    let mut at_end = false;
    for rec in records(buf) {
        let rec = match rec {
            Ok(r) => r,
            Err(e) => {
                inv.losses.push(e);
                break;
            }
        };
        if !matches!(rec, Record::MessageIndex(_)) && w.pending.is_some() {
            // A chunk without message indexes: its messages are counted from the chunk.
            let indexed = w.pending_indexed;
            if !indexed {
                w.open_pending(true, topics, inv);
            }
            w.pending = None;
        }
        match rec {
            Record::Header(h) => {
                inv.profile = h.profile;
                inv.library = h.library;
            }
            Record::Schema { header, .. } => {
                w.schemas.insert(header.id, header.name);
            }
            Record::Channel(c) => w.add_channel(&c),
            Record::Message { header, .. } => {
                w.message(header.channel_id, header.log_time, topics, inv)
            }
            Record::Chunk { header, data } => {
                inv.chunks += 1;
                inv.compression.insert(if header.compression.is_empty() {
                    "none".to_string()
                } else {
                    header.compression.clone()
                });
                w.pending = Some((header, data));
                w.pending_indexed = false;
            }
            Record::MessageIndex(mi) => {
                if !w.channels.contains_key(&mi.channel_id) {
                    w.open_pending(false, topics, inv);
                }
                if w.pending.is_some() || w.pending_indexed {
                    w.pending_indexed = true;
                }
                for e in &mi.records {
                    w.message(mi.channel_id, e.log_time, topics, inv);
                }
            }
            Record::Metadata(m) => inv.metadata.push((m.name, m.metadata)),
            Record::Attachment { header, data, .. } => {
                inv.attachments.push((header.name, data.len() as u64));
            }
            Record::DataEnd(_) => {
                at_end = true;
                break;
            }
            Record::Unknown { opcode: 0, .. } => {
                // Opcode 0 is never written: zeros where a record should start (space a
                // writer reserved and never filled), not records to step through 9 at a time.
                inv.losses.push(
                    "the data section holds zeros where a record should start (space the \
                     writer reserved and never filled): read stopped there"
                        .to_string(),
                );
                break;
            }
            _ => {}
        }
    }
    if w.pending.is_some() && !w.pending_indexed {
        w.open_pending(true, topics, inv);
    }
    w.settle(topics, inv);
    if !at_end && inv.losses.is_empty() {
        inv.losses
            .push("the file ends before its data-end record (cut short)".to_string());
    }
    inv.channels = w.channels.into_values().collect();
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn write_sample(path: &Path, summary: bool) {
        let file = std::fs::File::create(path).unwrap();
        let opts = mcap::WriteOptions::new()
            .chunk_size(Some(64))
            .emit_summary_records(summary)
            .emit_summary_offsets(summary)
            .emit_message_indexes(true)
            .emit_chunk_indexes(summary)
            .emit_statistics(summary)
            .emit_metadata_indexes(summary);
        let mut w = opts.create(std::io::BufWriter::new(file)).unwrap();
        let schema = w
            .add_schema("sensor_msgs/msg/Image", "ros2msg", b"")
            .unwrap();
        let a = w
            .add_channel(schema, "/ccd_a/image_raw", "cdr", &BTreeMap::new())
            .unwrap();
        let j = w
            .add_channel(0, "/joint_states", "cdr", &BTreeMap::new())
            .unwrap();
        for k in 0..10u64 {
            let t = 1_000_000_000 * k;
            let h = |c| mcap::records::MessageHeader {
                channel_id: c,
                sequence: k as u32,
                log_time: t,
                publish_time: t,
            };
            w.write_to_known_channel(&h(a), &[0u8; 40]).unwrap();
            if k % 2 == 0 {
                w.write_to_known_channel(&h(j), &[1u8; 8]).unwrap();
            }
        }
        let mut md = BTreeMap::new();
        md.insert("name".to_string(), "run1".to_string());
        w.write_metadata(&mcap::records::Metadata {
            name: "thermrs.run".into(),
            metadata: md,
        })
        .unwrap();
        w.finish().unwrap();
    }

    fn check(inv: &Inventory) {
        let by: BTreeMap<_, _> = inv.channels.iter().map(|c| (c.topic.as_str(), c)).collect();
        assert_eq!(by["/ccd_a/image_raw"].messages, 10);
        assert_eq!(by["/joint_states"].messages, 5);
        assert_eq!(by["/ccd_a/image_raw"].schema, "sensor_msgs/msg/Image");
        assert_eq!(inv.messages, 15);
        assert_eq!(inv.start_ns, Some(0));
        assert_eq!(inv.end_ns, Some(9_000_000_000));
        let times = &inv.log_times["/ccd_a/image_raw"];
        assert_eq!(
            times,
            &(0..10).map(|k| k * 1_000_000_000).collect::<Vec<u64>>()
        );
        assert_eq!(inv.metadata.len(), 1);
        assert_eq!(inv.metadata[0].1["name"], "run1");
    }

    #[test]
    fn summary_and_walk_agree_with_what_was_written() {
        let dir = std::env::temp_dir().join(format!("thermrs-inv-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let topics = vec!["/ccd_a/image_raw".to_string()];
        for summary in [true, false] {
            let p = dir.join(format!("s{summary}.mcap"));
            write_sample(&p, summary);
            let inv = inventory(&p, &topics).unwrap();
            assert_eq!(inv.from_summary, summary);
            check(&inv);
            assert!(inv.losses.is_empty(), "{:?}", inv.losses);
        }
        // Cut short: the walk reports the loss and keeps what came before.
        let whole = std::fs::read(dir.join("strue.mcap")).unwrap();
        let p = dir.join("cut.mcap");
        std::fs::File::create(&p)
            .unwrap()
            .write_all(&whole[..whole.len() / 2])
            .unwrap();
        let inv = inventory(&p, &topics).unwrap();
        assert!(!inv.from_summary);
        assert!(!inv.losses.is_empty());
        assert!(inv.messages < 15);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn not_mcap_is_a_recording_error() {
        let p = std::env::temp_dir().join(format!("thermrs-inv-no-{}.mcap", std::process::id()));
        std::fs::write(&p, b"hello world, not mcap").unwrap();
        assert!(matches!(inventory(&p, &[]), Err(Error::NotMcap { .. })));
        std::fs::remove_file(&p).unwrap();
    }
}
