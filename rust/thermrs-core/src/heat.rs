//! Lumped thermal model of the robot's links: how hot each region the IR camera sees gets for a
//! motion duty, calibrated to the paper's KR-15/2 runs (Table 4); and the first-order lag of the
//! structure behind that surface temperature (SPEC §6 effect `thermal_lag`).
//!
//! # Nodes
//!
//! A *node* is one region of the robot the IR camera sees, named like the rig's ROIs (`link2`,
//! `link3`, `base`). It is one lumped heat capacity `C` (J/K) coupled to the room through one
//! thermal resistance `R` (K/W) and heated by the losses `P` (W) of the motors and gearboxes next
//! to it. Its temperature `T` (°C) obeys
//!
//! ```text
//!   C·dT/dt = P − (T − T_amb)/R      ⇔      dT/dt = (T_ss − T)/τ,
//!   τ = R·C,     T_ss = T_amb + ΔT_ss,     ΔT_ss = R·P.
//! ```
//!
//! The losses depend on the duty. With the servo off (`speed = None`, "idle") there are none and
//! `ΔT_ss = 0`. With the robot running at speed `s` (fraction of maximum, 0..=1; `Some(0.0)` is
//! standstill under servo) they are `P(s)`: the holding losses `P(0)` (brake released, motors
//! holding the arm against gravity) plus motor copper losses and gearbox friction, which grow
//! with speed, so `P` is non-decreasing in `s`. Only the product with `R` is observable from
//! surface temperatures, so the parameters are the steady rise `ΔT_ss(s) = R·P(s)` (K) and the
//! time constant `τ` ([`NodeParams::tau_min`], minutes). Time steps are in seconds.
//!
//! The steady rise ([`NodeParams::rise`], a [`Rise`]) takes one of two forms, both required to be
//! non-decreasing on `[0, 1]` ([`Rise::check`]):
//!
//! ```text
//!   saturating:  ΔT_ss(s) = r0 + r_span·(1 − exp(−s/s0))     r_span ≥ 0, s0 > 0
//!   quadratic:   ΔT_ss(s) = r0 + r1·s + r2·s²                 r1 ≥ 0, r1 + 2·r2 ≥ 0
//! ```
//!
//! **Saturating** ([`Rise::Saturating`] `{ r0_k, span_k, s0 }`): `r0` is the standstill rise
//! under servo (holding losses), `r_span` the extra rise the speed-dependent losses add as speed
//! grows, approached as `s ≫ s0`, and `s0` the speed scale (fraction of maximum) over which they
//! build up: `1 − e^{−1}` = 63 % of `r_span` is reached at `s = s0`. Its slope
//! `(r_span/s0)·exp(−s/s0)` is positive for every `s` (with `r_span > 0`), so it is strictly
//! increasing and concave, bounded by `r0 + r_span`. The paper's links use it.
//! **Quadratic** ([`Rise::Quadratic`] `[r0, r1, r2]`): `r_i = R·p_i` of losses
//! `p0 + p1·s + p2·s²`; its slope `r1 + 2·r2·s` is linear in `s`, so it is non-decreasing on
//! `[0, 1]` iff the slope is ≥ 0 at both ends. The assumed `base` node uses it.
//! In scenario files a `[[node]]` gives one of them: `rise_saturating = { r0_k, span_k, s0 }` or
//! `rise_k = [r0, r1, r2]` ([`crate::scenario::Node`]).
//!
//! **Exact integration.** For inputs (speed, ambient) constant over a step `dt` the ODE solves in
//! closed form, `T(t+dt) = T_ss + (T(t) − T_ss)·exp(−dt/τ)`; [`NodeParams::step`] and
//! [`simulate`] use it (no Euler), so one long step equals many short ones to rounding and the
//! result does not depend on the sampling of a piecewise-constant duty.
//!
//! # Calibration to the paper (Table 4), [`kr15_paper_nodes`]
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
//!
//! # Surface vs structure: [`first_order_lag`]
//!
//! The IR camera sees the surface; the structure that expands lags it by a first-order filter
//! `dy/dt = (x − y)/τ_lag` (SPEC §6 `thermal_lag`; its `tau_min` × 60 = `tau_s`). The surface
//! series is taken piecewise linear between samples, and the update is exact for that: on
//! `[t_k, t_k + h]` with `x(t) = x_k + m·(t − t_k)`, `m = (x_{k+1} − x_k)/h`, the solution is the
//! ramp's particular solution `x(t) − m·τ` plus a decaying transient:
//!
//! ```text
//!   y(t) = x(t) − m·τ + (y_k − x_k + m·τ)·exp(−(t − t_k)/τ)
//!   y_{k+1} = x_{k+1} − (x_{k+1} − x_k)·φ(u) + a·(y_k − x_k),
//!   u = h/τ,  a = exp(−u),  φ(u) = (1 − a)/u = m·τ·(1 − a)/(x_{k+1} − x_k)
//! ```
//!
//! `φ` is evaluated as `−expm1(−u)/u` (a short series for tiny `u`), so the update neither
//! overflows nor cancels for any `h/τ`: `h ≫ τ` gives `y_{k+1} = x_{k+1}`, `h ≪ τ` gives
//! `y_{k+1} ≈ y_k + (h/τ)·((x_k + x_{k+1})/2 − y_k)`.

/// Ambient temperature of the paper's runs, °C, used for every node of [`kr15_paper_nodes`].
pub const KR15_PAPER_AMBIENT_C: f64 = 23.38;

/// Steady rise of a node above ambient as a function of speed (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Rise {
    /// `[r0, r1, r2]` (K): `ΔT_ss(s) = r0 + r1·s + r2·s²`.
    Quadratic([f64; 3]),
    /// `ΔT_ss(s) = r0_k + span_k·(1 − exp(−s/s0))`: standstill rise `r0_k` (K), extra rise
    /// `span_k` (K, ≥ 0) approached as speed grows, speed scale `s0` (fraction of maximum, > 0).
    Saturating { r0_k: f64, span_k: f64, s0: f64 },
}

impl Rise {
    /// `ΔT_ss` (K) at `speed` (fraction of maximum), evaluated as is (no clamping).
    pub fn at(&self, speed: f64) -> f64 {
        match *self {
            Rise::Quadratic([r0, r1, r2]) => r0 + speed * (r1 + speed * r2),
            Rise::Saturating { r0_k, span_k, s0 } => r0_k - span_k * (-speed / s0).exp_m1(),
        }
    }

    /// Check the parameters are finite and the rise is non-decreasing on [0, 1]: a quadratic
    /// needs `r1 ≥ 0` and `r1 + 2·r2 ≥ 0`, a saturating rise `span_k ≥ 0` and `s0 > 0`. The error
    /// names the offending key as a scenario file spells it (`rise_k`, `rise_saturating.s0`, …).
    pub fn check(&self) -> Result<(), (&'static str, String)> {
        match *self {
            Rise::Quadratic(r) => {
                if let Some(v) = r.iter().find(|v| !v.is_finite()) {
                    return Err(("rise_k", format!("has {v}, expected finite numbers")));
                }
                let [_, r1, r2] = r;
                if !(r1 >= 0.0 && r1 + 2.0 * r2 >= 0.0) {
                    return Err((
                        "rise_k",
                        format!(
                            "is {r:?}, which decreases with speed on [0, 1] \
                             (expected r1 ≥ 0 and r1 + 2·r2 ≥ 0)"
                        ),
                    ));
                }
            }
            Rise::Saturating { r0_k, span_k, s0 } => {
                if !r0_k.is_finite() {
                    return Err((
                        "rise_saturating.r0_k",
                        format!("is {r0_k}, expected a finite number"),
                    ));
                }
                if !(span_k.is_finite() && span_k >= 0.0) {
                    return Err((
                        "rise_saturating.span_k",
                        format!("is {span_k}, expected a finite number ≥ 0"),
                    ));
                }
                if !(s0.is_finite() && s0 > 0.0) {
                    return Err((
                        "rise_saturating.s0",
                        format!("is {s0}, expected a positive number"),
                    ));
                }
            }
        }
        Ok(())
    }
}

/// One lumped thermal node (see the module documentation).
#[derive(Debug, Clone, PartialEq)]
pub struct NodeParams {
    /// The IR ROI / temperature name (`link2`, `link3`, `base`, …).
    pub name: String,
    /// Time constant τ, minutes (> 0).
    pub tau_min: f64,
    /// Steady rise above ambient while running, as a function of speed.
    pub rise: Rise,
}

impl NodeParams {
    /// A validated node.
    pub fn new(name: impl Into<String>, tau_min: f64, rise: Rise) -> Result<Self, String> {
        let node = NodeParams {
            name: name.into(),
            tau_min,
            rise,
        };
        node.validate()?;
        Ok(node)
    }

    /// Check the name is non-empty, `tau_min` is finite and > 0 and the rise passes
    /// [`Rise::check`] (finite, non-decreasing in speed on [0, 1]).
    pub fn validate(&self) -> Result<(), String> {
        if self.name.trim().is_empty() {
            return Err("thermal node: name is empty".into());
        }
        if !(self.tau_min.is_finite() && self.tau_min > 0.0) {
            return Err(format!(
                "thermal node {:?}: tau_min must be finite and > 0, got {}",
                self.name, self.tau_min
            ));
        }
        self.rise
            .check()
            .map_err(|(key, msg)| format!("thermal node {:?}: {key} {msg}", self.name))
    }

    /// Steady rise above ambient when running at `speed` (fraction of maximum), K: the
    /// [`Rise`] evaluated as is (no clamping).
    pub fn steady_rise_k(&self, speed: f64) -> f64 {
        self.rise.at(speed)
    }

    /// Steady-state temperature, °C, for a duty (`None` = idle, servo off: ambient).
    pub fn steady_state_c(&self, ambient_c: f64, speed: Option<f64>) -> f64 {
        match speed {
            None => ambient_c,
            Some(s) => ambient_c + self.steady_rise_k(s),
        }
    }

    /// Temperature after `dt_s` seconds from `t_c` with constant ambient and duty, exactly:
    /// `T_ss + (t_c − T_ss)·exp(−dt/τ)`. `dt_s ≤ 0` returns `t_c` (no time passes). Speeds
    /// outside [0, 1] are not rejected here (the rise is evaluated as is); [`simulate`]
    /// validates.
    pub fn step(&self, t_c: f64, ambient_c: f64, speed: Option<f64>, dt_s: f64) -> f64 {
        if dt_s <= 0.0 {
            return t_c;
        }
        let t_ss = self.steady_state_c(ambient_c, speed);
        t_ss + (t_c - t_ss) * (-dt_s / (self.tau_min * 60.0)).exp()
    }
}

/// Temperature of `node` at each time stamp `t_s` (seconds), starting at `t0_c` at `t_s[0]`.
///
/// `speed[k]` (`None` = idle) and `ambient_c[k]` hold over the interval `[t_s[k], t_s[k+1])`;
/// all three slices have the same length (the last `speed`/`ambient_c` entries are unused).
/// Intervals with non-increasing time stamps pass no time. Integration is exact for these
/// piecewise-constant inputs. Errors on an invalid node, unequal lengths, a speed outside
/// [0, 1] or non-finite, or a non-finite time, ambient or start temperature.
pub fn simulate(
    node: &NodeParams,
    t_s: &[f64],
    speed: &[Option<f64>],
    ambient_c: &[f64],
    t0_c: f64,
) -> Result<Vec<f64>, String> {
    node.validate()?;
    let n = t_s.len();
    if speed.len() != n || ambient_c.len() != n {
        return Err(format!(
            "simulate {:?}: t_s, speed and ambient_c must have equal lengths, got {}, {} and {}",
            node.name,
            n,
            speed.len(),
            ambient_c.len()
        ));
    }
    if !t0_c.is_finite() {
        return Err(format!(
            "simulate {:?}: start temperature must be finite, got {t0_c}",
            node.name
        ));
    }
    if let Some(k) = t_s.iter().position(|t| !t.is_finite()) {
        return Err(format!(
            "simulate {:?}: t_s[{k}] = {} is not finite",
            node.name, t_s[k]
        ));
    }
    if let Some(k) = ambient_c.iter().position(|a| !a.is_finite()) {
        return Err(format!(
            "simulate {:?}: ambient_c[{k}] = {} is not finite",
            node.name, ambient_c[k]
        ));
    }
    for (k, s) in speed.iter().enumerate() {
        if let Some(s) = *s {
            if !(0.0..=1.0).contains(&s) {
                return Err(format!(
                    "simulate {:?}: speed[{k}] = {s} is outside [0, 1] (fraction of maximum)",
                    node.name
                ));
            }
        }
    }
    let mut out = Vec::with_capacity(n);
    if n == 0 {
        return Ok(out);
    }
    let mut t = t0_c;
    out.push(t);
    for k in 1..n {
        t = node.step(t, ambient_c[k - 1], speed[k - 1], t_s[k] - t_s[k - 1]);
        out.push(t);
    }
    Ok(out)
}

/// One link's temperatures in the paper's Table 4, °C.
struct Table4Link {
    name: &'static str,
    /// Run 1 (30 %): start, end.
    run1: (f64, f64),
    /// Run 2 (75 %): start, end. Run 3 (10 %) starts at Run 2's end.
    run2: (f64, f64),
    /// Run 3 end.
    run3_end: f64,
}

const TABLE4: [Table4Link; 2] = [
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
const PAPER_RUN_MIN: f64 = 900.0;
/// Idle time between Runs 1 and 2, minutes.
const PAPER_COOL_MIN: f64 = 600.0;
/// Speeds of Runs 1, 2, 3.
const PAPER_SPEEDS: [f64; 3] = [0.30, 0.75, 0.10];

/// `g(s0) = (E_2 − E_3)/(E_1 − E_2)` with `E_i = exp(−x_i/s0)` (module documentation, step 3),
/// written as `e^{−a}·(1 − e^{−b})/(1 − e^{−a})`, `a = (x_2 − x_1)/s0`, `b = (x_3 − x_2)/s0`, so
/// that it neither underflows for small `s0` nor cancels for large `s0`.
fn saturating_ratio(x: [f64; 3], s0: f64) -> f64 {
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
pub fn solve_saturating_s0(x: [f64; 3], rho: f64) -> Result<f64, String> {
    if !(x.iter().all(|v| v.is_finite()) && x[0] < x[1] && x[1] < x[2]) {
        return Err(format!(
            "saturating rise: speeds {x:?} must be finite and strictly increasing"
        ));
    }
    let limit = (x[2] - x[1]) / (x[1] - x[0]);
    if !(rho > 0.0 && rho < limit) {
        return Err(format!(
            "saturating rise: ratio of rises ρ = {rho} is outside (0, {}); \
             no saturating curve through these points",
            (limit * 1e12).round() / 1e12
        ));
    }
    let g = |s0: f64| saturating_ratio(x, s0);
    // Bracket the root within a factor 2, starting at the speeds' span.
    let (mut lo, mut hi) = (x[2] - x[0], x[2] - x[0]);
    if g(lo) < rho {
        while g(hi) < rho {
            lo = hi;
            hi *= 2.0;
            if hi > 1e12 {
                return Err(format!(
                    "saturating rise: ρ = {rho} is too close to its limit {limit} \
                     (the points are nearly on a straight line; s0 > 1e12)"
                ));
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
pub fn saturating_through(p: [(f64, f64); 3]) -> Result<Rise, String> {
    let [(x1, d1), (x2, d2), (x3, d3)] = p;
    let step = d2 - d1;
    if !(step.is_finite() && step > 0.0) {
        return Err(format!(
            "saturating rise: D({x1}) = {d1} must be less than D({x2}) = {d2}"
        ));
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
fn table4_rises(link: &Table4Link, ambient_c: f64) -> (f64, [f64; 3]) {
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
fn calibrate(link: &Table4Link, ambient_c: f64) -> Result<NodeParams, String> {
    let (tau_min, [d1, d2, d3]) = table4_rises(link, ambient_c);
    let [s1, s2, s3] = PAPER_SPEEDS;
    let rise = saturating_through([(s3, d3), (s1, d1), (s2, d2)])
        .map_err(|e| format!("calibrating {}: {e}", link.name))?;
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

/// `(1 − exp(−u))/u` for `u ≥ 0` (1 at 0, 0 at +∞), accurate for every `u`.
fn phi(u: f64) -> f64 {
    if u < 1e-5 {
        1.0 - u * (0.5 - u / 6.0)
    } else {
        -(-u).exp_m1() / u
    }
}

/// The first-order lag `dy/dt = (x − y)/tau_s` of the series `x` sampled at `t_s` (seconds),
/// exact for `x` linear between samples (module documentation), with `y[0] = x[0]`.
///
/// `tau_s = 0` returns `x` unchanged; `tau_s = +∞` holds `y` at `x[0]`. A step with
/// `t_s[k+1] ≤ t_s[k]` passes no time (`y[k+1] = y[k]`), so a repeated time stamp models a jump
/// in `x`. A NaN in `t_s` or `x` propagates to the output. Errors on unequal lengths or a
/// negative or NaN `tau_s`.
pub fn first_order_lag(t_s: &[f64], x: &[f64], tau_s: f64) -> Result<Vec<f64>, String> {
    if t_s.len() != x.len() {
        return Err(format!(
            "first_order_lag: t_s and x must have equal lengths, got {} and {}",
            t_s.len(),
            x.len()
        ));
    }
    if tau_s.is_nan() || tau_s < 0.0 {
        return Err(format!("first_order_lag: tau_s must be >= 0, got {tau_s}"));
    }
    if tau_s == 0.0 || x.is_empty() {
        return Ok(x.to_vec());
    }
    let mut y = Vec::with_capacity(x.len());
    let mut yk = x[0];
    y.push(yk);
    for k in 1..x.len() {
        let h = t_s[k] - t_s[k - 1];
        // NaN steps go through the update so that the NaN propagates.
        if h > 0.0 || h.is_nan() {
            yk = lag_step(x[k - 1], x[k], yk, h, tau_s);
        }
        y.push(yk);
    }
    Ok(y)
}

/// One step of the first-order lag (the law of [`first_order_lag`], module documentation):
/// the lagged value after `h` seconds from `y_prev`, with the input going linearly from
/// `x_prev` to `x_now`. `tau_s ≤ 0` (no lag) or a step that passes no time gives `x_now`; a NaN
/// propagates.
#[inline]
pub fn lag_step(x_prev: f64, x_now: f64, y_prev: f64, h: f64, tau_s: f64) -> f64 {
    if tau_s <= 0.0 || h <= 0.0 {
        return x_now;
    }
    let u = h / tau_s;
    let a = (-u).exp();
    x_now - (x_now - x_prev) * phi(u) + a * (y_prev - x_prev)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn node(name: &str) -> NodeParams {
        kr15_paper_nodes()
            .into_iter()
            .find(|n| n.name == name)
            .unwrap()
    }

    /// The paper's protocol with 1-minute steps: Run 1 (30 %, 900 min), 600 min idle, Run 2
    /// (75 %, 900 min), Run 3 (10 %, 900 min). Returns (t_s, speed, ambient) and the sample
    /// indices of the five Table 4 instants (Run 1 start/end, Run 2 start/end = Run 3 start,
    /// Run 3 end).
    fn paper_protocol() -> (Vec<f64>, Vec<Option<f64>>, Vec<f64>, [usize; 5]) {
        let segments: [(Option<f64>, usize); 4] = [
            (Some(0.30), 900),
            (None, 600),
            (Some(0.75), 900),
            (Some(0.10), 900),
        ];
        let mut speed = Vec::new();
        for (s, minutes) in segments {
            speed.extend(std::iter::repeat_n(s, minutes));
        }
        speed.push(None); // after the last sample: unused
        let n = speed.len();
        let t_s: Vec<f64> = (0..n).map(|k| k as f64 * 60.0).collect();
        let ambient = vec![KR15_PAPER_AMBIENT_C; n];
        (t_s, speed, ambient, [0, 900, 1500, 2400, 3300])
    }

    #[test]
    fn reproduces_table4_within_0_05_c() {
        let (t_s, speed, ambient, idx) = paper_protocol();
        for link in &TABLE4 {
            let n = node(link.name);
            let t = simulate(&n, &t_s, &speed, &ambient, link.run1.0).unwrap();
            let want = [
                link.run1.0,
                link.run1.1,
                link.run2.0,
                link.run2.1,
                link.run3_end,
            ];
            for (i, w) in idx.iter().zip(want) {
                let got = t[*i];
                assert!(
                    (got - w).abs() < 0.05,
                    "{} at minute {i}: {got:.4} vs Table 4 {w}",
                    link.name
                );
                // The calibration is analytic, so in fact it is exact to rounding.
                assert!((got - w).abs() < 1e-9, "{} at {i}: {got} vs {w}", link.name);
            }
        }
    }

    /// Every rise of [`kr15_paper_nodes`] at 0, 50 and 100 % (the module documentation's
    /// numbers).
    #[test]
    fn documented_calibration_numbers_match() {
        let l2 = node("link2");
        let l3 = node("link3");
        let close = |a: f64, b: f64, tol: f64| (a - b).abs() < tol;
        assert!(close(l2.tau_min, 391.64, 0.005), "{}", l2.tau_min);
        assert!(close(l3.tau_min, 308.34, 0.005), "{}", l3.tau_min);
        // (q, ρ, [s0, span, r0], D at 10/30/75 %, ΔT_ss at 0/50/100 %, plateau)
        for (n, q, rho, p, d, at, plateau) in [
            (
                &l2,
                0.10046,
                0.14230,
                [0.096403, 5.0305, 0.4383],
                [3.686, 5.245, 5.467],
                [0.438, 5.441, 5.469],
                5.469,
            ),
            (
                &l3,
                0.05399,
                0.24291,
                [0.124159, 6.0418, 1.6027],
                [4.944, 7.105, 7.630],
                [1.603, 7.537, 7.643],
                7.645,
            ),
        ] {
            assert!(close((-900.0 / n.tau_min).exp(), q, 5e-6), "{}", n.name);
            let Rise::Saturating { r0_k, span_k, s0 } = n.rise else {
                panic!("{}: {:?} is not saturating", n.name, n.rise);
            };
            assert!(close(s0, p[0], 5e-7), "{}: s0 {s0}", n.name);
            assert!(close(span_k, p[1], 5e-5), "{}: span {span_k}", n.name);
            assert!(close(r0_k, p[2], 5e-5), "{}: r0 {r0_k}", n.name);
            assert!(close(r0_k + span_k, plateau, 5e-4), "{}", n.name);
            let got_rho = (n.steady_rise_k(0.75) - n.steady_rise_k(0.30))
                / (n.steady_rise_k(0.30) - n.steady_rise_k(0.10));
            assert!(close(got_rho, rho, 5e-6), "{}: ρ {got_rho}", n.name);
            for (s, d) in [0.10, 0.30, 0.75].into_iter().zip(d) {
                let got = n.steady_rise_k(s);
                assert!(close(got, d, 5e-4), "{} at {s}: {got}", n.name);
            }
            for (s, d) in [0.0, 0.5, 1.0].into_iter().zip(at) {
                let got = n.steady_rise_k(s);
                assert!(close(got, d, 5e-4), "{} at {s}: {got}", n.name);
            }
        }
        // "from 75 % to 100 % it adds 0.002 K / 0.012 K"
        for (n, add) in [(&l2, 0.002), (&l3, 0.012)] {
            let got = n.steady_rise_k(1.0) - n.steady_rise_k(0.75);
            assert!(close(got, add, 5e-4), "{}: {got}", n.name);
        }
        let base = node("base");
        assert_eq!(base.rise, Rise::Quadratic([0.10, 0.85, 0.50]));
        assert!(close(base.steady_rise_k(0.30), 0.40, 1e-12));
        assert!(close(base.steady_rise_k(1.0), 1.45, 1e-12));
        assert_eq!(base.tau_min, 600.0);
        for n in kr15_paper_nodes() {
            n.validate().unwrap();
        }
    }

    /// The saturating rises go through the three steady rises D that Table 4 implies, exactly.
    #[test]
    fn calibration_reproduces_the_three_rises() {
        for link in &TABLE4 {
            let n = node(link.name);
            // D recomputed here from the table (module documentation, steps 1–2).
            let e = |t: f64| t - KR15_PAPER_AMBIENT_C;
            let tau = 600.0 / (e(link.run1.1) / e(link.run2.0)).ln();
            let q = (-900.0 / tau).exp();
            let d = |a: f64, b: f64| (e(b) - e(a) * q) / (1.0 - q);
            assert!((n.tau_min - tau).abs() < 1e-12, "{}", link.name);
            for (s, want) in [
                (0.30, d(link.run1.0, link.run1.1)),
                (0.75, d(link.run2.0, link.run2.1)),
                (0.10, d(link.run2.1, link.run3_end)),
            ] {
                let got = n.steady_rise_k(s);
                assert!(
                    (got - want).abs() < 1e-9,
                    "{} at {s}: {got} vs {want}",
                    n.name
                );
            }
        }
    }

    /// Losses grow with speed: every default node's rise is strictly increasing on [0, 1].
    #[test]
    fn every_default_rise_increases_with_speed() {
        let grid: Vec<f64> = (0..=1000).map(|i| i as f64 / 1000.0).collect();
        for n in kr15_paper_nodes() {
            n.rise.check().unwrap();
            let d: Vec<f64> = grid.iter().map(|&s| n.steady_rise_k(s)).collect();
            for (w, s) in d.windows(2).zip(&grid) {
                assert!(w[1] > w[0], "{} at s = {s}: {} → {}", n.name, w[0], w[1]);
            }
            // above the measured 75 % it keeps rising, and never above the plateau
            if let Rise::Saturating { r0_k, span_k, .. } = n.rise {
                assert!(n.steady_rise_k(1.0) > n.steady_rise_k(0.75));
                assert!(n.steady_rise_k(1.0) < r0_k + span_k);
                assert!(n.steady_rise_k(1.0) > n.steady_rise_k(0.30), "{}", n.name);
            }
        }
    }

    /// The quadratic `[c0, c1, c2]` (`c0 + c1·x + c2·x²`) through three points with distinct x.
    fn quadratic_through(p: [(f64, f64); 3]) -> [f64; 3] {
        let [(x0, y0), (x1, y1), (x2, y2)] = p;
        let f01 = (y1 - y0) / (x1 - x0);
        let f12 = (y2 - y1) / (x2 - x1);
        let c2 = (f12 - f01) / (x2 - x0);
        let c1 = f01 - c2 * (x0 + x1);
        let c0 = y0 - c1 * x0 - c2 * x0 * x0;
        [c0, c1, c2]
    }

    /// What the replaced quadratic calibration did (module documentation): through the same
    /// three points it peaked at ~55 % and fell below its 30 % value at 100 %; it fails
    /// [`Rise::check`] now.
    #[test]
    fn replaced_quadratic_as_documented() {
        for (link, coef, vertex, peak, full, r0) in [
            (
                &TABLE4[0],
                [2.5695, 12.2877, -11.2331],
                0.547,
                5.93,
                3.62,
                2.57,
            ),
            (
                &TABLE4[1],
                [3.4192, 16.7351, -14.8273],
                0.564,
                8.14,
                5.33,
                3.42,
            ),
        ] {
            let (_, [d1, d2, d3]) = table4_rises(link, KR15_PAPER_AMBIENT_C);
            let c = quadratic_through([(0.10, d3), (0.30, d1), (0.75, d2)]);
            for (g, w) in c.iter().zip(coef) {
                assert!((g - w).abs() < 5e-5, "{}: {c:?}", link.name);
            }
            let q = Rise::Quadratic(c);
            let v = -c[1] / (2.0 * c[2]);
            assert!((v - vertex).abs() < 5e-4, "{}: vertex {v}", link.name);
            assert!((q.at(v) - peak).abs() < 5e-3, "{}", link.name);
            assert!((q.at(1.0) - full).abs() < 5e-3, "{}", link.name);
            assert!((q.at(0.0) - r0).abs() < 5e-3, "{}", link.name);
            assert!(q.at(1.0) < q.at(0.30), "{}", link.name);
            assert_eq!(q.check().unwrap_err().0, "rise_k");
            // same three points as the saturating calibration
            let sat = node(link.name).rise;
            for s in [0.10, 0.30, 0.75] {
                assert!((q.at(s) - sat.at(s)).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn quadratic_through_recovers_a_quadratic() {
        let f = |x: f64| 1.5 - 2.0 * x + 0.25 * x * x;
        let c = quadratic_through([(0.1, f(0.1)), (0.3, f(0.3)), (0.75, f(0.75))]);
        for (g, w) in c.iter().zip([1.5, -2.0, 0.25]) {
            assert!((g - w).abs() < 1e-12, "{c:?}");
        }
    }

    #[test]
    fn solver_recovers_a_known_s0() {
        let x = [0.10, 0.30, 0.75];
        // g is increasing in s0 and spans (0, 2.25)
        let gs: Vec<f64> = (-30..=40)
            .map(|k| saturating_ratio(x, 10f64.powf(k as f64 / 10.0)))
            .collect();
        assert!(gs.windows(2).all(|w| w[1] > w[0]), "{gs:?}");
        assert!(gs[0] > 0.0 && gs[0] < 1e-80, "{gs:?}");
        assert!((gs[70] - 2.25).abs() < 1e-4, "{gs:?}");
        assert_eq!(saturating_ratio(x, 1e-5), 0.0); // underflows, no NaN
                                                    // ρ from the exponentials themselves (no rises to cancel): s0 to full precision, up to
                                                    // the conditioning near the straight-line limit.
        for (s0, tol) in [
            (0.002, 1e-13),
            (0.01, 1e-13),
            (0.0964, 1e-13),
            (0.3, 1e-13),
            (1.0, 1e-12),
            (10.0, 1e-10),
            (100.0, 1e-8),
        ] {
            let e = |s: f64| (-s / s0).exp();
            let rho = (e(0.30) - e(0.75)) / (e(0.10) - e(0.30));
            let got = solve_saturating_s0(x, rho).unwrap();
            assert!((got / s0 - 1.0).abs() < tol, "s0 {s0}: {got}");
        }
        // the whole curve through three points of a known one
        for (s0, tol) in [(0.05, 1e-9), (0.0964, 1e-11), (0.3, 1e-11), (1.0, 1e-10)] {
            let (r0, span) = (1.25, 3.5);
            let f = |s: f64| r0 + span * (1.0 - (-s / s0).exp());
            let Rise::Saturating {
                r0_k,
                span_k,
                s0: s,
            } = saturating_through([(0.10, f(0.10)), (0.30, f(0.30)), (0.75, f(0.75))]).unwrap()
            else {
                unreachable!()
            };
            assert!((s / s0 - 1.0).abs() < tol, "s0 {s0}: {s}");
            assert!((r0_k - r0).abs() < 1e3 * tol, "s0 {s0}: r0 {r0_k}");
            assert!((span_k - span).abs() < 1e3 * tol, "s0 {s0}: span {span_k}");
        }
        // other speeds: the limit is (x3 − x2)/(x2 − x1)
        let x = [0.0, 1.0, 3.0];
        let s0 = 0.7;
        let e = |s: f64| (-s / s0).exp();
        let rho = (e(1.0) - e(3.0)) / (e(0.0) - e(1.0));
        assert!((solve_saturating_s0(x, rho).unwrap() - s0).abs() < 1e-13);
        assert!(solve_saturating_s0(x, 1.999).is_ok());
        assert!(solve_saturating_s0(x, 2.0).is_err());
    }

    #[test]
    fn solver_rejects_impossible_ratios() {
        let x = [0.10, 0.30, 0.75];
        for rho in [0.0, -0.5, 2.2500001, 2.5, 100.0, f64::NAN, f64::INFINITY] {
            let e = solve_saturating_s0(x, rho).unwrap_err();
            assert!(e.contains("outside (0, 2.25)"), "{rho}: {e}");
        }
        // 2.25 itself is the straight line: 0.45/0.2 rounds just above it, so it is caught
        // by the bracket instead
        assert!(solve_saturating_s0(x, 2.25).is_err());
        // within (0, 2.25) in floating point but indistinguishable from the straight line
        let e = solve_saturating_s0(x, 2.25 - 1e-15).unwrap_err();
        assert!(e.contains("too close"), "{e}");
        for bad in [[0.3, 0.1, 0.75], [0.1, 0.1, 0.75], [0.1, f64::NAN, 0.75]] {
            let e = solve_saturating_s0(bad, 1.0).unwrap_err();
            assert!(e.contains("strictly increasing"), "{e}");
        }
        // a convex rise (slope growing) or a falling one has no saturating curve
        assert!(saturating_through([(0.1, 1.0), (0.3, 2.0), (0.75, 5.0)]).is_err());
        assert!(saturating_through([(0.1, 3.0), (0.3, 2.0), (0.75, 1.0)]).is_err());
        assert!(saturating_through([(0.1, 1.0), (0.3, 2.0), (0.75, 1.5)]).is_err());
        assert!(saturating_through([(0.1, 1.0), (0.3, 1.0), (0.75, 1.5)]).is_err());
    }

    #[test]
    fn rise_check_names_the_key() {
        let ok = [
            Rise::Quadratic([0.0; 3]),
            Rise::Quadratic([1.0, 0.0, 0.5]),
            Rise::Quadratic([1.0, 2.0, -1.0]), // slope 0 at s = 1
            Rise::Saturating {
                r0_k: -1.0,
                span_k: 0.0,
                s0: 0.1,
            },
            Rise::Saturating {
                r0_k: 0.5,
                span_k: 3.0,
                s0: 5.0,
            },
        ];
        for r in ok {
            r.check().unwrap();
        }
        let bad = [
            (Rise::Quadratic([1.0, -0.1, 0.5]), "rise_k"),
            (Rise::Quadratic([1.0, 2.0, -1.01]), "rise_k"),
            (Rise::Quadratic([f64::NAN, 1.0, 0.0]), "rise_k"),
            (Rise::Quadratic([0.0, 1.0, f64::INFINITY]), "rise_k"),
            (
                Rise::Saturating {
                    r0_k: f64::NAN,
                    span_k: 1.0,
                    s0: 0.1,
                },
                "rise_saturating.r0_k",
            ),
            (
                Rise::Saturating {
                    r0_k: 0.0,
                    span_k: -1.0,
                    s0: 0.1,
                },
                "rise_saturating.span_k",
            ),
            (
                Rise::Saturating {
                    r0_k: 0.0,
                    span_k: f64::INFINITY,
                    s0: 0.1,
                },
                "rise_saturating.span_k",
            ),
            (
                Rise::Saturating {
                    r0_k: 0.0,
                    span_k: 1.0,
                    s0: 0.0,
                },
                "rise_saturating.s0",
            ),
            (
                Rise::Saturating {
                    r0_k: 0.0,
                    span_k: 1.0,
                    s0: f64::NAN,
                },
                "rise_saturating.s0",
            ),
        ];
        for (r, key) in bad {
            let (k, m) = r.check().unwrap_err();
            assert_eq!(k, key, "{r:?}: {m}");
            assert!(!m.contains('\n'));
            let e = NodeParams::new("x", 1.0, r).unwrap_err();
            assert!(e.contains(key), "{e}");
        }
        // the saturating form at its ends
        let r = Rise::Saturating {
            r0_k: 0.5,
            span_k: 3.0,
            s0: 0.2,
        };
        assert_eq!(r.at(0.0), 0.5);
        assert!((r.at(0.2) - (0.5 + 3.0 * (1.0 - (-1.0f64).exp()))).abs() < 1e-15);
        assert!((r.at(1e3) - 3.5).abs() < 1e-15);
    }

    #[test]
    fn warm_up_is_first_order() {
        for n in kr15_paper_nodes() {
            let tau_s = n.tau_min * 60.0;
            let amb = KR15_PAPER_AMBIENT_C;
            let rise = n.steady_rise_k(0.30);
            // 1-minute grid over 10 τ with t = τ inserted; start at ambient.
            let mut t_s: Vec<f64> = (0..=(10.0 * n.tau_min) as usize)
                .map(|k| k as f64 * 60.0)
                .collect();
            let at = t_s.partition_point(|&t| t < tau_s);
            t_s.insert(at, tau_s);
            let m = t_s.len();
            let temp = simulate(&n, &t_s, &vec![Some(0.30); m], &vec![amb; m], amb).unwrap();
            let frac = (temp[at] - amb) / rise;
            assert!((frac - (1.0 - (-1.0f64).exp())).abs() < 1e-12, "{frac}");
            assert!((frac - 0.632).abs() < 5e-4);
            let end = (temp[m - 1] - amb) / rise;
            assert!(end > 0.9999, "{}: {end}", n.name);
            // y0 + A·exp(−t/τ) with y0 = amb + rise, A = −rise, at every sample.
            for (t, y) in t_s.iter().zip(&temp) {
                let fit = amb + rise - rise * (-t / tau_s).exp();
                assert!((y - fit).abs() < 1e-10, "{}: t {t}", n.name);
            }
        }
        // Run 1 of the protocol itself: equally spaced increments shrink by exp(−h/τ).
        let n = node("link3");
        let (t_s, speed, ambient, _) = paper_protocol();
        let temp = simulate(&n, &t_s, &speed, &ambient, 23.35).unwrap();
        let ratio = (-(100.0 / n.tau_min)).exp();
        for k in [0, 200, 500, 700] {
            let d1 = temp[k + 100] - temp[k];
            let d2 = temp[k + 200] - temp[k + 100];
            assert!((d2 / d1 - ratio).abs() < 1e-9);
        }
    }

    #[test]
    fn one_big_step_equals_many_small_steps() {
        for n in kr15_paper_nodes() {
            for speed in [None, Some(0.0), Some(0.3), Some(1.0)] {
                let big = n.step(31.0, 22.0, speed, 7200.0);
                // Rounding of the stored temperature (ulp(30 °C) ≈ 3.6e-15) accumulates with the
                // number of steps, hence the looser bound for 7200 one-second steps.
                for (steps, tol) in [(120, 1e-12), (600, 1e-12), (7200, 1e-10)] {
                    let dt = 7200.0 / steps as f64;
                    let mut small = 31.0;
                    for _ in 0..steps {
                        small = n.step(small, 22.0, speed, dt);
                    }
                    assert!((big - small).abs() < tol, "{}: {big} vs {small}", n.name);
                }
                // and via simulate on an irregular grid
                let t_s = [0.0, 0.5, 13.0, 600.0, 601.0, 4000.0, 7200.0];
                let out = simulate(&n, &t_s, &[speed; 7], &[22.0; 7], 31.0).unwrap();
                assert!((out[6] - big).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn idle_cools_to_ambient() {
        let n = node("link2");
        let t = n.step(40.0, 21.0, None, 50.0 * n.tau_min * 60.0);
        assert!((t - 21.0).abs() < 1e-12, "{t}");
        // one τ of idle leaves 1/e of the excess
        let t = n.step(31.0, 21.0, None, n.tau_min * 60.0);
        assert!((t - (21.0 + 10.0 / std::f64::consts::E)).abs() < 1e-12);
        // standstill under servo is not idle: it settles at ambient + r0
        let t = n.step(21.0, 21.0, Some(0.0), 1e9);
        let Rise::Saturating { r0_k, .. } = n.rise else {
            panic!("{:?}", n.rise)
        };
        assert!((t - (21.0 + r0_k)).abs() < 1e-12);
        // at steady state nothing changes
        let ss = n.steady_state_c(21.0, Some(0.4));
        assert_eq!(n.step(ss, 21.0, Some(0.4), 3600.0), ss);
    }

    #[test]
    fn simulate_degenerate_and_invalid_inputs() {
        let n = node("link2");
        assert_eq!(
            simulate(&n, &[], &[], &[], 20.0).unwrap(),
            Vec::<f64>::new()
        );
        assert_eq!(
            simulate(&n, &[5.0], &[Some(0.5)], &[20.0], 25.0).unwrap(),
            vec![25.0]
        );
        // non-increasing time stamps pass no time
        let out = simulate(
            &n,
            &[0.0, 600.0, 600.0, 300.0, 900.0],
            &[Some(1.0); 5],
            &[20.0; 5],
            20.0,
        )
        .unwrap();
        assert_eq!(out[2], out[1]);
        assert_eq!(out[3], out[1]);
        assert!((out[4] - n.step(out[1], 20.0, Some(1.0), 600.0)).abs() < 1e-15);
        let e = simulate(&n, &[0.0, 1.0], &[None], &[20.0, 20.0], 20.0).unwrap_err();
        assert!(e.contains("equal lengths"), "{e}");
        let e = simulate(&n, &[0.0, 1.0], &[None, None], &[20.0], 20.0).unwrap_err();
        assert!(e.contains("equal lengths"), "{e}");
        for bad in [-0.1, 1.5, f64::NAN] {
            let e = simulate(&n, &[0.0, 1.0], &[Some(bad), None], &[20.0; 2], 20.0).unwrap_err();
            assert!(e.contains("speed[0]"), "{e}");
        }
        let e = simulate(&n, &[0.0, f64::NAN], &[None; 2], &[20.0; 2], 20.0).unwrap_err();
        assert!(e.contains("t_s[1]"), "{e}");
        let e = simulate(&n, &[0.0, 1.0], &[None; 2], &[20.0, f64::INFINITY], 20.0).unwrap_err();
        assert!(e.contains("ambient_c[1]"), "{e}");
        assert!(simulate(&n, &[0.0], &[None], &[20.0], f64::NAN).is_err());
        let mut bad = n.clone();
        bad.tau_min = 0.0;
        assert!(simulate(&bad, &[0.0], &[None], &[20.0], 20.0).is_err());
        let flat = Rise::Quadratic([0.0; 3]);
        for tau in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let e = NodeParams::new("x", tau, flat).unwrap_err();
            assert!(e.contains("tau_min"), "{e}");
        }
        assert!(NodeParams::new("x", 1.0, Rise::Quadratic([0.0, f64::NAN, 0.0])).is_err());
        assert!(NodeParams::new(" ", 1.0, flat).is_err());
        assert_eq!(
            NodeParams::new("x", 2.0, Rise::Quadratic([1.0, 2.0, 3.0])).unwrap(),
            NodeParams {
                name: "x".into(),
                tau_min: 2.0,
                rise: Rise::Quadratic([1.0, 2.0, 3.0])
            }
        );
        // dt ≤ 0 in step
        assert_eq!(n.step(30.0, 20.0, Some(1.0), 0.0), 30.0);
        assert_eq!(n.step(30.0, 20.0, Some(1.0), -5.0), 30.0);
    }

    #[test]
    fn lag_of_a_ramp_is_exact() {
        let tau = 300.0;
        let c = 0.01; // K/s
        let t_s = [0.0, 1.0, 7.5, 100.0, 101.0, 900.0, 2000.0, 20000.0];
        let x: Vec<f64> = t_s.iter().map(|t| 5.0 + c * t).collect();
        let y = first_order_lag(&t_s, &x, tau).unwrap();
        for (t, y) in t_s.iter().zip(&y) {
            let want = 5.0 + c * (t - tau * (1.0 - (-t / tau).exp()));
            assert!((y - want).abs() < 1e-12, "t {t}: {y} vs {want}");
        }
        // lags the ramp by c·τ in the end
        assert!((x[7] - y[7] - c * tau).abs() < 1e-9);
    }

    #[test]
    fn lag_of_a_step_is_exact() {
        // x = 0 until t = 50, jumps to 2 (repeated time stamp), then constant.
        let tau = 40.0;
        let t_s = [0.0, 20.0, 50.0, 50.0, 60.0, 90.0, 250.0];
        let x = [0.0, 0.0, 0.0, 2.0, 2.0, 2.0, 2.0];
        let y = first_order_lag(&t_s, &x, tau).unwrap();
        assert_eq!(&y[..4], &[0.0; 4]);
        for k in 4..7 {
            let want = 2.0 * (1.0 - (-(t_s[k] - 50.0) / tau).exp());
            assert!((y[k] - want).abs() < 1e-12, "{k}: {} vs {want}", y[k]);
        }
        // starting off equilibrium with constant x: pure decay (y0 = x0, so use a first jump)
        let y = first_order_lag(&[0.0, 0.0, 1e6], &[1.0, 3.0, 3.0], tau).unwrap();
        assert_eq!(y[1], 1.0);
        assert!((y[2] - 3.0).abs() < 1e-12);
    }

    #[test]
    fn lag_converges_for_dense_samples() {
        // x = sin(ωt), y(0) = 0: y = (sin ωt − ωτ cos ωt + ωτ e^{−t/τ}) / (1 + ω²τ²).
        let (tau, w, t_end) = (120.0, 2.0 * std::f64::consts::PI / 900.0, 3000.0);
        let wt = w * tau;
        let exact =
            |t: f64| ((w * t).sin() - wt * (w * t).cos() + wt * (-t / tau).exp()) / (1.0 + wt * wt);
        let err = |n: usize| {
            let t_s: Vec<f64> = (0..=n).map(|k| t_end * k as f64 / n as f64).collect();
            let x: Vec<f64> = t_s.iter().map(|t| (w * t).sin()).collect();
            let y = first_order_lag(&t_s, &x, tau).unwrap();
            t_s.iter()
                .zip(&y)
                .map(|(t, y)| (y - exact(*t)).abs())
                .fold(0.0, f64::max)
        };
        let errs: Vec<f64> = [25, 50, 100, 200, 400].into_iter().map(err).collect();
        for e in errs.windows(2) {
            let ratio = e[0] / e[1];
            assert!((3.5..4.5).contains(&ratio), "second order: {errs:?}");
        }
        assert!(errs[4] < 5e-4, "{errs:?}");
    }

    #[test]
    fn lag_degenerate_inputs() {
        let t_s = [0.0, 10.0, 20.0];
        let x = [1.0, 5.0, -2.0];
        assert_eq!(first_order_lag(&t_s, &x, 0.0).unwrap(), x.to_vec());
        assert_eq!(first_order_lag(&[], &[], 5.0).unwrap(), Vec::<f64>::new());
        assert_eq!(first_order_lag(&[3.0], &[7.0], 5.0).unwrap(), vec![7.0]);
        assert_eq!(
            first_order_lag(&t_s, &x, f64::INFINITY).unwrap(),
            vec![1.0; 3]
        );
        // non-increasing time: no time passes
        let y = first_order_lag(&[0.0, 10.0, 5.0, 10.0], &[0.0, 1.0, 9.0, 9.0], 10.0).unwrap();
        assert_eq!(y[2], y[1]);
        // tiny and huge steps stay finite and sensible
        let y = first_order_lag(&[0.0, 1e-300, 1e300], &[0.0, 1.0, 1.0], 1.0).unwrap();
        assert!(y[1].abs() < 1e-299 && (y[2] - 1.0).abs() < 1e-15, "{y:?}");
        let y = first_order_lag(&[0.0, 1.0], &[0.0, 1.0], 1e-300).unwrap();
        assert_eq!(y[1], 1.0);
        assert!(first_order_lag(&t_s, &x[..2], 1.0)
            .unwrap_err()
            .contains("equal lengths"));
        for tau in [-1.0, f64::NAN] {
            assert!(first_order_lag(&t_s, &x, tau)
                .unwrap_err()
                .contains("tau_s"));
        }
        // NaN propagates rather than being hidden
        let y = first_order_lag(&[0.0, 1.0, 2.0], &[0.0, f64::NAN, 1.0], 1.0).unwrap();
        assert!(y[1].is_nan() && y[2].is_nan());
    }
}
