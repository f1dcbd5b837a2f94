//! The thermal-expansion forward model (SPEC §4) — the one place its physics lives.
//!
//! A DH length L listed in the rig's `[expansion]` expands to
//! `L·(1 + α_T·ΔT·(1 + κ·ΔT))`, ΔT = T − reference_c, with T the temperature mapped to it at
//! that sample. The flange pose is the DH product with the expanded lengths at the sample's
//! joints; the laser ray is mapped through it and meets the chip plane (see [`crate::optics`]).
//!
//! The nominal model has one α and nothing else. [`ModelParams`] adds the SPEC §6 effects that
//! act on geometry, each in one place here:
//! - `alpha_per_link`: one α per mapped temperature (`alpha_by_temperature`);
//! - `nonlinear_alpha`: strain α·ΔT·(1 + κ·ΔT) (`kappa_per_k`);
//! - `unmodelled_length`: a DH length the rig does not list expands too (`extra_lengths`);
//! - `joint_offset`: a joint's zero moves by k·ΔT of a temperature (`joint_offsets`);
//! - `laser_tilt`: the true laser direction is tilted from the rig's (`laser_tilt`).
//!
//! These fields are set from the effects' one home, [`crate::effects`], which also holds the
//! effects that act elsewhere: on the chip (`fixture_drift`, `sensor_drift`) and on the
//! temperatures before they reach this model (`thermal_lag`).
//!
//! Everything is vectorised over samples: joints are an `N×6` row-major slice (radians),
//! temperatures one `N`-long column per mapped name. Work over 8,192 samples is spread over the
//! rayon pool.

use std::collections::BTreeMap;

use nalgebra::Vector3;
use rayon::prelude::*;

use crate::error::{Error, NameKind, Result, UnknownName};
use crate::kinematics::{Chain, Frame};
use crate::optics::{Chip, Ray};
use crate::rig::{LengthRef, Rig};

/// Samples below this count are computed on the calling thread.
const PARALLEL_THRESHOLD: usize = 8192;
/// Samples per parallel work item.
const PARALLEL_CHUNK: usize = 4096;

/// A joint whose zero moves with a temperature (`joint_offset`).
#[derive(Debug, Clone, PartialEq)]
pub struct JointOffset {
    /// 0-based joint index.
    pub joint: usize,
    /// ROI name or `ambient`.
    pub temperature: String,
    /// Offset per kelvin above `reference_c`, radians (SPEC reports µrad/K).
    pub rad_per_k: f64,
}

/// A tilt of the laser direction in the flange frame (`laser_tilt`): the direction is turned by
/// `tilt_deg` about an axis perpendicular to it. With `azimuth_deg` = 0 that axis is
/// direction × flange z (flange x where the laser runs along z); `azimuth_deg` turns the axis
/// about the direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LaserTilt {
    pub tilt_deg: f64,
    pub azimuth_deg: f64,
}

impl LaserTilt {
    /// The tilted unit direction.
    pub fn apply(&self, d: &Vector3<f64>) -> Vector3<f64> {
        let d = d.normalize();
        let mut axis = d.cross(&Vector3::z());
        if axis.norm() < 1e-9 {
            axis = Vector3::x();
        }
        let axis = nalgebra::Unit::new_normalize(axis);
        let du = nalgebra::Unit::new_normalize(d);
        let axis = nalgebra::Rotation3::from_axis_angle(&du, self.azimuth_deg.to_radians()) * axis;
        (nalgebra::Rotation3::from_axis_angle(&axis, self.tilt_deg.to_radians()) * d).normalize()
    }
}

/// Parameters of the forward model: the expansion law and the geometric effects.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelParams {
    /// α (1/K) for every mapped temperature without its own entry.
    pub alpha_per_k: f64,
    /// The temperature at which the rig's lengths are exact (°C).
    pub reference_c: f64,
    /// Per-temperature α overrides (`alpha_per_link`).
    pub alpha_by_temperature: BTreeMap<String, f64>,
    /// Quadratic strain term κ (1/K): strain = α·ΔT·(1 + κ·ΔT) (`nonlinear_alpha`).
    pub kappa_per_k: f64,
    /// DH lengths the rig does not list that expand too (`unmodelled_length`), each with its
    /// temperature and its α as a multiple of that temperature's α.
    pub extra_lengths: Vec<(LengthRef, String, f64)>,
    /// Joints whose zero moves with a temperature (`joint_offset`).
    pub joint_offsets: Vec<JointOffset>,
    /// The laser's true direction differs from the rig's (`laser_tilt`).
    pub laser_tilt: Option<LaserTilt>,
}

impl ModelParams {
    /// The rig's nominal α and reference temperature, no effects.
    pub fn nominal(rig: &Rig) -> ModelParams {
        ModelParams {
            alpha_per_k: rig.expansion.alpha_per_k,
            reference_c: rig.expansion.reference_c,
            alpha_by_temperature: BTreeMap::new(),
            kappa_per_k: 0.0,
            extra_lengths: Vec::new(),
            joint_offsets: Vec::new(),
            laser_tilt: None,
        }
    }

    /// Length factor 1 + strain for a temperature with coefficient `alpha`.
    #[inline]
    pub fn factor(alpha: f64, kappa: f64, reference_c: f64, t_c: f64) -> f64 {
        let dt = t_c - reference_c;
        1.0 + alpha * dt * (1.0 + kappa * dt)
    }
}

/// What [`ForwardModel::flange_batch`] writes per sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FlangeOutput {
    /// x, y, z (mm): 3 values.
    Position,
    /// The 4×4 homogeneous matrix, row-major: 16 values.
    Matrix,
}

impl FlangeOutput {
    pub fn width(self) -> usize {
        match self {
            FlangeOutput::Position => 3,
            FlangeOutput::Matrix => 16,
        }
    }
}

/// Values per sample written by [`ForwardModel::spot_batch`]: x_px, y_px, distance_mm,
/// incidence_deg (all NaN where the ray meets no chip plane in front of it).
pub const SPOT_WIDTH: usize = 4;

/// The rig's robot, laser and chips with an expansion law, ready for batches.
#[derive(Debug, Clone)]
pub struct ForwardModel {
    chain: Chain,
    laser_origin: Vector3<f64>,
    laser_direction: Vector3<f64>,
    chips: Vec<Chip>,
    camera_names: Vec<String>,
    temperature_names: Vec<String>,
    /// (length, index into temperature_names)
    lengths: Vec<(LengthRef, usize)>,
    /// Each length's α as a multiple of its temperature's (1 but for `unmodelled_length`).
    length_scale: Vec<f64>,
    /// α per temperature name.
    alpha: Vec<f64>,
    /// (joint, index into temperature_names, rad per K)
    joint_offsets: Vec<(usize, usize, f64)>,
    kappa: f64,
    reference_c: f64,
}

/// Per-sample temperature columns, one per [`ForwardModel::temperature_names`] entry, or none
/// (every length at its nominal value).
pub type TemperatureColumns<'a> = Option<&'a [&'a [f64]]>;

impl ForwardModel {
    /// Build the model of a validated rig.
    pub fn new(rig: &Rig, params: &ModelParams) -> Result<ForwardModel> {
        finite("alpha_per_k", params.alpha_per_k)?;
        finite("reference_c", params.reference_c)?;
        finite("kappa_per_k", params.kappa_per_k)?;
        let mut temps = Temperatures::of(rig);
        let (lengths, length_scale) = expanding_lengths(rig, params, &mut temps)?;
        let mut joint_offsets = Vec::new();
        for o in &params.joint_offsets {
            if o.joint >= 6 {
                return Err(Error::OutOfRange {
                    name: "joint_offset.joint".to_string(),
                    value: o.joint as f64,
                    allowed: "a joint index 0..=5 (0-based)".to_string(),
                });
            }
            finite("joint_offset.rad_per_k", o.rad_per_k)?;
            let t = temps.index(&o.temperature, "joint_offset")?;
            joint_offsets.push((o.joint, t, o.rad_per_k));
        }
        let temperature_names = temps.names;
        let alpha = alphas(params, &temperature_names)?;
        let l = &rig.laser;
        let direction = Vector3::from(l.direction);
        let laser_direction = match &params.laser_tilt {
            Some(t) => {
                finite("laser_tilt.tilt_deg", t.tilt_deg)?;
                finite("laser_tilt.azimuth_deg", t.azimuth_deg)?;
                t.apply(&direction)
            }
            None => direction,
        };
        Ok(ForwardModel {
            chain: Chain::new(&rig.robot.dh),
            laser_origin: Vector3::from(l.origin_mm),
            laser_direction,
            chips: rig.camera.iter().map(Chip::from_camera).collect(),
            camera_names: rig.camera.iter().map(|c| c.name.clone()).collect(),
            temperature_names,
            lengths,
            length_scale,
            alpha,
            joint_offsets,
            kappa: params.kappa_per_k,
            reference_c: params.reference_c,
        })
    }

    /// The nominal model of a rig (its own α, no effects).
    pub fn nominal(rig: &Rig) -> Result<ForwardModel> {
        ForwardModel::new(rig, &ModelParams::nominal(rig))
    }

    pub fn chain(&self) -> &Chain {
        &self.chain
    }

    pub fn chips(&self) -> &[Chip] {
        &self.chips
    }

    /// The temperature names the model needs, in the order temperature columns are given.
    pub fn temperature_names(&self) -> &[String] {
        &self.temperature_names
    }

    /// Index of a camera by name, or an error naming the known ones.
    pub fn camera_index(&self, name: &str) -> Result<usize> {
        self.camera_names
            .iter()
            .position(|c| c == name)
            .ok_or_else(|| {
                UnknownName::new("", NameKind::Camera, name, self.camera_names.clone()).into()
            })
    }

    /// The lengths that expand (the rig's mapped ones, then the effects' extra ones) and the
    /// index of the temperature each follows, in `temperature_names` order.
    pub fn expanding_lengths(&self) -> &[(LengthRef, usize)] {
        &self.lengths
    }

    /// The DH lengths (a, d) in mm at one set of temperatures (one per temperature name).
    #[inline]
    pub fn lengths_at(&self, temps: Option<&[f64]>) -> ([f64; 6], [f64; 6]) {
        let mut a = self.chain.a_mm;
        let mut d = self.chain.d_mm;
        if let Some(t) = temps {
            for (&(l, ti), &scale) in self.lengths.iter().zip(&self.length_scale) {
                let alpha = self.alpha[ti] * scale;
                let f = ModelParams::factor(alpha, self.kappa, self.reference_c, t[ti]);
                match l {
                    LengthRef::A(r) => a[r] *= f,
                    LengthRef::D(r) => d[r] *= f,
                }
            }
        }
        (a, d)
    }

    /// The flange frame for joints `q` (radians) at temperatures `temps`.
    #[inline]
    pub fn flange(&self, q: &[f64], temps: Option<&[f64]>) -> Frame {
        let (a, d) = self.lengths_at(temps);
        match (temps, self.joint_offsets.is_empty()) {
            (Some(t), false) => {
                let mut qq = [0.0; 6];
                qq.copy_from_slice(&q[..6]);
                for &(j, ti, k) in &self.joint_offsets {
                    qq[j] += k * (t[ti] - self.reference_c);
                }
                self.chain.flange_with(&qq, &a, &d)
            }
            _ => self.chain.flange_with(q, &a, &d),
        }
    }

    /// The laser ray in the base frame for a flange frame.
    #[inline]
    pub fn laser_ray(&self, flange: &Frame) -> Ray {
        Ray::through(flange, &self.laser_origin, &self.laser_direction)
    }

    /// Check a batch's shapes; returns its sample count N.
    pub fn batch_len(&self, q: &[f64], temps: TemperatureColumns<'_>) -> Result<usize> {
        if q.len() % 6 != 0 {
            return Err(Error::Ragged {
                what: "joints".to_string(),
                len: q.len(),
                width: 6,
            });
        }
        let n = q.len() / 6;
        if let Some(cols) = temps {
            if cols.len() != self.temperature_names.len() {
                return Err(Error::Shape {
                    what: format!(
                        "temperature columns (the model needs {})",
                        self.temperature_names.join(", ")
                    ),
                    expected: self.temperature_names.len(),
                    got: cols.len(),
                });
            }
            for (c, name) in cols.iter().zip(&self.temperature_names) {
                if c.len() != n {
                    return Err(Error::Shape {
                        what: format!("samples of temperature {name:?} (one per joint sample)"),
                        expected: n,
                        got: c.len(),
                    });
                }
            }
        }
        Ok(n)
    }

    /// Run `f(sample, temps_at_sample, out_row)` for every sample, in parallel for large batches.
    fn for_samples<F>(
        &self,
        n: usize,
        temps: TemperatureColumns<'_>,
        out: &mut [f64],
        width: usize,
        f: F,
    ) where
        F: Fn(usize, Option<&[f64]>, &mut [f64]) + Sync,
    {
        let k = self.temperature_names.len();
        let work = |start: usize, chunk: &mut [f64]| {
            let mut t = vec![0.0; k];
            for (j, row) in chunk.chunks_exact_mut(width).enumerate() {
                let i = start + j;
                let tt = temps.map(|cols| {
                    for (slot, col) in t.iter_mut().zip(cols.iter()) {
                        *slot = col[i];
                    }
                    &t[..]
                });
                f(i, tt, row);
            }
        };
        if n < PARALLEL_THRESHOLD {
            work(0, out);
        } else {
            out.par_chunks_mut(PARALLEL_CHUNK * width)
                .enumerate()
                .for_each(|(c, chunk)| work(c * PARALLEL_CHUNK, chunk));
        }
    }

    /// Flange poses for `N` samples. `q`: N×6 joints (radians, row-major). `out`: N×width.
    pub fn flange_batch(
        &self,
        q: &[f64],
        temps: TemperatureColumns<'_>,
        what: FlangeOutput,
        out: &mut [f64],
    ) -> Result<()> {
        let n = self.batch_len(q, temps)?;
        let width = what.width();
        if out.len() != n * width {
            return Err(Error::Shape {
                what: "output values".to_string(),
                expected: n * width,
                got: out.len(),
            });
        }
        self.for_samples(n, temps, out, width, |i, t, row| {
            let f = self.flange(&q[6 * i..6 * i + 6], t);
            match what {
                FlangeOutput::Position => row.copy_from_slice(f.translation.as_slice()),
                FlangeOutput::Matrix => {
                    let m = f.to_matrix();
                    for r in 0..4 {
                        for c in 0..4 {
                            row[4 * r + c] = m[(r, c)];
                        }
                    }
                }
            }
        });
        Ok(())
    }

    /// Where the laser meets `camera`'s chip plane for `N` samples: per sample
    /// [`SPOT_WIDTH`] values (x_px, y_px, distance_mm, incidence_deg), NaN where it does not.
    pub fn spot_batch(
        &self,
        camera: usize,
        q: &[f64],
        temps: TemperatureColumns<'_>,
        out: &mut [f64],
    ) -> Result<()> {
        let n = self.batch_len(q, temps)?;
        let chip = self.chips.get(camera).ok_or_else(|| Error::OutOfRange {
            name: "camera index".to_string(),
            value: camera as f64,
            allowed: format!("0..{} ({} cameras)", self.chips.len(), self.chips.len()),
        })?;
        if out.len() != n * SPOT_WIDTH {
            return Err(Error::Shape {
                what: "output values".to_string(),
                expected: n * SPOT_WIDTH,
                got: out.len(),
            });
        }
        self.for_samples(n, temps, out, SPOT_WIDTH, |i, t, row| {
            let f = self.flange(&q[6 * i..6 * i + 6], t);
            match chip.intersect(&self.laser_ray(&f)) {
                Some(h) => row.copy_from_slice(&[h.x_px, h.y_px, h.distance_mm, h.incidence_deg]),
                None => row.fill(f64::NAN),
            }
        });
        Ok(())
    }
}

/// `Ok` if `value` is finite, else an error naming it.
fn finite(name: &str, value: f64) -> Result<()> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(Error::OutOfRange {
            name: name.to_string(),
            value,
            allowed: "a finite number".to_string(),
        })
    }
}

/// The temperatures a model follows: the rig's mapped ones, then those the effects add, first
/// use first; each must be a ROI of the rig or ambient.
struct Temperatures {
    names: Vec<String>,
    known: Vec<String>,
}

impl Temperatures {
    fn of(rig: &Rig) -> Temperatures {
        Temperatures {
            names: rig.mapped_temperatures(),
            known: rig
                .rois()
                .into_keys()
                .chain(rig.ambient.iter().map(|_| crate::rig::AMBIENT.to_string()))
                .collect(),
        }
    }

    /// The index of temperature `name` (added if new); `what` uses it (named in the error).
    fn index(&mut self, name: &str, what: &str) -> Result<usize> {
        if !self.known.iter().any(|k| k == name) {
            let known = self.known.clone();
            return Err(UnknownName::new(what, NameKind::Temperature, name, known).into());
        }
        Ok(match self.names.iter().position(|n| n == name) {
            Some(i) => i,
            None => {
                self.names.push(name.to_string());
                self.names.len() - 1
            }
        })
    }
}

/// The expanding lengths with their temperatures' indices, and each one's α scale.
type ExpandingLengths = (Vec<(LengthRef, usize)>, Vec<f64>);

/// The lengths that expand, each with its temperature's index: the rig's `[expansion]`, then
/// the effects' extra ones (`unmodelled_length`: not already expanding, not 0 mm); beside them
/// each length's α as a multiple of its temperature's.
fn expanding_lengths(
    rig: &Rig,
    params: &ModelParams,
    temps: &mut Temperatures,
) -> Result<ExpandingLengths> {
    let mut lengths: Vec<(LengthRef, usize)> = Vec::new();
    let mut scale = Vec::new();
    for (l, t) in rig.length_map() {
        lengths.push((l, temps.index(&t, "expansion")?));
        scale.push(1.0);
    }
    for (l, t, w) in &params.extra_lengths {
        if lengths.iter().any(|(m, _)| m == l) {
            return Err(Error::LengthAlreadyExpands {
                length: l.to_string(),
            });
        }
        let row = &rig.robot.dh[l.row()];
        let v = match l {
            LengthRef::A(_) => row.a_mm,
            LengthRef::D(_) => row.d_mm,
        };
        if v == 0.0 {
            return Err(Error::ZeroLength {
                length: l.to_string(),
            });
        }
        finite("unmodelled_length.weight", *w)?;
        lengths.push((*l, temps.index(t, "unmodelled_length")?));
        scale.push(*w);
    }
    Ok((lengths, scale))
}

/// α per temperature (its own where `alpha_per_link` gives one, else the nominal); an own α
/// for a temperature no length follows is an error.
fn alphas(params: &ModelParams, names: &[String]) -> Result<Vec<f64>> {
    for name in params.alpha_by_temperature.keys() {
        if !names.contains(name) {
            let known = names.to_vec();
            return Err(UnknownName::new("", NameKind::ExpandingTemperature, name, known).into());
        }
    }
    Ok(names
        .iter()
        .map(|n| {
            *params
                .alpha_by_temperature
                .get(n)
                .unwrap_or(&params.alpha_per_k)
        })
        .collect())
}

/// Number of threads the parallel loops use (rayon's pool; `RAYON_NUM_THREADS` sets it).
pub fn num_threads() -> usize {
    rayon::current_num_threads()
}

/// A pose's taught joints in radians.
pub fn pose_joints_rad(joints_deg: &[f64; 6]) -> [f64; 6] {
    joints_deg.map(f64::to_radians)
}

#[cfg(test)]
mod tests {
    use super::*;

    const PAPER: &str = include_str!("../../../python/thermrs/data/kr15-paper.toml");

    fn rig() -> Rig {
        Rig::from_toml(PAPER, "paper").unwrap()
    }

    #[test]
    fn reference_temperature_leaves_lengths_nominal() {
        let rig = rig();
        let m = ForwardModel::nominal(&rig).unwrap();
        let (a, d) = m.lengths_at(Some(&[23.0, 23.0]));
        assert_eq!(a, m.chain().a_mm);
        assert_eq!(d, m.chain().d_mm);
        let (a, d) = m.lengths_at(Some(&[33.0, 13.0]));
        assert!((a[1] - 650.0 * (1.0 + 2.32e-5 * 10.0)).abs() < 1e-12);
        assert!((d[3] - -600.0 * (1.0 - 2.32e-5 * 10.0)).abs() < 1e-12);
    }

    #[test]
    fn batch_matches_single_and_parallel_matches_serial() {
        let rig = rig();
        let m = ForwardModel::nominal(&rig).unwrap();
        let n = 20_000;
        let q: Vec<f64> = (0..n * 6)
            .map(|i| ((i * 7919) % 1000) as f64 / 500.0 - 1.0)
            .collect();
        let t1: Vec<f64> = (0..n).map(|i| 20.0 + (i % 17) as f64).collect();
        let t2: Vec<f64> = (0..n).map(|i| 25.0 - (i % 13) as f64).collect();
        let cols: [&[f64]; 2] = [&t1, &t2];
        let mut out = vec![0.0; n * 3];
        m.flange_batch(&q, Some(&cols), FlangeOutput::Position, &mut out)
            .unwrap();
        for i in [0, 1, 4095, 4096, 12345, n - 1] {
            let f = m.flange(&q[6 * i..6 * i + 6], Some(&[t1[i], t2[i]]));
            assert_eq!(&out[3 * i..3 * i + 3], f.translation.as_slice());
        }
    }

    #[test]
    fn warming_link2_moves_the_spot_on_camera_a() {
        let rig = rig();
        let m = ForwardModel::nominal(&rig).unwrap();
        let q = pose_joints_rad(&rig.pose[0].joints_deg);
        let mut cold = [0.0; SPOT_WIDTH];
        let mut warm = [0.0; SPOT_WIDTH];
        m.spot_batch(0, &q, Some(&[&[23.0][..], &[23.0][..]]), &mut cold)
            .unwrap();
        m.spot_batch(0, &q, Some(&[&[28.0][..], &[23.0][..]]), &mut warm)
            .unwrap();
        assert!((cold[0] - 375.5).abs() < 1e-6 && (cold[1] - 290.5).abs() < 1e-6);
        // 650 mm·α·5 K ≈ 75 µm of arm growth, mostly along base x = chip y.
        let dy_um = (warm[1] - cold[1]) * 8.3;
        assert!(dy_um > 50.0 && dy_um < 80.0, "{dy_um}");
    }

    #[test]
    fn bad_batches_are_rejected() {
        let rig = rig();
        let m = ForwardModel::nominal(&rig).unwrap();
        let mut out = vec![0.0; 3];
        assert!(m
            .flange_batch(&[0.0; 5], None, FlangeOutput::Position, &mut out)
            .is_err());
        let short: [&[f64]; 2] = [&[1.0, 2.0], &[1.0]];
        let e = m
            .flange_batch(
                &[0.0; 12],
                Some(&short),
                FlangeOutput::Position,
                &mut [0.0; 6],
            )
            .unwrap_err();
        assert!(e.to_string().contains("link3"), "{e}");
        assert!(
            matches!(
                e,
                Error::Shape {
                    expected: 2,
                    got: 1,
                    ..
                }
            ),
            "{e:?}"
        );
        assert!(matches!(
            m.flange_batch(&[0.0; 5], None, FlangeOutput::Position, &mut out),
            Err(Error::Ragged {
                len: 5,
                width: 6,
                ..
            })
        ));
        let e = m.camera_index("C").unwrap_err();
        assert!(e.to_string().contains("A, B"));
        match e {
            Error::UnknownName(u) => {
                assert_eq!((u.kind, u.name.as_str()), (NameKind::Camera, "C"));
                assert_eq!(u.known, ["A", "B"]);
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn laser_tilt_turns_by_its_angle_and_stays_unit() {
        let d = Vector3::new(0.3, -0.2, 0.9).normalize();
        for (tilt, az) in [(0.0, 0.0), (1.0, 0.0), (2.5, 90.0), (10.0, 217.0)] {
            let t = LaserTilt {
                tilt_deg: tilt,
                azimuth_deg: az,
            }
            .apply(&d);
            assert!((t.norm() - 1.0).abs() < 1e-12);
            assert!((t.dot(&d).clamp(-1.0, 1.0).acos().to_degrees() - tilt).abs() < 1e-9);
        }
        // Along flange z the axis falls back to flange x.
        let z = LaserTilt {
            tilt_deg: 90.0,
            azimuth_deg: 0.0,
        }
        .apply(&Vector3::z());
        assert!((z - Vector3::new(0.0, -1.0, 0.0)).norm() < 1e-12, "{z}");
    }
}
