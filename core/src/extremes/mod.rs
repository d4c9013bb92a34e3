//! The silhouette stage: the body's axis, nose tip, tail edge and diameter, subpixel.
//!
//! 1. The cross-section of the cylindrical body is fitted on two stretches either side of the
//!    centre ([`cross_profile`]): diameter, contrast and blur, and, from the two stretches'
//!    offsets, the axis line corrected for the mask's moment errors.
//! 2. The width profile along that axis ([`axial_profile`]) gives the ends; which one is the
//!    nose, the profile compared with the model's both ways round tells ([`orientation`]). The
//!    nose tip is where a line fitted to the tapering width reaches zero; the tail edge
//!    is where the width falls to half its plateau.

pub mod axial_profile;
pub mod cross_profile;
pub mod orientation;

use crate::chip::ChipView;
use crate::model::ProjectileModel;
use crate::point::ImagePoint;
use crate::segment::Target;
use crate::segment::background::Background;
use axial_profile::WidthProfile;
use cross_profile::{CrossSection, DiameterBounds, Stretch};

/// The silhouette stage's tunables.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SilhouetteConfig {
    /// Half the body's length in standard deviations of the mask along its axis (a uniform bar's
    /// is sqrt 3): the cross-section is fitted over half of it either side of the centre.
    pub half_length_sds: f32,
    /// The cross-section reaches this many standard deviations of the mask across its axis ...
    pub section_reach_sds: f32,
    /// ... plus this many px.
    pub section_reach_px: f32,
    /// Width fractions of the body diameter between which the nose ramp is fitted.
    pub nose_ramp: (f32, f32),
    /// The body's ends: where the width falls below this fraction of the diameter.
    pub end_level: f32,
    /// Gaps in the width profile shorter than this fraction of the half-length are crossed (a
    /// broken silhouette).
    pub max_gap: f32,
    /// The tail's plateau width is the mean over this stretch inside the tail edge, in fractions
    /// of the length; the tail edge is where the width falls to half of it.
    pub plateau_window: (f32, f32),
    /// Below this difference between the width profile's misfit to the model with the nose at
    /// one end and at the other ([`orientation`]), in diameters squared, the nose is the end
    /// nearest the recent frames' nose direction.
    pub min_nose_evidence: f32,
    /// An opposite-polarity plume of at least this area, in body diameters squared, at one end
    /// and ...
    pub min_plume_area: f32,
    /// ... at least this many times the other end's marks its end as the tail
    /// ([`orientation::plume_at_high`]).
    pub plume_dominance: f32,
    /// Where the body's diameter is expected (from the range), the cross-sections' fitted
    /// diameter stays within this factor of the body's narrowest and widest diameter over the
    /// middle of its length.
    pub diameter_tolerance: f32,
}

impl SilhouetteConfig {
    /// The defaults.
    pub const DEFAULT: SilhouetteConfig = SilhouetteConfig {
        half_length_sds: 1.732,
        section_reach_sds: 3.0,
        section_reach_px: 3.0,
        nose_ramp: (0.2, 0.65),
        end_level: 0.15,
        max_gap: 0.25,
        plateau_window: (0.03, 0.08),
        min_nose_evidence: 0.002,
        min_plume_area: 0.25,
        plume_dominance: 4.0,
        diameter_tolerance: 1.3,
    };
}

impl Default for SilhouetteConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// A line in the chip: a point and a unit direction.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Axis {
    /// A point on the axis, chip px.
    pub centre: ImagePoint,
    /// Unit direction.
    pub dir: ImagePoint,
}

impl Axis {
    /// Signed distances of a chip point along and across the axis, px.
    pub fn local(&self, x: f32, y: f32) -> (f32, f32) {
        let (dx, dy) = (x - self.centre.x, y - self.centre.y);
        (
            dx * self.dir.x + dy * self.dir.y,
            -dx * self.dir.y + dy * self.dir.x,
        )
    }

    /// The chip point `t` px along the axis from its centre.
    pub fn point(&self, t: f32) -> ImagePoint {
        self.centre + self.dir * t
    }
}

/// The columns `x_range` (`start..end`) of row `y`, narrowed to those whose signed distances
/// along and across the line through `centre` with unit direction `dir` may lie within `along`
/// (`min, max`) and within `across` of it, px: a superset by a pixel either side, so that a
/// per-pixel test over the span selects the same pixels as over the whole range, without
/// visiting the rest of a slanted stretch's bounding box.
pub fn row_span(
    centre: ImagePoint,
    dir: ImagePoint,
    y: usize,
    along: (f32, f32),
    across: f32,
    x_range: (usize, usize),
) -> (usize, usize) {
    let dy = y as f32 - centre.y;
    let (mut lo, mut hi) = (x_range.0 as f32, x_range.1 as f32);
    // Distance = slope (x - centre.x) + offset, within min..max.
    for (slope, offset, min, max) in [
        (dir.x, dy * dir.y, along.0, along.1),
        (-dir.y, dy * dir.x, -across, across),
    ] {
        if slope.is_nan() || libm::fabsf(slope) < 1e-3 {
            continue; // nearly constant along the row (or NaN): no narrowing
        }
        let a = (min - offset) / slope + centre.x;
        let b = (max - offset) / slope + centre.x;
        let (a, b) = if a <= b { (a, b) } else { (b, a) };
        if a <= b {
            lo = lo.max(a - 1.0);
            hi = hi.min(b + 2.0);
        }
    }
    if lo >= hi {
        return (x_range.0, x_range.0);
    }
    ((lo as usize).max(x_range.0), (hi as usize).min(x_range.1))
}

/// Image measurements of the silhouette.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Silhouette {
    /// The body axis, directed from the tail towards the nose.
    pub axis: Axis,
    /// Nose tip, extrapolated from the tapering width (not yet corrected for the ogive's
    /// curvature: see `nose_ramp_offset_m`), px along `axis`.
    pub nose_t: f32,
    /// How far the model's true nose tip lies beyond the zero of a line fitted to its width
    /// between the fractions [`SilhouetteConfig::nose_ramp`] of the diameter (the ogive's
    /// curvature), m along the body ([`ProjectileModel::nose_ramp_zero_offset_m`]).
    pub nose_ramp_offset_m: f32,
    /// Tail edge, where the width falls to half its plateau, px along `axis`.
    pub tail_t: f32,
    /// Body diameter across the axis, px.
    pub diameter_px: f32,
    /// Body contrast against the sky (positive), grey levels.
    pub contrast: f32,
    /// Blur standard deviation, px.
    pub sigma_px: f32,
    /// How much better the width profile fits the model with the nose where it was put than the
    /// other way round, in diameters squared (0: no evidence; [`orientation`]).
    pub nose_evidence: f32,
    /// True where a plume of the opposite polarity lies beyond the tail: it blurs into the
    /// tail's edge, which `tail_t` allows for and the width profile there does not.
    pub plume_at_tail: bool,
}

/// Where along the body (fractions of its length from the tip) the cross-sections may be
/// fitted: the middle of the mask, with room for a mask shorter than the body.
const MIDDLE: (f32, f32) = (0.15, 0.85);

/// What the silhouette stage knows of the body before it looks.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Prior {
    /// The nose direction of recent frames (used only when the shape itself does not tell nose
    /// from tail).
    pub nose_dir: Option<ImagePoint>,
    /// The body's diameter expected from the range, px.
    pub diameter_px: Option<f32>,
}

/// Why the silhouette could not be measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ExtremesError {
    /// The cross-section fit found no body.
    NoCrossSection,
    /// The width profile has no recognisable ends.
    NoEnds,
}

/// Measures the silhouette of `target`, with what is known of it beforehand (`prior`): the
/// expected diameter bounds the cross-sections' ([`SilhouetteConfig::diameter_tolerance`]).
pub fn measure(
    chip: &ChipView,
    background: &Background,
    target: &Target,
    model: &ProjectileModel,
    prior: &Prior,
    config: &SilhouetteConfig,
) -> Result<Silhouette, ExtremesError> {
    let prior_dir = prior.nose_dir;
    // The cross-sections are fitted over the middle of the body, where a tapered body (a
    // mortar round, a shell's ogive) is narrower than its full diameter.
    let (narrowest, widest) =
        model.radius_extremes_m(MIDDLE.0 * model.length_m, MIDDLE.1 * model.length_m);
    let radius = model.radius_m();
    let bounds = prior.diameter_px.map(|d| DiameterBounds {
        min_px: d * narrowest / radius / config.diameter_tolerance,
        max_px: d * widest / radius * config.diameter_tolerance,
    });
    let shape = &target.shape;
    let half_length = config.half_length_sds * shape.major_sd;
    let half_width = config.section_reach_sds * shape.minor_sd + config.section_reach_px;
    let fit = |t0: f32, t1: f32| {
        cross_profile::fit(
            chip,
            background,
            shape,
            target.polarity,
            Stretch { t0, t1 },
            half_width,
            bounds,
        )
    };
    let back = fit(-0.5 * half_length, 0.0);
    let front = fit(0.0, 0.5 * half_length);
    let axis0 = Axis {
        centre: shape.centre,
        dir: shape.axis,
    };
    let (axis, section) = match (back, front) {
        (Some(b), Some(f)) => (
            corrected_axis(&axis0, &b, &f, 0.5 * half_length),
            average(&b, &f),
        ),
        (Some(s), None) | (None, Some(s)) => (shifted(&axis0, s.offset_px), s),
        (None, None) => return Err(ExtremesError::NoCrossSection),
    };
    let d = section.diameter_px;
    let band = 0.5 * d * model.max_radius_m() / model.radius_m() + 2.0 * section.sigma_px + 1.0;
    let reach = 1.3 * half_length + 4.0 * section.sigma_px + 8.0;
    let profile = WidthProfile::build(
        chip,
        background,
        &axis,
        target.polarity,
        section.contrast,
        reach,
        band,
    );
    let centre_bin = profile.bin_of(0.0);
    // Gaps of up to a quarter of the half-length (a broken silhouette) are crossed.
    let max_gap = (config.max_gap * half_length) as usize + 2;
    let low = profile.body_end(centre_bin, -1, config.end_level * d, max_gap);
    let high = profile.body_end(centre_bin, 1, config.end_level * d, max_gap);
    let lo50 = profile
        .crossing_inward(low, 1, 0.5 * d)
        .ok_or(ExtremesError::NoEnds)?;
    let hi50 = profile
        .crossing_inward(high, -1, 0.5 * d)
        .ok_or(ExtremesError::NoEnds)?;
    let length = hi50 - lo50;
    if length.is_nan() || length <= 0.0 {
        return Err(ExtremesError::NoEnds);
    }
    let evidence = orientation::nose_high_evidence(&profile, lo50, hi50, d, model);
    let plume_high = orientation::plume_at_high(
        &profile,
        lo50,
        hi50,
        d,
        config.min_plume_area,
        config.plume_dominance,
    );
    let nose_high = match plume_high {
        Some(plume_high) => !plume_high,
        None if libm::fabsf(evidence) < config.min_nose_evidence
            && let Some(prior) = prior_dir =>
        {
            axis.dir.dot(prior) >= 0.0
        }
        None => evidence >= 0.0,
    };
    let (nose_outer, nose_inward, nose50, tail_outer, tail_inward, tail50) = if nose_high {
        (high, -1isize, hi50, low, 1isize, lo50)
    } else {
        (low, 1isize, lo50, high, -1isize, hi50)
    };
    let (ramp_low, ramp_high) = config.nose_ramp;
    let nose_t = profile
        .ramp_zero(nose_outer, nose_inward, ramp_low * d, ramp_high * d)
        .unwrap_or(nose50);
    // The tail plateau just inside the tail edge, then its half-level crossing.
    let inward = tail_inward as f32;
    let (near, far) = config.plateau_window;
    let plateau = profile.mean_between(
        tail50 + inward * near * length,
        tail50 + inward * far * length,
    );
    // A plume of the opposite polarity over the tail blurs into the body's edge: the edge is
    // where the whole contrast is halfway between the body's plateau and the plume's level just
    // beyond it, found walking in from there.
    let plume_at_tail = plume_high.is_some_and(|high| high != nose_high);
    let tail_t = if plume_at_tail {
        let beyond = |f: f32| tail50 - inward * f * length;
        let plume_level = profile
            .signed_mean_between(beyond(near), beyond(far))
            .min(0.0);
        profile.signed_crossing_inward(
            profile.bin_of(beyond(far)),
            tail_inward,
            0.5 * (plateau + plume_level),
        )
    } else {
        profile.crossing_inward(tail_outer, tail_inward, 0.5 * plateau)
    }
    .unwrap_or(tail50);
    // Express along an axis directed from the tail to the nose.
    let (axis, nose_t, tail_t) = if nose_high {
        (axis, nose_t, tail_t)
    } else {
        (
            Axis {
                centre: axis.centre,
                dir: -axis.dir,
            },
            -nose_t,
            -tail_t,
        )
    };
    // The cross-sections were fitted over the middle of the mask, +-half_length/2 about its
    // centre: m aft of the tip, where the radius may be short of the full one (a tapered body).
    let s_of = |t: f32| (nose_t - t) / (nose_t - tail_t) * model.length_m;
    let fitted_s = (s_of(0.5 * half_length), s_of(-0.5 * half_length));
    Ok(Silhouette {
        axis,
        nose_t,
        nose_ramp_offset_m: model.nose_ramp_zero_offset_m(ramp_low, ramp_high),
        tail_t,
        diameter_px: model.full_diameter(d, fitted_s.0, fitted_s.1).unwrap_or(d),
        contrast: section.contrast,
        sigma_px: section.sigma_px,
        nose_evidence: libm::fabsf(evidence),
        plume_at_tail,
    })
}

/// The axis through the two stretches' fitted centres (at -`lever`/2 and +`lever`/2 along it).
fn corrected_axis(axis: &Axis, back: &CrossSection, front: &CrossSection, lever: f32) -> Axis {
    let turn = libm::atanf((front.offset_px - back.offset_px) / lever.max(1.0));
    let (s, c) = libm::sincosf(turn);
    let dir = ImagePoint::new(
        axis.dir.x * c - axis.dir.y * s,
        axis.dir.x * s + axis.dir.y * c,
    );
    let shifted = shifted(axis, 0.5 * (back.offset_px + front.offset_px));
    Axis {
        centre: shifted.centre,
        dir,
    }
}

/// The axis moved `offset` px across itself.
fn shifted(axis: &Axis, offset: f32) -> Axis {
    Axis {
        centre: ImagePoint::new(
            axis.centre.x - offset * axis.dir.y,
            axis.centre.y + offset * axis.dir.x,
        ),
        dir: axis.dir,
    }
}

/// The pixel-weighted mean of two cross-sections.
fn average(a: &CrossSection, b: &CrossSection) -> CrossSection {
    let (wa, wb) = (a.pixels as f32, b.pixels as f32);
    let mean = |x: f32, y: f32| (x * wa + y * wb) / (wa + wb).max(1.0);
    CrossSection {
        diameter_px: mean(a.diameter_px, b.diameter_px),
        contrast: mean(a.contrast, b.contrast),
        shading: mean(a.shading, b.shading),
        sigma_px: mean(a.sigma_px, b.sigma_px),
        offset_px: mean(a.offset_px, b.offset_px),
        pixels: a.pixels + b.pixels,
    }
}
