//! Laser-spot detection and sub-pixel centroiding on raw CCD frames.
//!
//! One call, [`find_spot`], per frame: is the laser spot on it, and if so where (to a few
//! hundredths of a pixel), how bright, how big and how round. Pixel convention: the centre
//! of the first pixel of the first row is (0, 0); `x` runs along a row (columns), `y` down
//! the rows.
//!
//! # Algorithm
//!
//! **1. Sparse detection (dark frames stop here).** Only every `k`-th row is read, with
//! `k = max(1, floor(2 · min_sigma_px))` (4 for the default `min_sigma_px = 2`): the centre
//! of a spot is never more than `k/2 ≤ σ` rows from a scanned row, where a Gaussian of
//! σ ≥ `min_sigma_px` still shows at least `r = exp(−(k/2)² / 2σ²)` of its peak above the
//! background (≥ 0.61; pixel integration only raises it). The per-row maximum is computed on
//! fixed-size chunks of `u8`/`u16` with no branch per pixel, which the compiler vectorises.
//! While those rows are in cache, about a thousand pixels on a regular grid are copied
//! aside; their median, MAD and then a 4σ-clipped mean and standard deviation give the
//! frame's background `B` and noise `n`. The detection threshold is
//! `T = B + max(detect_sigmas · max(n, 0.5), min_peak_dn)`, and the scanned rows are
//! compared with the lowered `T_s = B + r · (T − B)`, so that any spot whose brightest pixel
//! exceeds `T` shows up wherever it lies between scanned rows. A dark frame is one where no
//! scanned row has a maximum above `T_s`; it costs one read of `1/k` of the rows (whole
//! rows: a cache line holds 64 pixels, so skipping columns would save nothing).
//!
//! **2. Blobs, not pixels.** In each scanned row whose maximum exceeds `T_s` (found by
//! 32-pixel chunks, skipped unless their maximum is above `T_s`), the pixels above `T_s`
//! form candidate stretches (gaps ≤ 2 px bridged). Each candidate is checked on the rows
//! around it, up to the scanned rows above and below (its columns ± 2): its peak is the
//! brightest pixel there that is above `T` and whose 3×3 neighbourhood has its median above
//! `B + (T − B)/2` (at least 5 of 9 pixels, proportionally fewer at the frame edge); with no
//! such pixel the candidate is dropped. A Gaussian spot of σ ≥ 2 passes easily; an isolated
//! hot pixel, or a pair, never does, and noise that crossed `T_s` only costs that check.
//! Stretches of neighbouring scanned rows that overlap (with `k` px tolerance) are joined
//! into blobs (union–find). The blob with the brightest peak is *the* spot; the others are
//! kept for the `multiple` test, which therefore sees a second spot of σ ≥ `min_sigma_px`
//! above `T` wherever it lies.
//!
//! **3. Measurement (only a window around the spot is read).** Seed: the brightest pixel
//! within ±`k` of the blob's peak, and σ from the half-maximum width along its row and
//! column. Then iterate on a box of ±`window_sigmas`·σ around the current centre:
//! - background `b` and noise `n` from a ring `ring_px` wide around the box (median/MAD,
//!   then 4σ-clipped mean and rms; the frame-wide values if the ring has fewer than 8
//!   pixels), recomputed only when the box moves;
//! - with `v = I − b`, a Gaussian `G` of the current pixel-level covariance
//!   `S = diag(sx², sy²)` (σ² + 1/12 per axis) centred on the estimate `c`, and the
//!   amplitude `A = ΣGv / ΣG²`, the centre solves the maximum-likelihood score equation of
//!   the model `b + A·G` with per-pixel variance `n² + α·A·G` (background and read noise
//!   plus shot noise): `Σ W (v − A·G) (x − c) = 0` with `W = G / (α·A·G + n²)`. For a box
//!   symmetric about the spot the `A·G` term vanishes and this is a centroid weighted by
//!   signal/(signal + noise): a plain centre of gravity in the photon-limited core, a
//!   Gaussian-weighted one in the background-limited wings, which is what reaches the
//!   Cramér–Rao bound (a Gaussian weight alone loses ~25 %, a plain centre of gravity over
//!   the box much more). For a box cut by the frame edge, the model term removes most of
//!   the bias. Each pass takes one Fisher-scoring step (`Δc = Σ W (v − A·G) d · s² /
//!   (A · Σ W G d²)`, `d = x − c`);
//! - `α` (DN of variance per DN of signal, i.e. the gain in DN/e⁻) is
//!   [`SpotParams::dn_per_electron`] if given, otherwise estimated each pass from the
//!   residuals `r = v − A·G` by least squares of `r² − n²` on `A·G`; it only shapes the
//!   weights (efficiency), it cannot bias the centre, because every weight is symmetric;
//! - second moments of `v` weighted by `G` (adaptive moments) give `M`; the spot's
//!   covariance is recovered, exactly for a Gaussian, by `C = (M⁻¹ − S⁻¹)⁻¹` (or `2M` when
//!   that is not positive definite) and its diagonal becomes the next `S` and box size.
//!   When the box is cut along one axis only, that axis' σ is taken from the other (the
//!   laser spot is round; the other axis' moments are unaffected by the cut). Once `S`
//!   changes by < 2 % and the centre by < 0.2 px (or after 5 passes), box, `S`, `b` and
//!   `n` are frozen and only the centre, `A` and `α` iterate until the step is below
//!   `tolerance_px` (or `max_iterations`); 4–5 passes in all for typical spots.
//!
//! On simulated pixel-integrated Gaussian spots (σ 2–9 px, 8 and 16 bit, shot and read
//! noise) the per-axis RMS error is within a few per cent of the Cramér–Rao bound of
//! Mortensen et al. (2010) ([`cramer_rao_px`]) and the bias below 0.001 px.
//!
//! Outputs: `x_px`, `y_px` the centre; `peak` = `A`, the spot's amplitude in DN above the
//! background at pixel level; `signal` = `Σ(I − b)` over the final box; `size_px` = σ of the
//! spot, `sqrt(sqrt(λ₁λ₂) − 1/12)` from the eigenvalues of `C`; `elongation` = `λ₁/λ₂`
//! (ratio of the principal second moments of the spot, pixel term removed); `background`,
//! `noise` from the ring. For `no_spot`: position, signal, size and elongation are NaN,
//! `background`/`noise` are the frame-wide estimates and `peak` is the highest scanned
//! pixel above the background (a diagnostic of how far from detection the frame was).
//!
//! # Statuses
//! When several apply, the first in this list wins; all but `no_spot` carry a measurement.
//! - `no_spot`: no blob above the threshold (or its measurement failed: no positive signal);
//! - `multiple`: another blob's brightest pixel lies outside the spot's box (plus ring);
//! - `at_border`: the spot's box is cut by the frame edge (the position is still reported:
//!   within a few tenths of a pixel when one axis is cut, about a pixel in a corner);
//! - `streak`: `elongation > streak_elongation` (motion smear; the centre is that of the
//!   smeared light);
//! - `saturated`: a pixel of the box is at or above the saturation level (the centre is
//!   still reported; within 0.1 px in the tests, even with the core clipped at 1/4 of the
//!   true peak);
//! - `ok`.
//!
//! # Speed
//! A dark 752×582 8-bit frame reads 1/4 of its rows (k = 4) with vectorised maxima (AVX2
//! where the CPU has it, checked at run time), plus a 256-bin histogram of ~1000 sampled
//! pixels, counted as they are read (8-bit frames; wider ones are gathered first): ≈ 1.9 µs
//! with the frame in cache, ≈ 2.5–3.1 µs cycling through 42 MB of frames (≈ 515,000 and
//! 320,000–390,000 frames/s on one core of the development machine; reading every byte caps
//! at ≈ 205,000 and ≈ 92,000). A spot frame (σ 4) adds the candidate rows and 4–5 passes
//! over a 33×33 box: ≈ 9.1 µs in cache (≈ 110,000 frames/s). `cargo test --release
//! -p thermrs-core --lib -- --ignored --nocapture bench_find_spot` measures these. The pixel
//! pass walks the box eight columns at a time down all its rows, with its ten per-column
//! sums in `f32` registers (vectorised, no reduction inside the loop, no `exp` per pixel:
//! the Gaussian is separable and its 1-D factors come from a recurrence); the sums are
//! finished in `f64`. Nothing is allocated per pixel. The function never panics, whatever
//! the input: invalid views give `no_spot`, and only the first `width · bytes_per_px` bytes
//! of each row are read (the padding up to `step` is ignored).

use std::fmt;

mod background;
mod crlb;
mod detect;
mod frame;
mod measure;

use background::*;
use detect::*;
use frame::*;
use measure::*;

pub use crlb::cramer_rao_px;
pub use frame::{FrameError, FrameView};

/// Variance of a uniform distribution over one pixel (px²).
pub(super) const PIXEL_VAR: f64 = 1.0 / 12.0;
/// The box's rows are padded with zeros to a multiple of this many pixels, so that the
/// window pass has no scalar tail (8: one AVX2 vector of f32, two SSE ones).
pub(super) const LANES: usize = 8;
/// Upper bound on runs collected from the scanned rows (pathological frames).
pub(super) const MAX_RUNS: usize = 4096;
/// Target number of background samples taken during the sparse scan (per axis: 32 × 32).
pub(super) const SAMPLE_GRID: usize = 32;

/// What [`find_spot`] concluded about a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpotStatus {
    /// One round, unclipped spot fully inside the frame.
    Ok,
    /// Nothing above the detection threshold.
    NoSpot,
    /// A pixel of the spot's window is at the saturation level.
    Saturated,
    /// The spot's window is cut by the frame edge.
    AtBorder,
    /// A second, separate blob well away from the spot.
    Multiple,
    /// The spot is smeared (elongation above the limit).
    Streak,
}

impl SpotStatus {
    /// `"ok"`, `"no_spot"`, `"saturated"`, `"at_border"`, `"multiple"` or `"streak"`.
    pub fn as_str(&self) -> &'static str {
        match self {
            SpotStatus::Ok => "ok",
            SpotStatus::NoSpot => "no_spot",
            SpotStatus::Saturated => "saturated",
            SpotStatus::AtBorder => "at_border",
            SpotStatus::Multiple => "multiple",
            SpotStatus::Streak => "streak",
        }
    }
}

impl fmt::Display for SpotStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Tuning of [`find_spot`]; `Default` suits a laser spot of σ ≥ 2 px on a CCD.
#[derive(Clone, Debug, PartialEq)]
pub struct SpotParams {
    /// Detection threshold above the background, in units of the frame's noise rms.
    pub detect_sigmas: f64,
    /// Minimum peak above the background (DN) to detect; the larger of this and
    /// `detect_sigmas · noise` applies.
    pub min_peak_dn: f64,
    /// Saturation level in DN; `None`: 255 for 8-bit, 65535 for 16-bit frames.
    pub saturation_dn: Option<u32>,
    /// Smallest spot σ (px) that must be detected; sets the row stride of the sparse
    /// scan, `k = max(1, floor(2 · min_sigma_px))`, and how far below the threshold the
    /// scanned rows are searched (see the module documentation).
    pub min_sigma_px: f64,
    /// Half-size of the measurement box in units of the spot's σ along each axis.
    pub window_sigmas: f64,
    /// Upper bound on the half-size of the measurement box (px); bounds the time per frame.
    pub max_window_half_px: usize,
    /// Width (px) of the ring around the box from which the local background is taken.
    pub ring_px: usize,
    /// Maximum number of passes over the box.
    pub max_iterations: usize,
    /// Convergence: stop when the centre moves less than this (px) in a pass.
    pub tolerance_px: f64,
    /// `streak` when the ratio of the principal second moments exceeds this.
    pub streak_elongation: f64,
    /// Camera gain (DN per photo-electron), used to weight pixels by their shot noise;
    /// `None`: estimated from each spot's residuals.
    pub dn_per_electron: Option<f64>,
}

impl Default for SpotParams {
    fn default() -> Self {
        SpotParams {
            detect_sigmas: 8.0,
            min_peak_dn: 0.0,
            saturation_dn: None,
            min_sigma_px: 2.0,
            window_sigmas: 4.0,
            max_window_half_px: 96,
            ring_px: 2,
            max_iterations: 20,
            tolerance_px: 1e-4,
            streak_elongation: 2.0,
            dn_per_electron: None,
        }
    }
}

/// The result of [`find_spot`] for one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spot {
    /// What was found.
    pub status: SpotStatus,
    /// Centre, column direction (px; centre of the first pixel = 0); NaN for `no_spot`.
    pub x_px: f64,
    /// Centre, row direction (px); NaN for `no_spot`.
    pub y_px: f64,
    /// Amplitude above the background (DN) of the fitted pixel-level Gaussian; for
    /// `no_spot` the highest scanned pixel above the background.
    pub peak: f64,
    /// Background-subtracted DN summed over the measurement box; NaN for `no_spot`.
    pub signal: f64,
    /// Gaussian σ of the spot (px), pixel size removed; NaN for `no_spot`.
    pub size_px: f64,
    /// Background level (DN): local ring for a spot, frame-wide for `no_spot`.
    pub background: f64,
    /// Background noise rms (DN), same origin as `background`.
    pub noise: f64,
    /// Ratio of the principal second moments (≥ 1; 1 for a round spot); NaN for `no_spot`.
    pub elongation: f64,
    /// Number of separate blobs found above the threshold (0 for `no_spot`).
    pub blobs: usize,
    /// Passes over the measurement box (0 for `no_spot`).
    pub iterations: usize,
}

impl Spot {
    fn none(background: f64, noise: f64, peak: f64, blobs: usize) -> Spot {
        Spot {
            status: SpotStatus::NoSpot,
            x_px: f64::NAN,
            y_px: f64::NAN,
            peak,
            signal: f64::NAN,
            size_px: f64::NAN,
            background,
            noise,
            elongation: f64::NAN,
            blobs,
            iterations: 0,
        }
    }
}

/// Finds the laser spot on a frame. Never panics; see the module documentation.
pub fn find_spot(frame: &FrameView, params: &SpotParams) -> Spot {
    if frame.check().is_err() || frame.width == 0 || frame.height == 0 {
        return Spot::none(f64::NAN, f64::NAN, f64::NAN, 0);
    }
    match (frame.bytes_per_px, frame.big_endian) {
        (1, _) => find_spot_px::<U8>(frame, params),
        (_, false) => find_spot_px::<U16Le>(frame, params),
        (_, true) => find_spot_px::<U16Be>(frame, params),
    }
}

#[cfg(test)]
mod tests;
