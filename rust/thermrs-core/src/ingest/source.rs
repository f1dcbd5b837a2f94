//! Where the bytes of a mapped recording come from, and the route an uncompressed chunk takes
//! to the detector (in place from the map, or copied with `pread`).

/// A file and its read-only memory map (whose bytes [`extract_bytes`](crate::ingest::extract_bytes) walks).
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
/// (cheaper where a fault maps a large folio's pages at once), the copy per byte, and either
/// can win by 1.3× or more (BENCHMARKS.md). Each chunk's processing time per byte is recorded
/// for its route. The first [`RouteChooser::WARM_UP`] chunks alternate the routes; then
/// chunks take the route with the lower estimate, and now and then the other (a probe), so
/// that a change (the page cache of a long file need not be uniform) is noticed.
///
/// Probes back off while the choice holds: the first comes [`RouteChooser::PROBE`] chunks
/// after the warm-up, and each next one twice as far after the last, up to
/// [`RouteChooser::PROBE_MAX`] chunks (256 MiB of 4 MiB chunks); when the best route changes
/// (a probe found the other faster, or the best one got slower), the spacing starts again at
/// `PROBE`, so that a choice made on a burst of slow chunks is soon looked at again. A probe
/// costs what its route is slower: with a fixed one in 16, the kernel's copy took 13 % of an
/// unchecked extraction's profile on a page cache where the copy cost 1.4× the map
/// (BENCHMARKS.md).
///
/// A route's estimate is the least of its last [`KEEP`] samples. The first chunks of an
/// extraction pay its cold start (first faults, buffers and tables growing) whichever route
/// they take, and slow chunks come in bursts on either route (2–5× the usual cost for a few
/// chunks in a row); such costs only ever add time, so a few slow samples must not decide the
/// route for the rest of the file (with three samples kept, bursts of three switched it, and
/// the file stayed on the slower route until the next probe). Outputs never depend on the
/// route.
#[derive(Default)]
pub(super) struct RouteChooser {
    /// Per route, its last [`KEEP`] samples of ns per KiB, a ring (0: empty).
    samples: [[std::sync::atomic::AtomicU64; KEEP]; 2],
    /// Samples recorded per route.
    taken: [std::sync::atomic::AtomicU64; 2],
    chunks: std::sync::atomic::AtomicU64,
    /// The chunk number of the last probe (0 before the first).
    probed: std::sync::atomic::AtomicU64,
    /// Chunks from the last probe to the next (0: `PROBE`).
    spacing: std::sync::atomic::AtomicU64,
    /// The best route at the last pick (0: none yet, 1: map, 2: copy).
    best: std::sync::atomic::AtomicU8,
    /// Always this route (tests).
    forced: Option<Route>,
}

/// Samples kept per route: more than the slow bursts are long.
const KEEP: usize = 5;

impl RouteChooser {
    /// The fewest chunks from one probe of the route that is not the best to the next.
    pub(super) const PROBE: u64 = 16;
    /// The most chunks from one probe to the next.
    pub(super) const PROBE_MAX: u64 = 64;
    /// Chunks that alternate the routes before the first choice: two samples of each.
    pub(super) const WARM_UP: u64 = 4;

    /// A chooser; every chunk takes `forced` if given.
    pub(super) fn new(forced: Option<Route>) -> Self {
        RouteChooser {
            forced,
            ..RouteChooser::default()
        }
    }

    pub(super) fn pick(&self) -> Route {
        use std::sync::atomic::Ordering::Relaxed;
        if let Some(r) = self.forced {
            return r;
        }
        let n = self.chunks.fetch_add(1, Relaxed);
        if n < Self::WARM_UP {
            return if n % 2 == 0 { Route::Map } else { Route::Read };
        }
        let (best, other) = match (self.estimate(Route::Map), self.estimate(Route::Read)) {
            (None, _) => return Route::Map,
            (_, None) => return Route::Read,
            (Some(m), Some(r)) if m <= r => (Route::Map, Route::Read),
            _ => (Route::Read, Route::Map),
        };
        let code = 1 + best as u8;
        let was = self.best.swap(code, Relaxed);
        if was != code {
            // A new choice (or the first): its first probe comes `PROBE` chunks from here.
            self.spacing.store(Self::PROBE, Relaxed);
            if was != 0 {
                self.probed.store(n, Relaxed);
            }
        }
        let raw = self.spacing.load(Relaxed);
        let spacing = raw.max(Self::PROBE);
        // Several threads may pick at once: only the one that moves `probed` probes.
        let prev = self.probed.load(Relaxed);
        let last = if prev == 0 { Self::WARM_UP - 1 } else { prev };
        if n >= last + spacing
            && self
                .probed
                .compare_exchange(prev, n, Relaxed, Relaxed)
                .is_ok()
        {
            // Doubled only if no other thread has started the spacing again meanwhile.
            let _ = self.spacing.compare_exchange(
                raw,
                (2 * spacing).min(Self::PROBE_MAX),
                Relaxed,
                Relaxed,
            );
            other
        } else {
            best
        }
    }

    /// The least of the route's last samples (ns per KiB), if it has any.
    pub(super) fn estimate(&self, route: Route) -> Option<u64> {
        use std::sync::atomic::Ordering::Relaxed;
        self.samples[route as usize]
            .iter()
            .map(|s| s.load(Relaxed))
            .filter(|&x| x > 0)
            .min()
    }

    pub(super) fn record(&self, route: Route, elapsed: std::time::Duration, bytes: usize) {
        use std::sync::atomic::Ordering::Relaxed;
        let kib = (bytes as u64 / 1024).max(1);
        let x = (elapsed.as_nanos() as u64 / kib).max(1);
        let i = self.taken[route as usize].fetch_add(1, Relaxed) as usize % KEEP;
        self.samples[route as usize][i].store(x, Relaxed);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    /// Record a chunk of 1 MiB that took `ns_per_kib` per KiB on `route`.
    fn took(c: &RouteChooser, route: Route, ns_per_kib: u64) {
        c.record(route, Duration::from_nanos(ns_per_kib * 1024), 1 << 20);
    }

    /// The chunks' picks from here on, until `n` chunks have been picked in all.
    fn picks(c: &RouteChooser, n: u64) -> Vec<Route> {
        use std::sync::atomic::Ordering::Relaxed;
        (c.chunks.load(Relaxed)..n).map(|_| c.pick()).collect()
    }

    /// The first chunks pay the extraction's cold start whichever route they take: a slow
    /// first sample of the faster route must not hand the file to the slower one (as a
    /// running mean did: 0.60× one read where the mapped route alone ran at 0.73×).
    #[test]
    fn a_cold_first_chunk_does_not_decide_the_route() {
        let c = RouteChooser::new(None);
        use Route::{Map, Read};
        assert_eq!(picks(&c, RouteChooser::WARM_UP), [Map, Read, Map, Read]);
        // What the chunks of a fresh page cache cost (ns per KiB): cold, then warm.
        for (route, ns) in [(Map, 227), (Read, 218), (Map, 50), (Read, 116)] {
            took(&c, route, ns);
        }
        let p = picks(&c, 300);
        let probes: Vec<u64> = (0..p.len())
            .filter(|&i| p[i] == Read)
            .map(|i| i as u64 + RouteChooser::WARM_UP)
            .collect();
        // Map everywhere but the probes, which back off while the map stays the best.
        assert_eq!(probes, [19, 51, 115, 179, 243], "{p:?}");
    }

    /// A choice made on a burst of slow chunks is looked at again soon: when the best route
    /// changes, the probes start again `PROBE` chunks apart.
    #[test]
    fn a_change_of_route_brings_the_probes_back() {
        use Route::{Map, Read};
        let c = RouteChooser::new(None);
        picks(&c, RouteChooser::WARM_UP);
        for (route, ns) in [(Map, 30), (Read, 45), (Map, 30), (Read, 45)] {
            took(&c, route, ns);
        }
        // Settled on the map: probes 16, 32, 64 chunks apart.
        let p = picks(&c, 200);
        let at = |p: &[Route], r: Route, from: u64| -> Vec<u64> {
            (0..p.len())
                .filter(|&i| p[i] == r)
                .map(|i| i as u64 + from)
                .collect()
        };
        assert_eq!(at(&p, Read, 4), [19, 51, 115, 179]);
        // A burst of slow mapped chunks: the copy is now the best route (chunk 200), and the
        // map is probed 16 chunks later, then 32 after that.
        for _ in 0..KEEP {
            took(&c, Map, 150);
        }
        let p = picks(&c, 260);
        assert_eq!(at(&p, Map, 200), [216, 248], "{p:?}");
        // That probe finds the map fast again: back to it at once.
        took(&c, Map, 30);
        assert_eq!(c.pick(), Map);
    }

    /// Either route's change of cost is followed: a probe that finds the other route faster
    /// switches at once; the chosen route getting slower switches after its last samples.
    #[test]
    fn the_route_follows_the_page_cache() {
        use Route::{Map, Read};
        let c = RouteChooser::new(None);
        picks(&c, RouteChooser::WARM_UP);
        for (route, ns) in [(Map, 50), (Read, 65), (Map, 50), (Read, 65)] {
            took(&c, route, ns);
        }
        assert_eq!(c.pick(), Map);
        // A probe of the copy finds it faster now.
        took(&c, Read, 40);
        assert_eq!(c.pick(), Read);
        // The copy gets slower than the map's last samples: after KEEP chunks, back to Map.
        for _ in 0..KEEP {
            took(&c, Read, 90);
        }
        assert_eq!(c.estimate(Read), Some(90));
        assert_eq!(c.pick(), Map);
    }

    /// Threads picking and recording at once: the chooser never stops probing (nor probes
    /// more than its least spacing allows), whatever the interleaving.
    #[test]
    fn threads_picking_at_once_keep_the_probes_spaced() {
        use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
        let c = RouteChooser::new(None);
        let other = AtomicU64::new(0);
        let (threads, per) = (4u64, 2000u64);
        std::thread::scope(|s| {
            for t in 0..threads {
                let (c, other) = (&c, &other);
                s.spawn(move || {
                    for i in 0..per {
                        let r = c.pick();
                        // The map costs 30 ns/KiB, the copy 45; a burst now and then.
                        let slow = (i + t) % 97 < 4;
                        let ns = match (r, slow) {
                            (Route::Map, false) => 30,
                            (Route::Map, true) => 150,
                            (Route::Read, _) => 45,
                        };
                        took(c, r, ns);
                        if r == Route::Read {
                            other.fetch_add(1, Relaxed);
                        }
                    }
                });
            }
        });
        let n = threads * per - RouteChooser::WARM_UP;
        let probes = other.load(Relaxed);
        assert!(
            probes >= n / RouteChooser::PROBE_MAX / 2 && probes <= n / RouteChooser::PROBE + 50,
            "{probes} copies in {n} chunks"
        );
        // Afterwards, alone: a probe within PROBE_MAX chunks.
        let p = picks(&c, threads * per + RouteChooser::PROBE_MAX + 1);
        assert!(p.contains(&Route::Read), "{p:?}");
    }

    #[test]
    fn a_forced_route_is_always_taken() {
        let c = RouteChooser::new(Some(Route::Read));
        took(&c, Route::Read, 500);
        took(&c, Route::Map, 1);
        assert!(picks(&c, 40).iter().all(|&r| r == Route::Read));
    }
}
