//! Rendering: a CCD frame (a pixel-integrated Gaussian spot along its path during the exposure,
//! shot and read noise) and an IR frame (°C: ambient, a hot region per ROI, a distractor,
//! noise). Each draws from its own random stream, in a fixed order.

use rand::rngs::StdRng;
use rand::Rng;
use rand_distr::{Distribution, Normal, Poisson, StandardNormal};
use rand_xoshiro::Xoshiro256PlusPlus;

use crate::rig::Rig;
use crate::scenario::Scenario;

/// The distribution of a CCD frame's background pixels (`bpp` bytes each): the background's
/// Poisson noise as its Gaussian equivalent (mean ≥ 16 e⁻ by default) plus read noise,
/// rounded and clipped (see [`RoundedNormal`]). It depends only on the camera model, so a
/// simulation builds it once.
pub(super) fn ccd_background(cam: &crate::scenario::CameraModel, bpp: usize) -> RoundedNormal {
    let gain = cam.dn_per_electron;
    let bg_e = cam.background_dn / gain;
    let read_e = cam.read_noise_dn / gain;
    let max = if bpp == 1 { 255.0 } else { 65535.0 };
    RoundedNormal::new(
        cam.background_dn,
        (bg_e + read_e * read_e).sqrt() * gain,
        max,
    )
}

/// A CCD frame's pixels: spot at (x, y) px plus noise, written into `out` (row-major, `bpp`
/// bytes per pixel little-endian). `bg` is [`ccd_background`] of the camera model.
#[allow(clippy::too_many_arguments)]
pub(super) fn render_ccd(
    out: &mut [u8],
    w: usize,
    h: usize,
    bpp: usize,
    path: &[(f64, f64)],
    weight: f64,
    cam: &crate::scenario::CameraModel,
    bg: &RoundedNormal,
    rng: &mut Xoshiro256PlusPlus,
) {
    let gain = cam.dn_per_electron;
    let bg_e = cam.background_dn / gain;
    let read_e = cam.read_noise_dn / gain;
    let max = if bpp == 1 { 255.0 } else { 65535.0 };
    let put = |out: &mut [u8], i: usize, dn: f64| {
        let v = round_clamped(dn, max);
        if bpp == 1 {
            out[i] = v as u8;
        } else {
            out[2 * i..2 * i + 2].copy_from_slice(&(v as u16).to_le_bytes());
        }
    };
    // The background: each pixel's rounded, clipped value drawn at once from its exact
    // distribution (one 32-bit uniform a pixel, two from each 64-bit draw), not as a Gaussian
    // draw then rounded.
    let mut two = || {
        let u = rng.next_u64();
        (bg.draw(u as u32), bg.draw((u >> 32) as u32))
    };
    if bpp == 1 {
        let mut px = out[..w * h].chunks_exact_mut(2);
        for p in &mut px {
            let (a, b) = two();
            p[0] = a as u8;
            p[1] = b as u8;
        }
        if let [last] = px.into_remainder() {
            *last = two().0 as u8;
        }
    } else {
        let mut px = out[..2 * w * h].chunks_exact_mut(4);
        for p in &mut px {
            let (a, b) = two();
            p[..2].copy_from_slice(&(a as u16).to_le_bytes());
            p[2..].copy_from_slice(&(b as u16).to_le_bytes());
        }
        let rest = px.into_remainder();
        if !rest.is_empty() {
            rest.copy_from_slice(&(two().0 as u16).to_le_bytes());
        }
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

/// `round_clamped(mean + sd·z, max)` for a standard normal `z`, as a discrete distribution drawn
/// by inversion from one 32-bit uniform `u` (a guide table over `u`'s top 8 bits, then a
/// short search: Chen & Asau's method). `P(value ≤ k) = Φ((k + ½ − mean) / sd)` below `max`
/// (rounding half away from zero; everything under ½ clips to 0, everything from `max − ½` to
/// `max`), each cumulative probability rounded to a multiple of 2⁻³², so a value is drawn with
/// its exact probability to within 2⁻³² (values beyond ±8 sd, rarer than 10⁻¹⁵, never).
pub(crate) struct RoundedNormal {
    /// The least value drawn.
    lo: u32,
    /// `upper[k]`: `P(value ≤ lo + k)·2³²`, rounded; the last is 2³².
    upper: Vec<u64>,
    /// `guide[g]`: the least `k` with `upper[k] > g·2²⁴`.
    guide: [u32; 256],
    /// `fast[g]`: the `k` every `u` with `u >> 20 == g` gives, where they all give one
    /// (`u16::MAX` where a threshold falls inside that range: then the search decides); 8 kB,
    /// so that it stays in the first-level cache.
    fast: Vec<u16>,
}

impl RoundedNormal {
    pub(crate) fn new(mean: f64, sd: f64, max: f64) -> RoundedNormal {
        let scale = 4_294_967_296.0_f64; // 2³²
        if !(sd > 0.0 && sd.is_finite() && mean.is_finite()) {
            let v = round_clamped(mean, max);
            return RoundedNormal {
                lo: v,
                upper: vec![1 << 32],
                guide: [0; 256],
                fast: vec![0; 1 << 12],
            };
        }
        let lo = round_clamped(mean - 8.0 * sd, max);
        let hi = round_clamped(mean + 8.0 * sd, max);
        let phi = |x: f64| 0.5 * libm::erfc(-x / std::f64::consts::SQRT_2);
        let mut upper: Vec<u64> = (lo..hi)
            .map(|k| {
                (phi((f64::from(k) + 0.5 - mean) / sd) * scale)
                    .round()
                    .min(scale) as u64
            })
            .collect();
        upper.push(1 << 32);
        let mut guide = [0u32; 256];
        let mut k = 0usize;
        for (g, slot) in guide.iter_mut().enumerate() {
            while upper[k] <= (g as u64) << 24 {
                k += 1;
            }
            *slot = k as u32;
        }
        let mut t = RoundedNormal {
            lo,
            upper,
            guide,
            fast: Vec::new(),
        };
        t.fast = (0..1u32 << 12)
            .map(|g| {
                let (a, b) = (t.search(g << 20), t.search((g << 20) | 0xF_FFFF));
                if a == b && a - lo < u32::from(u16::MAX) {
                    (a - lo) as u16
                } else {
                    u16::MAX
                }
            })
            .collect();
        t
    }

    /// The value for the uniform `u`: one look-up, or the search where the look-up's range
    /// holds a threshold (a few ranges in a hundred).
    #[inline]
    pub(crate) fn draw(&self, u: u32) -> u32 {
        let f = self.fast[(u >> 20) as usize];
        if f != u16::MAX {
            return self.lo + u32::from(f);
        }
        self.search(u)
    }

    /// The value for the uniform `u`, by the guide table and a short search.
    #[inline]
    fn search(&self, u: u32) -> u32 {
        let u = u64::from(u);
        let mut k = self.guide[(u >> 24) as usize] as usize;
        while self.upper[k] <= u {
            k += 1;
        }
        self.lo + k as u32
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

    /// The background sampler's values have the closed-form probabilities of a rounded,
    /// clipped Gaussian, to within 2⁻³² each, and inversion is monotone.
    #[test]
    fn the_rounded_background_has_the_normal_probabilities() {
        use super::RoundedNormal;
        let phi = |x: f64| 0.5 * libm::erfc(-x / std::f64::consts::SQRT_2);
        for &(mean, sd, max) in &[
            (10.0, 4.1, 255.0),
            (2.0, 3.0, 255.0),
            (250.3, 2.2, 255.0),
            (1000.0, 33.0, 65535.0),
            (0.7, 0.35, 255.0),
        ] {
            let t = RoundedNormal::new(mean, sd, max);
            // P(value = k) from the cumulative thresholds, against the closed form.
            let mut prev = 0u64;
            let mut total = 0.0;
            for (k, &u) in t.upper.iter().enumerate() {
                let v = f64::from(t.lo) + k as f64;
                let hi = if v >= max {
                    1.0
                } else {
                    phi((v + 0.5 - mean) / sd)
                };
                let lo = if v <= 0.0 {
                    0.0
                } else {
                    phi((v - 0.5 - mean) / sd)
                };
                let got = (u - prev) as f64 / 4_294_967_296.0;
                assert!(
                    (got - (hi - lo)).abs() <= 2.0 / 4_294_967_296.0,
                    "{mean} {sd} {v}"
                );
                total += hi - lo;
                // Inversion: the uniforms just below and at a threshold fall either side.
                if u > prev {
                    assert_eq!(t.draw((u - 1) as u32), t.lo + k as u32);
                }
                if u < 1 << 32 {
                    assert!(t.draw(u as u32) > t.lo + k as u32);
                }
                prev = u;
            }
            assert!(
                (total - 1.0).abs() < 1e-12,
                "{mean} {sd}: the support holds {total}"
            );
            // The extreme uniforms give the extreme values of non-zero probability.
            let least = t.upper.iter().position(|&u| u > 0).expect("reaches 2³²");
            assert_eq!(t.draw(0), t.lo + least as u32);
            let top = t
                .upper
                .iter()
                .position(|&u| u == 1 << 32)
                .expect("ends at 2³²");
            assert_eq!(t.draw(u32::MAX), t.lo + top as u32);
        }
        // The look-up gives what the search gives, over the whole range of uniforms.
        let t = RoundedNormal::new(10.0, 4.1, 255.0);
        for u in (0..=u32::MAX).step_by(65_521) {
            for v in [u, u.wrapping_add(1), u | 0xF_FFFF, u & !0xF_FFFF] {
                assert_eq!(t.draw(v), t.search(v), "u {v}");
            }
        }
        // No spread: the rounded mean.
        assert_eq!(RoundedNormal::new(7.6, 0.0, 255.0).draw(12345), 8);
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
