//! Following an MCAP recording while it is written (`thermrs watch`): each step reads only the
//! complete records added since the last, through the same walk as [`extract`], and waits for
//! a record still being written instead of reporting it lost.
//!
//! The follower keeps where the next unread record starts and the schemas and channels met
//! so far (a writer defines each once, often inside an earlier chunk). A step maps the file up
//! to the end of its last complete record and walks from the follower's position: the bytes
//! before it are neither read nor mapped in again, so a step costs what the new records cost.
//! The recording is closed once its data section has ended (a Data End or Footer record) and
//! the file ends with the closing magic; the tables of every step, appended, are then the
//! tables [`extract`] gives on the finished file.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::*;

/// A recording followed while it is written.
#[derive(Debug, Clone)]
pub struct Follow {
    path: PathBuf,
    /// The file offset where the next unread record starts (0: the magic not read yet).
    pos: u64,
    reg: Registry,
    closed: bool,
}

/// What a follower keeps between steps, to go on in another process (a watch resumed).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct FollowState {
    /// The file offset where the next unread record starts.
    pub pos: u64,
    /// Schema names by id.
    pub schemas: Vec<(u16, String)>,
    /// Channels by id: topic, schema id, message encoding.
    pub channels: Vec<(u16, String, u16, String)>,
}

/// One step of a [`Follow`].
#[derive(Debug, Default)]
pub struct FollowStep {
    /// The tables of the records read in this step.
    pub tables: Tables,
    /// What the step read, skipped and lost (losses only in complete records: a record still
    /// being written is waited for).
    pub report: Report,
    /// The byte range read (`from..to`, file offsets).
    pub from: u64,
    pub to: u64,
    /// The recording is complete: nothing more will be added.
    pub closed: bool,
}

impl Follow {
    /// A follower of the MCAP file at `path`, from its start.
    pub fn new(path: &Path) -> Follow {
        Follow {
            path: path.to_path_buf(),
            pos: 0,
            reg: Registry::default(),
            closed: false,
        }
    }

    /// A follower that goes on from `state` (a previous follower's [`Follow::state`]).
    pub fn resume(path: &Path, state: &FollowState) -> Follow {
        let mut reg = Registry::default();
        for (id, name) in &state.schemas {
            reg.add_schema(*id, name);
        }
        for (id, topic, schema_id, encoding) in &state.channels {
            reg.add_channel(
                *id,
                ChannelInfo {
                    topic: topic.clone(),
                    schema_id: *schema_id,
                    encoding: encoding.clone(),
                },
            );
        }
        Follow {
            path: path.to_path_buf(),
            pos: state.pos,
            reg,
            closed: false,
        }
    }

    /// What to keep to go on later ([`Follow::resume`]).
    pub fn state(&self) -> FollowState {
        let mut schemas: Vec<(u16, String)> = self
            .reg
            .schemas
            .iter()
            .map(|(k, v)| (*k, v.clone()))
            .collect();
        schemas.sort();
        let mut channels: Vec<(u16, String, u16, String)> = self
            .reg
            .channels
            .iter()
            .map(|(k, c)| (*k, c.topic.clone(), c.schema_id, c.encoding.clone()))
            .collect();
        channels.sort();
        FollowState {
            pos: self.pos,
            schemas,
            channels,
        }
    }

    /// The file offset up to which the recording has been read.
    pub fn position(&self) -> u64 {
        self.pos
    }

    /// Whether the recording was complete at the last step.
    pub fn closed(&self) -> bool {
        self.closed
    }

    /// Topics of the channels met so far.
    pub fn topics(&self) -> Vec<String> {
        let mut t: Vec<String> = self
            .reg
            .channels
            .values()
            .map(|c| c.topic.clone())
            .collect();
        t.sort_unstable();
        t.dedup();
        t
    }

    /// Read the complete records added since the last step.
    ///
    /// # Errors
    /// [`Error::Io`] when the file cannot be read; [`Error::NotMcap`] when its first bytes are
    /// not MCAP's magic; [`Error::Interrupted`] when `progress` asked to stop (the follower is
    /// then where it was before the step).
    pub fn step(
        &mut self,
        rig: &Rig,
        opts: &ExtractOptions,
        progress: &ProgressFn<'_>,
    ) -> Result<FollowStep> {
        let name = self.path.display().to_string();
        let io = |source| Error::Io {
            path: name.clone(),
            source,
        };
        let file = std::fs::File::open(&self.path).map_err(io)?;
        let len = file.metadata().map_err(io)?.len();
        let magic = MAGIC.len() as u64;
        let mut out = FollowStep {
            from: self.pos.max(magic),
            to: self.pos.max(magic),
            closed: self.closed,
            ..FollowStep::default()
        };
        if self.closed || len < magic {
            return Ok(out);
        }
        // SAFETY: read-only map; a writer only appends to a recording being followed.
        let whole = unsafe { memmap2::Mmap::map(&file) }.map_err(io)?;
        if &whole[..MAGIC.len()] != MAGIC {
            return Err(Error::NotMcap {
                path: name,
                bytes: len,
            });
        }
        let start = self.pos.max(magic) as usize - MAGIC.len();
        let (stop, ended) = complete_records(&whole[MAGIC.len()..], start);
        let closed = ended && recovery::closed(&whole[MAGIC.len()..]);
        drop(whole);
        if stop == start {
            self.closed = closed;
            out.closed = closed;
            return Ok(out);
        }
        let upto = stop + MAGIC.len();
        // SAFETY: as above; the map stops at the last complete record.
        let mmap = unsafe { memmap2::MmapOptions::new().len(upto).map(&file) }.map_err(io)?;
        let _ = mmap.advise(memmap2::Advice::Sequential);
        let source = Source {
            file: &file,
            map: &mmap,
        };
        let mut ctx = Context::new(rig, opts.spot.clone(), Some(source), None);
        ctx.verify_crc = opts.verify_crc;
        let extent = Extent {
            len: upto as u64,
            holes: Vec::new(),
        };
        let mut walk = Walk::new(&mmap, extent, &ctx, opts.window_bytes, progress);
        walk.follow_from(start, self.reg.clone());
        if !walk.run() {
            return Err(Error::Interrupted);
        }
        self.reg = walk.reg.clone();
        self.pos = upto as u64;
        self.closed = closed;
        walk.report.file_bytes = upto as u64 - out.from;
        Ok(FollowStep {
            tables: walk.tables,
            report: walk.report,
            from: out.from,
            to: self.pos,
            closed,
        })
    }
}

/// Where the complete records from `start` end in `body` (an MCAP file's bytes after the
/// magic), and whether the data section ended there (a Data End or Footer record). A damaged
/// stretch is passed over where an intact record follows it (the walk reports it); where none
/// does yet, the stretch may be a record still being written, and the records end before it.
fn complete_records(body: &[u8], start: usize) -> (usize, bool) {
    let mut pos = start;
    loop {
        match recovery::record_at(body, pos) {
            Some((op::DATA_END | op::FOOTER, _, _)) => return (pos, true),
            Some((o, _, end)) if recovery::valid_opcode(o) || (o == op::HEADER && pos == 0) => {
                pos = end
            }
            Some(_) => match recovery::resync(body, pos, &[], &[]) {
                Some(next) => pos = next,
                None => return (pos, false),
            },
            None => return (pos, false),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ingest::tests::{frame_bits, paper_rig, write_spots};

    /// A recording appended a piece at a time (pieces cut inside chunks and record headers):
    /// each step reads from where the last stopped, claims no loss, and the steps' tables
    /// appended are the tables of the finished file; a follower resumed from a state goes on.
    #[test]
    fn steps_over_a_growing_file_give_the_finished_files_tables() {
        let rig = paper_rig();
        let dir = std::env::temp_dir();
        let src = dir.join(format!("thermrs-follow-src-{}.mcap", std::process::id()));
        let live = dir.join(format!("thermrs-follow-live-{}.mcap", std::process::id()));
        write_spots(&src, &rig);
        let full = std::fs::read(&src).unwrap();
        let (want, _) = extract(&src, &rig, &ExtractOptions::default(), &|_, _, _| true).unwrap();
        std::fs::write(&live, b"").unwrap();
        let mut f = Follow::new(&live);
        let mut got = Tables::default();
        let mut to = 0u64;
        let piece = full.len() / 9 + 4099;
        let mut at = 0;
        while at < full.len() {
            let end = (at + piece).min(full.len());
            let mut fh = std::fs::OpenOptions::new()
                .append(true)
                .open(&live)
                .unwrap();
            std::io::Write::write_all(&mut fh, &full[at..end]).unwrap();
            at = end;
            // Half way: go on in a follower resumed from the state.
            if at > full.len() / 2 && to > 0 && !f.closed() && f.state().pos == to {
                f = Follow::resume(&live, &f.state());
            }
            let s = f
                .step(&rig, &ExtractOptions::default(), &|_, _, _| true)
                .unwrap();
            assert!(s.report.losses.is_empty(), "{:?}", s.report.losses);
            assert_eq!(s.from, to.max(MAGIC.len() as u64));
            to = s.to;
            got.append(&s.tables);
            assert_eq!(s.closed, at == full.len());
        }
        assert!(f.closed());
        assert_eq!(frame_bits(&got.frames), frame_bits(&want.frames));
        std::fs::remove_file(&src).unwrap();
        std::fs::remove_file(&live).unwrap();
    }
}
