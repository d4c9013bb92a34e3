//! One frame's input to the pipeline, what became of it, and its result with the contract that
//! every result keeps.

use crate::chip::ChipView;
use crate::extremes::Silhouette;
use crate::pose::Pose;
use crate::segment::{CapacityKind, SegmentError, TrackUse};
use crate::table_match::search::Match;
use crate::world::{Mount, WorldState};

/// One frame's input.
#[derive(Debug, Clone, Copy)]
pub struct FrameInput<'a> {
    /// The chip.
    pub chip: ChipView<'a>,
    /// Capture time, s (arbitrary origin; must increase from frame to frame).
    pub time_s: f64,
    /// Slant range to the body origin from a range sensor, m, where there is one.
    pub range_m: Option<f32>,
    /// Where the tracking mount pointed the camera, where it says: the result is then stated
    /// in the world frame too ([`FrameResult::world`]).
    pub mount: Option<Mount>,
}

/// What became of a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Status {
    /// A pose was estimated.
    Ok,
    /// No target in the chip.
    NoTarget,
    /// A fixed capacity ran out (which one is in [`FrameResult::capacity`]).
    Capacity,
    /// The input is unusable (invalid camera, non-finite or non-positive range, ...).
    BadInput,
    /// A target was found but its silhouette could not be measured.
    Unmeasurable,
}

impl Status {
    /// The status as written in imade-results/1.
    pub fn as_str(&self) -> &'static str {
        match self {
            Status::Ok => "ok",
            Status::NoTarget => "no_target",
            Status::Capacity => "capacity",
            Status::BadInput => "bad_input",
            Status::Unmeasurable => "unmeasurable",
        }
    }
}

/// Why a frame gave no pose.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameError {
    /// The input is unusable (invalid camera, non-finite time, non-finite or non-positive range).
    BadInput,
    /// No target in the chip.
    NoTarget,
    /// A fixed capacity ran out.
    Capacity(CapacityKind),
    /// A target was found but its silhouette could not be measured, or reaches the chip's
    /// edge, or no range could be had, or the pose came out non-finite.
    Unmeasurable,
}

impl From<SegmentError> for FrameError {
    fn from(e: SegmentError) -> Self {
        match e {
            SegmentError::NoTarget => FrameError::NoTarget,
            SegmentError::Capacity(kind) => FrameError::Capacity(kind),
            SegmentError::AtEdge => FrameError::Unmeasurable,
        }
    }
}

/// How a [`FrameResult`] breaks its contract ([`FrameResult::check`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ResultFault {
    /// A `Capacity` status without its capacity, or a capacity named with another status.
    Capacity,
    /// An ok result without its silhouette.
    NoSilhouette,
    /// An ok result with a number that is not finite.
    NotFinite,
    /// An ok pose behind the camera (`tz_m` not positive).
    BehindCamera,
    /// A pitch outside [-90, 90] or a yaw outside [-180, 180] deg.
    AngleOutOfRange,
}

/// One frame's result.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FrameResult {
    /// What became of the frame; the other fields are meaningful only when it is `Ok`.
    pub status: Status,
    /// Which capacity ran out, when the status is `Capacity`.
    pub capacity: Option<CapacityKind>,
    /// The pose with the chosen yaw candidate.
    pub pose: Pose,
    /// Pitch of the mirrored candidate, deg.
    pub pitch_alt_deg: f32,
    /// Yaw of the mirrored candidate, deg.
    pub yaw_alt_deg: f32,
    /// True when the choice between the candidates was resolved by the range trend.
    pub yaw_resolved: bool,
    /// True when a range measurement fixed the distance.
    pub range_used: bool,
    /// Roll, deg, modulo the fins' spacing (90 for four fins) in [0, spacing), where the
    /// grey-level fit measured it within [`crate::uncertainty::UncertaintyConfig::max_roll_sd_deg`].
    pub roll_deg: Option<f32>,
    /// One sigma of `roll_deg`, deg, where it is given.
    pub roll_sd_deg: Option<f32>,
    /// One sigma of `pose.tz_m`, m, where the motion model estimated it (the range from the
    /// image, not a sensor's).
    pub tz_sd_m: Option<f32>,
    /// One sigma of `pose.pitch_deg`, deg.
    pub pitch_sd_deg: f32,
    /// One sigma of `pose.yaw_deg`, deg.
    pub yaw_sd_deg: f32,
    /// Slant range measured from the image (before smoothing), m; 0 where not measured.
    pub image_range_m: f32,
    /// The silhouette's measurements.
    pub silhouette: Option<Silhouette>,
    /// The table match, where a table is loaded and it matched (the pose is then the refined
    /// one; otherwise it is the closed form's).
    pub matched: Option<Match>,
    /// How detection used the track across frames, where a target was found.
    pub track: Option<TrackUse>,
    /// The frame in the world frame, where it has a pose and the mount's pointing.
    pub world: Option<WorldState>,
}

impl FrameResult {
    /// Checks the contract of a result, which the pipeline keeps on any input (the fuzz oracle
    /// and the property tests hold it to it): a `Capacity` status, and only it, names its
    /// capacity; an ok result has its silhouette, every number finite ([`Self::is_finite`]),
    /// the body in front of the camera, and pitches in [-90, 90] and yaws in [-180, 180] deg.
    pub fn check(&self) -> Result<(), ResultFault> {
        if (self.status == Status::Capacity) != self.capacity.is_some() {
            return Err(ResultFault::Capacity);
        }
        if self.status != Status::Ok {
            return Ok(());
        }
        if self.silhouette.is_none() {
            return Err(ResultFault::NoSilhouette);
        }
        if !self.is_finite() {
            return Err(ResultFault::NotFinite);
        }
        if self.pose.tz_m <= 0.0 {
            return Err(ResultFault::BehindCamera);
        }
        let p = &self.pose;
        for (pitch, yaw) in [
            (p.pitch_deg, p.yaw_deg),
            (self.pitch_alt_deg, self.yaw_alt_deg),
        ] {
            if !((-90.0..=90.0).contains(&pitch) && (-180.0..=180.0).contains(&yaw)) {
                return Err(ResultFault::AngleOutOfRange);
            }
        }
        Ok(())
    }

    /// True when every number of the result is finite: pose, mirrored candidate, measurements
    /// and table match.
    pub fn is_finite(&self) -> bool {
        let p = &self.pose;
        let pose = [p.tx_m, p.ty_m, p.tz_m, p.pitch_deg, p.yaw_deg];
        let other = [self.pitch_alt_deg, self.yaw_alt_deg, self.image_range_m];
        let silhouette = self.silhouette.map_or([0.0; 11], |s| {
            [
                s.axis.centre.x,
                s.axis.centre.y,
                s.axis.dir.x,
                s.axis.dir.y,
                s.nose_t,
                s.nose_ramp_offset_m,
                s.tail_t,
                s.diameter_px,
                s.contrast,
                s.sigma_px,
                s.nose_evidence,
            ]
        });
        let matched = self.matched.map_or([0.0; 6], |m| {
            [
                m.tilt_deg,
                m.roll_deg,
                m.roll_confidence,
                m.px_per_d,
                m.origin_t,
                m.rms_px,
            ]
        });
        let uncertain = [
            self.roll_deg.unwrap_or(0.0),
            self.roll_sd_deg.unwrap_or(0.0),
            self.tz_sd_m.unwrap_or(0.0),
            self.pitch_sd_deg,
            self.yaw_sd_deg,
        ];
        [&pose[..], &other, &silhouette, &matched, &uncertain]
            .iter()
            .all(|values| values.iter().all(|v| v.is_finite()))
    }

    /// The result of a frame that gave no pose.
    pub const fn from_error(error: FrameError) -> Self {
        match error {
            FrameError::BadInput => Self::failed(Status::BadInput),
            FrameError::NoTarget => Self::failed(Status::NoTarget),
            FrameError::Capacity(kind) => FrameResult {
                capacity: Some(kind),
                ..Self::failed(Status::Capacity)
            },
            FrameError::Unmeasurable => Self::failed(Status::Unmeasurable),
        }
    }

    /// A result with only a status.
    pub const fn failed(status: Status) -> Self {
        FrameResult {
            status,
            capacity: None,
            pose: Pose {
                tx_m: 0.0,
                ty_m: 0.0,
                tz_m: 0.0,
                pitch_deg: 0.0,
                yaw_deg: 0.0,
            },
            pitch_alt_deg: 0.0,
            yaw_alt_deg: 0.0,
            yaw_resolved: false,
            range_used: false,
            roll_deg: None,
            roll_sd_deg: None,
            tz_sd_m: None,
            pitch_sd_deg: 0.0,
            yaw_sd_deg: 0.0,
            image_range_m: 0.0,
            track: None,
            silhouette: None,
            matched: None,
            world: None,
        }
    }
}
