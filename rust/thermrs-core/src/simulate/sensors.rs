//! One cycle's messages: joint states along the trajectory, CCD frames of each camera's spot
//! (with its smear while the robot moves), then the thermal camera and the thermometer that
//! close the cycle; and the truth of each.

use std::io::{Seek, Write};

use rand_distr::{Distribution, StandardNormal};

use super::render::{render_ccd, render_ir};
use super::setup::{write_error, Setup};
use super::state::{ambient_at, mount_at, State};
use super::trajectory::{self, Segment};
use super::{LOG_DELAY_NS, MAX_SMEAR_SAMPLES};
use crate::error::{Error, Result};
use crate::record::{ImageFields, RecordingWriter};
use crate::rig::{LengthRef, Thermal};
use crate::scenario::Run;

/// Where one cycle is in the scenario.
pub(super) struct Cycle<'s> {
    /// The run's index and the run.
    pub(super) ri: usize,
    pub(super) run: &'s Run,
    /// Speed, fraction of maximum.
    pub(super) speed: f64,
    /// When the run and this cycle started (s since the scenario's start).
    pub(super) run_start_s: f64,
    pub(super) cycle_t: f64,
    /// When the thermal camera closes the cycle (s since the scenario's start).
    pub(super) t_ir: f64,
    pub(super) segs: Vec<Segment>,
}

/// Joint states on a regular grid and at every segment boundary.
pub(super) fn joint_states<W: Write + Seek>(
    setup: &Setup<'_>,
    wr: &mut RecordingWriter<W>,
    c: &Cycle<'_>,
) -> Result<()> {
    let rig = setup.rig;
    for tq_s in trajectory::joint_times(&c.segs, setup.sc, c.cycle_t, c.run.cycle_s) {
        let tq = setup.t0_ns + (tq_s * 1e9).round() as i64;
        wr.write_joint_state(
            &rig.robot.joint_states_topic,
            (tq + LOG_DELAY_NS) as u64,
            tq,
            "base",
            &rig.robot.joint_names,
            &trajectory::q_at(&c.segs, tq_s),
        )
        .map_err(write_error)?;
    }
    Ok(())
}

/// Where camera `ci`'s spot is at time `t` (px, with the chip effects), and whether it is on
/// the chip. `tcols` are the model's temperatures (constant within a cycle).
fn spot_at(
    setup: &Setup<'_>,
    c: &Cycle<'_>,
    tcols: &[&[f64]],
    ci: usize,
    t: f64,
) -> Result<(f64, f64, bool)> {
    let cam = &setup.rig.camera[ci];
    let mut out = [0.0; crate::model::SPOT_WIDTH];
    let q = trajectory::q_at(&c.segs, t);
    setup.model.spot_batch(ci, &q, Some(tcols), &mut out)?;
    let (mut x, mut y) = (out[0], out[1]);
    let amb = ambient_at(&setup.sc.ambient, t);
    let mount = setup
        .fx
        .mount_lag_s(ci)
        .map_or(amb, |tau| mount_at(&setup.sc.ambient, t, tau));
    let d = setup.fx.chip_shift_um(ci, amb, mount, t - c.run_start_s);
    x += d[0] / cam.pixel_pitch_um[0];
    y += d[1] / cam.pixel_pitch_um[1];
    let (w, h) = (cam.size_px[0] as f64, cam.size_px[1] as f64);
    let on = x.is_finite()
        && y.is_finite()
        && (-0.5..=w - 0.5).contains(&x)
        && (-0.5..=h - 0.5).contains(&y);
    Ok((x, y, on))
}

/// Frame times per camera: during its dwell (visits) or all cycle long (continuous), in time
/// order.
fn frame_times(setup: &Setup<'_>, c: &Cycle<'_>) -> Vec<(f64, usize)> {
    let cam = &setup.sc.camera;
    let frame_dt = 1.0 / cam.frame_rate_hz;
    let mut frames: Vec<(f64, usize)> = Vec::new();
    for (ci, _) in setup.rig.camera.iter().enumerate() {
        if cam.mode == "continuous" {
            let n = (c.run.cycle_s * cam.frame_rate_hz).floor() as usize;
            frames.extend((0..n).map(|f| {
                (
                    c.cycle_t + f as f64 * frame_dt + ci as f64 * 0.25 * frame_dt,
                    ci,
                )
            }));
        } else if let Some(sg) = c.segs.iter().find(|sg| sg.dwell == Some(ci)) {
            frames
                .extend((0..cam.frames_per_visit).map(|f| (sg.t0 + 0.5 + f as f64 * frame_dt, ci)));
        }
    }
    frames.sort_by(|a, b| a.0.total_cmp(&b.0));
    frames
}

/// The spot's on-chip path during an exposure from `tf_s`: enough sub-exposure samples that
/// neighbours are ≤ σ/2 apart (a continuous streak rather than a row of separate spots), one
/// point when still. Returns the path and the number of samples.
fn exposure_path(
    setup: &Setup<'_>,
    c: &Cycle<'_>,
    tcols: &[&[f64]],
    ci: usize,
    tf_s: f64,
) -> Result<(Vec<(f64, f64)>, usize)> {
    let cam = &setup.sc.camera;
    let subs = if trajectory::moving(&c.segs, tf_s, cam.exposure_s) {
        let a = spot_at(setup, c, tcols, ci, tf_s)?;
        let b = spot_at(setup, c, tcols, ci, tf_s + cam.exposure_s)?;
        let len = (b.0 - a.0).hypot(b.1 - a.1);
        if len.is_finite() {
            ((len / (0.5 * cam.sigma_px)).ceil() as usize).clamp(2, MAX_SMEAR_SAMPLES)
        } else {
            MAX_SMEAR_SAMPLES
        }
    } else {
        1
    };
    let mut path = Vec::with_capacity(subs);
    for k in 0..subs {
        let ts = tf_s + cam.exposure_s * (k as f64 + 0.5) / subs as f64;
        let (x, y, on) = spot_at(setup, c, tcols, ci, ts)?;
        if on {
            path.push((x, y));
        }
    }
    Ok((path, subs))
}

/// Every CCD frame of the cycle, rendered and written one at a time, with its true spot (the
/// mean of its on-chip path; NaN when off the chip). Asks `cancel` before each.
pub(super) fn ccd_frames<W: Write + Seek>(
    setup: &Setup<'_>,
    st: &mut State,
    mut wr: Option<&mut RecordingWriter<W>>,
    c: &Cycle<'_>,
    cancel: &dyn Fn() -> bool,
) -> Result<()> {
    // Temperatures are stepped per cycle; within a cycle the structure is taken as constant
    // (minutes against time constants of hours).
    let seen: Vec<f64> = (st.surface.iter().zip(&st.structure))
        .map(|(&x, &y)| setup.fx.structure_seen(x, y))
        .collect();
    let temps = setup.model_temperatures(&seen, ambient_at(&setup.sc.ambient, c.cycle_t));
    let tcols: Vec<&[f64]> = temps.iter().map(std::slice::from_ref).collect();
    let cam = &setup.sc.camera;
    let bpp = if cam.bits == 8 { 1 } else { 2 };
    for (tf_s, ci) in frame_times(setup, c) {
        if cancel() {
            return Err(Error::Interrupted);
        }
        let camera = &setup.rig.camera[ci];
        let (path, subs) = exposure_path(setup, c, &tcols, ci, tf_s)?;
        let weight = 1.0 / subs as f64;
        let tf = setup.t0_ns + (tf_s * 1e9).round() as i64;
        if let Some(wr) = wr.as_deref_mut() {
            let (w, h) = (camera.size_px[0] as usize, camera.size_px[1] as usize);
            let fields = ImageFields {
                stamp_ns: tf,
                frame_id: &camera.name,
                width: w as u32,
                height: h as u32,
                encoding: if bpp == 1 { "mono8" } else { "mono16" },
                is_bigendian: false,
                step: (w * bpp) as u32,
            };
            let rng = &mut st.ccd_rng;
            wr.write_image_with(
                &camera.topic,
                (tf + LOG_DELAY_NS) as u64,
                &fields,
                w * h * bpp,
                |buf| {
                    render_ccd(
                        buf,
                        w,
                        h,
                        bpp,
                        &path,
                        weight,
                        cam,
                        &setup.ccd_background,
                        rng,
                    )
                },
            )
            .map_err(write_error)?;
        }
        let n = path.len() as f64;
        let (x, y) = if path.is_empty() {
            (f64::NAN, f64::NAN)
        } else {
            (
                path.iter().map(|p| p.0).sum::<f64>() / n,
                path.iter().map(|p| p.1).sum::<f64>() / n,
            )
        };
        let truth = &mut st.truth;
        truth.frame_camera.push(ci as u32);
        truth.frame_t_ns.push(tf);
        truth.frame_run.push(c.ri as u32);
        truth.frame_x_px.push(x);
        truth.frame_y_px.push(y);
    }
    Ok(())
}

/// An IR frame in °C as the camera sends it: `32FC1` floats, or `16UC1` counts through the
/// rig's scale and offset.
fn ir_payload(img: &[f64], th: &Thermal, encoding: &str) -> (&'static str, Vec<u8>) {
    if encoding == "32FC1" {
        (
            "32FC1",
            img.iter().flat_map(|v| (*v as f32).to_le_bytes()).collect(),
        )
    } else {
        (
            "16UC1",
            img.iter()
                .flat_map(|v| {
                    (((v - th.offset_c) / th.scale).round().clamp(0.0, 65535.0) as u16)
                        .to_le_bytes()
                })
                .collect(),
        )
    }
}

/// The thermal camera and the thermometer close the cycle, seeing the temperatures of their
/// own time (the state stepped from the cycle's start to `t_ir`); the truth sample with every
/// expanded length.
pub(super) fn thermal<W: Write + Seek>(
    setup: &Setup<'_>,
    st: &mut State,
    wr: Option<&mut RecordingWriter<W>>,
    c: &Cycle<'_>,
) -> Result<()> {
    let sc = setup.sc;
    let ambient = ambient_at(&sc.ambient, c.t_ir);
    let into = c.t_ir - c.cycle_t;
    let a_ir = ambient_at(&sc.ambient, c.cycle_t + into / 2.0);
    let surface_ir: Vec<f64> = setup
        .nodes
        .iter()
        .zip(&st.surface)
        .map(|(n, &t)| n.step(t, a_ir, Some(c.speed), into))
        .collect();
    let structure_ir: Vec<f64> = (0..setup.nodes.len())
        .map(|k| {
            setup
                .fx
                .structure_step(st.surface[k], surface_ir[k], st.structure[k], into)
        })
        .zip(&surface_ir)
        .map(|(y, &x)| setup.fx.structure_seen(x, y))
        .collect();
    let ti = setup.t0_ns + (c.t_ir * 1e9) as i64;
    if let Some(wr) = wr {
        write_thermal(setup, st, wr, &surface_ir, ambient, ti)?;
    }
    let truth = &mut st.truth;
    truth.sample_t_ns.push(ti);
    truth.sample_run.push(c.ri as u32);
    truth.sample_ambient_c.push(ambient);
    truth.surface_c.extend_from_slice(&surface_ir);
    truth.structure_c.extend_from_slice(&structure_ir);
    let temps_ir = setup.model_temperatures(&structure_ir, ambient);
    let (a_mm, d_mm) = setup.model.lengths_at(Some(&temps_ir));
    for (l, _) in setup.model.expanding_lengths() {
        truth.lengths_mm.push(match *l {
            LengthRef::A(r) => a_mm[r],
            LengthRef::D(r) => d_mm[r],
        });
    }
    Ok(())
}

/// The cycle's IR frames (the surface temperatures `surface_ir`) and thermometer readings at
/// `ti`, written to `wr`.
fn write_thermal<W: Write + Seek>(
    setup: &Setup<'_>,
    st: &mut State,
    wr: &mut RecordingWriter<W>,
    surface_ir: &[f64],
    ambient: f64,
    ti: i64,
) -> Result<()> {
    let (sc, th) = (setup.sc, setup.th);
    for _ in 0..sc.ir.frames_per_cycle.max(1) {
        let roi_c: Vec<(usize, f64)> = setup
            .node_roi
            .iter()
            .zip(surface_ir)
            .map(|(&r, &t)| (r, t))
            .collect();
        let img = render_ir(setup.rig, sc, ambient, &roi_c, &mut st.ir_rng);
        let (w, h) = (th.size_px[0] as u32, th.size_px[1] as u32);
        let (encoding, data) = ir_payload(&img, th, &sc.ir.encoding);
        let fields = ImageFields {
            stamp_ns: ti,
            frame_id: "thermal",
            width: w,
            height: h,
            encoding,
            is_bigendian: false,
            step: w * if encoding == "32FC1" { 4 } else { 2 },
        };
        wr.write_image(&th.topic, (ti + LOG_DELAY_NS) as u64, &fields, &data)
            .map_err(write_error)?;
    }
    if let Some(a) = &setup.rig.ambient {
        for r in 0..sc.ambient.readings_per_cycle {
            let z: f64 = StandardNormal.sample(&mut st.ir_rng);
            let tr = ti + r as i64 * 1_000_000;
            wr.write_temperature(
                &a.topic,
                (tr + LOG_DELAY_NS) as u64,
                tr,
                "ambient",
                ambient + sc.ambient.noise_c * z,
                sc.ambient.noise_c.powi(2),
            )
            .map_err(write_error)?;
        }
    }
    Ok(())
}
