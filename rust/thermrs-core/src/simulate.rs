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

use std::io::{Seek, Write};

use rand::rngs::StdRng;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal, Poisson, StandardNormal};

use crate::effects::Effects;
use crate::error::{Error, Result};
use crate::heat::{self, NodeParams};
use crate::model::{pose_joints_rad, ForwardModel};
use crate::record::{ImageFields, MsgType, RecordCompression, RecordOptions, RecordingWriter};
use crate::rig::{LengthRef, Rig, AMBIENT};
use crate::scenario::{Scenario, Start};

/// Transport delay between a message's stamp and its log time.
const LOG_DELAY_NS: i64 = 2_000_000;
/// The epoch the first run starts at (2025-06-15T15:06:40Z), like the sample recording.
pub const T0_NS: i64 = 1_750_000_000_000_000_000;

/// Most sub-exposure samples of a spot that moves during a frame (its smear).
const MAX_SMEAR_SAMPLES: usize = 4096;

/// One piece of a cycle's joint-space trajectory: a move (`dwell` None) or a dwell at a
/// camera's pose.
struct Segment {
    t0: f64,
    t1: f64,
    q0: [f64; 6],
    q1: [f64; 6],
    dwell: Option<usize>,
}

impl Segment {
    /// A move from `from` to `to` starting at `t0`, every joint at `speed` × its maximum rate
    /// (°/s); it lasts as long as the slowest joint needs.
    fn movement(
        t0: f64,
        from: [f64; 6],
        to: [f64; 6],
        max_rate_deg_s: &[f64; 6],
        speed: f64,
    ) -> Segment {
        let dur = (0..6)
            .map(|j| (to[j] - from[j]).abs() / (max_rate_deg_s[j].to_radians() * speed))
            .fold(0.0, f64::max);
        Segment {
            t0,
            t1: t0 + dur,
            q0: from,
            q1: to,
            dwell: None,
        }
    }
}

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

/// A scenario's effects on a rig (see [`crate::effects`]).
fn effects(rig: &Rig, sc: &Scenario) -> Result<Effects> {
    let list = sc.effects()?;
    Effects::build(
        rig,
        &list,
        rig.expansion.alpha_per_k,
        rig.expansion.reference_c,
    )
}

/// Thermal nodes: the scenario's, else the KR 15/2 calibration; each must be a ROI of the rig.
fn nodes(rig: &Rig, sc: &Scenario) -> Result<Vec<NodeParams>> {
    let nodes: Vec<NodeParams> = if sc.node.is_empty() {
        heat::kr15_paper_nodes()
    } else {
        sc.node
            .iter()
            .map(|n| {
                let rise = n.rise().ok_or_else(|| {
                    Error::Input(format!(
                        "thermal node {:?}: give exactly one of rise_k and rise_saturating",
                        n.name
                    ))
                })?;
                NodeParams::new(n.name.clone(), n.tau_min, rise).map_err(Error::Input)
            })
            .collect::<Result<_>>()?
    };
    let rois = rig.rois();
    for n in &nodes {
        if !rois.contains_key(&n.name) {
            return Err(Error::Input(format!(
                "thermal node {:?} is not a ROI of the rig ({})",
                n.name,
                rois.keys().cloned().collect::<Vec<_>>().join(", ")
            )));
        }
    }
    Ok(nodes)
}

/// A CCD frame's pixels: spot at (x, y) px plus noise, written into `out` (row-major, `bpp`
/// bytes per pixel little-endian).
#[allow(clippy::too_many_arguments)]
fn render_ccd(
    out: &mut [u8],
    w: usize,
    h: usize,
    bpp: usize,
    path: &[(f64, f64)],
    weight: f64,
    cam: &crate::scenario::CameraModel,
    rng: &mut StdRng,
) {
    let gain = cam.dn_per_electron;
    let bg_e = cam.background_dn / gain;
    let read_e = cam.read_noise_dn / gain;
    let max = if bpp == 1 { 255.0 } else { 65535.0 };
    let sd_dn = (bg_e + read_e * read_e).sqrt() * gain;
    let put = |out: &mut [u8], i: usize, dn: f64| {
        let v = dn.round().clamp(0.0, max) as u32;
        if bpp == 1 {
            out[i] = v as u8;
        } else {
            out[2 * i..2 * i + 2].copy_from_slice(&(v as u16).to_le_bytes());
        }
    };
    for i in 0..w * h {
        let z: f64 = StandardNormal.sample(rng);
        put(out, i, cam.background_dn + sd_dn * z);
    }
    if path.is_empty() {
        return;
    }
    // The spot's Gaussian at each point of its path, `weight` of the signal each.
    let s = cam.sigma_px;
    let r = (5.0 * s).ceil() as i64;
    let xs = path.iter().map(|p| p.0);
    let ys = path.iter().map(|p| p.1);
    let (xmin, xmax) = (
        xs.clone().fold(f64::INFINITY, f64::min),
        xs.fold(f64::NEG_INFINITY, f64::max),
    );
    let (ymin, ymax) = (
        ys.clone().fold(f64::INFINITY, f64::min),
        ys.fold(f64::NEG_INFINITY, f64::max),
    );
    let (x0, x1) = (
        (xmin.round() as i64 - r).max(0),
        (xmax.round() as i64 + r).min(w as i64 - 1),
    );
    let (y0, y1) = (
        (ymin.round() as i64 - r).max(0),
        (ymax.round() as i64 + r).min(h as i64 - 1),
    );
    if x0 > x1 || y0 > y1 {
        return;
    }
    let total_e = weight * cam.peak_dn * 2.0 * std::f64::consts::PI * s * s / gain;
    let k = 1.0 / (s * std::f64::consts::SQRT_2);
    let frac = |c: i64, mu: f64| {
        0.5 * (libm::erf((c as f64 + 0.5 - mu) * k) - libm::erf((c as f64 - 0.5 - mu) * k))
    };
    let (nx, ny) = ((x1 - x0 + 1) as usize, (y1 - y0 + 1) as usize);
    let mut signal = vec![0.0; nx * ny];
    for &(x, y) in path {
        let fx: Vec<f64> = (x0..=x1).map(|c| frac(c, x)).collect();
        let fy: Vec<f64> = (y0..=y1).map(|c| frac(c, y)).collect();
        for (j, fyj) in fy.iter().enumerate() {
            for (i, fxi) in fx.iter().enumerate() {
                signal[j * nx + i] += total_e * fxi * fyj;
            }
        }
    }
    let read = Normal::new(0.0, read_e.max(1e-12)).expect("finite");
    for (j, row) in (y0..=y1).enumerate() {
        for (i, col) in (x0..=x1).enumerate() {
            let lam = signal[j * nx + i] + bg_e;
            let e = if lam > 0.0 {
                Poisson::new(lam).map(|p| p.sample(rng)).unwrap_or(lam)
            } else {
                0.0
            };
            let dn = (e + read.sample(rng)) * gain;
            put(out, row as usize * w + col as usize, dn);
        }
    }
}

/// An IR frame in °C: ambient, a hot Gaussian region per ROI peaking at its node's surface
/// temperature, a distractor outside the ROIs, noise.
fn render_ir(
    rig: &Rig,
    sc: &Scenario,
    ambient: f64,
    roi_c: &[(usize, f64)],
    rng: &mut StdRng,
) -> Vec<f64> {
    let th = rig.thermal.as_ref().expect("checked");
    let (w, h) = (th.size_px[0] as usize, th.size_px[1] as usize);
    let mut img = vec![ambient; w * h];
    let blob = |cx: f64, cy: f64, sx: f64, sy: f64, peak: f64, img: &mut Vec<f64>| {
        for yy in 0..h {
            let dy = (yy as f64 - cy) / sy;
            for xx in 0..w {
                let dx = (xx as f64 - cx) / sx;
                let g = (-(dx * dx + dy * dy) / 2.0).exp();
                if g > 1e-4 {
                    let v = ambient + (peak - ambient) * g;
                    let p = &mut img[yy * w + xx];
                    if v > *p {
                        *p = v;
                    }
                }
            }
        }
    };
    for &(ri, t) in roi_c {
        let [x0, y0, x1, y1] = th.roi[ri].rect_px;
        let (cx, cy) = ((x0 + x1) as f64 / 2.0 - 0.5, (y0 + y1) as f64 / 2.0 - 0.5);
        blob(
            cx,
            cy,
            (x1 - x0) as f64 / 6.0,
            (y1 - y0) as f64 / 6.0,
            t,
            &mut img,
        );
    }
    if sc.ir.distractor_c > 0.0 {
        // The first 4×4 block, scanning from the top right, that touches no ROI.
        let clear = |x: i64, y: i64| {
            th.roi.iter().all(|r| {
                let [x0, y0, x1, y1] = r.rect_px;
                x + 6 < x0 || x - 6 >= x1 || y + 6 < y0 || y - 6 >= y1
            })
        };
        let spot = (0..h as i64)
            .flat_map(|y| (0..w as i64).rev().map(move |x| (x, y)))
            .find(|&(x, y)| {
                x >= 6 && y >= 6 && x + 6 < w as i64 && y + 6 < h as i64 && clear(x, y)
            });
        if let Some((x, y)) = spot {
            blob(x as f64, y as f64, 1.5, 1.5, sc.ir.distractor_c, &mut img);
        }
    }
    if sc.ir.noise_c > 0.0 {
        for v in img.iter_mut() {
            let z: f64 = StandardNormal.sample(rng);
            *v += sc.ir.noise_c * z;
        }
    }
    img
}

/// Simulate `scenario` on `rig`, writing the recording to `out`; returns the truth.
pub fn simulate<W: Write + Seek>(rig: &Rig, sc: &Scenario, out: W) -> Result<(W, Truth)> {
    simulate_cancellable(rig, sc, out, &|| false)
}

/// [`simulate`], asking `cancel` before every cycle and every CCD frame: once it returns
/// `true` the simulation stops with [`Error::Interrupted`] (how the bindings honour Ctrl-C).
pub fn simulate_cancellable<W: Write + Seek>(
    rig: &Rig,
    sc: &Scenario,
    out: W,
    cancel: &dyn Fn() -> bool,
) -> Result<(W, Truth)> {
    let th = rig
        .thermal
        .as_ref()
        .ok_or_else(|| Error::Input("the rig has no [thermal] camera to simulate".into()))?;
    let fx = effects(rig, sc)?;
    let model = ForwardModel::new(rig, &fx.params)?;
    let nodes = nodes(rig, sc)?;
    let roi_names: Vec<String> = th.roi.iter().map(|r| r.name.clone()).collect();
    let node_roi: Vec<usize> = nodes
        .iter()
        .map(|n| {
            roi_names
                .iter()
                .position(|r| *r == n.name)
                .expect("checked")
        })
        .collect();
    // For every temperature the model needs: which node, or ambient.
    let temp_src: Vec<Option<usize>> = model
        .temperature_names()
        .iter()
        .map(|t| {
            if t == AMBIENT {
                Ok(None)
            } else {
                nodes
                    .iter()
                    .position(|n| n.name == *t)
                    .map(Some)
                    .ok_or_else(|| {
                        Error::Input(format!(
                            "the model needs temperature {t:?} but no thermal node simulates it"
                        ))
                    })
            }
        })
        .collect::<Result<_>>()?;
    let opts = RecordOptions {
        compression: sc
            .output
            .compression
            .parse::<RecordCompression>()
            .map_err(|e| Error::Input(e.to_string()))?,
        chunk_size: sc.output.chunk_size,
        ..RecordOptions::default()
    };
    let mut wr = RecordingWriter::new(out, &opts).map_err(|e| Error::Input(e.to_string()))?;
    let werr = |e: crate::record::RecordError| Error::Input(format!("writing the recording: {e}"));
    wr.add_channel(&rig.robot.joint_states_topic, MsgType::JointState)
        .map_err(werr)?;
    for c in &rig.camera {
        wr.add_channel(&c.topic, MsgType::Image).map_err(werr)?;
    }
    wr.add_channel(&th.topic, MsgType::Image).map_err(werr)?;
    if let Some(a) = &rig.ambient {
        wr.add_channel(&a.topic, MsgType::Temperature)
            .map_err(werr)?;
    }
    // Independent streams, so that what one sensor draws never shifts another's noise (an
    // effect on one camera leaves every other truth unchanged).
    let stream = |k: u64| StdRng::seed_from_u64(sc.seed ^ k.wrapping_mul(0x9E37_79B9_7F4A_7C15));
    let mut rng = stream(1); // motion
    let mut ccd_rng = stream(2);
    let mut ir_rng = stream(3);
    let mut truth = Truth {
        node_names: nodes.iter().map(|n| n.name.clone()).collect(),
        length_names: model
            .expanding_lengths()
            .iter()
            .map(|(l, _)| l.to_string())
            .collect(),
        ..Truth::default()
    };
    let amb = &sc.ambient;
    let ambient_at = |t_s: f64| {
        amb.start_c
            + amb.drift_c_per_h * t_s / 3600.0
            + amb.swing_c * (2.0 * std::f64::consts::PI * t_s / 86_400.0).sin()
    };
    let mut surface: Vec<f64> = nodes.iter().map(|_| ambient_at(0.0)).collect();
    let mut structure = surface.clone();
    let mut t_s = 0.0f64; // seconds since T0
    let cam = &sc.camera;
    let bpp = if cam.bits == 8 { 1 } else { 2 };
    let enc = if bpp == 1 { "mono8" } else { "mono16" };
    let joint_names = &rig.robot.joint_names;
    let frame_dt = 1.0 / cam.frame_rate_hz;
    let continuous = cam.mode == "continuous";
    let mut q_cur: Option<[f64; 6]> = None;
    for (ri, run) in sc.run.iter().enumerate() {
        // Idle (cooling) before the run; a run that starts at ambient resets every node.
        if run.start == Start::Ambient || ri == 0 {
            let a = ambient_at(t_s + run.idle_before_min * 60.0);
            surface.iter_mut().for_each(|s| *s = a);
            structure = surface.clone();
            t_s += run.idle_before_min * 60.0;
        } else if run.idle_before_min > 0.0 {
            let dt = run.idle_before_min * 60.0;
            let a = ambient_at(t_s + dt / 2.0);
            for (k, n) in nodes.iter().enumerate() {
                let before = surface[k];
                surface[k] = n.step(before, a, None, dt);
                structure[k] = fx.structure_step(before, surface[k], structure[k], dt);
            }
            t_s += dt;
        }
        let run_start_s = t_s;
        let speed = run.speed_pct / 100.0;
        let cycles = (run.duration_min * 60.0 / run.cycle_s).floor() as usize;
        let slot = run.cycle_s / (rig.camera.len() as f64 + 1.0);
        for _ in 0..cycles {
            if cancel() {
                return Err(Error::Interrupted);
            }
            let cycle_t = t_s;
            // This cycle's trajectory: to each camera's pose in turn (joint space, every joint
            // at the run's share of its maximum rate), a dwell there, then away to the rest
            // pose until the thermal camera closes the cycle. Per-visit repeatability noise on
            // each camera pose.
            let mut segs: Vec<Segment> = Vec::new();
            let mut t = cycle_t;
            for (ci, c) in rig.camera.iter().enumerate() {
                let pose = rig.pose_by_name(&c.pose).expect("validated");
                let mut target = pose_joints_rad(&pose.joints_deg);
                for v in target.iter_mut() {
                    let z: f64 = StandardNormal.sample(&mut rng);
                    *v += sc.motion.repeatability_urad * 1e-6 * z;
                }
                let mv = Segment::movement(
                    t,
                    q_cur.unwrap_or(target),
                    target,
                    &sc.motion.max_rate_deg_s,
                    speed,
                );
                t = mv.t1;
                segs.push(mv);
                segs.push(Segment {
                    t0: t,
                    t1: t + sc.motion.dwell_s,
                    q0: target,
                    q1: target,
                    dwell: Some(ci),
                });
                t += sc.motion.dwell_s;
                q_cur = Some(target);
            }
            // Then away from the cameras, to rest facing the thermal camera.
            {
                let first = rig.pose_by_name(&rig.camera[0].pose).expect("validated");
                let mut rest = pose_joints_rad(&first.joints_deg);
                for (j, v) in rest.iter_mut().enumerate() {
                    *v += sc.motion.rest_offset_deg[j].to_radians();
                }
                let mv = Segment::movement(
                    t,
                    q_cur.unwrap_or(rest),
                    rest,
                    &sc.motion.max_rate_deg_s,
                    speed,
                );
                t = mv.t1;
                segs.push(mv);
                q_cur = Some(rest);
            }
            let t_ir = cycle_t + rig.camera.len() as f64 * slot;
            if t > t_ir {
                return Err(Error::Input(format!(
                    "run {:?}: moves and dwells take {:.1} s, more than the {:.1} s of the cycle \
                     before the thermal frame (lengthen cycle_s or shorten motion.dwell_s)",
                    run.name,
                    t - cycle_t,
                    t_ir - cycle_t
                )));
            }
            let q_at = |t: f64| -> [f64; 6] {
                for sgm in &segs {
                    if t < sgm.t1 || sgm.t1 <= sgm.t0 && t <= sgm.t1 {
                        if t <= sgm.t0 {
                            return sgm.q0;
                        }
                        let f = ((t - sgm.t0) / (sgm.t1 - sgm.t0)).clamp(0.0, 1.0);
                        return std::array::from_fn(|j| sgm.q0[j] + f * (sgm.q1[j] - sgm.q0[j]));
                    }
                }
                segs.last().map(|sg| sg.q1).unwrap_or([0.0; 6])
            };
            // Joint states on a regular grid and at every segment boundary.
            let mut tj: Vec<f64> = segs.iter().flat_map(|sg| [sg.t0, sg.t1]).collect();
            let step = 1.0 / sc.motion.joint_rate_hz;
            let mut k = 0.0;
            while cycle_t + k * step < cycle_t + run.cycle_s {
                tj.push(cycle_t + k * step);
                k += 1.0;
            }
            tj.sort_by(f64::total_cmp);
            tj.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
            for &tq_s in &tj {
                let tq = T0_NS + (tq_s * 1e9).round() as i64;
                wr.write_joint_state(
                    &rig.robot.joint_states_topic,
                    (tq + LOG_DELAY_NS) as u64,
                    tq,
                    "base",
                    joint_names,
                    &q_at(tq_s),
                )
                .map_err(werr)?;
            }
            // Temperatures are stepped per cycle; within a cycle the structure is taken as
            // constant (minutes against time constants of hours).
            let ambient = ambient_at(cycle_t);
            let temps: Vec<f64> = temp_src
                .iter()
                .map(|s| s.map(|k| structure[k]).unwrap_or(ambient))
                .collect();
            let tcols: Vec<&[f64]> = temps.iter().map(std::slice::from_ref).collect();
            // Where camera ci's spot is at time t (px, with the chip effects), if on its chip.
            let spot_at = |ci: usize, t: f64| -> Result<(f64, f64, bool)> {
                let c = &rig.camera[ci];
                let mut out = [0.0; crate::model::SPOT_WIDTH];
                model.spot_batch(ci, &q_at(t), Some(&tcols), &mut out)?;
                let (mut x, mut y) = (out[0], out[1]);
                let d = fx.chip_shift_um(ci, ambient_at(t), t - run_start_s);
                x += d[0] / c.pixel_pitch_um[0];
                y += d[1] / c.pixel_pitch_um[1];
                let (w, h) = (c.size_px[0] as f64, c.size_px[1] as f64);
                let on = x.is_finite()
                    && y.is_finite()
                    && (-0.5..=w - 0.5).contains(&x)
                    && (-0.5..=h - 0.5).contains(&y);
                Ok((x, y, on))
            };
            // Frame times per camera: during its dwell (visits) or all cycle long (continuous).
            let mut frames: Vec<(f64, usize)> = Vec::new();
            for (ci, _) in rig.camera.iter().enumerate() {
                if continuous {
                    let n = (run.cycle_s * cam.frame_rate_hz).floor() as usize;
                    frames.extend((0..n).map(|f| {
                        (
                            cycle_t + f as f64 * frame_dt + ci as f64 * 0.25 * frame_dt,
                            ci,
                        )
                    }));
                } else if let Some(sg) = segs.iter().find(|sg| sg.dwell == Some(ci)) {
                    frames.extend(
                        (0..cam.frames_per_visit).map(|f| (sg.t0 + 0.5 + f as f64 * frame_dt, ci)),
                    );
                }
            }
            frames.sort_by(|a, b| a.0.total_cmp(&b.0));
            for (tf_s, ci) in frames {
                if cancel() {
                    return Err(Error::Interrupted);
                }
                let c = &rig.camera[ci];
                // The spot along its path during the exposure (one point when still).
                let moving = segs.iter().any(|sg| {
                    sg.dwell.is_none()
                        && sg.t1 > sg.t0
                        && tf_s < sg.t1
                        && tf_s + cam.exposure_s > sg.t0
                });
                // Enough sub-exposure samples that neighbours are ≤ σ/2 apart: a continuous
                // streak rather than a row of separate spots.
                let subs = if moving {
                    let a = spot_at(ci, tf_s)?;
                    let b = spot_at(ci, tf_s + cam.exposure_s)?;
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
                    let (x, y, on) = spot_at(ci, ts)?;
                    if on {
                        path.push((x, y));
                    }
                }
                let weight = 1.0 / subs as f64;
                let tf = T0_NS + (tf_s * 1e9).round() as i64;
                let (w, h) = (c.size_px[0] as usize, c.size_px[1] as usize);
                let fields = ImageFields {
                    stamp_ns: tf,
                    frame_id: &c.name,
                    width: w as u32,
                    height: h as u32,
                    encoding: enc,
                    is_bigendian: false,
                    step: (w * bpp) as u32,
                };
                let rng_ref = &mut ccd_rng;
                let path_ref = &path;
                wr.write_image_with(
                    &c.topic,
                    (tf + LOG_DELAY_NS) as u64,
                    &fields,
                    w * h * bpp,
                    |buf| render_ccd(buf, w, h, bpp, path_ref, weight, cam, rng_ref),
                )
                .map_err(werr)?;
                let n = path.len() as f64;
                let (x, y) = if path.is_empty() {
                    (f64::NAN, f64::NAN)
                } else {
                    (
                        path.iter().map(|p| p.0).sum::<f64>() / n,
                        path.iter().map(|p| p.1).sum::<f64>() / n,
                    )
                };
                truth.frame_camera.push(ci as u32);
                truth.frame_t_ns.push(tf);
                truth.frame_run.push(ri as u32);
                truth.frame_x_px.push(x);
                truth.frame_y_px.push(y);
            }
            // The thermal camera and the thermometer close the cycle, seeing the temperatures
            // of their own time (the state stepped from the cycle's start to t_ir).
            let t_ir = cycle_t + rig.camera.len() as f64 * slot;
            let ambient = ambient_at(t_ir);
            let into = t_ir - cycle_t;
            let a_ir = ambient_at(cycle_t + into / 2.0);
            let surface_ir: Vec<f64> = nodes
                .iter()
                .zip(&surface)
                .map(|(n, &t)| n.step(t, a_ir, Some(speed), into))
                .collect();
            let structure_ir: Vec<f64> = (0..nodes.len())
                .map(|k| fx.structure_step(surface[k], surface_ir[k], structure[k], into))
                .collect();
            for _ in 0..sc.ir.frames_per_cycle.max(1) {
                let roi_c: Vec<(usize, f64)> = node_roi
                    .iter()
                    .zip(&surface_ir)
                    .map(|(&r, &t)| (r, t))
                    .collect();
                let img = render_ir(rig, sc, ambient, &roi_c, &mut ir_rng);
                let ti = T0_NS + (t_ir * 1e9) as i64;
                let (w, h) = (th.size_px[0] as u32, th.size_px[1] as u32);
                let (encoding, data): (&str, Vec<u8>) = if sc.ir.encoding == "32FC1" {
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
                };
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
                    .map_err(werr)?;
            }
            if let Some(a) = &rig.ambient {
                let ti = T0_NS + (t_ir * 1e9) as i64;
                for r in 0..sc.ambient.readings_per_cycle {
                    let z: f64 = StandardNormal.sample(&mut ir_rng);
                    let tr = ti + r as i64 * 1_000_000;
                    wr.write_temperature(
                        &a.topic,
                        (tr + LOG_DELAY_NS) as u64,
                        tr,
                        "ambient",
                        ambient + sc.ambient.noise_c * z,
                        sc.ambient.noise_c.powi(2),
                    )
                    .map_err(werr)?;
                }
            }
            truth.sample_t_ns.push(T0_NS + (t_ir * 1e9) as i64);
            truth.sample_run.push(ri as u32);
            truth.sample_ambient_c.push(ambient);
            truth.surface_c.extend_from_slice(&surface_ir);
            truth.structure_c.extend_from_slice(&structure_ir);
            let temps_ir: Vec<f64> = temp_src
                .iter()
                .map(|s| s.map(|k| structure_ir[k]).unwrap_or(ambient))
                .collect();
            let (a_mm, d_mm) = model.lengths_at(Some(&temps_ir));
            for (l, _) in model.expanding_lengths() {
                truth.lengths_mm.push(match *l {
                    LengthRef::A(r) => a_mm[r],
                    LengthRef::D(r) => d_mm[r],
                });
            }
            // Advance the thermal state over the cycle (running at the run's speed).
            let a_mid = ambient_at(cycle_t + run.cycle_s / 2.0);
            for (k, n) in nodes.iter().enumerate() {
                let before = surface[k];
                surface[k] = n.step(before, a_mid, Some(speed), run.cycle_s);
                structure[k] = fx.structure_step(before, surface[k], structure[k], run.cycle_s);
            }
            t_s = cycle_t + run.cycle_s;
        }
        let stamp = |t: f64| T0_NS + (t * 1e9).round() as i64;
        wr.write_run_marker(&run.name, stamp(run_start_s), stamp(t_s))
            .map_err(werr)?;
    }
    let out = wr.finish().map_err(werr)?;
    Ok((out, truth))
}
