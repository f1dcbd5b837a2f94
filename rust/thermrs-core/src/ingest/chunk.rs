//! Chunk bodies: decompression into a reused per-thread buffer (bounded by the header's
//! size and the limit), the record walk inside a buffer, and a chunk cut short.

use std::io::Read;

use mcap::records::ChunkHeader;

use super::recovery::MAX_CHUNK_BYTES;

thread_local! {
    pub(super) static CHUNK_BUF: std::cell::RefCell<Vec<u8>> = const { std::cell::RefCell::new(Vec::new()) };
    pub(super) static INPUT_BUF: std::cell::RefCell<Vec<u8>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Decompress a chunk's records into `out` (uncompressed chunks are walked in place and never
/// come here). For a cut chunk, decode as much as there is.
pub(super) fn decompress(
    header: &ChunkHeader,
    data: &[u8],
    partial: bool,
    out: &mut Vec<u8>,
) -> std::result::Result<(), String> {
    out.clear();
    // The header's size is checked before anything is reserved for it, and no decoder may
    // write past it: memory follows what the data really holds, up to the limit.
    if header.uncompressed_size > MAX_CHUNK_BYTES {
        return Err(format!(
            "the chunk header claims {} uncompressed bytes, more than the {} MiB limit",
            header.uncompressed_size,
            MAX_CHUNK_BYTES >> 20
        ));
    }
    let want = header.uncompressed_size as usize;
    match header.compression.as_str() {
        "zstd" if !partial => {
            out.reserve(want);
            zstd::bulk::Decompressor::new()
                .and_then(|mut d| d.decompress_to_buffer(data, out))
                .map_err(|e| format!("zstd: {e}"))?;
        }
        "zstd" => {
            let dec =
                zstd::stream::read::Decoder::with_buffer(data).map_err(|e| format!("zstd: {e}"))?;
            read_until_error(dec, out, want);
        }
        "lz4" => {
            let dec = lz4::Decoder::new(data).map_err(|e| format!("lz4: {e}"))?;
            if partial {
                read_until_error(dec, out, want);
            } else {
                // One byte more than claimed tells a lying header from a true one.
                out.reserve(want);
                dec.take(want as u64 + 1)
                    .read_to_end(out)
                    .map_err(|e| format!("lz4: {e}"))?;
            }
        }
        other => return Err(format!("unsupported chunk compression {other:?}")),
    }
    if !partial && out.len() as u64 != header.uncompressed_size {
        return Err(format!(
            "decompressed to {} bytes, header says {}",
            out.len(),
            header.uncompressed_size
        ));
    }
    Ok(())
}

/// Read a stream until it ends or fails, keeping what came out.
pub(super) fn read_until_error(mut r: impl Read, out: &mut Vec<u8>, limit: usize) {
    let mut buf = vec![0u8; 1 << 16];
    while out.len() < limit {
        let room = (limit - out.len()).min(buf.len());
        match r.read(&mut buf[..room]) {
            Ok(0) | Err(_) => break,
            Ok(n) => out.extend_from_slice(&buf[..n]),
        }
    }
}

/// Walk the records of a buffer: `(offset, opcode, body)`; stops at the first incomplete one,
/// returning its offset.
pub(super) fn walk<'a>(
    buf: &'a [u8],
    mut f: impl FnMut(usize, u8, &'a [u8]) -> bool,
) -> Option<usize> {
    let mut pos = 0;
    while pos < buf.len() {
        if buf.len() - pos < 9 {
            return Some(pos);
        }
        let opcode = buf[pos];
        let len = u64::from_le_bytes(buf[pos + 1..pos + 9].try_into().expect("8 bytes"));
        let Some(end) = usize::try_from(len)
            .ok()
            .and_then(|l| (pos + 9).checked_add(l))
        else {
            return Some(pos);
        };
        if end > buf.len() {
            return Some(pos);
        }
        if !f(pos, opcode, &buf[pos + 9..end]) {
            return None;
        }
        pos = end;
    }
    None
}

/// Parse the fixed part of a chunk record that was cut short: its header and whatever records
/// bytes are present.
pub(super) fn partial_chunk(body: &[u8]) -> Option<(ChunkHeader, &[u8])> {
    let u64_at = |p: usize| {
        body.get(p..p + 8)
            .map(|b| u64::from_le_bytes(b.try_into().expect("8")))
    };
    let start = u64_at(0)?;
    let end = u64_at(8)?;
    let size = u64_at(16)?;
    let crc = u32::from_le_bytes(body.get(24..28)?.try_into().ok()?);
    let clen = u32::from_le_bytes(body.get(28..32)?.try_into().ok()?) as usize;
    let comp = std::str::from_utf8(body.get(32..32 + clen)?)
        .ok()?
        .to_string();
    let p = 32 + clen + 8; // skip records_length
    let data = body.get(p..)?;
    Some((
        ChunkHeader {
            message_start_time: start,
            message_end_time: end,
            uncompressed_size: size,
            uncompressed_crc: crc,
            compression: comp,
            compressed_size: data.len() as u64,
        },
        data,
    ))
}

/// Bytes copied per `pread` when a chunk is read record by record ([`walk_read`]): small
/// enough that the copy stays in the core's L2 cache for the checksum and the detector.
pub(super) const READ_WINDOW: usize = 256 << 10;

/// [`walk`] over the `len` record bytes of a chunk that start at byte `start` of `file`, read
/// with `pread` into `buf` a window at a time rather than mapped: each record is copied once
/// into a buffer that stays in cache, then handed to `f` as `(offset, opcode, body, record)`
/// (`record`: its bytes with opcode and length, for the checksum). A record longer than the
/// window grows the buffer to it; a record cut by the window's end is carried to the front of
/// the buffer and completed by the next read. Returns what [`walk`] returns: the offset of an
/// incomplete record at the end, if any.
pub(super) fn walk_read(
    file: &std::fs::File,
    start: u64,
    len: usize,
    buf: &mut Vec<u8>,
    mut f: impl FnMut(usize, u8, &[u8], &[u8]) -> bool,
) -> std::io::Result<Option<usize>> {
    use std::os::unix::fs::FileExt;
    let mut base = 0usize; // chunk offset of buf[0]
    let mut filled = 0usize;
    loop {
        if base == len {
            return Ok(None);
        }
        // The record at the front of the buffer: how many bytes it needs.
        let need = if filled >= 9 {
            let rlen = u64::from_le_bytes(buf[1..9].try_into().expect("8 bytes"));
            match usize::try_from(rlen).ok().and_then(|l| l.checked_add(9)) {
                Some(n) if base + n <= len => n,
                _ => return Ok(Some(base)),
            }
        } else {
            9
        };
        if filled < need {
            let want = need.max(READ_WINDOW).min(len - base);
            if want < need {
                return Ok(Some(base));
            }
            if buf.len() < want {
                buf.resize(want, 0);
            }
            file.read_exact_at(&mut buf[filled..want], start + (base + filled) as u64)?;
            filled = want;
            continue;
        }
        // Every complete record in the buffer.
        let mut q = 0usize;
        while filled - q >= 9 {
            let rlen = u64::from_le_bytes(buf[q + 1..q + 9].try_into().expect("8 bytes"));
            let Some(end) = usize::try_from(rlen)
                .ok()
                .and_then(|l| (q + 9).checked_add(l))
            else {
                return Ok(Some(base + q));
            };
            if base + end > len {
                return Ok(Some(base + q));
            }
            if end > filled {
                break;
            }
            if !f(base + q, buf[q], &buf[q + 9..end], &buf[q..end]) {
                return Ok(None);
            }
            q = end;
        }
        buf.copy_within(q..filled, 0);
        base += q;
        filled -= q;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `walk_read` (windows through a file) sees exactly what `walk` (the bytes in memory)
    /// sees: the same records at the same offsets, whole or cut anywhere.
    #[test]
    fn reading_by_windows_walks_the_same_records() {
        let mut bytes = Vec::new();
        let mut x = 12345u64;
        for i in 0..40u64 {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            // Sizes from 0 to ~600 KB: records shorter, around and longer than a window.
            let len = if i % 5 == 0 {
                (x >> 40) % 16
            } else {
                (x >> 33) % 600_000
            };
            bytes.push((i % 7 + 2) as u8);
            bytes.extend_from_slice(&len.to_le_bytes());
            bytes.extend((0..len).map(|k| (k as u8).wrapping_mul(31).wrapping_add(i as u8)));
        }
        let path = std::env::temp_dir().join(format!("thermrs-walk-{}.bin", std::process::id()));
        std::fs::write(&path, &bytes).unwrap();
        let file = std::fs::File::open(&path).unwrap();
        let mut buf = Vec::new();
        for cut in [bytes.len(), bytes.len() - 1, bytes.len() / 2, 5, 0] {
            let mut want = Vec::new();
            let w = walk(&bytes[..cut], |at, op, body| {
                want.push((at, op, body.to_vec()));
                true
            });
            let mut got = Vec::new();
            let g = walk_read(&file, 0, cut, &mut buf, |at, op, body, rec| {
                assert_eq!(rec, &bytes[at..at + 9 + body.len()]);
                got.push((at, op, body.to_vec()));
                true
            })
            .unwrap();
            assert_eq!((g, got.len()), (w, want.len()), "cut at {cut}");
            assert!(got == want, "cut at {cut}");
        }
        std::fs::remove_file(&path).unwrap();
    }
}
