//! Does work run while a memory stream's bytes are in flight, on one core? The question behind
//! a one-core checked extraction (issue #20): its CRC pass brings every byte of the file from
//! memory, and the frames' interpretation is free only if it runs under that stream.
//!
//! On a file in the page cache, mapped anew for every pass (faulted in by the pass itself, as
//! the extraction's mapped route reads it), cut into pieces of 752 × 582 bytes (one CCD frame).
//! The "load" is a register-only multiply–add chain of `--load-us` µs per piece (default 3.5,
//! about the part of a frame's interpretation that reads little memory). Times are µs per
//! piece, medians of `--repeats`; "hidden" = (pass + load − both) / load: 100 % if the load ran
//! wholly under the pass, 0 % if the two added.
//!
//! 1. crc32fast (what thermrs uses), its `update` called on blocks of 4 KiB to a whole piece,
//!    the load spread between the calls.
//! 2. A plain pass (a sum of 8-byte words), the same way.
//! 3. `fold.rs`, a CRC-32 kernel whose state stays wide between calls (checked against
//!    crc32fast on random splits first): the load called from inside its loop every 4 KiB or
//!    16 KiB, and its `update` called on 4 KiB blocks.
//! 4. The row scan of the spot detector (every 4th row's maximum) after each piece's CRC, and
//!    fused into `fold.rs`'s pass (each scanned row read just after the pass folded it).
//! 5. The next piece's CRC advanced 4 KiB at a time ("pumped", `fold.rs`) while the current
//!    piece is interpreted (row scan, then the load), from the load alone or from the scan too,
//!    against the same work one piece after the other.
//!
//! Run: `cargo run --release --manifest-path benchmarks/experiments/overlap/Cargo.toml -- FILE
//! [--load-us 3.5] [--repeats 7]` (x86-64 with AVX-512 and VPCLMULQDQ for parts 3 and 5).

mod fold;

use std::hint::black_box;
use std::time::Instant;

const ROW: usize = 752;
const ROWS: usize = 582;
const PIECE: usize = ROW * ROWS;
const KIB: usize = 1024;

fn spin(n: u64, mut x: u64) -> u64 {
    for _ in 0..n {
        x = x
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
    }
    x
}

/// Wrapping sum of the 8-byte words of `b` into eight lanes (a tail under 64 bytes is left out).
fn sum(b: &[u8], s: &mut [u64; 8]) {
    for c in b.chunks_exact(64) {
        for (k, w) in c.chunks_exact(8).enumerate() {
            s[k] = s[k].wrapping_add(u64::from_le_bytes(w.try_into().expect("8 bytes")));
        }
    }
}

/// Maximum of every 4th row of a piece among rows `rows`, calling `tick` after every 8th row.
fn scan(piece: &[u8], rows: std::ops::Range<usize>, tick: &mut dyn FnMut()) -> u8 {
    let mut m = 0u8;
    for r in rows.filter(|r| r % 4 == 0) {
        let row = &piece[r * ROW..(r + 1) * ROW];
        m = m.max(row.iter().fold(0, |a, &b| a.max(b)));
        if r % 8 == 0 {
            tick();
        }
    }
    m
}

struct Bench {
    file: std::fs::File,
    n: usize,
    repeats: usize,
}

impl Bench {
    /// µs per piece of `f` over the file's pieces, mapped anew each time (median).
    fn timed(&self, f: &dyn Fn(&[u8]) -> u64) -> f64 {
        let mut ts: Vec<f64> = (0..self.repeats)
            .map(|_| {
                // SAFETY: a read-only map of a file nobody writes during the run.
                let map = unsafe { memmap2::Mmap::map(&self.file) }.expect("the file maps");
                let t = Instant::now();
                black_box(f(&map[..self.n * PIECE]));
                t.elapsed().as_secs_f64()
            })
            .collect();
        ts.sort_by(f64::total_cmp);
        ts[ts.len() / 2] / self.n as f64 * 1e6
    }

    /// µs per piece of `f`, no file.
    fn timed_cpu(&self, f: &dyn Fn() -> u64) -> f64 {
        let mut ts: Vec<f64> = (0..self.repeats)
            .map(|_| {
                let t = Instant::now();
                black_box(f());
                t.elapsed().as_secs_f64()
            })
            .collect();
        ts.sort_by(f64::total_cmp);
        ts[ts.len() / 2] / self.n as f64 * 1e6
    }
}

fn hidden(pass: f64, load: f64, both: f64) -> f64 {
    100.0 * (pass + load - both) / load
}

/// Check `fold.rs` against crc32fast: random lengths, starting CRCs and splits.
fn check_fold() -> usize {
    let mut s = 88172645463325252u64;
    let mut rnd = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        s
    };
    let data: Vec<u8> = (0..400_000).map(|_| rnd() as u8).collect();
    let cases = 2000;
    for t in 0..cases {
        let len = (rnd() % 300_000) as usize + if t % 3 == 0 { 0 } else { 300 };
        let init = if t % 2 == 0 { 0 } else { rnd() as u32 };
        let d = &data[(rnd() % 1000) as usize..][..len];
        let mut want = crc32fast::Hasher::new_with_initial(init);
        want.update(d);
        let mut f = fold::Fold::new(init);
        let mut p = 0;
        while p < d.len() {
            let step = ((rnd() % 5000) as usize + 1).min(d.len() - p);
            f.update(&d[p..p + step]);
            p += step;
        }
        assert_eq!(
            f.finish(),
            want.finalize(),
            "fold.rs disagrees with crc32fast"
        );
    }
    cases
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let Some(path) = args.get(1) else {
        eprintln!("usage: overlap FILE [--load-us 3.5] [--repeats 7]");
        std::process::exit(2);
    };
    let opt = |name: &str, default: f64| {
        args.iter()
            .position(|a| a == name)
            .and_then(|i| args.get(i + 1))
            .map_or(default, |v| v.parse().expect("a number"))
    };
    let file = std::fs::File::open(path).expect("the file opens");
    let n = file.metadata().expect("metadata").len() as usize / PIECE;
    assert!(n >= 10, "the file is too small");
    let b = Bench {
        file,
        n,
        repeats: opt("--repeats", 7.0).max(1.0) as usize,
    };
    let per_us = {
        let k = 50_000_000;
        let t = Instant::now();
        black_box(spin(k, 1));
        k as f64 / (t.elapsed().as_secs_f64() * 1e6)
    };
    let iters = (opt("--load-us", 3.5) * per_us) as u64;
    let load = b.timed_cpu(&|| (0..n as u64).fold(0, |x, i| spin(iters, x ^ i)));
    println!(
        "{n} pieces of {PIECE} bytes; µs per piece, medians of {}",
        b.repeats
    );
    println!("load alone: {load:.2}");

    // 1 and 2: calls on blocks, the load between them.
    for crc in [true, false] {
        let name = if crc { "crc32fast" } else { "plain sum" };
        for block in [4 * KIB, 16 * KIB, 64 * KIB, PIECE] {
            let per = iters / PIECE.div_ceil(block) as u64;
            let run = |with: bool| {
                move |d: &[u8]| {
                    let (mut h, mut s, mut x) = (crc32fast::Hasher::new(), [0u64; 8], 0);
                    for p in d.chunks_exact(PIECE) {
                        for c in p.chunks(block) {
                            if crc {
                                h.update(c);
                            } else {
                                sum(c, &mut s);
                            }
                            if with {
                                x = spin(per, x);
                            }
                        }
                    }
                    u64::from(h.finalize()) ^ x ^ s.iter().fold(0, |a, v| a ^ v)
                }
            };
            let (pass, both) = (b.timed(&run(false)), b.timed(&run(true)));
            println!(
                "1-2 {name}, calls of {:>6} B: pass {pass:.2}, with the load between calls \
                 {both:.2}, hidden {:.0} %",
                block.min(PIECE),
                hidden(pass, load, both)
            );
        }
    }

    if !fold::available() {
        println!("3, 5: skipped (no AVX-512 with VPCLMULQDQ)");
    } else {
        println!(
            "3 fold.rs agrees with crc32fast on {} random splits",
            check_fold()
        );
        let whole = |d: &[u8]| d.len() / 256 * 256;
        for every in [16, 64] {
            let per = iters / (PIECE / 256 / every) as u64;
            let run = |with: bool| {
                move |d: &[u8]| {
                    let (mut f, mut x) = (fold::Fold::new(0), 0);
                    let mut tick = || {
                        if with {
                            x = spin(per, x);
                        }
                    };
                    // SAFETY: `available` is true.
                    unsafe { f.steps_with(&d[..whole(d)], every, &mut tick) };
                    u64::from(f.finish()) ^ x
                }
            };
            let (pass, both) = (b.timed(&run(false)), b.timed(&run(true)));
            println!(
                "3 fold.rs, the load inside its loop every {:>2} KiB: pass {pass:.2}, with the \
                 load {both:.2}, hidden {:.0} %",
                every / 4,
                hidden(pass, load, both)
            );
        }
        let per = iters / (PIECE / (4 * KIB)) as u64;
        let run = |with: bool| {
            move |d: &[u8]| {
                let (mut f, mut x) = (fold::Fold::new(0), 0);
                for c in d.chunks(4 * KIB) {
                    f.update(c);
                    if with {
                        x = spin(per, x);
                    }
                }
                u64::from(f.finish()) ^ x
            }
        };
        let (pass, both) = (b.timed(&run(false)), b.timed(&run(true)));
        println!(
            "3 fold.rs, calls of 4 KiB: pass {pass:.2}, with the load between calls {both:.2}, \
             hidden {:.0} %",
            hidden(pass, load, both)
        );
    }

    // 4: the row scan after each piece's CRC.
    let stream = b.timed(&|d: &[u8]| {
        let mut h = crc32fast::Hasher::new();
        d.chunks_exact(PIECE).for_each(|p| h.update(p));
        u64::from(h.finalize())
    });
    let after = b.timed(&|d: &[u8]| {
        let (mut h, mut m) = (crc32fast::Hasher::new(), 0);
        for p in d.chunks_exact(PIECE) {
            h.update(p);
            m = m.max(scan(p, 0..ROWS, &mut || {}));
        }
        u64::from(h.finalize()) ^ u64::from(m)
    });
    let piece = vec![7u8; PIECE];
    let hot = b.timed_cpu(&|| {
        (0..n).fold(0, |m, _| {
            u64::from(scan(black_box(&piece), 0..ROWS, &mut || {})).max(m)
        })
    });
    println!(
        "4 row scan: alone on a piece in cache {hot:.2}; crc32fast pass {stream:.2}, the scan \
         after each piece's CRC {after:.2} (+{:.2})",
        after - stream
    );
    if fold::available() {
        // The scan fused: each scanned row read right after the fold has passed it, whole
        // (`touch` false) or one byte per cache line.
        let fused = |touch: bool| {
            move |d: &[u8]| {
                let mut m = 0u8;
                let mut f = fold::Fold::new(0);
                let mut done = 0usize; // bytes of `d` folded (whole steps)
                let lim = d.len() / 256 * 256;
                for (i, p) in d.chunks_exact(PIECE).enumerate() {
                    for r in (0..ROWS).filter(|r| r % 4 == 0) {
                        // Up to the step holding the row's last byte: a byte left unfolded
                        // would be a miss to memory for the scan.
                        let want = ((i * PIECE + (r + 1) * ROW).div_ceil(256) * 256).min(lim);
                        if want > done {
                            // SAFETY: `available` is true.
                            unsafe { f.steps_with(&d[done..want], usize::MAX, &mut || {}) };
                            done = want;
                        }
                        if touch {
                            let row = &p[r * ROW..(r + 1) * ROW];
                            for k in (0..ROW).step_by(64) {
                                // SAFETY: `k < ROW`: inside the row.
                                m ^= unsafe { std::ptr::read_volatile(row.as_ptr().add(k)) };
                            }
                        } else {
                            m = m.max(scan(p, r..r + 1, &mut || {}));
                        }
                    }
                }
                // SAFETY: as above.
                unsafe { f.steps_with(&d[done..lim], usize::MAX, &mut || {}) };
                u64::from(f.finish()) ^ u64::from(m)
            }
        };
        let (fused, touched) = (b.timed(&fused(false)), b.timed(&fused(true)));
        let fold_pass = b.timed(&|d: &[u8]| {
            let mut f = fold::Fold::new(0);
            // SAFETY: as above.
            unsafe { f.steps_with(&d[..d.len() / 256 * 256], usize::MAX, &mut || {}) };
            u64::from(f.finish())
        });
        println!(
            "4 row scan fused into fold.rs's pass (each scanned row read just after it is \
             folded): fold.rs pass {fold_pass:.2}, fused {fused:.2} (+{:.2}); one byte per \
             line of each scanned row instead {touched:.2} (+{:.2})",
            fused - fold_pass,
            touched - fold_pass
        );
    }

    // 5: the next piece's CRC pumped from the current piece's interpretation.
    if fold::available() {
        let pumped = |from_scan: bool, from_load: bool| {
            move |d: &[u8]| {
                let pieces: Vec<&[u8]> = d.chunks_exact(PIECE).collect();
                let mut x = 0u64;
                let mut crc = fold::Fold::new(0);
                let mut at = 0; // bytes of the next piece already folded
                for (i, p) in pieces.iter().enumerate() {
                    crc.update(&p[at..]);
                    x ^= u64::from(crc.finish());
                    crc = fold::Fold::new(0);
                    at = 0;
                    let next = pieces.get(i + 1).copied().unwrap_or(&[]);
                    let mut pump = || {
                        let e = (at + 4 * KIB).min(next.len());
                        crc.update(&next[at..e]);
                        at = e;
                    };
                    let m = if from_scan {
                        scan(p, 0..ROWS, &mut pump)
                    } else {
                        scan(p, 0..ROWS, &mut || {})
                    };
                    let slices = (PIECE / (4 * KIB)) as u64;
                    for _ in 0..slices {
                        x = spin(iters / slices, x);
                        if from_load {
                            pump();
                        }
                    }
                    x ^= u64::from(m);
                }
                x
            }
        };
        let seq = b.timed(&pumped(false, false));
        let load_only = b.timed(&pumped(false, true));
        let scan_too = b.timed(&pumped(true, true));
        println!(
            "5 CRC, row scan and load of each piece one after the other {seq:.2}; the next \
             piece's CRC pumped from the load {load_only:.2} ({:.2}x), from the scan and the \
             load {scan_too:.2} ({:.2}x)",
            seq / load_only,
            seq / scan_too
        );
    }
}
