//! The simulated camera: pinhole intrinsics and an azimuth-elevation tracking mount.
//!
//! World frame W: east, north, up (x, y, z), metres, the axes of the world frame E of
//! `docs/geometry.md`. Camera frame C (`docs/geometry.md`): +X right in the image, +Y down, +Z
//! along the optical axis. The mount keeps the image's X axis level (no roll).

use super::math::{Mat3, Vec3};

/// Pinhole intrinsics and the full-frame size (no distortion).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Intrinsics {
    /// Focal length along x, px.
    pub fx: f64,
    /// Focal length along y, px.
    pub fy: f64,
    /// Principal point x, full-frame px (pixel centres at integers).
    pub cx: f64,
    /// Principal point y, full-frame px.
    pub cy: f64,
    /// Full-frame width, px.
    pub width: u32,
    /// Full-frame height, px.
    pub height: u32,
}

impl Intrinsics {
    /// Projects a camera-frame point (m) to full-frame pixel coordinates (u, v); `None` for a
    /// point on or behind the image plane's z = 0.
    pub fn project(&self, p: Vec3) -> Option<(f64, f64)> {
        (p.z > 0.0).then(|| (self.fx * p.x / p.z + self.cx, self.fy * p.y / p.z + self.cy))
    }

    /// The camera-frame ray (not normalized, z = 1) through full-frame pixel coordinates (u, v).
    pub fn ray(&self, u: f64, v: f64) -> Vec3 {
        Vec3::new((u - self.cx) / self.fx, (v - self.cy) / self.fy, 1.0)
    }
}

/// Azimuth (radians clockwise from north) and elevation (radians above the horizon) of a world
/// direction.
pub fn azimuth_elevation(d: Vec3) -> (f64, f64) {
    let horizontal = libm::sqrt(d.x * d.x + d.y * d.y);
    (libm::atan2(d.x, d.y), libm::atan2(d.z, horizontal))
}

/// The camera's placement for one frame: where it is and where it points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraPose {
    /// Optical centre in W, m.
    pub position: Vec3,
    /// Rotation from W to C.
    pub r_cw: Mat3,
}

impl CameraPose {
    /// A level camera at `position` whose optical axis has azimuth `az` and elevation `el`
    /// (radians, as [`azimuth_elevation`]).
    pub fn on_mount(position: Vec3, az: f64, el: f64) -> CameraPose {
        let (sa, ca) = (libm::sin(az), libm::cos(az));
        let (se, ce) = (libm::sin(el), libm::cos(el));
        let z = Vec3::new(sa * ce, ca * ce, se);
        let x = Vec3::new(ca, -sa, 0.0);
        let y = z.cross(x);
        CameraPose {
            position,
            // Rows are the camera axes expressed in W.
            r_cw: Mat3::from_cols(x, y, z).transpose(),
        }
    }

    /// Where the optical axis points: azimuth and elevation, radians (as [`azimuth_elevation`]).
    pub fn pointing(&self) -> (f64, f64) {
        azimuth_elevation(self.r_cw.row(2))
    }

    /// Maps a world point (m) to the camera frame (m).
    pub fn to_camera(&self, p: Vec3) -> Vec3 {
        self.r_cw * (p - self.position)
    }

    /// Maps a camera-frame direction to the world frame.
    pub fn direction_to_world(&self, d: Vec3) -> Vec3 {
        self.r_cw.transpose() * d
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::math::rad;
    use crate::sim::pose::{Attitude, BodyPose};

    #[test]
    fn spec_test_vector_projection() {
        let k = Intrinsics {
            fx: 100000.0,
            fy: 100000.0,
            cx: 1023.5,
            cy: 1023.5,
            width: 2048,
            height: 2048,
        };
        let pose = BodyPose {
            translation: Vec3::new(3.0, -2.0, 1500.0),
            rotation: Attitude {
                pitch_deg: 30.0,
                yaw_deg: -60.0,
                roll_deg: 20.0,
            }
            .rotation_cb(),
        };
        let cases = [
            (Vec3::new(0.689, 0.0, 0.0), (1189.017, 867.231)),
            (Vec3::new(-0.689, 0.0, 0.0), (1257.997, 913.111)),
            (Vec3::new(0.0, 0.0, 0.0), (1223.500, 890.167)),
            (Vec3::new(-0.689, 0.0, 0.100), (1254.144, 918.537)),
        ];
        for (b, (u, v)) in cases {
            let (pu, pv) = k
                .project(pose.to_camera(b))
                .expect("in front of the camera");
            assert!(
                (pu - u).abs() < 1e-3 && (pv - v).abs() < 1e-3,
                "{b:?}: ({pu}, {pv})"
            );
        }
    }

    #[test]
    fn mount_axes_are_right_down_forward() {
        // Looking north and level: right is east, down is -up.
        let cam = CameraPose::on_mount(Vec3::default(), 0.0, 0.0);
        let east = cam.to_camera(Vec3::new(1.0, 0.0, 0.0));
        let up = cam.to_camera(Vec3::new(0.0, 0.0, 1.0));
        let north = cam.to_camera(Vec3::new(0.0, 1.0, 0.0));
        assert!((east - Vec3::new(1.0, 0.0, 0.0)).norm() < 1e-15);
        assert!((up - Vec3::new(0.0, -1.0, 0.0)).norm() < 1e-15);
        assert!((north - Vec3::new(0.0, 0.0, 1.0)).norm() < 1e-15);
        // The mount's optical axis has the azimuth and elevation it was given.
        let cam = CameraPose::on_mount(Vec3::default(), rad(250.0 - 360.0), rad(17.0));
        let (az, el) = azimuth_elevation(cam.direction_to_world(Vec3::new(0.0, 0.0, 1.0)));
        assert!((az - rad(-110.0)).abs() < 1e-12 && (el - rad(17.0)).abs() < 1e-12);
    }
}
