//! Thermal (IR) frames: each ROI's maximum temperature and where it is (SPEC §2, §3).
//!
//! Integer frames (`16UC1`/`mono16`) carry raw counts: °C = raw × `scale` + `offset_c` (the
//! rig's radiometric scale; e.g. centi-kelvin with scale 0.01, offset −273.15). `32FC1` frames
//! are already °C. Either byte order. A ROI `[x0, y0, x1, y1]` covers columns x0..x1−1 and rows
//! y0..y1−1; its temperature is its maximum (the paper's "maximum temperature of each link").

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

/// One ROI's maximum: temperature (°C) and the pixel it is at (first in row-major order).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoiMax {
    pub max_c: f64,
    pub x_px: u32,
    pub y_px: u32,
}

/// Maximum of each ROI in °C. `scale`/`offset_c` apply to U16 frames only. NaN pixels of float
/// frames are ignored; a ROI with no finite pixel gives NaN. ROIs are clipped to the frame.
pub fn roi_maxima(
    view: &ThermalView<'_>,
    rois: &[[i64; 4]],
    scale: f64,
    offset_c: f64,
) -> Vec<RoiMax> {
    rois.iter()
        .map(|&[x0, y0, x1, y1]| {
            let cx = |v: i64, hi: usize| v.clamp(0, hi as i64) as usize;
            let (x0, x1) = (cx(x0, view.width), cx(x1, view.width));
            let (y0, y1) = (cx(y0, view.height), cx(y1, view.height));
            let mut best = RoiMax {
                max_c: f64::NAN,
                x_px: 0,
                y_px: 0,
            };
            let mut best_raw = f64::NEG_INFINITY;
            for y in y0..y1 {
                let row = &view.data[y * view.step..];
                for x in x0..x1 {
                    let v = view.raw(row, x);
                    if v > best_raw {
                        best_raw = v;
                        best = RoiMax {
                            max_c: 0.0,
                            x_px: x as u32,
                            y_px: y as u32,
                        };
                    }
                }
            }
            if best_raw.is_finite() {
                best.max_c = match view.format {
                    ThermalFormat::U16 => best_raw * scale + offset_c,
                    ThermalFormat::F32 => best_raw,
                };
            } else {
                best.max_c = f64::NAN;
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

    #[test]
    fn short_buffers_are_rejected() {
        assert!(ThermalView::new(&[0; 10], 4, 2, 8, ThermalFormat::U16, false).is_err());
        assert!(ThermalView::new(&[0; 16], 4, 2, 6, ThermalFormat::U16, false).is_err());
        assert!(ThermalView::new(&[0; 16], 4, 2, 8, ThermalFormat::U16, false).is_ok());
    }
}
