//! Frame access: a borrowed, possibly padded, 8- or 16-bit frame ([`FrameView`]) and
//! pixel reads specialised per format ([`Px`]) so that the row loops vectorise.

/// Why bytes are not a frame of the given shape. `Display` is one line.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    #[error("bytes_per_px must be 1 or 2, got {0}")]
    BytesPerPixel(usize),
    #[error("{0} overflows")]
    Overflow(&'static str),
    #[error("step {step} is smaller than width * bytes_per_px = {row_bytes}")]
    StepTooSmall { step: usize, row_bytes: usize },
    #[error("data has {have} bytes, a {width}x{height} frame with step {step} needs {need}")]
    TooShort {
        have: usize,
        width: usize,
        height: usize,
        step: usize,
        need: usize,
    },
}

/// Where a frame's problem is reported as text (a skipped message's reason).
impl From<FrameError> for String {
    fn from(e: FrameError) -> String {
        e.to_string()
    }
}

/// A borrowed, possibly padded, 8- or 16-bit single-channel frame.
#[derive(Clone, Copy, Debug)]
pub struct FrameView<'a> {
    /// Pixel bytes, row after row, `step` bytes apart.
    pub data: &'a [u8],
    /// Pixels per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Bytes from the start of one row to the next (≥ `width * bytes_per_px`).
    pub step: usize,
    /// 1 (8-bit) or 2 (16-bit).
    pub bytes_per_px: usize,
    /// Byte order of 16-bit pixels (ignored for 8-bit).
    pub big_endian: bool,
}

impl<'a> FrameView<'a> {
    /// Checks `bytes_per_px ∈ {1, 2}`, `step ≥ width·bytes_per_px` and
    /// `data.len() ≥ step·(height − 1) + width·bytes_per_px`. A frame with no pixels is
    /// valid (and holds no spot).
    pub fn new(
        data: &'a [u8],
        width: usize,
        height: usize,
        step: usize,
        bytes_per_px: usize,
        big_endian: bool,
    ) -> Result<Self, FrameError> {
        let view = FrameView {
            data,
            width,
            height,
            step,
            bytes_per_px,
            big_endian,
        };
        view.check()?;
        Ok(view)
    }

    /// A tightly packed 8-bit frame (`step = width`).
    pub fn mono8(data: &'a [u8], width: usize, height: usize) -> Result<Self, FrameError> {
        Self::new(data, width, height, width, 1, false)
    }

    pub(super) fn check(&self) -> Result<(), FrameError> {
        if self.bytes_per_px != 1 && self.bytes_per_px != 2 {
            return Err(FrameError::BytesPerPixel(self.bytes_per_px));
        }
        let row_bytes = self
            .width
            .checked_mul(self.bytes_per_px)
            .ok_or(FrameError::Overflow("width * bytes_per_px"))?;
        if self.step < row_bytes {
            return Err(FrameError::StepTooSmall {
                step: self.step,
                row_bytes,
            });
        }
        if self.width == 0 || self.height == 0 {
            return Ok(());
        }
        let need = self
            .step
            .checked_mul(self.height - 1)
            .and_then(|v| v.checked_add(row_bytes))
            .ok_or(FrameError::Overflow("frame size"))?;
        if self.data.len() < need {
            return Err(FrameError::TooShort {
                have: self.data.len(),
                width: self.width,
                height: self.height,
                step: self.step,
                need,
            });
        }
        Ok(())
    }

    /// The pixel bytes of row `y` (without padding). Caller guarantees `y < height` on a
    /// checked view.
    #[inline]
    pub(super) fn row(&self, y: usize) -> &'a [u8] {
        let start = y * self.step;
        &self.data[start..start + self.width * self.bytes_per_px]
    }
}

/// Ask the CPU to start loading `bytes` into its cache: a hint that changes no result. The
/// sparse row scan jumps `k` rows at a time and across pages, which the hardware prefetcher
/// does not follow; without the hint every scanned row of a frame that is not in cache waits
/// one memory latency (the row scan was half of an uncompressed extraction's time, nearly all
/// of it waiting; BENCHMARKS.md, "Extraction against one read of the file").
#[inline(always)]
pub(crate) fn prefetch(bytes: &[u8]) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        let p = bytes.as_ptr();
        let mut off = 0;
        while off < bytes.len() {
            // SAFETY: SSE is part of x86_64; a prefetch reads nothing architecturally and
            // never faults, and `p + off` is inside `bytes`.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(off).cast()) };
            off += 64;
        }
        if let Some(last) = bytes.len().checked_sub(1) {
            // SAFETY: as above.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(last).cast()) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = bytes;
}

// Pixel access, specialised per format so that the row loops vectorise.

pub(super) trait Px {
    const BPP: usize;
    const MAX: u32;
    /// Pixel `i` of a row's bytes.
    fn get(row: &[u8], i: usize) -> u32;
    /// Maximum over a run of whole pixels (`bytes.len()` a multiple of `BPP`).
    fn max_of(bytes: &[u8]) -> u32;
    /// Sum over a run of whole pixels.
    fn sum_of(bytes: &[u8]) -> u64;
    /// `out[i] = pixel(i) − b` for the pixels of `bytes`.
    fn to_f32(bytes: &[u8], b: f32, out: &mut [f32]);
}

pub(super) struct U8;

/// The largest byte of `bytes` (0 for none): 32 independent lanes, which the compiler turns
/// into vector maxima; the ragged end is covered by one overlapping last chunk.
#[inline(always)]
fn max_u8(bytes: &[u8]) -> u8 {
    if bytes.len() < 32 {
        return bytes.iter().fold(0u8, |m, &v| m.max(v));
    }
    let mut acc = [0u8; 32];
    let lanes = |acc: &mut [u8; 32], c: &[u8]| {
        for (a, &v) in acc.iter_mut().zip(c) {
            *a = (*a).max(v);
        }
    };
    for c in bytes.chunks_exact(32) {
        lanes(&mut acc, c);
    }
    lanes(&mut acc, &bytes[bytes.len() - 32..]);
    acc.iter().fold(0u8, |m, &v| m.max(v))
}

/// [`max_u8`] compiled for AVX2: one 32-byte maximum per instruction instead of two.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn max_u8_avx2(bytes: &[u8]) -> u8 {
    max_u8(bytes)
}
pub(super) struct U16Le;
pub(super) struct U16Be;

impl Px for U8 {
    const BPP: usize = 1;
    const MAX: u32 = 255;
    #[inline(always)]
    fn get(row: &[u8], i: usize) -> u32 {
        row[i] as u32
    }
    #[inline]
    fn max_of(bytes: &[u8]) -> u32 {
        #[cfg(target_arch = "x86_64")]
        if bytes.len() >= 64 && std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2 (checked just above).
            return unsafe { max_u8_avx2(bytes) } as u32;
        }
        max_u8(bytes) as u32
    }
    #[inline]
    fn sum_of(bytes: &[u8]) -> u64 {
        bytes.iter().map(|&v| v as u64).sum()
    }
    #[inline]
    fn to_f32(bytes: &[u8], b: f32, out: &mut [f32]) {
        for (o, &v) in out.iter_mut().zip(bytes) {
            *o = v as f32 - b;
        }
    }
}

/// The largest 16-bit pixel of `bytes` (big-endian if `BE`; whole pixels only, 0 for none):
/// as [`max_u8`], 16 lanes of 16 bits.
#[inline(always)]
fn max_u16<const BE: bool>(bytes: &[u8]) -> u16 {
    let px = |p: &[u8]| {
        if BE {
            u16::from_be_bytes([p[0], p[1]])
        } else {
            u16::from_le_bytes([p[0], p[1]])
        }
    };
    if bytes.len() < 32 {
        return bytes.chunks_exact(2).fold(0u16, |m, p| m.max(px(p)));
    }
    let mut acc = [0u16; 16];
    let lanes = |acc: &mut [u16; 16], c: &[u8]| {
        for (a, p) in acc.iter_mut().zip(c.chunks_exact(2)) {
            *a = (*a).max(px(p));
        }
    };
    for c in bytes.chunks_exact(32) {
        lanes(&mut acc, c);
    }
    let end = bytes.len() & !1;
    lanes(&mut acc, &bytes[end - 32..end]);
    acc.iter().fold(0u16, |m, &v| m.max(v))
}

/// [`max_u16`] compiled for AVX2.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn max_u16_avx2<const BE: bool>(bytes: &[u8]) -> u16 {
    max_u16::<BE>(bytes)
}

macro_rules! impl_u16 {
    ($t:ident, $conv:ident, $be:literal) => {
        impl Px for $t {
            const BPP: usize = 2;
            const MAX: u32 = 65535;
            #[inline(always)]
            fn get(row: &[u8], i: usize) -> u32 {
                u16::$conv([row[2 * i], row[2 * i + 1]]) as u32
            }
            #[inline]
            fn max_of(bytes: &[u8]) -> u32 {
                #[cfg(target_arch = "x86_64")]
                if bytes.len() >= 64 && std::arch::is_x86_feature_detected!("avx2") {
                    // SAFETY: the CPU has AVX2 (checked just above).
                    return unsafe { max_u16_avx2::<$be>(bytes) } as u32;
                }
                max_u16::<$be>(bytes) as u32
            }
            #[inline]
            fn sum_of(bytes: &[u8]) -> u64 {
                bytes
                    .chunks_exact(2)
                    .map(|p| u16::$conv([p[0], p[1]]) as u64)
                    .sum()
            }
            #[inline]
            fn to_f32(bytes: &[u8], b: f32, out: &mut [f32]) {
                for (o, p) in out.iter_mut().zip(bytes.chunks_exact(2)) {
                    *o = u16::$conv([p[0], p[1]]) as f32 - b;
                }
            }
        }
    };
}
impl_u16!(U16Le, from_le_bytes, false);
impl_u16!(U16Be, from_be_bytes, true);

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{rngs::StdRng, RngExt, SeedableRng};

    #[test]
    fn row_maxima_agree_with_the_iterator_maximum() {
        // Every length up to 300 bytes at every alignment, the largest byte anywhere (the
        // ragged end included): the route the CPU takes (AVX2 where it has it) and the
        // portable one, against `Iterator::max`.
        let mut rng = StdRng::seed_from_u64(5);
        let buf: Vec<u8> = (0..400).map(|_| rng.random_range(0..200u8)).collect();
        for len in 0..=300 {
            for off in 0..4 {
                let mut b = buf[off..off + len].to_vec();
                if len > 0 {
                    b[rng.random_range(0..len)] = 200 + rng.random_range(0..56u8);
                }
                let want = b.iter().copied().max().unwrap_or(0) as u32;
                assert_eq!(U8::max_of(&b), want, "u8, {len} bytes");
                assert_eq!(max_u8(&b) as u32, want, "u8 portable, {len} bytes");
                let even = &b[..len & !1];
                let px = |p: &[u8], big: bool| {
                    if big {
                        u16::from_be_bytes([p[0], p[1]])
                    } else {
                        u16::from_le_bytes([p[0], p[1]])
                    }
                };
                let want = |big| even.chunks_exact(2).map(|p| px(p, big)).max().unwrap_or(0);
                assert_eq!(
                    U16Le::max_of(even),
                    want(false) as u32,
                    "u16le, {len} bytes"
                );
                assert_eq!(U16Be::max_of(even), want(true) as u32, "u16be, {len} bytes");
                assert_eq!(max_u16::<false>(even), want(false), "u16le portable, {len}");
                assert_eq!(max_u16::<true>(even), want(true), "u16be portable, {len}");
            }
        }
    }
}
