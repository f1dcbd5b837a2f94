//! The ROS 1 bag format 2.0 (`#ROSBAG V2.0`), read record by record with `pread`: each
//! record is a header (`u32` length, then fields `u32` length + `name=value`), then its data
//! (`u32` length + bytes). Chunks (op 0x05) hold connection (0x07) and message data (0x02)
//! records, uncompressed, bz2 or lz4 (a frame); beside each chunk its index data records
//! (0x04), and at the end the index section (connections and chunk infos, 0x06), which a
//! recorder killed before closing the bag never writes (the bag header's `index_pos` is then
//! 0). Nothing read is trusted: every length is checked against what remains of the file and
//! against [`MAX_CHUNK_BYTES`] before it is used.

use std::fs::File;
use std::io::Read;
use std::os::unix::fs::FileExt;

use super::recovery::MAX_CHUNK_BYTES;

/// The file's first bytes.
pub(crate) const MAGIC: &[u8] = b"#ROSBAG V2.0\n";
/// A record header longer than this is taken as damage (real ones are under 1 KiB, a
/// connection's message definition being in its data, not its header).
const MAX_HEADER: u64 = 1 << 20;

pub(crate) const OP_MSG_DATA: u8 = 0x02;
pub(crate) const OP_BAG_HEADER: u8 = 0x03;
pub(crate) const OP_INDEX_DATA: u8 = 0x04;
pub(crate) const OP_CHUNK: u8 = 0x05;
pub(crate) const OP_CHUNK_INFO: u8 = 0x06;
pub(crate) const OP_CONNECTION: u8 = 0x07;

/// The fields of a record header that thermrs reads (others are ignored).
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Header {
    pub op: Option<u8>,
    /// Connection id (message data, connection, index data).
    pub conn: Option<u32>,
    /// Receive time in ns (message data).
    pub time: Option<u64>,
    /// `none`, `bz2` or `lz4` (chunk).
    pub compression: Option<Vec<u8>>,
    /// Uncompressed bytes (chunk).
    pub size: Option<u32>,
    /// Topic (connection).
    pub topic: Option<String>,
    /// Messages (index data), connections (chunk info).
    pub count: Option<u32>,
    /// Offset of the index section (bag header).
    pub index_pos: Option<u64>,
    /// Offset of the chunk (chunk info).
    pub chunk_pos: Option<u64>,
    /// Times of the chunk's first and last messages (chunk info).
    pub start_time: Option<u64>,
    pub end_time: Option<u64>,
}

/// ROS 1 `time` (u32 seconds, u32 ns) in ns.
fn time_ns(v: &[u8]) -> u64 {
    let s = u64::from(u32::from_le_bytes(v[..4].try_into().expect("4 bytes")));
    let ns = u64::from(u32::from_le_bytes(v[4..8].try_into().expect("4 bytes")));
    s * 1_000_000_000 + ns
}

/// The `name=value` fields of a header or of a connection's data, in order.
pub(crate) fn fields(mut b: &[u8]) -> impl Iterator<Item = Result<(&[u8], &[u8]), String>> {
    std::iter::from_fn(move || {
        if b.is_empty() {
            return None;
        }
        if b.len() < 4 {
            b = &[];
            return Some(Err("a header field's length is cut".into()));
        }
        let n = u32::from_le_bytes(b[..4].try_into().expect("4 bytes")) as usize;
        let Some(field) = b.get(4..4 + n) else {
            b = &[];
            return Some(Err(format!(
                "a header field of {n} bytes runs past the header"
            )));
        };
        b = &b[4 + n..];
        match field.iter().position(|&c| c == b'=') {
            Some(eq) => Some(Ok((&field[..eq], &field[eq + 1..]))),
            None => {
                b = &[];
                Some(Err("a header field has no `=`".into()))
            }
        }
    })
}

impl Header {
    /// Parse a record header.
    pub(crate) fn parse(b: &[u8]) -> Result<Header, String> {
        let mut h = Header::default();
        let u32v = |v: &[u8], what: &str| -> Result<u32, String> {
            v.try_into()
                .map(u32::from_le_bytes)
                .map_err(|_| format!("field {what} is {} bytes, not 4", v.len()))
        };
        let u64v = |v: &[u8], what: &str| -> Result<u64, String> {
            v.try_into()
                .map(u64::from_le_bytes)
                .map_err(|_| format!("field {what} is {} bytes, not 8", v.len()))
        };
        let timev = |v: &[u8], what: &str| -> Result<u64, String> {
            if v.len() == 8 {
                Ok(time_ns(v))
            } else {
                Err(format!("field {what} is {} bytes, not 8", v.len()))
            }
        };
        for f in fields(b) {
            let (name, v) = f?;
            match name {
                b"op" if v.len() == 1 => h.op = Some(v[0]),
                b"op" => return Err(format!("field op is {} bytes, not 1", v.len())),
                b"conn" => h.conn = Some(u32v(v, "conn")?),
                b"time" => h.time = Some(timev(v, "time")?),
                b"compression" => h.compression = Some(v.to_vec()),
                b"size" => h.size = Some(u32v(v, "size")?),
                b"topic" => h.topic = Some(String::from_utf8_lossy(v).into_owned()),
                b"count" => h.count = Some(u32v(v, "count")?),
                b"index_pos" => h.index_pos = Some(u64v(v, "index_pos")?),
                b"chunk_pos" => h.chunk_pos = Some(u64v(v, "chunk_pos")?),
                b"start_time" => h.start_time = Some(timev(v, "start_time")?),
                b"end_time" => h.end_time = Some(timev(v, "end_time")?),
                _ => {}
            }
        }
        if h.op.is_none() {
            return Err("the record header has no op field".into());
        }
        Ok(h)
    }
}

/// A connection: its id, topic (the data's `topic`, else the header's) and type (`pkg/Name`).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Connection {
    pub id: u32,
    pub topic: String,
    pub tp: String,
}

impl Connection {
    /// From a connection record's parsed header and its data (the publisher's fields).
    pub(crate) fn parse(h: &Header, data: &[u8]) -> Result<Connection, String> {
        let id = h.conn.ok_or("a connection record without conn")?;
        let (mut topic, mut tp) = (None, None);
        for f in fields(data) {
            let (name, v) = f?;
            match name {
                b"topic" => topic = Some(String::from_utf8_lossy(v).into_owned()),
                b"type" => tp = Some(String::from_utf8_lossy(v).into_owned()),
                _ => {}
            }
        }
        Ok(Connection {
            id,
            topic: topic
                .or_else(|| h.topic.clone())
                .ok_or("a connection record without a topic")?,
            tp: tp.ok_or("a connection record without a type")?,
        })
    }
}

/// A top-level record, its header read, its data not.
#[derive(Debug, Clone)]
pub(crate) struct RecordAt {
    pub at: u64,
    pub header: Header,
    /// Where its data starts, and its length.
    pub data_at: u64,
    pub data_len: u64,
}

impl RecordAt {
    /// Where the next record starts.
    pub(crate) fn end(&self) -> u64 {
        self.data_at + self.data_len
    }
}

/// What is at an offset of the file.
#[derive(Debug)]
pub(crate) enum At {
    Record(RecordAt),
    /// The file ends inside the record starting here: its header is read if that much is
    /// there (the data then starts at `data_at`, of `data_len` bytes of which the file holds
    /// the rest).
    Cut {
        header: Option<Header>,
        data_at: u64,
        data_len: u64,
    },
    /// Not a record: why.
    Bad(String),
}

/// A ROS 1 bag opened for reading with `pread`.
pub(crate) struct Bag1 {
    pub file: File,
    pub len: u64,
    /// The bag header's `index_pos`: 0 (or past the end) when the index section is missing.
    pub index_pos: u64,
    /// Where the first record after the bag header starts.
    pub first: u64,
}

impl Bag1 {
    /// Open the bag at `path` and read its header.
    pub(crate) fn open(path: &std::path::Path) -> std::io::Result<Result<Bag1, String>> {
        let file = File::open(path)?;
        let len = file.metadata()?.len();
        let mut magic = [0u8; 13];
        if len < 13 || file.read_exact_at(&mut magic, 0).is_err() || magic != MAGIC {
            return Ok(Err("it does not start with #ROSBAG V2.0".into()));
        }
        let mut bag = Bag1 {
            file,
            len,
            index_pos: 0,
            first: MAGIC.len() as u64,
        };
        let mut buf = Vec::new();
        Ok(match bag.record_at(MAGIC.len() as u64, &mut buf) {
            At::Record(r) if r.header.op == Some(OP_BAG_HEADER) => {
                bag.index_pos = r.header.index_pos.unwrap_or(0);
                bag.first = r.end();
                Ok(bag)
            }
            At::Record(r) => Err(format!(
                "its first record is not a bag header (op {:?})",
                r.header.op
            )),
            At::Cut { .. } => Err("the file ends inside its bag header".into()),
            At::Bad(e) => Err(format!("its bag header cannot be read: {e}")),
        })
    }

    /// Whether the bag has its index section (it was closed by its recorder).
    pub(crate) fn indexed(&self) -> bool {
        self.index_pos >= self.first && self.index_pos < self.len
    }

    fn u32_at(&self, at: u64) -> Option<u64> {
        let mut b = [0u8; 4];
        self.file.read_exact_at(&mut b, at).ok()?;
        Some(u64::from(u32::from_le_bytes(b)))
    }

    /// The record at `at` (`buf` holds its header bytes after the call).
    pub(crate) fn record_at(&self, at: u64, buf: &mut Vec<u8>) -> At {
        let cut = |header, data_at, data_len| At::Cut {
            header,
            data_at,
            data_len,
        };
        if at + 4 > self.len {
            return cut(None, self.len, 0);
        }
        let Some(hlen) = self.u32_at(at) else {
            return At::Bad(format!("byte {at} cannot be read"));
        };
        if hlen > MAX_HEADER {
            return At::Bad(format!("a record header of {hlen} bytes at byte {at}"));
        }
        if at + 4 + hlen > self.len {
            return cut(None, self.len, 0);
        }
        buf.resize(hlen as usize, 0);
        if self.file.read_exact_at(buf, at + 4).is_err() {
            return At::Bad(format!("byte {at} cannot be read"));
        }
        let header = match Header::parse(buf) {
            Ok(h) => h,
            Err(e) => return At::Bad(format!("the record at byte {at}: {e}")),
        };
        let len_at = at + 4 + hlen;
        if len_at + 4 > self.len {
            return cut(Some(header), self.len, 0);
        }
        let Some(dlen) = self.u32_at(len_at) else {
            return At::Bad(format!("byte {len_at} cannot be read"));
        };
        let data_at = len_at + 4;
        if dlen > MAX_CHUNK_BYTES {
            return At::Bad(format!(
                "the record at byte {at} claims {dlen} bytes of data (more than {MAX_CHUNK_BYTES})"
            ));
        }
        if data_at + dlen > self.len {
            return cut(Some(header), data_at, dlen);
        }
        At::Record(RecordAt {
            at,
            header,
            data_at,
            data_len: dlen,
        })
    }

    /// The next offset after `from` where a record of a kind found at the top level starts
    /// whose lengths fit in the file (a chunk, connection, index data or chunk info), or
    /// `None`. Used to go on after damage.
    pub(crate) fn resync(&self, from: u64, buf: &mut Vec<u8>) -> Option<u64> {
        const STEP: u64 = 1 << 20;
        let mut window = vec![0u8; (STEP + 8) as usize];
        let mut base = from;
        while base < self.len {
            let n = ((self.len - base).min(STEP + 8)) as usize;
            self.file.read_exact_at(&mut window[..n], base).ok()?;
            // A record's header holds `op=` + one byte as a field of 4 bytes.
            for i in 0..n.saturating_sub(8) {
                if window[i..i + 7] != *b"\x04\x00\x00\x00op=" {
                    continue;
                }
                let op = window[i + 7];
                if !matches!(op, OP_CHUNK | OP_CONNECTION | OP_INDEX_DATA | OP_CHUNK_INFO) {
                    continue;
                }
                // The op field is somewhere in its header: try the header starts before it.
                let field = base + i as u64;
                let lo = field.saturating_sub(512).max(from);
                let mut s = field.saturating_sub(4);
                while s >= lo {
                    if let At::Record(r) = self.record_at(s, buf) {
                        if r.header.op == Some(op) && s + 4 + buf.len() as u64 > field {
                            return Some(s);
                        }
                    }
                    if s == 0 {
                        break;
                    }
                    s -= 1;
                }
            }
            base += STEP;
        }
        None
    }
}

/// Decompress a chunk's data `raw` (`compression`) into `out` (cleared first), expecting
/// `size` bytes. With `partial` (the file was cut inside the chunk) as much as the bytes
/// present decode to is kept and no error is returned for the cut.
pub(crate) fn decompress(
    compression: &[u8],
    raw: &[u8],
    size: u64,
    out: &mut Vec<u8>,
    partial: bool,
) -> Result<(), String> {
    out.clear();
    if size > MAX_CHUNK_BYTES {
        return Err(format!(
            "it claims {size} bytes uncompressed (more than {MAX_CHUNK_BYTES})"
        ));
    }
    match compression {
        b"none" => out.extend_from_slice(raw),
        b"bz2" => {
            out.reserve(size as usize);
            let mut d = bzip2::Decompress::new(false);
            loop {
                let before = (d.total_in(), out.len());
                let want = out.len() + (1 << 20).min(size as usize + 1);
                out.reserve(want.saturating_sub(out.len()));
                let r = d.decompress_vec(&raw[d.total_in() as usize..], out);
                match r {
                    Ok(bzip2::Status::StreamEnd) => break,
                    Ok(_) if (d.total_in(), out.len()) == before => {
                        if partial {
                            break;
                        }
                        return Err("its bz2 data ends before the bz2 stream does".into());
                    }
                    Ok(_) if out.len() as u64 > size => {
                        return Err(format!(
                            "its bz2 data holds more than the {size} bytes it claims"
                        ))
                    }
                    Ok(_) => {}
                    Err(e) if partial => {
                        let _ = e;
                        break;
                    }
                    Err(e) => return Err(format!("its bz2 data does not decompress: {e}")),
                }
            }
        }
        b"lz4" => {
            let mut d = lz4::Decoder::new(raw)
                .map_err(|e| format!("its lz4 data does not decompress: {e}"))?;
            out.resize(size as usize + 1, 0);
            let mut n = 0usize;
            loop {
                match d.read(&mut out[n..]) {
                    Ok(0) => break,
                    Ok(k) => {
                        n += k;
                        if n > size as usize {
                            out.truncate(n);
                            return Err(format!(
                                "its lz4 data holds more than the {size} bytes it claims"
                            ));
                        }
                    }
                    Err(_) if partial => break,
                    Err(e) => {
                        out.truncate(n);
                        return Err(format!("its lz4 data does not decompress: {e}"));
                    }
                }
            }
            out.truncate(n);
        }
        other => {
            return Err(format!(
                "its compression {:?} is none of none, bz2, lz4",
                String::from_utf8_lossy(other)
            ))
        }
    }
    if !partial && out.len() as u64 != size {
        return Err(format!(
            "it decompresses to {} bytes, not the {size} it claims",
            out.len()
        ));
    }
    Ok(())
}

/// A record inside a chunk's (decompressed) data.
#[derive(Debug)]
pub(crate) enum Inner<'a> {
    Connection(Connection),
    Message {
        conn: u32,
        time: u64,
        data: &'a [u8],
    },
    /// Another kind of record (skipped).
    Other,
}

/// The records of a chunk's data, in order: each with its offset in the data. Ends at the
/// end of the data, at the first record cut by it (`Err((offset, None))`), or at a record
/// that cannot be read (`Err((offset, Some(why)))`).
pub(crate) fn inner_records(
    data: &[u8],
) -> impl Iterator<Item = Result<(usize, Inner<'_>), (usize, Option<String>)>> {
    let mut pos = 0usize;
    let mut done = false;
    std::iter::from_fn(move || {
        if done || pos == data.len() {
            return None;
        }
        let at = pos;
        let rest = &data[pos..];
        let u32_at = |i: usize| -> Option<usize> {
            rest.get(i..i + 4)
                .map(|b| u32::from_le_bytes(b.try_into().expect("4 bytes")) as usize)
        };
        done = true;
        let Some(hlen) = u32_at(0) else {
            return Some(Err((at, None)));
        };
        let Some(hb) = rest.get(4..4 + hlen) else {
            return Some(Err((at, None)));
        };
        let Some(dlen) = u32_at(4 + hlen) else {
            return Some(Err((at, None)));
        };
        let Some(body) = rest.get(8 + hlen..8 + hlen + dlen) else {
            return Some(Err((at, None)));
        };
        let h = match Header::parse(hb) {
            Ok(h) => h,
            Err(e) => return Some(Err((at, Some(e)))),
        };
        let rec = match h.op {
            Some(OP_MSG_DATA) => match (h.conn, h.time) {
                (Some(conn), Some(time)) => Inner::Message {
                    conn,
                    time,
                    data: body,
                },
                _ => {
                    return Some(Err((
                        at,
                        Some("a message data record without conn or time".into()),
                    )))
                }
            },
            Some(OP_CONNECTION) => match Connection::parse(&h, body) {
                Ok(c) => Inner::Connection(c),
                Err(e) => return Some(Err((at, Some(e)))),
            },
            _ => Inner::Other,
        };
        done = false;
        pos += 8 + hlen + dlen;
        Some(Ok((at, rec)))
    })
}
