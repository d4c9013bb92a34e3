//! The camera-frame pose of `docs/geometry.md`, implemented independently of the core.
//!
//! `R_CB = P * Rz(yaw) * Ry(pitch) * Rx(roll)`, `P = [[0,1,0],[0,0,1],[1,0,0]]`: the aerospace
//! yaw-pitch-roll sequence in the level frame L = (forward, right, down) = (+Z, +X, +Y) of C.

use super::math::{Mat3, Vec3, deg, rad, wrap_deg};

/// The permutation taking level-frame coordinates (forward, right, down) to camera coordinates.
const P: Mat3 = Mat3 {
    m: [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]],
};

/// Attitude of the body relative to the camera frame C, degrees.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Attitude {
    /// Nose elevation above the camera X-Z plane, deg, in [-90, 90].
    pub pitch_deg: f64,
    /// Nose azimuth in the X-Z plane from +Z towards +X, deg, in (-180, 180].
    pub yaw_deg: f64,
    /// Rotation about +x_B, deg, in (-180, 180].
    pub roll_deg: f64,
}

impl Attitude {
    /// The rotation from body frame B to camera frame C.
    pub fn rotation_cb(&self) -> Mat3 {
        P * Mat3::rot_z(rad(self.yaw_deg))
            * Mat3::rot_y(rad(self.pitch_deg))
            * Mat3::rot_x(rad(self.roll_deg))
    }

    /// The attitude of a rotation from B to C (the inverse of [`Attitude::rotation_cb`] away from
    /// pitch = +-90 deg, where yaw and roll are not separable).
    pub fn from_rotation_cb(r_cb: &Mat3) -> Attitude {
        // M = P^T R_CB = Rz(yaw) Ry(pitch) Rx(roll), the textbook Z-Y-X sequence.
        let m = P.transpose() * *r_cb;
        let pitch = libm::asin((-m.m[2][0]).clamp(-1.0, 1.0));
        let yaw = libm::atan2(m.m[1][0], m.m[0][0]);
        let roll = libm::atan2(m.m[2][1], m.m[2][2]);
        Attitude {
            pitch_deg: deg(pitch),
            yaw_deg: wrap_deg(deg(yaw)),
            roll_deg: wrap_deg(deg(roll)),
        }
    }

    /// The nose direction in C: (cos(pitch) sin(yaw), -sin(pitch), cos(pitch) cos(yaw)).
    pub fn nose_direction(&self) -> Vec3 {
        let (p, y) = (rad(self.pitch_deg), rad(self.yaw_deg));
        Vec3::new(
            libm::cos(p) * libm::sin(y),
            -libm::sin(p),
            libm::cos(p) * libm::cos(y),
        )
    }
}

/// A body pose in the camera frame: p_C = translation + rotation * b for a body point b.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyPose {
    /// Position of the body origin in C, m.
    pub translation: Vec3,
    /// R_CB.
    pub rotation: Mat3,
}

impl BodyPose {
    /// Maps a body-frame point (m) to the camera frame (m).
    pub fn to_camera(&self, b: Vec3) -> Vec3 {
        self.translation + self.rotation * b
    }

    /// The spec attitude of this pose.
    pub fn attitude(&self) -> Attitude {
        Attitude::from_rotation_cb(&self.rotation)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The attitude of the spec's test vector.
    fn spec_attitude() -> Attitude {
        Attitude {
            pitch_deg: 30.0,
            yaw_deg: -60.0,
            roll_deg: 20.0,
        }
    }

    #[test]
    fn spec_test_vector_rotation() {
        let expected = Mat3 {
            m: [
                [-0.750000, 0.321747, -0.577909],
                [-0.500000, 0.296198, 0.813798],
                [0.433013, 0.899303, -0.061275],
            ],
        };
        let r = spec_attitude().rotation_cb();
        assert!(r.max_abs_diff(&expected) < 1e-6, "{r:?}");
        let n = spec_attitude().nose_direction();
        assert!((n - r.col(0)).norm() < 1e-12);
        assert!((n - Vec3::new(-0.75, -0.5, 0.433013)).norm() < 1e-6);
    }

    #[test]
    fn attitude_round_trips_through_the_rotation() {
        for pitch in [-80.0, -30.0, 0.0, 12.5, 45.0, 89.0] {
            for yaw in [-179.0, -120.0, -90.0, -3.0, 0.0, 60.0, 90.0, 135.0, 180.0] {
                for roll in [-170.0, -45.0, 0.0, 20.0, 90.0, 180.0] {
                    let a = Attitude {
                        pitch_deg: pitch,
                        yaw_deg: yaw,
                        roll_deg: roll,
                    };
                    let back = Attitude::from_rotation_cb(&a.rotation_cb());
                    assert!((back.pitch_deg - pitch).abs() < 1e-9, "{a:?} -> {back:?}");
                    assert!(
                        wrap_deg(back.yaw_deg - yaw).abs() < 1e-9,
                        "{a:?} -> {back:?}"
                    );
                    assert!(
                        wrap_deg(back.roll_deg - roll).abs() < 1e-9,
                        "{a:?} -> {back:?}"
                    );
                    assert!(back.yaw_deg > -180.0 && back.yaw_deg <= 180.0);
                }
            }
        }
    }
}
