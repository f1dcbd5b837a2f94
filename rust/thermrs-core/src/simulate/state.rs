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
