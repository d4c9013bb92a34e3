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

/// The body's roll (about +x_B, deg, in (-180, 180]) at attitude `pitch_deg`, `yaw_deg` whose
/// silhouette, seen along `line_of_sight` (C, towards the body), shows its fins turned by
/// `silhouette_roll_deg` ([`crate::lut::render::View::roll_deg`]: a fin's angle from the
/// silhouette's `+v`, the projected axis turned +90 deg in the image, towards the axis cross
/// `+v`).
///
/// The silhouette frame's `+v` lies at an angle `alpha` from +y_B towards +z_B of the body at
/// roll 0; a fin at `psi` from `+v` then lies at `alpha + psi` from +y_B, so the roll is
/// `alpha + silhouette_roll_deg`. A silhouette is drawn with the nose tilted away from the
/// camera; the same outline with the nose towards it is its mirror image across the image
/// plane, which turns the fins the other way round: there the roll is
/// `alpha - silhouette_roll_deg`.
pub fn roll_of_silhouette(
    pitch_deg: f32,
    yaw_deg: f32,
    line_of_sight: &Vector3<f32>,
    silhouette_roll_deg: f32,
) -> f32 {
    let level = rotation_body_to_camera(pitch_deg, yaw_deg, 0.0);
    let (nose, y0, z0) = (level.column(0), level.column(1), level.column(2));
    let sight = line_of_sight.normalize();
    let along = nose.dot(&sight);
    let projected = (nose - sight * along).normalize();
    let v = sight.cross(&projected);
    let alpha = libm::atan2f(v.dot(&z0), v.dot(&y0)) * DEG;
    let turn = if along >= 0.0 { 1.0 } else { -1.0 };
    wrap_deg(alpha + turn * silhouette_roll_deg)
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

    /// The roll of a silhouette is the pose's: the reference posed at a pitch, yaw and roll
    /// (nose away from the camera or towards it), seen along a line of sight, projects its fin
    /// tips where the silhouette renderer draws them at the view's tilt and at the silhouette
    /// roll that `roll_of_silhouette` maps back to the pose's roll.
    #[test]
    fn a_silhouettes_roll_is_the_poses() {
        let model = crate::model::testing::reference();
        let fins = model.fins().unwrap();
        let sight = Vector3::new(0.01, -0.02, 1.0).normalize();
        for (pitch, yaw, roll) in [
            (30.0f32, -60.0f32, 20.0f32),
            (-10.0, 110.0, -35.0),
            (50.0, 150.0, 70.0),
            (5.0, -95.0, 10.0),
        ] {
            let r = rotation_body_to_camera(pitch, yaw, roll);
            let nose = r.column(0).into_owned();
            let along = nose.dot(&sight);
            let u = (nose - sight * along).normalize();
            let v = sight.cross(&u);
            // The silhouette roll that maps back to `roll`, found by search (no inverse
            // formula): the one whose image the mapping returns as `roll`.
            let silhouette_roll = (0..3600)
                .map(|i| i as f32 * 0.1)
                .min_by(|a, b| {
                    let miss =
                        |x: f32| wrap_deg(roll_of_silhouette(pitch, yaw, &sight, x) - roll).abs();
                    miss(*a).total_cmp(&miss(*b))
                })
                .unwrap();
            let view = crate::lut::render::View {
                tilt_deg: libm::asinf(along.abs()) * DEG,
                roll_deg: silhouette_roll,
            };
            // The fins are drawn last: the last 64 vertices hold theirs.
            let mut drawn: [(f32, f32); 64] = [(f32::NAN, f32::NAN); 64];
            let mut count = 0usize;
            crate::lut::render::for_each_triangle(&model, &view, |t| {
                for p in t {
                    drawn[count % 64] = p;
                    count += 1;
                }
            });
            let half = 0.5 * model.length_m;
            let (tip_le, _) = fins.tip_s;
            for k in 0..fins.count {
                let phi = (fins.first_roll_deg + 90.0 * f32::from(k)) * RAD;
                let body = Vector3::new(
                    half - tip_le,
                    fins.tip_radius_m * libm::cosf(phi),
                    fins.tip_radius_m * libm::sinf(phi),
                );
                let seen = r * body;
                let (pu, pv) = (seen.dot(&u), seen.dot(&v));
                let nearest = drawn
                    .iter()
                    .map(|(a, b)| libm::hypotf(a - pu, b - pv))
                    .fold(f32::INFINITY, f32::min);
                assert!(
                    nearest < 2e-3,
                    "pose ({pitch}, {yaw}, {roll}): fin {k} tip ({pu}, {pv}) is {nearest} m from the silhouette's"
                );
            }
        }
    }
}
