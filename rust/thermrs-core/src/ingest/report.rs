//! What an extraction read, skipped and lost: the report and its losses.

use std::collections::BTreeMap;

/// Data that could not be read.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Loss {
    /// `truncated` (file cut short), `corrupt_chunk` (a chunk that does not decompress,
    /// parse or match its checksum) or `corrupt_record` (a stretch of bad records).
    pub kind: &'static str,
    /// Byte offset of the damaged record.
    pub offset: u64,
    /// Bytes not used: the lost range is `offset..offset + bytes`.
    pub bytes: u64,
    /// One line: what happened, the byte range, what was recovered and lost.
    pub detail: String,
    /// Messages lost per topic, where the file tells (message indexes, the summary's chunk
    /// index, or the damaged chunk's own records); empty where it does not.
    pub messages_lost: BTreeMap<String, u64>,
    /// The file of a bag the loss is in (a bag folder read as one recording), else none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub part: Option<String>,
    /// The same by channel id, until the topics are known.
    #[serde(skip)]
    pub(super) channels_lost: BTreeMap<u16, u64>,
}

impl Loss {
    pub(super) fn new(kind: &'static str, offset: u64, bytes: u64, detail: String) -> Loss {
        Loss {
            kind,
            offset,
            bytes,
            detail,
            messages_lost: BTreeMap::new(),
            part: None,
            channels_lost: BTreeMap::new(),
        }
    }
}

/// What an extraction read, skipped and lost.
#[derive(Debug, Default, Clone, serde::Serialize)]
pub struct Report {
    pub file_bytes: u64,
    pub used_summary: bool,
    pub chunks: u64,
    /// Messages read per rig topic.
    pub messages: BTreeMap<String, u64>,
    /// Messages on topics the rig does not name.
    pub other_messages: u64,
    /// Skipped messages per reason ("topic: reason", numbers as `N`).
    pub skipped: BTreeMap<String, u64>,
    /// The first full reason of each group of `skipped`.
    pub skipped_examples: BTreeMap<String, String>,
    pub losses: Vec<Loss>,
    /// Complete messages recovered from a chunk the file was cut inside.
    pub recovered_messages: u64,
    /// The file's MCAP Metadata records, in file order (e.g. run markers, `thermrs.run`).
    pub metadata: Vec<MetadataRecord>,
    /// Chunks skipped because their CRC-32 did not match.
    pub crc_failures: u64,
    /// Messages lost per topic, summed over `losses` (where known).
    pub lost_messages: BTreeMap<String, u64>,
    /// How the file was read where that is worth saying and nothing was lost (a summary
    /// unreadable, so the data section's own definitions were used; ids defined twice).
    pub notes: Vec<String>,
    /// BLAKE3 of the whole file (hex), when asked for ([`super::ExtractOptions::content_hash`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub content_hash: Option<String>,
    /// A bag folder's files in order (empty for one file): name, size and content hash.
    pub parts: Vec<PartInfo>,
}

/// One file of a bag folder read as one recording.
#[derive(Debug, Default, Clone, serde::Serialize)]
pub struct PartInfo {
    /// Its name in the bag's folder.
    pub file: String,
    /// Its size (0: missing).
    pub bytes: u64,
    /// Its content hash, when asked for (none: missing).
    pub content_hash: Option<String>,
}

/// One MCAP Metadata record: its name and string map.
#[derive(Debug, Default, Clone, serde::Serialize)]
pub struct MetadataRecord {
    pub name: String,
    pub values: BTreeMap<String, String>,
}

impl Report {
    /// Count a skipped message. Reasons are grouped with their numbers replaced by `N` (byte
    /// counts and sizes vary frame to frame); the first full reason of each group is kept.
    pub(super) fn skip(&mut self, topic: &str, reason: impl AsRef<str>) {
        let reason = reason.as_ref();
        let mut key = format!("{topic}: ");
        // A number is a digit run not glued to letters ("100x50" → "NxN"; "rgb8", "16UC1" stay).
        let c: Vec<char> = reason.chars().collect();
        let mut i = 0;
        while i < c.len() {
            if c[i].is_ascii_digit() {
                let mut j = i;
                while j < c.len() && c[j].is_ascii_digit() {
                    j += 1;
                }
                let glued_before = i > 0
                    && c[i - 1].is_alphabetic()
                    && !(c[i - 1] == 'x' && i > 1 && c[i - 2].is_ascii_digit());
                let glued_after = j < c.len()
                    && c[j].is_alphabetic()
                    && !(c[j] == 'x' && j + 1 < c.len() && c[j + 1].is_ascii_digit());
                if glued_before || glued_after {
                    key.extend(&c[i..j]);
                } else {
                    key.push('N');
                }
                i = j;
            } else {
                key.push(c[i]);
                i += 1;
            }
        }
        self.skipped_examples
            .entry(key.clone())
            .or_insert_with(|| format!("{topic}: {reason}"));
        *self.skipped.entry(key).or_insert(0) += 1;
    }

    pub(super) fn merge(&mut self, o: &Report) {
        self.chunks += o.chunks;
        for (k, v) in &o.messages {
            *self.messages.entry(k.clone()).or_insert(0) += v;
        }
        self.other_messages += o.other_messages;
        for (k, v) in &o.skipped {
            *self.skipped.entry(k.clone()).or_insert(0) += v;
        }
        for (k, v) in &o.skipped_examples {
            self.skipped_examples
                .entry(k.clone())
                .or_insert_with(|| v.clone());
        }
        self.losses.extend(o.losses.iter().cloned());
        self.recovered_messages += o.recovered_messages;
        self.crc_failures += o.crc_failures;
    }
}
