//! CRC-32 (IEEE 802.3, reflected; what MCAP uses) by folding four 512-bit lanes with
//! VPCLMULQDQ, 256 bytes per step, the state kept wide between calls: a measuring instrument
//! for `main.rs`, checked against crc32fast there before anything is timed.
//!
//! Folding a 128-bit lane forward by `d` bits multiplies its low 64 bits by `x^(d+32) mod P`
//! and its high 64 bits by `x^(d-32) mod P` (bit-reflected, shifted left by one): with these
//! formulas the constants of Linux's `crc32-pclmul_asm.S` come out (d = 512: 0x154442bd4 and
//! 0x1c6e41596; d = 128: 0x1751997d0 and 0xccaa009e). The four lanes are folded into one
//! 128-bit value whose own CRC (from a zero register) is that of the data so far; crc32fast
//! takes it from there, with the bytes of an unfinished step.

use std::arch::x86_64::*;

const P: u64 = 0x1_04C1_1DB7;

const fn xpow_mod(e: u32) -> u64 {
    let mut r: u64 = 1;
    let mut i = 0;
    while i < e {
        r <<= 1;
        if r & (1 << 32) != 0 {
            r ^= P;
        }
        i += 1;
    }
    r
}

const fn k(e: u32) -> u64 {
    ((xpow_mod(e) as u32).reverse_bits() as u64) << 1
}

/// The constants folding a lane forward by `d` bits: (low, high).
const fn pair(d: u32) -> [u64; 2] {
    [k(d + 32), k(d - 32)]
}

const BY_2048: [u64; 2] = pair(2048);
const BY_1536: [u64; 2] = pair(1536);
const BY_1024: [u64; 2] = pair(1024);
const BY_512: [u64; 2] = pair(512);
const BY_384: [u64; 2] = pair(384);
const BY_256: [u64; 2] = pair(256);
const BY_128: [u64; 2] = pair(128);

/// True where the CPU runs this kernel.
pub fn available() -> bool {
    is_x86_feature_detected!("avx512f")
        && is_x86_feature_detected!("vpclmulqdq")
        && is_x86_feature_detected!("pclmulqdq")
}

/// A CRC-32 in progress.
pub struct Fold {
    x: [__m512i; 4],
    started: bool,
    /// Bytes of a step not yet folded.
    pending: Vec<u8>,
    /// The CRC of the bytes before this one's (0 for none).
    init: u32,
}

#[inline(always)]
unsafe fn wide(c: [u64; 2]) -> __m512i {
    let [lo, hi] = c.map(|v| v as i64);
    _mm512_set_epi64(hi, lo, hi, lo, hi, lo, hi, lo)
}

#[inline(always)]
unsafe fn fold512(x: __m512i, c: [u64; 2]) -> __m512i {
    let k = wide(c);
    _mm512_xor_si512(
        _mm512_clmulepi64_epi128(x, k, 0x00),
        _mm512_clmulepi64_epi128(x, k, 0x11),
    )
}

#[inline(always)]
unsafe fn fold128(x: __m128i, c: [u64; 2]) -> __m128i {
    let k = _mm_set_epi64x(c[1] as i64, c[0] as i64);
    _mm_xor_si128(
        _mm_clmulepi64_si128(x, k, 0x00),
        _mm_clmulepi64_si128(x, k, 0x11),
    )
}

/// One 256-byte step into the lanes.
#[inline(always)]
unsafe fn step(x: &mut [__m512i; 4], k: __m512i, p: *const u8) {
    for (i, xi) in x.iter_mut().enumerate() {
        let d = _mm512_loadu_si512(p.add(64 * i).cast());
        *xi = _mm512_ternarylogic_epi64(
            _mm512_clmulepi64_epi128(*xi, k, 0x00),
            _mm512_clmulepi64_epi128(*xi, k, 0x11),
            d,
            0x96,
        );
    }
}

impl Fold {
    /// A CRC continuing one that stood at `init` (0: a new one). Call only if [`available`].
    pub fn new(init: u32) -> Self {
        Fold {
            // SAFETY: AVX-512F is present (the caller checked `available`).
            x: unsafe { [_mm512_setzero_si512(); 4] },
            started: false,
            pending: Vec::with_capacity(256),
            init,
        }
    }

    /// Fold `d`'s whole 256-byte steps, calling `between` after every `every` steps: the work
    /// placed inside the kernel's own loop. `d.len()` must be a multiple of 256 and nothing may
    /// be pending.
    ///
    /// # Safety
    /// [`available`] must be true.
    #[target_feature(enable = "avx512f,vpclmulqdq,pclmulqdq")]
    pub unsafe fn steps_with(&mut self, d: &[u8], every: usize, between: &mut dyn FnMut()) {
        assert!(d.len().is_multiple_of(256) && self.pending.is_empty());
        let mut blocks = d.chunks_exact(256);
        if !self.started {
            let Some(first) = blocks.next() else { return };
            let p = first.as_ptr();
            let load = |i: usize| _mm512_loadu_si512(p.add(64 * i).cast());
            let init = _mm512_castsi128_si512(_mm_cvtsi32_si128(!self.init as i32));
            self.x = [_mm512_xor_si512(load(0), init), load(1), load(2), load(3)];
            self.started = true;
        }
        let k = wide(BY_2048);
        let mut x = self.x;
        for (i, b) in blocks.enumerate() {
            step(&mut x, k, b.as_ptr());
            if (i + 1) % every == 0 {
                between();
            }
        }
        self.x = x;
    }

    /// Fold `d` (any length; an unfinished step waits for the next call).
    pub fn update(&mut self, mut d: &[u8]) {
        if !self.pending.is_empty() {
            let take = (256 - self.pending.len()).min(d.len());
            self.pending.extend_from_slice(&d[..take]);
            d = &d[take..];
            if self.pending.len() < 256 {
                return;
            }
            let p = std::mem::take(&mut self.pending);
            // SAFETY: `new`'s caller checked `available`.
            unsafe { self.steps_with(&p, usize::MAX, &mut || {}) };
            self.pending = p;
            self.pending.clear();
        }
        let whole = d.len() / 256 * 256;
        // SAFETY: as above.
        unsafe { self.steps_with(&d[..whole], usize::MAX, &mut || {}) };
        self.pending.extend_from_slice(&d[whole..]);
    }

    #[target_feature(enable = "avx512f,vpclmulqdq,pclmulqdq")]
    unsafe fn lanes(&self) -> [u8; 16] {
        let [a, b, c, d] = self.x;
        let z = _mm512_xor_si512(
            _mm512_xor_si512(fold512(a, BY_1536), fold512(b, BY_1024)),
            _mm512_xor_si512(fold512(c, BY_512), d),
        );
        let v = _mm_xor_si128(
            _mm_xor_si128(
                fold128(_mm512_extracti64x2_epi64(z, 0), BY_384),
                fold128(_mm512_extracti64x2_epi64(z, 1), BY_256),
            ),
            _mm_xor_si128(
                fold128(_mm512_extracti64x2_epi64(z, 2), BY_128),
                _mm512_extracti64x2_epi64(z, 3),
            ),
        );
        let mut out = [0u8; 16];
        _mm_storeu_si128(out.as_mut_ptr().cast(), v);
        out
    }

    /// The CRC-32 of everything folded so far.
    pub fn finish(&self) -> u32 {
        let mut h = if self.started {
            // crc32fast from state !0 runs the register from zero, with no final inversion
            // of its own beyond the standard one.
            let mut h = crc32fast::Hasher::new_with_initial(0xFFFF_FFFF);
            // SAFETY: as above.
            h.update(&unsafe { self.lanes() });
            h
        } else {
            crc32fast::Hasher::new_with_initial(self.init)
        };
        h.update(&self.pending);
        h.finalize()
    }
}
