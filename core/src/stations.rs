//! Several stations: one instant of the flight seen by two or more cameras that do not look
//! along the same line, combined in the range's East-North-Up frame E.
//!
//! One station's silhouette fixes the body's axis only up to its tilt out of the image plane:
//! the two yaw candidates mirror each other about it, and near broadside the tilt is weakly
//! conditioned by the silhouette's length. What it fixes sharply is the *axis plane*, the plane
//! through the camera's optical centre and the body's axis: both candidates lie in it, and its
//! unit normal `m = d x n` (the line of sight `d` to the body origin, either candidate's nose
//! `n`) rotates about `d` only with the axis's angle in the image. Two axis planes that are not
//! the same meet in the axis, so the nose is the unit vector nearest to lying in every plane:
//! the eigenvector of `sum m mᵀ / sd²` of least eigenvalue, on the side to which every station
//! sees the nose point in its image. No yaw candidate and no range enter; the yaw ambiguity is
//! gone. Each station's own tilt is then taken in too: the candidate nearer that nose is the
//! one the stations agree on, and one weighted least-squares step across the nose weighs every
//! plane by its sigma and every agreed candidate by its tilt's, so a station that sees the tilt
//! well still counts where the planes meet at a narrow angle. The body origin is the point
//! nearest to every line of sight (weighted least squares), so the stations fix it without a
//! range sensor too.
//!
//! The arithmetic is `f64`, on the host and on a co-processor alike.

use crate::pose::nose_direction;
use crate::world::{Mount, Station};
use nalgebra::{Matrix2, Matrix3, Matrix3x2, SymmetricEigen, Vector2, Vector3};

/// What one station saw of the body at one instant, in E.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StationSight {
    /// The station's optical centre in E, m.
    pub station_enu_m: Vector3<f64>,
    /// Unit line of sight from the station to the body origin, in E.
    pub sight: Vector3<f64>,
    /// Unit normal of the axis plane, `sight x nose`, in E.
    pub axis_normal: Vector3<f64>,
    /// The two yaw candidates' unit noses in E (both in the axis plane, mirror images across
    /// the line of sight's normal plane).
    pub candidates: [Vector3<f64>; 2],
    /// One sigma of a candidate's tilt within the axis plane, rad.
    pub tilt_sd_rad: f64,
    /// The station's range to the body origin, m (its own estimate: it weights the line of
    /// sight, whose sideways error grows with it).
    pub range_m: f64,
    /// One sigma of the axis plane's normal (the axis's angle in the image), rad.
    pub plane_sd_rad: f64,
    /// One sigma of the line of sight's direction, rad.
    pub sight_sd_rad: f64,
}

/// One sigma of each part of a station's sight, rad.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SightSd {
    /// The axis plane's normal (the axis's angle in the image).
    pub plane: f64,
    /// The tilt within the axis plane.
    pub tilt: f64,
    /// The line of sight.
    pub sight: f64,
}

/// Why the stations' sights cannot be combined.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FusionError {
    /// Fewer than two stations saw the body.
    TooFewStations,
    /// The lines of sight are nearly parallel: the stations look along the same line, and the
    /// position along it is not fixed.
    SameLine,
    /// The axis planes are nearly the same plane (the body's axis lies in the plane of the
    /// stations and the body): the axis is not fixed within it.
    SamePlane,
    /// A sight is not a finite unit vector, or its range or sigmas are not positive.
    BadSight,
}

/// Where the combination is refused.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FusionConfig {
    /// The largest angle between two stations' lines of sight must be at least this, deg.
    pub min_sight_angle_deg: f64,
    /// The axis planes must meet at least at this angle, deg.
    pub min_plane_angle_deg: f64,
}

impl FusionConfig {
    /// The defaults: 5 deg either way (below it, a 0.01 deg error of a plane or sight moves the
    /// result over 0.1 deg or 0.1 % of the range).
    pub const DEFAULT: FusionConfig = FusionConfig {
        min_sight_angle_deg: 5.0,
        min_plane_angle_deg: 5.0,
    };
}

impl Default for FusionConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The stations' sights combined.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FusedSight {
    /// Unit nose direction in E.
    pub nose: Vector3<f64>,
    /// Its covariance in E, rad² (rank 2: across the nose).
    pub nose_cov: Matrix3<f64>,
    /// The body origin in E, m.
    pub origin_enu_m: Vector3<f64>,
    /// Its covariance, m².
    pub origin_cov: Matrix3<f64>,
    /// The angle at which the axis planes meet, deg (the two largest apart, for more than two).
    pub plane_angle_deg: f64,
}

impl StationSight {
    /// A station's sight from its frame's pose in its camera frame C: the body origin
    /// `origin_c_m` (m) and either yaw candidate's `pitch_deg` and `yaw_deg`, with the camera
    /// at `station` pointed as `mount`; `sd_rad` are the sigmas of the axis plane, the tilt and
    /// the line of sight. None where the axis lies along the line of sight (no axis plane) or
    /// the origin is not in front of the camera.
    pub fn from_camera(
        station: &Station,
        mount: &Mount,
        origin_c_m: [f64; 3],
        pitch_deg: f64,
        yaw_deg: f64,
        sd_rad: SightSd,
    ) -> Option<StationSight> {
        let r_ec = mount.rotation_camera_to_world();
        let origin_c = Vector3::from(origin_c_m);
        let range_m = origin_c.norm();
        if !(origin_c.z > 0.0 && range_m.is_finite()) {
            return None;
        }
        let sight = r_ec * origin_c / range_m;
        let nose = r_ec * nose_direction(pitch_deg as f32, yaw_deg as f32).map(f64::from);
        let normal = sight.cross(&nose);
        let length = normal.norm();
        (length > 1e-6).then(|| StationSight {
            station_enu_m: Vector3::from(station.enu_m),
            sight,
            axis_normal: normal / length,
            candidates: [nose, mirror(&nose, &sight)],
            tilt_sd_rad: sd_rad.tilt,
            range_m,
            plane_sd_rad: sd_rad.plane,
            sight_sd_rad: sd_rad.sight,
        })
    }

    /// The sight at `fraction` (0 to 1) of the way from `self` to `later`, a later frame of the
    /// same station: the body origin (along each sight at its range) and the axis plane's
    /// normal interpolated linearly, made unit again, the rest linearly. None
    /// where the two frames' axis planes face opposite ways (one of them read nose and tail the
    /// other way round).
    pub fn between(&self, later: &StationSight, fraction: f64) -> Option<StationSight> {
        if self.axis_normal.dot(&later.axis_normal) <= 0.0 {
            return None;
        }
        let lerp = |a: f64, b: f64| a + (b - a) * fraction;
        // The later frame's candidates in the order of this one's (its choice may differ).
        let [c0, c1] = later.candidates;
        let later_candidates = if self.candidates[0].dot(&c0) >= self.candidates[0].dot(&c1) {
            [c0, c1]
        } else {
            [c1, c0]
        };
        let unit = |a: &Vector3<f64>, b: &Vector3<f64>| (a + (b - a) * fraction).normalize();
        let sight = unit(&(self.sight * self.range_m), &(later.sight * later.range_m));
        // The normal kept at right angles to the sight it goes with.
        let normal = unit(&self.axis_normal, &later.axis_normal);
        let normal = (normal - sight * normal.dot(&sight)).normalize();
        let in_plane = |a: &Vector3<f64>, b: &Vector3<f64>| {
            let n = unit(a, b);
            (n - normal * n.dot(&normal)).normalize()
        };
        Some(StationSight {
            station_enu_m: self.station_enu_m,
            sight,
            axis_normal: normal,
            candidates: [
                in_plane(&self.candidates[0], &later_candidates[0]),
                in_plane(&self.candidates[1], &later_candidates[1]),
            ],
            tilt_sd_rad: lerp(self.tilt_sd_rad, later.tilt_sd_rad),
            range_m: lerp(self.range_m, later.range_m),
            plane_sd_rad: lerp(self.plane_sd_rad, later.plane_sd_rad),
            sight_sd_rad: lerp(self.sight_sd_rad, later.sight_sd_rad),
        })
    }

    /// The nose's direction in this station's image plane, up to length: across the line of
    /// sight and the axis plane's normal.
    fn nose_across(&self) -> Vector3<f64> {
        self.axis_normal.cross(&self.sight)
    }

    fn is_valid(&self) -> bool {
        let unit = |v: &Vector3<f64>| (v.norm() - 1.0).abs() < 1e-6;
        unit(&self.sight)
            && unit(&self.axis_normal)
            && self.candidates.iter().all(unit)
            && self.station_enu_m.iter().all(|x| x.is_finite())
            && [
                self.range_m,
                self.plane_sd_rad,
                self.tilt_sd_rad,
                self.sight_sd_rad,
            ]
            .iter()
            .all(|&x| x.is_finite() && x > 0.0)
    }
}

/// Combines two or more stations' sights of one instant (module docs).
pub fn fuse(sights: &[StationSight], config: &FusionConfig) -> Result<FusedSight, FusionError> {
    if sights.len() < 2 {
        return Err(FusionError::TooFewStations);
    }
    if !sights.iter().all(StationSight::is_valid) {
        return Err(FusionError::BadSight);
    }
    let widest_sight = sights
        .iter()
        .enumerate()
        .flat_map(|(i, a)| {
            sights
                .iter()
                .skip(i + 1)
                .map(move |b| angle_deg(&a.sight, &b.sight))
        })
        .fold(0.0, f64::max);
    if widest_sight < config.min_sight_angle_deg {
        return Err(FusionError::SameLine);
    }
    let (planes_nose, plane_angle_deg) = nose_of_planes(sights);
    if plane_angle_deg < config.min_plane_angle_deg {
        return Err(FusionError::SamePlane);
    }
    let (nose, nose_cov) = nose_with_tilts(sights, &planes_nose);
    let (origin_enu_m, origin_cov) = origin_of(sights).ok_or(FusionError::SameLine)?;
    Ok(FusedSight {
        nose,
        nose_cov,
        origin_enu_m,
        origin_cov,
        plane_angle_deg,
    })
}

/// The nose nearest to every axis plane, and the planes' effective angle, deg.
fn nose_of_planes(sights: &[StationSight]) -> (Vector3<f64>, f64) {
    let scatter: Matrix3<f64> = sights
        .iter()
        .map(|s| s.axis_normal * s.axis_normal.transpose() / (s.plane_sd_rad * s.plane_sd_rad))
        .sum();
    let eigen = SymmetricEigen::new(scatter);
    let mut order = [0, 1, 2];
    order.sort_unstable_by(|&a, &b| eigen.eigenvalues[a].total_cmp(&eigen.eigenvalues[b]));
    let [least, middle, most] = order;
    let lambda = |i: usize| eigen.eigenvalues[i];
    let mut nose = eigen.eigenvectors.column(least).into_owned();
    // On the side each station sees the nose point to, weighted by how well it sees it.
    let towards: f64 = sights
        .iter()
        .map(|s| nose.dot(&s.nose_across()) / s.plane_sd_rad)
        .sum();
    if towards < 0.0 {
        nose = -nose;
    }
    // Two planes whose normals meet at phi give eigenvalues w (1 -+ cos phi): their ratio is
    // tan²(phi / 2).
    let ratio = (lambda(middle) - lambda(least)) / (lambda(most) - lambda(least));
    (
        nose,
        2.0 * libm::atan(libm::sqrt(ratio.max(0.0))).to_degrees(),
    )
}

/// The nose from the planes' `start`, refined by one weighted least-squares step across it over
/// every plane and every station's candidate nearer `start` (its tilt), and its covariance in E.
fn nose_with_tilts(sights: &[StationSight], start: &Vector3<f64>) -> (Vector3<f64>, Matrix3<f64>) {
    // Two directions across the start.
    let helper = if start.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let e1 = start.cross(&helper).normalize();
    let e2 = start.cross(&e1);
    let mut normal = Matrix2::<f64>::zeros();
    let mut rhs = Vector2::<f64>::zeros();
    let mut add = |direction: &Vector3<f64>, residual: f64, sd: f64| {
        let row = Vector2::new(direction.dot(&e1), direction.dot(&e2)) / sd;
        normal += row * row.transpose();
        rhs -= row * (residual / sd);
    };
    for s in sights {
        add(&s.axis_normal, s.axis_normal.dot(start), s.plane_sd_rad);
        let agreed = if s.candidates[0].dot(start) >= s.candidates[1].dot(start) {
            s.candidates[0]
        } else {
            s.candidates[1]
        };
        let tilt = s.axis_normal.cross(&agreed);
        add(&tilt, tilt.dot(&(start - agreed)), s.tilt_sd_rad);
    }
    let basis = Matrix3x2::from_columns(&[e1, e2]);
    match normal.try_inverse() {
        Some(cov) => {
            let step = cov * rhs;
            let nose = (start + basis * step).normalize();
            (nose, basis * cov * basis.transpose())
        }
        None => (*start, Matrix3::zeros()),
    }
}

/// The point nearest every line of sight, each weighted by its sideways sigma at its range,
/// and its covariance. None where the normal equations are singular.
fn origin_of(sights: &[StationSight]) -> Option<(Vector3<f64>, Matrix3<f64>)> {
    let mut normal = Matrix3::<f64>::zeros();
    let mut rhs = Vector3::<f64>::zeros();
    for s in sights {
        let sideways_sd_m = s.range_m * s.sight_sd_rad;
        let across =
            (Matrix3::identity() - s.sight * s.sight.transpose()) / (sideways_sd_m * sideways_sd_m);
        normal += across;
        rhs += across * s.station_enu_m;
    }
    let cov = normal.try_inverse()?;
    Some((cov * rhs, cov))
}

/// `nose` mirrored across the plane normal to the unit `sight`: the other yaw candidate.
pub fn mirror(nose: &Vector3<f64>, sight: &Vector3<f64>) -> Vector3<f64> {
    nose - sight * 2.0 * nose.dot(sight)
}

/// The angle between two unit vectors, deg.
fn angle_deg(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    libm::atan2(a.cross(b).norm(), a.dot(b)).to_degrees()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sight of a body at `origin` with nose `nose` (both E) from a station at `station`.
    fn sight(station: [f64; 3], origin: Vector3<f64>, nose: Vector3<f64>) -> StationSight {
        let station = Vector3::from(station);
        let d = origin - station;
        let sight = d.normalize();
        StationSight {
            station_enu_m: station,
            sight,
            axis_normal: sight.cross(&nose).normalize(),
            candidates: [nose, mirror(&nose, &sight)],
            range_m: d.norm(),
            plane_sd_rad: 1e-4,
            // The tilt a thousand times worse than the plane: the planes decide.
            tilt_sd_rad: 1e-1,
            sight_sd_rad: 1e-5,
        }
    }

    #[test]
    fn two_stations_give_the_nose_and_the_origin() {
        // Hand-made: the body 1 km north of A at 500 m, nose north-east and climbing.
        let origin = Vector3::new(0.0, 1000.0, 500.0);
        let nose = Vector3::new(1.0, 1.0, 0.5).normalize();
        let a = sight([0.0, 0.0, 0.0], origin, nose);
        // B 1.5 km east and 1.8 km north: its axis plane meets A's at 45 deg.
        let b = sight([1500.0, 1800.0, 10.0], origin, nose);
        let fused = fuse(&[a, b], &FusionConfig::DEFAULT).unwrap();
        assert!((fused.plane_angle_deg - 45.32).abs() < 0.01);
        assert!((fused.nose - nose).norm() < 1e-9, "{:?}", fused.nose);
        assert!((fused.origin_enu_m - origin).norm() < 1e-6);
        // Either yaw candidate gives the same axis plane: the mirrored nose (about the image
        // plane, across A's sight) fuses to the same answer.
        let a_mirrored = sight([0.0, 0.0, 0.0], origin, mirror(&nose, &a.sight));
        let again = fuse(&[a_mirrored, b], &FusionConfig::DEFAULT).unwrap();
        assert!((again.nose - nose).norm() < 1e-9);
    }

    #[test]
    fn the_planes_angle_and_the_nose_sigma_follow_the_geometry() {
        let origin = Vector3::new(0.0, 1000.0, 0.0);
        // The nose straight up; A looks north, B north-east from 45 deg round: the axis planes
        // (both vertical, through each line of sight) meet at 45 deg.
        let nose = Vector3::new(0.0, 0.0, 1.0);
        let a = sight([0.0, 0.0, 0.0], origin, nose);
        let b = sight([-1000.0, 0.0, 0.0], origin, nose);
        let fused = fuse(&[a, b], &FusionConfig::DEFAULT).unwrap();
        assert!((fused.plane_angle_deg - 45.0).abs() < 1e-6);
        // Across both planes' normals' bisector the sigma is sd / (sqrt 2 sin(phi / 2))...
        let sd = 1e-4;
        let (half, n_sum) = (22.5_f64.to_radians(), a.axis_normal + b.axis_normal);
        let along_sum = n_sum.normalize();
        let var = (along_sum.transpose() * fused.nose_cov * along_sum)[0];
        let expected = sd / (2.0_f64.sqrt() * half.cos());
        assert!(
            (var.sqrt() - expected).abs() < 1e-9,
            "{} {}",
            var.sqrt(),
            expected
        );
        let along_diff = (a.axis_normal - b.axis_normal).normalize();
        let var = (along_diff.transpose() * fused.nose_cov * along_diff)[0];
        let expected = sd / (2.0_f64.sqrt() * half.sin());
        assert!((var.sqrt() / expected - 1.0).abs() < 1e-5);
    }

    #[test]
    fn a_station_that_sees_the_tilt_well_counts_where_the_planes_meet_narrowly() {
        let origin = Vector3::new(0.0, 1000.0, 0.0);
        let nose = Vector3::new(0.3, 0.2, 1.0).normalize();
        let a = sight([0.0, 0.0, 0.0], origin, nose);
        let b = sight([-200.0, 0.0, 0.0], origin, nose);
        // Each plane off by its sigma (turned about its line of sight); B's candidate exact and
        // its tilt sharp.
        let turn = |s: &StationSight, angle: f64| {
            let r = nalgebra::Rotation3::from_axis_angle(
                &nalgebra::Unit::new_normalize(s.sight),
                angle,
            );
            StationSight {
                axis_normal: r * s.axis_normal,
                candidates: [r * s.candidates[0], r * s.candidates[1]],
                ..*s
            }
        };
        let (a, b) = (turn(&a, 1e-4), turn(&b, -1e-4));
        let planes_only = fuse(&[a, b], &FusionConfig::DEFAULT).unwrap();
        let b_sharp = StationSight {
            tilt_sd_rad: 1e-5,
            candidates: sight([-200.0, 0.0, 0.0], origin, nose).candidates,
            ..b
        };
        let with_tilt = fuse(&[a, b_sharp], &FusionConfig::DEFAULT).unwrap();
        let error = |f: &FusedSight| libm::acos(f.nose.dot(&nose).min(1.0));
        assert!(error(&planes_only) > 5e-4, "{}", error(&planes_only));
        assert!(error(&with_tilt) < 1.5e-4, "{}", error(&with_tilt));
    }

    #[test]
    fn degenerate_geometry_is_refused() {
        let origin = Vector3::new(0.0, 1000.0, 500.0);
        let nose = Vector3::new(1.0, 0.2, 0.1).normalize();
        let a = sight([0.0, 0.0, 0.0], origin, nose);
        assert_eq!(
            fuse(&[a], &FusionConfig::DEFAULT),
            Err(FusionError::TooFewStations)
        );
        // B 20 m beside A: the lines of sight meet at about 1 deg.
        let b = sight([20.0, 0.0, 0.0], origin, nose);
        assert_eq!(
            fuse(&[a, b], &FusionConfig::DEFAULT),
            Err(FusionError::SameLine)
        );
        // The axis in the plane of both stations and the body: the planes coincide.
        let in_plane = (origin - Vector3::new(0.0, 0.0, 0.0)).normalize();
        let along = Vector3::new(0.0, 1.0, 0.0) * 0.3 + in_plane;
        let c = sight([0.0, 2000.0, 0.0], origin, along.normalize());
        let d = sight([0.0, 0.0, 0.0], origin, along.normalize());
        assert_eq!(
            fuse(&[c, d], &FusionConfig::DEFAULT),
            Err(FusionError::SamePlane)
        );
        let mut bad = a;
        bad.range_m = f64::NAN;
        let b = sight([1500.0, 200.0, 10.0], origin, nose);
        assert_eq!(
            fuse(&[bad, b], &FusionConfig::DEFAULT),
            Err(FusionError::BadSight)
        );
    }

    #[test]
    fn a_sight_between_two_frames_is_interpolated() {
        let nose = Vector3::new(1.0, 1.0, 0.5).normalize();
        let a0 = sight([0.0, 0.0, 0.0], Vector3::new(0.0, 1000.0, 500.0), nose);
        let a1 = sight([0.0, 0.0, 0.0], Vector3::new(0.0, 1010.0, 502.0), nose);
        let mid = a0.between(&a1, 0.5).unwrap();
        let truth = sight([0.0, 0.0, 0.0], Vector3::new(0.0, 1005.0, 501.0), nose);
        assert!((mid.sight - truth.sight).norm() < 1e-12);
        assert!((mid.axis_normal - truth.axis_normal).norm() < 1e-5);
        assert!(mid.axis_normal.dot(&mid.sight).abs() < 1e-12);
        let flipped = StationSight {
            axis_normal: -a1.axis_normal,
            ..a1
        };
        assert_eq!(a0.between(&flipped, 0.5), None);
    }

    #[test]
    fn a_camera_frame_pose_gives_its_sight() {
        // The mount looking north and level: C's +Z is north, +X east, +Y down.
        let mount = Mount::new_checked(0.0, 0.0).unwrap();
        let station = Station {
            enu_m: [10.0, 20.0, 30.0],
        };
        // Nose along +X_C (east): pitch 0, yaw 90.
        let sd = SightSd {
            plane: 1e-4,
            tilt: 1e-3,
            sight: 1e-5,
        };
        let s =
            StationSight::from_camera(&station, &mount, [0.0, 0.0, 1000.0], 0.0, 90.0, sd).unwrap();
        assert!((s.sight - Vector3::new(0.0, 1.0, 0.0)).norm() < 1e-12);
        // north x east = down.
        assert!((s.axis_normal - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-6);
        assert!((s.range_m - 1000.0).abs() < 1e-9);
        // The nose along the line of sight has no axis plane.
        assert!(
            StationSight::from_camera(&station, &mount, [0.0, 0.0, 1000.0], 0.0, 0.0, sd).is_none()
        );
    }
}
