//! Surface vs structure: the first-order lag [`first_order_lag`] (SPEC §6 `thermal_lag`).
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

use super::HeatError;

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
pub fn first_order_lag(t_s: &[f64], x: &[f64], tau_s: f64) -> Result<Vec<f64>, HeatError> {
    let series = |message: String| HeatError::Series {
        context: "first_order_lag".into(),
        message,
    };
    if t_s.len() != x.len() {
        return Err(series(format!(
            "t_s and x must have equal lengths, got {} and {}",
            t_s.len(),
            x.len()
        )));
    }
    if tau_s.is_nan() || tau_s < 0.0 {
        return Err(series(format!("tau_s must be >= 0, got {tau_s}")));
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
