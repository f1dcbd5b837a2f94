//! Tests against known truth: simulated pixel-integrated Gaussian spots (erf
//! differences per pixel via `libm`, Poisson shot noise on signal and background
//! electrons, Gaussian read noise, gain, rounding, clipping), the independent sample
//! frames of `kr15-sample.mcap` (when decoded to raw files), robustness cases and an
//! ignored benchmark.
use super::crlb::mortensen_integral;
use super::*;
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal, Poisson};
use std::time::Instant;

/// Camera model: gain (DN/e⁻), background (DN), read noise (DN), bit depth.
#[derive(Clone, Copy, Debug)]
struct Cam {
    gain: f64,
    bg_dn: f64,
    read_dn: f64,
    bits: u32,
}

const CAM8: Cam = Cam {
    gain: 0.5,
    bg_dn: 8.0,
    read_dn: 1.5,
    bits: 8,
};
const PEAK8: f64 = 170.0;
const CAM16: Cam = Cam {
    gain: 8.0,
    bg_dn: 100.0,
    read_dn: 12.0,
    bits: 16,
};
const PEAK16: f64 = 16000.0;

/// A Gaussian light source: centre, σ (px), peak of the continuous Gaussian (DN).
#[derive(Clone, Copy, Debug)]
struct Src {
    x: f64,
    y: f64,
    sigma: f64,
    peak_dn: f64,
}

/// Fraction of a unit-integral 1-D Gaussian (centre c, σ s) falling in each pixel
/// `[i − ½, i + ½]`, accurate in the tails (erfc on the far side).
fn pixel_fractions(n: usize, c: f64, s: f64) -> Vec<f64> {
    let k = 1.0 / (s * std::f64::consts::SQRT_2);
    (0..n)
        .map(|i| {
            let a = (i as f64 - 0.5 - c) * k;
            let b = (i as f64 + 0.5 - c) * k;
            if a >= 0.0 {
                0.5 * (libm::erfc(a) - libm::erfc(b))
            } else if b <= 0.0 {
                0.5 * (libm::erfc(-b) - libm::erfc(-a))
            } else {
                0.5 * (libm::erf(b) - libm::erf(a))
            }
        })
        .collect()
}

/// Expected signal electrons per pixel of a set of sources.
fn expected_electrons(w: usize, h: usize, srcs: &[Src], cam: Cam) -> Vec<f64> {
    let mut e = vec![0.0; w * h];
    for s in srcs {
        let n_e = 2.0 * std::f64::consts::PI * s.sigma * s.sigma * s.peak_dn / cam.gain;
        let fx = pixel_fractions(w, s.x, s.sigma);
        let fy = pixel_fractions(h, s.y, s.sigma);
        for (j, &fyj) in fy.iter().enumerate() {
            if fyj < 1e-12 {
                continue;
            }
            for (i, &fxi) in fx.iter().enumerate() {
                e[j * w + i] += n_e * fyj * fxi;
            }
        }
    }
    e
}

/// Noisy frame in DN (before packing): Poisson(signal + background electrons),
/// Gaussian read noise, gain, rounding, clipping.
fn noisy_dn(expected: &[f64], cam: Cam, rng: &mut StdRng) -> Vec<u16> {
    let bg_e = cam.bg_dn / cam.gain;
    let read = Normal::new(0.0, cam.read_dn / cam.gain).unwrap();
    let max = ((1u32 << cam.bits) - 1) as f64;
    let bg_pois = Poisson::new(bg_e).unwrap();
    expected
        .iter()
        .map(|&s| {
            let lam = s + bg_e;
            let ne: f64 = if s < 1e-9 {
                bg_pois.sample(rng)
            } else {
                Poisson::new(lam).unwrap().sample(rng)
            };
            let dn = ((ne + read.sample(rng)) * cam.gain).round();
            dn.clamp(0.0, max) as u16
        })
        .collect()
}

fn pack(dn: &[u16], bits: u32, big_endian: bool) -> Vec<u8> {
    if bits == 8 {
        dn.iter().map(|&v| v as u8).collect()
    } else {
        dn.iter()
            .flat_map(|&v| {
                if big_endian {
                    v.to_be_bytes()
                } else {
                    v.to_le_bytes()
                }
            })
            .collect()
    }
}

fn render(w: usize, h: usize, srcs: &[Src], cam: Cam, rng: &mut StdRng) -> Vec<u8> {
    pack(
        &noisy_dn(&expected_electrons(w, h, srcs, cam), cam, rng),
        cam.bits,
        false,
    )
}

fn view(data: &[u8], w: usize, h: usize, bits: u32) -> FrameView<'_> {
    let bpp = if bits == 8 { 1 } else { 2 };
    FrameView::new(data, w, h, w * bpp, bpp, false).unwrap()
}

#[test]
fn cramer_rao_reference_value() {
    let c = cramer_rao_px(4.0, 170.0, 8.0, 1.5, 0.5);
    println!("CRB(σ 4, peak 170, bg 8, read 1.5, 0.5 DN/e) = {c:.5} px");
    assert!((c - 0.02726).abs() < 5e-5, "{c}");
    // Integral against the closed form τ·Li₂(−1/τ), Li₂(−x) for large x:
    // −π²/6 − ½ln²x − Li₂(−1/x), Li₂(−y) = Σ (−y)^k / k².
    let tau: f64 = 0.01;
    let x = 1.0 / tau;
    let li_small: f64 = (1..40).map(|k| (-1.0 / x).powi(k) / (k * k) as f64).sum();
    let li = -std::f64::consts::PI.powi(2) / 6.0 - 0.5 * x.ln().powi(2) - li_small;
    assert!((mortensen_integral(tau) - tau * li).abs() < 1e-9);
    // No background: the photon limit σa/√N.
    let n = 2.0 * std::f64::consts::PI * 16.0 * 170.0 / 0.5;
    let c0 = cramer_rao_px(4.0, 170.0, 0.0, 0.0, 0.5);
    assert!((c0 - ((16.0 + PIXEL_VAR) / n).sqrt()).abs() < 1e-12);
    assert!(cramer_rao_px(4.0, 0.0, 8.0, 1.5, 0.5).is_infinite());
    assert!(cramer_rao_px(4.0, 170.0, 8.0, 1.5, 0.0).is_infinite());
}

#[test]
fn frame_view_checks() {
    let d = vec![0u8; 100];
    assert!(FrameView::new(&d, 10, 10, 10, 1, false).is_ok());
    assert!(FrameView::new(&d, 10, 10, 9, 1, false).is_err());
    assert!(FrameView::new(&d, 10, 11, 10, 1, false).is_err());
    assert!(FrameView::new(&d, 5, 10, 10, 2, false).is_ok());
    assert!(FrameView::new(&d, 5, 10, 10, 3, false).is_err());
    assert!(FrameView::new(&d, 0, 0, 0, 1, false).is_ok());
    // Last row need not be padded.
    assert!(FrameView::new(&d[..94], 4, 10, 10, 1, false).is_ok());
    assert!(FrameView::new(&d, usize::MAX, 2, usize::MAX, 2, false).is_err());
    assert!(FrameView::new(&d, 2, usize::MAX, 4, 1, false).is_err());
    assert_eq!(SpotStatus::AtBorder.as_str(), "at_border");
    assert_eq!(SpotStatus::NoSpot.to_string(), "no_spot");
}

/// Accuracy against the Cramér–Rao bound: 1000 trials per setting (the standard error
/// of the mean error is RMS/√1000 ≈ 0.03 × CRB, < 0.001 px), true centres uniform over
/// ±2 px around the frame centre (all sub-pixel and scan-row phases).
#[test]
fn accuracy_vs_cramer_rao() {
    let trials = 1000usize;
    let mut rng = StdRng::seed_from_u64(20240611);
    let params = SpotParams::default();
    let mut lines = Vec::new();
    let mut failures = Vec::new();
    for (cam, peak) in [(CAM8, PEAK8), (CAM16, PEAK16)] {
        for sigma in [2.0, 4.0, 6.0, 9.0] {
            let size = ((12.0 * sigma + 40.0) as usize).max(64);
            let crb = cramer_rao_px(sigma, peak, cam.bg_dn, cam.read_dn, cam.gain);
            let (mut sx, mut sy, mut sxx, mut syy) = (0.0, 0.0, 0.0, 0.0);
            let (mut sizes, mut iters) = (0.0, 0usize);
            for _ in 0..trials {
                let x = size as f64 / 2.0 + rng.random_range(-2.0..2.0);
                let y = size as f64 / 2.0 + rng.random_range(-2.0..2.0);
                let src = Src {
                    x,
                    y,
                    sigma,
                    peak_dn: peak,
                };
                let data = render(size, size, &[src], cam, &mut rng);
                let s = find_spot(&view(&data, size, size, cam.bits), &params);
                assert_eq!(s.status, SpotStatus::Ok, "{s:?} truth {x} {y} σ {sigma}");
                let (ex, ey) = (s.x_px - x, s.y_px - y);
                sx += ex;
                sy += ey;
                sxx += ex * ex;
                syy += ey * ey;
                sizes += s.size_px;
                iters += s.iterations;
            }
            let n = trials as f64;
            let (rx, ry) = ((sxx / n).sqrt(), (syy / n).sqrt());
            let (bx, by) = (sx / n, sy / n);
            let line = format!(
                "{:>2}-bit σ {sigma:.0}: CRB {crb:.4} px  RMS/CRB x {:.3} y {:.3}  bias x {:+.4} y {:+.4} px  mean size {:.3}  passes {:.1}",
                cam.bits,
                rx / crb,
                ry / crb,
                bx,
                by,
                sizes / n,
                iters as f64 / n
            );
            if rx > 1.3 * crb || ry > 1.3 * crb || bx.abs() > 0.005 || by.abs() > 0.005 {
                failures.push(line.clone());
            }
            lines.push(line);
        }
    }
    for l in &lines {
        println!("{l}");
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// The independent sample recording: frames of `kr15-sample.mcap` decoded to raw files
/// named `{camera}_{t_ns}_{w}x{h}_{step}_{encoding}.raw` (directory from
/// `THERMRS_CENTROID_FRAMES`, default `dev-centroid/frames` in the temporary folder), truth from
/// `kr15-sample.truth.csv` (`THERMRS_SAMPLE_TRUTH`). Skipped when either is missing.
#[test]
fn sample_recording_frames() {
    let dir = std::env::var("THERMRS_CENTROID_FRAMES").unwrap_or_else(|_| {
        std::env::temp_dir()
            .join("dev-centroid")
            .join("frames")
            .to_string_lossy()
            .into_owned()
    });
    let truth_path = std::env::var("THERMRS_SAMPLE_TRUTH").unwrap_or_else(|_| {
        // The shared folder beside the repository (SPEC's `samples/`).
        concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../../shared/samples/kr15-sample.truth.csv"
        )
        .to_string()
    });
    let (Ok(entries), Ok(truth)) = (
        std::fs::read_dir(&dir),
        std::fs::read_to_string(&truth_path),
    ) else {
        println!("skipped: no decoded sample frames in {dir} or no {truth_path}");
        return;
    };
    type Row = (String, String, Option<(f64, f64)>);
    let truth: Vec<Row> = truth
        .lines()
        .skip(1)
        .filter_map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            if c.len() < 5 {
                return None;
            }
            let xy = match (c[2].parse::<f64>(), c[3].parse::<f64>()) {
                (Ok(x), Ok(y)) => Some((x, y)),
                _ => None,
            };
            Some((c[0].to_string(), c[1].to_string(), xy))
        })
        .collect();
    let mut names: Vec<String> = entries
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".raw"))
        .collect();
    names.sort();
    let limit = 4.0 * cramer_rao_px(4.0, 170.0, 8.0, 1.5, 0.5);
    let params = SpotParams::default();
    let (mut n_spot, mut n_dark) = (0, 0);
    let mut errs: Vec<[f64; 2]> = Vec::new();
    for name in &names {
        let parts: Vec<&str> = name.trim_end_matches(".raw").split('_').collect();
        let (cam, t) = (parts[0], parts[1]);
        let (w, h) = parts[2].split_once('x').unwrap();
        let (w, h): (usize, usize) = (w.parse().unwrap(), h.parse().unwrap());
        let step: usize = parts[3].parse().unwrap();
        assert_eq!(parts[4], "mono8");
        let data = std::fs::read(format!("{dir}/{name}")).unwrap();
        let frame = FrameView::new(&data, w, h, step, 1, false).unwrap();
        let s = find_spot(&frame, &params);
        let row = truth
            .iter()
            .find(|(c, tt, _)| c == cam && tt == t)
            .unwrap_or_else(|| panic!("no truth for {name}"));
        match row.2 {
            Some((x, y)) => {
                n_spot += 1;
                let (ex, ey) = (s.x_px - x, s.y_px - y);
                errs.push([ex, ey]);
                println!(
                    "{cam} {t}: {} x {:.4} y {:.4}  error x {ex:+.4} y {ey:+.4} px  size {:.3} peak {:.1} bg {:.2} noise {:.2}",
                    s.status, s.x_px, s.y_px, s.size_px, s.peak, s.background, s.noise
                );
                assert_eq!(s.status, SpotStatus::Ok, "{name}: {s:?}");
                assert!(ex.abs() < limit && ey.abs() < limit, "{name}: {s:?}");
            }
            None => {
                n_dark += 1;
                println!(
                    "{cam} {t}: {} (dark; max excess {:.1} DN)",
                    s.status, s.peak
                );
                assert_eq!(s.status, SpotStatus::NoSpot, "{name}: {s:?}");
            }
        }
    }
    let rms = |k: usize| {
        (errs.iter().map(|e| e[k] * e[k]).sum::<f64>() / errs.len().max(1) as f64).sqrt()
    };
    let mean = |k: usize| errs.iter().map(|e| e[k]).sum::<f64>() / errs.len().max(1) as f64;
    println!(
        "{n_spot} spot frames: RMS error x {:.4} y {:.4} px, mean x {:+.4} y {:+.4} px (CRB {:.4}); {n_dark} dark frames; limit {limit:.4} px per axis",
        rms(0),
        rms(1),
        mean(0),
        mean(1),
        limit / 4.0
    );
    assert!(n_spot + n_dark == names.len());
}

mod detection;
mod kernels;
