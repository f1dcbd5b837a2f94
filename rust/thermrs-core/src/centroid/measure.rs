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

/// Per-column sums over the rows of the box, with `G = gx·gy`, `W = G/(αA·G + n²)`,
/// `v = I − b`: `Wv`, `Wv·dy`, `WG`, `WG·dy`, `WG·dy²`, `Gv`, `Gv·dy`, `Gv·dy²`, `Gv²`, `G²v`.
pub(super) struct ColSums<'a> {
    pub(super) wv: &'a mut [f32],
    pub(super) wv_dy: &'a mut [f32],
    pub(super) wg: &'a mut [f32],
    pub(super) wg_dy: &'a mut [f32],
    pub(super) wg_dy2: &'a mut [f32],
    pub(super) gv: &'a mut [f32],
    pub(super) gv_dy: &'a mut [f32],
    pub(super) gv_dy2: &'a mut [f32],
    pub(super) v2g: &'a mut [f32],
    pub(super) vg2: &'a mut [f32],
}

/// Adds one row of the box to the column sums (all slices of the same, padded, length;
/// padding has `g = v = 0` and contributes nothing).
#[inline]
pub(super) fn accumulate_row(
    v: &[f32],
    g: &[f32],
    gy: f32,
    dy: f32,
    aa: f32,
    nn: f32,
    c: &mut ColSums,
) {
    row_kernel(
        v, g, gy, dy, aa, nn, c.wv, c.wv_dy, c.wg, c.wg_dy, c.wg_dy2, c.gv, c.gv_dy, c.gv_dy2,
        c.v2g, c.vg2,
    );
}

/// The pixel loop of [`accumulate_row`]; every output is its own `&mut` argument so that
/// the compiler knows they do not alias and vectorises without run-time overlap checks.
#[allow(clippy::too_many_arguments)]
#[inline(never)]
pub(super) fn row_kernel(
    v: &[f32],
    g: &[f32],
    gy: f32,
    dy: f32,
    aa: f32,
    nn: f32,
    wv_: &mut [f32],
    wv_dy: &mut [f32],
    wg_: &mut [f32],
    wg_dy: &mut [f32],
    wg_dy2: &mut [f32],
    gv_: &mut [f32],
    gv_dy: &mut [f32],
    gv_dy2: &mut [f32],
    v2g: &mut [f32],
    vg2: &mut [f32],
) {
    let n = v.len().min(g.len()).min(wv_.len());
    let (v, g) = (&v[..n], &g[..n]);
    let (wv_, wv_dy) = (&mut wv_[..n], &mut wv_dy[..n]);
    let (wg_, wg_dy, wg_dy2) = (&mut wg_[..n], &mut wg_dy[..n], &mut wg_dy2[..n]);
    let (gv_, gv_dy, gv_dy2) = (&mut gv_[..n], &mut gv_dy[..n], &mut gv_dy2[..n]);
    let (v2g, vg2) = (&mut v2g[..n], &mut vg2[..n]);
    let dy2 = dy * dy;
    for i in 0..n {
        let gg = g[i] * gy;
        let wgt = gg / (aa * gg + nn);
        let vv = v[i];
        let wv = wgt * vv;
        let wg = wgt * gg;
        let gv = gg * vv;
        wv_[i] += wv;
        wv_dy[i] += wv * dy;
        wg_[i] += wg;
        wg_dy[i] += wg * dy;
        wg_dy2[i] += wg * dy2;
        gv_[i] += gv;
        gv_dy[i] += gv * dy;
        gv_dy2[i] += gv * dy2;
        v2g[i] += gv * vv;
        vg2[i] += gv * gg;
    }
}

#[allow(clippy::too_many_arguments)]
// Long (~310 lines) on purpose for now: the Fisher-scoring iterations, the moment
// fallback and the size estimate share ~30 per-spot locals; it moved here unchanged (seed /
// iterate / finish is the intended split, see ARCHITECTURE.md).
pub(super) fn measure<P: Px>(
    f: &FrameView,
    p: &SpotParams,
    seed: Blob,
    k: usize,
    bg0: f64,
    noise0: f64,
    sat: u32,
) -> Option<Measured> {
    let (w, h) = (f.width as isize, f.height as isize);
    // Seed: brightest pixel within ±k of the blob's peak.
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
    let half = bg0 + 0.5 * amp0;
    let steps = maxh as isize;
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
    let fwhm_to_sigma = 1.0 / (2.0 * std::f64::consts::LN_2).sqrt();
    let mut sx2 = (hwx * fwhm_to_sigma).powi(2).clamp(0.25, max_s2);
    let mut sy2 = (hwy * fwhm_to_sigma).powi(2).clamp(0.25, max_s2);

    let (mut cx, mut cy) = (px as f64, py as f64);
    let (seed_x, seed_y) = (cx, cy);
    let est_alpha = !matches!(p.dn_per_electron, Some(g) if g.is_finite() && g >= 0.0);
    let mut alpha = if est_alpha {
        0.0
    } else {
        p.dn_per_electron.unwrap_or(0.0)
    };
    let mut amp = amp0;
    let mut b = bg0;
    let mut n2 = (noise0 * noise0).max(PIXEL_VAR);
    let mut cov = [sx2, 0.0, sy2];
    let mut frozen = false;
    let (mut bx0, mut bx1, mut by0, mut by1) = (0isize, 0isize, 0isize, 0isize);
    let (mut hx, mut hy) = (0isize, 0isize);
    let (mut cut_x, mut cut_y) = (false, false);
    let mut iterations = 0usize;
    let tol = if p.tolerance_px > 0.0 {
        p.tolerance_px
    } else {
        1e-4
    };

    let mut gx: Vec<f32> = Vec::new();
    let mut dxv: Vec<f32> = Vec::new();
    let mut gy: Vec<f32> = Vec::new();
    let mut dyv: Vec<f32> = Vec::new();
    let mut vals: Vec<f32> = Vec::new();
    let mut cols: Vec<f32> = Vec::new();
    let mut ring: Vec<u16> = Vec::new();

    let mut ring_box = (isize::MIN, 0isize, 0isize, 0isize);
    for it in 0..p.max_iterations.max(1) {
        iterations = it + 1;
        if !frozen {
            hx = (nsig * sx2.sqrt()).ceil().clamp(2.0, maxh) as isize;
            hy = (nsig * sy2.sqrt()).ceil().clamp(2.0, maxh) as isize;
            let (ix, iy) = (cx.round() as isize, cy.round() as isize);
            cut_x = ix - hx < 0 || ix + hx >= w;
            cut_y = iy - hy < 0 || iy + hy >= h;
            bx0 = (ix - hx).max(0);
            bx1 = (ix + hx).min(w - 1);
            by0 = (iy - hy).max(0);
            by1 = (iy + hy).min(h - 1);
            if bx1 < bx0 || by1 < by0 {
                return None;
            }
            // Local background from the ring around the box (when the box moved).
            let unclipped = (ix - hx, ix + hx, iy - hy, iy + hy);
            if unclipped != ring_box {
                ring_box = unclipped;
                ring.clear();
                let rp = p.ring_px.min(1 << 20) as isize;
                let (rx0, rx1) = ((ix - hx - rp).max(0), (ix + hx + rp).min(w - 1));
                let (ry0, ry1) = ((iy - hy - rp).max(0), (iy + hy + rp).min(h - 1));
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
                if ring.len() >= 8 {
                    let (rb, rn) = robust_stats(&ring);
                    b = rb;
                    n2 = (rn * rn).max(PIXEL_VAR);
                } else {
                    b = bg0;
                    n2 = (noise0 * noise0).max(PIXEL_VAR);
                }
            }
        }
        let nx = (bx1 - bx0 + 1) as usize;
        let ny = (by1 - by0 + 1) as usize;
        let nxp = nx.div_ceil(LANES) * LANES;
        for v in [&mut gx, &mut dxv, &mut vals] {
            v.clear();
            v.resize(nxp, 0.0);
        }
        for v in [&mut gy, &mut dyv] {
            v.clear();
            v.resize(ny, 0.0);
        }
        cols.clear();
        cols.resize(N_COLS * nxp, 0.0);
        let mut sxs = [0.0f64; 3];
        let mut sys = [0.0f64; 3];
        gauss_1d(bx0, nx, cx, sx2, &mut gx, &mut dxv, &mut sxs);
        gauss_1d(by0, ny, cy, sy2, &mut gy, &mut dyv, &mut sys);
        let sum_g = sxs[0] * sys[0];
        let sum_g2 = sxs[1] * sys[1];
        let sum_g3 = sxs[2] * sys[2];

        // One pass over the box: per-column sums of the weighted terms (no reductions
        // inside the pixel loop, so it vectorises).
        let aa = (alpha * amp) as f32;
        let nn = n2 as f32;
        let bf = b as f32;
        {
            let mut c = cols.chunks_exact_mut(nxp);
            let mut next = || c.next().unwrap_or_default();
            let cs = ColSums {
                wv: next(),
                wv_dy: next(),
                wg: next(),
                wg_dy: next(),
                wg_dy2: next(),
                gv: next(),
                gv_dy: next(),
                gv_dy2: next(),
                v2g: next(),
                vg2: next(),
            };
            let mut cs = cs;
            for (j, (&gyj, &dy)) in gy.iter().zip(&dyv).enumerate() {
                let row = f.row(by0 as usize + j);
                let bytes = &row[bx0 as usize * P::BPP..(bx1 as usize + 1) * P::BPP];
                P::to_f32(bytes, bf, &mut vals[..nx]);
                accumulate_row(&vals, &gx, gyj, dy, aa, nn, &mut cs);
            }
        }
        let col = |k: usize| &cols[k * nxp..(k + 1) * nxp];
        let sum = |k: usize| col(k).iter().map(|&v| v as f64).sum::<f64>();
        let dot = |k: usize, pow: i32| {
            col(k)
                .iter()
                .zip(&dxv)
                .map(|(&v, &d)| v as f64 * (d as f64).powi(pow))
                .sum::<f64>()
        };
        let (wv, wv_dx, wv_dy) = (sum(0), dot(0, 1), sum(1));
        let (wg_dx, wg_dx2, wg_dy, wg_dy2) = (dot(2, 1), dot(2, 2), sum(3), sum(4));
        let (gv, gv_dx, gv_dx2) = (sum(5), dot(5, 1), dot(5, 2));
        let (gv_dy, gv_dy2, gv_dxdy) = (sum(6), sum(7), dot(6, 1));
        let (v2g, vg2) = (sum(8), sum(9));
        if !(gv > 0.0 && wv > 0.0 && sum_g2 > 0.0) {
            return None;
        }

        // Amplitude and gain at the current centre.
        let amp_new = gv / sum_g2;
        if est_alpha && amp_new > 0.0 {
            let num = v2g - 2.0 * amp_new * vg2 + amp_new * amp_new * sum_g3 - n2 * sum_g;
            let a = num / (amp_new * sum_g2);
            alpha = if a.is_finite() {
                a.clamp(0.0, 1e4)
            } else {
                0.0
            };
        }
        if amp_new > 0.0 {
            amp = amp_new;
        }
        // Fisher-scoring step on the score Σ W (v − A·G) d = 0 (d = x − c); the model term
        // vanishes for a box symmetric about the spot and removes most of the bias of a
        // box cut by the frame edge. Centre-of-gravity step as fallback.
        let step = |psi: f64, info: f64, limit: f64| -> f64 {
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
        };
        let dx = step(wv_dx - amp * wg_dx, amp * wg_dx2 / sx2, sx2.sqrt().max(1.0));
        let dy = step(wv_dy - amp * wg_dy, amp * wg_dy2 / sy2, sy2.sqrt().max(1.0));

        // Moments weighted by G at the current centre, deconvolved.
        let mx = gv_dx / gv;
        let my = gv_dy / gv;
        let mxx = gv_dx2 / gv - mx * mx;
        let myy = gv_dy2 / gv - my * my;
        let mxy = gv_dxdy / gv - mx * my;
        cov = deconvolve(mxx, myy, mxy, sx2, sy2).unwrap_or(cov);

        cx = (cx + dx).clamp(-0.5, w as f64 - 0.5);
        cy = (cy + dy).clamp(-0.5, h as f64 - 0.5);
        if (cx - seed_x).abs() > maxh || (cy - seed_y).abs() > maxh {
            return None;
        }
        let moved = dx.abs().max(dy.abs());
        if frozen {
            if moved < tol {
                break;
            }
        } else {
            let mut nsx2 = cov[0].clamp(0.25, max_s2);
            let mut nsy2 = cov[2].clamp(0.25, max_s2);
            // A box cut by the frame edge along one axis biases that axis' moments low;
            // the other axis is unaffected (the spot is separable), so take the spot as
            // round there.
            if cut_x && !cut_y {
                nsx2 = nsy2;
            } else if cut_y && !cut_x {
                nsy2 = nsx2;
            }
            let change = ((nsx2 - sx2) / sx2).abs().max(((nsy2 - sy2) / sy2).abs());
            sx2 = nsx2;
            sy2 = nsy2;
            if (change < 0.02 && moved < 0.2) || it >= 4 {
                frozen = true;
            }
        }
    }

    // Final box: signal and saturation.
    let mut sum = 0u64;
    let mut maxv = 0u32;
    for y in by0..=by1 {
        let row = f.row(y as usize);
        let bytes = &row[bx0 as usize * P::BPP..(bx1 as usize + 1) * P::BPP];
        sum += P::sum_of(bytes);
        maxv = maxv.max(P::max_of(bytes));
    }
    let npix = ((bx1 - bx0 + 1) * (by1 - by0 + 1)) as f64;
    let (cxx, cyy, cxy) = (cov[0] - PIXEL_VAR, cov[2] - PIXEL_VAR, cov[1]);
    let mean = 0.5 * (cxx + cyy);
    let disc = (0.25 * (cxx - cyy).powi(2) + cxy * cxy).sqrt();
    let (l1, l2) = (mean + disc, mean - disc);
    let (size, elongation) = if l2 > 0.0 {
        ((l1 * l2).sqrt().sqrt(), l1 / l2)
    } else {
        (mean.max(0.0).sqrt(), f64::INFINITY)
    };
    Some(Measured {
        x: cx,
        y: cy,
        amp,
        signal: sum as f64 - b * npix,
        size,
        elongation,
        bg: b,
        noise: n2.sqrt(),
        hx: hx as usize,
        hy: hy as usize,
        cut: cut_x || cut_y,
        saturated: maxv >= sat,
        iterations,
    })
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
