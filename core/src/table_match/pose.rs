//! One table match: from the closed-form hypothesis to the pose of the best-matching entry.
//!
//! 1. [`super::section`]: the cylindrical stretch's cross-section with Lambertian shading gives
//!    the section's mean contrast (and an unbiased diameter);
//! 2. the contrast summed across the axis per bin, over that mean contrast, is the silhouette's
//!    width profile along the whole body, nose, fins and base included;
//! 3. [`super::search`]: the table's entries are fitted to that profile: tilt, roll (folded),
//!    and the body origin along the axis, at the scale of the range (or of the shaded diameter);
//! 4. the pose follows from the matched ends and scale ([`closed_form::from_ends`]).

use super::MatchConfig;
use super::search::{self, Fit, Match, Measured};
use super::section::{self, LambertSection};
use crate::camera::Camera;
use crate::chip::ChipView;
use crate::closed_form::{self, ClosedForm};
use crate::config::BodyPolarity;
use crate::extremes::axial_profile::WidthProfile;
use crate::extremes::cross_profile::{self, DiameterBounds, Stretch};
use crate::extremes::{Axis, Silhouette};
use crate::lut::render::{Placement, View};
use crate::lut::table::Table;
use crate::model::ProjectileModel;
use crate::point::ImagePoint;
use crate::pose::RAD;
use crate::segment::background::Background;
use crate::segment::select::Shape;

/// Why the table match gave no pose.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MatchError {
    /// The cylindrical stretch is too short or its section could not be fitted.
    NoSection,
    /// No entry fitted the profile.
    NoMatch,
    /// The matched scale gives no finite range.
    NoRange,
}

/// What the table match measured.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MatchedPose {
    /// The refined pose (both yaw candidates) at `range_m`.
    pub solution: ClosedForm,
    /// Slant range: the given one, or the one of the matched scale, m.
    pub range_m: f32,
    /// The best entry.
    pub matched: Match,
    /// The cylinder's shaded cross-section.
    pub section: LambertSection,
    /// The matched silhouette's attitude.
    pub view: View,
    /// Where the matched entry's silhouette lies on the chip (px per body diameter).
    pub placement: Placement,
    /// The projected nose tip and tail base, full-frame px.
    pub ends: [ImagePoint; 2],
}

/// One frame's measurements, as the table match needs them.
pub struct MatchInput<'a> {
    /// The chip.
    pub chip: &'a ChipView<'a>,
    /// Its sky model.
    pub background: &'a Background,
    /// The silhouette measured by [`crate::extremes`].
    pub silhouette: &'a Silhouette,
    /// The body's contrast polarity against the sky.
    pub polarity: BodyPolarity,
    /// Full-frame pixel of the chip's top-left.
    pub origin: (i32, i32),
}

/// Where a match's scale comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MatchScale {
    /// The range is known (a sensor's, or the flight's held one), m.
    Range(f32),
    /// The range is not known, and the scale is held at this many px a body diameter: the
    /// shape-guided loop's re-match, at its first match's scale.
    Held(f32),
    /// The range is not known: the scale is the shaded section's diameter.
    Free,
}

/// Matches `table` to the frame, starting from the closed-form `closed`, at `scale`.
pub fn match_pose(
    frame: &MatchInput,
    table: &Table,
    model: &ProjectileModel,
    camera: &Camera,
    closed: &ClosedForm,
    scale: MatchScale,
    config: &MatchConfig,
) -> Result<MatchedPose, MatchError> {
    let sil = frame.silhouette;
    let range_m = match scale {
        MatchScale::Range(r) => Some(r),
        MatchScale::Held(_) | MatchScale::Free => None,
    };
    let section = cylinder_section(frame, model, config, range_m.is_none())?;
    let axis = sil.axis;
    let sigma = section.sigma_px;
    let across = axis.dir.perpendicular().into();
    let d_px = section.diameter_px;
    let reach = libm::fabsf(sil.nose_t).max(libm::fabsf(sil.tail_t)) + 4.0 * sigma + 6.0;
    let band = 0.5 * d_px * model.max_radius_m() / model.radius_m() + 3.0 * sigma + 1.5;
    let profile = WidthProfile::build(
        frame.chip,
        frame.background,
        &axis,
        frame.polarity,
        section.mean_contrast,
        reach,
        band,
    );
    let margin = 3.0 * sigma + 3.0;
    let aspect = closed.aspect_deg * RAD;
    let px_per_m = d_px / model.diameter_m;
    let ends_t =
        closed_form::corrected_ends(sil, model, libm::sinf(aspect), libm::cosf(aspect), px_per_m);
    let measured = Measured {
        profile: &profile,
        // Where a plume blurs into the tail, the profile is matched from inside its reach; the
        // tail's place comes from the silhouette's plume-aware edge (`ends_t`).
        bins: (
            profile.bin_of(if sil.plume_at_tail {
                sil.tail_t + margin
            } else {
                sil.tail_t - margin
            }),
            (profile.bin_of(sil.nose_t + margin) + 1).min(profile.len()),
        ),
        // The profile's linear split between bins adds a 1-px triangle: variance 1/6.
        sigma_px: libm::sqrtf(sigma * sigma + 1.0 / 6.0),
        ends_t,
        end_weight: config.end_weight,
        half_length_d: 0.5 * model.length_m / model.diameter_m,
        max_roll_deg: model.distinct_roll_deg(),
    };
    // The scale: the range's where it is known, the held one, else the shaded section's
    // diameter (the width profile's own scale leans on the fins' unknown contrast and came out
    // 1-3 % low).
    let px_per_d = match scale {
        MatchScale::Range(r) => {
            model.diameter_m / (r * camera.normalized_length(1.0, across)).max(f32::MIN_POSITIVE)
        }
        MatchScale::Held(px_per_d) => px_per_d,
        MatchScale::Free => d_px,
    };
    let start = Fit {
        px_per_d,
        origin_t: 0.5 * (sil.nose_t + sil.tail_t),
        cost: 0.0,
    };
    let matched = search::search(table, &measured, 90.0 - closed.aspect_deg, start)
        .ok_or(MatchError::NoMatch)?;
    let range = match range_m {
        Some(r) => r,
        None => model.diameter_m / camera.normalized_length(matched.px_per_d, across),
    };
    if !(range.is_finite() && range > 0.0) {
        return Err(MatchError::NoRange);
    }
    let ends = matched_ends(&axis, &matched, model, frame.origin);
    Ok(MatchedPose {
        solution: closed_form::from_ends(ends[0], ends[1], camera, model.length_m, range),
        range_m: range,
        matched,
        section,
        view: View {
            tilt_deg: matched.tilt_deg,
            roll_deg: matched.roll_deg,
        },
        placement: Placement {
            origin: axis.point(matched.origin_t),
            dir: axis.dir,
            px_per_unit: matched.px_per_d,
        },
        ends,
    })
}

impl MatchedPose {
    /// The same match at another slant range (the smoothed one of the temporal stage).
    pub fn at_range(&self, camera: &Camera, model: &ProjectileModel, range_m: f32) -> ClosedForm {
        let [nose, tail] = self.ends;
        closed_form::from_ends(nose, tail, camera, model.length_m, range_m)
    }
}

/// The nose tip and tail base of the matched silhouette, full-frame px.
fn matched_ends(
    axis: &Axis,
    matched: &Match,
    model: &ProjectileModel,
    origin: (i32, i32),
) -> [ImagePoint; 2] {
    let half = 0.5 * model.length_m / model.diameter_m
        * libm::cosf(matched.tilt_deg * RAD)
        * matched.px_per_d;
    let o = ImagePoint::of_pixel(origin);
    let at = |t: f32| o + axis.point(t);
    [at(matched.origin_t + half), at(matched.origin_t - half)]
}

/// The shaded cross-section of the cylinder between the nose shoulder and the fins; where the
/// model's cylinder is too short to measure (a tapered body), of its wide stretch instead
/// ([`ProjectileModel::wide_s`]), with the diameter scaled from the stretch's mean radius to the
/// full one. `unranged`: the frame has no range (the sensor's or the flight's): on a cluttered
/// sky the diameter is then held near the silhouette's
/// ([`MatchConfig::clutter_diameter_tolerance`]).
fn cylinder_section(
    frame: &MatchInput,
    model: &ProjectileModel,
    config: &MatchConfig,
    unranged: bool,
) -> Result<LambertSection, MatchError> {
    let sil = frame.silhouette;
    let length = sil.nose_t - sil.tail_t;
    let margin = config.cylinder_margin;
    let l = model.length_m;
    // The stretch (m aft of the tip, inside the margins) and where it lies along the axis.
    let within = |(start_s, end_s): (f32, f32)| {
        let (s0, s1) = (start_s + margin * l, end_s - margin * l);
        let t0 = sil.tail_t + length * (l - s1) / l;
        let t1 = sil.nose_t - length * s0 / l;
        (t1 - t0 >= config.min_cylinder_px).then_some((s0, s1, t0, t1))
    };
    let (s0, s1, t0, t1) = within(model.cylinder_s())
        .or_else(|| within(model.wide_s()))
        .ok_or(MatchError::NoSection)?;
    let shape = Shape {
        centre: sil.axis.centre,
        axis: sil.axis.dir,
        major_sd: 0.0,
        minor_sd: 0.0,
    };
    let half_width = 0.5 * sil.diameter_px + 4.0 * sil.sigma_px + 2.0;
    let binned = cross_profile::bin(
        frame.chip,
        frame.background,
        &shape,
        frame.polarity,
        Stretch { t0, t1 },
        half_width,
        config.section_bin_px,
    );
    let bounds = (unranged && frame.background.follows_corridor())
        .then(|| DiameterBounds::around(sil.diameter_px, config.clutter_diameter_tolerance));
    let start = cross_profile::fit_binned(&binned, bounds).ok_or(MatchError::NoSection)?;
    let mut section = section::fit(&binned, &start, bounds).ok_or(MatchError::NoSection)?;
    section.diameter_px = model
        .full_diameter(section.diameter_px, s0, s1)
        .ok_or(MatchError::NoSection)?;
    Ok(section)
}
