//! The simulator: a rig at work under a scenario, written as a real recording (SPEC §2).
//!
//! Per run and cycle the robot visits every camera's pose in turn: it moves (joint states),
//! dwells (joint states with repeatability noise, CCD frames of that camera), then the thermal
//! camera and the ambient thermometer report. Temperatures come from the lumped thermal model
//! ([`crate::heat`]) stepped exactly cycle by cycle; the structure may lag the surface
//! (`thermal_lag`); the spot comes from the one forward model ([`crate::model`]) with every
//! geometric effect, plus the chip shifts (`fixture_drift`, `sensor_drift`). Frames are made
//! and written one at a time (memory does not grow with the run), and every random draw comes
//! from one seeded generator, so the same seed gives byte-identical files.
//!
//! CCD frames: a pixel-integrated Gaussian spot (erf differences) of σ `sigma_px` and peak
//! `peak_dn` above background; within ±5σ of the spot every pixel gets Poisson shot noise on
//! signal + background electrons plus Gaussian read noise; elsewhere the background's Poisson
//! noise (mean ≥ 16 e⁻ by default) is drawn as its Gaussian equivalent for speed. Rounded and
//! clipped to 8 or 16 bits. IR frames: ambient plus a Gaussian hot region per ROI whose peak is
//! the node's surface temperature, a hot distractor outside every ROI, Gaussian noise.
//!
//! Files: `setup` (effects, model, nodes, writer), `trajectory` (a cycle's moves and
//! dwells), `render` (CCD and IR pixels), `sensors` (one cycle's messages and truth),
//! `state` (clock, temperatures, random streams); this file runs the runs and cycles.

use std::io::{Seek, Write};

use crate::error::{Error, Result};
use crate::record::RecordingWriter;
use crate::rig::Rig;
use crate::scenario::Scenario;

mod render;
mod sensors;
mod setup;
mod state;
mod trajectory;

use sensors::Cycle;
use setup::{write_error, Setup};
use state::State;

/// Transport delay between a message's stamp and its log time.
const LOG_DELAY_NS: i64 = 2_000_000;
/// When the first run starts unless the scenario says: [`crate::scenario::T0_NS`].
pub use crate::scenario::T0_NS;

/// Most sub-exposure samples of a spot that moves during a frame (its smear).
const MAX_SMEAR_SAMPLES: usize = 4096;

/// Ground truth of a simulation, column by column.
#[derive(Debug, Default, Clone)]
pub struct Truth {
    /// Per CCD frame: camera index, stamp, run index, true spot (px, SPEC §4).
    pub frame_camera: Vec<u32>,
    pub frame_t_ns: Vec<i64>,
    pub frame_run: Vec<u32>,
    pub frame_x_px: Vec<f64>,
    pub frame_y_px: Vec<f64>,
    /// Per thermal sample (one per IR frame): stamp, run, ambient, then per node the surface
    /// and structure temperatures (`node_names` order, row-major N × nodes).
    pub sample_t_ns: Vec<i64>,
    pub sample_run: Vec<u32>,
    pub sample_ambient_c: Vec<f64>,
    pub node_names: Vec<String>,
    pub surface_c: Vec<f64>,
    pub structure_c: Vec<f64>,
    /// Per thermal sample the true length (mm) of every expanding DH length (`length_names`
    /// order, row-major N × lengths), from the structure temperatures with every effect.
    pub length_names: Vec<String>,
    pub lengths_mm: Vec<f64>,
}

/// Simulate `scenario` on `rig`, writing the recording to `out`; returns the truth.
pub fn simulate<W: Write + Seek>(rig: &Rig, sc: &Scenario, out: W) -> Result<(W, Truth)> {
    simulate_cancellable(rig, sc, out, &|| false)
}

/// [`simulate`], asking `cancel` before every cycle and every CCD frame: once it returns
/// `true` the simulation stops with [`Error::Interrupted`] (how the bindings honour Ctrl-C).
/// A failed write is [`Error::Write`].
pub fn simulate_cancellable<W: Write + Seek>(
    rig: &Rig,
    sc: &Scenario,
    out: W,
    cancel: &dyn Fn() -> bool,
) -> Result<(W, Truth)> {
    let setup = Setup::new(rig, sc)?;
    let mut wr = setup.writer(out)?;
    let truth = run_scenario(&setup, Some(&mut wr), cancel)?;
    let out = wr.finish().map_err(write_error)?;
    Ok((out, truth))
}

/// The truth of [`simulate`] without the recording: the same runs, cycles, motion and thermal
/// state, so the same truth to the last bit (every sensor draws from its own random stream),
/// but no pixel is rendered and nothing is written. What a forecast needs (where and when the
/// visits are, the temperatures) at a small fraction of the cost. Asks `cancel` like
/// [`simulate_cancellable`].
pub fn simulate_truth(rig: &Rig, sc: &Scenario, cancel: &dyn Fn() -> bool) -> Result<Truth> {
    let setup = Setup::new(rig, sc)?;
    run_scenario::<std::io::Cursor<Vec<u8>>>(&setup, None, cancel)
}

/// Every run and cycle of the scenario; messages go to `wr` when there is one.
fn run_scenario<W: Write + Seek>(
    setup: &Setup<'_>,
    mut wr: Option<&mut RecordingWriter<W>>,
    cancel: &dyn Fn() -> bool,
) -> Result<Truth> {
    let (rig, sc) = (setup.rig, setup.sc);
    let mut st = State::new(setup);
    for (ri, run) in sc.run.iter().enumerate() {
        st.idle_before(setup, ri, run);
        let run_start_s = st.t_s;
        let speed = run.speed_pct / 100.0;
        let cycles = (run.duration_min * 60.0 / run.cycle_s).floor() as usize;
        let slot = run.cycle_s / (rig.camera.len() as f64 + 1.0);
        for _ in 0..cycles {
            if cancel() {
                return Err(Error::Interrupted);
            }
            let cycle_t = st.t_s;
            let segs = trajectory::plan_cycle(rig, sc, cycle_t, speed, &mut st.q_cur, &mut st.rng);
            let t_ir = cycle_t + rig.camera.len() as f64 * slot;
            let t = trajectory::end_of(&segs);
            if t > t_ir {
                return Err(Error::CycleTooShort {
                    run: run.name.clone(),
                    motion_s: t - cycle_t,
                    available_s: t_ir - cycle_t,
                });
            }
            let c = Cycle {
                ri,
                run,
                speed,
                run_start_s,
                cycle_t,
                t_ir,
                segs,
            };
            if let Some(w) = wr.as_deref_mut() {
                sensors::joint_states(setup, w, &c)?;
            }
            sensors::ccd_frames(setup, &mut st, wr.as_deref_mut(), &c, cancel)?;
            sensors::thermal(setup, &mut st, wr.as_deref_mut(), &c)?;
            // Advance the thermal state over the cycle (running at the run's speed).
            let a_mid = state::ambient_at(&sc.ambient, cycle_t + run.cycle_s / 2.0);
            st.step_nodes(setup, a_mid, Some(speed), run.cycle_s);
            st.t_s = cycle_t + run.cycle_s;
        }
        if let Some(w) = wr.as_deref_mut() {
            let stamp = |t: f64| setup.t0_ns + (t * 1e9).round() as i64;
            w.write_run_marker(
                &run.name,
                stamp(run_start_s),
                stamp(st.t_s),
                Some(run.speed_pct),
            )
            .map_err(write_error)?;
        }
    }
    Ok(st.truth)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn paper_rig() -> Rig {
        Rig::from_path(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../python/thermrs/data/kr15-paper.toml"
        ))
        .unwrap()
    }

    const SCENARIO: &str = r#"
format = "thermrs-scenario/1"
name = "two short runs, a lag and a chip drift"
seed = 11

[[run]]
name = "a"
speed_pct = 75
duration_min = 30
cycle_s = 60
start = "ambient"

[[run]]
name = "b"
speed_pct = 10
duration_min = 20
cycle_s = 60
start = "continue"
idle_before_min = 15

[ambient]
start_c = 22.0
drift_c_per_h = 0.4
noise_c = 0.02

[camera]
mode = "visits"
frames_per_visit = 2

[[effect]]
name = "thermal_lag"
tau_min = 40.0

[[effect]]
name = "fixture_drift"
camera = "A"
um_per_k = [0.8, -0.5]
"#;

    fn bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    #[test]
    fn the_truth_alone_is_the_recordings_truth_to_the_bit() {
        let rig = paper_rig();
        let sc = Scenario::from_toml(SCENARIO, "test").unwrap();
        let (bytes, full) = simulate(&rig, &sc, std::io::Cursor::new(Vec::new())).unwrap();
        assert!(
            bytes.into_inner().len() > 100_000,
            "a recording was written"
        );
        let only = simulate_truth(&rig, &sc, &|| false).unwrap();
        assert!(full.frame_t_ns.len() > 50 && full.sample_t_ns.len() > 40);
        assert_eq!(only.frame_camera, full.frame_camera);
        assert_eq!(only.frame_t_ns, full.frame_t_ns);
        assert_eq!(only.frame_run, full.frame_run);
        assert_eq!(bits(&only.frame_x_px), bits(&full.frame_x_px));
        assert_eq!(bits(&only.frame_y_px), bits(&full.frame_y_px));
        assert_eq!(only.sample_t_ns, full.sample_t_ns);
        assert_eq!(only.sample_run, full.sample_run);
        assert_eq!(bits(&only.sample_ambient_c), bits(&full.sample_ambient_c));
        assert_eq!(bits(&only.surface_c), bits(&full.surface_c));
        assert_eq!(bits(&only.structure_c), bits(&full.structure_c));
        assert_eq!(bits(&only.lengths_mm), bits(&full.lengths_mm));
        assert_eq!(only.node_names, full.node_names);
        assert_eq!(only.length_names, full.length_names);
    }

    #[test]
    fn the_truth_alone_stops_when_asked() {
        let rig = paper_rig();
        let sc = Scenario::from_toml(SCENARIO, "test").unwrap();
        let e = simulate_truth(&rig, &sc, &|| true).unwrap_err();
        assert!(matches!(e, Error::Interrupted));
    }
}
