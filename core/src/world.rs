//! The world frame: a pose in the camera frame C restated in a station's level East-North-Up
//! frame E (`docs/geometry.md`, "World frame"), from where the tracking mount pointed the camera.
//!
//! The mount points the optical axis +Z_C at azimuth `az` (clockwise from north) and elevation
//! `el` (above the horizontal), with the image's X axis horizontal:
//!
//! ```text
//! Z_C in E = ( sin az cos el,  cos az cos el,  sin el )
//! X_C in E = ( cos az,        -sin az,         0      )
//! Y_C in E = Z_C x X_C          R_EC = [X_C Y_C Z_C]      p_E = station + R_EC p_C
//! ```
//!
//! This stage runs after the pose ([`WorldPose::of`]): the mount's co-processor states each ok
//! frame in E live. The arithmetic is in `f64`: a range frame spans kilometres, and the
//! rounding is IEEE's on every target, so host and firmware agree bit for bit.

use crate::pose::Pose;
use nalgebra::{Matrix3, Vector3};

/// Where the tracking mount pointed the camera's optical axis at a frame's capture time.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Mount {
    /// Azimuth, deg clockwise from north.
    az_deg: f64,
    /// Elevation above the horizontal, deg, in [-90, 90].
    el_deg: f64,
}

/// Why a mount pointing is refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MountError {
    /// The azimuth or the elevation is not a finite number.
    NotFinite,
    /// The elevation is outside [-90, 90] deg.
    ElevationOutOfRange,
}

impl Mount {
    /// The pointing at azimuth `az_deg` (clockwise from north; any finite value, taken modulo
    /// 360) and elevation `el_deg` (in [-90, 90]), both deg.
    pub fn new_checked(az_deg: f64, el_deg: f64) -> Result<Mount, MountError> {
        if !(az_deg.is_finite() && el_deg.is_finite()) {
            return Err(MountError::NotFinite);
        }
        if !(-90.0..=90.0).contains(&el_deg) {
            return Err(MountError::ElevationOutOfRange);
        }
        Ok(Mount { az_deg, el_deg })
    }

    /// Azimuth, deg clockwise from north, as given.
    pub fn az_deg(&self) -> f64 {
        self.az_deg
    }

    /// Elevation above the horizontal, deg.
    pub fn el_deg(&self) -> f64 {
        self.el_deg
    }

    /// The rotation from C to E: its columns are the camera's axes in E.
    pub fn rotation_camera_to_world(&self) -> Matrix3<f64> {
        let (sa, ca) = libm::sincos(self.az_deg.to_radians());
        let (se, ce) = libm::sincos(self.el_deg.to_radians());
        let z = Vector3::new(sa * ce, ca * ce, se);
        let x = Vector3::new(ca, -sa, 0.0);
        let y = z.cross(&x);
        Matrix3::from_columns(&[x, y, z])
    }
}

/// Where the camera stands in the range's East-North-Up frame E, m (the origin where the clip
/// names no station).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Station {
    /// East, north and up of the optical centre, m.
    pub enu_m: [f64; 3],
}

/// A frame's pose in the world frame E.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct WorldPose {
    /// Azimuth of the nose direction, deg clockwise from north, in [0, 360).
    pub nose_az_deg: f64,
    /// Elevation of the nose direction above the horizontal, deg, in [-90, 90].
    pub nose_el_deg: f64,
    /// The body origin in E: east, north, up, m.
    pub origin_enu_m: [f64; 3],
}

impl WorldPose {
    /// `pose` (in C: the chosen yaw candidate's attitude) restated in E, for a camera at
    /// `station` pointed as `mount`.
    pub fn of(pose: &Pose, mount: &Mount, station: &Station) -> WorldPose {
        let r_ec = mount.rotation_camera_to_world();
        // The nose in C (`crate::pose::nose_direction`, in f64).
        let (sp, cp) = libm::sincos(f64::from(pose.pitch_deg).to_radians());
        let (sy, cy) = libm::sincos(f64::from(pose.yaw_deg).to_radians());
        let n = r_ec * Vector3::new(cp * sy, -sp, cp * cy);
        let origin_c = Vector3::new(
            f64::from(pose.tx_m),
            f64::from(pose.ty_m),
            f64::from(pose.tz_m),
        );
        let origin = Vector3::from(station.enu_m) + r_ec * origin_c;
        let horizontal = libm::sqrt(n.x * n.x + n.y * n.y);
        let az = libm::atan2(n.x, n.y).to_degrees();
        WorldPose {
            // atan2 gives (-180, 180]; -0 and rounding up to 360 are folded into [0, 360).
            nose_az_deg: if az < 0.0 { (az + 360.0) % 360.0 } else { az },
            nose_el_deg: libm::atan2(n.z, horizontal).to_degrees(),
            origin_enu_m: [origin.x, origin.y, origin.z],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `docs/geometry.md`'s world test vector: the geometry test vector's pose (T = (3, -2,
    /// 1500) m, pitch 30, yaw -60 deg) from a mount at az 30, el 20 deg, station (100, -200,
    /// 5) m.
    #[test]
    fn the_world_test_vector_holds() {
        let mount = Mount::new_checked(30.0, 20.0).unwrap();
        let r = mount.rotation_camera_to_world();
        let expected = [
            [0.866025, 0.171010, 0.469846],
            [-0.500000, 0.296198, 0.813798],
            [0.000000, -0.939693, 0.342020],
        ];
        for (i, row) in expected.iter().enumerate() {
            for (j, value) in row.iter().enumerate() {
                assert!(
                    (r[(i, j)] - value).abs() < 1e-6,
                    "R_EC[{i}][{j}] = {}",
                    r[(i, j)]
                );
            }
        }
        let pose = Pose {
            tx_m: 3.0,
            ty_m: -2.0,
            tz_m: 1500.0,
            pitch_deg: 30.0,
            yaw_deg: -60.0,
        };
        let station = Station {
            enu_m: [100.0, -200.0, 5.0],
        };
        let world = WorldPose::of(&pose, &mount, &station);
        assert!((world.nose_az_deg - 317.459).abs() < 1e-3, "{world:?}");
        assert!((world.nose_el_deg - 38.166).abs() < 1e-3, "{world:?}");
        for (got, want) in world.origin_enu_m.iter().zip([807.026, 1018.604, 519.910]) {
            assert!((got - want).abs() < 2e-3, "{world:?}");
        }
    }

    /// By hand: a camera looking due east along the horizon sees a nose pointing straight at
    /// it (yaw 180 in C) as pointing west, level; one pointing up in the image (pitch 90) as
    /// pointing up. The body 1000 m in front of the camera lies 1000 m east of it.
    #[test]
    fn a_level_camera_looking_east_by_hand() {
        let mount = Mount::new_checked(90.0, 0.0).unwrap();
        let station = Station {
            enu_m: [10.0, 20.0, 30.0],
        };
        let towards = Pose {
            tx_m: 0.0,
            ty_m: 0.0,
            tz_m: 1000.0,
            pitch_deg: 0.0,
            yaw_deg: 180.0,
        };
        let world = WorldPose::of(&towards, &mount, &station);
        assert!((world.nose_az_deg - 270.0).abs() < 1e-9, "{world:?}");
        assert!(world.nose_el_deg.abs() < 1e-9, "{world:?}");
        for (got, want) in world.origin_enu_m.iter().zip([1010.0, 20.0, 30.0]) {
            assert!((got - want).abs() < 1e-9, "{world:?}");
        }
        let up = Pose {
            pitch_deg: 90.0,
            ..towards
        };
        assert!((WorldPose::of(&up, &mount, &station).nose_el_deg - 90.0).abs() < 1e-9);
        // Image +Y is down: a body below the image centre is below the horizon.
        let below = Pose {
            ty_m: 5.0,
            ..towards
        };
        assert!((WorldPose::of(&below, &mount, &station).origin_enu_m[2] - 25.0).abs() < 1e-9);
    }

    #[test]
    fn pointings_that_are_no_pointing_are_refused() {
        assert_eq!(
            Mount::new_checked(f64::NAN, 0.0),
            Err(MountError::NotFinite)
        );
        assert_eq!(
            Mount::new_checked(0.0, f64::INFINITY),
            Err(MountError::NotFinite)
        );
        assert_eq!(
            Mount::new_checked(0.0, 90.5),
            Err(MountError::ElevationOutOfRange)
        );
        assert!(Mount::new_checked(-400.0, -90.0).is_ok());
    }

    /// The azimuth stays in [0, 360) whatever the mount's azimuth is written as.
    #[test]
    fn the_nose_azimuth_is_folded_into_a_turn() {
        let pose = Pose {
            tx_m: 0.0,
            ty_m: 0.0,
            tz_m: 1000.0,
            pitch_deg: 10.0,
            yaw_deg: 0.0,
        };
        for az in [-720.0, -30.0, 0.0, 359.999, 725.0] {
            let mount = Mount::new_checked(az, 5.0).unwrap();
            let world = WorldPose::of(&pose, &mount, &Station::default());
            assert!((0.0..360.0).contains(&world.nose_az_deg), "{az}: {world:?}");
            let expected = (az % 360.0 + 360.0) % 360.0;
            let gap = ((world.nose_az_deg - expected + 540.0) % 360.0) - 180.0;
            assert!(gap.abs() < 1e-6, "{az}: {world:?}");
        }
    }
}
