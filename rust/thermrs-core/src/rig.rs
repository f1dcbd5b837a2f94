//! Rig files (SPEC §3, `format = "thermrs-rig/1"`): parsing and validation.
//!
//! Parsing is strict: unknown keys, missing keys and wrong types are rejected by serde with the
//! key path (via `serde_path_to_error`) and the line. Validation then checks what types cannot:
//! counts, unit vectors, references between sections, ROIs inside the frame. Every error is one
//! line naming the key.

use std::collections::{BTreeMap, HashSet};
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{Error, FileKind, KeyError, RigError};

/// The format string every rig file must carry.
pub const RIG_FORMAT: &str = "thermrs-rig/1";
/// Tolerance on the norm of unit vectors and on the orthogonality of chip axes.
pub const UNIT_TOLERANCE: f64 = 1e-6;
/// The temperature name that refers to the ambient thermometer rather than a ROI.
pub const AMBIENT: &str = "ambient";

/// A whole rig: one robot, its poses, the laser, the CCD cameras, the thermal camera.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rig {
    pub format: String,
    #[serde(default)]
    pub name: Option<String>,
    pub robot: Robot,
    pub laser: Laser,
    pub camera: Vec<Camera>,
    pub pose: Vec<Pose>,
    #[serde(default)]
    pub thermal: Option<Thermal>,
    #[serde(default)]
    pub ambient: Option<Ambient>,
    pub expansion: Expansion,
    /// `[tolerances]` as the file states it; `None` where it has no such section (the
    /// defaults apply, [`Rig::tolerances`], and a diagnosis says so). Keys a section leaves
    /// out take their defaults.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tolerances: Option<Tolerances>,
}

/// `[tolerances]`: how well the rig and its instruments are known, as standard uncertainties
/// (1 σ). A real rig is never exactly its file; the diagnoser's null world draws these, so
/// that what they alone leave over the nominal model is never named as an effect.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Tolerances {
    /// Every DH length (`a_mm`, `d_mm`).
    pub length_mm: f64,
    /// Every DH twist and joint zero.
    pub angle_deg: f64,
    /// Each chip's centre, along each base axis.
    pub chip_mm: f64,
    /// Each chip's orientation, about each of its axes.
    pub chip_deg: f64,
    /// The laser's origin in the flange frame, along each axis.
    pub laser_mm: f64,
    /// The laser's direction, about each of two axes across it.
    pub laser_deg: f64,
    /// The IR camera's gain on the rise above the room, common to every ROI (relative).
    pub ir_scale: f64,
    /// Each ROI's own gain error on the rise above the room (relative).
    pub ir_gain: f64,
    /// Each ROI's offset drifting over a run (kelvin from the run's start to its end).
    pub ir_drift_k: f64,
    /// The IR camera's clock against the CCD cameras', per run (seconds).
    pub ir_clock_s: f64,
    /// Each ROI's reading scatter from visit to visit (kelvin): the detector's noise
    /// (its NETD), which the diagnosis' own smoother of the readings is made for.
    pub ir_noise_k: f64,
}

impl Default for Tolerances {
    /// A rig of the kind thermrs is for, as the field's published metrology states it
    /// (`docs/tolerances.md` gives each source): nominal DH geometry of an uncalibrated
    /// six-axis industrial robot, chips located with the robot itself, a radiometric LWIR
    /// camera to its data sheet's "±2 % of reading" with each ROI's emissivity known to about
    /// ±0.03, its readings scattering by an uncooled detector's NETD, clocks synchronised
    /// over the network (NTP/chrony) and stamped by the drivers.
    fn default() -> Tolerances {
        Tolerances {
            length_mm: 0.5,
            angle_deg: 0.03,
            chip_mm: 0.5,
            chip_deg: 0.1,
            laser_mm: 0.2,
            laser_deg: 0.05,
            ir_scale: 0.012,
            ir_gain: 0.03,
            ir_drift_k: 0.1,
            ir_clock_s: 1.0,
            ir_noise_k: 0.05,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Robot {
    pub model: String,
    pub joint_names: Vec<String>,
    pub joint_states_topic: String,
    pub dh: Vec<DhRow>,
    /// The joints' rated maximum rates (°/s, one per joint), optional: with them a run's speed
    /// override (% of these rates) is estimated from its joint states where a recording does
    /// not say it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_rate_deg_s: Option<Vec<f64>>,
}

/// One standard (distal) DH row: θᵢ = signᵢ·qᵢ + theta_offsetᵢ.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DhRow {
    pub a_mm: f64,
    pub alpha_deg: f64,
    pub d_mm: f64,
    pub theta_offset_deg: f64,
    pub sign: i64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Laser {
    #[serde(deserialize_with = "exact_array")]
    pub origin_mm: [f64; 3],
    #[serde(deserialize_with = "exact_array")]
    pub direction: [f64; 3],
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Camera {
    pub name: String,
    pub topic: String,
    pub pose: String,
    #[serde(deserialize_with = "exact_array")]
    pub centre_mm: [f64; 3],
    #[serde(deserialize_with = "exact_array")]
    pub x_axis: [f64; 3],
    #[serde(deserialize_with = "exact_array")]
    pub y_axis: [f64; 3],
    #[serde(deserialize_with = "exact_array")]
    pub pixel_pitch_um: [f64; 2],
    #[serde(deserialize_with = "exact_array")]
    pub size_px: [i64; 2],
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pose {
    pub name: String,
    #[serde(deserialize_with = "exact_array")]
    pub joints_deg: [f64; 6],
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Thermal {
    pub topic: String,
    #[serde(deserialize_with = "exact_array")]
    pub size_px: [i64; 2],
    pub scale: f64,
    pub offset_c: f64,
    #[serde(default)]
    pub roi: Vec<Roi>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Roi {
    pub name: String,
    /// [x0, y0, x1, y1]: columns x0..x1−1, rows y0..y1−1.
    #[serde(deserialize_with = "exact_array")]
    pub rect_px: [i64; 4],
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Ambient {
    pub topic: String,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Expansion {
    pub alpha_per_k: f64,
    pub reference_c: f64,
    #[serde(default)]
    pub length: Vec<LengthMap>,
}

/// One DH length that expands with one temperature.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LengthMap {
    /// `a<i>` or `d<i>`, i the 1-based DH row.
    pub name: String,
    /// A ROI name or `ambient`.
    pub temperature: String,
}

/// Which DH length: `a` or `d` of a 0-based row.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
pub enum LengthRef {
    A(usize),
    D(usize),
}

impl LengthRef {
    /// Parse `a1`..`a6`, `d1`..`d6`.
    pub fn parse(name: &str) -> Option<LengthRef> {
        let (kind, row) = name.split_at_checked(1)?;
        let row: usize = row.parse().ok()?;
        if !(1..=6).contains(&row) || name.len() != 2 {
            return None;
        }
        match kind {
            "a" => Some(LengthRef::A(row - 1)),
            "d" => Some(LengthRef::D(row - 1)),
            _ => None,
        }
    }

    pub fn row(&self) -> usize {
        match *self {
            LengthRef::A(r) | LengthRef::D(r) => r,
        }
    }
}

impl std::fmt::Display for LengthRef {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            LengthRef::A(r) => write!(f, "a{}", r + 1),
            LengthRef::D(r) => write!(f, "d{}", r + 1),
        }
    }
}

/// Deserialize a fixed-size array, rejecting extra entries (serde's own array support stops
/// reading after N entries and would silently drop a typo'd 7th joint angle).
fn exact_array<'de, D, T, const N: usize>(de: D) -> Result<[T; N], D::Error>
where
    D: serde::Deserializer<'de>,
    T: Deserialize<'de>,
{
    let v: Vec<T> = Vec::deserialize(de)?;
    let len = v.len();
    v.try_into().map_err(|_| {
        serde::de::Error::custom(format!("has {len} entries, expected an array of {N}"))
    })
}

impl Rig {
    /// Read and validate a rig file.
    pub fn from_path(path: impl AsRef<Path>) -> Result<Rig, Error> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
            path: path.display().to_string(),
            source,
        })?;
        Ok(Rig::from_toml(&text, &path.display().to_string())?)
    }

    /// Parse and validate rig TOML text; `source_name` names it in errors.
    pub fn from_toml(text: &str, source_name: &str) -> Result<Rig, RigError> {
        crate::config::parse_strict(text, source_name, FileKind::Rig, Rig::validate)
    }

    /// The checks types cannot express. Returns (key, message) of the first problem.
    pub fn validate(&self) -> Result<(), KeyError> {
        let fail = |key: &str, message: String| Err(KeyError::new(key.to_string(), message));
        if self.format != RIG_FORMAT {
            return fail(
                "format",
                format!("is {:?}, expected {RIG_FORMAT:?}", self.format),
            );
        }
        self.validate_robot()?;
        let pose_names = self.validate_laser_and_poses()?;
        // Every topic once: joint states, cameras, thermal camera, thermometer.
        let mut topics: HashSet<&str> = HashSet::new();
        topics.insert(self.robot.joint_states_topic.as_str());
        self.validate_cameras(&pose_names, &mut topics)?;
        let temp_names = self.validate_thermal_and_ambient(&mut topics)?;
        self.validate_expansion(&temp_names)?;
        self.validate_tolerances()
    }

    /// The tolerances in force: the file's `[tolerances]`, else the defaults.
    pub fn tolerances(&self) -> Tolerances {
        self.tolerances.unwrap_or_default()
    }

    /// Whether the file states its `[tolerances]` (else the defaults are in force).
    pub fn tolerances_stated(&self) -> bool {
        self.tolerances.is_some()
    }

    /// `[tolerances]`: every value finite and not negative.
    fn validate_tolerances(&self) -> Result<(), KeyError> {
        let t = &self.tolerances();
        for (name, v) in [
            ("length_mm", t.length_mm),
            ("angle_deg", t.angle_deg),
            ("chip_mm", t.chip_mm),
            ("chip_deg", t.chip_deg),
            ("laser_mm", t.laser_mm),
            ("laser_deg", t.laser_deg),
            ("ir_scale", t.ir_scale),
            ("ir_gain", t.ir_gain),
            ("ir_drift_k", t.ir_drift_k),
            ("ir_clock_s", t.ir_clock_s),
            ("ir_noise_k", t.ir_noise_k),
        ] {
            let key = format!("tolerances.{name}");
            check_finite(v, &key)?;
            if v < 0.0 {
                return Err(KeyError::new(
                    key,
                    format!("is {v}, expected a standard uncertainty (0 or more)"),
                ));
            }
        }
        Ok(())
    }

    /// A rig given as JSON (the keys of [`Rig::to_json`]), validated as a file would be.
    pub fn from_json(text: &str, source_name: &str) -> Result<Rig, RigError> {
        let err = |key: String, message: String| RigError {
            kind: FileKind::Rig,
            source_name: source_name.to_string(),
            line: None,
            key,
            message,
        };
        let mut de = serde_json::Deserializer::from_str(text);
        let rig: Rig = serde_path_to_error::deserialize(&mut de).map_err(|e| {
            let path = e.path().to_string();
            let key = if path == "." { String::new() } else { path };
            err(key, e.into_inner().to_string())
        })?;
        rig.validate().map_err(|e| err(e.key, e.message))?;
        Ok(rig)
    }

    /// `[robot]`: model, joint names, topic, the six DH rows.
    fn validate_robot(&self) -> Result<(), KeyError> {
        let fail = |key: &str, message: String| Err(KeyError::new(key.to_string(), message));
        let r = &self.robot;
        if r.model.trim().is_empty() {
            return fail("robot.model", "is empty".into());
        }
        if r.joint_names.len() != 6 {
            return fail(
                "robot.joint_names",
                format!("has {} names, expected 6", r.joint_names.len()),
            );
        }
        check_names(&r.joint_names, "robot.joint_names")?;
        check_topic(&r.joint_states_topic, "robot.joint_states_topic")?;
        if r.dh.len() != 6 {
            return fail("robot.dh", format!("has {} rows, expected 6", r.dh.len()));
        }
        for (i, row) in r.dh.iter().enumerate() {
            for (k, v) in [
                ("a_mm", row.a_mm),
                ("alpha_deg", row.alpha_deg),
                ("d_mm", row.d_mm),
                ("theta_offset_deg", row.theta_offset_deg),
            ] {
                check_finite(v, &format!("robot.dh[{i}].{k}"))?;
            }
            if row.sign != 1 && row.sign != -1 {
                return fail(
                    &format!("robot.dh[{i}].sign"),
                    format!("is {}, expected 1 or -1", row.sign),
                );
            }
        }
        if let Some(rates) = &r.max_rate_deg_s {
            if rates.len() != 6 {
                return fail(
                    "robot.max_rate_deg_s",
                    format!("has {} rates, expected 6", rates.len()),
                );
            }
            for (i, v) in rates.iter().enumerate() {
                if !(v.is_finite() && *v > 0.0) {
                    return fail(
                        &format!("robot.max_rate_deg_s[{i}]"),
                        format!("is {v}, expected a positive rate in °/s"),
                    );
                }
            }
        }
        Ok(())
    }

    /// `[laser]` and the `[[pose]]`s; returns the pose names.
    fn validate_laser_and_poses(&self) -> Result<Vec<String>, KeyError> {
        let fail = |key: &str, message: String| -> Result<Vec<String>, KeyError> {
            Err(KeyError::new(key.to_string(), message))
        };
        check_vec(&self.laser.origin_mm, "laser.origin_mm")?;
        check_unit(&self.laser.direction, "laser.direction")?;
        // poses
        if self.pose.is_empty() {
            return fail("pose", "no [[pose]] given; at least one is needed".into());
        }
        let pose_names: Vec<String> = self.pose.iter().map(|p| p.name.clone()).collect();
        check_names(&pose_names, "pose")?;
        for (i, p) in self.pose.iter().enumerate() {
            for (j, v) in p.joints_deg.iter().enumerate() {
                check_finite(*v, &format!("pose[{i}].joints_deg[{j}]"))?;
            }
        }
        Ok(pose_names)
    }

    /// The `[[camera]]`s: names, topics (each once in `topics`), poses they refer to, chips.
    fn validate_cameras<'a>(
        &'a self,
        pose_names: &[String],
        topics: &mut HashSet<&'a str>,
    ) -> Result<(), KeyError> {
        let fail = |key: &str, message: String| Err(KeyError::new(key.to_string(), message));
        if self.camera.is_empty() {
            return fail(
                "camera",
                "no [[camera]] given; at least one is needed".into(),
            );
        }
        let cam_names: Vec<String> = self.camera.iter().map(|c| c.name.clone()).collect();
        check_names(&cam_names, "camera")?;
        for (i, c) in self.camera.iter().enumerate() {
            let key = |k: &str| format!("camera[{i}].{k}");
            check_topic(&c.topic, &key("topic"))?;
            if !topics.insert(c.topic.as_str()) {
                return fail(&key("topic"), format!("{:?} is used twice", c.topic));
            }
            if !pose_names.contains(&c.pose) {
                return fail(
                    &key("pose"),
                    format!(
                        "{:?} names no [[pose]] (poses: {})",
                        c.pose,
                        pose_names.join(", ")
                    ),
                );
            }
            check_vec(&c.centre_mm, &key("centre_mm"))?;
            check_unit(&c.x_axis, &key("x_axis"))?;
            check_unit(&c.y_axis, &key("y_axis"))?;
            let dot: f64 = (0..3).map(|k| c.x_axis[k] * c.y_axis[k]).sum();
            if dot.abs() > UNIT_TOLERANCE {
                return fail(
                    &key("y_axis"),
                    format!("is not orthogonal to x_axis (dot product {dot:.3e})"),
                );
            }
            for (k, v) in c.pixel_pitch_um.iter().enumerate() {
                if !(v.is_finite() && *v > 0.0) {
                    return fail(
                        &format!("camera[{i}].pixel_pitch_um[{k}]"),
                        format!("is {v}, expected a positive pitch"),
                    );
                }
            }
            for (k, v) in c.size_px.iter().enumerate() {
                if *v <= 0 {
                    return fail(
                        &format!("camera[{i}].size_px[{k}]"),
                        format!("is {v}, expected a positive pixel count"),
                    );
                }
            }
        }
        Ok(())
    }

    /// `[thermal]` and `[ambient]`: topics, ROIs inside the frame; returns the temperature
    /// names (ROIs, `ambient`).
    fn validate_thermal_and_ambient<'a>(
        &'a self,
        topics: &mut HashSet<&'a str>,
    ) -> Result<Vec<&'a str>, KeyError> {
        let fail = |key: &str, message: String| -> Result<Vec<&str>, KeyError> {
            Err(KeyError::new(key.to_string(), message))
        };
        let mut temp_names: Vec<&str> = Vec::new();
        if let Some(t) = &self.thermal {
            check_topic(&t.topic, "thermal.topic")?;
            if !topics.insert(t.topic.as_str()) {
                return fail("thermal.topic", format!("{:?} is used twice", t.topic));
            }
            for (k, v) in t.size_px.iter().enumerate() {
                if *v <= 0 {
                    return fail(
                        &format!("thermal.size_px[{k}]"),
                        format!("is {v}, expected a positive pixel count"),
                    );
                }
            }
            if !(t.scale.is_finite() && t.scale != 0.0) {
                return fail(
                    "thermal.scale",
                    format!("is {}, expected a non-zero number", t.scale),
                );
            }
            check_finite(t.offset_c, "thermal.offset_c")?;
            let roi_names: Vec<String> = t.roi.iter().map(|r| r.name.clone()).collect();
            check_names(&roi_names, "thermal.roi")?;
            for (i, roi) in t.roi.iter().enumerate() {
                if roi.name == AMBIENT {
                    return fail(
                        &format!("thermal.roi[{i}].name"),
                        format!("{AMBIENT:?} is reserved for the ambient thermometer"),
                    );
                }
                let [x0, y0, x1, y1] = roi.rect_px;
                let [w, h] = t.size_px;
                if !(0 <= x0 && x0 < x1 && x1 <= w && 0 <= y0 && y0 < y1 && y1 <= h) {
                    return fail(
                        &format!("thermal.roi[{i}].rect_px"),
                        format!(
                            "[{x0}, {y0}, {x1}, {y1}] is empty or outside the {w}x{h} frame \
                             (need 0 <= x0 < x1 <= {w}, 0 <= y0 < y1 <= {h})"
                        ),
                    );
                }
                temp_names.push(roi.name.as_str());
            }
        }
        if let Some(a) = &self.ambient {
            check_topic(&a.topic, "ambient.topic")?;
            if !topics.insert(a.topic.as_str()) {
                return fail("ambient.topic", format!("{:?} is used twice", a.topic));
            }
            temp_names.push(AMBIENT);
        }
        Ok(temp_names)
    }

    /// `[expansion]`: α, the reference temperature, lengths mapped to known temperatures.
    fn validate_expansion(&self, temp_names: &[&str]) -> Result<(), KeyError> {
        let fail = |key: &str, message: String| Err(KeyError::new(key.to_string(), message));
        let r = &self.robot;
        let e = &self.expansion;
        check_finite(e.alpha_per_k, "expansion.alpha_per_k")?;
        if e.alpha_per_k.abs() > 1e-3 {
            return fail(
                "expansion.alpha_per_k",
                format!(
                    "is {}, not a plausible per-kelvin coefficient (|α| > 1e-3)",
                    e.alpha_per_k
                ),
            );
        }
        check_finite(e.reference_c, "expansion.reference_c")?;
        let mut seen = HashSet::new();
        for (i, l) in e.length.iter().enumerate() {
            let Some(lr) = LengthRef::parse(&l.name) else {
                return fail(
                    &format!("expansion.length[{i}].name"),
                    format!("{:?} is not a DH length (a1..a6 or d1..d6)", l.name),
                );
            };
            if !seen.insert(lr) {
                return fail(
                    &format!("expansion.length[{i}].name"),
                    format!("{:?} is listed twice", l.name),
                );
            }
            let row = &r.dh[lr.row()];
            let value = match lr {
                LengthRef::A(_) => row.a_mm,
                LengthRef::D(_) => row.d_mm,
            };
            if value == 0.0 {
                return fail(
                    &format!("expansion.length[{i}].name"),
                    format!("{:?} is 0 mm in robot.dh, so it cannot expand", l.name),
                );
            }
            if !temp_names.contains(&l.temperature.as_str()) {
                let known = if temp_names.is_empty() {
                    "none: the rig has no [[thermal.roi]] and no [ambient]".to_string()
                } else {
                    temp_names.join(", ")
                };
                return fail(
                    &format!("expansion.length[{i}].temperature"),
                    format!(
                        "{:?} is neither a ROI nor ambient (known: {known})",
                        l.temperature
                    ),
                );
            }
        }
        Ok(())
    }

    /// Index of a camera by name.
    pub fn camera_index(&self, name: &str) -> Option<usize> {
        self.camera.iter().position(|c| c.name == name)
    }

    /// A pose by name.
    pub fn pose_by_name(&self, name: &str) -> Option<&Pose> {
        self.pose.iter().find(|p| p.name == name)
    }

    /// The temperature names the nominal model needs, in first-use order.
    pub fn mapped_temperatures(&self) -> Vec<String> {
        let mut out: Vec<String> = Vec::new();
        for l in &self.expansion.length {
            if !out.contains(&l.temperature) {
                out.push(l.temperature.clone());
            }
        }
        out
    }

    /// Expanded lengths as (which length, temperature name), validated.
    pub fn length_map(&self) -> Vec<(LengthRef, String)> {
        self.expansion
            .length
            .iter()
            .filter_map(|l| LengthRef::parse(&l.name).map(|r| (r, l.temperature.clone())))
            .collect()
    }

    /// Rig as JSON (for the bindings and for `--json` outputs).
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).expect("a rig always serialises")
    }

    /// Every ROI name with its rectangle.
    pub fn rois(&self) -> BTreeMap<String, [i64; 4]> {
        self.thermal
            .iter()
            .flat_map(|t| t.roi.iter().map(|r| (r.name.clone(), r.rect_px)))
            .collect()
    }
}

fn check_finite(v: f64, key: &str) -> Result<(), KeyError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(KeyError::new(
            key.to_string(),
            format!("is {v}, expected a finite number"),
        ))
    }
}

fn check_vec(v: &[f64; 3], key: &str) -> Result<(), KeyError> {
    for (k, x) in v.iter().enumerate() {
        check_finite(*x, &format!("{key}[{k}]"))?;
    }
    Ok(())
}

fn check_unit(v: &[f64; 3], key: &str) -> Result<(), KeyError> {
    check_vec(v, key)?;
    let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    if norm == 0.0 {
        return Err(KeyError::new(
            key.to_string(),
            "is a zero-length vector, expected a unit vector",
        ));
    }
    if (norm - 1.0).abs() > UNIT_TOLERANCE {
        return Err(KeyError::new(
            key.to_string(),
            format!("has length {norm:.9}, expected a unit vector (within {UNIT_TOLERANCE:e})"),
        ));
    }
    Ok(())
}

fn check_topic(topic: &str, key: &str) -> Result<(), KeyError> {
    if topic.trim().is_empty() {
        return Err(KeyError::new(
            key.to_string(),
            "is empty, expected a topic name",
        ));
    }
    Ok(())
}

fn check_names(names: &[String], key: &str) -> Result<(), KeyError> {
    let mut seen = HashSet::new();
    for (i, n) in names.iter().enumerate() {
        let k = if key.starts_with("robot.") {
            format!("{key}[{i}]")
        } else {
            format!("{key}[{i}].name")
        };
        if n.trim().is_empty() {
            return Err(KeyError::new(k, "is empty"));
        }
        if !seen.insert(n.as_str()) {
            return Err(KeyError::new(k, format!("{n:?} is used twice")));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const PAPER: &str = include_str!("../../../python/thermrs/data/kr15-paper.toml");

    fn parse(text: &str) -> Result<Rig, RigError> {
        Rig::from_toml(text, "t.toml")
    }

    #[test]
    fn paper_rig_parses() {
        let rig = parse(PAPER).unwrap();
        assert_eq!(rig.camera.len(), 2);
        assert_eq!(rig.robot.dh[2].a_mm, 152.91);
        assert_eq!(rig.mapped_temperatures(), vec!["link2", "link3"]);
    }

    #[test]
    fn unknown_key_is_named_with_its_line() {
        let text = PAPER.replace(
            "topic = \"/ccd_b/image_raw\"",
            "tpoic = \"/ccd_b/image_raw\"",
        );
        let e = parse(&text).unwrap_err();
        assert!(e.key.starts_with("camera[1]"), "{e}");
        assert!(e.message.contains("tpoic"), "{e}");
        assert!(e.line.is_some(), "{e}");
        assert!(!e.to_string().contains('\n'));
    }

    #[test]
    fn wrong_type_is_named() {
        let text = PAPER.replace("a_mm = 650.0", "a_mm = \"650\"");
        let e = parse(&text).unwrap_err();
        assert_eq!(e.key, "robot.dh[1].a_mm", "{e}");
    }

    #[test]
    fn roi_outside_frame() {
        let text = PAPER.replace("140,\n    40,\n    250,", "140,\n    40,\n    350,");
        let e = parse(&text).unwrap_err();
        assert_eq!(e.key, "thermal.roi[1].rect_px", "{e}");
    }

    #[test]
    fn length_names_parse() {
        assert_eq!(LengthRef::parse("a2"), Some(LengthRef::A(1)));
        assert_eq!(LengthRef::parse("d6"), Some(LengthRef::D(5)));
        assert_eq!(LengthRef::parse("d7"), None);
        assert_eq!(LengthRef::parse("a12"), None);
        assert_eq!(LengthRef::parse("b1"), None);
        assert_eq!(LengthRef::parse(""), None);
    }
}
