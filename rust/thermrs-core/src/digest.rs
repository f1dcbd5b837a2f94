//! The content hash that identifies a recording in a campaign: BLAKE3 of the file's bytes, a
//! trailing hole (space a crashed writer reserved, see [`crate::holes`]) counted by its length
//! rather than read. Extraction takes the same hash in its own pass
//! ([`crate::ingest::ExtractOptions::content_hash`]); both must agree, so both use
//! [`finish`].

use std::path::Path;

use crate::error::{Error, Result};

/// Add the trailing hole of `hole` bytes (0: none) to a hash of the bytes before it, and give
/// the hex digest.
pub fn finish(mut h: blake3::Hasher, hole: u64) -> String {
    if hole > 0 {
        h.update(b"\0thermrs-hole\0");
        h.update(&hole.to_le_bytes());
    }
    h.finalize().to_hex().to_string()
}

/// The content hash of the file at `path` (see the module docs), read with `pread` a block at
/// a time (memory stays flat whatever the size), hashed on the rayon pool.
///
/// # Errors
/// [`Error::Io`] if the file cannot be opened or read.
pub fn content_hash(path: &Path) -> Result<String> {
    use std::os::unix::fs::FileExt;
    let io = |source| Error::Io {
        path: path.display().to_string(),
        source,
    };
    let file = std::fs::File::open(path).map_err(io)?;
    let len = file.metadata().map_err(io)?.len();
    let (_, data_end) = crate::holes::layout(&file, len);
    let mut h = blake3::Hasher::new();
    let mut buf = vec![0u8; 8 << 20];
    let mut at = 0u64;
    while at < data_end {
        let n = usize::try_from((data_end - at).min(buf.len() as u64)).expect("fits a buffer");
        file.read_exact_at(&mut buf[..n], at).map_err(io)?;
        if rayon::current_num_threads() > 1 {
            h.update_rayon(&buf[..n]);
        } else {
            h.update(&buf[..n]);
        }
        at += n as u64;
    }
    Ok(finish(h, len - data_end))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Without a hole, the hash is BLAKE3 of the bytes; with a trailing hole, it is what an
    /// extraction's own pass gives, and differs from the file without the hole.
    #[test]
    fn the_hash_is_blake3_of_the_bytes_and_counts_a_trailing_hole() {
        let p = std::env::temp_dir().join(format!("thermrs-digest-{}.bin", std::process::id()));
        let bytes: Vec<u8> = (0..3_000_000u32).map(|i| (i % 251) as u8).collect();
        std::fs::write(&p, &bytes).unwrap();
        assert_eq!(
            content_hash(&p).unwrap(),
            blake3::hash(&bytes).to_hex().to_string()
        );
        let f = std::fs::OpenOptions::new().write(true).open(&p).unwrap();
        f.set_len(3_000_000 + (256 << 20)).unwrap();
        drop(f);
        let with_hole = content_hash(&p).unwrap();
        assert_ne!(with_hole, blake3::hash(&bytes).to_hex().to_string());
        // The same bytes before a hole of the same length give the same hash.
        assert_eq!(with_hole, content_hash(&p).unwrap());
        std::fs::remove_file(&p).unwrap();
    }
}
