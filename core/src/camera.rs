//! Pinhole camera intrinsics (`docs/geometry.md`): `u = fx X/Z + cx`, `v = fy Y/Z + cy`,
//! pixel centres at integers, no distortion.

use nalgebra::{Matrix3, Vector2, Vector3};

/// Camera intrinsics, px.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Camera {
    /// Focal length along x, px.
    pub fx: f32,
    /// Focal length along y, px.
    pub fy: f32,
    /// Principal point x, full-frame px.
    pub cx: f32,
    /// Principal point y, full-frame px.
    pub cy: f32,
}

impl Camera {
    /// True when the focal lengths are finite and positive and the principal point finite.
    pub fn is_valid(&self) -> bool {
        self.fx.is_finite()
            && self.fy.is_finite()
            && self.fx > 0.0
            && self.fy > 0.0
            && self.cx.is_finite()
            && self.cy.is_finite()
    }

    /// Normalized image coordinates (X/Z, Y/Z) of full-frame pixel (u, v).
    pub fn normalize(&self, u: f32, v: f32) -> Vector2<f32> {
        Vector2::new((u - self.cx) / self.fx, (v - self.cy) / self.fy)
    }

    /// Full-frame pixel (u, v) of a point in the camera frame C (Z > 0).
    pub fn project(&self, p: &Vector3<f32>) -> Vector2<f32> {
        Vector2::new(self.fx * p.x / p.z + self.cx, self.fy * p.y / p.z + self.cy)
    }

    /// Length of an image displacement of `len_px` pixels along unit pixel direction `dir`, in
    /// normalized image units (radians for small angles).
    pub fn normalized_length(&self, len_px: f32, dir: Vector2<f32>) -> f32 {
        let dx = len_px * dir.x / self.fx;
        let dy = len_px * dir.y / self.fy;
        libm::sqrtf(dx * dx + dy * dy)
    }
}

/// The line-of-sight frame of a ray: rows are unit vectors (e1, e2, m) of C, where m is the ray
/// direction and e1, e2 are close to +X and +Y. Multiplying a C vector by it gives LOS coordinates.
pub fn line_of_sight_frame(normalized: Vector2<f32>) -> Matrix3<f32> {
    let m = Vector3::new(normalized.x, normalized.y, 1.0).normalize();
    let e1 = Vector3::new(m.z, 0.0, -m.x).normalize();
    let e2 = m.cross(&e1);
    Matrix3::from_rows(&[e1.transpose(), e2.transpose(), m.transpose()])
}
