//! Thermal (IR) frames: each ROI's maximum temperature and where it is (SPEC §2, §3).
//!
//! Integer frames (`16UC1`/`mono16`) carry raw counts: °C = raw × `scale` + `offset_c` (the
//! rig's radiometric scale; e.g. centi-kelvin with scale 0.01, offset −273.15). `32FC1` frames
//! are already °C. Either byte order. A ROI `[x0, y0, x1, y1]` covers columns x0..x1−1 and rows
//! y0..y1−1; its temperature is its maximum (the paper's "maximum temperature of each link").
//!
//! The maximum of noisy pixels reads high, and by an amount that depends on the shape of the
//! hot region: while a link's hot region is still flat many pixels compete for the maximum
//! (0.05 K of pixel noise: +0.11 K at a 0.3 K rise, +0.03 K at 10 K, measured on Gaussian hot
//! regions of the paper rig's ROI sizes). That compresses the measured temperature rise and
//! biases a fitted α high by 1–2 %. Each ROI therefore also gets a de-noised **peak**: the
//! vertex value of a least-squares quadratic surface over the 7×7 pixels around the maximum of
//! the 3×3-mean image (same frames: +0.008 K at a 0.3 K rise, +0.003 K at 1–2 K, −0.002 K at
//! 3.5 K; scatter 0.013 K against 0.02–0.035 K for the maximum; a 5×5 window reads +0.027 K
//! at 0.3 K, a 9×9 one curves low by 0.2 % of the rise on these regions). Where the surface has
//! no maximum inside the window (a flat ROI) the peak is the fitted level at its centre; ROIs
//! smaller than 7×7, or windows with non-finite pixels, fall back to the maximum.

/// Pixel format of a thermal frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ThermalFormat {
    /// 16-bit unsigned counts.
    U16,
    /// 32-bit float, °C.
    F32,
}

impl ThermalFormat {
    /// From a ROS image encoding; `None` for encodings thermal frames cannot have.
    pub fn from_encoding(encoding: &str) -> Option<ThermalFormat> {
        match encoding {
            "16UC1" | "mono16" => Some(ThermalFormat::U16),
            "32FC1" => Some(ThermalFormat::F32),
            _ => None,
        }
    }

    pub fn bytes_per_px(self) -> usize {
        match self {
            ThermalFormat::U16 => 2,
            ThermalFormat::F32 => 4,
        }
    }
}

/// A borrowed thermal frame.
#[derive(Debug, Clone, Copy)]
pub struct ThermalView<'a> {
    pub data: &'a [u8],
    pub width: usize,
    pub height: usize,
    /// Bytes per row (≥ width × bytes per pixel).
    pub step: usize,
    pub format: ThermalFormat,
    pub big_endian: bool,
}

impl<'a> ThermalView<'a> {
    /// Check the buffer holds `height` rows of `step` bytes (the last row may stop at the pixels).
    pub fn new(
        data: &'a [u8],
        width: usize,
        height: usize,
        step: usize,
        format: ThermalFormat,
        big_endian: bool,
    ) -> Result<ThermalView<'a>, String> {
        let row = width * format.bytes_per_px();
        if step < row {
            return Err(format!(
                "step {step} is less than width × {} bytes = {row}",
                format.bytes_per_px()
            ));
        }
        let need = if height == 0 {
            0
        } else {
            step * (height - 1) + row
        };
        if data.len() < need {
            return Err(format!(
                "data has {} bytes, {width}x{height} needs {need}",
                data.len()
            ));
        }
        Ok(ThermalView {
            data,
            width,
            height,
            step,
            format,
            big_endian,
        })
    }

    /// Append the raw values of pixels `x0..x1` of `row` to `out` (as [`Self::raw`]), the
    /// format chosen once for the row rather than per pixel.
    fn decode_into(&self, row: &[u8], x0: usize, x1: usize, out: &mut Vec<f64>) {
        let n = self.format.bytes_per_px();
        let bytes = &row[x0 * n..x1 * n];
        match (self.format, self.big_endian) {
            (ThermalFormat::U16, false) => out.extend(
                bytes
                    .chunks_exact(2)
                    .map(|b| f64::from(u16::from_le_bytes([b[0], b[1]]))),
            ),
            (ThermalFormat::U16, true) => out.extend(
                bytes
                    .chunks_exact(2)
                    .map(|b| f64::from(u16::from_be_bytes([b[0], b[1]]))),
            ),
            (ThermalFormat::F32, false) => out.extend(
                bytes
                    .chunks_exact(4)
                    .map(|b| f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]]))),
            ),
            (ThermalFormat::F32, true) => out.extend(
                bytes
                    .chunks_exact(4)
                    .map(|b| f64::from(f32::from_be_bytes([b[0], b[1], b[2], b[3]]))),
            ),
        }
    }

    /// The raw value of pixel (x, y) as f64 (counts for U16, °C for F32).
    #[inline]
    fn raw(&self, row: &[u8], x: usize) -> f64 {
        match self.format {
            ThermalFormat::U16 => {
                let b = [row[2 * x], row[2 * x + 1]];
                f64::from(if self.big_endian {
                    u16::from_be_bytes(b)
                } else {
                    u16::from_le_bytes(b)
                })
            }
            ThermalFormat::F32 => {
                let b = [row[4 * x], row[4 * x + 1], row[4 * x + 2], row[4 * x + 3]];
                f64::from(if self.big_endian {
                    f32::from_be_bytes(b)
                } else {
                    f32::from_le_bytes(b)
                })
            }
        }
    }
}

/// One ROI's maximum: temperature (°C) and the pixel it is at (first in row-major order), and
/// the de-noised peak (°C, see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoiMax {
    pub max_c: f64,
    pub x_px: u32,
    pub y_px: u32,
    pub peak_c: f64,
}

/// Half-width of the window the peak's quadratic surface is fitted over (7×7 pixels).
const PEAK_R: usize = 3;
const PEAK_N: usize = 2 * PEAK_R + 1;

/// Least-squares quadratic z = b0 + b1·dx + b2·dy + b3·dx² + b4·dy² + b5·dx·dy over the
/// `PEAK_N`×`PEAK_N` grid dx, dy ∈ −R..=R (row-major values): its value at the vertex, or `b0`
/// where the surface has no maximum within the window. The grid is symmetric, so the normal
/// equations separate into closed forms.
fn quadratic_peak(z: &[f64; PEAK_N * PEAK_N]) -> f64 {
    let r = PEAK_R as f64;
    let (mut s0, mut sx, mut sy, mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for (k, &v) in z.iter().enumerate() {
        let dx = (k % PEAK_N) as f64 - r;
        let dy = (k / PEAK_N) as f64 - r;
        s0 += v;
        sx += v * dx;
        sy += v * dy;
        sxx += v * dx * dx;
        syy += v * dy * dy;
        sxy += v * dx * dy;
    }
    // One axis: S2 = Σd², S4 = Σd⁴. Over the grid: Σ1 = n², Σdx² = n·S2, Σdx⁴ = n·S4,
    // Σdx²dy² = S2²; odd sums vanish.
    let n = PEAK_N as f64;
    let s2: f64 = (-(PEAK_R as i64)..=PEAK_R as i64)
        .map(|d| (d * d) as f64)
        .sum();
    let s4: f64 = (-(PEAK_R as i64)..=PEAK_R as i64)
        .map(|d| (d * d * d * d) as f64)
        .sum();
    let b1 = sx / (n * s2);
    let b2 = sy / (n * s2);
    let b5 = sxy / (s2 * s2);
    // b0, b3, b4 from  n²·b0 + n·S2·(b3 + b4) = s0,  n·S2·b0 + n·S4·b3 + S2²·b4 = sxx  and its
    // mirror for syy: the difference gives b3 − b4, the sum a 2×2 system in b0 and b3 + b4.
    let (a, b, c, d) = (n * n, n * s2, n * s4, s2 * s2);
    let det2 = a * (c + d) - 2.0 * b * b;
    let p = sxx + syy;
    let b0 = (s0 * (c + d) - b * p) / det2;
    let m = (a * p - 2.0 * b * s0) / det2;
    let half_diff = (sxx - syy) / (c - d) / 2.0;
    let b3 = m / 2.0 + half_diff;
    let b4 = m / 2.0 - half_diff;
    // Vertex: [[2 b3, b5], [b5, 2 b4]] · v = −[b1, b2]; a maximum needs a negative-definite
    // Hessian.
    let det = 4.0 * b3 * b4 - b5 * b5;
    if !(b3 < 0.0 && det > 0.0) {
        return b0;
    }
    let vx = (-b1 * 2.0 * b4 + b2 * b5) / det;
    let vy = (-b2 * 2.0 * b3 + b1 * b5) / det;
    if vx.abs() > r || vy.abs() > r {
        return b0;
    }
    b0 + 0.5 * (b1 * vx + b2 * vy)
}

/// Maximum of each ROI in °C. `scale`/`offset_c` apply to U16 frames only. NaN pixels of float
/// frames are ignored; a ROI with no finite pixel gives NaN. ROIs are clipped to the frame.
pub fn roi_maxima(
    view: &ThermalView<'_>,
    rois: &[[i64; 4]],
    scale: f64,
    offset_c: f64,
) -> Vec<RoiMax> {
    let to_c = |raw: f64| match view.format {
        ThermalFormat::U16 => raw * scale + offset_c,
        ThermalFormat::F32 => raw,
    };
    let px = |x: usize, y: usize| view.raw(&view.data[y * view.step..], x);
    rois.iter()
        .map(|&[x0, y0, x1, y1]| {
            let cx = |v: i64, hi: usize| v.clamp(0, hi as i64) as usize;
            let (x0, x1) = (cx(x0, view.width), cx(x1, view.width));
            let (y0, y1) = (cx(y0, view.height), cx(y1, view.height));
            let mut best = RoiMax {
                max_c: f64::NAN,
                x_px: 0,
                y_px: 0,
                peak_c: f64::NAN,
            };
            // The ROI's raw values once, row-major (one decode per pixel, not nine).
            let (w, h) = (x1.saturating_sub(x0), y1.saturating_sub(y0));
            let mut vals = Vec::with_capacity(w * h);
            for y in y0..y1 {
                view.decode_into(&view.data[y * view.step..], x0, x1, &mut vals);
            }
            let mut best_raw = f64::NEG_INFINITY;
            for (k, &v) in vals.iter().enumerate() {
                if v > best_raw {
                    best_raw = v;
                    best.x_px = (x0 + k % w) as u32;
                    best.y_px = (y0 + k / w) as u32;
                }
            }
            if !best_raw.is_finite() {
                return best;
            }
            best.max_c = to_c(best_raw);
            best.peak_c = best.max_c;
            if w < PEAK_N || h < PEAK_N {
                return best;
            }
            // The maximum of the 3×3 sum over centres whose 7×7 window lies in the ROI, as
            // sums of three row sums. The values are u16 counts or f32 readings held in f64,
            // where nine-term sums are exact (f32 values within 2^29 of each other), so the
            // order of the additions does not change which centre wins.
            let mut rows3: Vec<f64> = Vec::with_capacity(h * (w - 2));
            for v in vals.chunks_exact(w) {
                rows3.extend(v.windows(3).map(|t| t[0] + t[1] + t[2]));
            }
            let w3 = w - 2;
            let mut centre = None;
            let mut best_sum = f64::NEG_INFINITY;
            for r in PEAK_R..h - PEAK_R {
                for c in PEAK_R..w - PEAK_R {
                    let i = c - 1;
                    let s = rows3[(r - 1) * w3 + i] + rows3[r * w3 + i] + rows3[(r + 1) * w3 + i];
                    if s > best_sum {
                        best_sum = s;
                        centre = Some((x0 + c, y0 + r));
                    }
                }
            }
            if let Some((x, y)) = centre {
                let mut z = [0.0; PEAK_N * PEAK_N];
                for (k, v) in z.iter_mut().enumerate() {
                    *v = px(x + k % PEAK_N - PEAK_R, y + k / PEAK_N - PEAK_R);
                }
                if z.iter().all(|v| v.is_finite()) {
                    best.peak_c = to_c(quadratic_peak(&z));
                }
            }
            best
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn u16_frame(
        w: usize,
        h: usize,
        step: usize,
        big: bool,
        f: impl Fn(usize, usize) -> u16,
    ) -> Vec<u8> {
        let mut d = vec![0xAB; step * h];
        for y in 0..h {
            for x in 0..w {
                let b = if big {
                    f(x, y).to_be_bytes()
                } else {
                    f(x, y).to_le_bytes()
                };
                d[y * step + 2 * x..y * step + 2 * x + 2].copy_from_slice(&b);
            }
        }
        d
    }

    #[test]
    fn centikelvin_maxima_and_locations() {
        // Background 22 °C, a 31.5 °C pixel at (7, 3) inside ROI 0, a hotter one outside all ROIs.
        let ck = |c: f64| ((c + 273.15) * 100.0).round() as u16;
        for big in [false, true] {
            let d = u16_frame(12, 8, 30, big, |x, y| match (x, y) {
                (7, 3) => ck(31.5),
                (11, 7) => ck(60.0),
                (1, 1) => ck(25.0),
                _ => ck(22.0),
            });
            let v = ThermalView::new(&d, 12, 8, 30, ThermalFormat::U16, big).unwrap();
            let m = roi_maxima(
                &v,
                &[[4, 2, 9, 5], [0, 0, 3, 3], [0, 5, 4, 8]],
                0.01,
                -273.15,
            );
            assert!((m[0].max_c - 31.5).abs() < 1e-9 && (m[0].x_px, m[0].y_px) == (7, 3));
            assert!((m[1].max_c - 25.0).abs() < 1e-9 && (m[1].x_px, m[1].y_px) == (1, 1));
            assert!((m[2].max_c - 22.0).abs() < 1e-9);
        }
    }

    #[test]
    fn float_frames_are_celsius_and_skip_nan() {
        let (w, h) = (4, 3);
        let vals = [
            20.0f32,
            f32::NAN,
            21.0,
            20.0,
            20.5,
            23.25,
            20.0,
            20.0,
            20.0,
            20.0,
            20.0,
            19.0,
        ];
        for big in [false, true] {
            let d: Vec<u8> = vals
                .iter()
                .flat_map(|v| {
                    if big {
                        v.to_be_bytes()
                    } else {
                        v.to_le_bytes()
                    }
                })
                .collect();
            let v = ThermalView::new(&d, w, h, 16, ThermalFormat::F32, big).unwrap();
            let m = roi_maxima(&v, &[[0, 0, 4, 3], [1, 0, 2, 1]], 1.0, 0.0);
            assert_eq!((m[0].max_c, m[0].x_px, m[0].y_px), (23.25, 1, 1));
            assert!(m[1].max_c.is_nan());
        }
    }

    fn f32_frame(w: usize, h: usize, f: impl Fn(usize, usize) -> f64) -> Vec<u8> {
        (0..w * h)
            .flat_map(|k| (f(k % w, k / w) as f32).to_le_bytes())
            .collect()
    }

    #[test]
    fn peak_is_exact_on_a_quadratic_surface() {
        // z = 30 − 0.2 (x − 10.3)² − 0.1 (y − 7.6)² + 0.05 (x − 10.3)(y − 7.6): vertex 30.
        let f = |x: usize, y: usize| {
            let (dx, dy) = (x as f64 - 10.3, y as f64 - 7.6);
            30.0 - 0.2 * dx * dx - 0.1 * dy * dy + 0.05 * dx * dy
        };
        let d = f32_frame(20, 16, f);
        let v = ThermalView::new(&d, 20, 16, 80, ThermalFormat::F32, false).unwrap();
        let m = roi_maxima(&v, &[[0, 0, 20, 16]], 1.0, 0.0)[0];
        assert!((m.peak_c - 30.0).abs() < 1e-4, "{m:?}");
        assert!(m.max_c < 30.0 && (m.x_px, m.y_px) == (10, 8));
        // A flat ROI: the level itself; a ROI smaller than 7×7: the maximum.
        let d = f32_frame(8, 8, |_, _| 21.5);
        let v = ThermalView::new(&d, 8, 8, 32, ThermalFormat::F32, false).unwrap();
        let m = roi_maxima(&v, &[[0, 0, 8, 8], [0, 0, 6, 8]], 1.0, 0.0);
        assert!((m[0].peak_c - 21.5).abs() < 1e-6 && m[1].peak_c == m[1].max_c);
    }

    #[test]
    fn peak_removes_most_of_the_noisy_maximum_bias() {
        // A Gaussian hot region (the paper rig's link-2 ROI, 80×50, σ = size/6) 0.3 K and 3 K
        // above 23 °C, 0.05 K pixel noise: the mean excess of the maximum and of the peak.
        use rand::{rngs::StdRng, SeedableRng};
        use rand_distr::{Distribution, StandardNormal};
        let mut rng = StdRng::seed_from_u64(7);
        let (w, h) = (80usize, 50usize);
        for (rise, max_lo, peak_hi) in [(0.3, 0.08, 0.015), (3.0, 0.04, 0.006)] {
            let (mut emax, mut epeak) = (0.0, 0.0);
            let n = 300;
            for _ in 0..n {
                let noise: Vec<f64> = (0..w * h)
                    .map(|_| StandardNormal.sample(&mut rng))
                    .collect();
                let d = f32_frame(w, h, |x, y| {
                    let dx = (x as f64 - 39.8) / (w as f64 / 6.0);
                    let dy = (y as f64 - 24.3) / (h as f64 / 6.0);
                    23.0 + rise * (-(dx * dx + dy * dy) / 2.0).exp() + 0.05 * noise[y * w + x]
                });
                let v = ThermalView::new(&d, w, h, 4 * w, ThermalFormat::F32, false).unwrap();
                let m = roi_maxima(&v, &[[0, 0, w as i64, h as i64]], 1.0, 0.0)[0];
                emax += (m.max_c - 23.0 - rise) / n as f64;
                epeak += (m.peak_c - 23.0 - rise) / n as f64;
            }
            assert!(emax > max_lo, "rise {rise}: max excess {emax}");
            assert!(epeak.abs() < peak_hi, "rise {rise}: peak excess {epeak}");
        }
    }

    #[test]
    fn short_buffers_are_rejected() {
        assert!(ThermalView::new(&[0; 10], 4, 2, 8, ThermalFormat::U16, false).is_err());
        assert!(ThermalView::new(&[0; 16], 4, 2, 6, ThermalFormat::U16, false).is_err());
        assert!(ThermalView::new(&[0; 16], 4, 2, 8, ThermalFormat::U16, false).is_ok());
    }
}
