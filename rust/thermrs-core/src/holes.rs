//! Holes in a file: ranges the file system holds no data for (a sparse file, such as the
//! space a crashed writer pre-allocated and never filled), found with `SEEK_DATA`/`SEEK_HOLE`
//! so that a reader skips them without reading (or mapping) a byte of them.
//!
//! Where the file system cannot tell (`EINVAL`), or the platform has no such call, the whole
//! file counts as data: a reader then meets the zeros and reports them as damage.

use std::fs::File;

/// The data ranges of `file` (`start..end`, sorted, disjoint) in a file of `len` bytes: the
/// whole file where holes cannot be told.
pub fn data_ranges(file: &File, len: u64) -> Vec<(u64, u64)> {
    imp::data_ranges(file, len).unwrap_or_else(|| vec![(0, len)])
}

/// The holes of `file` (`len` bytes), and where its trailing hole starts (`len` if it has
/// none): what a reader maps and reads is the file up to there.
pub fn layout(file: &File, len: u64) -> (Vec<(u64, u64)>, u64) {
    let holes = holes(&data_ranges(file, len), len);
    let data_end = match holes.last() {
        Some(&(start, end)) if end == len => start,
        _ => len,
    };
    (holes, data_end)
}

/// The holes of a file of `len` bytes whose data ranges are `data`: what lies between them.
pub fn holes(data: &[(u64, u64)], len: u64) -> Vec<(u64, u64)> {
    let mut out = Vec::new();
    let mut at = 0;
    for &(s, e) in data {
        if s > at {
            out.push((at, s));
        }
        at = at.max(e);
    }
    if at < len {
        out.push((at, len));
    }
    out
}

#[cfg(any(target_os = "linux", target_os = "android", target_os = "freebsd"))]
mod imp {
    use std::fs::File;
    use std::os::fd::AsRawFd;

    pub(super) fn data_ranges(file: &File, len: u64) -> Option<Vec<(u64, u64)>> {
        let fd = file.as_raw_fd();
        let seek = |at: u64, whence| -> Option<Option<u64>> {
            let at = libc::off_t::try_from(at).ok()?;
            // SAFETY: lseek on a file descriptor this process owns; it changes only the
            // descriptor's offset, which nothing here relies on (reads use `pread` or a map).
            let r = unsafe { libc::lseek(fd, at, whence) };
            if r >= 0 {
                return Some(Some(r as u64));
            }
            match std::io::Error::last_os_error().raw_os_error() {
                // No data at or after `at`: the rest is a hole.
                Some(libc::ENXIO) => Some(None),
                _ => None,
            }
        };
        let mut out = Vec::new();
        let mut at = 0u64;
        while at < len {
            let Some(start) = seek(at, libc::SEEK_DATA)? else {
                break;
            };
            let end = seek(start, libc::SEEK_HOLE)?.unwrap_or(len).min(len);
            if end <= start {
                break;
            }
            out.push((start, end));
            at = end;
        }
        Some(out)
    }
}

#[cfg(not(any(target_os = "linux", target_os = "android", target_os = "freebsd")))]
mod imp {
    pub(super) fn data_ranges(_: &std::fs::File, _: u64) -> Option<Vec<(u64, u64)>> {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{Seek, SeekFrom, Write};

    /// A file with data, a hole of 64 MiB, data, and a trailing hole: the ranges the file
    /// system reports cover the written bytes and leave out most of the holes (a file system
    /// may keep a block of zeros around the data, never a whole hole of this size).
    #[test]
    fn a_sparse_file_has_its_holes_found() {
        let p = std::env::temp_dir().join(format!("thermrs-holes-{}.bin", std::process::id()));
        let mut f = File::create(&p).unwrap();
        f.write_all(&[7u8; 10_000]).unwrap();
        f.seek(SeekFrom::Start(64 << 20)).unwrap();
        f.write_all(&[9u8; 10_000]).unwrap();
        let len = (200 << 20) as u64;
        f.set_len(len).unwrap();
        drop(f);
        let f = File::open(&p).unwrap();
        let data = data_ranges(&f, len);
        let hole = holes(&data, len);
        let in_data = |x: u64| data.iter().any(|&(s, e)| s <= x && x < e);
        assert!(in_data(0) && in_data(9_999) && in_data(64 << 20) && in_data((64 << 20) + 9_999));
        let hole_bytes: u64 = hole.iter().map(|(s, e)| e - s).sum();
        let data_bytes: u64 = data.iter().map(|(s, e)| e - s).sum();
        assert_eq!(hole_bytes + data_bytes, len);
        // tmpfs, ext4, xfs and btrfs all report holes; a file system that cannot would give
        // the whole file as data, which this test would flag.
        assert!(hole_bytes > 190 << 20, "{data:?}");
        std::fs::remove_file(&p).unwrap();
    }

    #[test]
    fn holes_are_what_lies_between_the_data() {
        assert_eq!(
            holes(&[(10, 20), (30, 40)], 50),
            vec![(0, 10), (20, 30), (40, 50)]
        );
        assert_eq!(holes(&[(0, 50)], 50), vec![]);
        assert_eq!(holes(&[], 5), vec![(0, 5)]);
    }
}
