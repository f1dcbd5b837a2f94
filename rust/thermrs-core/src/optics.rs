//! The laser ray and the lensless CCD chip (SPEC §4).
//!
//! Pixel convention: the centre of the first pixel is (0, 0); x grows along columns (the chip's
//! `x_axis`), y along rows (`y_axis`). The chip centre is ((w−1)/2, (h−1)/2). The chip covers
//! x ∈ [−0.5, w−0.5], y ∈ [−0.5, h−0.5]. Chip micrometres: u = (x − (w−1)/2)·pitch_x,
//! v = (y − (h−1)/2)·pitch_y.

use nalgebra::Vector3;

use crate::kinematics::Frame;
use crate::rig::Camera;

/// A ray: origin and unit direction (base frame, mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    pub origin: Vector3<f64>,
    pub direction: Vector3<f64>,
}

impl Ray {
    /// The ray given in the flange frame, mapped through the flange pose to the base frame.
    #[inline]
    pub fn through(frame: &Frame, origin: &Vector3<f64>, direction: &Vector3<f64>) -> Ray {
        Ray {
            origin: frame.point(origin),
            direction: frame.vector(direction),
        }
    }
}

/// A chip plane with its pixel grid.
#[derive(Debug, Clone, PartialEq)]
pub struct Chip {
    pub centre_mm: Vector3<f64>,
    pub x_axis: Vector3<f64>,
    pub y_axis: Vector3<f64>,
    /// x_axis × y_axis.
    pub normal: Vector3<f64>,
    pub pitch_um: [f64; 2],
    pub size_px: [usize; 2],
}

/// Where a ray meets a chip plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Column coordinate (px, SPEC §4).
    pub x_px: f64,
    /// Row coordinate (px).
    pub y_px: f64,
    /// Distance along the ray from its origin to the plane (mm).
    pub distance_mm: f64,
    /// Angle between the ray and the chip normal (degrees, 0 = orthogonal).
    pub incidence_deg: f64,
}

impl Chip {
    pub fn from_camera(c: &Camera) -> Chip {
        let v = |a: [f64; 3]| Vector3::new(a[0], a[1], a[2]);
        let x = v(c.x_axis);
        let y = v(c.y_axis);
        Chip {
            centre_mm: v(c.centre_mm),
            x_axis: x,
            y_axis: y,
            normal: x.cross(&y),
            pitch_um: c.pixel_pitch_um,
            size_px: [c.size_px[0] as usize, c.size_px[1] as usize],
        }
    }

    /// The chip-centre pixel ((w−1)/2, (h−1)/2).
    pub fn centre_px(&self) -> [f64; 2] {
        [
            (self.size_px[0] as f64 - 1.0) / 2.0,
            (self.size_px[1] as f64 - 1.0) / 2.0,
        ]
    }

    /// Intersect a ray with the chip plane. `None` when the ray is parallel to the plane or
    /// the plane lies behind the ray's origin. The hit may lie off the chip: see [`Chip::contains`].
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let denom = ray.direction.dot(&self.normal);
        if denom.abs() < 1e-12 {
            return None;
        }
        let s = (self.centre_mm - ray.origin).dot(&self.normal) / denom;
        if s <= 0.0 {
            return None;
        }
        let p = ray.origin + ray.direction * s - self.centre_mm;
        let [cx, cy] = self.centre_px();
        let cos_inc = (denom / ray.direction.norm()).abs().min(1.0);
        Some(Hit {
            x_px: p.dot(&self.x_axis) * 1000.0 / self.pitch_um[0] + cx,
            y_px: p.dot(&self.y_axis) * 1000.0 / self.pitch_um[1] + cy,
            distance_mm: s * ray.direction.norm(),
            incidence_deg: cos_inc.acos().to_degrees(),
        })
    }

    /// Whether a pixel position lies on the chip's light-sensitive area.
    pub fn contains(&self, x_px: f64, y_px: f64) -> bool {
        let (w, h) = (self.size_px[0] as f64, self.size_px[1] as f64);
        (-0.5..=w - 0.5).contains(&x_px) && (-0.5..=h - 0.5).contains(&y_px)
    }

    /// Pixels to chip micrometres (u, v) about the chip centre.
    pub fn px_to_um(&self, x_px: f64, y_px: f64) -> [f64; 2] {
        let [cx, cy] = self.centre_px();
        [
            (x_px - cx) * self.pitch_um[0],
            (y_px - cy) * self.pitch_um[1],
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chip() -> Chip {
        let x = Vector3::new(0.0, 0.0, 1.0);
        let y = Vector3::new(1.0, 0.0, 0.0);
        Chip {
            centre_mm: Vector3::new(1000.0, -200.0, 150.0),
            x_axis: x,
            y_axis: y,
            normal: x.cross(&y),
            pitch_um: [8.6, 8.3],
            size_px: [752, 582],
        }
    }

    #[test]
    fn orthogonal_ray_at_centre_hits_centre_pixel() {
        let c = chip();
        // normal = z × x = +y; a ray travelling −y from y = −94 meets the plane at 106 mm.
        let ray = Ray {
            origin: Vector3::new(1000.0, -94.0, 150.0),
            direction: Vector3::new(0.0, -1.0, 0.0),
        };
        let h = c.intersect(&ray).unwrap();
        assert!((h.x_px - 375.5).abs() < 1e-12 && (h.y_px - 290.5).abs() < 1e-12);
        assert!((h.distance_mm - 106.0).abs() < 1e-12);
        assert!(h.incidence_deg.abs() < 1e-9);
        assert!(c.contains(h.x_px, h.y_px));
    }

    #[test]
    fn offsets_map_through_pitch() {
        let c = chip();
        // 86 µm along the chip x axis (base z) is 10 px; 83 µm along y (base x) is 10 px.
        let ray = Ray {
            origin: Vector3::new(1000.083, -94.0, 150.086),
            direction: Vector3::new(0.0, -1.0, 0.0),
        };
        let h = c.intersect(&ray).unwrap();
        assert!((h.x_px - 385.5).abs() < 1e-9, "{}", h.x_px);
        assert!((h.y_px - 300.5).abs() < 1e-9, "{}", h.y_px);
        assert_eq!(
            c.px_to_um(385.5, 300.5).map(|v| (v * 1e6).round() / 1e6),
            [86.0, 83.0]
        );
    }

    #[test]
    fn tilted_and_missing_rays() {
        let c = chip();
        let t = 10f64.to_radians();
        let ray = Ray {
            origin: Vector3::new(1000.0, -94.0, 150.0),
            direction: Vector3::new(0.0, -t.cos(), t.sin()),
        };
        let h = c.intersect(&ray).unwrap();
        assert!((h.incidence_deg - 10.0).abs() < 1e-9);
        assert!((h.distance_mm - 106.0 / t.cos()).abs() < 1e-9);
        // Pointing away from the plane, or along it: no hit.
        let away = Ray {
            direction: -ray.direction,
            ..ray
        };
        assert!(c.intersect(&away).is_none());
        let along = Ray {
            direction: Vector3::new(1.0, 0.0, 0.0),
            ..ray
        };
        assert!(c.intersect(&along).is_none());
        assert!(!c.contains(-0.6, 10.0) && !c.contains(10.0, 581.6));
        assert!(c.contains(-0.5, 581.5));
    }
}
