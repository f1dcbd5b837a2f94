//! Reading a damaged recording: the top-level record walk that survives bad record lengths
//! and opcodes, finding the next intact record from the summary's chunk index where the file
//! has one and by scanning where it has none; the limits every size read from a file is held
//! to; and what is known about the messages a damaged stretch held.

use std::collections::{BTreeMap, HashMap};

use mcap::records::op;

/// Largest uncompressed chunk accepted (a chunk claiming more is skipped and reported).
/// Writers use chunks of a few MiB; the limit bounds what one chunk can make a thread hold.
pub const MAX_CHUNK_BYTES: u64 = 256 << 20;

/// Whether `opcode` may appear in an MCAP data section. 0x00 and 0x10–0x7F are reserved
/// (never written), 0x80–0xFF are application records (skipped), 0x01 (header) appears once
/// at the start and never after.
pub fn valid_opcode(opcode: u8) -> bool {
    matches!(opcode, 0x02..=0x0F | 0x80..=0xFF)
}

/// The record at `pos` of `body` (MCAP bytes after the magic): opcode and body range, if its
/// header is complete and its length fits.
pub fn record_at(body: &[u8], pos: usize) -> Option<(u8, usize, usize)> {
    let head = body.get(pos..pos.checked_add(9)?)?;
    let len = u64::from_le_bytes(head[1..9].try_into().ok()?);
    let end = usize::try_from(len).ok()?.checked_add(pos + 9)?;
    (end <= body.len()).then_some((head[0], pos + 9, end))
}

/// Whether an intact record plausibly starts at `pos`: a data-section opcode, a length that
/// fits, a body that parses (records the walk uses), and the record after it starting the
/// same way (or the end of the file).
pub fn plausible_at(body: &[u8], pos: usize) -> bool {
    let Some((opcode, from, end)) = record_at(body, pos) else {
        return false;
    };
    if !matches!(opcode, 0x02..=0x0F) {
        return false;
    }
    let rec = &body[from..end];
    let parses = match opcode {
        op::SCHEMA | op::CHANNEL | op::MESSAGE => mcap::read::parse_record(opcode, rec).is_ok(),
        op::CHUNK => match mcap::read::parse_record(opcode, rec) {
            Ok(mcap::records::Record::Chunk { header, .. }) => {
                matches!(header.compression.as_str(), "" | "zstd" | "lz4")
                    && header.uncompressed_size <= MAX_CHUNK_BYTES
            }
            _ => false,
        },
        op::MESSAGE_INDEX => rec.len() >= 6 && (rec.len() - 6) % 16 == 0,
        // The footer is the last record before the closing magic.
        op::FOOTER => end + super::MAGIC.len() == body.len(),
        _ => true,
    };
    if !parses {
        return false;
    }
    // The magic after the footer, or the next record.
    if end == body.len() || opcode == op::FOOTER {
        return true;
    }
    match record_at(body, end) {
        Some((next, _, _)) => matches!(next, 0x02..=0x0F),
        None => false,
    }
}

/// The next offset after `pos` where an intact record starts: the next chunk of the summary's
/// index if it has one there, else the first plausible record found by scanning (`holes`,
/// ranges of `body` the file system holds no data for, are jumped over unread).
pub fn resync(
    body: &[u8],
    pos: usize,
    chunk_starts: &[usize],
    holes: &[(usize, usize)],
) -> Option<usize> {
    let i = chunk_starts.partition_point(|&s| s <= pos);
    for &s in &chunk_starts[i..] {
        if record_at(body, s).is_some_and(|(o, _, _)| o == op::CHUNK) {
            return Some(s);
        }
    }
    // Past the last indexed chunk, or no index: scan. Candidates are bytes holding a
    // data-section opcode followed by a length that fits; most fail on the length.
    let mut q = pos + 1;
    while q + 9 <= body.len() {
        if let Some(&(_, end)) = holes.iter().find(|&&(a, b)| a <= q && q < b) {
            q = end;
            continue;
        }
        if matches!(body[q], 0x02..=0x0F) && plausible_at(body, q) {
            return Some(q);
        }
        q += 1;
    }
    None
}

/// The summary CRC-32 a complete file's footer stores, and the one its bytes give, where the
/// writer stored one (the footer's `summary_crc` covers the summary section up to the footer's
/// own CRC field; 0 means none was stored). `buf` is the whole file.
pub fn summary_crc(buf: &[u8]) -> Option<(u32, u32)> {
    const FOOTER: usize = 1 + 8 + 8 + 8 + 4;
    let magic = super::MAGIC.len();
    let at = buf.len().checked_sub(magic + FOOTER)?;
    let f = &buf[at..buf.len() - magic];
    if f[0] != op::FOOTER || !buf.ends_with(super::MAGIC) {
        return None;
    }
    let start = usize::try_from(u64::from_le_bytes(f[9..17].try_into().ok()?)).ok()?;
    let stored = u32::from_le_bytes(f[25..29].try_into().ok()?);
    if stored == 0 || start == 0 || start > at {
        return None;
    }
    Some((stored, crc32fast::hash(&buf[start..at + 25])))
}

/// Whether the file ends with the closing magic (a complete file, not one cut short).
pub fn closed(body: &[u8]) -> bool {
    body.len() >= super::MAGIC.len() && body.ends_with(super::MAGIC)
}

/// Messages per channel listed by the message index record body `rec`, if it is one.
pub fn message_index_count(rec: &[u8]) -> Option<(u16, u64)> {
    let channel = u16::from_le_bytes(rec.get(0..2)?.try_into().ok()?);
    let bytes = u32::from_le_bytes(rec.get(2..6)?.try_into().ok()?) as usize;
    let have = rec.len() - 6;
    Some((channel, (bytes.min(have) / 16) as u64))
}

/// Messages per channel of the chunks whose records start in `from..to` (file offsets),
/// from the summary's chunk index and the message index records it points at.
pub fn indexed_losses(
    file: &[u8],
    index: &[mcap::records::ChunkIndex],
    from: u64,
    to: u64,
) -> BTreeMap<u16, u64> {
    let mut out = BTreeMap::new();
    for ci in index
        .iter()
        .filter(|c| c.chunk_start_offset >= from && c.chunk_start_offset < to)
    {
        for &at in ci.message_index_offsets.values() {
            let Ok(at) = usize::try_from(at) else {
                continue;
            };
            if let Some((o, b, e)) = record_at(file, at) {
                if o == op::MESSAGE_INDEX {
                    if let Some((ch, n)) = message_index_count(&file[b..e]) {
                        *out.entry(ch).or_insert(0) += n;
                    }
                }
            }
        }
    }
    out
}

/// Messages per channel in the records of a chunk (the messages a chunk that fails its
/// checksum held, as far as its damaged records still tell).
pub fn count_messages(records: &[u8]) -> BTreeMap<u16, u64> {
    let mut out = BTreeMap::new();
    let mut pos = 0;
    while let Some((o, b, e)) = record_at(records, pos) {
        if o == op::MESSAGE && e - b >= 2 {
            let ch = u16::from_le_bytes([records[b], records[b + 1]]);
            *out.entry(ch).or_insert(0) += 1;
        }
        pos = e;
    }
    out
}

/// Name what each loss held by topic (the message indexes the file wrote after the chunk
/// where they survive, else the summary's index or the chunk's own records), add it to the
/// loss's line and sum it per topic.
pub(super) fn name_losses(
    report: &mut super::Report,
    indexed: &HashMap<u64, BTreeMap<u16, u64>>,
    reg: &super::Registry,
) {
    report.losses.sort_by_key(|l| l.offset);
    for loss in &mut report.losses {
        // A lost chunk's message indexes tell what it held (not for messages lost within a
        // chunk read otherwise whole, which name their own channels).
        if loss.kind != "undefined_channel" {
            if let Some(m) = indexed.get(&loss.offset) {
                loss.channels_lost = m.clone();
            }
        }
        for (ch, n) in &loss.channels_lost {
            let topic = reg
                .channels
                .get(ch)
                .map(|c| c.topic.clone())
                .unwrap_or_else(|| format!("channel {ch}"));
            *loss.messages_lost.entry(topic).or_insert(0) += n;
        }
        if !loss.messages_lost.is_empty() {
            let list: Vec<String> = loss
                .messages_lost
                .iter()
                .map(|(t, n)| format!("{n} on {t}"))
                .collect();
            loss.detail
                .push_str(&format!("; messages lost: {}", list.join(", ")));
        }
        for (t, n) in &loss.messages_lost {
            *report.lost_messages.entry(t.clone()).or_insert(0) += n;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rec(opcode: u8, body: &[u8]) -> Vec<u8> {
        let mut v = vec![opcode];
        v.extend_from_slice(&(body.len() as u64).to_le_bytes());
        v.extend_from_slice(body);
        v
    }

    #[test]
    fn scanning_skips_garbage_to_the_next_record_chain() {
        let mut body = vec![
            0x06, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0x7f, 1, 2, 3,
        ];
        let good = body.len();
        body.extend(rec(op::DATA_END, &[0, 0, 0, 0]));
        body.extend(rec(op::MESSAGE_INDEX, &[1, 0, 0, 0, 0, 0]));
        assert_eq!(resync(&body, 0, &[], &[]), Some(good));
        // An index entry wins over scanning, if a chunk is there; a bad one is ignored.
        assert_eq!(resync(&body, 0, &[good], &[]), Some(good));
        // Nothing after the last record: no resync.
        assert_eq!(resync(&body, good + 13, &[], &[]), None);
    }

    #[test]
    fn message_index_counts_are_bounded_by_the_record() {
        let mut r = vec![7, 0];
        r.extend_from_slice(&u32::MAX.to_le_bytes());
        r.extend_from_slice(&[0u8; 32]);
        assert_eq!(message_index_count(&r), Some((7, 2)));
        assert_eq!(message_index_count(&[1]), None);
    }
}
