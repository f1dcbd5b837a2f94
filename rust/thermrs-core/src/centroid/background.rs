//! Robust background statistics of small integer samples: median and MAD by byte
//! histograms, then the mean and rms of the values within the clipping range.

/// The `rank`-th smallest of `key(s)` over `samples` (0-based; clamped), by a two-level
/// byte histogram: two passes, no sorting, no allocation.
pub(super) fn kth_by(samples: &[u16], rank: usize, key: impl Fn(u16) -> u16) -> u16 {
    if samples.is_empty() {
        return 0;
    }
    let rank = rank.min(samples.len() - 1);
    let mut hi = [0u32; 256];
    for &s in samples {
        hi[(key(s) >> 8) as usize] += 1;
    }
    let (mut hb, mut before) = (0usize, 0usize);
    for (i, &c) in hi.iter().enumerate() {
        if before + c as usize > rank {
            hb = i;
            break;
        }
        before += c as usize;
    }
    let mut lo = [0u32; 256];
    for &s in samples {
        let k = key(s);
        if (k >> 8) as usize == hb {
            lo[(k & 0xff) as usize] += 1;
        }
    }
    let rank = rank - before;
    let mut acc = 0usize;
    for (i, &c) in lo.iter().enumerate() {
        acc += c as usize;
        if acc > rank {
            return ((hb << 8) | i) as u16;
        }
    }
    (hb << 8) as u16
}

/// Background and noise of a sample: median and MAD, then the mean and rms of the values
/// within `max(4 · 1.4826 · MAD, 2)` of the median. `(NaN, NaN)` for an empty sample.
///
/// When the sample spans fewer than 256 DN (always for 8-bit data) everything comes from
/// one exact histogram; otherwise the median and MAD come from [`kth_by`].
pub(super) fn robust_stats(samples: &[u16]) -> (f64, f64) {
    if samples.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let n = samples.len();
    let lo = samples.iter().fold(u16::MAX, |m, &v| m.min(v));
    let hi = samples.iter().fold(0u16, |m, &v| m.max(v));
    if hi - lo < 256 {
        // Four interleaved histograms avoid store-to-load stalls on repeated values.
        let mut h4 = [[0u32; 256]; 4];
        let mut chunks = samples.chunks_exact(4);
        // `v − lo < 256` for every sample here; the mask tells the compiler so (no bounds
        // check per sample).
        for c in &mut chunks {
            for (h, &v) in h4.iter_mut().zip(c) {
                h[((v - lo) & 0xff) as usize] += 1;
            }
        }
        for &v in chunks.remainder() {
            h4[0][((v - lo) & 0xff) as usize] += 1;
        }
        return hist_stats(&merged(&h4), lo, (hi - lo) as usize, n);
    }
    let mid = n / 2;
    let med = kth_by(samples, mid, |s| s);
    let mad = kth_by(samples, mid, |s| s.abs_diff(med));
    let clip = (4.0 * 1.4826 * mad as f64).max(2.0);
    let (mut cnt, mut s1, mut s2) = (0.0f64, 0.0f64, 0.0f64);
    for &s in samples {
        let d = s as f64 - med as f64;
        if d.abs() <= clip {
            cnt += 1.0;
            s1 += d;
            s2 += d * d;
        }
    }
    finish_stats(med as f64, cnt, s1, s2)
}

/// One histogram from four interleaved ones (counted four apart, so that repeated values do
/// not wait on each other's stores).
pub(super) fn merged(h4: &[[u32; 256]; 4]) -> [u32; 256] {
    let mut hist = [0u32; 256];
    for (i, hv) in hist.iter_mut().enumerate() {
        *hv = h4[0][i] + h4[1][i] + h4[2][i] + h4[3][i];
    }
    hist
}

/// [`robust_stats`] of `n ≥ 1` samples given as their histogram: bin `i` counts the samples of
/// value `lo + i`, and no sample is above `lo + span` (`span ≤ 255`).
///
/// The result does not depend on `lo` and `span` beyond that: empty bins below the smallest
/// sample or above the largest add nothing to any count or sum (a zero count adds `+0.0`, and
/// no partial sum here is `−0.0`), so an 8-bit sample's histogram over all 256 values (`lo`
/// 0, `span` 255) gives the same bits as the one [`robust_stats`] builds from the sample.
pub(super) fn hist_stats(hist: &[u32; 256], lo: u16, span: usize, n: usize) -> (f64, f64) {
    if n == 0 {
        return (f64::NAN, f64::NAN);
    }
    let span = span.min(255);
    let half = n / 2;
    let mut acc = 0usize;
    let mut med = 0usize;
    for (i, &c) in hist[..=span].iter().enumerate() {
        acc += c as usize;
        if acc > half {
            med = i;
            break;
        }
    }
    // MAD: the smallest d with more than half the sample within med ± d.
    let mut within = hist[med] as usize;
    let mut mad = 0usize;
    while within <= half && mad < 256 {
        mad += 1;
        if med + mad <= span {
            within += hist[med + mad] as usize;
        }
        if mad <= med {
            within += hist[med - mad] as usize;
        }
    }
    let clip = (4.0 * 1.4826 * mad as f64).max(2.0) as usize;
    let (a, b) = (med.saturating_sub(clip), (med + clip).min(span));
    let (mut cnt, mut s1, mut s2) = (0.0f64, 0.0f64, 0.0f64);
    for (i, &c) in hist[a..=b].iter().enumerate() {
        let d = (a + i) as f64 - med as f64;
        let c = c as f64;
        cnt += c;
        s1 += c * d;
        s2 += c * d * d;
    }
    finish_stats(lo as f64 + med as f64, cnt, s1, s2)
}

/// Mean and (unbiased) rms from counts and sums of deviations from `centre`.
pub(super) fn finish_stats(centre: f64, n: f64, s1: f64, s2: f64) -> (f64, f64) {
    if n < 1.0 {
        return (centre, 0.0);
    }
    let mean = s1 / n;
    let var = (s2 / n - mean * mean).max(0.0);
    let var = if n > 1.0 { var * n / (n - 1.0) } else { var };
    (centre + mean, var.sqrt())
}
