//! Rendering: a CCD frame (a pixel-integrated Gaussian spot along its path during the exposure,
//! shot and read noise) and an IR frame (°C: ambient, a hot region per ROI, a distractor,
//! noise). Each draws from its own random stream, in a fixed order.

use rand::rngs::StdRng;
use rand_distr::{Distribution, Normal, Poisson, StandardNormal};

use crate::rig::Rig;
use crate::scenario::Scenario;

/// A CCD frame's pixels: spot at (x, y) px plus noise, written into `out` (row-major, `bpp`
/// bytes per pixel little-endian).
#[allow(clippy::too_many_arguments)]
pub(super) fn render_ccd(
    out: &mut [u8],
    w: usize,
    h: usize,
    bpp: usize,
    path: &[(f64, f64)],
    weight: f64,
    cam: &crate::scenario::CameraModel,
    rng: &mut StdRng,
) {
    let gain = cam.dn_per_electron;
    let bg_e = cam.background_dn / gain;
    let read_e = cam.read_noise_dn / gain;
    let max = if bpp == 1 { 255.0 } else { 65535.0 };
    let sd_dn = (bg_e + read_e * read_e).sqrt() * gain;
    let put = |out: &mut [u8], i: usize, dn: f64| {
        let v = round_clamped(dn, max);
        if bpp == 1 {
            out[i] = v as u8;
        } else {
            out[2 * i..2 * i + 2].copy_from_slice(&(v as u16).to_le_bytes());
        }
    };
    for i in 0..w * h {
        let z: f64 = StandardNormal.sample(rng);
        put(out, i, cam.background_dn + sd_dn * z);
    }
    if path.is_empty() {
        return;
    }
    let Some(Window {
        x0,
        x1,
        y0,
        y1,
        nx,
        signal,
    }) = spot_electrons(w, h, path, weight, cam, gain)
    else {
        return;
    };
    let read = Normal::new(0.0, read_e.max(1e-12)).expect("finite");
    for (j, row) in (y0..=y1).enumerate() {
        for (i, col) in (x0..=x1).enumerate() {
            let lam = signal[j * nx + i] + bg_e;
            let e = if lam > 0.0 {
                Poisson::new(lam).map(|p| p.sample(rng)).unwrap_or(lam)
            } else {
                0.0
            };
            let dn = (e + read.sample(rng)) * gain;
            put(out, row as usize * w + col as usize, dn);
        }
    }
}

/// `dn.round().clamp(0.0, max) as u32` to the bit (half away from zero, NaN to 0) without
/// the call to `round`, which cost a tenth of a simulation: clamped first, the value is ≥ 0, so
/// the cast truncates it and its fraction (exact) says whether to round up.
#[inline]
fn round_clamped(dn: f64, max: f64) -> u32 {
    let d = dn.max(0.0).min(max);
    let t = d as u32;
    t + u32::from(d - f64::from(t) >= 0.5)
}

/// The box around the spot's path (clipped to the frame) and the expected signal electrons
/// per pixel in it, row-major `nx` wide.
struct Window {
    x0: i64,
    x1: i64,
    y0: i64,
    y1: i64,
    nx: usize,
    signal: Vec<f64>,
}

/// The spot's pixel-integrated Gaussian at each point of its path, `weight` of the signal
/// each; `None` when the box misses the frame.
fn spot_electrons(
    w: usize,
    h: usize,
    path: &[(f64, f64)],
    weight: f64,
    cam: &crate::scenario::CameraModel,
    gain: f64,
) -> Option<Window> {
    // The spot's Gaussian at each point of its path, `weight` of the signal each.
    let s = cam.sigma_px;
    let r = (5.0 * s).ceil() as i64;
    let xs = path.iter().map(|p| p.0);
    let ys = path.iter().map(|p| p.1);
    let (xmin, xmax) = (
        xs.clone().fold(f64::INFINITY, f64::min),
        xs.fold(f64::NEG_INFINITY, f64::max),
    );
    let (ymin, ymax) = (
        ys.clone().fold(f64::INFINITY, f64::min),
        ys.fold(f64::NEG_INFINITY, f64::max),
    );
    let (x0, x1) = (
        (xmin.round() as i64 - r).max(0),
        (xmax.round() as i64 + r).min(w as i64 - 1),
    );
    let (y0, y1) = (
        (ymin.round() as i64 - r).max(0),
        (ymax.round() as i64 + r).min(h as i64 - 1),
    );
    if x0 > x1 || y0 > y1 {
        return None;
    }
    let total_e = weight * cam.peak_dn * 2.0 * std::f64::consts::PI * s * s / gain;
    let k = 1.0 / (s * std::f64::consts::SQRT_2);
    let frac = |c: i64, mu: f64| {
        0.5 * (libm::erf((c as f64 + 0.5 - mu) * k) - libm::erf((c as f64 - 0.5 - mu) * k))
    };
    let (nx, ny) = ((x1 - x0 + 1) as usize, (y1 - y0 + 1) as usize);
    let mut signal = vec![0.0; nx * ny];
    for &(x, y) in path {
        let fx: Vec<f64> = (x0..=x1).map(|c| frac(c, x)).collect();
        let fy: Vec<f64> = (y0..=y1).map(|c| frac(c, y)).collect();
        for (j, fyj) in fy.iter().enumerate() {
            for (i, fxi) in fx.iter().enumerate() {
                signal[j * nx + i] += total_e * fxi * fyj;
            }
        }
    }
    Some(Window {
        x0,
        x1,
        y0,
        y1,
        nx,
        signal,
    })
}

/// An IR frame in °C: ambient, a hot Gaussian region per ROI peaking at its node's surface
/// temperature, a distractor outside the ROIs, noise.
pub(super) fn render_ir(
    rig: &Rig,
    sc: &Scenario,
    ambient: f64,
    roi_c: &[(usize, f64)],
    rng: &mut StdRng,
) -> Vec<f64> {
    let th = rig.thermal.as_ref().expect("checked");
    let (w, h) = (th.size_px[0] as usize, th.size_px[1] as usize);
    let mut img = vec![ambient; w * h];
    // A pixel adds to the image only where its Gaussian exceeds 1e-4; beyond `reach` (in
    // standard deviations, with a margin) along either axis alone it cannot, so the loops skip
    // what would not change a bit.
    let reach = (2.0 * (1e4_f64.ln() + 1.0)).sqrt();
    let span = |c: f64, s: f64, n: usize| {
        let lo = (c - reach * s).floor().max(0.0) as usize;
        let hi = ((c + reach * s).ceil().max(-1.0) + 1.0).min(n as f64) as usize;
        lo..hi.max(lo)
    };
    let blob = |cx: f64, cy: f64, sx: f64, sy: f64, peak: f64, img: &mut Vec<f64>| {
        for yy in span(cy, sy, h) {
            let dy = (yy as f64 - cy) / sy;
            for xx in span(cx, sx, w) {
                let dx = (xx as f64 - cx) / sx;
                let g = (-(dx * dx + dy * dy) / 2.0).exp();
                if g > 1e-4 {
                    let v = ambient + (peak - ambient) * g;
                    let p = &mut img[yy * w + xx];
                    if v > *p {
                        *p = v;
                    }
                }
            }
        }
    };
    for &(ri, t) in roi_c {
        let [x0, y0, x1, y1] = th.roi[ri].rect_px;
        let (cx, cy) = ((x0 + x1) as f64 / 2.0 - 0.5, (y0 + y1) as f64 / 2.0 - 0.5);
        blob(
            cx,
            cy,
            (x1 - x0) as f64 / 6.0,
            (y1 - y0) as f64 / 6.0,
            t,
            &mut img,
        );
    }
    if sc.ir.distractor_c > 0.0 {
        // The first 4×4 block, scanning from the top right, that touches no ROI.
        let clear = |x: i64, y: i64| {
            th.roi.iter().all(|r| {
                let [x0, y0, x1, y1] = r.rect_px;
                x + 6 < x0 || x - 6 >= x1 || y + 6 < y0 || y - 6 >= y1
            })
        };
        let spot = (0..h as i64)
            .flat_map(|y| (0..w as i64).rev().map(move |x| (x, y)))
            .find(|&(x, y)| {
                x >= 6 && y >= 6 && x + 6 < w as i64 && y + 6 < h as i64 && clear(x, y)
            });
        if let Some((x, y)) = spot {
            blob(x as f64, y as f64, 1.5, 1.5, sc.ir.distractor_c, &mut img);
        }
    }
    if sc.ir.noise_c > 0.0 {
        for v in img.iter_mut() {
            let z: f64 = StandardNormal.sample(rng);
            *v += sc.ir.noise_c * z;
        }
    }
    img
}

#[cfg(test)]
mod tests {
    /// The cast route of `render_ccd`'s `put` is `round` then `clamp`, bit for bit, on the
    /// values around every integer and half, far out of range, and not numbers.
    use super::round_clamped;

    #[test]
    fn the_fast_rounding_is_round_then_clamp() {
        for max in [255.0_f64, 65535.0] {
            let mut xs = vec![
                f64::NAN,
                f64::INFINITY,
                f64::NEG_INFINITY,
                -1e300,
                1e300,
                -0.0,
            ];
            for k in -3..=(max as i64 + 3) {
                let h = k as f64 + 0.5;
                for x in [k as f64, h] {
                    xs.extend([x, x.next_up(), x.next_down()]);
                }
            }
            for dn in xs {
                let want = dn.round().clamp(0.0, max) as u32;
                let got = round_clamped(dn, max);
                assert_eq!(got, want, "dn {dn:e} max {max}");
            }
        }
    }

    /// The IR blob's pixels outside its span cannot pass the 1e-4 test.
    #[test]
    fn pixels_beyond_the_reach_are_below_the_threshold() {
        let reach = (2.0 * (1e4_f64.ln() + 1.0)).sqrt();
        for s in [0.5, 1.5, 7.3] {
            let d = reach * s;
            let g = (-(d / s) * (d / s) / 2.0).exp();
            assert!(g < 1e-4, "s {s}: {g}");
        }
    }
}
