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
            // Read to the end (what was read stays in `out` on an error), at most one byte
            // more than claimed.
            match (&mut d).take(size + 1).read_to_end(out) {
                Ok(_) => {}
                Err(_) if partial => {}
                Err(e) => return Err(format!("its lz4 data does not decompress: {e}")),
            }
            if out.len() as u64 > size {
                return Err(format!(
                    "its lz4 data holds more than the {size} bytes it claims"
                ));
            }
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    /// A message: connection, time, data.
    type Msg = (u32, u64, Vec<u8>);

    /// A record as the format lays it out: header fields, then data.
    fn record(fields: &[(&str, &[u8])], data: &[u8]) -> Vec<u8> {
        let mut h = Vec::new();
        for (name, v) in fields {
            h.extend_from_slice(&((name.len() + 1 + v.len()) as u32).to_le_bytes());
            h.extend_from_slice(name.as_bytes());
            h.push(b'=');
            h.extend_from_slice(v);
        }
        let mut out = (h.len() as u32).to_le_bytes().to_vec();
        out.extend_from_slice(&h);
        out.extend_from_slice(&(data.len() as u32).to_le_bytes());
        out.extend_from_slice(data);
        out
    }

    fn time(ns: u64) -> Vec<u8> {
        let mut v = ((ns / 1_000_000_000) as u32).to_le_bytes().to_vec();
        v.extend_from_slice(&((ns % 1_000_000_000) as u32).to_le_bytes());
        v
    }

    fn connection(id: u32, topic: &str) -> Vec<u8> {
        let data = [
            record(&[("topic", topic.as_bytes())], &[]),
            record(&[("type", b"std_msgs/String")], &[]),
            record(&[("md5sum", &[b'0'; 32])], &[]),
            record(&[("message_definition", b"string data\n")], &[]),
        ]
        // Fields of the data are `u32` + `name=value` as in a header: strip the data lengths.
        .iter()
        .flat_map(|r| {
            let n = u32::from_le_bytes(r[..4].try_into().unwrap()) as usize;
            r[4..4 + n].to_vec()
        })
        .collect::<Vec<u8>>();
        record(
            &[
                ("op", &[OP_CONNECTION]),
                ("conn", &id.to_le_bytes()),
                ("topic", topic.as_bytes()),
            ],
            &data,
        )
    }

    /// A bag of three chunks (none, bz2, lz4; the compressors of the `bzip2` and `lz4` crates)
    /// of `per` messages each on two connections, with its index section; and its messages.
    fn bag(per: usize) -> (Vec<u8>, Vec<Msg>) {
        let mut msgs = Vec::new();
        let mut body = Vec::new();
        let mut infos = Vec::new();
        let first = MAGIC.len() + 4096;
        for (c, comp) in ["none", "bz2", "lz4"].iter().enumerate() {
            let mut plain = if c == 0 {
                [connection(0, "/a"), connection(1, "/b")].concat()
            } else {
                Vec::new()
            };
            for i in 0..per {
                let conn = (i % 2) as u32;
                let t = 1_000_000_000 * (c * per + i) as u64 + 7;
                let data: Vec<u8> = (0..100 + i * 37).map(|k| (k * 31 + i) as u8).collect();
                plain.extend(record(
                    &[
                        ("op", &[OP_MSG_DATA]),
                        ("conn", &conn.to_le_bytes()),
                        ("time", &time(t)),
                    ],
                    &data,
                ));
                msgs.push((conn, t, data));
            }
            let packed = match *comp {
                "bz2" => {
                    let mut e =
                        bzip2::write::BzEncoder::new(Vec::new(), bzip2::Compression::best());
                    e.write_all(&plain).unwrap();
                    e.finish().unwrap()
                }
                "lz4" => {
                    let mut e = lz4::EncoderBuilder::new().build(Vec::new()).unwrap();
                    e.write_all(&plain).unwrap();
                    e.finish().0
                }
                _ => plain.clone(),
            };
            let pos = (first + body.len()) as u64;
            body.extend(record(
                &[
                    ("op", &[OP_CHUNK]),
                    ("compression", comp.as_bytes()),
                    ("size", &(plain.len() as u32).to_le_bytes()),
                ],
                &packed,
            ));
            infos.push((pos, c * per, (c + 1) * per - 1));
        }
        let index_pos = (first + body.len()) as u64;
        body.extend(connection(0, "/a"));
        body.extend(connection(1, "/b"));
        for (pos, a, b) in infos {
            let counts: Vec<u8> = [
                0u32,
                ((b - a + 2) / 2) as u32,
                1,
                (b - a).div_ceil(2) as u32,
            ]
            .iter()
            .flat_map(|x| x.to_le_bytes())
            .collect();
            body.extend(record(
                &[
                    ("op", &[OP_CHUNK_INFO]),
                    ("ver", &1u32.to_le_bytes()),
                    ("chunk_pos", &pos.to_le_bytes()),
                    ("start_time", &time(msgs[a].1)),
                    ("end_time", &time(msgs[b].1)),
                    ("count", &2u32.to_le_bytes()),
                ],
                &counts,
            ));
        }
        let mut out = MAGIC.to_vec();
        let mut head = record(
            &[
                ("op", &[OP_BAG_HEADER]),
                ("index_pos", &index_pos.to_le_bytes()),
                ("conn_count", &2u32.to_le_bytes()),
                ("chunk_count", &3u32.to_le_bytes()),
            ],
            &[],
        );
        // Padded to 4096 bytes as rosbag writes it (the data: spaces).
        let pad = 4096 - head.len();
        head.truncate(head.len() - 4);
        head.extend(((pad) as u32).to_le_bytes());
        head.extend(vec![b' '; pad]);
        out.extend(head);
        out.extend(body);
        (out, msgs)
    }

    /// Every message of the bag at `path` as this module reads it, in file order.
    fn read(path: &std::path::Path) -> (Vec<Msg>, bool) {
        let bag = Bag1::open(path).unwrap().unwrap();
        let (mut buf, mut raw, mut plain) = (Vec::new(), Vec::new(), Vec::new());
        let mut out = Vec::new();
        let mut at = bag.first;
        loop {
            match bag.record_at(at, &mut buf) {
                At::Record(r) => {
                    if r.header.op == Some(OP_CHUNK) {
                        raw.resize(r.data_len as usize, 0);
                        bag.file.read_exact_at(&mut raw, r.data_at).unwrap();
                        let comp = r.header.compression.clone().unwrap();
                        decompress(
                            &comp,
                            &raw,
                            r.header.size.unwrap().into(),
                            &mut plain,
                            false,
                        )
                        .unwrap();
                        let data = if comp == b"none" { &raw } else { &plain };
                        for rec in inner_records(data) {
                            if let Inner::Message { conn, time, data } = rec.unwrap().1 {
                                out.push((conn, time, data.to_vec()));
                            }
                        }
                    }
                    at = r.end();
                }
                At::Cut {
                    header, data_at, ..
                } => {
                    if let Some(h) = header.filter(|_| data_at < bag.len) {
                        raw.resize((bag.len - data_at) as usize, 0);
                        bag.file.read_exact_at(&mut raw, data_at).unwrap();
                        let comp = h.compression.clone().unwrap();
                        decompress(&comp, &raw, h.size.unwrap().into(), &mut plain, true).unwrap();
                        let data = if comp == b"none" { &raw } else { &plain };
                        for rec in inner_records(data).map_while(|r| r.ok()) {
                            if let Inner::Message { conn, time, data } = rec.1 {
                                out.push((conn, time, data.to_vec()));
                            }
                        }
                    }
                    return (out, at < bag.len);
                }
                At::Bad(e) => panic!("{e}"),
            }
        }
    }

    #[test]
    fn reads_what_the_rosbag_crate_reads() {
        let dir = std::env::temp_dir().join(format!("thermrs-ros1bag-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("three.bag");
        let (bytes, written) = bag(40);
        std::fs::write(&path, &bytes).unwrap();
        // The independent reader: the `rosbag` crate.
        let theirs = rosbag::RosBag::new(&path).unwrap();
        let mut want = Vec::new();
        for rec in theirs.chunk_records() {
            if let rosbag::ChunkRecord::Chunk(c) = rec.unwrap() {
                for m in c.messages() {
                    if let rosbag::MessageRecord::MessageData(d) = m.unwrap() {
                        want.push((d.conn_id, d.time, d.data.to_vec()));
                    }
                }
            }
        }
        assert_eq!(want, written);
        let (got, cut) = read(&path);
        assert_eq!(got, want);
        assert!(!cut);
        assert!(Bag1::open(&path).unwrap().unwrap().indexed());
        // Cut inside each chunk's data: a prefix of the messages, those of the earlier chunks
        // at least; uncompressed, exactly the records the bytes hold whole.
        let bag1 = Bag1::open(&path).unwrap().unwrap();
        let mut buf = Vec::new();
        let mut at = bag1.first;
        let mut before = 0;
        for c in 0..3 {
            let At::Record(r) = bag1.record_at(at, &mut buf) else {
                panic!("a chunk")
            };
            let cut_at = r.data_at + r.data_len * 2 / 3;
            let cut = dir.join(format!("cut-{c}.bag"));
            std::fs::write(&cut, &bytes[..cut_at as usize]).unwrap();
            let (got, was_cut) = read(&cut);
            assert!(was_cut);
            assert_eq!(got[..], want[..got.len()]);
            assert!(got.len() >= before && got.len() < before + 40);
            if c == 0 {
                // Records before the cut, by the layout the test wrote.
                let plain_cut = (cut_at - r.data_at) as usize;
                let mut end = 2 * connection(0, "/a").len();
                let mut n = 0;
                for (conn, t, d) in &written[..40] {
                    end += record(
                        &[
                            ("op", &[OP_MSG_DATA]),
                            ("conn", &conn.to_le_bytes()),
                            ("time", &time(*t)),
                        ],
                        d,
                    )
                    .len();
                    if end <= plain_cut {
                        n += 1;
                    }
                }
                assert_eq!(got.len(), n);
            }
            before += 40;
            at = r.end();
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn damage_is_an_error_not_a_panic() {
        let mut out = Vec::new();
        assert!(decompress(b"bz2", &[1, 2, 3], 10, &mut out, false).is_err());
        assert!(decompress(b"lz4", &[1, 2, 3], 10, &mut out, false).is_err());
        assert!(decompress(b"zip", &[1, 2, 3], 10, &mut out, false).is_err());
        assert!(decompress(b"none", &[1, 2, 3], MAX_CHUNK_BYTES + 1, &mut out, false).is_err());
        assert!(Header::parse(&[200, 0, 0, 0, b'o']).is_err());
        assert!(Header::parse(&record(&[("conn", &[1, 2])], &[])[4..]).is_err());
        let rec = record(&[("op", &[OP_MSG_DATA])], &[1, 2]);
        assert!(matches!(
            inner_records(&rec).next(),
            Some(Err((0, Some(_))))
        ));
        assert!(matches!(
            inner_records(&rec[..rec.len() - 1]).next(),
            Some(Err((0, None)))
        ));
    }
}
