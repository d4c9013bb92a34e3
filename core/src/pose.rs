//! Pose conventions of `docs/geometry.md`: translation of the body origin in the camera
//! frame C, and attitude (pitch, yaw, roll) in degrees relative to C.

use nalgebra::{Matrix3, Vector3};

/// Degrees per radian.
pub const DEG: f32 = 180.0 / core::f32::consts::PI;
/// Radians per degree.
pub const RAD: f32 = core::f32::consts::PI / 180.0;

/// A pose estimate.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Pose {
    /// Body origin in C, m (+X right in the image).
    pub tx_m: f32,
    /// Body origin in C, m (+Y down in the image).
    pub ty_m: f32,
    /// Depth of the body origin, m.
    pub tz_m: f32,
    /// Nose elevation above the C X-Z plane, deg, in [-90, 90].
    pub pitch_deg: f32,
    /// Nose azimuth from +Z towards +X, deg, in (-180, 180].
    pub yaw_deg: f32,
}

/// Unit nose direction in C for a pitch and yaw in degrees:
/// `(cos p sin y, -sin p, cos p cos y)`.
pub fn nose_direction(pitch_deg: f32, yaw_deg: f32) -> Vector3<f32> {
    let (sp, cp) = libm::sincosf(pitch_deg / DEG);
    let (sy, cy) = libm::sincosf(yaw_deg / DEG);
    Vector3::new(cp * sy, -sp, cp * cy)
}

/// Pitch and yaw in degrees of a nose direction in C (need not be unit length).
pub fn attitude_of(nose: &Vector3<f32>) -> (f32, f32) {
    let horizontal = libm::sqrtf(nose.x * nose.x + nose.z * nose.z);
    let pitch = libm::atan2f(-nose.y, horizontal) * DEG;
    let yaw = if horizontal > 0.0 {
        wrap_deg(libm::atan2f(nose.x, nose.z) * DEG)
    } else {
        0.0
    };
    (pitch, yaw)
}

/// The rotation from body frame B to C: `P * Rz(yaw) * Ry(pitch) * Rx(roll)`.
pub fn rotation_body_to_camera(pitch_deg: f32, yaw_deg: f32, roll_deg: f32) -> Matrix3<f32> {
    let (sp, cp) = libm::sincosf(pitch_deg / DEG);
    let (sy, cy) = libm::sincosf(yaw_deg / DEG);
    let (sr, cr) = libm::sincosf(roll_deg / DEG);
    let p = Matrix3::new(0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0);
    let rz = Matrix3::new(cy, -sy, 0.0, sy, cy, 0.0, 0.0, 0.0, 1.0);
    let ry = Matrix3::new(cp, 0.0, sp, 0.0, 1.0, 0.0, -sp, 0.0, cp);
    let rx = Matrix3::new(1.0, 0.0, 0.0, 0.0, cr, -sr, 0.0, sr, cr);
    p * rz * ry * rx
}

/// An angle in degrees wrapped to (-180, 180].
pub fn wrap_deg(a: f32) -> f32 {
    if !a.is_finite() {
        return a;
    }
    let mut w = a % 360.0;
    if w <= -180.0 {
        w += 360.0;
    } else if w > 180.0 {
        w -= 360.0;
    }
    w
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Camera;

    /// The test vector of `docs/geometry.md` ("Test vectors"), its digits copied as printed there.
    #[test]
    #[allow(clippy::excessive_precision)]
    fn spec_test_vector() {
        let r = rotation_body_to_camera(30.0, -60.0, 20.0);
        let expected = [
            [-0.750000, 0.321747, -0.577909],
            [-0.500000, 0.296198, 0.813798],
            [0.433013, 0.899303, -0.061275],
        ];
        for (i, row) in expected.iter().enumerate() {
            for (j, e) in row.iter().enumerate() {
                assert!((r[(i, j)] - e).abs() < 2e-6, "R[{i}][{j}] = {}", r[(i, j)]);
            }
        }
        let n = nose_direction(30.0, -60.0);
        assert!((n - Vector3::new(-0.75, -0.5, 0.433013)).norm() < 2e-6);
        assert!((r.column(0) - n).norm() < 2e-6, "nose is R's first column");

        let cam = Camera {
            fx: 100000.0,
            fy: 100000.0,
            cx: 1023.5,
            cy: 1023.5,
        };
        let t = Vector3::new(3.0, -2.0, 1500.0);
        let cases = [
            (Vector3::new(0.689, 0.0, 0.0), (1189.017, 867.231)),
            (Vector3::new(-0.689, 0.0, 0.0), (1257.997, 913.111)),
            (Vector3::zeros(), (1223.500, 890.167)),
            (Vector3::new(-0.689, 0.0, 0.100), (1254.144, 918.537)),
        ];
        for (b, (u, v)) in cases {
            let px = cam.project(&(t + r * b));
            assert!(
                (px.x - u).abs() < 2e-3 && (px.y - v).abs() < 2e-3,
                "{b:?} -> {px:?}"
            );
        }
        let (p, y) = attitude_of(&n);
        assert!((p - 30.0).abs() < 1e-4 && (y + 60.0).abs() < 1e-4);
    }

    #[test]
    fn wraps_into_half_open_range() {
        assert_eq!(wrap_deg(180.0), 180.0);
        assert_eq!(wrap_deg(-180.0), 180.0);
        assert_eq!(wrap_deg(190.0), -170.0);
        assert_eq!(wrap_deg(-540.0), 180.0);
        assert_eq!(wrap_deg(45.0), 45.0);
    }
}
