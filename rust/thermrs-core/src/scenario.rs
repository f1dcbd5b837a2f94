//! Scenario files (`format = "thermrs-scenario/1"`): what the simulator makes a rig do.
//!
//! A scenario names runs (speed, duration, cycle period, how each starts), the ambient profile,
//! the cameras' and sensors' noise and timing, and the unmodelled effects (SPEC §6) to switch
//! on. Parsing is as strict as for rig files: unknown keys, missing keys, wrong types and
//! impossible values are one-line errors naming the key.
//!
//! ```toml
//! format = "thermrs-scenario/1"
//! seed = 1
//! start_time = 2026-11-02T07:30:00Z  # when the first run starts (default 2025-06-15T15:06:40Z)
//!
//! [[run]]
//! name = "run1"
//! speed_pct = 30
//! duration_min = 900
//! cycle_s = 60
//! start = "ambient"            # or "continue": no cool-down after the previous run
//! idle_before_min = 0          # robot idle (cooling) before this run starts
//! # start_time = 2026-11-03T07:30:00Z  # or: when this run starts (idle until then)
//!
//! [ambient]
//! start_c = 23.38
//! drift_c_per_h = 0.0          # linear drift
//! swing_c = 0.0                # daily sine, amplitude
//! noise_c = 0.02               # thermometer noise
//!
//! [[effect]]
//! name = "thermal_lag"
//! tau_min = 25.0
//!
//! # Thermal nodes (optional; default the KR 15/2 calibration, `heat::kr15_paper_nodes`).
//! # Each gives its steady rise over ambient (K) at speed fraction s in exactly one of two
//! # forms, non-decreasing in s on [0, 1]:
//! [[node]]
//! name = "link2"               # a ROI of the rig
//! tau_min = 391.64
//! # r0_k + span_k·(1 − exp(−s/s0)), span_k ≥ 0, s0 > 0
//! rise_saturating = { r0_k = 0.4383, span_k = 5.0305, s0 = 0.096403 }
//!
//! [[node]]
//! name = "base"
//! tau_min = 600.0
//! rise_k = [0.10, 0.85, 0.50]  # r0 + r1·s + r2·s², r1 ≥ 0 and r1 + 2·r2 ≥ 0
//! ```

use serde::{Deserialize, Serialize};

use crate::effects::{Effect, EffectSpec};
use crate::error::{FileKind, KeyError, RigError};
use crate::heat::Rise;

/// The format string every scenario file must carry.
pub const SCENARIO_FORMAT: &str = "thermrs-scenario/1";
/// When the first run starts unless the scenario says (`start_time`): 2025-06-15T15:06:40Z,
/// like the sample recording.
pub const T0_NS: i64 = 1_750_000_000_000_000_000;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    pub format: String,
    #[serde(default)]
    pub name: Option<String>,
    /// Seed of every random draw: the same seed gives byte-identical recordings.
    #[serde(default)]
    pub seed: u64,
    /// When the first run starts, ns since the Unix epoch (a TOML offset date-time or an RFC
    /// 3339 string; default [`T0_NS`]).
    #[serde(default, with = "start_time")]
    pub start_time: Option<i64>,
    pub run: Vec<Run>,
    #[serde(default)]
    pub ambient: AmbientProfile,
    #[serde(default)]
    pub camera: CameraModel,
    #[serde(default)]
    pub ir: IrModel,
    #[serde(default)]
    pub motion: Motion,
    #[serde(default)]
    pub output: Output,
    /// Thermal nodes (default: the KR 15/2 calibration of `heat::kr15_paper_nodes`).
    #[serde(default)]
    pub node: Vec<Node>,
    /// SPEC §6 effects, as written (see [`crate::effects`]; [`Scenario::effects`] types them).
    #[serde(default)]
    pub effect: Vec<EffectSpec>,
}

/// How a run starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Start {
    /// Every node at ambient.
    Ambient,
    /// Where the previous run (and `idle_before_min` of cooling) left it; the first run of a
    /// scenario has nothing to continue from and starts at ambient.
    Continue,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Run {
    pub name: String,
    /// Robot speed, % of maximum (0 < speed ≤ 100).
    pub speed_pct: f64,
    pub duration_min: f64,
    /// One cycle visits every camera pose once.
    pub cycle_s: f64,
    #[serde(default = "default_start")]
    pub start: Start,
    /// Minutes of idling (cooling) before the run.
    #[serde(default)]
    pub idle_before_min: f64,
    /// When the run starts, ns since the Unix epoch: the robot idles (cools, the room
    /// drifting) from the previous run's end until then. Not with `idle_before_min`.
    #[serde(default, with = "start_time")]
    pub start_time: Option<i64>,
}

/// `start_time` keys: a TOML offset date-time (`2026-11-02T07:30:00Z`) or the same as an RFC
/// 3339 string, held as ns since the Unix epoch; written back as an RFC 3339 string.
mod start_time {
    use serde::{de::Error as _, Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(v: &Option<i64>, s: S) -> Result<S::Ok, S::Error> {
        match v {
            None => s.serialize_none(),
            Some(ns) => match jiff::Timestamp::from_nanosecond(i128::from(*ns)) {
                Ok(t) => s.serialize_some(&t.to_string()),
                Err(e) => Err(serde::ser::Error::custom(e)),
            },
        }
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<i64>, D::Error> {
        // `null` (the JSON this module writes for no start time) is none.
        let Some(v) = Option::<toml::Value>::deserialize(d)? else {
            return Ok(None);
        };
        let text = match &v {
            toml::Value::String(s) => s.clone(),
            toml::Value::Datetime(t) if t.offset.is_some() && t.time.is_some() => t.to_string(),
            toml::Value::Datetime(t) => {
                return Err(D::Error::custom(format!(
                    "{t} has no time zone: give one, e.g. {t}T07:30:00Z or with +01:00"
                )))
            }
            other => {
                return Err(D::Error::custom(format!(
                    "expected a date-time such as 2026-11-02T07:30:00Z, got {other}"
                )))
            }
        };
        let t: jiff::Timestamp = text.parse().map_err(|e| {
            D::Error::custom(format!(
                "{text:?} is not a date-time with a time zone such as 2026-11-02T07:30:00Z ({e})"
            ))
        })?;
        i64::try_from(t.as_nanosecond())
            .map(Some)
            .map_err(|_| D::Error::custom(format!("{text} is out of range")))
    }
}

fn default_start() -> Start {
    Start::Continue
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AmbientProfile {
    pub start_c: f64,
    pub drift_c_per_h: f64,
    /// Amplitude of a 24-hour sine (°C).
    pub swing_c: f64,
    /// Thermometer noise (°C rms).
    pub noise_c: f64,
    /// Ambient readings per cycle.
    pub readings_per_cycle: u32,
}

impl Default for AmbientProfile {
    fn default() -> Self {
        AmbientProfile {
            start_c: 23.38,
            drift_c_per_h: 0.0,
            swing_c: 0.0,
            noise_c: 0.02,
            readings_per_cycle: 1,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CameraModel {
    /// `visits`: frames only while the robot dwells at the camera's pose; `continuous`:
    /// frames all the time at `frame_rate_hz` (most of them dark).
    pub mode: String,
    pub frame_rate_hz: f64,
    /// Frames per visit (visit mode).
    pub frames_per_visit: u32,
    pub bits: u32,
    pub sigma_px: f64,
    pub peak_dn: f64,
    pub background_dn: f64,
    pub read_noise_dn: f64,
    pub dn_per_electron: f64,
    /// Exposure (s): a spot that moves during it is smeared along its path.
    pub exposure_s: f64,
}

impl Default for CameraModel {
    fn default() -> Self {
        CameraModel {
            mode: "visits".into(),
            frame_rate_hz: 25.0,
            frames_per_visit: 2,
            bits: 8,
            sigma_px: 4.0,
            peak_dn: 170.0,
            background_dn: 8.0,
            read_noise_dn: 1.5,
            dn_per_electron: 0.5,
            exposure_s: 0.01,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IrModel {
    /// `16UC1` (centi-kelvin counts with the rig's scale/offset) or `32FC1` (°C).
    pub encoding: String,
    /// IR frames per cycle.
    pub frames_per_cycle: u32,
    pub noise_c: f64,
    /// The hot distractor outside the ROIs (the paper's laser power supply), °C; 0 = none.
    pub distractor_c: f64,
}

impl Default for IrModel {
    fn default() -> Self {
        IrModel {
            encoding: "16UC1".into(),
            frames_per_cycle: 1,
            noise_c: 0.05,
            distractor_c: 35.0,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Motion {
    /// Seconds the robot dwells at each camera pose.
    pub dwell_s: f64,
    /// Pose repeatability: joint-angle noise per visit (µrad rms).
    pub repeatability_urad: f64,
    /// Joint states per second (plus one at every start and end of a move).
    pub joint_rate_hz: f64,
    /// Maximum joint rates (°/s) at 100 % speed; default the KR 15/2's (paper Table 1).
    pub max_rate_deg_s: [f64; 6],
    /// After its visits the robot turns away to present itself to the thermal camera: the
    /// first camera's pose plus this offset (°), where it rests until the next cycle.
    pub rest_offset_deg: [f64; 6],
}

impl Default for Motion {
    fn default() -> Self {
        Motion {
            dwell_s: 5.0,
            repeatability_urad: 2.0,
            joint_rate_hz: 2.0,
            max_rate_deg_s: [152.0, 152.0, 152.0, 284.0, 293.0, 604.0],
            rest_offset_deg: [-30.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Output {
    /// `none`, `zstd` or `lz4`.
    pub compression: String,
    pub chunk_size: u64,
}

impl Default for Output {
    fn default() -> Self {
        Output {
            compression: "zstd".into(),
            chunk_size: 4 << 20,
        }
    }
}

/// A thermal node (see `heat::NodeParams`). Its steady rise over ambient (K) at speed fraction
/// `s` is given by exactly one of `rise_k` and `rise_saturating`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Node {
    /// A ROI name of the rig.
    pub name: String,
    pub tau_min: f64,
    /// Quadratic steady rise `[r0, r1, r2]`: `r0 + r1·s + r2·s²` (`heat::Rise::Quadratic`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rise_k: Option<[f64; 3]>,
    /// Saturating steady rise: `r0_k + span_k·(1 − exp(−s/s0))` (`heat::Rise::Saturating`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rise_saturating: Option<RiseSaturating>,
}

/// `rise_saturating = { r0_k = …, span_k = …, s0 = … }` of a `[[node]]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RiseSaturating {
    /// Standstill rise under servo, K.
    pub r0_k: f64,
    /// Extra rise approached as speed grows, K (≥ 0).
    pub span_k: f64,
    /// Speed scale, fraction of maximum (> 0).
    pub s0: f64,
}

impl Node {
    /// The node's steady rise, if exactly one of `rise_k` and `rise_saturating` is given
    /// (unchecked; [`Scenario::validate`] checks it).
    pub fn rise(&self) -> Option<Rise> {
        match (self.rise_k, self.rise_saturating) {
            (Some(r), None) => Some(Rise::Quadratic(r)),
            (None, Some(RiseSaturating { r0_k, span_k, s0 })) => {
                Some(Rise::Saturating { r0_k, span_k, s0 })
            }
            _ => None,
        }
    }
}

impl Scenario {
    /// The scenario's effects, typed (valid once [`Scenario::validate`] passed).
    pub fn effects(&self) -> Result<Vec<Effect>, RigError> {
        self.effect
            .iter()
            .enumerate()
            .map(|(i, e)| {
                Effect::from_spec(e).map_err(|KeyError { key, message }| RigError {
                    kind: FileKind::Scenario,
                    source_name: self.name.clone().unwrap_or_else(|| "<scenario>".into()),
                    line: None,
                    key: if key.is_empty() {
                        format!("effect[{i}]")
                    } else {
                        format!("effect[{i}].{key}")
                    },
                    message,
                })
            })
            .collect()
    }

    /// Parse and validate scenario TOML text; `source_name` names it in errors.
    pub fn from_toml(text: &str, source_name: &str) -> Result<Scenario, RigError> {
        crate::config::parse_strict(text, source_name, FileKind::Scenario, Scenario::validate)
    }

    /// The checks types cannot express. Returns (key, message) of the first problem.
    pub fn validate(&self) -> Result<(), KeyError> {
        if self.format != SCENARIO_FORMAT {
            return fail(
                "format",
                format!("is {:?}, expected {SCENARIO_FORMAT:?}", self.format),
            );
        }
        self.validate_runs()?;
        self.validate_models()?;
        self.validate_nodes_and_effects()
    }

    /// The `[[run]]`s: names once each, speeds, durations, cycles, starts.
    fn validate_runs(&self) -> Result<(), KeyError> {
        if self.run.is_empty() {
            return fail("run", "no [[run]] given; at least one is needed".into());
        }
        let mut names = std::collections::HashSet::new();
        for (i, r) in self.run.iter().enumerate() {
            let k = |f: &str| format!("run[{i}].{f}");
            if r.name.trim().is_empty() || !names.insert(r.name.as_str()) {
                return fail(&k("name"), format!("{:?} is empty or used twice", r.name));
            }
            if !(r.speed_pct > 0.0 && r.speed_pct <= 100.0) {
                return fail(
                    &k("speed_pct"),
                    format!("is {}, expected 0 < speed ≤ 100", r.speed_pct),
                );
            }
            positive(r.duration_min, &k("duration_min"))?;
            positive(r.cycle_s, &k("cycle_s"))?;
            if !(r.idle_before_min.is_finite() && r.idle_before_min >= 0.0) {
                return fail(
                    &k("idle_before_min"),
                    format!("is {}, expected ≥ 0", r.idle_before_min),
                );
            }
            if r.start_time.is_some() && r.idle_before_min > 0.0 {
                return fail(
                    &k("start_time"),
                    "and idle_before_min both given: the start time sets the idle time".into(),
                );
            }
        }
        self.validate_start_times()
    }

    /// Each run's idle time before it (s): `idle_before_min`, or up to its `start_time`.
    /// Errors where a run's start time is before the previous run's end.
    pub fn idle_before_s(&self) -> Result<Vec<f64>, KeyError> {
        let t0 = self.start_time.unwrap_or(T0_NS);
        let mut t_s = 0.0_f64;
        let mut out = Vec::with_capacity(self.run.len());
        for (i, r) in self.run.iter().enumerate() {
            let idle = match r.start_time {
                None => r.idle_before_min * 60.0,
                Some(ns) => {
                    let at = (ns - t0) as f64 / 1e9;
                    if at < t_s {
                        let prev = if i == 0 {
                            "the scenario's start_time".to_string()
                        } else {
                            format!("run {:?} ends", self.run[i - 1].name)
                        };
                        return Err(KeyError::new(
                            format!("run[{i}].start_time"),
                            format!("is {:.0} s before {prev}", t_s - at),
                        ));
                    }
                    at - t_s
                }
            };
            out.push(idle);
            let cycles = (r.duration_min * 60.0 / r.cycle_s).floor();
            t_s += idle + cycles * r.cycle_s;
        }
        Ok(out)
    }

    fn validate_start_times(&self) -> Result<(), KeyError> {
        self.idle_before_s().map(|_| ())
    }

    /// The sensor and motion models: `[ambient]`, `[camera]`, `[ir]`, `[motion]`, `[output]`,
    /// in file order.
    fn validate_models(&self) -> Result<(), KeyError> {
        self.validate_ambient()?;
        self.validate_camera()?;
        self.validate_motion_and_output()
    }

    /// `[ambient]`: finite temperatures, noise ≥ 0.
    fn validate_ambient(&self) -> Result<(), KeyError> {
        let a = &self.ambient;
        for (k, v) in [
            ("ambient.start_c", a.start_c),
            ("ambient.drift_c_per_h", a.drift_c_per_h),
            ("ambient.swing_c", a.swing_c),
        ] {
            if !v.is_finite() {
                return fail(k, format!("is {v}, expected a finite number"));
            }
        }
        if !(a.noise_c.is_finite() && a.noise_c >= 0.0) {
            return fail("ambient.noise_c", format!("is {}, expected ≥ 0", a.noise_c));
        }
        Ok(())
    }

    /// `[camera]`: mode, rates, bits, the spot and noise model (the exposure is checked with
    /// the motion, after it, as it always was).
    fn validate_camera(&self) -> Result<(), KeyError> {
        let c = &self.camera;
        if c.mode != "visits" && c.mode != "continuous" {
            return fail(
                "camera.mode",
                format!("is {:?}, expected \"visits\" or \"continuous\"", c.mode),
            );
        }
        positive(c.frame_rate_hz, "camera.frame_rate_hz")?;
        if c.frames_per_visit == 0 {
            return fail(
                "camera.frames_per_visit",
                "is 0, expected at least 1".into(),
            );
        }
        if c.bits != 8 && c.bits != 16 {
            return fail("camera.bits", format!("is {}, expected 8 or 16", c.bits));
        }
        positive(c.sigma_px, "camera.sigma_px")?;
        positive(c.peak_dn, "camera.peak_dn")?;
        positive(c.dn_per_electron, "camera.dn_per_electron")?;
        for (k, v) in [
            ("camera.background_dn", c.background_dn),
            ("camera.read_noise_dn", c.read_noise_dn),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return fail(k, format!("is {v}, expected ≥ 0"));
            }
        }
        Ok(())
    }

    /// `[ir]` encoding, `[motion]` rates and dwell, the camera's exposure, `[output]`.
    fn validate_motion_and_output(&self) -> Result<(), KeyError> {
        if self.ir.encoding != "16UC1" && self.ir.encoding != "32FC1" {
            return fail(
                "ir.encoding",
                format!("is {:?}, expected \"16UC1\" or \"32FC1\"", self.ir.encoding),
            );
        }
        positive(self.motion.dwell_s, "motion.dwell_s")?;
        positive(self.motion.joint_rate_hz, "motion.joint_rate_hz")?;
        for (j, v) in self.motion.max_rate_deg_s.iter().enumerate() {
            positive(*v, &format!("motion.max_rate_deg_s[{j}]"))?;
        }
        let c = &self.camera;
        if !(c.exposure_s.is_finite()
            && c.exposure_s >= 0.0
            && c.exposure_s < 1.0 / c.frame_rate_hz)
        {
            return fail(
                "camera.exposure_s",
                format!(
                    "is {}, expected 0 ≤ exposure < 1/frame_rate_hz",
                    c.exposure_s
                ),
            );
        }
        if !matches!(self.output.compression.as_str(), "none" | "zstd" | "lz4") {
            return fail(
                "output.compression",
                format!(
                    "is {:?}, expected none, zstd or lz4",
                    self.output.compression
                ),
            );
        }
        Ok(())
    }

    /// The `[[node]]`s (time constant, one steady rise) and `[[effect]]`s (SPEC §6 values).
    fn validate_nodes_and_effects(&self) -> Result<(), KeyError> {
        for (i, n) in self.node.iter().enumerate() {
            positive(n.tau_min, &format!("node[{i}].tau_min"))?;
            let Some(rise) = n.rise() else {
                let m = if n.rise_k.is_some() {
                    "gives both `rise_k` and `rise_saturating`; give exactly one"
                } else {
                    "needs its steady rise: `rise_k = [r0, r1, r2]` or \
                     `rise_saturating = { r0_k, span_k, s0 }`"
                };
                return fail(&format!("node[{i}]"), m.into());
            };
            if let Err(KeyError { key, message: m }) = rise.check() {
                return fail(&format!("node[{i}].{key}"), m);
            }
        }
        for (i, e) in self.effect.iter().enumerate() {
            if let Err(KeyError { key, message: m }) = Effect::from_spec(e) {
                let k = if key.is_empty() {
                    format!("effect[{i}]")
                } else {
                    format!("effect[{i}].{key}")
                };
                return fail(&k, m);
            }
        }
        Ok(())
    }
}

/// A problem with `key`.
fn fail(key: &str, message: String) -> Result<(), KeyError> {
    Err(KeyError::new(key.to_string(), message))
}

/// `Ok` if `v` is a finite positive number, else an error naming `key`.
fn positive(v: f64, key: &str) -> Result<(), KeyError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        fail(key, format!("is {v}, expected a positive number"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MIN: &str = "format = \"thermrs-scenario/1\"\n[[run]]\nname = \"r\"\nspeed_pct = 30\nduration_min = 60\ncycle_s = 60\n";

    #[test]
    fn minimal_scenario_gets_defaults() {
        let s = Scenario::from_toml(MIN, "s.toml").unwrap();
        assert_eq!(s.run[0].start, Start::Continue);
        assert_eq!(s.camera.mode, "visits");
        assert_eq!(s.output.compression, "zstd");
    }

    #[test]
    fn start_times_set_the_clock_and_the_idle_time_between_runs() {
        // 2026-11-02T07:30:00Z is 1,793,604,600 s after the epoch (`date -d … +%s`).
        let t0: i64 = 1_793_604_600 * 1_000_000_000;
        let two = format!(
            "start_time = 2026-11-02T07:30:00Z\n{MIN}[[run]]\nname = \"next\"\nspeed_pct = 75\n\
             duration_min = 60\ncycle_s = 60\nstart_time = \"2026-11-03T08:30:00+01:00\"\n"
        );
        let s = Scenario::from_toml(&two, "s.toml").unwrap();
        assert_eq!(s.start_time, Some(t0));
        // The next day at 07:30 UTC: a day after the first started, 23 h after it ended.
        assert_eq!(s.run[1].start_time, Some(t0 + 86_400 * 1_000_000_000));
        assert_eq!(s.idle_before_s().unwrap(), vec![0.0, 86_400.0 - 3600.0]);
        // Written back as RFC 3339 text.
        let json = serde_json::to_value(&s).unwrap();
        assert_eq!(json["start_time"], "2026-11-02T07:30:00Z");
        let back: Scenario = serde_json::from_value(json).unwrap();
        assert_eq!(back, s);
        assert!(Scenario::from_toml(MIN, "s.toml")
            .unwrap()
            .start_time
            .is_none());
        let cases = [
            (format!("start_time = 2026-11-02\n{MIN}"), "no time zone"),
            (
                format!("start_time = 2026-11-02T07:30:00\n{MIN}"),
                "no time zone",
            ),
            (
                format!("start_time = \"yesterday\"\n{MIN}"),
                "not a date-time",
            ),
            (
                two.replace("2026-11-03T08:30:00+01:00", "2026-11-02T08:00:00Z"),
                "before run \"r\" ends",
            ),
            (
                two.replace(
                    "start_time = \"2026",
                    "idle_before_min = 5\nstart_time = \"2026",
                ),
                "both given",
            ),
        ];
        for (text, says) in cases {
            let e = Scenario::from_toml(&text, "s.toml").unwrap_err();
            assert!(e.to_string().contains(says), "{e}");
        }
    }

    #[test]
    fn bad_scenarios_name_the_key() {
        let cases = [
            (
                MIN.replace("speed_pct = 30", "speed_pct = 130"),
                "run[0].speed_pct",
            ),
            (MIN.replace("speed_pct", "sped_pct"), "run[0]"),
            (format!("{MIN}[camera]\nbits = 12\n"), "camera.bits"),
            (
                format!("{MIN}[camera]\nmode = \"sometimes\"\n"),
                "camera.mode",
            ),
            (
                format!("{MIN}[[effect]]\nname = \"thermal_lag\"\n"),
                "effect[0]",
            ),
            (
                format!("{MIN}[[effect]]\nname = \"thermal_lag\"\ntau_min = 3\num = [1, 2]\n"),
                "effect[0].um",
            ),
            (
                format!("{MIN}[[effect]]\nname = \"gremlins\"\n"),
                "effect[0].name",
            ),
            (
                format!("{MIN}[output]\ncompression = \"gzip\"\n"),
                "output.compression",
            ),
        ];
        for (text, key) in cases {
            let e = Scenario::from_toml(&text, "s.toml").unwrap_err();
            assert!(e.key.starts_with(key), "{key}: {e}");
            assert!(!e.to_string().contains('\n'));
        }
    }

    const NODE: &str = "[[node]]\nname = \"link2\"\ntau_min = 30\n";

    #[test]
    fn nodes_take_either_rise_form() {
        let text = format!(
            "{MIN}{NODE}rise_saturating = {{ r0_k = 0.44, span_k = 5.03, s0 = 0.0964 }}\n\
             [[node]]\nname = \"base\"\ntau_min = 600\nrise_k = [0.1, 0.85, 0.5]\n"
        );
        let s = Scenario::from_toml(&text, "s.toml").unwrap();
        assert_eq!(
            s.node[0].rise(),
            Some(Rise::Saturating {
                r0_k: 0.44,
                span_k: 5.03,
                s0: 0.0964
            })
        );
        assert_eq!(s.node[1].rise(), Some(Rise::Quadratic([0.1, 0.85, 0.5])));
        // The scenario as JSON (the simulator's truth) names only the form given, and reads back.
        let json = serde_json::to_value(&s).unwrap();
        assert_eq!(
            json["node"][0],
            serde_json::json!({
                "name": "link2",
                "tau_min": 30.0,
                "rise_saturating": { "r0_k": 0.44, "span_k": 5.03, "s0": 0.0964 }
            })
        );
        assert_eq!(
            json["node"][1],
            serde_json::json!({"name": "base", "tau_min": 600.0, "rise_k": [0.1, 0.85, 0.5]})
        );
        let back: Scenario = serde_json::from_value(json).unwrap();
        assert_eq!(back, s);
    }

    /// Each scenario text fails on `key` with a one-line message containing `msg`.
    fn assert_named(cases: &[(String, &str, &str)]) {
        for (text, key, msg) in cases {
            let e = Scenario::from_toml(text, "s.toml").unwrap_err();
            assert!(e.key.starts_with(key), "{key}: {e}");
            assert!(e.to_string().contains(msg), "{msg}: {e}");
            assert!(!e.to_string().contains('\n'));
        }
    }

    #[test]
    fn bad_nodes_name_the_key() {
        assert_named(&[
            (format!("{MIN}{NODE}"), "node[0]", "needs its steady rise"),
            (
                format!(
                    "{MIN}{NODE}rise_k = [1, 2, 0]\n\
                     rise_saturating = {{ r0_k = 1, span_k = 2, s0 = 0.1 }}\n"
                ),
                "node[0]",
                "exactly one",
            ),
            // the old default link 2 quadratic: peaks at ~55 % and falls
            (
                format!("{MIN}{NODE}rise_k = [2.5695, 12.2877, -11.2331]\n"),
                "node[0].rise_k",
                "decreases",
            ),
            (
                format!("{MIN}{NODE}rise_k = [1, -0.5, 2]\n"),
                "node[0].rise_k",
                "decreases",
            ),
            (
                format!("{MIN}{NODE}rise_k = [1, 2, nan]\n"),
                "node[0].rise_k",
                "finite",
            ),
            (
                format!("{MIN}{NODE}rise_k = [1, 2]\n"),
                "node[0].rise_k",
                "",
            ),
            (
                format!("{MIN}{NODE}rise_k = [0, 1, 0]\nrise = 3\n"),
                "node[0]",
                "rise",
            ),
        ]);
        // the second node is named
        let text = format!("{MIN}{NODE}rise_k = [0, 1, 0]\n{NODE}rise_k = [0, 1, -0.6]\n");
        let e = Scenario::from_toml(&text, "s.toml").unwrap_err();
        assert_eq!(e.key, "node[1].rise_k", "{e}");
    }

    #[test]
    fn bad_saturating_nodes_name_the_key() {
        let sat = |r0: &str, span: &str, s0: &str| {
            format!("{MIN}{NODE}rise_saturating = {{ r0_k = {r0}, span_k = {span}, s0 = {s0} }}\n")
        };
        assert_named(&[
            (
                sat("1", "-0.1", "0.1"),
                "node[0].rise_saturating.span_k",
                "≥ 0",
            ),
            (
                sat("1", "inf", "0.1"),
                "node[0].rise_saturating.span_k",
                "≥ 0",
            ),
            (sat("1", "2", "0"), "node[0].rise_saturating.s0", "positive"),
            (
                sat("1", "2", "-0.1"),
                "node[0].rise_saturating.s0",
                "positive",
            ),
            (
                sat("nan", "2", "0.1"),
                "node[0].rise_saturating.r0_k",
                "finite",
            ),
            (
                format!("{MIN}{NODE}rise_saturating = {{ r0_k = 1, span_k = 2 }}\n"),
                "node[0].rise_saturating",
                "s0",
            ),
            (
                format!(
                    "{MIN}{NODE}rise_saturating = {{ r0_k = 1, span_k = 2, s0 = 0.1, tau = 3 }}\n"
                ),
                "node[0].rise_saturating",
                "tau",
            ),
        ]);
    }

    #[test]
    fn effect_values_out_of_range_are_named() {
        for (body, key) in [
            (
                "name = \"thermal_lag\"\ntau_min = -5\n",
                "effect[0].tau_min",
            ),
            (
                "name = \"nonlinear_alpha\"\nkappa_per_k = 3\n",
                "effect[0].kappa_per_k",
            ),
        ] {
            let e = Scenario::from_toml(&format!("{MIN}[[effect]]\n{body}"), "s").unwrap_err();
            assert_eq!(e.key, key, "{e}");
        }
    }
}
