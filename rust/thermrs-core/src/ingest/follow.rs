//! Following a recording while it is written (`thermrs watch`): an MCAP file or a rosbag2
//! SQLite database (`.db3`), told apart by their first bytes ([`crate::bag::sniff`]). Each
//! step reads only what was added since the last, through the same interpretation as
//! [`extract`], and waits for a record still being written instead of reporting it lost.
//!
//! The follower keeps where the next unread record starts and the schemas and channels met
//! so far (a writer defines each once, often inside an earlier chunk). A step maps the file up
//! to the end of its last complete record and walks from the follower's position: the bytes
//! before it are neither read nor mapped in again, so a step costs what the new records cost.
//! The recording is closed once its data section has ended (a Data End or Footer record) and
//! the file ends with the closing magic; the tables of every step, appended, are then the
//! tables [`extract`] gives on the finished file.
//!
//! A SQLite database is opened read-only at each step (its writer is not disturbed: SQLite's
//! own locking, with WAL or a rollback journal, shows only committed rows, and each batch's
//! query holds its shared lock only while it fetches that batch). The follower keeps the `id`
//! of the last message row read and the topics met (by their rosbag2 ids); a step reads the
//! topics added since and the rows whose `id` is above the last read, in `id` order, so that no
//! row is read twice. Its byte range (`from..to`) counts the bytes of the `data` column of the
//! rows read, from the first row. A database alone never says it is closed (a rosbag2 bag
//! folder's `metadata.yaml` does): its follower steps until it is stopped. A database whose
//! tables are not created yet is waited for.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::*;
use crate::bag::Storage;

/// A recording followed while it is written.
#[derive(Debug, Clone)]
pub struct Follow {
    path: PathBuf,
    /// The file offset where the next unread record starts (0: the magic not read yet).
    pos: u64,
    reg: Registry,
    closed: bool,
    /// For a SQLite database: the `id` of the last message row read (0: none).
    last_row: i64,
    /// The storage, once the first bytes say it.
    storage: Option<Storage>,
}

/// What a follower keeps between steps, to go on in another process (a watch resumed).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct FollowState {
    /// The file offset where the next unread record starts (a SQLite database: the bytes of
    /// message data read so far).
    pub pos: u64,
    /// Schema names by id.
    pub schemas: Vec<(u16, String)>,
    /// Channels by id: topic, schema id, message encoding.
    pub channels: Vec<(u16, String, u16, String)>,
    /// A SQLite database: the `id` of the last message row read (the channels' ids are then
    /// rosbag2's topic ids).
    #[serde(default)]
    pub last_row: i64,
}

/// One step of a [`Follow`].
#[derive(Debug, Default)]
pub struct FollowStep {
    /// The tables of the records read in this step.
    pub tables: Tables,
    /// What the step read, skipped and lost (losses only in complete records: a record still
    /// being written is waited for).
    pub report: Report,
    /// The byte range read (`from..to`: file offsets; a SQLite database: bytes of message
    /// data, counted from its first row).
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
            last_row: 0,
            storage: None,
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
            last_row: state.last_row,
            storage: None,
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
            last_row: self.last_row,
        }
    }

    /// The file offset up to which the recording has been read (a SQLite database: the bytes
    /// of message data read).
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

    /// Read the complete records (a SQLite database: the committed rows) added since the last
    /// step.
    ///
    /// # Errors
    /// [`Error::Io`] when the file cannot be read; [`Error::NotMcap`] when its first bytes are
    /// neither MCAP's nor SQLite's magic; [`Error::BadBag`] when a SQLite database's tables
    /// cannot be read as rosbag2's; [`Error::Interrupted`] when `progress` asked to stop (the
    /// follower is then where it was before the step).
    pub fn step(
        &mut self,
        rig: &Rig,
        opts: &ExtractOptions,
        progress: &ProgressFn<'_>,
    ) -> Result<FollowStep> {
        if self.storage.is_none() {
            self.storage = self.sniff()?;
        }
        match self.storage {
            Some(Storage::Sqlite) => self.step_sqlite(rig, opts, progress),
            Some(_) => self.step_mcap(rig, opts, progress),
            None => Ok(FollowStep {
                from: self.pos,
                to: self.pos,
                ..FollowStep::default()
            }),
        }
    }

    /// The storage by the file's first bytes; `None` while they do not say yet (no file, or
    /// the start of SQLite's header).
    fn sniff(&self) -> Result<Option<Storage>> {
        let head = match std::fs::File::open(&self.path) {
            Ok(f) => {
                let mut head = Vec::with_capacity(16);
                std::io::Read::read_to_end(&mut std::io::Read::take(f, 16), &mut head).map_err(
                    |source| Error::Io {
                        path: self.path.display().to_string(),
                        source,
                    },
                )?;
                head
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(source) => {
                return Err(Error::Io {
                    path: self.path.display().to_string(),
                    source,
                })
            }
        };
        Ok(match crate::bag::sniff(&head) {
            Storage::Sqlite => Some(Storage::Sqlite),
            _ if head.len() < crate::bag::SQLITE_MAGIC.len()
                && (head.is_empty() || crate::bag::SQLITE_MAGIC.starts_with(&head)) =>
            {
                None
            }
            s => Some(s),
        })
    }

    /// A step of a SQLite database: the topics added and the rows above the last read.
    fn step_sqlite(
        &mut self,
        rig: &Rig,
        opts: &ExtractOptions,
        progress: &ProgressFn<'_>,
    ) -> Result<FollowStep> {
        let name = self.path.display().to_string();
        let bad = |e: rusqlite::Error| Error::BadBag {
            path: name.clone(),
            reason: format!("its SQLite database cannot be read as a rosbag2 bag: {e}"),
        };
        let mut out = FollowStep {
            from: self.pos,
            to: self.pos,
            ..FollowStep::default()
        };
        let conn = sqlite::open(&self.path, &bad)?;
        let tables: i64 = conn
            .query_row(
                "SELECT COUNT(*) FROM sqlite_master WHERE type = 'table' \
                 AND name IN ('topics', 'messages')",
                [],
                |r| r.get(0),
            )
            .map_err(bad)?;
        if tables < 2 {
            return Ok(out); // the recorder has not created its tables yet
        }
        let mut ctx = Context::new(rig, opts.spot.clone(), None, None);
        ctx.verify_crc = opts.verify_crc;
        let mut reg = self.reg.clone();
        let mut cur = sqlite::Cursor {
            last_id: self.last_row,
            ..sqlite::Cursor::default()
        };
        for (k, c) in &reg.channels {
            cur.ids.insert(i64::from(*k), *k);
            cur.wanted
                .insert(i64::from(*k), ctx.roles.contains_key(c.topic.as_str()));
        }
        // The registry's ids are rosbag2's topic ids: a resumed follower knows them again.
        let same = |id: i64, _: usize| u16::try_from(id).ok();
        sqlite::read_topics(&conn, &name, &ctx, &mut reg, &mut cur, &same, &bad)?;
        let max_id: i64 = conn
            .query_row("SELECT COALESCE(MAX(id), 0) FROM messages", [], |r| {
                r.get(0)
            })
            .map_err(bad)?;
        let len = std::fs::metadata(&self.path).map(|m| m.len()).unwrap_or(0);
        let read = sqlite::read_messages(
            &conn,
            &ctx,
            &reg,
            &mut cur,
            opts,
            (len, max_id),
            progress,
            &bad,
        )?;
        self.reg = reg;
        self.last_row = cur.last_id;
        self.pos += read.data_bytes;
        out.tables = read.tables;
        out.report = read.report;
        out.report.file_bytes = read.data_bytes;
        out.to = self.pos;
        Ok(out)
    }

    /// A step of an MCAP file.
    fn step_mcap(
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

    /// A rosbag2 SQLite database filled by a writer holding it open (WAL, as rosbag2's
    /// resilient preset; then a rollback journal, its default), rows committed in batches, a
    /// topic added part way, every other message zstd-compressed as rosbag2's message
    /// compression leaves it: each step reads only the rows added, and the steps' tables
    /// appended are those `extract` gives on the MCAP file the messages came from; a follower
    /// resumed from its state goes on after the last row.
    #[test]
    fn steps_over_a_growing_sqlite_database_give_the_sources_tables() {
        let rig = paper_rig();
        let dir = std::env::temp_dir();
        let src = dir.join(format!("thermrs-follow-dbsrc-{}.mcap", std::process::id()));
        write_spots(&src, &rig);
        let (want, _) = extract(&src, &rig, &ExtractOptions::default(), &|_, _, _| true).unwrap();
        let bytes = std::fs::read(&src).unwrap();
        let msgs: Vec<mcap::Message<'_>> = mcap::MessageStream::new(&bytes)
            .unwrap()
            .map(|m| m.unwrap())
            .collect();
        assert_eq!(msgs.len(), 40);
        for journal in ["WAL", "MEMORY"] {
            let live = dir.join(format!(
                "thermrs-follow-{journal}-{}.db3",
                std::process::id()
            ));
            let _ = std::fs::remove_file(&live);
            let mut f = Follow::new(&live);
            let none = f
                .step(&rig, &ExtractOptions::default(), &|_, _, _| true)
                .unwrap();
            assert_eq!((none.from, none.to, none.closed), (0, 0, false));
            let w = rusqlite::Connection::open(&live).unwrap();
            w.pragma_update(None, "journal_mode", journal).unwrap();
            w.execute_batch(
                "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT \
                 NOT NULL, serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT \
                 NULL); CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT \
                 NULL, timestamp INTEGER NOT NULL, data BLOB NOT NULL);",
            )
            .unwrap();
            w.execute(
                "INSERT INTO topics VALUES (4, ?1, 'sensor_msgs/msg/Image', 'cdr', '')",
                [msgs[0].channel.topic.as_str()],
            )
            .unwrap();
            let mut got = Tables::default();
            let (mut row, mut data_bytes) = (0usize, 0u64);
            for (b, batch) in msgs.chunks(7).enumerate() {
                let tx = w.unchecked_transaction().unwrap();
                if b == 2 {
                    tx.execute(
                        "INSERT INTO topics VALUES (9, '/rosout', 'rcl_interfaces/msg/Log', \
                         'cdr', '')",
                        [],
                    )
                    .unwrap();
                    tx.execute(
                        "INSERT INTO messages(topic_id, timestamp, data) VALUES (9, 1, x'00')",
                        [],
                    )
                    .unwrap();
                    data_bytes += 1;
                }
                for m in batch {
                    let data = if row % 2 == 0 {
                        zstd::encode_all(&m.data[..], 3).unwrap()
                    } else {
                        m.data.to_vec()
                    };
                    data_bytes += data.len() as u64;
                    tx.execute(
                        "INSERT INTO messages(topic_id, timestamp, data) VALUES (4, ?1, ?2)",
                        rusqlite::params![m.log_time as i64, data],
                    )
                    .unwrap();
                    row += 1;
                }
                tx.commit().unwrap();
                if b == 3 {
                    f = Follow::resume(&live, &f.state());
                }
                let before = f.position();
                let s = f
                    .step(&rig, &ExtractOptions::default(), &|_, _, _| true)
                    .unwrap();
                assert!(s.report.losses.is_empty(), "{:?}", s.report.losses);
                assert!(!s.closed);
                assert_eq!(s.from, before);
                assert_eq!(s.to, data_bytes);
                assert_eq!(s.report.other_messages, u64::from(b == 2));
                assert_eq!(s.report.messages.values().sum::<u64>(), batch.len() as u64);
                got.append(&s.tables);
                // Nothing added: nothing read.
                let again = f
                    .step(&rig, &ExtractOptions::default(), &|_, _, _| true)
                    .unwrap();
                assert_eq!((again.from, again.to), (s.to, s.to));
                assert_eq!(again.tables.frames.t_ns.len(), 0);
            }
            assert_eq!(f.state().last_row, 41);
            assert_eq!(f.topics().len(), 2);
            assert_eq!(frame_bits(&got.frames), frame_bits(&want.frames));
            drop(w);
            for suffix in ["", "-wal", "-shm"] {
                let _ = std::fs::remove_file(format!("{}{suffix}", live.display()));
            }
        }
        std::fs::remove_file(&src).unwrap();
    }
}
