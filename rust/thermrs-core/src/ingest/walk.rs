//! The top-level walk of a recording: records read in file order, chunks and loose messages
//! gathered into windows that run in parallel ([`Walk::flush`]), damaged stretches skipped to
//! the next intact record and reported ([`Walk::skip_damage`]), a file cut short decoded as far
//! as it goes ([`Walk::finish_cut`]).

use std::collections::{BTreeMap, HashMap};

use mcap::records::{op, ChunkIndex, MessageHeader, Record};
use rayon::prelude::*;

use super::chunk::partial_chunk;
use super::{
    recovery, ChannelInfo, Context, Extent, Loss, MetadataRecord, Part, ProgressFn, Registry,
    Report, Tables, Work, MAGIC,
};

/// Loose messages batched into one unit of work.
const LOOSE_BATCH: usize = 256;

/// The state of a walk over the bytes after the magic (`body`) of a recording (`buf`).
pub(super) struct Walk<'b, 'c> {
    buf: &'b [u8],
    body: &'b [u8],
    ctx: &'c Context<'c>,
    progress: &'c ProgressFn<'c>,
    /// Compressed bytes of chunks per parallel window.
    window_limit: usize,
    pub(super) reg: Registry,
    pub(super) report: Report,
    pub(super) tables: Tables,
    chunk_index: Vec<ChunkIndex>,
    /// Where the summary's index says chunks start (offsets in `body`).
    chunk_starts: Vec<usize>,
    window: Vec<Work<'b>>,
    window_bytes: usize,
    /// Offset in `body` where the current window's bytes start.
    window_start: usize,
    loose: Vec<(MessageHeader, &'b [u8])>,
    frames_done: u64,
    /// The last chunk met (file offset), whose message index records follow it.
    last_chunk: Option<u64>,
    /// Messages per channel that each chunk's message index records count (by file offset),
    /// so that a lost chunk's messages can be told by topic where there is no summary.
    indexed: HashMap<u64, BTreeMap<u16, u64>>,
    /// The file's content hash so far, and the bytes of `buf` it covers.
    hasher: Option<(blake3::Hasher, usize)>,
    /// Units with messages on channels not defined anywhere before their window ended, and
    /// where those messages are in them: read again at the end of the file, once every
    /// definition it holds is known.
    deferred: Vec<(Work<'b>, Vec<(usize, u16)>)>,
    /// The file's length (`buf` stops where a trailing hole starts).
    file_len: u64,
    /// The holes the file system reports inside `body` (offsets in `body`).
    holes: Vec<(usize, usize)>,
    /// Whether the bytes from where the recording ends to the end of the file were reported
    /// as zeros.
    zeros_reported: bool,
    /// Read in file order, one unit at a time, definitions taken in as they come (a file
    /// that defines an id twice).
    exact: bool,
    /// Where in `body` the walk starts (a follower's next unread record; 0 otherwise).
    start: usize,
    /// The buffer stops where a recording still being written has no complete record yet: its
    /// end is not a cut, and zeros at it are bytes not yet written, not reserved space.
    live: bool,
}

impl<'b, 'c> Walk<'b, 'c> {
    /// A walk over `buf` (which starts with the magic), with the channels, schemas and chunk
    /// index of the file's summary where it has one.
    pub(super) fn new(
        buf: &'b [u8],
        extent: Extent,
        ctx: &'c Context<'c>,
        window_limit: usize,
        progress: &'c ProgressFn<'c>,
    ) -> Self {
        let mut walk = Walk {
            buf,
            body: &buf[MAGIC.len()..],
            ctx,
            progress,
            window_limit,
            reg: Registry::default(),
            report: Report {
                file_bytes: extent.len,
                ..Report::default()
            },
            tables: Tables::default(),
            chunk_index: Vec::new(),
            chunk_starts: Vec::new(),
            window: Vec::new(),
            window_bytes: 0,
            window_start: 0,
            loose: Vec::new(),
            frames_done: 0,
            last_chunk: None,
            indexed: HashMap::new(),
            hasher: None,
            deferred: Vec::new(),
            file_len: extent.len,
            holes: extent
                .holes
                .iter()
                .filter_map(|&(a, b)| {
                    let a = usize::try_from(a).ok()?.max(MAGIC.len()) - MAGIC.len();
                    let b = usize::try_from(b)
                        .ok()?
                        .min(buf.len())
                        .checked_sub(MAGIC.len())?;
                    (b > a).then_some((a, b))
                })
                .collect(),
            zeros_reported: false,
            exact: false,
            start: 0,
            live: false,
        };
        walk.read_summary();
        walk
    }

    /// Hash the whole file as the walk goes (each window's bytes after it ran, while they
    /// are still in the page cache and mapped): [`Report::content_hash`].
    pub(super) fn hash_content(&mut self) {
        self.hasher = Some((blake3::Hasher::new(), 0));
    }

    /// Hash `buf` up to `to` (an offset in `buf`).
    fn hash_upto(&mut self, to: usize) {
        if let Some((h, done)) = self.hasher.as_mut() {
            if to > *done {
                if rayon::current_num_threads() > 1 {
                    h.update_rayon(&self.buf[*done..to]);
                } else {
                    h.update(&self.buf[*done..to]);
                }
                *done = to;
            }
        }
    }

    /// Read in file order: one unit at a time, each schema and channel definition taken in
    /// where it is, so that a message takes the last definition before it (see
    /// `Registry::conflict`).
    pub(super) fn exact_order(&mut self) {
        self.exact = true;
        self.report.notes.push(
            "a schema or channel id is defined twice with different contents (MCAP forbids \
             it): each message was read with the definition before it in the file"
                .to_string(),
        );
    }

    /// Walk a recording still being written from `start` (an offset in `body` where a record
    /// starts), with the definitions `reg` met before it; `buf` ends at a record's end.
    pub(super) fn follow_from(&mut self, start: usize, reg: Registry) {
        self.start = start;
        self.window_start = start;
        self.live = true;
        self.reg.merge(&reg);
    }

    fn read_summary(&mut self) {
        if let Some((stored, got)) = recovery::summary_crc(self.buf).filter(|(a, b)| a != b) {
            self.report.notes.push(format!(
                "the summary section's CRC-32 is {got:08x}, the footer says {stored:08x}: the \
                 summary was not used; channels and schemas were taken from the data section"
            ));
            return;
        }
        let summary = match mcap::read::Summary::read(self.buf) {
            Ok(Some(s)) => s,
            Ok(None) => return,
            // A summary that repeats channels but not their schemas is valid MCAP the crate
            // will not assemble: the data section has what it lacks; nothing to say.
            Err(mcap::McapError::UnknownSchema(..)) => return,
            Err(e) => {
                if recovery::closed(self.body) {
                    self.report.notes.push(format!(
                        "the summary section is unreadable ({e}): channels and schemas were \
                         taken from the data section"
                    ));
                }
                return;
            }
        };
        self.report.used_summary = true;
        for (id, s) in &summary.schemas {
            self.reg.add_schema(*id, &s.name);
        }
        for (id, c) in &summary.channels {
            self.reg.channels.insert(
                *id,
                ChannelInfo {
                    topic: c.topic.clone(),
                    schema_id: c.schema.as_ref().map(|s| s.id).unwrap_or(0),
                    encoding: c.message_encoding.clone(),
                },
            );
        }
        self.chunk_index = summary.chunk_indexes;
        let mut starts: Vec<usize> = self
            .chunk_index
            .iter()
            .filter_map(|c| {
                usize::try_from(c.chunk_start_offset)
                    .ok()?
                    .checked_sub(MAGIC.len())
            })
            .collect();
        starts.sort_unstable();
        starts.dedup();
        self.chunk_starts = starts;
    }

    /// Walk every record. `Ok(false)`: the caller asked to stop.
    pub(super) fn run(&mut self) -> bool {
        let closed = recovery::closed(self.body);
        let mut pos = self.start;
        while pos < self.body.len() {
            let rec = recovery::record_at(self.body, pos);
            let mut damage = self.damage_at(pos, rec);
            if let Some((opcode, from, end)) = rec.filter(|_| damage.is_none()) {
                match opcode {
                    op::DATA_END | op::FOOTER => break,
                    op::SCHEMA | op::CHANNEL
                        if self.exact && !(self.loose.is_empty() && self.window.is_empty()) =>
                    {
                        // What came before is read with the definitions before it.
                        if !self.loose.is_empty() {
                            self.window
                                .push(Work::Loose(std::mem::take(&mut self.loose)));
                        }
                        self.window_bytes = 0;
                        if !self.flush(pos) {
                            return false;
                        }
                        damage = self.record(pos, opcode, from, end);
                    }
                    _ => damage = self.record(pos, opcode, from, end),
                }
                if damage.is_none() {
                    pos = end;
                }
            }
            if let Some(why) = damage {
                match self.skip_damage(pos, rec.is_some(), closed, &why) {
                    Some(next) => pos = next,
                    None => break,
                }
            }
            if self.window_full() && !self.flush(pos.min(self.body.len())) {
                return false;
            }
        }
        if !self.loose.is_empty() {
            self.window
                .push(Work::Loose(std::mem::take(&mut self.loose)));
        }
        // Always: the last call reports the whole file done.
        if !self.flush(self.body.len()) {
            return false;
        }
        self.read_deferred();
        let mapped = self.buf.len() as u64;
        if self.file_len > mapped && !self.zeros_reported {
            self.report.losses.push(Loss::new(
                "hole",
                mapped,
                self.file_len - mapped,
                format!(
                    "bytes {mapped}..{} are a hole: space the writer reserved and never filled \
                     (the file system holds no data there), not read",
                    self.file_len
                ),
            ));
        }
        recovery::name_losses(&mut self.report, &self.indexed, &self.reg);
        self.hash_upto(self.buf.len());
        if let Some((h, _)) = self.hasher.take() {
            // A trailing hole counts by its length (its zeros are never read).
            let hole = self.file_len - self.buf.len() as u64;
            self.report.content_hash = Some(crate::digest::finish(h, hole));
        }
        true
    }

    /// Why the record at `pos` cannot be read, if it cannot.
    fn damage_at(&self, pos: usize, rec: Option<(u8, usize, usize)>) -> Option<String> {
        let body = self.body;
        match rec {
            None if body.len() - pos < 9 => Some("an incomplete record header".to_string()),
            None => Some(format!(
                "a record whose length ({} bytes) runs past the end of the file",
                u64::from_le_bytes(body[pos + 1..pos + 9].try_into().expect("8 bytes"))
            )),
            Some((o, _, _)) if !(recovery::valid_opcode(o) || o == op::HEADER && pos == 0) => {
                Some(format!("a record with the invalid opcode 0x{o:02x}"))
            }
            Some(_) => None,
        }
    }

    /// Take in one intact record (body `from..end` of the record at `pos`); a chunk that does
    /// not parse is damage.
    fn record(&mut self, pos: usize, opcode: u8, from: usize, end: usize) -> Option<String> {
        let at = (pos + MAGIC.len()) as u64;
        let rec = &self.body[from..end];
        match opcode {
            op::SCHEMA | op::CHANNEL => {
                if let Ok(r) = mcap::read::parse_record(opcode, rec) {
                    self.reg.absorb(&r);
                }
            }
            op::MESSAGE => {
                self.last_chunk = None;
                if let Ok(Record::Message {
                    header,
                    data: std::borrow::Cow::Borrowed(data),
                }) = mcap::read::parse_record(opcode, rec)
                {
                    self.window_bytes += data.len();
                    self.loose.push((header, data));
                    if self.loose.len() >= LOOSE_BATCH {
                        self.window
                            .push(Work::Loose(std::mem::take(&mut self.loose)));
                    }
                }
            }
            op::CHUNK => match mcap::read::parse_record(opcode, rec) {
                Ok(Record::Chunk {
                    header,
                    data: std::borrow::Cow::Borrowed(data),
                }) => {
                    self.last_chunk = Some(at);
                    self.window_bytes += data.len();
                    // A writer that died while writing a chunk into space it had reserved
                    // leaves the chunk's length right and its data ending in zeros, with
                    // zeros after it: decoded as a cut chunk (every complete message kept).
                    let cut = !self.live
                        && !recovery::closed(self.body)
                        && data.len() >= 16
                        && data[data.len() - 16..].iter().all(|&b| b == 0)
                        && self.body.get(end).is_none_or(|&b| b == 0);
                    if cut {
                        let zeros = data.iter().rev().take_while(|&&b| b == 0).count() as u64;
                        let to = (end + MAGIC.len()) as u64;
                        self.report.losses.push(Loss::new(
                            "truncated",
                            to - zeros,
                            zeros,
                            format!(
                                "the chunk at bytes {at}..{to} ends in zeros where its data \
                                 should be (its writer died while writing it into reserved \
                                 space): complete messages in the chunk are recovered"
                            ),
                        ));
                    }
                    self.window.push(Work::Chunk {
                        offset: at,
                        bytes: (end - pos) as u64,
                        header,
                        data,
                        partial: cut,
                    });
                }
                Ok(_) => {}
                Err(e) => return Some(format!("a chunk record that does not parse ({e})")),
            },
            op::METADATA => {
                if let Ok(Record::Metadata(m)) = mcap::read::parse_record(opcode, rec) {
                    self.report.metadata.push(MetadataRecord {
                        name: m.name,
                        values: m.metadata,
                    });
                }
            }
            op::MESSAGE_INDEX => {
                if let (Some(c), Some((ch, n))) =
                    (self.last_chunk, recovery::message_index_count(rec))
                {
                    *self.indexed.entry(c).or_default().entry(ch).or_insert(0) += n;
                }
            }
            _ => {}
        }
        None
    }

    /// A damaged stretch at `pos` (`why`): skipped to the next intact record and reported.
    /// Returns where the walk goes on, or `None` where it ends (nothing intact after it, or
    /// the file was cut there: then the cut is decoded and reported).
    fn skip_damage(&mut self, pos: usize, whole: bool, closed: bool, why: &str) -> Option<usize> {
        let body = self.body;
        let at = (pos + MAGIC.len()) as u64;
        if body[pos] == 0 && self.zeros_to_end(pos) {
            // Zeros to the end: a writer that reserved space and died. The recording ends
            // here; nothing was lost in the zeros.
            let holes: u64 = self.holes.iter().map(|(a, b)| (b - a) as u64).sum::<u64>()
                + (self.file_len - self.buf.len() as u64);
            let end = self.file_len;
            let mut detail = format!(
                "bytes {at}..{end} hold only zeros: space the writer reserved and never filled; \
                 the recording ends at byte {at}"
            );
            if holes > 0 {
                detail.push_str(&format!(
                    " ({holes} of those bytes a hole the file system holds no data for, not read)"
                ));
            }
            self.report
                .losses
                .push(Loss::new("zeros", at, end - at, detail));
            self.zeros_reported = true;
            return None;
        }
        let is_chunk = body[pos] == op::CHUNK;
        // A file cut inside a chunk: decode what is there, nothing follows.
        let cut_chunk = !closed
            && !whole
            && is_chunk
            && body.len() - pos > 9
            && partial_chunk(&body[pos + 9..]).is_some();
        let next = if cut_chunk {
            None
        } else {
            recovery::resync(body, pos, &self.chunk_starts, &self.holes)
        };
        if next.is_none() && !closed && !whole {
            // A record running past the end of a file without its closing magic: the cut.
            self.finish_cut(pos);
            return None;
        }
        let to = next.unwrap_or(body.len());
        let to_at = (to + MAGIC.len()) as u64;
        let resumed = match next {
            Some(_) if self.chunk_starts.binary_search(&to).is_ok() => {
                "reading resumed at the next chunk of the summary's index"
            }
            Some(_) => "reading resumed at the next intact record",
            None => "nothing intact after it",
        };
        let mut loss = Loss::new(
            if is_chunk {
                "corrupt_chunk"
            } else {
                "corrupt_record"
            },
            at,
            to_at - at,
            format!("bytes {at}..{to_at} skipped: {why} at byte {at}; {resumed}"),
        );
        loss.channels_lost = recovery::indexed_losses(self.buf, &self.chunk_index, at, to_at);
        self.report.losses.push(loss);
        self.last_chunk = Some(at);
        next
    }

    /// Whether `body` holds only zeros from `pos` to its end: holes are taken as zeros without
    /// reading them; other bytes are read a block at a time, their pages released behind.
    fn zeros_to_end(&self, pos: usize) -> bool {
        const BLOCK: usize = 1 << 20;
        let mut q = pos;
        while q < self.body.len() {
            if let Some(&(_, b)) = self.holes.iter().find(|&&(a, b)| a <= q && q < b) {
                q = b;
                continue;
            }
            let next_hole = self
                .holes
                .iter()
                .map(|&(a, _)| a)
                .filter(|&a| a > q)
                .min()
                .unwrap_or(self.body.len());
            let end = (q + BLOCK).min(next_hole);
            if self.body[q..end].iter().any(|&b| b != 0) {
                return false;
            }
            if let Some(src) = self.ctx.source {
                src.release(MAGIC.len() + q, MAGIC.len() + end);
            }
            q = end;
        }
        true
    }

    /// The file is cut inside the record at `pos`: the complete messages of a cut chunk are
    /// decoded, and the cut is reported.
    fn finish_cut(&mut self, pos: usize) {
        let rest = &self.body[pos..];
        let offset = (pos + MAGIC.len()) as u64;
        let mut detail = format!(
            "the file is cut short: the record at byte {offset} is incomplete ({} of its bytes present, bytes {offset}..{} lost)",
            rest.len(),
            offset + rest.len() as u64
        );
        if rest.first() == Some(&op::CHUNK) && rest.len() > 9 {
            if let Some((header, data)) = partial_chunk(&rest[9..]) {
                self.window.push(Work::Chunk {
                    offset,
                    bytes: rest.len() as u64,
                    header,
                    data,
                    partial: true,
                });
                detail.push_str("; complete messages in the cut chunk are recovered");
            }
        }
        self.report
            .losses
            .push(Loss::new("truncated", offset, rest.len() as u64, detail));
    }

    /// At the end of the file: the messages deferred for a channel not yet defined, read now
    /// that every definition the file holds is known; those whose channel the file never
    /// defines are reported as lost, per unit, with their byte range and channel.
    fn read_deferred(&mut self) {
        let deferred = std::mem::take(&mut self.deferred);
        let ctx = self.ctx;
        // A schema the file never defines is read as none (the message is then skipped for
        // its schema, with the reason).
        let mut reg = self.reg.clone();
        let missing: Vec<u16> = reg
            .channels
            .values()
            .map(|c| c.schema_id)
            .filter(|id| *id != 0 && !reg.schemas.contains_key(id))
            .collect();
        for id in missing {
            reg.schemas.insert(id, String::new());
        }
        let reg = &reg;
        let parts: Vec<Part> = deferred
            .par_iter()
            .map(|(w, d)| {
                let at: Vec<usize> = d.iter().map(|x| x.0).collect();
                ctx.run(reg, w, Some(&at))
            })
            .collect();
        for ((w, _), p) in deferred.iter().zip(parts) {
            self.frames_done += p.tables.frames.t_ns.len() as u64;
            self.tables.append(&p.tables);
            self.report.merge(&p.report);
            if p.deferred.is_empty() {
                continue;
            }
            let mut by: BTreeMap<u16, u64> = BTreeMap::new();
            for &(_, ch) in &p.deferred {
                *by.entry(ch).or_insert(0) += 1;
            }
            let ids: Vec<String> = by.keys().map(|c| c.to_string()).collect();
            let n = p.deferred.len();
            let (offset, bytes, place) = match w {
                Work::Chunk { offset, bytes, .. } => (
                    *offset,
                    *bytes,
                    format!("chunk at bytes {offset}..{}", offset + bytes),
                ),
                Work::Loose(msgs) => {
                    // The loose messages' own bytes, from the first deferred to the last.
                    let span = |i: usize| {
                        let d = msgs[i].1;
                        let at = d.as_ptr() as usize - self.buf.as_ptr() as usize;
                        (at, at + d.len())
                    };
                    let from = span(p.deferred[0].0).0 as u64;
                    let to = span(p.deferred[n - 1].0).1 as u64;
                    (from, to - from, format!("messages at bytes {from}..{to}"))
                }
            };
            let mut loss = Loss::new(
                "undefined_channel",
                offset,
                bytes,
                format!(
                    "{place}: {n} message{} on channel{} {} that the file never defines skipped \
                     (its other messages kept)",
                    if n == 1 { "" } else { "s" },
                    if by.len() == 1 { "" } else { "s" },
                    ids.join(", ")
                ),
            );
            loss.channels_lost = by;
            self.report.losses.push(loss);
        }
    }

    /// The window holds enough to run (its bytes, or its units for the pool); loose messages
    /// gathered so far join it.
    fn window_full(&mut self) -> bool {
        let full = self.window_bytes >= self.window_limit
            || self.window.len() >= 16 * rayon::current_num_threads().max(1)
            || (self.exact && !self.window.is_empty());
        if full {
            if !self.loose.is_empty() {
                self.window
                    .push(Work::Loose(std::mem::take(&mut self.loose)));
            }
            self.window_bytes = 0;
        }
        full
    }

    /// Run the window's units in parallel and take in their parts in file order; a unit that
    /// met a channel defined by another unit of the window runs again once the window's
    /// channels are known. Pages before `upto` are released. Returns what the progress
    /// callback returns (false: stop).
    fn flush(&mut self, upto: usize) -> bool {
        let ctx = self.ctx;
        let reg = &self.reg;
        // One thread: run here. Handing each window to a pool of one thread and waiting for
        // it is two context switches per window for nothing (futex waits on the pool's latch
        // were a tenth of a one-thread extraction's switches, `perf record -e sched:sched_switch`).
        let serial = rayon::current_num_threads() <= 1;
        let parts: Vec<Part> = if serial {
            self.window.iter().map(|w| ctx.run(reg, w, None)).collect()
        } else {
            self.window
                .par_iter()
                .map(|w| ctx.run(reg, w, None))
                .collect()
        };
        for p in &parts {
            self.reg.merge(&p.registry);
        }
        // Messages on channels defined elsewhere in the window (a chunk run beside the one
        // defining them) are read again now; those still unknown wait for the end of the file.
        let reg = &self.reg;
        let window = &self.window;
        let rerun = |(i, p): (usize, &Part)| {
            (!p.deferred.is_empty()).then(|| {
                let at: Vec<usize> = p.deferred.iter().map(|d| d.0).collect();
                (i, ctx.run(reg, &window[i], Some(&at)))
            })
        };
        let again: Vec<(usize, Part)> = if serial {
            parts.iter().enumerate().filter_map(rerun).collect()
        } else {
            parts.par_iter().enumerate().filter_map(rerun).collect()
        };
        let mut done: Vec<Vec<Part>> = parts.into_iter().map(|p| vec![p]).collect();
        for (i, mut p) in again {
            if !p.deferred.is_empty() {
                self.deferred
                    .push((self.window[i].clone(), std::mem::take(&mut p.deferred)));
            }
            done[i].push(p);
        }
        for p in done.into_iter().flatten() {
            // Deferred messages are in `self.deferred` (or read by the rerun just added).
            self.frames_done += p.tables.frames.t_ns.len() as u64;
            self.tables.append(&p.tables);
            self.report.merge(&p.report);
        }
        self.window.clear();
        self.hash_upto(MAGIC.len() + upto);
        if let Some(src) = ctx.source {
            src.release(
                MAGIC.len() + self.window_start.min(upto),
                MAGIC.len() + upto,
            );
        }
        self.window_start = upto;
        (self.progress)(
            (upto + MAGIC.len()) as u64,
            self.buf.len() as u64,
            self.frames_done,
        )
    }
}
