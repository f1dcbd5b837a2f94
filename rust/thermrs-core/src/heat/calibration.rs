//! The KR 15/2 nodes calibrated to the paper's Table 4 ([`kr15_paper_nodes`]): a derivation
//! from the printed temperatures, nothing fitted by hand.
//!
//! Protocol (temperatures are the ROI maxima, link 2 / link 3, °C):
//!
//! | step | duty | minutes | start | end |
//! | --- | --- | --- | --- | --- |
//! | Run 1 | 30 % | 900 | 23.40 / 23.35 | 28.10 / 30.10 |
//! | cool-down | idle (servo off) | 600 | 28.10 / 30.10 | 24.40 / 24.34 |
//! | Run 2 | 75 % | 900 | 24.40 / 24.34 | 28.40 / 30.65 |
//! | Run 3 (no cool-down) | 10 % | 900 | 28.40 / 30.65 | 27.20 / 28.45 |
//!
//! One room: ambient `T_amb` = [`KR15_PAPER_AMBIENT_C`] = 23.38 °C for every node (the mean of
//! the two Run-1 start temperatures, 23.375, to the table's 0.01; Run 1 then starts 0.02 K above
//! ambient on link 2 and 0.03 K below on link 3, within the camera's 0.1 K sensitivity). The
//! derivation below is exact for any ambient, so the model reproduces Table 4 exactly (to
//! rounding) with this choice; with per-node ambients 23.40 / 23.35 the numbers change by ≤ 1.4 %.
//! With excesses `e = T − T_amb`:
//!
//! 1. **τ from the cool-down.** Idle means `ΔT_ss = 0`, so the excess decays as
//!    `e(600 min) = e(0)·exp(−600/τ)`, i.e. `τ = 600 min / ln(e_end,run1 / e_start,run2)`.
//! 2. **Steady rise per run.** Over a 900-min run with `q = exp(−900/τ)`,
//!    `e_end = D + (e_start − D)·q`, so `D = ΔT_ss(s) = (e_end − e_start·q)/(1 − q)`. Run 3's
//!    start is Run 2's end.
//! 3. **Saturating rise** through the three points `(s_i, D_i)` = (10 %, 30 %, 75 %). With
//!    `E_i = exp(−s_i/s0)`, `D_j − D_i = r_span·(E_i − E_j)`, so the ratio of the two rises
//!
//!    ```text
//!      ρ = (D(0.75) − D(0.30)) / (D(0.30) − D(0.10)) = (E_2 − E_3)/(E_1 − E_2) = g(s0)
//!    ```
//!
//!    depends on `s0` alone. `g` rises monotonically from 0 (`s0 → 0`) to
//!    `(0.75 − 0.30)/(0.30 − 0.10)` = 2.25 (`s0 → ∞`, the straight line), so a solution exists
//!    iff `D` increases with speed and its slope falls, `0 < ρ < 2.25`; [`solve_saturating_s0`]
//!    finds it by bisection (to full precision). Then, in closed form,
//!    `r_span = (D(0.30) − D(0.10))/(E_1 − E_2)` and `r0 = D(0.10) − r_span·(1 − E_1)`.
//!
//! | node | e_end,1 → e_start,2 (K) | τ (min) | q | ΔT_ss 10 % | 30 % | 75 % | ρ | s0 | r_span (K) | r0 (K) |
//! | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |
//! | link2 | 4.72 → 1.02 | 391.64 | 0.10046 | 3.686 | 5.245 | 5.467 | 0.14230 | 0.096403 | 5.0305 | 0.4383 |
//! | link3 | 6.72 → 0.96 | 308.34 | 0.05399 | 4.944 | 7.105 | 7.630 | 0.24291 | 0.124159 | 6.0418 | 1.6027 |
//!
//! (e.g. link 2: τ = 600/ln(4.72/1.02) = 600/1.5321; Run 1: D = (4.72 − 0.02·q)/(1 − q);
//! Run 2: (5.02 − 1.02·q)/(1 − q); Run 3: (3.82 − 5.02·q)/(1 − q).) The parameters are computed
//! from the Table 4 numbers at run time, so they carry no rounding of the values above.
//!
//! Resulting `ΔT_ss` (K) at 0 / 50 / 100 % speed: link 2 0.438 / 5.441 / 5.469, link 3
//! 1.603 / 7.537 / 7.643 (plateaus `r0 + r_span` = 5.469 / 7.645).
//!
//! **Monotonic in speed, flat above ~50 %.** The data rise steeply from 10 % to 30 % and barely
//! from 30 % to 75 % (+0.22 K / +0.52 K), so the calibrated `s0` is small (~0.1) and the curve is
//! all but saturated above ~50 %: from 75 % to 100 % it adds 0.002 K / 0.012 K. It never falls.
//! The first calibration passed a quadratic through the same three points instead; being concave
//! it peaked inside [0, 1] (link 2 at s ≈ 0.547, 5.93 K; link 3 at s ≈ 0.564, 8.14 K) and fell
//! beyond, to 3.62 K / 5.33 K at 100 %, *less* than at 30 %: losses falling with speed, which
//! contradicts the model (issue #4), so it was replaced. Both forms go through the same three
//! points, so the paper's runs (Table 4) come out the same; they differ only between and outside
//! the measured speeds, where neither is supported by data: above 75 % and below 10 % (the
//! standstill rise `r0` = 0.44 K / 1.60 K; the quadratic gave 2.57 K / 3.42 K) are
//! extrapolations. The flattening between 30 % and 75 % may reflect the 900-min runs, a duty
//! that is not proportional to the speed limit (dwell and camera stops; with a fixed cycle a
//! faster robot rests longer), or the maximum-temperature ROI moving.
//!
//! **`base`** (an assumption, not from the paper): slow and small, τ = 600 min, quadratic
//! `ΔT_ss(s) = 0.10 + 0.85·s + 0.50·s²` (0.40 K at 30 %, 1.45 K at 100 %, increasing).

use super::{HeatError, NodeParams, Rise};

/// Ambient temperature of the paper's runs, °C, used for every node of [`kr15_paper_nodes`].
pub const KR15_PAPER_AMBIENT_C: f64 = 23.38;

/// One link's temperatures in the paper's Table 4, °C.
pub(super) struct Table4Link {
    pub(super) name: &'static str,
    /// Run 1 (30 %): start, end.
    pub(super) run1: (f64, f64),
    /// Run 2 (75 %): start, end. Run 3 (10 %) starts at Run 2's end.
    pub(super) run2: (f64, f64),
    /// Run 3 end.
    pub(super) run3_end: f64,
}

pub(super) const TABLE4: [Table4Link; 2] = [
    Table4Link {
        name: "link2",
        run1: (23.40, 28.10),
        run2: (24.40, 28.40),
        run3_end: 27.20,
    },
    Table4Link {
        name: "link3",
        run1: (23.35, 30.10),
        run2: (24.34, 30.65),
        run3_end: 28.45,
    },
];
/// Length of each run, minutes.
pub(super) const PAPER_RUN_MIN: f64 = 900.0;
/// Idle time between Runs 1 and 2, minutes.
pub(super) const PAPER_COOL_MIN: f64 = 600.0;
/// Speeds of Runs 1, 2, 3.
pub(super) const PAPER_SPEEDS: [f64; 3] = [0.30, 0.75, 0.10];

/// `g(s0) = (E_2 − E_3)/(E_1 − E_2)` with `E_i = exp(−x_i/s0)` (module documentation, step 3),
/// written as `e^{−a}·(1 − e^{−b})/(1 − e^{−a})`, `a = (x_2 − x_1)/s0`, `b = (x_3 − x_2)/s0`, so
/// that it neither underflows for small `s0` nor cancels for large `s0`.
pub(super) fn saturating_ratio(x: [f64; 3], s0: f64) -> f64 {
    let a = (x[1] - x[0]) / s0;
    let b = (x[2] - x[1]) / s0;
    (-a).exp() * (-b).exp_m1() / (-a).exp_m1()
}

/// The speed scale `s0` of a saturating rise `r0 + r_span·(1 − exp(−s/s0))` whose rises between
/// the speeds `x = [x_1, x_2, x_3]` (strictly increasing) have the ratio
/// `rho = (D_3 − D_2)/(D_2 − D_1)`: the root of `g(s0) = rho` (module documentation, step 3), by
/// bisection to full precision. `g` rises monotonically from 0 (`s0 → 0`) to
/// `(x_3 − x_2)/(x_2 − x_1)` (`s0 → ∞`); errors if `rho` is not strictly between (no saturating
/// curve has that shape), or so close to the upper limit that `s0` would exceed 1e12.
pub fn solve_saturating_s0(x: [f64; 3], rho: f64) -> Result<f64, HeatError> {
    if !(x.iter().all(|v| v.is_finite()) && x[0] < x[1] && x[1] < x[2]) {
        return Err(HeatError::Saturating(format!(
            "speeds {x:?} must be finite and strictly increasing"
        )));
    }
    let limit = (x[2] - x[1]) / (x[1] - x[0]);
    if !(rho > 0.0 && rho < limit) {
        return Err(HeatError::Saturating(format!(
            "ratio of rises ρ = {rho} is outside (0, {}); \
             no saturating curve through these points",
            (limit * 1e12).round() / 1e12
        )));
    }
    let g = |s0: f64| saturating_ratio(x, s0);
    // Bracket the root within a factor 2, starting at the speeds' span.
    let (mut lo, mut hi) = (x[2] - x[0], x[2] - x[0]);
    if g(lo) < rho {
        while g(hi) < rho {
            lo = hi;
            hi *= 2.0;
            if hi > 1e12 {
                return Err(HeatError::Saturating(format!(
                    "ρ = {rho} is too close to its limit {limit} \
                     (the points are nearly on a straight line; s0 > 1e12)"
                )));
            }
        }
    } else {
        // g → 0 as s0 → 0 and rho > 0, so this ends (g underflows to 0 by s0 ≈ 3e-4·span).
        while g(lo) >= rho {
            hi = lo;
            lo /= 2.0;
        }
    }
    // g(lo) < rho ≤ g(hi): bisect until the bracket cannot shrink.
    loop {
        let mid = lo + 0.5 * (hi - lo);
        if mid <= lo || mid >= hi {
            return Ok(if rho - g(lo) <= g(hi) - rho { lo } else { hi });
        }
        if g(mid) < rho {
            lo = mid;
        } else {
            hi = mid;
        }
    }
}

/// The saturating rise through three points `(s_i, D_i)` with strictly increasing speeds and
/// rises (module documentation, step 3): `s0` by [`solve_saturating_s0`], then `r_span` and `r0`
/// in closed form. Errors if the rises do not increase or their slope does not fall.
pub fn saturating_through(p: [(f64, f64); 3]) -> Result<Rise, HeatError> {
    let [(x1, d1), (x2, d2), (x3, d3)] = p;
    let step = d2 - d1;
    if !(step.is_finite() && step > 0.0) {
        return Err(HeatError::Saturating(format!(
            "D({x1}) = {d1} must be less than D({x2}) = {d2}"
        )));
    }
    let rho = (d3 - d2) / (d2 - d1);
    let s0 = solve_saturating_s0([x1, x2, x3], rho)?;
    // E_1 − E_2 = e^{−x1/s0}·(1 − e^{−(x2 − x1)/s0})
    let e12 = -(-x1 / s0).exp() * (-(x2 - x1) / s0).exp_m1();
    let span_k = (d2 - d1) / e12;
    let r0_k = d1 + span_k * (-x1 / s0).exp_m1();
    Ok(Rise::Saturating { r0_k, span_k, s0 })
}

/// The steady rises `D` of one link at the speeds of Runs 1, 2 and 3 (30 %, 75 %, 10 %) and τ
/// (minutes) from its Table 4 numbers (module documentation, steps 1–2).
pub(super) fn table4_rises(link: &Table4Link, ambient_c: f64) -> (f64, [f64; 3]) {
    let e = |t: f64| t - ambient_c;
    let tau_min = PAPER_COOL_MIN / (e(link.run1.1) / e(link.run2.0)).ln();
    let q = (-PAPER_RUN_MIN / tau_min).exp();
    let rise = |start: f64, end: f64| (e(end) - e(start) * q) / (1.0 - q);
    let d1 = rise(link.run1.0, link.run1.1);
    let d2 = rise(link.run2.0, link.run2.1);
    let d3 = rise(link.run2.1, link.run3_end);
    (tau_min, [d1, d2, d3])
}

/// τ and the saturating rise from one link's Table 4 numbers (module documentation, steps 1–3).
fn calibrate(link: &Table4Link, ambient_c: f64) -> Result<NodeParams, HeatError> {
    let (tau_min, [d1, d2, d3]) = table4_rises(link, ambient_c);
    let [s1, s2, s3] = PAPER_SPEEDS;
    let rise = saturating_through([(s3, d3), (s1, d1), (s2, d2)])?;
    NodeParams::new(link.name, tau_min, rise)
}

/// The KR-15/2 nodes calibrated to the paper (`link2`, `link3`, saturating rises) plus an assumed
/// `base` (quadratic), for ambient [`KR15_PAPER_AMBIENT_C`]. See the module documentation for the
/// derivation.
pub fn kr15_paper_nodes() -> Vec<NodeParams> {
    let mut nodes: Vec<NodeParams> = TABLE4
        .iter()
        .map(|l| calibrate(l, KR15_PAPER_AMBIENT_C).expect("Table 4 calibrates"))
        .collect();
    // Assumption, not from the paper: the base is massive and far from the hot motors.
    nodes.push(NodeParams {
        name: "base".to_string(),
        tau_min: 600.0,
        rise: Rise::Quadratic([0.10, 0.85, 0.50]),
    });
    nodes
}
