//! Measurement: the Gaussian-window fit around a detected spot (Fisher scoring on
//! per-column sums, a vectorised pixel pass), moment deconvolution, and the spot's size.

use super::*;

pub(super) struct Measured {
    pub(super) x: f64,
    pub(super) y: f64,
    pub(super) amp: f64,
    pub(super) signal: f64,
    pub(super) size: f64,
    pub(super) elongation: f64,
    pub(super) bg: f64,
    pub(super) noise: f64,
    pub(super) hx: usize,
    pub(super) hy: usize,
    pub(super) cut: bool,
    pub(super) saturated: bool,
    pub(super) iterations: usize,
}

/// Half width at half maximum (px) walking from `0` in one direction; `None` past the edge.
pub(super) fn half_width(
    get: impl Fn(isize) -> Option<f64>,
    half: f64,
    max_steps: isize,
) -> Option<f64> {
    let mut prev = get(0)?;
    for i in 1..=max_steps {
        let v = get(i)?;
        if v < half {
            let frac = if prev > v {
                (prev - half) / (prev - v)
            } else {
                0.5
            };
            return Some((i - 1) as f64 + frac.clamp(0.0, 1.0));
        }
        prev = v;
    }
    Some(max_steps as f64)
}

/// `g[i] = exp(−(x0 + i − c)² / (2 s2))` and `d[i] = x0 + i − c` for `i < n`, by a
/// two-sided recurrence from the pixel nearest `c` (four `exp` calls per axis); `sums`
/// receives `Σg`, `Σg²`, `Σg³`.
pub(super) fn gauss_1d(
    x0: isize,
    n: usize,
    c: f64,
    s2: f64,
    g: &mut [f32],
    d: &mut [f32],
    sums: &mut [f64; 3],
) {
    let inv = 1.0 / (2.0 * s2);
    let ic = ((c.round() as isize) - x0).clamp(0, n as isize - 1) as usize;
    let q = (-2.0 * inv).exp(); // ratio of successive ratios
    let dc = (x0 + ic as isize) as f64 - c;
    let gc = (-dc * dc * inv).exp();
    let mut s = [gc, gc * gc, gc * gc * gc];
    g[ic] = gc as f32;
    // Going right: g(d+1) = g(d)·exp(−(2d+1)·inv); the factor shrinks by q each step.
    let mut gi = gc;
    let mut r = (-(2.0 * dc + 1.0) * inv).exp();
    for o in g[ic + 1..n].iter_mut() {
        gi *= r;
        r *= q;
        *o = gi as f32;
        s[0] += gi;
        s[1] += gi * gi;
        s[2] += gi * gi * gi;
    }
    // Going left: g(d−1) = g(d)·exp((2d−1)·inv).
    let mut gi = gc;
    let mut r = ((2.0 * dc - 1.0) * inv).exp();
    for o in g[..ic].iter_mut().rev() {
        gi *= r;
        r *= q;
        *o = gi as f32;
        s[0] += gi;
        s[1] += gi * gi;
        s[2] += gi * gi * gi;
    }
    for (i, di) in d[..n].iter_mut().enumerate() {
        *di = ((x0 + i as isize) as f64 - c) as f32;
    }
    *sums = s;
}

/// Number of per-column accumulators of a pass over the box.
pub(super) const N_COLS: usize = 10;

/// The pixel loop of a pass: per-column sums over the rows of the box, with `G = gx·gy`,
/// `W = G/(αA·G + n²)`, `v = I − b`, into `cols` ([`N_COLS`] columns of `nxp`, in this
/// order): `Wv`, `Wv·dy`, `WG`, `WG·dy`, `WG·dy²`, `Gv`, `Gv·dy`, `Gv·dy²`, `Gv²`, `G²v`.
///
/// The box is walked [`LANES`] columns at a time, all rows down, with the ten sums in
/// registers (a row at a time would load and store all ten per pixel). Each column's sum still
/// adds its rows in order, so the bits do not depend on the walk. Where the CPU has AVX2 the
/// loop runs eight lanes wide; every operation is per pixel (no fused multiply-add, no sum
/// across lanes), so both routes give the same bits.
#[inline(never)]
pub(super) fn box_sums(b: &BoxPass, cols: &mut [f32]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2 (checked just above).
        return unsafe { box_sums_avx2(b, cols) };
    }
    box_sums_body(b, cols)
}

/// What [`box_sums`] sums over: the box's rows of `v = I − b` (`nxp` apart, padded with 0),
/// the window's 1-D factors `gx` (padded with 0, so that the padding contributes nothing) and
/// `gy`, the rows' offsets `dyv` from the centre, `aa = αA` and `nn = n²`.
pub(super) struct BoxPass<'a> {
    pub(super) vals: &'a [f32],
    pub(super) gx: &'a [f32],
    pub(super) gy: &'a [f32],
    pub(super) dyv: &'a [f32],
    pub(super) aa: f32,
    pub(super) nn: f32,
    pub(super) nxp: usize,
}

/// [`box_sums_body`] compiled for AVX2.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn box_sums_avx2(b: &BoxPass, cols: &mut [f32]) {
    box_sums_body(b, cols)
}

/// [`box_sums`] for whatever instructions the build targets.
#[inline(always)]
pub(super) fn box_sums_body(p: &BoxPass, cols: &mut [f32]) {
    let BoxPass {
        vals,
        gx,
        gy,
        dyv,
        aa,
        nn,
        nxp,
    } = *p;
    let ny = gy.len().min(dyv.len());
    if nxp % LANES != 0 || gx.len() < nxp || vals.len() < ny * nxp || cols.len() < N_COLS * nxp {
        return;
    }
    for b in (0..nxp).step_by(LANES) {
        let mut g = [0.0f32; LANES];
        g.copy_from_slice(&gx[b..b + LANES]);
        let mut acc = [[0.0f32; LANES]; N_COLS];
        for (j, (&gyj, &dy)) in gy.iter().zip(dyv).enumerate() {
            let v = &vals[j * nxp + b..j * nxp + b + LANES];
            let dy2 = dy * dy;
            for i in 0..LANES {
                let gg = g[i] * gyj;
                let wgt = gg / (aa * gg + nn);
                let vv = v[i];
                let wv = wgt * vv;
                let wg = wgt * gg;
                let gv = gg * vv;
                acc[0][i] += wv;
                acc[1][i] += wv * dy;
                acc[2][i] += wg;
                acc[3][i] += wg * dy;
                acc[4][i] += wg * dy2;
                acc[5][i] += gv;
                acc[6][i] += gv * dy;
                acc[7][i] += gv * dy2;
                acc[8][i] += gv * vv;
                acc[9][i] += gv * gg;
            }
        }
        for (k, a) in acc.iter().enumerate() {
            cols[k * nxp + b..k * nxp + b + LANES].copy_from_slice(a);
        }
    }
}

/// Scratch buffers of one measurement, reused by its passes.
#[derive(Default)]
struct Scratch {
    gx: Vec<f32>,
    dxv: Vec<f32>,
    gy: Vec<f32>,
    dyv: Vec<f32>,
    vals: Vec<f32>,
    cols: Vec<f32>,
    ring: Vec<u16>,
}

/// What one pass over the box gives the update (see [`box_sums`]; `dx`, `dy` the offsets
/// from the current centre, `sum_g*` the sums of `G`, `G²`, `G³`).
struct PassSums {
    wv: f64,
    wv_dx: f64,
    wv_dy: f64,
    wg_dx: f64,
    wg_dx2: f64,
    wg_dy: f64,
    wg_dy2: f64,
    gv: f64,
    gv_dx: f64,
    gv_dx2: f64,
    gv_dy: f64,
    gv_dy2: f64,
    gv_dxdy: f64,
    v2g: f64,
    vg2: f64,
    sum_g: f64,
    sum_g2: f64,
    sum_g3: f64,
}

/// The Gaussian-window fit of one spot: the window `S = diag(sx2, sy2)` and its box, the
/// local background `b` and noise `n2` (variance), the amplitude, the gain `alpha`, the
/// centre; fixed for the spot: the frame's size, the bounds on the box, the seed.
struct Fit {
    w: isize,
    h: isize,
    maxh: f64,
    nsig: f64,
    max_s2: f64,
    tol: f64,
    est_alpha: bool,
    bg0: f64,
    noise0: f64,
    seed_x: f64,
    seed_y: f64,
    cx: f64,
    cy: f64,
    sx2: f64,
    sy2: f64,
    alpha: f64,
    amp: f64,
    b: f64,
    n2: f64,
    cov: [f64; 3],
    frozen: bool,
    bx0: isize,
    bx1: isize,
    by0: isize,
    by1: isize,
    hx: isize,
    hy: isize,
    cut_x: bool,
    cut_y: bool,
    /// The unclipped box the ring background was last taken around.
    ring_box: (isize, isize, isize, isize),
    iterations: usize,
}

/// Measures the spot of blob `seed`: seed the fit, iterate (box and ring background until
/// the window is frozen, one pass, one update) until the centre's step is below the
/// tolerance, then the final box's signal, saturation and the spot's size.
#[allow(clippy::too_many_arguments)]
pub(super) fn measure<P: Px>(
    f: &FrameView,
    p: &SpotParams,
    seed: Blob,
    k: usize,
    bg0: f64,
    noise0: f64,
    sat: u32,
) -> Option<Measured> {
    let mut fit = Fit::seed::<P>(f, p, seed, k, bg0, noise0)?;
    let mut s = Scratch::default();
    for it in 0..p.max_iterations.max(1) {
        fit.iterations = it + 1;
        if !fit.frozen {
            fit.place_box::<P>(f, p.ring_px, &mut s.ring)?;
        }
        let sums = fit.pass::<P>(f, &mut s)?;
        if fit.update(&sums, it)? {
            break;
        }
    }
    Some(fit.finish::<P>(f, sat))
}

impl Fit {
    /// Seed: the brightest pixel within ±`k` of the blob's peak, and σ from the half-maximum
    /// widths along its row and column; `None` if that pixel is not above `bg0`.
    fn seed<P: Px>(
        f: &FrameView,
        p: &SpotParams,
        seed: Blob,
        k: usize,
        bg0: f64,
        noise0: f64,
    ) -> Option<Fit> {
        let (px, py, pv) = brightest_near::<P>(f, seed, k);
        let amp0 = pv as f64 - bg0;
        if amp0.is_nan() || amp0 <= 0.0 {
            return None;
        }
        let maxh = p.max_window_half_px.max(2) as f64;
        let nsig = if p.window_sigmas.is_finite() {
            p.window_sigmas.max(1.0)
        } else {
            4.0
        };
        let max_s2 = (maxh / nsig).powi(2);
        let (hwx, hwy) = half_widths::<P>(f, px, py, bg0 + 0.5 * amp0, maxh as isize);
        let fwhm_to_sigma = 1.0 / (2.0 * std::f64::consts::LN_2).sqrt();
        let sx2 = (hwx * fwhm_to_sigma).powi(2).clamp(0.25, max_s2);
        let sy2 = (hwy * fwhm_to_sigma).powi(2).clamp(0.25, max_s2);
        let (cx, cy) = (px as f64, py as f64);
        let est_alpha = !matches!(p.dn_per_electron, Some(g) if g.is_finite() && g >= 0.0);
        Some(Fit {
            w: f.width as isize,
            h: f.height as isize,
            maxh,
            nsig,
            max_s2,
            tol: if p.tolerance_px > 0.0 {
                p.tolerance_px
            } else {
                1e-4
            },
            est_alpha,
            bg0,
            noise0,
            seed_x: cx,
            seed_y: cy,
            cx,
            cy,
            sx2,
            sy2,
            alpha: if est_alpha {
                0.0
            } else {
                p.dn_per_electron.unwrap_or(0.0)
            },
            amp: amp0,
            b: bg0,
            n2: (noise0 * noise0).max(PIXEL_VAR),
            cov: [sx2, 0.0, sy2],
            frozen: false,
            bx0: 0,
            bx1: 0,
            by0: 0,
            by1: 0,
            hx: 0,
            hy: 0,
            cut_x: false,
            cut_y: false,
            ring_box: (isize::MIN, 0, 0, 0),
            iterations: 0,
        })
    }

    /// The box of ±`nsig`·σ around the current centre, clipped to the frame (`None` if
    /// nothing is left), and, when the box moved, the local background and noise from the
    /// ring `ring_px` wide around it (the frame-wide values if it has fewer than 8 pixels).
    fn place_box<P: Px>(
        &mut self,
        f: &FrameView,
        ring_px: usize,
        ring: &mut Vec<u16>,
    ) -> Option<()> {
        let (w, h) = (self.w, self.h);
        let hx = (self.nsig * self.sx2.sqrt()).ceil().clamp(2.0, self.maxh) as isize;
        let hy = (self.nsig * self.sy2.sqrt()).ceil().clamp(2.0, self.maxh) as isize;
        let (ix, iy) = (self.cx.round() as isize, self.cy.round() as isize);
        (self.hx, self.hy) = (hx, hy);
        self.cut_x = ix - hx < 0 || ix + hx >= w;
        self.cut_y = iy - hy < 0 || iy + hy >= h;
        self.bx0 = (ix - hx).max(0);
        self.bx1 = (ix + hx).min(w - 1);
        self.by0 = (iy - hy).max(0);
        self.by1 = (iy + hy).min(h - 1);
        if self.bx1 < self.bx0 || self.by1 < self.by0 {
            return None;
        }
        let unclipped = (ix - hx, ix + hx, iy - hy, iy + hy);
        if unclipped != self.ring_box {
            self.ring_box = unclipped;
            let rp = ring_px.min(1 << 20) as isize;
            let outer = (
                (ix - hx - rp).max(0),
                (ix + hx + rp).min(w - 1),
                (iy - hy - rp).max(0),
                (iy + hy + rp).min(h - 1),
            );
            let inner = (self.bx0, self.bx1, self.by0, self.by1);
            ring_pixels::<P>(f, outer, inner, ring);
            if ring.len() >= 8 {
                let (rb, rn) = robust_stats(ring);
                self.b = rb;
                self.n2 = (rn * rn).max(PIXEL_VAR);
            } else {
                self.b = self.bg0;
                self.n2 = (self.noise0 * self.noise0).max(PIXEL_VAR);
            }
        }
        Some(())
    }

    /// One pass over the box: the window's 1-D factors, per-column sums of the weighted
    /// terms (no reductions inside the pixel loop, so it vectorises), finished in `f64`;
    /// `None` if the box holds no positive signal.
    fn pass<P: Px>(&self, f: &FrameView, s: &mut Scratch) -> Option<PassSums> {
        let (bx0, bx1, by0, by1) = (self.bx0, self.bx1, self.by0, self.by1);
        let nx = (bx1 - bx0 + 1) as usize;
        let ny = (by1 - by0 + 1) as usize;
        let nxp = nx.div_ceil(LANES) * LANES;
        for v in [&mut s.gx, &mut s.dxv] {
            v.clear();
            v.resize(nxp, 0.0);
        }
        for v in [&mut s.gy, &mut s.dyv] {
            v.clear();
            v.resize(ny, 0.0);
        }
        s.cols.clear();
        s.cols.resize(N_COLS * nxp, 0.0);
        let mut sxs = [0.0f64; 3];
        let mut sys = [0.0f64; 3];
        gauss_1d(bx0, nx, self.cx, self.sx2, &mut s.gx, &mut s.dxv, &mut sxs);
        gauss_1d(by0, ny, self.cy, self.sy2, &mut s.gy, &mut s.dyv, &mut sys);
        let aa = (self.alpha * self.amp) as f32;
        let nn = self.n2 as f32;
        let bf = self.b as f32;
        s.vals.clear();
        s.vals.resize(ny * nxp, 0.0);
        for (j, out) in s.vals.chunks_exact_mut(nxp).enumerate() {
            let row = f.row(by0 as usize + j);
            let bytes = &row[bx0 as usize * P::BPP..(bx1 as usize + 1) * P::BPP];
            P::to_f32(bytes, bf, &mut out[..nx]);
        }
        let pass = BoxPass {
            vals: &s.vals,
            gx: &s.gx,
            gy: &s.gy,
            dyv: &s.dyv,
            aa,
            nn,
            nxp,
        };
        box_sums(&pass, &mut s.cols);
        pass_sums(&s.cols, &s.dxv, nxp, sxs, sys)
    }

    /// The update from one pass: amplitude and gain, one Fisher-scoring step of the centre,
    /// the deconvolved moments, and (until frozen) the window. `Some(true)` once frozen and
    /// the step is below the tolerance; `None` if the centre ran more than the largest box
    /// half-size from the seed.
    fn update(&mut self, s: &PassSums, it: usize) -> Option<bool> {
        self.amplitude_and_gain(s);
        // Fisher-scoring step on the score Σ W (v − A·G) d = 0 (d = x − c); the model term
        // vanishes for a box symmetric about the spot and removes most of the bias of a
        // box cut by the frame edge. Centre-of-gravity step as fallback.
        let (amp, sx2, sy2) = (self.amp, self.sx2, self.sy2);
        let dx = scoring_step(
            s.wv_dx - amp * s.wg_dx,
            amp * s.wg_dx2 / sx2,
            sx2.sqrt().max(1.0),
            s.wv,
        );
        let dy = scoring_step(
            s.wv_dy - amp * s.wg_dy,
            amp * s.wg_dy2 / sy2,
            sy2.sqrt().max(1.0),
            s.wv,
        );

        // Moments weighted by G at the current centre, deconvolved.
        let mx = s.gv_dx / s.gv;
        let my = s.gv_dy / s.gv;
        let mxx = s.gv_dx2 / s.gv - mx * mx;
        let myy = s.gv_dy2 / s.gv - my * my;
        let mxy = s.gv_dxdy / s.gv - mx * my;
        self.cov = deconvolve(mxx, myy, mxy, sx2, sy2).unwrap_or(self.cov);

        self.cx = (self.cx + dx).clamp(-0.5, self.w as f64 - 0.5);
        self.cy = (self.cy + dy).clamp(-0.5, self.h as f64 - 0.5);
        if (self.cx - self.seed_x).abs() > self.maxh || (self.cy - self.seed_y).abs() > self.maxh {
            return None;
        }
        let moved = dx.abs().max(dy.abs());
        if self.frozen {
            return Some(moved < self.tol);
        }
        self.adapt_window(moved, it);
        Some(false)
    }

    /// Amplitude `A = ΣGv / ΣG²` at the current centre and, unless given, the gain `α` by
    /// least squares of the residuals' `r² − n²` on `A·G`.
    fn amplitude_and_gain(&mut self, s: &PassSums) {
        let amp_new = s.gv / s.sum_g2;
        if self.est_alpha && amp_new > 0.0 {
            let num =
                s.v2g - 2.0 * amp_new * s.vg2 + amp_new * amp_new * s.sum_g3 - self.n2 * s.sum_g;
            let a = num / (amp_new * s.sum_g2);
            self.alpha = if a.is_finite() {
                a.clamp(0.0, 1e4)
            } else {
                0.0
            };
        }
        if amp_new > 0.0 {
            self.amp = amp_new;
        }
    }

    /// The next window from the spot's covariance; frozen once it changes by < 2 % and the
    /// centre by < 0.2 px, or after 5 passes.
    fn adapt_window(&mut self, moved: f64, it: usize) {
        let mut nsx2 = self.cov[0].clamp(0.25, self.max_s2);
        let mut nsy2 = self.cov[2].clamp(0.25, self.max_s2);
        // A box cut by the frame edge along one axis biases that axis' moments low;
        // the other axis is unaffected (the spot is separable), so take the spot as
        // round there.
        if self.cut_x && !self.cut_y {
            nsx2 = nsy2;
        } else if self.cut_y && !self.cut_x {
            nsy2 = nsx2;
        }
        let change = ((nsx2 - self.sx2) / self.sx2)
            .abs()
            .max(((nsy2 - self.sy2) / self.sy2).abs());
        self.sx2 = nsx2;
        self.sy2 = nsy2;
        if (change < 0.02 && moved < 0.2) || it >= 4 {
            self.frozen = true;
        }
    }

    /// The result: the final box's signal above `b` and saturation, the spot's size and
    /// elongation from its covariance.
    fn finish<P: Px>(&self, f: &FrameView, sat: u32) -> Measured {
        let (bx0, bx1, by0, by1) = (self.bx0, self.bx1, self.by0, self.by1);
        let mut sum = 0u64;
        let mut maxv = 0u32;
        for y in by0..=by1 {
            let row = f.row(y as usize);
            let bytes = &row[bx0 as usize * P::BPP..(bx1 as usize + 1) * P::BPP];
            sum += P::sum_of(bytes);
            maxv = maxv.max(P::max_of(bytes));
        }
        let npix = ((bx1 - bx0 + 1) * (by1 - by0 + 1)) as f64;
        let (size, elongation) = size_and_elongation(self.cov);
        Measured {
            x: self.cx,
            y: self.cy,
            amp: self.amp,
            signal: sum as f64 - self.b * npix,
            size,
            elongation,
            bg: self.b,
            noise: self.n2.sqrt(),
            hx: self.hx as usize,
            hy: self.hy as usize,
            cut: self.cut_x || self.cut_y,
            saturated: maxv >= sat,
            iterations: self.iterations,
        }
    }
}

/// The brightest pixel within ±`k` of the blob's peak (the peak itself unless one is
/// brighter): `(x, y, value)`.
fn brightest_near<P: Px>(f: &FrameView, seed: Blob, k: usize) -> (usize, usize, u32) {
    let (mut px, mut py, mut pv) = (seed.x, seed.y, seed.peak);
    let ylo = seed.y.saturating_sub(k);
    let yhi = (seed.y + k).min(f.height - 1);
    let xlo = seed.x.saturating_sub(k);
    let xhi = (seed.x + k).min(f.width - 1);
    for y in ylo..=yhi {
        let row = f.row(y);
        for x in xlo..=xhi {
            let v = P::get(row, x);
            if v > pv {
                (px, py, pv) = (x, y, v);
            }
        }
    }
    (px, py, pv)
}

/// Half widths (px) at the level `half` along the row and the column through `(px, py)`,
/// each the mean of its two directions (the one inside the frame if the other leaves it;
/// 1 if both do), walking at most `steps` px.
fn half_widths<P: Px>(f: &FrameView, px: usize, py: usize, half: f64, steps: isize) -> (f64, f64) {
    let (w, h) = (f.width as isize, f.height as isize);
    let pix = |x: isize, y: isize| -> Option<f64> {
        if x < 0 || y < 0 || x >= w || y >= h {
            None
        } else {
            Some(P::get(f.row(y as usize), x as usize) as f64)
        }
    };
    let (pxi, pyi) = (px as isize, py as isize);
    let hw = |a: Option<f64>, b: Option<f64>| match (a, b) {
        (Some(a), Some(b)) => 0.5 * (a + b),
        (Some(a), None) | (None, Some(a)) => a,
        (None, None) => 1.0,
    };
    let hwx = hw(
        half_width(|i| pix(pxi + i, pyi), half, steps),
        half_width(|i| pix(pxi - i, pyi), half, steps),
    );
    let hwy = hw(
        half_width(|i| pix(pxi, pyi + i), half, steps),
        half_width(|i| pix(pxi, pyi - i), half, steps),
    );
    (hwx, hwy)
}

/// The pixels of the rectangle `outer` that are not in the box `inner` (both
/// `(x0, x1, y0, y1)`, inclusive, inside the frame) into `ring`, cleared first.
#[inline]
fn ring_pixels<P: Px>(
    f: &FrameView,
    outer: (isize, isize, isize, isize),
    inner: (isize, isize, isize, isize),
    ring: &mut Vec<u16>,
) {
    let (rx0, rx1, ry0, ry1) = outer;
    let (bx0, bx1, by0, by1) = inner;
    ring.clear();
    for y in ry0..=ry1 {
        let row = f.row(y as usize);
        if y >= by0 && y <= by1 {
            for x in (rx0..bx0).chain(bx1 + 1..=rx1) {
                ring.push(P::get(row, x as usize) as u16);
            }
        } else {
            for x in rx0..=rx1 {
                ring.push(P::get(row, x as usize) as u16);
            }
        }
    }
}

/// The per-column sums of a pass (`cols`: [`N_COLS`] columns of `nxp`) finished in `f64`,
/// the `x` offsets `dxv` applied, with the sums of powers of `G` from its 1-D factors'
/// `sxs`, `sys`; `None` if the box holds no positive signal.
fn pass_sums(
    cols: &[f32],
    dxv: &[f32],
    nxp: usize,
    sxs: [f64; 3],
    sys: [f64; 3],
) -> Option<PassSums> {
    let col = |k: usize| &cols[k * nxp..(k + 1) * nxp];
    let sum = |k: usize| col(k).iter().map(|&v| v as f64).sum::<f64>();
    let dot = |k: usize, pow: i32| {
        col(k)
            .iter()
            .zip(dxv)
            .map(|(&v, &d)| v as f64 * (d as f64).powi(pow))
            .sum::<f64>()
    };
    let s = PassSums {
        wv: sum(0),
        wv_dx: dot(0, 1),
        wv_dy: sum(1),
        wg_dx: dot(2, 1),
        wg_dx2: dot(2, 2),
        wg_dy: sum(3),
        wg_dy2: sum(4),
        gv: sum(5),
        gv_dx: dot(5, 1),
        gv_dx2: dot(5, 2),
        gv_dy: sum(6),
        gv_dy2: sum(7),
        gv_dxdy: dot(6, 1),
        v2g: sum(8),
        vg2: sum(9),
        sum_g: sxs[0] * sys[0],
        sum_g2: sxs[1] * sys[1],
        sum_g3: sxs[2] * sys[2],
    };
    if !(s.gv > 0.0 && s.wv > 0.0 && s.sum_g2 > 0.0) {
        return None;
    }
    Some(s)
}

/// One step along an axis: the score `psi` over the information `info` (over `wv`, a
/// centre-of-gravity step, if the information is not positive), clamped to ±`limit`.
#[inline]
fn scoring_step(psi: f64, info: f64, limit: f64, wv: f64) -> f64 {
    let st = if info > 0.0 && info.is_finite() {
        psi / info
    } else {
        psi / wv
    };
    if st.is_finite() {
        st.clamp(-limit, limit)
    } else {
        0.0
    }
}

/// The spot's size `(λ₁λ₂)^¼` and elongation `λ₁/λ₂` from the eigenvalues of its
/// covariance, the pixel term removed (`√mean` and ∞ when it is not positive definite).
fn size_and_elongation(cov: [f64; 3]) -> (f64, f64) {
    let (cxx, cyy, cxy) = (cov[0] - PIXEL_VAR, cov[2] - PIXEL_VAR, cov[1]);
    let mean = 0.5 * (cxx + cyy);
    let disc = (0.25 * (cxx - cyy).powi(2) + cxy * cxy).sqrt();
    let (l1, l2) = (mean + disc, mean - disc);
    if l2 > 0.0 {
        ((l1 * l2).sqrt().sqrt(), l1 / l2)
    } else {
        (mean.max(0.0).sqrt(), f64::INFINITY)
    }
}

/// Spot covariance `C = (M⁻¹ − S⁻¹)⁻¹` from moments `M` measured with a Gaussian weight of
/// covariance `S = diag(sx2, sy2)` (exact for a Gaussian spot). If `M⁻¹ − S⁻¹` is not
/// positive definite (noise, or light not Gaussian), the adaptive-moments update `2M`.
pub(super) fn deconvolve(mxx: f64, myy: f64, mxy: f64, sx2: f64, sy2: f64) -> Option<[f64; 3]> {
    let det = mxx * myy - mxy * mxy;
    if !(mxx > 0.0 && myy > 0.0 && det > 0.0) {
        return None;
    }
    let pxx = myy / det - 1.0 / sx2;
    let pyy = mxx / det - 1.0 / sy2;
    let pxy = -mxy / det;
    let detp = pxx * pyy - pxy * pxy;
    if pxx > 0.0 && pyy > 0.0 && detp > 0.0 {
        Some([pyy / detp, -pxy / detp, pxx / detp])
    } else {
        Some([2.0 * mxx, 2.0 * mxy, 2.0 * myy])
    }
}
