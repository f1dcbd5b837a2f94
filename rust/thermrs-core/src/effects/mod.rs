//! The unmodelled effects of SPEC §6 — their one home.
//!
//! Each effect is one variant of [`Effect`], with its parameters (the SPEC's JSON keys), its
//! validation ([`Effect::validate`] on values, [`Effect::check`] against a rig) and its action
//! on the forward model ([`Effects::build`]). The simulator, the bindings and, through them, the
//! diagnoser all build on this module: adding an effect means a variant here, its Python face
//! (`thermrs.effects`) and a row of the SPEC table.
//!
//! An effect acts in one of three places:
//! - on the **geometry** the forward model computes ([`ModelParams`]): `alpha_per_link`,
//!   `nonlinear_alpha`, `unmodelled_length`, `joint_offset`, `laser_tilt`;
//! - on the **temperatures** before they reach the model: `thermal_lag` (the structure follows
//!   the surface the IR camera sees through the first-order law [`crate::heat::lag_step`]);
//! - on the **chip**, as an apparent shift of the spot: `fixture_drift` (with ambient) and
//!   `sensor_drift` (with time since the run began) ([`Effects::chip_shift_um`]).
//!
//! Scenario files write effects as flat tables (`[[effect]] name = "…" key = value`); they are
//! parsed into [`EffectSpec`] (so that a wrong key is named) and turned into an [`Effect`] by
//! [`Effect::from_spec`]. JSON (the bindings) uses the same shape: `{"name": "thermal_lag",
//! "tau_min": 25.0}`.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::error::{Error, NameKind, Result, UnknownName};
use crate::model::{JointOffset, LaserTilt, ModelParams};
use crate::rig::{LengthRef, Rig, AMBIENT};

/// Effect names of SPEC §6 (the contract), in the SPEC's order.
pub const EFFECT_NAMES: [&str; 8] = [
    "alpha_per_link",
    "thermal_lag",
    "unmodelled_length",
    "fixture_drift",
    "laser_tilt",
    "joint_offset",
    "nonlinear_alpha",
    "sensor_drift",
];

/// Physical bounds on effect values: beyond them a value is a typo or a unit slip.
pub mod bounds {
    /// |α| of any length (1/K): every engineering solid is below 1e-4; 1e-3 leaves room.
    pub const ALPHA_PER_K: f64 = 1e-3;
    /// |κ| (1/K) of the quadratic strain term.
    pub const KAPPA_PER_K: f64 = 0.1;
    /// Time constants (min): above zero, below a week.
    pub const TAU_MIN_MAX: f64 = 10_080.0;
    /// |tilt| of the laser (degrees).
    pub const TILT_DEG: f64 = 10.0;
    /// |joint zero drift| (µrad/K).
    pub const URAD_PER_K: f64 = 10_000.0;
    /// |chip mount drift| (µm/K).
    pub const UM_PER_K: f64 = 1_000.0;
    /// |chip self-heating drift| (µm).
    pub const UM: f64 = 10_000.0;
    /// The share of the expansion that lags (`thermal_lag`'s `weight`): above zero, at most
    /// this (a structure cannot overshoot its surface's change by more).
    pub const LAG_WEIGHT: f64 = 2.0;
    /// An unmodelled length's α over the model's (`unmodelled_length`'s `weight`): above zero,
    /// at most this (a polymer part's ≈1e-4/K against a steel structure's 1.2e-5/K is 8).
    pub const LENGTH_WEIGHT: f64 = 10.0;
}

/// One SPEC §6 effect with its parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "name", rename_all = "snake_case", deny_unknown_fields)]
pub enum Effect {
    /// Each mapped temperature has its own α (1/K); temperatures not listed keep the model's α.
    AlphaPerLink { alpha_per_k: BTreeMap<String, f64> },
    /// The structure lags the surface temperature the IR camera sees, first order, `tau_min`;
    /// `weight` (an extension, default 1: all of it) is the share of the expansion that lags,
    /// the structure seeing T + weight·(lag(T) − T).
    ThermalLag {
        tau_min: f64,
        #[serde(default = "unit_weight", skip_serializing_if = "is_unit_weight")]
        weight: f64,
    },
    /// A DH length (`a<i>`/`d<i>`) the rig does not list expands with `temperature`;
    /// `weight` (an extension, default 1: the same α) is its α as a multiple of the model's
    /// α for that temperature (a part of another material).
    UnmodelledLength {
        length: String,
        temperature: String,
        #[serde(default = "unit_weight", skip_serializing_if = "is_unit_weight")]
        weight: f64,
    },
    /// `camera`'s mount moves with ambient: `um_per_k` [u, v] per kelvin above reference; the
    /// mount follows the room through its own first-order inertia `mount_tau_min` (an
    /// extension, default 0: at once).
    FixtureDrift {
        camera: String,
        um_per_k: [f64; 2],
        #[serde(default)]
        mount_tau_min: f64,
    },
    /// The true laser direction is the rig's turned by `tilt_deg` (about the axis direction ×
    /// flange z, itself turned by `azimuth_deg` about the ray; an extension, default 0).
    LaserTilt {
        tilt_deg: f64,
        #[serde(default)]
        azimuth_deg: f64,
    },
    /// `joint`'s zero moves by `urad_per_k` per kelvin of `temperature` above reference.
    JointOffset {
        joint: String,
        temperature: String,
        urad_per_k: f64,
    },
    /// strain = α·ΔT·(1 + κ·ΔT).
    NonlinearAlpha { kappa_per_k: f64 },
    /// `camera`'s chip drifts on its own: `um`·(1 − e^(−t/τ)), t since the run began.
    SensorDrift {
        camera: String,
        tau_min: f64,
        um: [f64; 2],
    },
}

fn unit_weight() -> f64 {
    1.0
}

fn is_unit_weight(w: &f64) -> bool {
    *w == 1.0
}

/// An effect as a scenario file writes it: a name and flat optional keys (parsed strictly, so
/// that an unknown key is named), turned into an [`Effect`] by [`Effect::from_spec`].
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EffectSpec {
    pub name: String,
    #[serde(default)]
    pub alpha_per_k: Option<BTreeMap<String, f64>>,
    #[serde(default)]
    pub tau_min: Option<f64>,
    #[serde(default)]
    pub length: Option<String>,
    #[serde(default)]
    pub temperature: Option<String>,
    #[serde(default)]
    pub camera: Option<String>,
    #[serde(default)]
    pub um_per_k: Option<[f64; 2]>,
    #[serde(default)]
    pub tilt_deg: Option<f64>,
    #[serde(default)]
    pub azimuth_deg: Option<f64>,
    #[serde(default)]
    pub joint: Option<String>,
    #[serde(default)]
    pub urad_per_k: Option<f64>,
    #[serde(default)]
    pub kappa_per_k: Option<f64>,
    #[serde(default)]
    pub um: Option<[f64; 2]>,
    #[serde(default)]
    pub mount_tau_min: Option<f64>,
    #[serde(default)]
    pub weight: Option<f64>,
}

/// A problem with an effect: the key (relative to the effect) and what is wrong.
pub use crate::error::KeyError;

fn finite_within(key: &str, v: f64, bound: f64, unit: &str) -> std::result::Result<(), KeyError> {
    if v.is_finite() && v.abs() <= bound {
        Ok(())
    } else {
        Err(KeyError::new(
            key,
            format!("is {v}, expected a finite value with |value| ≤ {bound} {unit}"),
        ))
    }
}

fn time_constant(key: &str, v: f64) -> std::result::Result<(), KeyError> {
    if v.is_finite() && v > 0.0 && v <= bounds::TAU_MIN_MAX {
        Ok(())
    } else {
        Err(KeyError::new(
            key,
            format!(
                "is {v}, expected a time constant 0 < τ ≤ {} min",
                bounds::TAU_MIN_MAX
            ),
        ))
    }
}

fn nonempty(key: &str, v: &str) -> std::result::Result<(), KeyError> {
    if v.trim().is_empty() {
        Err(KeyError::new(key, "is empty"))
    } else {
        Ok(())
    }
}

impl Effect {
    /// The SPEC §6 name.
    pub fn name(&self) -> &'static str {
        match self {
            Effect::AlphaPerLink { .. } => "alpha_per_link",
            Effect::ThermalLag { .. } => "thermal_lag",
            Effect::UnmodelledLength { .. } => "unmodelled_length",
            Effect::FixtureDrift { .. } => "fixture_drift",
            Effect::LaserTilt { .. } => "laser_tilt",
            Effect::JointOffset { .. } => "joint_offset",
            Effect::NonlinearAlpha { .. } => "nonlinear_alpha",
            Effect::SensorDrift { .. } => "sensor_drift",
        }
    }

    /// The keys each effect requires (SPEC §6) and the optional ones it also takes.
    pub fn keys(name: &str) -> Option<(&'static [&'static str], &'static [&'static str])> {
        Some(match name {
            "alpha_per_link" => (&["alpha_per_k"], &[]),
            "thermal_lag" => (&["tau_min"], &["weight"]),
            "unmodelled_length" => (&["length", "temperature"], &["weight"]),
            "fixture_drift" => (&["camera", "um_per_k"], &["mount_tau_min"]),
            "laser_tilt" => (&["tilt_deg"], &["azimuth_deg"]),
            "joint_offset" => (&["joint", "temperature", "urad_per_k"], &[]),
            "nonlinear_alpha" => (&["kappa_per_k"], &[]),
            "sensor_drift" => (&["camera", "tau_min", "um"], &[]),
            _ => return None,
        })
    }

    /// The effect a scenario's flat table describes, its values checked
    /// ([`Effect::validate`]); the error names the key.
    pub fn from_spec(s: &EffectSpec) -> std::result::Result<Effect, KeyError> {
        let Some((required, optional)) = Effect::keys(&s.name) else {
            return Err(KeyError::new(
                "name",
                format!(
                    "{:?} is not a SPEC §6 effect ({})",
                    s.name,
                    EFFECT_NAMES.join(", ")
                ),
            ));
        };
        let present = s.present_keys();
        for r in required {
            if !present.contains(r) {
                return Err(KeyError::new(
                    String::new(),
                    format!("effect {:?} needs `{r}`", s.name),
                ));
            }
        }
        for p in &present {
            if !required.contains(p) && !optional.contains(p) {
                let mut takes: Vec<&str> = required.to_vec();
                takes.extend_from_slice(optional);
                return Err(KeyError::new(
                    *p,
                    format!(
                        "is not a parameter of {:?} (it takes {})",
                        s.name,
                        takes.join(", ")
                    ),
                ));
            }
        }
        let text = |o: &Option<String>| o.clone().unwrap_or_default();
        let e = match s.name.as_str() {
            "alpha_per_link" => Effect::AlphaPerLink {
                alpha_per_k: s.alpha_per_k.clone().unwrap_or_default(),
            },
            "thermal_lag" => Effect::ThermalLag {
                tau_min: s.tau_min.unwrap_or(f64::NAN),
                weight: s.weight.unwrap_or(1.0),
            },
            "unmodelled_length" => Effect::UnmodelledLength {
                length: text(&s.length),
                temperature: text(&s.temperature),
                weight: s.weight.unwrap_or(1.0),
            },
            "fixture_drift" => Effect::FixtureDrift {
                camera: text(&s.camera),
                um_per_k: s.um_per_k.unwrap_or([f64::NAN; 2]),
                mount_tau_min: s.mount_tau_min.unwrap_or(0.0),
            },
            "laser_tilt" => Effect::LaserTilt {
                tilt_deg: s.tilt_deg.unwrap_or(f64::NAN),
                azimuth_deg: s.azimuth_deg.unwrap_or(0.0),
            },
            "joint_offset" => Effect::JointOffset {
                joint: text(&s.joint),
                temperature: text(&s.temperature),
                urad_per_k: s.urad_per_k.unwrap_or(f64::NAN),
            },
            "nonlinear_alpha" => Effect::NonlinearAlpha {
                kappa_per_k: s.kappa_per_k.unwrap_or(f64::NAN),
            },
            "sensor_drift" => Effect::SensorDrift {
                camera: text(&s.camera),
                tau_min: s.tau_min.unwrap_or(f64::NAN),
                um: s.um.unwrap_or([f64::NAN; 2]),
            },
            _ => unreachable!("keys() knows every name"),
        };
        e.validate()?;
        Ok(e)
    }

    /// Values in range, names well formed (rig-independent); the error names the key.
    pub fn validate(&self) -> std::result::Result<(), KeyError> {
        use bounds::*;
        match self {
            Effect::AlphaPerLink { alpha_per_k } => {
                if alpha_per_k.is_empty() {
                    return Err(KeyError::new("alpha_per_k", "names no temperature"));
                }
                for (k, v) in alpha_per_k {
                    nonempty("alpha_per_k", k)?;
                    finite_within(&format!("alpha_per_k.{k}"), *v, ALPHA_PER_K, "1/K")?;
                }
            }
            Effect::ThermalLag { tau_min, weight } => {
                time_constant("tau_min", *tau_min)?;
                if !(weight.is_finite() && *weight > 0.0 && *weight <= LAG_WEIGHT) {
                    return Err(KeyError::new(
                        "weight",
                        format!("is {weight}, expected a share 0 < weight ≤ {LAG_WEIGHT}"),
                    ));
                }
            }
            Effect::UnmodelledLength {
                length,
                temperature,
                weight,
            } => {
                if LengthRef::parse(length).is_none() {
                    return Err(KeyError::new(
                        "length",
                        format!("{length:?} is not a DH length (a1..a6, d1..d6)"),
                    ));
                }
                nonempty("temperature", temperature)?;
                if !(weight.is_finite() && *weight > 0.0 && *weight <= LENGTH_WEIGHT) {
                    return Err(KeyError::new(
                        "weight",
                        format!(
                            "is {weight}, expected the length's α over the model's, \
                             0 < weight ≤ {LENGTH_WEIGHT}"
                        ),
                    ));
                }
            }
            Effect::FixtureDrift {
                camera,
                um_per_k,
                mount_tau_min,
            } => {
                nonempty("camera", camera)?;
                for v in um_per_k {
                    finite_within("um_per_k", *v, UM_PER_K, "µm/K")?;
                }
                if *mount_tau_min != 0.0 {
                    time_constant("mount_tau_min", *mount_tau_min)?;
                }
            }
            Effect::LaserTilt {
                tilt_deg,
                azimuth_deg,
            } => {
                finite_within("tilt_deg", *tilt_deg, TILT_DEG, "°")?;
                finite_within("azimuth_deg", *azimuth_deg, 360.0, "°")?;
            }
            Effect::JointOffset {
                joint,
                temperature,
                urad_per_k,
            } => {
                nonempty("joint", joint)?;
                nonempty("temperature", temperature)?;
                finite_within("urad_per_k", *urad_per_k, URAD_PER_K, "µrad/K")?;
            }
            Effect::NonlinearAlpha { kappa_per_k } => {
                finite_within("kappa_per_k", *kappa_per_k, KAPPA_PER_K, "1/K")?
            }
            Effect::SensorDrift {
                camera,
                tau_min,
                um,
            } => {
                nonempty("camera", camera)?;
                time_constant("tau_min", *tau_min)?;
                for v in um {
                    finite_within("um", *v, UM, "µm")?;
                }
            }
        }
        Ok(())
    }

    /// The names an effect uses exist in `rig`: cameras, joints, temperatures (a ROI or
    /// `ambient`), lengths (not already listed in `[expansion]`).
    pub fn check(&self, rig: &Rig) -> Result<()> {
        let context = format!("effect {}", self.name());
        let rois: Vec<String> = rig
            .thermal
            .iter()
            .flat_map(|t| t.roi.iter().map(|r| r.name.clone()))
            .collect();
        let temperature = |context: &str, t: &str| -> Result<()> {
            if t == AMBIENT || rois.iter().any(|r| r == t) {
                return Ok(());
            }
            let mut known = rois.clone();
            known.push(AMBIENT.into());
            Err(UnknownName::new(context, NameKind::Temperature, t, known).into())
        };
        match self {
            Effect::AlphaPerLink { alpha_per_k } => {
                for t in alpha_per_k.keys() {
                    temperature(&format!("{context}: alpha_per_k"), t)?;
                }
            }
            Effect::UnmodelledLength {
                length,
                temperature: t,
                ..
            } => {
                temperature(&context, t)?;
                if rig.expansion.length.iter().any(|l| l.name == *length) {
                    return Err(Error::LengthAlreadyExpands {
                        length: length.clone(),
                    });
                }
            }
            Effect::FixtureDrift { camera, .. } | Effect::SensorDrift { camera, .. } => {
                if rig.camera_index(camera).is_none() {
                    let known = rig.camera.iter().map(|c| c.name.clone()).collect();
                    return Err(UnknownName::new(context, NameKind::Camera, camera, known).into());
                }
            }
            Effect::JointOffset {
                joint,
                temperature: t,
                ..
            } => {
                if joint_index(rig, joint).is_none() {
                    let known = rig.robot.joint_names.clone();
                    return Err(UnknownName::new(context, NameKind::Joint, joint, known).into());
                }
                temperature(&context, t)?;
            }
            Effect::ThermalLag { .. }
            | Effect::LaserTilt { .. }
            | Effect::NonlinearAlpha { .. } => {}
        }
        Ok(())
    }

    /// One effect from JSON (`{"name": …, key: value, …}`), its values validated.
    pub fn from_json(json: &str) -> Result<Effect> {
        let e: Effect = serde_json::from_str(json).map_err(|source| Error::EffectJson {
            what: "effect",
            source,
        })?;
        e.validated()
    }

    /// A JSON list of effects (`[{"name": …, …}, …]`), each one's values validated.
    pub fn list_from_json(json: &str) -> Result<Vec<Effect>> {
        let list: Vec<Effect> = serde_json::from_str(json).map_err(|source| Error::EffectJson {
            what: "effects",
            source,
        })?;
        list.into_iter().map(Effect::validated).collect()
    }

    /// The effect, if its values validate ([`Effect::validate`]); the error names it and the key.
    pub fn validated(self) -> Result<Effect> {
        match self.validate() {
            Ok(()) => Ok(self),
            Err(error) => Err(Error::EffectValue {
                effect: self.name(),
                error,
            }),
        }
    }
}

/// 0-based index of a joint given by its rig name or as a 1-based number `"1"`..`"6"`.
pub fn joint_index(rig: &Rig, joint: &str) -> Option<usize> {
    rig.robot
        .joint_names
        .iter()
        .position(|n| n == joint)
        .or_else(|| match joint.parse::<usize>() {
            Ok(k) if (1..=6).contains(&k) => Some(k - 1),
            _ => None,
        })
}

impl EffectSpec {
    fn present_keys(&self) -> Vec<&'static str> {
        let mut k = Vec::new();
        macro_rules! has {
            ($($f:ident),*) => { $( if self.$f.is_some() { k.push(stringify!($f)); } )* };
        }
        has!(
            alpha_per_k,
            tau_min,
            length,
            temperature,
            camera,
            um_per_k,
            tilt_deg,
            azimuth_deg,
            joint,
            urad_per_k,
            kappa_per_k,
            um,
            weight
        );
        k
    }
}

/// A chip shift: an apparent spot displacement on one camera's chip.
#[derive(Debug, Clone, Copy, PartialEq)]
enum ChipShift {
    /// `fixture_drift`: (camera index, µm per K above reference, the mount's lag s or 0).
    Fixture(usize, [f64; 2], f64),
    /// `sensor_drift`: (camera index, τ min, µm).
    Sensor(usize, f64, [f64; 2]),
}

/// A set of effects turned into what acts where: the forward model's parameters, the
/// structure's lag behind the surface, and the chip shifts.
#[derive(Debug, Clone, PartialEq)]
pub struct Effects {
    /// The forward model's parameters with every geometric effect.
    pub params: ModelParams,
    /// `thermal_lag`'s time constant (s), if any.
    pub lag_tau_s: Option<f64>,
    /// `thermal_lag`'s share of the expansion that lags (1 without one).
    pub lag_weight: f64,
    chip: Vec<ChipShift>,
}

impl Effects {
    /// `effects` on `rig` with the nominal expansion `alpha_per_k` at `reference_c`: each
    /// effect validated and checked against the rig; an effect given twice is an error.
    pub fn build(
        rig: &Rig,
        effects: &[Effect],
        alpha_per_k: f64,
        reference_c: f64,
    ) -> Result<Effects> {
        let mut params = ModelParams::nominal(rig);
        params.alpha_per_k = alpha_per_k;
        params.reference_c = reference_c;
        let mut set = Effects {
            params,
            lag_tau_s: None,
            lag_weight: 1.0,
            chip: Vec::new(),
        };
        let mut seen: Vec<String> = Vec::new();
        for e in effects {
            e.validate().map_err(|error| Error::EffectValue {
                effect: e.name(),
                error,
            })?;
            e.check(rig)?;
            // One of each, except where several instances are distinct mechanisms.
            let key = match e {
                Effect::UnmodelledLength { length, .. } => format!("unmodelled_length {length}"),
                Effect::JointOffset { joint, .. } => format!("joint_offset {joint}"),
                Effect::FixtureDrift { camera, .. } => format!("fixture_drift {camera}"),
                Effect::SensorDrift { camera, .. } => format!("sensor_drift {camera}"),
                other => other.name().to_string(),
            };
            if seen.contains(&key) {
                return Err(Error::DuplicateEffect { key });
            }
            seen.push(key);
            set.add(rig, e);
        }
        Ok(set)
    }

    /// The action of one (validated, checked) effect.
    fn add(&mut self, rig: &Rig, e: &Effect) {
        let p = &mut self.params;
        let camera = |c: &str| rig.camera_index(c).expect("checked");
        match e {
            Effect::AlphaPerLink { alpha_per_k } => {
                p.alpha_by_temperature = alpha_per_k.clone();
            }
            Effect::NonlinearAlpha { kappa_per_k } => p.kappa_per_k = *kappa_per_k,
            Effect::ThermalLag { tau_min, weight } => {
                self.lag_tau_s = Some(tau_min * 60.0);
                self.lag_weight = *weight;
            }
            Effect::UnmodelledLength {
                length,
                temperature,
                weight,
            } => p.extra_lengths.push((
                LengthRef::parse(length).expect("validated"),
                temperature.clone(),
                *weight,
            )),
            Effect::JointOffset {
                joint,
                temperature,
                urad_per_k,
            } => p.joint_offsets.push(JointOffset {
                joint: joint_index(rig, joint).expect("checked"),
                temperature: temperature.clone(),
                rad_per_k: urad_per_k * 1e-6,
            }),
            Effect::LaserTilt {
                tilt_deg,
                azimuth_deg,
            } => {
                p.laser_tilt = Some(LaserTilt {
                    tilt_deg: *tilt_deg,
                    azimuth_deg: *azimuth_deg,
                })
            }
            Effect::FixtureDrift {
                camera: c,
                um_per_k,
                mount_tau_min,
            } => self.chip.push(ChipShift::Fixture(
                camera(c),
                *um_per_k,
                mount_tau_min * 60.0,
            )),
            Effect::SensorDrift {
                camera: c,
                tau_min,
                um,
            } => self.chip.push(ChipShift::Sensor(camera(c), *tau_min, *um)),
        }
    }

    /// The lagged state after `dt` seconds, from the surface's `x_prev` → `x_now` (linear in
    /// between) and the state's `y_prev` (`thermal_lag`; without it the surface itself); the
    /// structure expands with [`Effects::structure_seen`] of it.
    pub fn structure_step(&self, x_prev: f64, x_now: f64, y_prev: f64, dt: f64) -> f64 {
        match self.lag_tau_s {
            Some(tau) => crate::heat::lag_step(x_prev, x_now, y_prev, dt, tau),
            None => x_now,
        }
    }

    /// The temperature the structure expands with, from the surface's `x` and the lagged
    /// state `y` of [`Effects::structure_step`]: x + weight·(y − x) (`thermal_lag`'s share).
    pub fn structure_seen(&self, x: f64, y: f64) -> f64 {
        x + self.lag_weight * (y - x)
    }

    /// A surface temperature series (times `t_s`, seconds) as the structure sees it
    /// ([`Effects::structure_seen`] of its lag).
    pub fn structure_series(&self, t_s: &[f64], x: &[f64]) -> Result<Vec<f64>> {
        match self.lag_tau_s {
            Some(tau) => {
                let y = crate::heat::first_order_lag(t_s, x, tau)?;
                Ok(x.iter()
                    .zip(&y)
                    .map(|(&a, &b)| self.structure_seen(a, b))
                    .collect())
            }
            None => Ok(x.to_vec()),
        }
    }

    /// An ambient temperature series (times `t_s`, seconds) as camera `camera`'s mount sees it
    /// (`fixture_drift`'s `mount_tau_min`; unchanged without one).
    pub fn mount_series(&self, camera: usize, t_s: &[f64], x: &[f64]) -> Result<Vec<f64>> {
        match self.mount_lag_s(camera) {
            Some(tau) => Ok(crate::heat::first_order_lag(t_s, x, tau)?),
            None => Ok(x.to_vec()),
        }
    }

    /// Whether any effect shifts chips.
    pub fn shifts_chips(&self) -> bool {
        !self.chip.is_empty()
    }

    /// The first-order lag (s) through which camera `camera`'s mount follows the room
    /// (`fixture_drift`'s `mount_tau_min`), if it has one.
    pub fn mount_lag_s(&self, camera: usize) -> Option<f64> {
        self.chip.iter().find_map(|s| match *s {
            ChipShift::Fixture(c, _, tau) if c == camera && tau > 0.0 => Some(tau),
            _ => None,
        })
    }

    /// The apparent shift (u, v) µm of camera `camera`'s spot at an ambient temperature, the
    /// temperature its mount has reached (the ambient through [`Effects::mount_lag_s`]; the
    /// ambient itself without one) and a time since the run began (s).
    pub fn chip_shift_um(
        &self,
        camera: usize,
        ambient_c: f64,
        mount_c: f64,
        t_since_start_s: f64,
    ) -> [f64; 2] {
        let mut d = [0.0; 2];
        for s in &self.chip {
            let add = match *s {
                ChipShift::Fixture(c, k, tau) if c == camera => {
                    let at = if tau > 0.0 { mount_c } else { ambient_c };
                    fixture_drift_um(k, self.params.reference_c, at)
                }
                ChipShift::Sensor(c, tau, um) if c == camera => {
                    sensor_drift_um(um, tau, t_since_start_s)
                }
                _ => continue,
            };
            d[0] += add[0];
            d[1] += add[1];
        }
        d
    }
}

/// `fixture_drift`: the apparent spot shift (u, v) in µm on a chip whose mount moves with the
/// ambient temperature, `um_per_k` per kelvin above `reference_c`.
pub fn fixture_drift_um(um_per_k: [f64; 2], reference_c: f64, ambient_c: f64) -> [f64; 2] {
    let d = ambient_c - reference_c;
    [um_per_k[0] * d, um_per_k[1] * d]
}

/// `sensor_drift`: the apparent spot shift (u, v) in µm of a chip drifting on its own, first
/// order with time since the run began: `um`·(1 − e^(−t/τ)).
pub fn sensor_drift_um(um: [f64; 2], tau_min: f64, t_since_start_s: f64) -> [f64; 2] {
    let f = if tau_min > 0.0 {
        -(-t_since_start_s.max(0.0) / (tau_min * 60.0)).exp_m1()
    } else {
        1.0
    };
    [um[0] * f, um[1] * f]
}

#[cfg(test)]
mod tests;
