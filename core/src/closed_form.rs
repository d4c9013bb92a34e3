//! Closed-form pose from the silhouette's measurements: the source paper's Eq. 1-2 made exact
//! for chips away from the optical centre.
//!
//! The paper reads pitch and yaw from the projected axis: `H = L sin(pitch)`,
//! `W = L cos(pitch) sin(yaw)`, `L` the full length in px at the target's distance. Here the same
//! relation is solved in the line-of-sight frame of the body origin (whose z axis is the ray
//! through it): the nose-tail vector's components across the line of sight are the measured
//! angular offsets times the slant range, and its component along it is `±sqrt(L² - |Δ|²)`, the
//! two signs being the two yaw candidates of the paper's Eq. 3. Rotating back to the camera frame
//! gives pitch and yaw without the error of treating the line of sight as the optical axis (up to
//! half the field of view, 0.6° for the 2048 px, 100000 px-focal camera).
//!
//! The measured ends are first corrected with the model: the nose tip for the ogive's curvature
//! ([`ProjectileModel::nose_ramp_zero_offset_m`]) and the tail edge for the base, whose
//! foreshortened disc (of the base radius R_b) reaches `R_b |cos(aspect)|` beyond the base centre (its half-width point
//! at `0.866 R |cos(aspect)|`).

use crate::camera::{Camera, line_of_sight_frame};
use crate::extremes::Silhouette;
use crate::model::ProjectileModel;
use crate::point::ImagePoint;
use crate::pose::{DEG, attitude_of, nose_direction};
use nalgebra::{Vector2, Vector3};

/// Where the width of a foreshortened disc falls to half, in radii from its centre.
const DISC_HALF_WIDTH_REACH: f32 = 0.866;

/// Iterations of the end corrections, which depend on the aspect angle being solved for.
const END_CORRECTION_ITERATIONS: usize = 4;

/// Pitch and yaw of one candidate, deg.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Attitude {
    /// Pitch, deg.
    pub pitch_deg: f32,
    /// Yaw, deg.
    pub yaw_deg: f32,
}

/// The closed-form solution.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ClosedForm {
    /// Body origin in C, m.
    pub translation: [f32; 3],
    /// The two mirror candidates: `[0]` with the nose pointing away along the line of sight
    /// (range growing in nose-first flight), `[1]` with it pointing towards the camera.
    pub candidates: [Attitude; 2],
    /// Angle between the body axis and the line of sight, deg, in [0, 90].
    pub aspect_deg: f32,
}

impl Attitude {
    /// The mean of two attitudes: of their unit nose directions.
    pub fn mean(&self, other: &Attitude) -> Attitude {
        let nose = nose_direction(self.pitch_deg, self.yaw_deg)
            + nose_direction(other.pitch_deg, other.yaw_deg);
        let (pitch_deg, yaw_deg) = attitude_of(&nose);
        Attitude { pitch_deg, yaw_deg }
    }
}

impl ClosedForm {
    /// The mean of two solutions of one frame at one range, candidate by candidate, and of the
    /// aspects; the translation stays this one's.
    pub fn mean(&self, other: &ClosedForm) -> ClosedForm {
        let [a, b] = self.candidates;
        let [c, d] = other.candidates;
        ClosedForm {
            translation: self.translation,
            candidates: [a.mean(&c), b.mean(&d)],
            aspect_deg: 0.5 * (self.aspect_deg + other.aspect_deg),
        }
    }
}

/// The closed-form stage's result: the pose hypothesis that the table match starts from, and the
/// pose of a frame that has no table match.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Hypothesis {
    /// The silhouette it was solved from.
    pub silhouette: Silhouette,
    /// Full-frame px of the chip's top-left pixel.
    pub origin: (i32, i32),
    /// The slant range the image stages hold the body's scale at, m, where there is one: a
    /// range sensor's reading, or the flight filter's where it is sure ([`Hypothesis::from_flight`]).
    pub fixed_range_m: Option<f32>,
    /// True where `fixed_range_m` is the flight filter's prediction (no range sensor,
    /// [`crate::flight_filter::FlightFilterConfig::hold_fraction`]).
    pub from_flight: bool,
    /// Slant range from the silhouette's diameter, m, where it gives a finite one.
    pub image_range_m: Option<f32>,
    /// The slant range the hypothesis is solved at: the sensor's, else the image's, m.
    pub range_m: f32,
    /// The closed-form solution at `range_m`.
    pub solution: ClosedForm,
}

impl Hypothesis {
    /// The hypothesis from `silhouette` on a chip whose top-left is full-frame `origin`, at the
    /// sensor's range where there is one, else at the range of the apparent diameter; None when
    /// neither gives a range.
    pub fn solve(
        silhouette: &Silhouette,
        origin: (i32, i32),
        camera: &Camera,
        model: &ProjectileModel,
        sensor_range_m: Option<f32>,
    ) -> Option<Hypothesis> {
        let image_range_m = range_from_diameter(silhouette, camera, model);
        let range_m = sensor_range_m.or(image_range_m)?;
        Some(Hypothesis {
            silhouette: *silhouette,
            origin,
            fixed_range_m: sensor_range_m,
            from_flight: false,
            image_range_m,
            range_m,
            solution: solve(silhouette, origin, camera, model, range_m),
        })
    }

    /// The range sensor's reading the hypothesis was solved at, m, where it was (not the
    /// flight filter's).
    pub fn sensor_range_m(&self) -> Option<f32> {
        self.fixed_range_m.filter(|_| !self.from_flight)
    }

    /// The closed form at slant range `range_m` (the temporal stage's).
    pub fn at_range(&self, camera: &Camera, model: &ProjectileModel, range_m: f32) -> ClosedForm {
        if range_m == self.range_m {
            self.solution
        } else {
            solve(&self.silhouette, self.origin, camera, model, range_m)
        }
    }
}

/// The silhouette's ends in full-frame px, for a chip whose top-left is `origin`.
fn ends(
    sil: &Silhouette,
    origin: (i32, i32),
    nose_t: f32,
    tail_t: f32,
) -> (ImagePoint, ImagePoint) {
    let o = ImagePoint::of_pixel(origin);
    (o + sil.axis.point(nose_t), o + sil.axis.point(tail_t))
}

/// Slant range to the body from its apparent diameter, m.
pub fn range_from_diameter(
    sil: &Silhouette,
    camera: &Camera,
    model: &ProjectileModel,
) -> Option<f32> {
    let across = sil.axis.dir.perpendicular().into();
    let angular = camera.normalized_length(sil.diameter_px, across);
    let range = model.diameter_m / angular;
    (range.is_finite() && range > 0.0).then_some(range)
}

/// The nose tip and the tail base centre along the silhouette's axis, px, from its measured
/// ends, at an aspect with sine `sin_a` and cosine `cos_a` and a scale of `px_per_m` across the
/// line of sight.
pub fn corrected_ends(
    sil: &Silhouette,
    model: &ProjectileModel,
    sin_a: f32,
    cos_a: f32,
    px_per_m: f32,
) -> (f32, f32) {
    (
        sil.nose_t + sil.nose_ramp_offset_m * sin_a * px_per_m,
        sil.tail_t + DISC_HALF_WIDTH_REACH * model.base_radius_m() * cos_a * px_per_m,
    )
}

/// Solves the pose at slant range `range_m` from the silhouette of a chip whose top-left pixel is
/// full-frame `origin`.
pub fn solve(
    sil: &Silhouette,
    origin: (i32, i32),
    camera: &Camera,
    model: &ProjectileModel,
    range_m: f32,
) -> ClosedForm {
    let dir = sil.axis.dir.into();
    // Pixels per metre across the line of sight, along the image axis.
    let px_per_m = 1.0 / (range_m * camera.normalized_length(1.0, dir)).max(f32::MIN_POSITIVE);
    let corrected = |sin_a: f32, cos_a: f32| {
        let (nose_t, tail_t) = corrected_ends(sil, model, sin_a, cos_a, px_per_m);
        let (nose, tail) = ends(sil, origin, nose_t, tail_t);
        from_ends(nose, tail, camera, model.length_m, range_m)
    };
    // Start broadside; each pass corrects the ends for the aspect of the last.
    let mut solution = corrected(1.0, 0.0);
    for _ in 1..END_CORRECTION_ITERATIONS {
        let aspect = solution.aspect_deg / DEG;
        solution = corrected(libm::sinf(aspect), libm::cosf(aspect));
    }
    solution
}

/// The pose whose nose tip and tail base centre project to full-frame `nose` and `tail` px, for a
/// body `length` m long at slant range `range_m`.
pub fn from_ends(
    nose: ImagePoint,
    tail: ImagePoint,
    camera: &Camera,
    length: f32,
    range_m: f32,
) -> ClosedForm {
    let mid = camera.normalize(0.5 * (nose.x + tail.x), 0.5 * (nose.y + tail.y));
    let frame = line_of_sight_frame(mid);
    let angle = |p: ImagePoint| {
        let n = camera.normalize(p.x, p.y);
        let r = frame * Vector3::new(n.x, n.y, 1.0);
        Vector2::new(r.x / r.z, r.y / r.z)
    };
    let delta = (angle(nose) - angle(tail)) * range_m;
    let sin_a = (delta.norm() / length).min(1.0);
    let cos_a = libm::sqrtf((1.0 - sin_a * sin_a).max(0.0));
    let transverse = delta / (length.max(delta.norm()));
    let candidate = |sign: f32| {
        let n_los = Vector3::new(transverse.x, transverse.y, sign * cos_a);
        let n = frame.transpose() * n_los;
        let (pitch_deg, yaw_deg) = attitude_of(&n);
        Attitude { pitch_deg, yaw_deg }
    };
    let los = frame.row(2).transpose();
    let t = los * range_m;
    ClosedForm {
        translation: [t.x, t.y, t.z],
        candidates: [candidate(1.0), candidate(-1.0)],
        aspect_deg: libm::asinf(sin_a) * DEG,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn attitude(pitch_deg: f32, yaw_deg: f32) -> Attitude {
        Attitude { pitch_deg, yaw_deg }
    }

    /// Means by hand: of yaws +-10 deg at zero pitch, yaw 0; of pitches 10 and 20 deg at one
    /// yaw, 15 deg (the unit vectors' bisector); of yaws 179 and -179 deg, 180 (across the wrap).
    #[test]
    fn the_mean_attitude_bisects_the_nose_directions() {
        let m = attitude(0.0, 10.0).mean(&attitude(0.0, -10.0));
        assert!(m.pitch_deg.abs() < 1e-4 && m.yaw_deg.abs() < 1e-4, "{m:?}");
        let m = attitude(10.0, 30.0).mean(&attitude(20.0, 30.0));
        assert!((m.pitch_deg - 15.0).abs() < 1e-4 && (m.yaw_deg - 30.0).abs() < 1e-4);
        let m = attitude(0.0, 179.0).mean(&attitude(0.0, -179.0));
        assert!(
            (crate::pose::wrap_deg(m.yaw_deg - 180.0)).abs() < 1e-3,
            "{m:?}"
        );
    }
}
