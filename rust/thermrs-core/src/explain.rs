//! A rig checked and explained pose by pose (`thermrs rig`, SPEC §7).

use std::collections::BTreeMap;

use serde::Serialize;

use crate::error::{Error, LaserMiss, Result};
use crate::model::{pose_joints_rad, ForwardModel};
use crate::rig::Rig;

/// Where the laser meets one camera's chip at one pose.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ChipView {
    /// Pixel position, `None` where the ray misses the chip (off the chip, parallel, or behind).
    pub spot_px: Option<[f64; 2]>,
    /// Angle between the ray and the chip normal (degrees), `None` where the ray never meets
    /// the chip plane in front of the laser.
    pub incidence_deg: Option<f64>,
    /// Distance from the laser origin to the chip plane along the ray (mm).
    pub distance_mm: Option<f64>,
}

/// One pose explained: flange position and what every camera sees.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PoseView {
    pub flange_mm: [f64; 3],
    /// Elevation and azimuth of the flange position (degrees), the paper's φ and θ.
    pub elevation_deg: f64,
    pub azimuth_deg: f64,
    pub cameras: BTreeMap<String, ChipView>,
}

/// The whole rig explained at the reference temperature (nominal lengths).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RigView {
    pub poses: BTreeMap<String, PoseView>,
    /// One line per problem: a pose whose own camera the laser misses.
    pub problems: Vec<LaserMiss>,
}

impl RigView {
    /// The SPEC §7 JSON shape (`poses` → `flange_mm`, `spot_px`, `incidence_deg`), extended with
    /// `distance_mm`, `elevation_deg` and `azimuth_deg`.
    pub fn to_spec_json(&self) -> serde_json::Value {
        let poses: serde_json::Map<String, serde_json::Value> = self
            .poses
            .iter()
            .map(|(name, p)| {
                let per = |f: &dyn Fn(&ChipView) -> serde_json::Value| -> serde_json::Value {
                    p.cameras.iter().map(|(c, v)| (c.clone(), f(v))).collect()
                };
                let v = serde_json::json!({
                    "flange_mm": p.flange_mm,
                    "spot_px": per(&|v| serde_json::json!(v.spot_px)),
                    "incidence_deg": per(&|v| serde_json::json!(v.incidence_deg)),
                    "distance_mm": per(&|v| serde_json::json!(v.distance_mm)),
                    "elevation_deg": p.elevation_deg,
                    "azimuth_deg": p.azimuth_deg,
                });
                (name.clone(), v)
            })
            .collect();
        serde_json::json!({ "poses": poses })
    }
}

/// Explain every pose of a rig with its nominal lengths.
pub fn explain(rig: &Rig) -> Result<RigView> {
    let model = ForwardModel::nominal(rig)?;
    let mut poses = BTreeMap::new();
    let mut problems = Vec::new();
    for pose in &rig.pose {
        let q = pose_joints_rad(&pose.joints_deg);
        let flange = model.flange(&q, None);
        let ray = model.laser_ray(&flange);
        let t = flange.translation;
        let mut cameras = BTreeMap::new();
        for (cam, chip) in rig.camera.iter().zip(model.chips()) {
            let hit = chip.intersect(&ray);
            let view = ChipView {
                spot_px: hit
                    .filter(|h| chip.contains(h.x_px, h.y_px))
                    .map(|h| [h.x_px, h.y_px]),
                incidence_deg: hit.map(|h| h.incidence_deg),
                distance_mm: hit.map(|h| h.distance_mm),
            };
            if cam.pose == pose.name && view.spot_px.is_none() {
                problems.push(LaserMiss {
                    pose: pose.name.clone(),
                    camera: cam.name.clone(),
                    hit_px: hit.map(|h| [h.x_px, h.y_px]),
                    chip_px: chip.size_px,
                });
            }
            cameras.insert(cam.name.clone(), view);
        }
        poses.insert(
            pose.name.clone(),
            PoseView {
                flange_mm: [t.x, t.y, t.z],
                elevation_deg: t.z.atan2(t.x.hypot(t.y)).to_degrees(),
                azimuth_deg: t.y.atan2(t.x).to_degrees(),
                cameras,
            },
        );
    }
    Ok(RigView { poses, problems })
}

/// Explain, and fail with the first problem (a pose whose camera the laser misses).
pub fn check(rig: &Rig) -> Result<RigView> {
    let view = explain(rig)?;
    match view.problems.first() {
        Some(p) => Err(Error::LaserMisses(p.clone())),
        None => Ok(view),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const PAPER: &str = include_str!("../../../python/thermrs/data/kr15-paper.toml");

    #[test]
    fn paper_rig_is_explained() {
        let rig = Rig::from_toml(PAPER, "paper").unwrap();
        let v = check(&rig).unwrap();
        let a = &v.poses["A"];
        let near =
            |got: [f64; 3], want: [f64; 3]| got.iter().zip(want).all(|(g, w)| (g - w).abs() < 0.1);
        assert!(
            near(a.flange_mm, [1087.78, -48.62, 217.75]),
            "{:?}",
            a.flange_mm
        );
        let b = &v.poses["B"];
        assert!(
            near(b.flange_mm, [1087.33, -38.29, 198.07]),
            "{:?}",
            b.flange_mm
        );
        // The paper's φ, θ (Table 2 geometry): A 11.31°, 2.56°; B 10.32°, 2.02°.
        assert!(
            (a.elevation_deg - 11.31).abs() < 0.005 && (a.azimuth_deg.abs() - 2.56).abs() < 0.005
        );
        assert!(
            (b.elevation_deg - 10.32).abs() < 0.005 && (b.azimuth_deg.abs() - 2.02).abs() < 0.005
        );
        let spot = a.cameras["A"].spot_px.unwrap();
        assert!((spot[0] - 375.5).abs() < 1e-6 && (spot[1] - 290.5).abs() < 1e-6);
        assert!(a.cameras["A"].incidence_deg.unwrap() < 1e-4);
        assert!((a.cameras["A"].distance_mm.unwrap() - 106.0).abs() < 1e-6);
        // Camera B: within 0.4 mm of its centre along each chip axis, orthogonal (SPEC §4;
        // u = 0.069 mm, v = -0.397 mm, so 0.403 mm in the plane).
        let sb = b.cameras["B"].spot_px.unwrap();
        let du = (sb[0] - 375.5) * 8.6e-3;
        let dv = (sb[1] - 290.5) * 8.3e-3;
        assert!(du.abs() < 0.4 && dv.abs() < 0.4, "{sb:?}");
        assert!(b.cameras["B"].incidence_deg.unwrap() < 0.1);
        // At pose A the laser does not land on camera B's chip.
        assert!(a.cameras["B"].spot_px.is_none());
    }

    #[test]
    fn a_laser_that_misses_is_a_problem() {
        let text = PAPER.replace("    0.39251211004513664,", "    0.49251211004513664,");
        // Keep it a unit vector: renormalise by rewriting the whole direction.
        let rig0 = Rig::from_toml(PAPER, "paper").unwrap();
        let mut d = rig0.laser.direction;
        d[0] += 0.1;
        let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let mut rig = rig0.clone();
        rig.laser.direction = [d[0] / n, d[1] / n, d[2] / n];
        let e = check(&rig).unwrap_err().to_string();
        assert!(e.contains("misses camera \"A\""), "{e}");
        assert!(
            Rig::from_toml(&text, "t").is_err(),
            "non-unit direction must fail"
        );
    }
}
