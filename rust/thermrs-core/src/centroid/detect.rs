//! Detection: a sparse row scan for runs above the threshold, each verified on the rows
//! around it and on its 3×3 neighbourhood, the best blob chosen; then measured.

use super::*;

#[derive(Clone, Copy, Debug)]
pub(super) struct Run {
    pub(super) scan_idx: usize,
    pub(super) y: usize,
    pub(super) x0: usize,
    pub(super) x1: usize,
    /// The brightest pixel of the rows around the stretch that passes the blob test.
    pub(super) peak: u32,
    pub(super) peak_x: usize,
    pub(super) peak_y: usize,
}

#[derive(Clone, Copy, Debug)]
pub(super) struct Blob {
    pub(super) peak: u32,
    pub(super) x: usize,
    pub(super) y: usize,
}

/// Row stride of the sparse scan for a minimum spot σ: `floor(2σ)`, so that a spot's centre
/// is never more than `σ` rows from a scanned row.
pub(super) fn scan_stride(min_sigma_px: f64) -> usize {
    let k = (2.0 * min_sigma_px).floor();
    if k.is_finite() && k >= 1.0 {
        (k as usize).min(64)
    } else {
        1
    }
}

/// The least fraction of a Gaussian spot's peak (σ ≥ `min_sigma_px`) that the nearest of
/// the rows scanned every `k` shows: `exp(−(k/2)² / 2σ²)` (1 when every row is scanned).
/// Pixel integration only broadens the spot, which raises the fraction.
pub(super) fn scan_reach(k: usize, min_sigma_px: f64) -> f64 {
    if k <= 1 {
        return 1.0;
    }
    let d = k as f64 / 2.0;
    let r = (-d * d / (2.0 * min_sigma_px * min_sigma_px)).exp();
    if r.is_finite() {
        r.clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// Finds and measures the spot of one frame: the sparse scan, the frame's levels, the
/// candidate runs, the blobs, then the measurement of the brightest (see the module
/// documentation).
pub(super) fn find_spot_px<P: Px>(f: &FrameView, p: &SpotParams) -> Spot {
    let k = scan_stride(p.min_sigma_px).min(f.height.max(1));
    let rows = ScanRows::new(f.height, k);
    let (row_max, stats) = scan::<P>(f, rows);
    let lv = match Levels::new::<P>(p, k, &row_max, stats) {
        Ok(lv) => lv,
        Err(none) => return none,
    };
    let runs = candidate_runs::<P>(f, rows, &row_max, &lv);
    if runs.is_empty() {
        return lv.none(0);
    }
    let blobs = blobs_of(&runs, k);
    let primary = brightest_blob(&blobs);
    let sat = p.saturation_dn.unwrap_or(P::MAX);
    match measure::<P>(f, p, blobs[primary], k, lv.bg, lv.noise, sat) {
        Some(m) => spot_of(&m, &blobs, primary, p),
        None => lv.none(blobs.len()),
    }
}

/// The rows the sparse scan reads: `(k−1)/2`, `+k`, …, and the last row of the frame if the
/// stride leaves it uncovered.
#[derive(Clone, Copy)]
struct ScanRows {
    first: usize,
    k: usize,
    n_scan: usize,
    /// Rows read: `n_scan`, plus the last row if it is added.
    n_rows: usize,
    last: usize,
}

impl ScanRows {
    /// The scanned rows of a frame of `h ≥ 1` rows with stride `1 ≤ k ≤ h`.
    fn new(h: usize, k: usize) -> Self {
        let first = ((k - 1) / 2).min(h - 1);
        let n_scan = (h - 1 - first) / k + 1;
        let last = first + (n_scan - 1) * k;
        let extra = h - 1 - last > (k - 1) / 2;
        ScanRows {
            first,
            k,
            n_scan,
            n_rows: n_scan + extra as usize,
            last: h - 1,
        }
    }

    /// The frame row of the `i`-th scanned row.
    #[inline]
    fn row(&self, i: usize) -> usize {
        if i < self.n_scan {
            self.first + i * self.k
        } else {
            self.last
        }
    }
}

/// Step 1, the sparse scan: the maximum of every scanned row, and the frame's background and
/// noise from a sample on a grid of some of them, taken while they are in cache.
///
/// 8-bit pixels go straight into the sample's histogram (four interleaved ones, as in
/// `robust_stats`); wider ones are gathered for `robust_stats`. Same bits either way
/// (`background::hist_stats`).
fn scan<P: Px>(f: &FrameView, rows: ScanRows) -> (Vec<u32>, (f64, f64)) {
    let grid = SampleGrid::new(f.width, rows.n_rows);
    let n = grid.n_rows(rows.n_rows) * grid.n_cols;
    if P::BPP == 1 {
        let mut h4 = [[0u32; 256]; 4];
        let row_max = scan_rows::<P>(f, rows, grid.every, |row| {
            for (j, x) in grid.cols().enumerate() {
                h4[j & 3][P::get(row, x) as usize & 0xff] += 1;
            }
        });
        (row_max, hist_stats(&merged(&h4), 0, 255, n))
    } else {
        let mut samples: Vec<u16> = Vec::with_capacity(n);
        let row_max = scan_rows::<P>(f, rows, grid.every, |row| {
            samples.extend(grid.cols().map(|x| P::get(row, x) as u16));
        });
        (row_max, robust_stats(&samples))
    }
}

/// The maxima of the scanned rows; `sample` is handed every `every`-th of them, from the
/// first, right after its maximum.
fn scan_rows<P: Px>(
    f: &FrameView,
    rows: ScanRows,
    every: usize,
    mut sample: impl FnMut(&[u8]),
) -> Vec<u32> {
    let n_rows = rows.n_rows;
    let mut row_max: Vec<u32> = Vec::with_capacity(n_rows);
    let mut next_sample = 0usize;
    // Rows are asked for `AHEAD` scanned rows before they are read (see `frame::prefetch`).
    const AHEAD: usize = 4;
    for i in 0..AHEAD.min(n_rows) {
        prefetch(f.row(rows.row(i)));
    }
    for i in 0..n_rows {
        if i + AHEAD < n_rows {
            prefetch(f.row(rows.row(i + AHEAD)));
        }
        let row = f.row(rows.row(i));
        row_max.push(P::max_of(row));
        if i == next_sample {
            next_sample += every;
            sample(row);
        }
    }
    row_max
}

/// The background sample's grid: every `every`-th scanned row from the first, and in each
/// `n_cols` columns `step` apart from column `first` (about [`SAMPLE_GRID`] each way).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct SampleGrid {
    pub(super) every: usize,
    pub(super) first: usize,
    pub(super) step: usize,
    pub(super) n_cols: usize,
}

impl SampleGrid {
    /// The grid of a frame `w` pixels wide whose scan reads `n_rows` rows.
    pub(super) fn new(w: usize, n_rows: usize) -> Self {
        let step = (w / SAMPLE_GRID).max(1);
        let first = step / 2;
        SampleGrid {
            every: (n_rows / SAMPLE_GRID).max(1),
            first,
            step,
            n_cols: w.saturating_sub(first).div_ceil(step),
        }
    }

    /// How many of the `n_rows` scanned rows are sampled.
    pub(super) fn n_rows(&self, n_rows: usize) -> usize {
        n_rows.div_ceil(self.every)
    }

    /// The sampled columns of a row.
    pub(super) fn cols(&self) -> impl Iterator<Item = usize> {
        let (first, step) = (self.first, self.step);
        (0..self.n_cols).map(move |j| first + j * step)
    }
}

/// The frame's background and noise, its brightest scanned pixel, and the thresholds: `T`
/// (`thr`), the lowered one of the scanned rows (`scan_thr`) and the blob test's
/// (`half_thr`), as the largest pixel values at or below them.
struct Levels {
    bg: f64,
    noise: f64,
    best: u32,
    thr: u32,
    scan_thr: u32,
    half_thr: u32,
}

impl Levels {
    /// The levels from the scan; `Err` the `no_spot` result when no scanned row exceeds
    /// the lowered threshold (or the threshold is out of the pixels' range, or NaN).
    fn new<P: Px>(
        p: &SpotParams,
        k: usize,
        row_max: &[u32],
        (bg, noise): (f64, f64),
    ) -> Result<Self, Spot> {
        let excess = (p.detect_sigmas * noise.max(0.5)).max(p.min_peak_dn);
        let thr_f = bg + if excess.is_finite() { excess } else { 0.0 };
        // A spot whose peak is above T shows at least `reach` of its excess on a scanned row.
        let scan_f = bg + scan_reach(k, p.min_sigma_px) * (thr_f - bg);
        let best = row_max.iter().copied().max().unwrap_or(0);
        let detectable = thr_f < P::MAX as f64 && scan_f <= thr_f; // false for NaN
        if !detectable || (best as f64) <= scan_f {
            return Err(Spot::none(bg, noise, best as f64 - bg, 0));
        }
        Ok(Levels {
            bg,
            noise,
            best,
            thr: thr_f.floor() as u32, // pixel > thr  ⇔  pixel > thr_f
            scan_thr: scan_f.floor() as u32,
            half_thr: (bg + 0.5 * (thr_f - bg)).floor() as u32,
        })
    }

    /// `no_spot` with these levels, after `blobs` blobs were found.
    fn none(&self, blobs: usize) -> Spot {
        Spot::none(self.bg, self.noise, self.best as f64 - self.bg, blobs)
    }
}

/// Step 2, candidates in the bright scanned rows (at most [`MAX_RUNS`] rows' worth):
/// stretches of pixels above the scan threshold, each kept as a run if [`verify_run`]
/// finds its peak on the rows around it.
fn candidate_runs<P: Px>(f: &FrameView, rows: ScanRows, row_max: &[u32], lv: &Levels) -> Vec<Run> {
    let mut runs: Vec<Run> = Vec::new();
    for (i, &m) in row_max.iter().enumerate() {
        if m <= lv.scan_thr || runs.len() >= MAX_RUNS {
            continue;
        }
        row_runs::<P>(f, i, rows.row(i), rows.k, lv, &mut runs);
    }
    runs
}

/// The runs of scanned row `i` (frame row `y`) onto `runs`: stretches of pixels above the
/// scan threshold (gaps of ≤ 2 px bridged; 32-pixel chunks skipped unless their maximum is
/// above it), each checked on the rows around it (up to the next scanned rows, `k` away).
#[inline]
fn row_runs<P: Px>(f: &FrameView, i: usize, y: usize, k: usize, lv: &Levels, runs: &mut Vec<Run>) {
    let keep = |r: Run, runs: &mut Vec<Run>| {
        if let Some(r) = verify_run::<P>(f, r, k, lv.thr, lv.half_thr) {
            runs.push(r);
        }
    };
    let (w, scan_thr) = (f.width, lv.scan_thr);
    let row = f.row(y);
    let mut cur: Option<Run> = None;
    let mut x0 = 0usize;
    while x0 < w {
        let x1 = (x0 + 32).min(w);
        if P::max_of(&row[x0 * P::BPP..x1 * P::BPP]) > scan_thr {
            for x in x0..x1 {
                let v = P::get(row, x);
                if v <= scan_thr {
                    continue;
                }
                match cur.as_mut() {
                    Some(r) if x <= r.x1 + 3 => {
                        r.x1 = x;
                        if v > r.peak {
                            r.peak = v;
                            r.peak_x = x;
                        }
                    }
                    _ => {
                        if let Some(r) = cur.take() {
                            keep(r, runs);
                        }
                        cur = Some(Run {
                            scan_idx: i,
                            y,
                            x0: x,
                            x1: x,
                            peak: v,
                            peak_x: x,
                            peak_y: y,
                        });
                    }
                }
            }
        }
        x0 = x1;
    }
    if let Some(r) = cur {
        keep(r, runs);
    }
}

/// Step 3, blobs: runs joined into blobs, each with its brightest run's peak, in the order
/// of their first run.
fn blobs_of(runs: &[Run], k: usize) -> Vec<Blob> {
    let mut parent = join_runs(runs, k);
    let mut blobs: Vec<Blob> = Vec::new();
    let mut blob_of_root = vec![usize::MAX; runs.len()];
    for (i, run) in runs.iter().enumerate() {
        let r = root(&mut parent, i);
        let here = Blob {
            peak: run.peak,
            x: run.peak_x,
            y: run.peak_y,
        };
        match blobs.get_mut(blob_of_root[r]) {
            Some(b) => {
                if run.peak > b.peak {
                    *b = here;
                }
            }
            None => {
                blob_of_root[r] = blobs.len();
                blobs.push(here);
            }
        }
    }
    blobs
}

/// Union–find of runs overlapping (± `k` px) between neighbouring scanned rows: the parent
/// of every run (runs in scan order).
fn join_runs(runs: &[Run], k: usize) -> Vec<usize> {
    let mut parent: Vec<usize> = (0..runs.len()).collect();
    let mut prev_start = 0usize; // first run of the previous scanned row
    let mut cur_start = 0usize; // first run of the current scanned row
    for i in 0..runs.len() {
        if i > 0 && runs[i].scan_idx != runs[i - 1].scan_idx {
            prev_start = if runs[i].scan_idx == runs[i - 1].scan_idx + 1 {
                cur_start
            } else {
                i // no runs on the previous scanned row
            };
            cur_start = i;
        }
        for j in prev_start..cur_start {
            let (a, b) = (&runs[i], &runs[j]);
            if a.x0 <= b.x1 + k + 1 && b.x0 <= a.x1 + k + 1 {
                let (ra, rb) = (root(&mut parent, i), root(&mut parent, j));
                if ra != rb {
                    parent[ra] = rb;
                }
            }
        }
    }
    parent
}

/// The root of `i` in the union–find `parent` (halving the path on the way).
fn root(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

/// The blob with the brightest peak (the first of equals); `blobs` is not empty.
fn brightest_blob(blobs: &[Blob]) -> usize {
    let mut primary = 0usize;
    for (i, b) in blobs.iter().enumerate() {
        if b.peak > blobs[primary].peak {
            primary = i;
        }
    }
    primary
}

/// Step 4, the result: the measurement of blob `primary` and its status (the first that
/// applies of `multiple`, `at_border`, `streak`, `saturated`, `ok`).
fn spot_of(m: &Measured, blobs: &[Blob], primary: usize, p: &SpotParams) -> Spot {
    let margin = p.ring_px as f64;
    let far = blobs.iter().enumerate().any(|(i, b)| {
        i != primary
            && ((b.x as f64 - m.x).abs() > m.hx as f64 + margin
                || (b.y as f64 - m.y).abs() > m.hy as f64 + margin)
    });
    let status = if far {
        SpotStatus::Multiple
    } else if m.cut {
        SpotStatus::AtBorder
    } else if m.elongation > p.streak_elongation || m.elongation.is_nan() {
        SpotStatus::Streak
    } else if m.saturated {
        SpotStatus::Saturated
    } else {
        SpotStatus::Ok
    };
    Spot {
        status,
        x_px: m.x,
        y_px: m.y,
        peak: m.amp,
        signal: m.signal,
        size_px: m.size,
        background: m.bg,
        noise: m.noise,
        elongation: m.elongation,
        blobs: blobs.len(),
        iterations: m.iterations,
    }
}

/// Check a candidate stretch of a scanned row on the rows around it (up to the scanned
/// rows `k` above and below; its columns ± 2): the brightest pixel above `thr` that passes
/// [`is_blob`] becomes the run's peak; `None` if there is none.
pub(super) fn verify_run<P: Px>(
    f: &FrameView,
    mut r: Run,
    k: usize,
    thr: u32,
    half_thr: u32,
) -> Option<Run> {
    let reach = k.saturating_sub(1);
    let (y0, y1) = (r.y.saturating_sub(reach), (r.y + reach).min(f.height - 1));
    let (x0, x1) = (r.x0.saturating_sub(2), (r.x1 + 2).min(f.width - 1));
    let mut best: Option<(u32, usize, usize)> = None;
    for y in y0..=y1 {
        let row = f.row(y);
        if P::max_of(&row[x0 * P::BPP..(x1 + 1) * P::BPP]) <= thr.max(best.map_or(0, |b| b.0)) {
            continue;
        }
        for x in x0..=x1 {
            let v = P::get(row, x);
            if v > thr && best.is_none_or(|b| v > b.0) && is_blob::<P>(f, x, y, half_thr) {
                best = Some((v, x, y));
            }
        }
    }
    let (peak, x, y) = best?;
    (r.peak, r.peak_x, r.peak_y) = (peak, x, y);
    Some(r)
}

/// Is the 3×3 neighbourhood of (x, y) mostly (its median) above `half_thr`?
#[inline]
pub(super) fn is_blob<P: Px>(f: &FrameView, x: usize, y: usize, half_thr: u32) -> bool {
    let (x0, x1) = (x.saturating_sub(1), (x + 1).min(f.width - 1));
    let (y0, y1) = (y.saturating_sub(1), (y + 1).min(f.height - 1));
    let mut n = 0usize;
    let mut above = 0usize;
    for yy in y0..=y1 {
        let row = f.row(yy);
        for xx in x0..=x1 {
            n += 1;
            above += (P::get(row, xx) > half_thr) as usize;
        }
    }
    // ≥ 5 of 9 inside the frame, proportionally fewer at an edge or corner.
    above * 9 >= 5 * n
}
