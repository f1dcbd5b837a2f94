//! Running a unit of work: a batch of loose messages, or a chunk (its route to the detector
//! chosen, decompressed into a reused buffer, its records checksummed and interpreted one by
//! one, a chunk that fails its CRC dropped whole).

use mcap::records::{op, ChunkHeader, MessageHeader, Record};

use super::*;

impl Context<'_> {
    /// Process one unit of work: every message, or with `only` just those at the places
    /// listed (sorted; a rerun of messages deferred for an unknown channel, whose unit was
    /// already checked, counted and reported).
    pub(super) fn run(&self, reg: &Registry, work: &Work<'_>, only: Option<&[usize]>) -> Part {
        match work {
            Work::Loose(msgs) => self.run_loose(reg, msgs, only),
            Work::Chunk {
                offset,
                bytes,
                header,
                data,
                partial,
            } => self.run_chunk(
                reg,
                ChunkAt {
                    offset: *offset,
                    bytes: *bytes,
                    header,
                    partial: *partial,
                },
                data,
                only,
            ),
        }
    }

    fn run_loose(
        &self,
        reg: &Registry,
        msgs: &[(MessageHeader, &[u8])],
        only: Option<&[usize]>,
    ) -> Part {
        let mut part = Part::default();
        let local = Registry::default();
        for (i, (h, d)) in msgs.iter().enumerate() {
            if only.is_some_and(|o| o.binary_search(&i).is_err()) {
                continue;
            }
            if !self.message(reg, &local, h, d, &mut part) {
                // Perhaps defined later in the file: read again once it is.
                part.deferred.push((i, h.channel_id));
            }
        }
        part
    }

    fn run_chunk(
        &self,
        reg: &Registry,
        at: ChunkAt<'_>,
        data: &[u8],
        only: Option<&[usize]>,
    ) -> Part {
        let mut part = Part::default();
        part.report.chunks = u64::from(only.is_none());
        let started = std::time::Instant::now();
        // A rerun reads the chunk in place (or decompressed), untimed.
        let route = match only {
            None => self.route_for(&at, data),
            Some(_) => {
                if let Some(src) = self.source {
                    src.populate(data);
                }
                None
            }
        };
        CHUNK_BUF.with(|cell| {
            INPUT_BUF.with(|icell| {
                let mut scratch = cell.borrow_mut();
                // Uncompressed chunks are walked in place.
                let buf: &[u8] = if at.header.compression.is_empty() {
                    data
                } else if let Err(e) = decompress(at.header, data, at.partial, &mut scratch) {
                    part.report
                        .losses
                        .push(at.loss(format!("{} skipped: {e}", at.name())));
                    return;
                } else {
                    &scratch
                };
                let mut reader = ChunkReader::new(self, reg, &at, &mut part, only);
                // Read route: the chunk's records are copied window by window into a buffer
                // that stays in cache (`walk_read`), not mapped.
                let read = match (route, self.source) {
                    (Some(Route::Read), Some(src)) => {
                        let (from, len) = src.range(data);
                        let mut input = icell.borrow_mut();
                        Some(walk_read(
                            src.file,
                            from as u64,
                            len,
                            &mut input,
                            |a, o, b, r| reader.visit(a, o, b, r),
                        ))
                    }
                    _ => None,
                };
                let (stop, failed) = match read {
                    Some(Ok(stop)) => (stop, None),
                    Some(Err(e)) if reader.visited > 0 => (Some(0), Some(e)),
                    // In place (or the read failed at once: the map has the same bytes).
                    _ => (
                        walk(buf, |a, o, b| {
                            reader.visit(a, o, b, &buf[a..a + 9 + b.len()])
                        }),
                        None,
                    ),
                };
                if let Some(e) = failed {
                    reader.err = Some(format!("read failed: {e}"));
                }
                reader.finish(buf, stop);
            })
        });
        if let (Some(route), Some(src)) = (route, self.source) {
            if route == Route::Map {
                // Unmap the chunk's whole pages now, so that the cost is timed with its route
                // (the window's ends are released by the walk).
                let (from, len) = src.range(data);
                let page = 4096;
                src.release(from.div_ceil(page) * page, (from + len) / page * page);
            }
            self.routes.record(route, started.elapsed(), data.len());
        }
        part
    }

    /// The route of an uncompressed chunk of a mapped file (timed), or `None` (in memory,
    /// compressed or cut; a compressed chunk's pages are mapped in with one call).
    fn route_for(&self, at: &ChunkAt<'_>, data: &[u8]) -> Option<Route> {
        let src = self.source?;
        if at.header.compression.is_empty() && !at.partial {
            // The mapped route is mapped in by the faults of the walk itself: one
            // `MADV_POPULATE_READ` for the chunk costs more (it maps page by page; a fault
            // maps a folio's pages at once).
            Some(self.routes.pick())
        } else {
            src.populate(data);
            None
        }
    }
}

/// Where a chunk is in the file and its header.
struct ChunkAt<'h> {
    /// File offset of the chunk record.
    offset: u64,
    /// Bytes of the whole chunk record (opcode and length included).
    bytes: u64,
    header: &'h ChunkHeader,
    /// The chunk was cut short: decode what is there.
    partial: bool,
}

impl ChunkAt<'_> {
    fn name(&self) -> String {
        format!(
            "chunk at bytes {}..{}",
            self.offset,
            self.offset + self.bytes
        )
    }

    fn loss(&self, detail: String) -> Loss {
        Loss::new("corrupt_chunk", self.offset, self.bytes, detail)
    }
}

/// The records of one chunk, interpreted one by one into `part`. The CRC is taken record by
/// record just before each is interpreted, so that its pass brings the frame into cache for the
/// detector (one pass over memory, not two).
struct ChunkReader<'a, 'r> {
    ctx: &'a Context<'r>,
    reg: &'a Registry,
    at: &'a ChunkAt<'a>,
    part: &'a mut Part,
    check: bool,
    hasher: crc32fast::Hasher,
    /// Bytes of the chunk checksummed so far.
    hashed: usize,
    /// Channels and schemas the chunk defines.
    local: Registry,
    err: Option<String>,
    /// Messages read.
    n: u64,
    /// Records visited.
    visited: usize,
    /// Read only the messages at these record offsets (a rerun of deferred messages).
    only: Option<&'a [usize]>,
}

impl<'a, 'r> ChunkReader<'a, 'r> {
    fn new(
        ctx: &'a Context<'r>,
        reg: &'a Registry,
        at: &'a ChunkAt<'a>,
        part: &'a mut Part,
        only: Option<&'a [usize]>,
    ) -> Self {
        ChunkReader {
            ctx,
            reg,
            check: ctx.verify_crc
                && !at.partial
                && at.header.uncompressed_crc != 0
                && only.is_none(),
            at,
            part,
            hasher: crc32fast::Hasher::new(),
            hashed: 0,
            local: Registry::default(),
            err: None,
            n: 0,
            visited: 0,
            only,
        }
    }

    /// One record at chunk offset `at` (`record`: its bytes with opcode and length). Returns
    /// false to stop the walk (a bad record). A message on a channel nobody has defined yet
    /// is deferred and the walk goes on.
    fn visit(&mut self, at: usize, opcode: u8, body: &[u8], record: &[u8]) -> bool {
        self.visited += 1;
        if self.check {
            self.hasher.update(record);
            self.hashed = at + record.len();
        }
        if let Some(only) = self.only {
            if opcode != op::MESSAGE || only.binary_search(&at).is_err() {
                return true;
            }
        }
        match opcode {
            op::SCHEMA | op::CHANNEL => match mcap::read::parse_record(opcode, body) {
                Ok(r) => {
                    self.local.absorb(&r);
                    true
                }
                Err(e) => {
                    self.err = Some(format!("bad record: {e}"));
                    false
                }
            },
            op::MESSAGE => match mcap::read::parse_record(opcode, body) {
                Ok(Record::Message { header, data }) => {
                    self.n += 1;
                    let known = self
                        .ctx
                        .message(self.reg, &self.local, &header, &data, self.part);
                    if !known {
                        self.part.deferred.push((at, header.channel_id));
                    }
                    true
                }
                Ok(_) => true,
                Err(e) => {
                    self.err = Some(format!("bad message record: {e}"));
                    false
                }
            },
            _ => true,
        }
    }

    /// After the walk (`stop`: the offset of an incomplete record it ended at): the CRC
    /// checked over the whole chunk (`buf`), and what went wrong reported.
    fn finish(self, buf: &[u8], stop: Option<usize>) {
        let (at, part) = (self.at, self.part);
        if self.only.is_some() {
            // A rerun: the chunk's damage was reported by its first reading.
            return;
        }
        if self.check {
            let mut hasher = self.hasher;
            hasher.update(&buf[self.hashed..]);
            let crc = hasher.finalize();
            if crc != at.header.uncompressed_crc {
                *part = Part::default();
                part.report.chunks = 1;
                part.report.crc_failures = 1;
                let mut loss = at.loss(format!(
                    "{} skipped: its CRC-32 is {crc:08x}, the header says {:08x}",
                    at.name(),
                    at.header.uncompressed_crc
                ));
                loss.channels_lost = recovery::count_messages(buf);
                part.report.losses.push(loss);
                return;
            }
        }
        part.registry = self.local;
        let n = self.n;
        if let Some(e) = self.err {
            part.report
                .losses
                .push(at.loss(format!("{}: {e}; {n} messages before it kept", at.name())));
        } else if stop.is_some() && !at.partial {
            part.report.losses.push(at.loss(format!(
                "{} ends inside a record; {n} messages before it kept",
                at.name()
            )));
        } else if at.partial {
            part.report.recovered_messages = n;
        }
    }
}
