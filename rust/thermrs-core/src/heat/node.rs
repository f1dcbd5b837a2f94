//! Lumped thermal nodes: one heat capacity per region the IR camera sees, stepped exactly.
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

use super::HeatError;
use crate::error::KeyError;

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
    pub fn check(&self) -> Result<(), KeyError> {
        match *self {
            Rise::Quadratic(r) => {
                if let Some(v) = r.iter().find(|v| !v.is_finite()) {
                    return Err(KeyError::new(
                        "rise_k",
                        format!("has {v}, expected finite numbers"),
                    ));
                }
                let [_, r1, r2] = r;
                if !(r1 >= 0.0 && r1 + 2.0 * r2 >= 0.0) {
                    return Err(KeyError::new(
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
                    return Err(KeyError::new(
                        "rise_saturating.r0_k",
                        format!("is {r0_k}, expected a finite number"),
                    ));
                }
                if !(span_k.is_finite() && span_k >= 0.0) {
                    return Err(KeyError::new(
                        "rise_saturating.span_k",
                        format!("is {span_k}, expected a finite number ≥ 0"),
                    ));
                }
                if !(s0.is_finite() && s0 > 0.0) {
                    return Err(KeyError::new(
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
    pub fn new(name: impl Into<String>, tau_min: f64, rise: Rise) -> Result<Self, HeatError> {
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
    pub fn validate(&self) -> Result<(), HeatError> {
        if self.name.trim().is_empty() {
            return Err(HeatError::EmptyName);
        }
        if !(self.tau_min.is_finite() && self.tau_min > 0.0) {
            return Err(HeatError::Node {
                node: self.name.clone(),
                error: KeyError::new(
                    "tau_min",
                    format!("must be finite and > 0, got {}", self.tau_min),
                ),
            });
        }
        self.rise.check().map_err(|error| HeatError::Node {
            node: self.name.clone(),
            error,
        })
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
) -> Result<Vec<f64>, HeatError> {
    node.validate()?;
    let series = |message: String| HeatError::Series {
        context: format!("simulate {:?}", node.name),
        message,
    };
    let n = t_s.len();
    if speed.len() != n || ambient_c.len() != n {
        return Err(series(format!(
            "t_s, speed and ambient_c must have equal lengths, got {}, {} and {}",
            n,
            speed.len(),
            ambient_c.len()
        )));
    }
    if !t0_c.is_finite() {
        return Err(series(format!(
            "start temperature must be finite, got {t0_c}"
        )));
    }
    if let Some(k) = t_s.iter().position(|t| !t.is_finite()) {
        return Err(series(format!("t_s[{k}] = {} is not finite", t_s[k])));
    }
    if let Some(k) = ambient_c.iter().position(|a| !a.is_finite()) {
        return Err(series(format!(
            "ambient_c[{k}] = {} is not finite",
            ambient_c[k]
        )));
    }
    for (k, s) in speed.iter().enumerate() {
        if let Some(s) = *s {
            if !(0.0..=1.0).contains(&s) {
                return Err(series(format!(
                    "speed[{k}] = {s} is outside [0, 1] (fraction of maximum)"
                )));
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
