//! What changes as a simulation runs: the clock, the node temperatures (surface and lagging
//! structure), the last joint position, the per-sensor random streams and the truth so far.

use rand::rngs::StdRng;
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

use super::setup::Setup;
use super::Truth;
use crate::scenario::{AmbientProfile, Run, Start};

/// The room's temperature at `t_s` seconds since the first run's start: drift plus a daily
/// swing.
pub(super) fn ambient_at(amb: &AmbientProfile, t_s: f64) -> f64 {
    amb.start_c
        + amb.drift_c_per_h * t_s / 3600.0
        + amb.swing_c * (2.0 * std::f64::consts::PI * t_s / 86_400.0).sin()
}

/// The temperature at `t_s` of a camera mount that follows the room through a first-order lag
/// `tau_s` (`fixture_drift`'s `mount_tau_min`), at the room's temperature when the first run
/// starts: the closed form of the lag of [`ambient_at`]'s drift and daily sine.
pub(super) fn mount_at(amb: &AmbientProfile, t_s: f64, tau_s: f64) -> f64 {
    if tau_s <= 0.0 || t_s <= 0.0 {
        return ambient_at(amb, t_s);
    }
    let b = amb.drift_c_per_h / 3600.0;
    let w = 2.0 * std::f64::consts::PI / 86_400.0;
    let decay = (-t_s / tau_s).exp();
    let wt = w * tau_s;
    let sine =
        amb.swing_c * ((w * t_s).sin() - wt * (w * t_s).cos() + wt * decay) / (1.0 + wt * wt);
    amb.start_c + b * (t_s - tau_s) + b * tau_s * decay + sine
}

/// The running state of a simulation.
pub(super) struct State {
    /// Motion noise (repeatability).
    pub(super) rng: StdRng,
    /// CCD frame noise (a pixel's background is one draw of half of 64 bits: xoshiro256++,
    /// which is fast, passes the statistical test batteries and is reproducible).
    pub(super) ccd_rng: Xoshiro256PlusPlus,
    /// IR frame and thermometer noise.
    pub(super) ir_rng: StdRng,
    /// Per node: what the IR camera sees and what expands.
    pub(super) surface: Vec<f64>,
    pub(super) structure: Vec<f64>,
    /// Seconds since the scenario's start (`Setup::t0_ns`).
    pub(super) t_s: f64,
    /// The last joint position (`None` before the first move).
    pub(super) q_cur: Option<[f64; 6]>,
    pub(super) truth: Truth,
}

impl State {
    /// The start: nodes at ambient, the clock at 0, one seeded stream per sensor.
    pub(super) fn new(setup: &Setup<'_>) -> State {
        let sc = setup.sc;
        // Independent streams, so that what one sensor draws never shifts another's noise (an
        // effect on one camera leaves every other truth unchanged).
        let stream =
            |k: u64| StdRng::seed_from_u64(sc.seed ^ k.wrapping_mul(0x9E37_79B9_7F4A_7C15));
        let truth = Truth {
            node_names: setup.nodes.iter().map(|n| n.name.clone()).collect(),
            length_names: setup
                .model
                .expanding_lengths()
                .iter()
                .map(|(l, _)| l.to_string())
                .collect(),
            ..Truth::default()
        };
        let surface: Vec<f64> = setup
            .nodes
            .iter()
            .map(|_| ambient_at(&sc.ambient, 0.0))
            .collect();
        State {
            rng: stream(1),
            ccd_rng: Xoshiro256PlusPlus::seed_from_u64(
                sc.seed ^ 2u64.wrapping_mul(0x9E37_79B9_7F4A_7C15),
            ),
            ir_rng: stream(3),
            structure: surface.clone(),
            surface,
            t_s: 0.0,
            q_cur: None,
            truth,
        }
    }

    /// Idle (cooling) before run `ri`; a run that starts at ambient resets every node.
    pub(super) fn idle_before(&mut self, setup: &Setup<'_>, ri: usize, run: &Run) {
        let amb = &setup.sc.ambient;
        let idle = setup.idle_s[ri];
        if run.start == Start::Ambient || ri == 0 {
            let a = ambient_at(amb, self.t_s + idle);
            self.surface.iter_mut().for_each(|s| *s = a);
            self.structure = self.surface.clone();
            self.t_s += idle;
        } else if idle > 0.0 {
            let dt = idle;
            let a = ambient_at(amb, self.t_s + dt / 2.0);
            self.step_nodes(setup, a, None, dt);
            self.t_s += dt;
        }
    }

    /// Step every node `dt` seconds at ambient `a` and duty `speed` (`None`: idle).
    pub(super) fn step_nodes(&mut self, setup: &Setup<'_>, a: f64, speed: Option<f64>, dt: f64) {
        for (k, n) in setup.nodes.iter().enumerate() {
            let before = self.surface[k];
            self.surface[k] = n.step(before, a, speed, dt);
            self.structure[k] =
                setup
                    .fx
                    .structure_step(before, self.surface[k], self.structure[k], dt);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closed form against the lag integrated step by step on a fine grid
    /// ([`crate::heat::first_order_lag`]) of the room's own series.
    #[test]
    fn the_mounts_closed_form_is_the_lag_of_the_room() {
        let amb = AmbientProfile {
            start_c: 21.0,
            drift_c_per_h: 0.3,
            swing_c: 1.5,
            ..AmbientProfile::default()
        };
        let tau = 25.0 * 60.0;
        let t: Vec<f64> = (0..=48 * 360).map(|k| 10.0 * k as f64).collect();
        let x: Vec<f64> = t.iter().map(|&tk| ambient_at(&amb, tk)).collect();
        let y = crate::heat::first_order_lag(&t, &x, tau).unwrap();
        for k in (0..t.len()).step_by(97) {
            assert!(
                (mount_at(&amb, t[k], tau) - y[k]).abs() < 1e-6,
                "t = {}",
                t[k]
            );
        }
        assert_eq!(mount_at(&amb, 3600.0, 0.0), ambient_at(&amb, 3600.0));
    }
}
