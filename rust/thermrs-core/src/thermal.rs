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

    /// The raw values of the ROI columns `x0..x1`, rows `y0..y1`, row-major, into `out`
    /// (cleared first): counts as `i32` for U16 frames, °C readings as `f64` for F32 ones
    /// (see [`Sample`]); the format is chosen once per ROI, not per pixel.
    fn decode_roi<T: Sample>(
        &self,
        (x0, x1, y0, y1): (usize, usize, usize, usize),
        out: &mut Vec<T>,
    ) {
        out.clear();
        let n = self.format.bytes_per_px();
        for y in y0..y1 {
            let row = &self.data[y * self.step..];
            T::decode(&row[x0 * n..x1 * n], self.big_endian, out);
        }
    }
}

/// A thermal pixel's raw value while its ROI is searched: `i32` for U16 counts (sums of nine
/// are exact and the loops vectorise), `f64` for F32 readings (NaN pixels are skipped, as
/// `NaN > x` is false).
trait Sample: Copy + PartialOrd + std::ops::Add<Output = Self> {
    /// Below every value a pixel can have.
    const LEAST: Self;
    /// The values of `bytes` (whole pixels of this format) appended to `out`.
    fn decode(bytes: &[u8], big_endian: bool, out: &mut Vec<Self>);
    /// The larger of `a` and `b`, `a` where `b` is NaN.
    fn larger(a: Self, b: Self) -> Self;
    /// Whether a maximum is a pixel's value rather than `LEAST` for none (every `i32` is).
    fn found(self) -> bool;
    fn to_f64(self) -> f64;
}

impl Sample for i32 {
    const LEAST: Self = i32::MIN;
    fn decode(bytes: &[u8], big_endian: bool, out: &mut Vec<i32>) {
        let px = bytes.chunks_exact(2);
        if big_endian {
            out.extend(px.map(|b| i32::from(u16::from_be_bytes([b[0], b[1]]))));
        } else {
            out.extend(px.map(|b| i32::from(u16::from_le_bytes([b[0], b[1]]))));
        }
    }
    #[inline(always)]
    fn larger(a: i32, b: i32) -> i32 {
        a.max(b)
    }
    fn found(self) -> bool {
        true
    }
    fn to_f64(self) -> f64 {
        f64::from(self)
    }
}

impl Sample for f64 {
    const LEAST: Self = f64::NEG_INFINITY;
    fn decode(bytes: &[u8], big_endian: bool, out: &mut Vec<f64>) {
        let px = bytes.chunks_exact(4);
        if big_endian {
            out.extend(px.map(|b| f64::from(f32::from_be_bytes([b[0], b[1], b[2], b[3]]))));
        } else {
            out.extend(px.map(|b| f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]]))));
        }
    }
    #[inline(always)]
    fn larger(a: f64, b: f64) -> f64 {
        if b > a {
            b
        } else {
            a
        }
    }
    fn found(self) -> bool {
        self > f64::NEG_INFINITY
    }
    fn to_f64(self) -> f64 {
        self
    }
}

/// The largest of `v` (`LEAST` for none).
#[inline]
fn largest<T: Sample>(v: impl Iterator<Item = T>) -> T {
    v.fold(T::LEAST, T::larger)
}

/// The row (of `rows`, each a row's values) holding the largest value that
/// [`Sample::found`] accepts, and the column of its first occurrence there: the first in
/// row-major order. The rows' maxima vectorise; only the winning row is searched for where.
fn first_max<T: Sample, I: Iterator<Item = T>>(
    rows: impl Iterator<Item = I>,
    row: impl Fn(usize) -> I,
) -> Option<(usize, usize)> {
    let mut best: Option<(T, usize)> = None;
    for (r, v) in rows.enumerate() {
        let m = largest(v);
        if m.found() && best.is_none_or(|b| m > b.0) {
            best = Some((m, r));
        }
    }
    let (m, r) = best?;
    row(r).position(|x| x == m).map(|c| (r, c))
}

/// Where the search of one ROI's `w`×`h` values `vals` (row-major) ended: the index of its
/// maximum (first in row-major order; `None` if no value is above `LEAST`) and the centre
/// (column, row in the ROI) of the largest 3×3 sum among centres whose 7×7 window lies in the
/// ROI (first in row-major order; `None` when the ROI is smaller than 7×7 or no sum is above
/// `LEAST`). `rows3` is scratch.
fn search_roi<T: Sample>(
    vals: &[T],
    w: usize,
    h: usize,
    rows3: &mut Vec<T>,
) -> (Option<usize>, Option<(usize, usize)>) {
    if w == 0 || h == 0 {
        return (None, None);
    }
    let row = |r: usize| vals[r * w..(r + 1) * w].iter().copied();
    let at = first_max((0..h).map(row), row).map(|(r, c)| r * w + c);
    if at.is_none() || w < PEAK_N || h < PEAK_N {
        return (at, None);
    }
    // The 3×3 sums as sums of three row sums; for each row of centres the largest, then the
    // first centre of the first row that holds the overall largest.
    rows3.clear();
    for v in vals.chunks_exact(w) {
        rows3.extend(v.windows(3).map(|t| t[0] + t[1] + t[2]));
    }
    let w3 = w - 2;
    // Centre columns PEAK_R..w−PEAK_R are row-sum indices PEAK_R−1..w−PEAK_R−1.
    let cols = PEAK_R - 1..w - PEAK_R - 1;
    let sums = |r: usize| {
        let a = &rows3[(r - 1) * w3..][cols.clone()];
        let b = &rows3[r * w3..][cols.clone()];
        let c = &rows3[(r + 1) * w3..][cols.clone()];
        a.iter().zip(b).zip(c).map(|((&a, &b), &c)| a + b + c)
    };
    let centre = first_max((PEAK_R..h - PEAK_R).map(sums), |i| sums(PEAK_R + i))
        .map(|(i, c)| (PEAK_R + c, PEAK_R + i));
    (at, centre)
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
/// frames are ignored; a ROI whose largest pixel is not finite (no pixel at all, only NaN, or
/// +∞) gives NaN, at the +∞ pixel if there is one. ROIs are clipped to the frame.
pub fn roi_maxima(
    view: &ThermalView<'_>,
    rois: &[[i64; 4]],
    scale: f64,
    offset_c: f64,
) -> Vec<RoiMax> {
    match view.format {
        ThermalFormat::U16 => maxima_of::<i32>(view, rois, |raw| raw * scale + offset_c),
        ThermalFormat::F32 => maxima_of::<f64>(view, rois, |raw| raw),
    }
}

/// [`roi_maxima`] with the pixels held as `T`; `to_c` turns a raw value into °C.
fn maxima_of<T: Sample>(
    view: &ThermalView<'_>,
    rois: &[[i64; 4]],
    to_c: impl Fn(f64) -> f64,
) -> Vec<RoiMax> {
    let (mut vals, mut rows3) = (Vec::<T>::new(), Vec::<T>::new());
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
            let (w, h) = (x1.saturating_sub(x0), y1.saturating_sub(y0));
            view.decode_roi((x0, x1, y0, y1), &mut vals);
            let (at, centre) = search_roi(&vals, w, h, &mut rows3);
            let Some(k) = at else { return best };
            (best.x_px, best.y_px) = ((x0 + k % w) as u32, (y0 + k / w) as u32);
            let raw = vals[k].to_f64();
            if !raw.is_finite() {
                return best;
            }
            best.max_c = to_c(raw);
            best.peak_c = best.max_c;
            if let Some((c, r)) = centre {
                let mut z = [0.0; PEAK_N * PEAK_N];
                for (i, v) in z.iter_mut().enumerate() {
                    let (dx, dy) = (i % PEAK_N, i / PEAK_N);
                    *v = vals[(r + dy - PEAK_R) * w + c + dx - PEAK_R].to_f64();
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

    /// The search as first written: every pixel decoded on its own, the first strictly
    /// larger value in row-major order kept, the 3×3 sum of each centre added up from its
    /// pixels, row by row (`(a + b + c)` per row, then the rows above, at and below the
    /// centre in that order, as the landed code grouped it). What [`roi_maxima`] computes by
    /// rows must agree with it bit for bit.
    fn reference(view: &ThermalView<'_>, roi: [i64; 4], scale: f64, offset_c: f64) -> RoiMax {
        let to_c = |raw: f64| match view.format {
            ThermalFormat::U16 => raw * scale + offset_c,
            ThermalFormat::F32 => raw,
        };
        let px = |x: usize, y: usize| {
            let row = &view.data[y * view.step..];
            match view.format {
                ThermalFormat::U16 => {
                    let b = [row[2 * x], row[2 * x + 1]];
                    f64::from(if view.big_endian {
                        u16::from_be_bytes(b)
                    } else {
                        u16::from_le_bytes(b)
                    })
                }
                ThermalFormat::F32 => {
                    let b = [row[4 * x], row[4 * x + 1], row[4 * x + 2], row[4 * x + 3]];
                    f64::from(if view.big_endian {
                        f32::from_be_bytes(b)
                    } else {
                        f32::from_le_bytes(b)
                    })
                }
            }
        };
        let cx = |v: i64, hi: usize| v.clamp(0, hi as i64) as usize;
        let (x0, x1) = (cx(roi[0], view.width), cx(roi[2], view.width));
        let (y0, y1) = (cx(roi[1], view.height), cx(roi[3], view.height));
        let mut best = RoiMax {
            max_c: f64::NAN,
            x_px: 0,
            y_px: 0,
            peak_c: f64::NAN,
        };
        let mut best_raw = f64::NEG_INFINITY;
        for y in y0..y1 {
            for x in x0..x1 {
                if px(x, y) > best_raw {
                    best_raw = px(x, y);
                    (best.x_px, best.y_px) = (x as u32, y as u32);
                }
            }
        }
        if !best_raw.is_finite() {
            return best;
        }
        best.max_c = to_c(best_raw);
        best.peak_c = best.max_c;
        if x1 - x0 < PEAK_N || y1 - y0 < PEAK_N {
            return best;
        }
        let mut centre = None;
        let mut best_sum = f64::NEG_INFINITY;
        for y in y0 + PEAK_R..y1 - PEAK_R {
            for x in x0 + PEAK_R..x1 - PEAK_R {
                let row3 = |yy: usize| px(x - 1, yy) + px(x, yy) + px(x + 1, yy);
                let s = row3(y - 1) + row3(y) + row3(y + 1);
                if s > best_sum {
                    (best_sum, centre) = (s, Some((x, y)));
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
    }

    #[test]
    fn the_row_wise_search_agrees_with_the_pixel_by_pixel_one() {
        // Random frames of few distinct values (ties everywhere), NaN and
        // infinite float pixels, both byte orders, ROIs cut by the frame, thin and empty.
        use rand::{rngs::StdRng, RngExt, SeedableRng};
        let mut rng = StdRng::seed_from_u64(11);
        let (w, h) = (40usize, 30usize);
        let rois = [
            [0, 0, 40, 30],
            [3, 2, 17, 12],
            [-5, -5, 9, 8],
            [30, 20, 60, 50],
            [10, 10, 16, 25],
            [5, 5, 5, 20],
            [12, 4, 19, 11],
        ];
        for trial in 0..200 {
            let levels = [1, 3, 50][trial % 3];
            let big = trial % 2 == 1;
            let same = |a: &RoiMax, b: &RoiMax| {
                let eq = |p: f64, q: f64| p == q || (p.is_nan() && q.is_nan());
                eq(a.max_c, b.max_c)
                    && eq(a.peak_c, b.peak_c)
                    && (a.x_px, a.y_px) == (b.x_px, b.y_px)
            };
            let counts: Vec<u16> = (0..w * h)
                .map(|_| 29_000 + 7 * rng.random_range(0..levels) as u16)
                .collect();
            let d = u16_frame(w, h, 2 * w + 6, big, |x, y| counts[y * w + x]);
            let v = ThermalView::new(&d, w, h, 2 * w + 6, ThermalFormat::U16, big).unwrap();
            let got = roi_maxima(&v, &rois, 0.01, -273.15);
            for (roi, g) in rois.iter().zip(&got) {
                let want = reference(&v, *roi, 0.01, -273.15);
                assert!(
                    same(g, &want),
                    "u16 trial {trial} roi {roi:?}: {g:?} vs {want:?}"
                );
            }
            // Readings on a coarse grid (ties), anywhere near one level, or of any magnitude;
            // rows padded.
            let coarse = trial % 4 < 2;
            let vals: Vec<f32> = (0..w * h)
                .map(|_| match rng.random_range(0..40) {
                    0 => f32::NAN,
                    1 if trial % 5 == 0 => f32::INFINITY,
                    2 if trial % 7 == 0 => f32::NEG_INFINITY,
                    _ if coarse => 21.0 + 0.25 * rng.random_range(0..levels) as f32,
                    _ if trial % 4 == 2 => {
                        21.0 + rng.random_range(0.0f32..1e-3) * 10f32.powi(rng.random_range(0..4))
                    }
                    // Magnitudes 2^±40 apart: nine-term sums round in f64, so the grouping
                    // of the additions decides near-ties.
                    _ => rng.random_range(-1.0f32..1.0) * 2f32.powi(rng.random_range(-40..40)),
                })
                .collect();
            let step = 4 * w + 12;
            let mut d = vec![0xCDu8; step * h];
            for (k, v) in vals.iter().enumerate() {
                let b = if big {
                    v.to_be_bytes()
                } else {
                    v.to_le_bytes()
                };
                let at = (k / w) * step + 4 * (k % w);
                d[at..at + 4].copy_from_slice(&b);
            }
            let v = ThermalView::new(&d, w, h, step, ThermalFormat::F32, big).unwrap();
            let got = roi_maxima(&v, &rois, 1.0, 0.0);
            for (roi, g) in rois.iter().zip(&got) {
                let want = reference(&v, *roi, 1.0, 0.0);
                assert!(
                    same(g, &want),
                    "f32 trial {trial} roi {roi:?}: {g:?} vs {want:?}"
                );
            }
        }
        // All NaN: nothing found, as before.
        let d: Vec<u8> = (0..w * h).flat_map(|_| f32::NAN.to_le_bytes()).collect();
        let v = ThermalView::new(&d, w, h, 4 * w, ThermalFormat::F32, false).unwrap();
        let m = roi_maxima(&v, &rois[..1], 1.0, 0.0)[0];
        assert!(m.max_c.is_nan() && m.peak_c.is_nan() && (m.x_px, m.y_px) == (0, 0));
    }

    /// Time per frame of the paper rig's three ROIs on a 320×240 16UC1 frame in cache, flat
    /// and with two hot regions and noise. `cargo test --release -p thermrs-core --lib --
    /// --ignored --nocapture bench_roi_maxima`.
    #[test]
    #[ignore]
    fn bench_roi_maxima() {
        use rand::{rngs::StdRng, SeedableRng};
        use rand_distr::{Distribution, StandardNormal};
        use std::time::Instant;
        let mut rng = StdRng::seed_from_u64(3);
        let (w, h) = (320usize, 240usize);
        let rois = [[40, 60, 120, 110], [140, 40, 250, 90], [60, 170, 140, 230]];
        let ck = |c: f64| ((c + 273.15) * 100.0).round() as u16;
        let noise: Vec<f64> = (0..w * h)
            .map(|_| StandardNormal.sample(&mut rng))
            .collect();
        let flat = u16_frame(w, h, 2 * w, false, |_, _| ck(22.0));
        let hot = u16_frame(w, h, 2 * w, false, |x, y| {
            let g = |cx: f64, cy: f64, sx: f64, sy: f64| {
                let (dx, dy) = ((x as f64 - cx) / sx, (y as f64 - cy) / sy);
                (-(dx * dx + dy * dy) / 2.0).exp()
            };
            ck(23.0
                + 3.0 * g(80.0, 85.0, 13.0, 8.0)
                + 2.0 * g(195.0, 65.0, 18.0, 8.0)
                + 0.05 * noise[y * w + x])
        });
        for (label, d) in [("flat", &flat), ("hot regions", &hot)] {
            let v = ThermalView::new(d, w, h, 2 * w, ThermalFormat::U16, false).unwrap();
            let (mut n, mut acc) = (0usize, 0.0);
            let t0 = Instant::now();
            while t0.elapsed().as_secs_f64() < 1.5 {
                acc += roi_maxima(&v, &rois, 0.01, -273.15)[0].peak_c;
                n += 1;
            }
            let dt = t0.elapsed().as_secs_f64();
            println!(
                "{label:<12} {:.2} µs/frame (checksum {:.3})",
                1e6 * dt / n as f64,
                acc / n as f64
            );
        }
    }
}
