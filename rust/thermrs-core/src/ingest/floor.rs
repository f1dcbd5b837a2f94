//! The least a checked extraction must do, for benchmarks: every chunk's bytes checksummed in
//! place through the map, nothing interpreted.

use std::path::Path;

use mcap::records::{op, Record};

use super::chunk::walk;
use super::source::Source;
use super::MAGIC;
use crate::error::{Error, Result};

/// What [`checksum_chunks`] did: chunks seen, bytes checksummed, and the CRC-32 of the last
/// chunk (so that the work cannot be optimised away).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ChecksumScan {
    pub chunks: u64,
    pub bytes: u64,
    pub last_crc: u32,
}

/// CRC-32 of every chunk's stored bytes on the calling thread, read in place from the map as
/// [`super::extract`]'s mapped route reads them (mapped in by faults, dropped after each
/// chunk), and nothing else: the floor of a checked extraction of an uncompressed recording,
/// which must touch every byte at least once (BENCHMARKS.md compares it with one read).
pub fn checksum_chunks(path: &Path) -> Result<ChecksumScan> {
    let io = |source| Error::Io {
        path: path.display().to_string(),
        source,
    };
    let file = std::fs::File::open(path).map_err(io)?;
    // SAFETY: read-only map of a file not being written (as in `extract`).
    let map = unsafe { memmap2::Mmap::map(&file) }.map_err(io)?;
    if map.len() < MAGIC.len() || &map[..MAGIC.len()] != MAGIC {
        return Err(Error::NotMcap {
            path: path.display().to_string(),
            bytes: map.len() as u64,
        });
    }
    let src = Source {
        file: &file,
        map: &map,
    };
    let mut scan = ChecksumScan::default();
    let mut done = 0usize;
    walk(&map[MAGIC.len()..], |_, opcode, rec| {
        if opcode == op::CHUNK {
            if let Ok(Record::Chunk { data, .. }) = mcap::read::parse_record(opcode, rec) {
                scan.chunks += 1;
                scan.bytes += data.len() as u64;
                scan.last_crc = crc32fast::hash(&data);
                let (from, len) = src.range(&data);
                src.release(done, from + len);
                done = from + len;
            }
        }
        opcode != op::DATA_END
    });
    Ok(scan)
}

#[cfg(test)]
mod tests {
    /// CRC-32 by its definition (reflected polynomial 0xEDB88320, bit by bit): the
    /// reference the fast path must equal.
    fn crc32_by_definition(bytes: &[u8]) -> u32 {
        let mut c = !0u32;
        for &b in bytes {
            c ^= u32::from(b);
            for _ in 0..8 {
                c = if c & 1 == 1 {
                    (c >> 1) ^ 0xEDB8_8320
                } else {
                    c >> 1
                };
            }
        }
        !c
    }

    #[test]
    fn checksums_every_chunk_as_the_definition_does() {
        let path = std::env::temp_dir().join(format!("thermrs-floor-{}.mcap", std::process::id()));
        let mut w = mcap::WriteOptions::new()
            .compression(None)
            .chunk_size(Some(4096))
            .create(std::io::BufWriter::new(
                std::fs::File::create(&path).unwrap(),
            ))
            .unwrap();
        let ch = w
            .add_channel(0, "/x", "cdr", &std::collections::BTreeMap::new())
            .unwrap();
        for i in 0..10u64 {
            let header = mcap::records::MessageHeader {
                channel_id: ch,
                sequence: i as u32,
                log_time: i,
                publish_time: i,
            };
            w.write_to_known_channel(&header, &vec![i as u8 * 7; 1000])
                .unwrap();
        }
        w.finish().unwrap();
        drop(w);
        let bytes = std::fs::read(&path).unwrap();
        let chunks: Vec<Vec<u8>> = mcap::read::LinearReader::new(&bytes)
            .unwrap()
            .filter_map(|r| match r.unwrap() {
                mcap::records::Record::Chunk { data, .. } => Some(data.into_owned()),
                _ => None,
            })
            .collect();
        let scan = super::checksum_chunks(&path).unwrap();
        assert!(chunks.len() >= 2, "{} chunks", chunks.len());
        assert_eq!(scan.chunks, chunks.len() as u64);
        assert_eq!(
            scan.bytes,
            chunks.iter().map(|c| c.len() as u64).sum::<u64>()
        );
        assert_eq!(scan.last_crc, crc32_by_definition(chunks.last().unwrap()));
        std::fs::remove_file(&path).unwrap();
    }
}
