//! The Cramér–Rao bound of a pixel-integrated Gaussian spot's position: what no unbiased
//! centroid can beat, the yardstick of the accuracy tests.

use super::*;

/// Per-axis standard deviation (px) of the Cramér–Rao bound for the position of a
/// pixel-integrated Gaussian spot on a CCD (Mortensen et al. 2010, Nature Methods 7:377,
/// eq. 5 with F = 1, pixel size a = 1 px):
/// `var = (σa²/N) · [1 + ∫₀¹ ln t / (1 + t/τ) dt]⁻¹`, `σa² = σ² + 1/12`,
/// `τ = 2π σa² b² / N`, with `N = 2π σ² · peak / g` signal electrons,
/// `b² = background / g + (read_noise / g)²` electrons² per pixel and `g = dn_per_electron`.
/// `peak_dn` is the amplitude of the continuous Gaussian, `background_dn` and
/// `read_noise_dn` per pixel. Returns +∞ when there is no signal.
pub fn cramer_rao_px(
    sigma_px: f64,
    peak_dn: f64,
    background_dn: f64,
    read_noise_dn: f64,
    dn_per_electron: f64,
) -> f64 {
    let g = dn_per_electron;
    if !(sigma_px > 0.0 && peak_dn > 0.0 && g > 0.0) {
        return f64::INFINITY;
    }
    let n = 2.0 * std::f64::consts::PI * sigma_px * sigma_px * peak_dn / g;
    let b2 = (background_dn.max(0.0) / g) + (read_noise_dn / g).powi(2);
    let sa2 = sigma_px * sigma_px + PIXEL_VAR;
    let tau = 2.0 * std::f64::consts::PI * sa2 * b2 / n;
    let factor = 1.0 + mortensen_integral(tau);
    if factor <= 0.0 || !factor.is_finite() {
        return f64::INFINITY;
    }
    (sa2 / n / factor).sqrt()
}

/// `∫₀¹ ln t / (1 + t/τ) dt` by Simpson's rule after `t = e^(−u)`:
/// `−∫₀^∞ u τ e^(−u) / (τ + e^(−u)) du`, a smooth, exponentially decaying integrand.
pub(super) fn mortensen_integral(tau: f64) -> f64 {
    if tau <= 0.0 {
        return 0.0;
    }
    if !tau.is_finite() {
        return -1.0;
    }
    let upper = 60.0 + (1.0 / tau).ln().max(0.0);
    let steps = 4000usize; // even
    let h = upper / steps as f64;
    let f = |u: f64| {
        let e = (-u).exp();
        u * tau * e / (tau + e)
    };
    let mut s = f(0.0) + f(upper);
    for i in 1..steps {
        let w = if i % 2 == 1 { 4.0 } else { 2.0 };
        s += w * f(i as f64 * h);
    }
    -s * h / 3.0
}
