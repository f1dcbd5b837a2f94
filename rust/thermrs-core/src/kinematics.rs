//! Standard (distal) Denavit–Hartenberg forward kinematics.
//!
//! Row i maps frame i−1 to frame i: `T_i = Rz(θᵢ)·Tz(dᵢ)·Tx(aᵢ)·Rx(αᵢ)`, with the joint angle
//! θᵢ = signᵢ·qᵢ + offsetᵢ (SPEC §3). The flange frame is the product of all six rows. Lengths
//! are passed per call so that the thermal model ([`crate::model`]) can expand them sample by
//! sample; this module knows nothing of temperature.

use nalgebra::{Matrix3, Matrix4, Vector3};

use crate::rig::DhRow;

/// A rigid transform as rotation + translation (cheaper to compose than a 4×4).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    pub rotation: Matrix3<f64>,
    pub translation: Vector3<f64>,
}

impl Frame {
    pub fn identity() -> Frame {
        Frame {
            rotation: Matrix3::identity(),
            translation: Vector3::zeros(),
        }
    }

    /// `self ∘ other`: apply `other`, then `self`.
    #[inline]
    pub fn compose(&self, other: &Frame) -> Frame {
        Frame {
            rotation: self.rotation * other.rotation,
            translation: self.rotation * other.translation + self.translation,
        }
    }

    /// Map a point of this frame into the parent frame.
    #[inline]
    pub fn point(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.rotation * p + self.translation
    }

    /// Map a direction of this frame into the parent frame.
    #[inline]
    pub fn vector(&self, v: &Vector3<f64>) -> Vector3<f64> {
        self.rotation * v
    }

    /// The homogeneous 4×4 matrix.
    pub fn to_matrix(&self) -> Matrix4<f64> {
        let mut m = Matrix4::identity();
        m.fixed_view_mut::<3, 3>(0, 0).copy_from(&self.rotation);
        m.fixed_view_mut::<3, 1>(0, 3).copy_from(&self.translation);
        m
    }
}

/// The six DH rows in the form the hot loop wants: angles in radians, cos/sin of α precomputed.
#[derive(Debug, Clone, PartialEq)]
pub struct Chain {
    /// Nominal `a` lengths (mm).
    pub a_mm: [f64; 6],
    /// Nominal `d` lengths (mm).
    pub d_mm: [f64; 6],
    cos_alpha: [f64; 6],
    sin_alpha: [f64; 6],
    theta_offset_rad: [f64; 6],
    sign: [f64; 6],
}

impl Chain {
    /// Build from six validated rig rows.
    pub fn new(rows: &[DhRow]) -> Chain {
        assert_eq!(rows.len(), 6, "a chain has six DH rows");
        let mut c = Chain {
            a_mm: [0.0; 6],
            d_mm: [0.0; 6],
            cos_alpha: [0.0; 6],
            sin_alpha: [0.0; 6],
            theta_offset_rad: [0.0; 6],
            sign: [0.0; 6],
        };
        for (i, r) in rows.iter().enumerate() {
            c.a_mm[i] = r.a_mm;
            c.d_mm[i] = r.d_mm;
            let al = r.alpha_deg.to_radians();
            // Exact zeros for the common right angles keep rotations exactly orthogonal.
            c.cos_alpha[i] = snap(al.cos());
            c.sin_alpha[i] = snap(al.sin());
            c.theta_offset_rad[i] = r.theta_offset_deg.to_radians();
            c.sign[i] = r.sign as f64;
        }
        c
    }

    /// The DH angle θᵢ of row i for joint value qᵢ (radians).
    #[inline]
    pub fn theta(&self, i: usize, q: f64) -> f64 {
        self.sign[i] * q + self.theta_offset_rad[i]
    }

    /// One DH row as a frame, with the given lengths.
    #[inline]
    pub fn row_frame(&self, i: usize, q: f64, a: f64, d: f64) -> Frame {
        let (st, ct) = self.theta(i, q).sin_cos();
        let (ca, sa) = (self.cos_alpha[i], self.sin_alpha[i]);
        Frame {
            rotation: Matrix3::new(ct, -st * ca, st * sa, st, ct * ca, -ct * sa, 0.0, sa, ca),
            translation: Vector3::new(a * ct, a * st, d),
        }
    }

    /// Flange frame in the base frame for joints `q` (radians) and lengths `a`, `d` (mm).
    #[inline]
    pub fn flange_with(&self, q: &[f64], a: &[f64; 6], d: &[f64; 6]) -> Frame {
        let mut t = self.row_frame(0, q[0], a[0], d[0]);
        for i in 1..6 {
            t = t.compose(&self.row_frame(i, q[i], a[i], d[i]));
        }
        t
    }

    /// Flange frame with the nominal lengths.
    pub fn flange(&self, q: &[f64]) -> Frame {
        self.flange_with(q, &self.a_mm, &self.d_mm)
    }

    /// Frames 1..=6 (each joint frame in the base frame), nominal lengths.
    pub fn frames(&self, q: &[f64]) -> [Frame; 6] {
        let mut out = [Frame::identity(); 6];
        let mut t = Frame::identity();
        for (i, slot) in out.iter_mut().enumerate() {
            t = t.compose(&self.row_frame(i, q[i], self.a_mm[i], self.d_mm[i]));
            *slot = t;
        }
        out
    }
}

fn snap(x: f64) -> f64 {
    if x.abs() < 1e-15 {
        0.0
    } else if (x.abs() - 1.0).abs() < 1e-15 {
        x.signum()
    } else {
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dh(a: f64, alpha: f64, d: f64, off: f64, sign: i64) -> DhRow {
        DhRow {
            a_mm: a,
            alpha_deg: alpha,
            d_mm: d,
            theta_offset_deg: off,
            sign,
        }
    }

    fn kr15() -> Chain {
        Chain::new(&[
            dh(300.0, 90.0, 675.0, 0.0, 1),
            dh(650.0, 0.0, 0.0, 0.0, 1),
            dh(152.91, -90.0, 0.0, 0.0, 1),
            dh(0.0, 90.0, -600.0, 0.0, 1),
            dh(0.0, 90.0, 0.0, 180.0, -1),
            dh(0.0, 0.0, -140.0, 0.0, 1),
        ])
    }

    #[test]
    fn zero_pose_is_the_sum_of_lengths() {
        // Planar arm along x: a1 + a2 + a3 at θ = 0, z = d1.
        let c = Chain::new(&[
            dh(1.0, 0.0, 5.0, 0.0, 1),
            dh(2.0, 0.0, 0.0, 0.0, 1),
            dh(3.0, 0.0, 0.0, 0.0, 1),
            dh(0.0, 0.0, 0.0, 0.0, 1),
            dh(0.0, 0.0, 0.0, 0.0, 1),
            dh(0.0, 0.0, 0.0, 0.0, 1),
        ]);
        let f = c.flange(&[0.0; 6]);
        assert!((f.translation - Vector3::new(6.0, 0.0, 5.0)).norm() < 1e-12);
        // Rotating joint 1 by 90° swings it onto y.
        let f = c.flange(&[std::f64::consts::FRAC_PI_2, 0.0, 0.0, 0.0, 0.0, 0.0]);
        assert!((f.translation - Vector3::new(0.0, 6.0, 5.0)).norm() < 1e-12);
    }

    #[test]
    fn paper_pose_a_matches_table_2() {
        let q: Vec<f64> = [4.23, 17.5462, -16.884, -89.516, -66.8551, 180.0]
            .iter()
            .map(|d: &f64| d.to_radians())
            .collect();
        let f = kr15().flange(&q);
        let want = Vector3::new(1087.78, -48.62, 217.75);
        assert!((f.translation - want).norm() < 0.1, "{}", f.translation);
        // A rotation stays a rotation.
        let r = f.rotation;
        assert!((r.transpose() * r - Matrix3::identity()).norm() < 1e-12);
        assert!((r.determinant() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn frames_end_at_the_flange() {
        let q = [0.1, -0.4, 0.7, 1.1, -0.3, 2.0];
        let c = kr15();
        let frames = c.frames(&q);
        assert_eq!(frames[5], c.flange(&q));
        // The wrist centre (frame 4 origin) does not depend on joints 4..6.
        let mut q2 = q;
        q2[3] += 0.5;
        q2[4] -= 0.2;
        q2[5] += 1.0;
        let w1 = frames[3].translation;
        let w2 = c.frames(&q2)[3].translation;
        assert!((w1 - w2).norm() < 1e-12);
    }

    #[test]
    fn frame_matrix_roundtrip() {
        let c = kr15();
        let f = c.flange(&[0.3, 0.2, -0.1, 0.5, 0.4, -0.6]);
        let m = f.to_matrix();
        let p = Vector3::new(1.0, 2.0, 3.0);
        let hp = m * nalgebra::Vector4::new(p.x, p.y, p.z, 1.0);
        assert!((hp.xyz() - f.point(&p)).norm() < 1e-12);
    }
}
