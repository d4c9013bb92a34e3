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
//! The pipeline runs this stage after the temporal estimate, where a frame comes with the mount's
//! pointing: the mount's co-processor states each ok frame in E live ([`WorldPose::of`]), fits
//! the body origin's velocity to its recent positions ([`WorldStage::motion`]), lets the velocity
//! choose the yaw candidate where the range sensor makes it sharp ([`Motion::side`]: a
//! projectile flies nose first), and gives the angle of attack ([`AngleOfAttack`]). The
//! arithmetic is in `f64`: a range frame spans kilometres, and the rounding is IEEE's on every
//! target, so host and firmware agree bit for bit. The trigonometry alone goes through `f32`
//! (the Cortex-M4F's FPU; `f64` there is software, ten times the cost): its 1e-7 of a radian
//! is 0.2 mm at 2 km and 1e-5 deg, below what the results print.

use crate::camera::Camera;
use crate::frame::{FrameResult, Status};
use crate::point::ImagePoint;
use crate::pose::{DEG, Pose, nose_direction};
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
        let (sa, ca) = sincos_deg(self.az_deg);
        let (se, ce) = sincos_deg(self.el_deg);
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
        Self::with_nose(pose, &mount.rotation_camera_to_world(), station).0
    }

    /// `pose` restated in E by the rotation `r_ec` from C, and its unit nose direction in E.
    fn with_nose(pose: &Pose, r_ec: &Matrix3<f64>, station: &Station) -> (WorldPose, Vector3<f64>) {
        let n = nose_in_world(r_ec, pose.pitch_deg, pose.yaw_deg);
        let horizontal = libm::sqrt(n.x * n.x + n.y * n.y);
        let az = atan2_deg(n.x, n.y);
        let pose = WorldPose {
            // atan2 gives (-180, 180]; -0 and rounding up to 360 are folded into [0, 360).
            nose_az_deg: if az < 0.0 { (az + 360.0) % 360.0 } else { az },
            nose_el_deg: atan2_deg(n.z, horizontal),
            origin_enu_m: origin_in_world(r_ec, pose, station),
        };
        (pose, n)
    }
}

/// The nose direction of an attitude in C (`crate::pose::nose_direction`) turned into E by
/// `r_ec`.
fn nose_in_world(r_ec: &Matrix3<f64>, pitch_deg: f32, yaw_deg: f32) -> Vector3<f64> {
    r_ec * nose_direction(pitch_deg, yaw_deg).map(f64::from)
}

/// The body origin of `pose` in E, m, for a camera at `station` turned into E by `r_ec`.
fn origin_in_world(r_ec: &Matrix3<f64>, pose: &Pose, station: &Station) -> [f64; 3] {
    let origin_c = Vector3::new(
        f64::from(pose.tx_m),
        f64::from(pose.ty_m),
        f64::from(pose.tz_m),
    );
    let origin = Vector3::from(station.enu_m) + r_ec * origin_c;
    [origin.x, origin.y, origin.z]
}

/// The angle of attack of one frame: the nose direction against the velocity, both in E.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AngleOfAttack {
    /// The total angle between the nose and the velocity, deg, in [0, 180].
    pub total_deg: f64,
    /// Its component in the vertical plane of the velocity: the nose above the velocity
    /// (positive) or below it, deg.
    pub up_deg: f64,
    /// Its component across: the nose right of the velocity, seen from behind (positive), or
    /// left of it, deg.
    pub right_deg: f64,
}

impl AngleOfAttack {
    /// The nose direction `nose_enu` (E, unit length) against `velocity_enu_m_s` (E, m/s). In
    /// the plane normal to the velocity, "right" is the horizontal `v x up` and "up" is
    /// `right x v`. None for a velocity that is not finite or too slow to have a direction, or
    /// vertical (no horizontal right).
    pub fn of(nose_enu: &[f64; 3], velocity_enu_m_s: &[f64; 3]) -> Option<AngleOfAttack> {
        let v = Vector3::from(*velocity_enu_m_s);
        let speed = v.norm();
        if !(speed.is_finite() && speed > MIN_SPEED_M_S) {
            return None;
        }
        let forward = v / speed;
        let right = forward.cross(&Vector3::z());
        let across = right.norm();
        if across < 1e-6 {
            return None;
        }
        let right = right / across;
        let up = right.cross(&forward);
        let nose = Vector3::from(*nose_enu);
        let ahead = nose.dot(&forward);
        Some(AngleOfAttack {
            total_deg: atan2_deg(nose.cross(&forward).norm(), ahead),
            up_deg: atan2_deg(nose.dot(&up), ahead),
            right_deg: atan2_deg(nose.dot(&right), ahead),
        })
    }
}

/// Sine and cosine of an angle in degrees, computed in `f32`.
fn sincos_deg(deg: f64) -> (f64, f64) {
    // Reduced to a turn first, so that f32 keeps its precision for any finite angle.
    let (s, c) = libm::sincosf(((deg % 360.0) as f32).to_radians());
    (f64::from(s), f64::from(c))
}

/// `atan2(y, x)` in degrees, computed in `f32`.
fn atan2_deg(y: f64, x: f64) -> f64 {
    f64::from(libm::atan2f(y as f32, x as f32).to_degrees())
}

/// Slowest body origin whose motion has a direction, m/s.
const MIN_SPEED_M_S: f64 = 1.0;

/// Positions in the velocity's fit.
pub const FLIGHT_SAMPLES: usize = 5;

/// The world stage's tunables.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct WorldConfig {
    /// The velocity is fitted over the positions of at most this many seconds (and at most
    /// [`FLIGHT_SAMPLES`] of them): a quadratic in time, exact for a ballistic arc without
    /// drag, so the window's span is what the drag's change of the acceleration allows.
    pub max_span_s: f64,
    /// A gap between frames with a position longer than this, s, starts the fit afresh.
    pub max_gap_s: f64,
    /// The velocity chooses the yaw candidate whose nose lies nearer to it where the two
    /// candidates' angles of attack differ by more than this, deg (a projectile flies nose
    /// first: within its angle of attack of the velocity); closer, the choice stays the range
    /// trend's.
    pub side_margin_deg: f64,
    /// Without a range sensor the positions, and so the velocity, stand on the image's ranges:
    /// the velocity resolves the yaw side only where the range's one sigma (`tz_sd_m`) is at
    /// most this fraction of it; elsewhere it still picks the candidate, unresolved. On the
    /// clear bundled clips 198 of the 208 frames resolved without the range had at most 2 %; on
    /// 18 simulated clutter clips the median was 7 %, and 107 of their 229 resolved frames were
    /// on the wrong side (13 of 47 with this and [`WorldConfig::side_min_sigmas`]:
    /// docs/benchmarks.md, "The yaw side").
    pub side_max_range_sd_fraction: f32,
    /// Whatever told the side, it is reported unresolved where the two yaw candidates' noses
    /// lie within this many of their angle sigmas (`pitch_sd_deg` and `yaw_sd_deg` together)
    /// of each other ([`side_within_reach`]): a body crossing near 90 deg, whose nose lies so
    /// near the image plane that the measurement does not tell on which side.
    pub side_min_sigmas: f32,
    /// ... unless a range sensor placed the positions and the velocity lies farther than this
    /// from the image plane, deg: a projectile's nose lies within its angle of attack of the
    /// velocity, so it is then on the velocity's side whatever its measured aspect.
    pub side_clear_velocity_deg: f64,
    /// The velocity predicted for a frame from the positions before it tells the silhouette
    /// stage which end is the nose ([`Flight::in_chip`]) where it lies at least this far across
    /// the line of sight (the sine of its angle to it): its image then points within a few
    /// degrees of the body's axis, however the body's ends look (a plume of the body's own
    /// polarity tapers like a nose).
    pub min_flight_across: f64,
    /// A projectile in stable flight keeps its nose within a few degrees of its velocity: a
    /// frame whose measured angle of attack exceeds this, deg, beyond the reach of its own
    /// sigmas, where the velocity is sure (the side's rule: a sensor's range, or
    /// [`WorldConfig::side_max_range_sd_fraction`]), has its attitude off by about the excess,
    /// and its pitch and yaw sigmas are at least the excess ([`attitude_sd_floor_deg`]). On 18
    /// simulated clutter clips with their range, the frames more than two sigmas off had a
    /// median angle of attack of 39 deg, the others 3.3.
    pub max_aoa_deg: f64,
}

impl WorldConfig {
    /// The defaults.
    pub const DEFAULT: WorldConfig = WorldConfig {
        max_span_s: 2.5,
        max_gap_s: 1.0,
        side_margin_deg: 1.0,
        side_max_range_sd_fraction: 0.02,
        side_min_sigmas: 2.0,
        side_clear_velocity_deg: 3.0,
        min_flight_across: 0.5,
        max_aoa_deg: 5.0,
    };

    /// Whether a frame at `time_s` continues the flight whose last position was at `last_s`
    /// (s): after it, by at most `max_gap_s`.
    fn continues(&self, last_s: f64, time_s: f64) -> bool {
        time_s > last_s && time_s - last_s <= self.max_gap_s
    }
}

impl Default for WorldConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// One frame in the world frame: its pose and, where the velocity is known, its angle of attack.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct WorldState {
    /// The pose in E (the chosen yaw candidate's).
    pub pose: WorldPose,
    /// The angle of attack against the velocity fitted to the body origin's recent positions
    /// ([`Motion::velocity_enu_m_s`]).
    pub aoa: Option<AngleOfAttack>,
}

/// How a frame was seen moving: the mount's pointing and the body origin's velocity.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Motion {
    /// Where the mount pointed the camera.
    pub mount: Mount,
    /// The body origin's velocity at the frame, m/s in E: the slope of a least-squares
    /// quadratic in time through its positions of this frame and the ones before it (through
    /// two, gravity's: [`velocity_at`]); None for the first, and wherever one of them had its range from the image
    /// rather than a sensor (a position along the line of sight from the image scatters by
    /// metres: tens of m/s between frames).
    pub velocity_enu_m_s: Option<[f64; 3]>,
}

impl Motion {
    /// The frame of `result` (ok, its range and attitude the chosen candidate's) in E, seen
    /// from `station`.
    pub fn state(&self, result: &FrameResult, station: &Station) -> WorldState {
        let r_ec = self.mount.rotation_camera_to_world();
        let (pose, nose) = WorldPose::with_nose(&result.pose, &r_ec, station);
        WorldState {
            aoa: self
                .velocity_enu_m_s
                .and_then(|v| AngleOfAttack::of(&nose.into(), &v)),
            pose,
        }
    }

    /// How far the velocity lies from the image plane of `result` (the plane across its line of
    /// sight, about which the mirror candidate is mirrored), deg, where it is known.
    pub fn velocity_off_image_plane_deg(&self, result: &FrameResult) -> Option<f64> {
        let velocity = Vector3::from(self.velocity_enu_m_s?);
        let Pose {
            tx_m, ty_m, tz_m, ..
        } = result.pose;
        let sight = self.mount.rotation_camera_to_world()
            * Vector3::new(f64::from(tx_m), f64::from(ty_m), f64::from(tz_m));
        let sine = velocity.dot(&sight) / (velocity.norm() * sight.norm());
        sine.is_finite()
            .then(|| libm::asin(libm::fabs(sine).min(1.0)).to_degrees())
    }

    /// Which yaw candidate of `result` the velocity points out, where it is known: the one
    /// whose nose lies nearer to it, where the candidates' angles of attack differ by more than
    /// `margin_deg`, else [`Side::Either`] (the velocity lies within the angle of attack of the
    /// image plane: the range trend cannot tell either).
    pub fn side(&self, result: &FrameResult, margin_deg: f64) -> Option<Side> {
        let velocity = self.velocity_enu_m_s?;
        let r_ec = self.mount.rotation_camera_to_world();
        let aoa = |pitch_deg: f32, yaw_deg: f32| {
            let nose = nose_in_world(&r_ec, pitch_deg, yaw_deg);
            AngleOfAttack::of(&nose.into(), &velocity).map(|a| a.total_deg)
        };
        let chosen = aoa(result.pose.pitch_deg, result.pose.yaw_deg)?;
        let mirrored = aoa(result.pitch_alt_deg, result.yaw_alt_deg)?;
        Some(if libm::fabs(chosen - mirrored) <= margin_deg {
            Side::Either
        } else if chosen < mirrored {
            Side::Chosen
        } else {
            Side::Mirrored
        })
    }
}

/// One sigma of the nose's direction of `result`, deg: its pitch and yaw sigmas in quadrature
/// (NaN where one is).
fn attitude_sd_deg(result: &FrameResult) -> f32 {
    libm::hypotf(result.pitch_sd_deg, result.yaw_sd_deg)
}

/// Angle sigmas of a frame whose reach its angle of attack must pass beyond
/// [`WorldConfig::max_aoa_deg`] before the frame's attitude counts as failed
/// ([`attitude_sd_floor_deg`]).
const AOA_REACH_SIGMAS: f32 = 2.0;

/// The least one sigma of the pitch and yaw of the frame of `result`, deg, that its angle of
/// attack `aoa` allows. Where the angle exceeds [`WorldConfig::max_aoa_deg`] by more than the
/// reach of two of the frame's own angle sigmas (`pitch_sd_deg` and `yaw_sd_deg` together), the
/// nose is not where the frame measured it (a projectile flies within that angle of its
/// velocity) by at least the excess, which is then the floor; zero otherwise (and where a sigma
/// is NaN).
pub fn attitude_sd_floor_deg(
    aoa: &AngleOfAttack,
    result: &FrameResult,
    config: &WorldConfig,
) -> f32 {
    let excess = aoa.total_deg - config.max_aoa_deg;
    let reach = AOA_REACH_SIGMAS * attitude_sd_deg(result);
    if excess > f64::from(reach) {
        excess as f32
    } else {
        0.0
    }
}

/// Whether the two yaw candidates of `result` lie within `sigmas` of their angle sigmas of each
/// other (half the angle between their noses against `pitch_sd_deg` and `yaw_sd_deg` in
/// quadrature): the nose so near the image plane that its side of it is within the
/// measurement's reach. True too where the sigmas are not finite.
pub fn side_within_reach(result: &FrameResult, sigmas: f32) -> bool {
    let nose = nose_direction(result.pose.pitch_deg, result.pose.yaw_deg);
    let mirrored = nose_direction(result.pitch_alt_deg, result.yaw_alt_deg);
    let half_apart_deg = 0.5 * libm::acosf(nose.dot(&mirrored).clamp(-1.0, 1.0)) * DEG;
    half_apart_deg
        .partial_cmp(&(sigmas * attitude_sd_deg(result)))
        .is_none_or(|order| order.is_le())
}

/// Which yaw candidate the velocity points out ([`Motion::side`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Side {
    /// The chosen candidate's nose lies nearer to the velocity.
    Chosen,
    /// The mirrored candidate's does.
    Mirrored,
    /// Both lie within the margin of each other: the velocity cannot tell.
    Either,
}

/// A position of the body origin at a frame.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Position {
    /// The frame's capture time, s.
    pub time_s: f64,
    /// East, north and up, m.
    pub enu_m: [f64; 3],
    /// True where a range sensor's reading placed it along the line of sight.
    pub range_used: bool,
}

impl Position {
    /// The body origin of the ok `result` at `time_s`, seen from `station` pointed as `mount`.
    pub fn of(time_s: f64, result: &FrameResult, mount: &Mount, station: &Station) -> Position {
        Position {
            time_s,
            enu_m: origin_in_world(&mount.rotation_camera_to_world(), &result.pose, station),
            range_used: result.range_used,
        }
    }
}

/// Standard gravity, m/s²: the acceleration a fit through only two positions is given.
const GRAVITY_M_S2: f64 = 9.80665;

/// The velocity at `at_s`, m/s in E: the slope there of a least-squares quadratic in time
/// through `positions`; through only two, the quadratic term is gravity's (a line would miss the
/// arc's bend: g dt / 2v of angle, 0.3 deg at 0.3 s and 240 m/s). None with fewer than two,
/// where any had its range from the image (its place along the line of sight scatters by
/// metres), or where their times do not determine the fit.
pub fn velocity_at<'a>(
    positions: impl IntoIterator<Item = &'a Position>,
    at_s: f64,
) -> Option<[f64; 3]> {
    // Normal equations of p(t) = a + b tau + c tau^2, tau = t - at_s, per axis.
    let mut normal = Matrix3::<f64>::zeros();
    let mut rhs = Matrix3::<f64>::zeros();
    let mut count = 0;
    let mut first_two = [None; 2];
    for position in positions {
        if !position.range_used {
            return None;
        }
        let tau = position.time_s - at_s;
        let basis = Vector3::new(1.0, tau, tau * tau);
        normal += basis * basis.transpose();
        rhs += basis * Vector3::from(position.enu_m).transpose();
        if let Some(slot) = first_two.get_mut(count) {
            *slot = Some((tau, Vector3::from(position.enu_m)));
        }
        count += 1;
    }
    let velocity = match (count, first_two) {
        (2, [Some((tau0, p0)), Some((tau1, p1))]) => {
            // p = a + b tau - g/2 tau^2 up: the slope of the chord less gravity's share.
            let mut b = (p1 - p0) / (tau1 - tau0);
            b.z += 0.5 * GRAVITY_M_S2 * (tau0 + tau1);
            [b.x, b.y, b.z]
        }
        (3.., _) => {
            let solution = normal.try_inverse()? * rhs;
            [solution[(1, 0)], solution[(1, 1)], solution[(1, 2)]]
        }
        _ => return None,
    };
    velocity.iter().all(|v| v.is_finite()).then_some(velocity)
}

/// A velocity as the camera sees it at one line of sight: the velocity in the camera frame C
/// and the line of sight through a full-frame pixel (C, unit depth).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Flight {
    /// The velocity in C, m/s.
    velocity: Vector3<f64>,
    /// The line of sight, with z = 1.
    sight: Vector3<f64>,
    /// The camera's focal lengths, px.
    focal: (f64, f64),
}

impl Flight {
    /// A body flying with `velocity_enu` (m/s in E) seen by a camera `camera` pointed as `mount`
    /// at the line of sight through the full-frame pixel `at_px`.
    pub fn new(velocity_enu: &[f64; 3], mount: &Mount, camera: &Camera, at_px: ImagePoint) -> Self {
        let velocity = mount.rotation_camera_to_world().transpose() * Vector3::from(*velocity_enu);
        let focal = (f64::from(camera.fx), f64::from(camera.fy));
        let sight = Vector3::new(
            (f64::from(at_px.x) - f64::from(camera.cx)) / focal.0,
            (f64::from(at_px.y) - f64::from(camera.cy)) / focal.1,
            1.0,
        );
        Flight {
            velocity,
            sight,
            focal,
        }
    }

    /// The direction in the chip (unit, chip px axes) in which the body moves across the image;
    /// None where the velocity lies less than `min_across` (the sine of its angle) across the
    /// line of sight, or is no velocity.
    pub fn in_chip(&self, min_across: f64) -> Option<ImagePoint> {
        let (v, sight) = (&self.velocity, &self.sight);
        let speed = v.norm();
        let along = v.dot(sight) / sight.norm_squared();
        let across = (v - sight * along).norm();
        if !(speed.is_finite() && speed > 0.0 && across >= min_across * speed) {
            return None;
        }
        // The image of a point moving along v from depth z: (fx (v.x - x v.z), fy (v.y - y v.z)) / z.
        let du = self.focal.0 * (v.x - sight.x * v.z);
        let dv = self.focal.1 * (v.y - sight.y * v.z);
        let norm = libm::hypot(du, dv);
        (norm > 0.0 && norm.is_finite())
            .then(|| ImagePoint::new((du / norm) as f32, (dv / norm) as f32))
    }

    /// The velocity's angle out of the image plane (to the plane normal to the line of sight),
    /// deg in [0, 90]: the tilt of a body flying along it (a projectile flies within its angle
    /// of attack of it); None where there is no velocity.
    pub fn tilt_deg(&self) -> Option<f32> {
        let sine =
            self.velocity.dot(&self.sight).abs() / (self.velocity.norm() * self.sight.norm());
        (sine.is_finite() && sine <= 1.0).then(|| libm::asin(sine).to_degrees() as f32)
    }
}

/// The world stage's state: the body origin's recent positions, for the velocity.
#[derive(Debug, Clone, Default)]
pub struct WorldStage {
    flight: heapless::Deque<Position, FLIGHT_SAMPLES>,
}

impl WorldStage {
    /// No positions yet.
    pub const fn new() -> Self {
        WorldStage {
            flight: heapless::Deque::new(),
        }
    }

    /// Forgets the positions (a new clip).
    pub fn reset(&mut self) {
        self.flight.clear();
    }

    /// The velocity at `time_s` (s, after the positions taken), m/s in E, from the positions
    /// before it ([`velocity_at`]), where the last is within `config.max_gap_s` and all within
    /// `config.max_span_s` of it.
    pub fn velocity_ahead(&self, time_s: f64, config: &WorldConfig) -> Option<[f64; 3]> {
        let last = self.flight.back()?;
        let fresh = config.continues(last.time_s, time_s);
        let recent = self
            .flight
            .iter()
            .filter(|p| time_s - p.time_s <= config.max_span_s);
        fresh.then(|| velocity_at(recent, time_s)).flatten()
    }

    /// Takes the body origin of the frame at `time_s` (s, after the frames given before) whose
    /// result is `result`, the camera at `station` pointed as `mount`, and returns how the frame
    /// was seen moving; None unless the frame has a pose.
    pub fn motion(
        &mut self,
        time_s: f64,
        result: &FrameResult,
        mount: Mount,
        station: &Station,
        config: &WorldConfig,
    ) -> Option<Motion> {
        if result.status != Status::Ok {
            return None;
        }
        let position = Position::of(time_s, result, &mount, station);
        let stale = self
            .flight
            .back()
            .is_some_and(|last| !config.continues(last.time_s, time_s));
        if stale {
            self.flight.clear();
        }
        while self
            .flight
            .front()
            .is_some_and(|first| time_s - first.time_s > config.max_span_s)
            || self.flight.is_full()
        {
            self.flight.pop_front();
        }
        // Room was made above.
        let _ = self.flight.push_back(position);
        Some(Motion {
            mount,
            velocity_enu_m_s: velocity_at(&self.flight, time_s),
        })
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

    /// By hand (to the f32 trigonometry's precision: 1e-4 deg and m): a camera looking due east
    /// along the horizon sees a nose pointing straight at
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
        assert!((world.nose_az_deg - 270.0).abs() < 1e-4, "{world:?}");
        assert!(world.nose_el_deg.abs() < 1e-4, "{world:?}");
        for (got, want) in world.origin_enu_m.iter().zip([1010.0, 20.0, 30.0]) {
            assert!((got - want).abs() < 1e-4, "{world:?}");
        }
        let up = Pose {
            pitch_deg: 90.0,
            ..towards
        };
        assert!((WorldPose::of(&up, &mount, &station).nose_el_deg - 90.0).abs() < 1e-4);
        // Image +Y is down: a body below the image centre is below the horizon.
        let below = Pose {
            ty_m: 5.0,
            ..towards
        };
        assert!((WorldPose::of(&below, &mount, &station).origin_enu_m[2] - 25.0).abs() < 1e-4);
    }

    /// A level camera looking east (its +x south, +y down), 1000 px focal length, and its
    /// principal point (500, 400).
    fn level_camera_east() -> (Mount, Camera, ImagePoint) {
        let mount = Mount::new_checked(90.0, 0.0).unwrap();
        let camera = Camera {
            fx: 1000.0,
            fy: 1000.0,
            cx: 500.0,
            cy: 400.0,
        };
        (mount, camera, ImagePoint::new(500.0, 400.0))
    }

    /// [`level_camera_east`], by hand: flying north, the body moves left across the image;
    /// climbing, up; north-east at 45 deg to the line of sight, still left; 20 deg off the line
    /// of sight (sin 0.34 < 0.5) or along it, no direction. Off the image centre, a velocity
    /// along the line of sight through that pixel has none either.
    #[test]
    fn the_flight_across_the_image_by_hand() {
        let (mount, camera, centre) = level_camera_east();
        let flight =
            |v: [f64; 3], at: ImagePoint| Flight::new(&v, &mount, &camera, at).in_chip(0.5);
        let close = |got: Option<ImagePoint>, want: (f32, f32)| {
            got.is_some_and(|p| (p.x - want.0).abs() < 1e-5 && (p.y - want.1).abs() < 1e-5)
        };
        assert!(close(flight([0.0, 250.0, 0.0], centre), (-1.0, 0.0)));
        assert!(close(flight([0.0, 0.0, 100.0], centre), (0.0, -1.0)));
        assert!(close(flight([200.0, 200.0, 0.0], centre), (-1.0, 0.0)));
        let (s, c) = (20f64.to_radians().sin(), 20f64.to_radians().cos());
        assert_eq!(flight([c * 250.0, s * 250.0, 0.0], centre), None);
        assert_eq!(flight([250.0, 0.0, 0.0], centre), None);
        // The line of sight through (600, 400): east and 0.1 of it south (camera +x).
        assert_eq!(
            flight([250.0, -25.0, 0.0], ImagePoint::new(600.0, 400.0)),
            None
        );
        assert_eq!(flight([0.0, 0.0, 0.0], centre), None);
    }

    /// The same camera, by hand: flying north, or north and climbing, the velocity lies in the
    /// image plane (tilt 0); east, along the line of sight (90); 20 deg from north towards east,
    /// 20 deg out of the plane; east and a tenth of it south is along the line of sight through
    /// (600, 400) (90 there).
    #[test]
    fn the_flight_tilt_by_hand() {
        let (mount, camera, centre) = level_camera_east();
        let tilt = |v: [f64; 3], at: ImagePoint| Flight::new(&v, &mount, &camera, at).tilt_deg();
        let close = |got: Option<f32>, want: f32| got.is_some_and(|t| (t - want).abs() < 1e-3);
        assert!(close(tilt([0.0, 250.0, 0.0], centre), 0.0));
        assert!(close(tilt([0.0, 200.0, 150.0], centre), 0.0));
        assert!(close(tilt([250.0, 0.0, 0.0], centre), 90.0));
        let (s, c) = (20f64.to_radians().sin(), 20f64.to_radians().cos());
        assert!(close(tilt([s * 250.0, c * 250.0, 0.0], centre), 20.0));
        assert!(close(
            tilt([250.0, -25.0, 0.0], ImagePoint::new(600.0, 400.0)),
            90.0
        ));
        assert_eq!(tilt([0.0, 0.0, 0.0], centre), None);
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
            assert!(gap.abs() < 1e-5, "{az}: {world:?}");
        }
    }

    /// By hand: a body flying due north, level; a nose 2 deg up is 2 deg of angle of attack in
    /// the vertical plane, one 3 deg east of north 3 deg to the right.
    #[test]
    fn the_angle_of_attack_by_hand() {
        let velocity = [0.0, 300.0, 0.0];
        // The unit nose at azimuth `az` (clockwise from north) and elevation `el`, deg.
        let nose = |az: f64, el: f64| {
            let (a, e) = (f64::to_radians(az), f64::to_radians(el));
            [
                libm::sin(a) * libm::cos(e),
                libm::cos(a) * libm::cos(e),
                libm::sin(e),
            ]
        };
        let up = AngleOfAttack::of(&nose(0.0, 2.0), &velocity).unwrap();
        assert!(
            (up.total_deg - 2.0).abs() < 1e-4 && (up.up_deg - 2.0).abs() < 1e-4,
            "{up:?}"
        );
        assert!(up.right_deg.abs() < 1e-4, "{up:?}");
        let right = AngleOfAttack::of(&nose(3.0, 0.0), &velocity).unwrap();
        assert!(
            (right.right_deg - 3.0).abs() < 1e-4 && right.up_deg.abs() < 1e-4,
            "{right:?}"
        );
        let backwards = AngleOfAttack::of(&nose(180.0, 0.0), &velocity).unwrap();
        assert!((backwards.total_deg - 180.0).abs() < 1e-4, "{backwards:?}");
        assert_eq!(AngleOfAttack::of(&nose(0.0, 0.0), &[0.0, 0.0, 0.5]), None);
        assert_eq!(AngleOfAttack::of(&nose(0.0, 0.0), &[0.0, 0.0, 300.0]), None);
        assert_eq!(
            AngleOfAttack::of(&nose(0.0, 0.0), &[f64::NAN, 1.0, 0.0]),
            None
        );
    }

    /// A camera at the origin looking due north, level: its C is (east, -up, north), so a
    /// pose's pitch is the nose's elevation and its yaw the nose's azimuth.
    fn seen_from_the_south(enu: [f64; 3], nose_az_deg: f64, nose_el_deg: f64) -> FrameResult {
        let mut result = FrameResult::failed(Status::Ok);
        result.pose = Pose {
            tx_m: enu[0] as f32,
            ty_m: -enu[2] as f32,
            tz_m: enu[1] as f32,
            pitch_deg: nose_el_deg as f32,
            yaw_deg: nose_az_deg as f32,
        };
        result.range_used = true;
        result
    }

    /// A camera looking north at a body 1 km away: a velocity 10 deg off east towards north
    /// lies 10 deg off the image plane, one due east 0, one due north 90; none without one.
    #[test]
    fn the_velocitys_angle_to_the_image_plane() {
        let mut result = FrameResult::failed(Status::Ok);
        result.pose.tz_m = 1000.0;
        let motion = |velocity_enu_m_s| Motion {
            mount: Mount::new_checked(0.0, 0.0).unwrap(),
            velocity_enu_m_s,
        };
        let (s, c) = libm::sincos(10f64.to_radians());
        for (velocity, off_deg) in [
            ([c, s, 0.0], 10.0),
            ([250.0, 0.0, 0.0], 0.0),
            ([0.0, -3.0, 0.0], 90.0),
        ] {
            let off = motion(Some(velocity))
                .velocity_off_image_plane_deg(&result)
                .unwrap();
            assert!((off - off_deg).abs() < 1e-6, "{velocity:?}: {off}");
        }
        assert_eq!(motion(None).velocity_off_image_plane_deg(&result), None);
    }

    /// A nose 12 deg above a level velocity is 7 deg beyond a 5 deg angle of attack: with angle
    /// sigmas of 1.5 and 2 deg (2 x 2.5 = 5 deg of reach) its attitude sigmas are at least 7
    /// deg; with sigmas of 3 and 2.4 deg (reach 7.7 deg) the excess is within its reach, and a
    /// nose 3 deg off is within 5 deg: no floor.
    #[test]
    fn an_angle_of_attack_beyond_the_flights_sets_the_attitude_sigmas_floor() {
        let velocity = [200.0, 0.0, 0.0];
        let mut result = FrameResult::failed(Status::Ok);
        for (nose_deg, sds, floor_deg) in [
            (12.0f64, (1.5, 2.0), 7.0f32),
            (12.0, (3.0, 2.4), 0.0),
            (3.0, (0.1, 0.1), 0.0),
        ] {
            (result.pitch_sd_deg, result.yaw_sd_deg) = sds;
            let (s, c) = libm::sincos(nose_deg.to_radians());
            let aoa = AngleOfAttack::of(&[c, 0.0, s], &velocity).unwrap();
            let floor = attitude_sd_floor_deg(&aoa, &result, &WorldConfig::DEFAULT);
            assert!(
                (floor - floor_deg).abs() < 1e-4,
                "{nose_deg} {sds:?}: {floor}"
            );
        }
    }

    /// Mirror candidates 2 x 5 deg apart in yaw (a nose 5 deg off the image plane): within
    /// reach of the measurement at a 2.6 deg sigma and two of them (5 <= 5.2), out of reach at
    /// 2.4 deg (5 > 4.8); 2 x 5 deg apart in pitch alike, the two sigmas in quadrature; with a
    /// NaN sigma, within reach.
    #[test]
    fn candidates_near_the_image_plane_are_within_the_measurements_reach() {
        let mut result = FrameResult::failed(Status::Ok);
        (result.pose.yaw_deg, result.yaw_alt_deg) = (95.0, 85.0);
        for (sd, within) in [(2.6, true), (2.4, false), (f32::NAN, true)] {
            (result.pitch_sd_deg, result.yaw_sd_deg) = (0.0, sd);
            assert_eq!(side_within_reach(&result, 2.0), within, "sd {sd}");
        }
        // The same apart in pitch, nose and mirror seen from above; the two sigmas together.
        (result.pose.yaw_deg, result.yaw_alt_deg) = (90.0, 90.0);
        (result.pose.pitch_deg, result.pitch_alt_deg) = (5.0, -5.0);
        (result.pitch_sd_deg, result.yaw_sd_deg) = (1.6, 2.0);
        assert!(side_within_reach(&result, 2.0));
        (result.pitch_sd_deg, result.yaw_sd_deg) = (1.2, 2.0);
        assert!(!side_within_reach(&result, 2.0));
    }

    /// A ballistic arc (no drag, standard gravity) seen every 0.5 s with the nose along its
    /// velocity: from the second frame on the fit's velocity is exact (through two positions
    /// with gravity's bend, then the quadratic) and the angle of attack zero; a frame whose
    /// range came from the image gives none, nor does the frame after a gap. The velocity tells
    /// the nose from its mirror image (here the arc crosses the line of sight at 40 deg).
    #[test]
    fn a_ballistic_arc_flown_nose_first_has_no_angle_of_attack() {
        let mount = Mount::new_checked(0.0, 0.0).unwrap();
        let station = Station::default();
        let config = WorldConfig::DEFAULT;
        let mut stage = WorldStage::new();
        let (p0, v0, g) = ([-200.0, 1500.0, 300.0], [150.0, 60.0, 120.0], GRAVITY_M_S2);
        let at = |t: f64| {
            let enu = [
                p0[0] + v0[0] * t,
                p0[1] + v0[1] * t,
                p0[2] + v0[2] * t - 0.5 * g * t * t,
            ];
            let v = [v0[0], v0[1], v0[2] - g * t];
            let horizontal = libm::sqrt(v[0] * v[0] + v[1] * v[1]);
            let az = libm::atan2(v[0], v[1]).to_degrees();
            let el = libm::atan2(v[2], horizontal).to_degrees();
            let mut result = seen_from_the_south(enu, az, el);
            // The mirrored candidate: the nose's component along the line of sight (+north)
            // turned over, as a silhouette cannot tell.
            let (pitch, yaw) = (result.pose.pitch_deg, result.pose.yaw_deg);
            (result.pitch_alt_deg, result.yaw_alt_deg) = (pitch, 180.0 - yaw);
            result
        };
        for k in 0..8 {
            let t = 0.5 * f64::from(k);
            let result = at(t);
            let motion = stage.motion(t, &result, mount, &station, &config).unwrap();
            let aoa = motion.state(&result, &station).aoa;
            let side = motion.side(&result, config.side_margin_deg);
            match k {
                0 => assert_eq!((aoa, side), (None, None)),
                _ => {
                    let aoa = aoa.unwrap().total_deg;
                    assert!(aoa < 2e-3, "frame {k}: {aoa}");
                    assert_eq!(side, Some(Side::Chosen));
                    let mut mirrored = result;
                    core::mem::swap(&mut mirrored.pose.yaw_deg, &mut mirrored.yaw_alt_deg);
                    assert_eq!(motion.side(&mirrored, 1.0), Some(Side::Mirrored));
                    // A margin wider than the candidates' difference: either.
                    assert_eq!(motion.side(&result, 179.0), Some(Side::Either));
                }
            }
        }
        let mut unranged = at(4.0);
        unranged.range_used = false;
        let motion = stage.motion(4.0, &unranged, mount, &station, &config);
        assert_eq!(motion.unwrap().velocity_enu_m_s, None);
        let motion = stage.motion(5.5, &at(5.5), mount, &station, &config);
        assert_eq!(motion.unwrap().velocity_enu_m_s, None);
        let failed = FrameResult::failed(Status::NoTarget);
        assert_eq!(stage.motion(6.0, &failed, mount, &station, &config), None);
    }
}
