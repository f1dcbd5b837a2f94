//! Where the bytes of a mapped recording come from, and the route an uncompressed chunk takes
//! to the detector (in place from the map, or copied with `pread`).

/// A file and its read-only memory map (whose bytes [`extract_bytes`] walks).
#[derive(Clone, Copy)]
pub struct Source<'a> {
    pub file: &'a std::fs::File,
    pub map: &'a memmap2::Mmap,
}

impl Source<'_> {
    /// Offset in the map and length of `data` (a slice of it).
    pub(super) fn range(&self, data: &[u8]) -> (usize, usize) {
        let from = data.as_ptr() as usize - self.map.as_ptr() as usize;
        (from, data.len())
    }

    /// Map the pages of `data` in with one call (`MADV_POPULATE_READ`) rather than one
    /// fault per page.
    pub(super) fn populate(&self, data: &[u8]) {
        let (from, len) = self.range(data);
        let _ = self
            .map
            .advise_range(memmap2::Advice::PopulateRead, from, len);
    }

    /// Drop the pages of the byte range `from..to` from the mapping (they stay in the page
    /// cache).
    pub(super) fn release(&self, from: usize, to: usize) {
        if to > from {
            // SAFETY: a read-only file mapping: a later access faults the same bytes back
            // in from the file; DONTNEED only drops this process's view of the pages.
            let _ = unsafe {
                self.map
                    .unchecked_advise_range(memmap2::UncheckedAdvice::DontNeed, from, to - from)
            };
        }
    }
}

/// How the body of an uncompressed chunk reaches the detector.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Route {
    /// Read in place from the mapping (pages mapped in by the walk's faults, then dropped):
    /// no copy, and only the bytes the detector asks for cross the memory bus, but the kernel
    /// pays per page to map and unmap them.
    Map,
    /// Copied with `pread` record by record through a per-thread buffer of a few hundred KiB
    /// (`chunk::walk_read`): one copy, each record checksummed and read by the detector while
    /// it is still in cache, at a cost nearly independent of how the page cache holds the file.
    Read,
}

/// Picks the faster [`Route`] for uncompressed chunks as the file is read. Which one wins
/// depends on the page cache and the machine, not on the file: mapping is paid per page
/// (cheaper where a fault maps a large folio's pages at once), the copy per byte; on the
/// machine of BENCHMARKS.md the mapped route, mapped in by its own faults, ran at 1.07× one
/// read and the copy at 0.7×, but earlier page caches there favoured the copy. Each chunk's
/// processing time per byte is recorded for its route (a running mean); chunks take the
/// faster route, and one in [`RouteChooser::PROBE`] the other, so that a change (the page
/// cache of a long file need not be uniform) is noticed. Outputs never depend on the route.
#[derive(Default)]
pub(super) struct RouteChooser {
    /// Running mean of ns per KiB, per route (0: not measured yet).
    pub(super) ns_per_kib: [std::sync::atomic::AtomicU64; 2],
    pub(super) chunks: std::sync::atomic::AtomicU64,
    /// Always this route (tests).
    pub(super) forced: Option<Route>,
}

impl RouteChooser {
    const PROBE: u64 = 16;

    pub(super) fn pick(&self) -> Route {
        use std::sync::atomic::Ordering::Relaxed;
        if let Some(r) = self.forced {
            return r;
        }
        let n = self.chunks.fetch_add(1, Relaxed);
        let map = self.ns_per_kib[0].load(Relaxed);
        let read = self.ns_per_kib[1].load(Relaxed);
        let (best, other) = match (map, read) {
            (0, _) => return Route::Map,
            (_, 0) => return Route::Read,
            (m, r) if m <= r => (Route::Map, Route::Read),
            _ => (Route::Read, Route::Map),
        };
        if n % Self::PROBE == Self::PROBE - 1 {
            other
        } else {
            best
        }
    }

    pub(super) fn record(&self, route: Route, elapsed: std::time::Duration, bytes: usize) {
        use std::sync::atomic::Ordering::Relaxed;
        let kib = (bytes as u64 / 1024).max(1);
        let x = (elapsed.as_nanos() as u64 / kib).max(1);
        let slot = &self.ns_per_kib[route as usize];
        let old = slot.load(Relaxed);
        slot.store(if old == 0 { x } else { (3 * old + x) / 4 }, Relaxed);
    }
}
