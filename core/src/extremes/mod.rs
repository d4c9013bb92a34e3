//! The silhouette stage: the body's axis, nose tip, tail edge and diameter, subpixel.
//!
//! 1. The cross-section of the cylindrical body is fitted on two stretches either side of the
//!    centre ([`cross_profile`]): diameter, contrast and blur, and, from the two stretches'
//!    offsets, the axis line corrected for the mask's moment errors.
//! 2. The width profile along that axis ([`axial_profile`]) gives the ends; which one is the
//!    nose, the profile compared with the model's both ways round tells ([`orientation`]). The
//!    nose tip is where a line fitted to the tapering width reaches zero; the tail edge
//!    is where the width falls to half its plateau. Where the range gives the body's size, an
//!    end goes on where more of the body follows (past a gap), also at a lower contrast
//!    ([`follow`]: a cloud behind a faint body).

pub mod axial_profile;
pub mod cross_profile;
pub mod follow;
pub mod orientation;

use crate::chip::ChipView;
use crate::config::BodyPolarity;
use crate::model::ProjectileModel;
use crate::point::ImagePoint;
use crate::segment::background::Background;
use crate::segment::select::Shape;
use crate::segment::{FoundBy, Target};
use axial_profile::WidthProfile;
use cross_profile::{ClutterWidth, CrossSection, DiameterBounds, Stretch};
use follow::{FollowConfig, Follower};
use orientation::FadeBridge;

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
    /// Where the body's size is expected (from the range), a plume beyond a faded stretch of
    /// the body marks its tail ([`orientation::plume_beyond_fade`]); None: not looked for.
    pub fade_bridge: Option<FadeBridge>,
    /// Where the range gives the body's size, a body whose contrast falls beyond an end (the sky
    /// behind it darker) is followed there by its cross-section ([`follow`]); None: not
    /// followed.
    pub follow: Option<FollowConfig>,
    /// Where the body's ends lie this many times farther apart than the detected target is
    /// long, the silhouette is measured again about the axis and extent found.
    pub remeasure_length: f32,
    /// Where the body's diameter is expected (from the range), the cross-sections' fitted
    /// diameter stays within this factor of the body's narrowest and widest diameter over the
    /// middle of its length.
    pub diameter_tolerance: f32,
    /// The width profile sums a band across the axis as wide as the fins' span; where detection
    /// follows the sky beside the body (the tiles' sky is cluttered there:
    /// [`crate::segment::background::Background::follows_corridor`]) and the body's contrast is
    /// at most this many noise sigmas, the band is the body's own width. A sky error of a few
    /// grey levels summed over the fins' band reads as many px of width on a faint body (a
    /// filament beside a 7-px body at 2.6 sigmas: -5 to -15 px of width where the body plainly
    /// shows), more than its few fin pixels are worth.
    pub narrow_band_max_contrast_sigmas: f32,
    /// Where the body's size is not expected (no range) and detection follows the sky beside
    /// the body (it is cluttered there), the cross-sections' diameter stays within
    /// `diameter_tolerance` of the diameter short stretches along the body read
    /// ([`ClutterWidth`]); None: the cross-sections' diameter is free there.
    pub clutter_width: Option<ClutterWidth>,
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
        fade_bridge: Some(FadeBridge {
            onset_diameters: 0.5,
            min_plume_area: 1.0,
            min_fill_diameters: 0.1,
            max_contrast_sigmas: 10.0,
        }),
        follow: Some(FollowConfig::DEFAULT),
        remeasure_length: 1.3,
        diameter_tolerance: 1.3,
        narrow_band_max_contrast_sigmas: 5.0,
        clutter_width: Some(ClutterWidth::DEFAULT),
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

/// The columns of `span` (`start..end`) from the first for which `passes` holds to the last:
/// the same columns as testing each, where the columns that pass form one interval. They do for
/// a test of distances along and across a line that are computed the same way at every column
/// ([`Axis::local`]): those are monotone along a row in f32 too (each rounding is), so each
/// bound on them holds on an interval of columns, and so do several bounds together. Testing
/// from the ends inward leaves the columns between untested: the per-pixel loops over a body's
/// rows then skip the test.
pub fn passing_span(span: (usize, usize), passes: impl Fn(usize) -> bool) -> (usize, usize) {
    let (mut start, mut end) = span;
    while start < end && !passes(start) {
        start += 1;
    }
    while end > start && !passes(end - 1) {
        end -= 1;
    }
    (start, end)
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
    /// The direction in which the body flies across the chip, from the velocity of recent
    /// frames ([`crate::world::Flight::in_chip`]): a projectile flies nose first, so it tells the
    /// nose from the tail before anything in the image does, whatever the ends look like (a
    /// plume of the body's own polarity tapers like a nose; a bright cloud beyond the nose of a
    /// dark body looks like a plume).
    pub flight_dir: Option<ImagePoint>,
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
    let found = Found {
        shape: &target.shape,
        polarity: target.polarity,
        by_bar: target.found_by == FoundBy::Bar,
    };
    let silhouette = measure_on(chip, background, &found, model, prior, config)?;
    // Where detection saw only part of the body (a faint stretch or a filament across it cut it
    // short), the axis fitted over that part is measured again over the body's whole length; not
    // where the ends lie farther apart than the body can look (clutter joined to it).
    let detected = 2.0 * config.half_length_sds * target.shape.major_sd;
    let length = silhouette.nose_t - silhouette.tail_t;
    let longest = longest_px(prior, model, silhouette.sigma_px);
    let part = length > config.remeasure_length * detected;
    if !(part && longest.is_some_and(|l| length <= l)) {
        return Ok(silhouette);
    }
    let whole = Shape {
        centre: silhouette
            .axis
            .point(0.5 * (silhouette.nose_t + silhouette.tail_t)),
        axis: silhouette.axis.dir,
        major_sd: 0.5 * length / config.half_length_sds,
        minor_sd: target.shape.minor_sd,
    };
    let found = Found {
        shape: &whole,
        ..found
    };
    match measure_on(chip, background, &found, model, prior, config) {
        Ok(again) if longest.is_some_and(|l| again.nose_t - again.tail_t <= l) => Ok(again),
        _ => Ok(silhouette),
    }
}

/// The longest the body can look where its size is expected (`prior`), px: its length seen
/// broadside, blurred by `sigma_px` at both ends.
fn longest_px(prior: &Prior, model: &ProjectileModel, sigma_px: f32) -> Option<f32> {
    prior
        .diameter_px
        .map(|d| d * model.length_m / model.diameter_m + 2.0 * sigma_px)
}

/// What detection found of the body: its mask's shape and its polarity.
struct Found<'a> {
    shape: &'a Shape,
    polarity: BodyPolarity,
    /// The shape is a bar's, its direction integrated over the body's length
    /// ([`crate::segment::bar`]).
    by_bar: bool,
}

/// [`measure`] about the found `shape`'s axis and extent.
fn measure_on(
    chip: &ChipView,
    background: &Background,
    found: &Found,
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
    let shape = found.shape;
    let half_length = config.half_length_sds * shape.major_sd;
    let half_width = config.section_reach_sds * shape.minor_sd + config.section_reach_px;
    let bounds = bounds.or_else(|| {
        let clutter = config
            .clutter_width
            .filter(|_| background.follows_corridor())?;
        let d = clutter.diameter_px(
            chip,
            background,
            shape,
            found.polarity,
            half_length,
            half_width,
        )?;
        Some(DiameterBounds::around(d, config.diameter_tolerance))
    });
    let fit = |t0: f32, t1: f32| {
        cross_profile::fit(
            chip,
            background,
            shape,
            found.polarity,
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
        // A bar's direction, from block sums along the whole body, is coarse but holds where
        // the sky beside the body is cluttered (detection then follows its corridor): there two
        // stretches' offsets are pulled by a cloud band or a filament beside them, and only move
        // the bar across.
        (Some(b), Some(f)) if found.by_bar && background.follows_corridor() => (
            shifted(&axis0, 0.5 * (b.offset_px + f.offset_px)),
            average(&b, &f),
        ),
        (Some(b), Some(f)) => (
            corrected_axis(&axis0, &b, &f, 0.5 * half_length),
            average(&b, &f),
        ),
        (Some(s), None) | (None, Some(s)) => (shifted(&axis0, s.offset_px), s),
        (None, None) => return Err(ExtremesError::NoCrossSection),
    };
    let d = section.diameter_px;
    // The band holds the fins' span, but a faint body's where the sky beside it is cluttered
    // (`narrow_band_max_contrast_sigmas`).
    let narrow = background.follows_corridor()
        && section.contrast <= config.narrow_band_max_contrast_sigmas * background.sigma();
    let span = if narrow {
        1.0
    } else {
        model.max_radius_m() / model.radius_m()
    };
    let band = 0.5 * d * span + 2.0 * section.sigma_px + 1.0;
    let reach = 1.3 * half_length + 4.0 * section.sigma_px + 8.0;
    // Where the body's size is expected, the profile reaches as far as the body can from
    // wherever its middle was found, and the ends found walking out go on where more of the body
    // follows (past a filament crossing it, or a stretch where the sky behind it is as dark).
    let longest = longest_px(prior, model, section.sigma_px);
    // Longer by whole px, so that the bins lie where they would without (the nose's ramp is
    // read from a few of them).
    let found_reach = reach;
    let reach = longest.map_or(reach, |l| {
        reach + libm::ceilf(l + 4.0 * section.sigma_px + 8.0 - reach).max(0.0)
    });
    let profile = WidthProfile::build(
        chip,
        background,
        &axis,
        found.polarity,
        section.contrast,
        reach,
        band,
    );
    // Gaps of up to a quarter of the half-length (a broken silhouette) are crossed.
    let max_gap = (config.max_gap * half_length) as usize + 2;
    let floor = config.end_level * d;
    let mut ends = Ends::find(&profile, d, floor, max_gap, found_reach)?;
    if let Some(longest) = longest {
        ends = ends.extended(&profile, d, floor, longest);
        // A stretch where the sky behind is darker reads narrow: followed by its own contrast.
        if let Some(follow) = &config.follow {
            let follower = Follower {
                chip,
                background,
                axis: &axis,
                polarity: found.polarity,
                middle: &section,
                half_width,
                config: follow,
            };
            ends = ends.followed(&profile, &follower, longest);
        }
    }
    let mut plume_high = orientation::plume_at_high(
        &profile,
        ends.lo50,
        ends.hi50,
        d,
        config.min_plume_area,
        config.plume_dominance,
    );
    // A faint body can fade before its tail, its plume beyond.
    if let (None, Some(bridge), Some(longest)) = (plume_high, &config.fade_bridge, longest)
        && let Some((high, onset)) =
            orientation::plume_beyond_fade(&profile, ends.lo50, ends.hi50, d, longest, bridge)
    {
        let outer = profile.bin_of(onset);
        if high {
            (ends.high, ends.hi50) = (outer, onset);
        } else {
            (ends.low, ends.lo50) = (outer, onset);
        }
        plume_high = Some(high);
    }
    // Where the body's size is expected and a plume marks the tail of a faint body, a faded
    // stretch before the plume or a filament beyond the nose is read by the model.
    if let (Some(plume_high), Some(longest), Some(bridge)) =
        (plume_high, longest, &config.fade_bridge)
        && let Some(read) = ends_by_model(
            &profile,
            &ends,
            plume_high,
            &section,
            background.sigma(),
            prior,
            model,
            longest,
            bridge,
            || LocalContrast::new(background, &axis, found.polarity, &section, half_length),
        )
    {
        ends = read;
    }
    let Ends {
        low,
        high,
        lo50,
        hi50,
    } = ends;
    let length = hi50 - lo50;
    let evidence = orientation::nose_high_evidence(&profile, lo50, hi50, d, model);
    let nose_high = match (plume_high, prior.flight_dir) {
        (_, Some(flight)) => axis.dir.dot(flight) >= 0.0,
        (Some(plume_high), None) => !plume_high,
        (None, None)
            if libm::fabsf(evidence) < config.min_nose_evidence
                && let Some(prior) = prior_dir =>
        {
            axis.dir.dot(prior) >= 0.0
        }
        (None, None) => evidence >= 0.0,
    };
    let (nose_outer, nose_inward, nose50, tail_outer, tail_inward, tail50) = if nose_high {
        (high, -1isize, hi50, low, 1isize, lo50)
    } else {
        (low, 1isize, lo50, high, -1isize, hi50)
    };
    let (ramp_low, ramp_high) = config.nose_ramp;
    // The tip lies ahead of the half-width point by at most the model's nose (tip to full
    // diameter) and the blur; a filament along the nose line once put it 330 px beyond a 113-px
    // body.
    let nose_reach_px = model.nose_length_m() / model.diameter_m * d + 2.0 * section.sigma_px;
    let nose_t = profile.nose_tip(
        nose_outer,
        nose_inward,
        (ramp_low * d, ramp_high * d),
        nose50,
        nose_reach_px,
    );
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

/// The ends of a faint body (at most [`FadeBridge::max_contrast_sigmas`] noise sigmas `noise`
/// from the sky) whose tail a plume marks (`plume_high`: at the high end), read again by the
/// model where the found ones cannot be the body's:
/// - where the plume begins beyond the found tail by more than the blur, the stretch between is
///   the body faded (the sky behind it as bright as the body): the tail is where the plume
///   begins;
/// - where the found ends lie farther apart than the body can look (`longest_px`), the nose
///   went on along a filament.
///
/// In either case the nose is where the model's silhouette from the tail best fits the profile
/// ([`orientation::nose_by_model`], at the body's expected diameter and its contrast along the
/// axis, `local()`: made only where the ends are read again). None where neither holds, the
/// body is not faint, or its diameter is not expected.
#[allow(clippy::too_many_arguments)]
fn ends_by_model<'a>(
    profile: &WidthProfile,
    ends: &Ends,
    plume_high: bool,
    section: &CrossSection,
    noise: f32,
    prior: &Prior,
    model: &ProjectileModel,
    longest_px: f32,
    bridge: &FadeBridge,
    local: impl FnOnce() -> LocalContrast<'a>,
) -> Option<Ends> {
    let expected_d = prior.diameter_px?;
    if section.contrast > bridge.max_contrast_sigmas * noise {
        return None;
    }
    let (found_tail, outward) = if plume_high {
        (ends.hi50, 1.0)
    } else {
        (ends.lo50, -1.0)
    };
    let found_length = ends.hi50 - ends.lo50;
    let onset = profile
        .opposite_onset(
            found_tail,
            outward as isize,
            longest_px - found_length,
            bridge.onset_diameters * section.diameter_px,
        )
        .filter(|onset| (onset - found_tail) * outward > 1.0 + 2.0 * section.sigma_px);
    let tail50 = match onset {
        Some(onset) => onset,
        None if found_length > longest_px => found_tail,
        None => return None,
    };
    let local = local();
    let (nose50, tip) = orientation::nose_by_model(
        profile,
        tail50,
        -outward,
        expected_d,
        0.25 * longest_px,
        longest_px,
        0.3 * longest_px,
        model,
        |t| local.at(t),
    )?;
    let tail = profile.bin_of(tail50);
    let nose = profile.bin_of(tip - outward * 2.0 * section.sigma_px);
    Some(if plume_high {
        Ends {
            low: nose,
            high: tail,
            lo50: nose50,
            hi50: tail50,
        }
    } else {
        Ends {
            low: tail,
            high: nose,
            lo50: tail50,
            hi50: nose50,
        }
    })
}

/// The body's contrast along its axis in fractions of the middle's, where the sky model behind
/// it changes and the body's own radiance does not: 1 where the sky is as at the middle, 0 where
/// it is as bright as the body, negative where it is beyond.
struct LocalContrast<'a> {
    background: &'a Background,
    axis: &'a Axis,
    /// The polarity's sign.
    sign: f32,
    /// The sky model's mean at the middle's cross-sections, grey levels.
    middle_sky: f32,
    /// The middle's contrast, grey levels.
    contrast: f32,
}

impl<'a> LocalContrast<'a> {
    fn new(
        background: &'a Background,
        axis: &'a Axis,
        polarity: BodyPolarity,
        section: &CrossSection,
        half_length: f32,
    ) -> Self {
        let mut local = LocalContrast {
            background,
            axis,
            sign: polarity.sign(),
            middle_sky: 0.0,
            contrast: section.contrast.max(f32::EPSILON),
        };
        local.middle_sky = 0.25
            * [-0.375, -0.125, 0.125, 0.375]
                .iter()
                .map(|f| local.sky_at(f * half_length))
                .sum::<f32>();
        local
    }

    /// The sky model at `t` px along the axis, grey levels.
    fn sky_at(&self, t: f32) -> f32 {
        let p = self.axis.point(t);
        self.background.at(p.x, p.y)
    }

    /// At `t` px along the axis, within -0.5 to 2.
    fn at(&self, t: f32) -> f32 {
        (1.0 + self.sign * (self.middle_sky - self.sky_at(t)) / self.contrast).clamp(-0.5, 2.0)
    }
}

/// The body's ends in a width profile: the outermost bins at the end level (`low`, `high`) and
/// the half-diameter crossings inside them (`lo50`, `hi50`, px along the axis).
#[derive(Debug, Clone, Copy)]
struct Ends {
    low: usize,
    high: usize,
    lo50: f32,
    hi50: f32,
}

impl Ends {
    /// The ends of a body `diameter_px` wide, walking out from the profile's middle while the
    /// width stays above `floor` px, crossing gaps shorter than `max_gap` bins, no farther than
    /// `reach` px (what lies beyond, such as terrain joined to the body, is not walked into).
    fn find(
        profile: &WidthProfile,
        diameter_px: f32,
        floor: f32,
        max_gap: usize,
        reach: f32,
    ) -> Result<Ends, ExtremesError> {
        let centre_bin = profile.bin_of(0.0);
        let low = profile
            .body_end(centre_bin, -1, floor, max_gap)
            .max(profile.bin_of(-reach));
        let high = profile
            .body_end(centre_bin, 1, floor, max_gap)
            .min(profile.bin_of(reach));
        let (lo50, hi50) = (
            profile.crossing_inward(low, 1, 0.5 * diameter_px),
            profile.crossing_inward(high, -1, 0.5 * diameter_px),
        );
        let (Some(lo50), Some(hi50)) = (lo50, hi50) else {
            return Err(ExtremesError::NoEnds);
        };
        if (hi50 - lo50).is_nan() || hi50 <= lo50 {
            return Err(ExtremesError::NoEnds);
        }
        Ok(Ends {
            low,
            high,
            lo50,
            hi50,
        })
    }

    /// The ends moved outwards where more of a body `diameter_px` wide follows
    /// ([`WidthProfile::paying_end`]: its width above half the diameter, at most half a
    /// diameter a bin, pays for the gaps), a body no longer than `longest_px`; the outer bins
    /// again where the width stays above `floor` px.
    fn extended(
        self,
        profile: &WidthProfile,
        diameter_px: f32,
        floor: f32,
        longest_px: f32,
    ) -> Ends {
        self.moved_outwards(longest_px, |end, outward, reach| {
            let last = profile.paying_end(end, outward, reach, 0.5 * diameter_px, diameter_px);
            if last == end {
                return None;
            }
            let last_bin = profile.bin_of(last);
            let crossing = profile
                .crossing_from_beyond(last_bin, outward, 0.5 * diameter_px)
                .unwrap_or(last);
            Some((profile.body_end(last_bin, outward, floor, 2), crossing))
        })
    }

    /// The ends moved outwards where the body goes on at a lower contrast
    /// ([`Follower::follow`]), a body no longer than `longest_px`: the outer end of the last
    /// stretch that was the body's, and the crossing of half its diameter at the contrast there.
    fn followed(self, profile: &WidthProfile, follower: &Follower, longest_px: f32) -> Ends {
        let d = follower.middle.diameter_px;
        self.moved_outwards(longest_px, |end, outward, reach| {
            let followed = follower.follow(end, outward as f32, reach)?;
            let outer = profile.bin_of(followed.outer_t);
            let level = 0.5 * d * followed.contrast_fraction;
            let crossing = profile
                .crossing_from_beyond(outer, outward, level)
                .unwrap_or(followed.outer_t);
            ((crossing - end) * (outward as f32) > 0.0).then_some((outer, crossing))
        })
    }

    /// Each end (`hi50` going +1, `lo50` going -1) moved to the outer bin and half-diameter
    /// crossing `moved(end, outward, reach)` gives, where it gives one: `reach` is how much
    /// farther that end can lie for a body no longer than `longest_px`.
    fn moved_outwards(
        self,
        longest_px: f32,
        mut moved: impl FnMut(f32, isize, f32) -> Option<(usize, f32)>,
    ) -> Ends {
        let mut ends = self;
        for outward in [1isize, -1] {
            let (end, other) = if outward > 0 {
                (ends.hi50, ends.lo50)
            } else {
                (ends.lo50, ends.hi50)
            };
            let reach = longest_px - libm::fabsf(end - other);
            let Some((outer, crossing)) = moved(end, outward, reach) else {
                continue;
            };
            if outward > 0 {
                (ends.high, ends.hi50) = (outer, crossing);
            } else {
                (ends.low, ends.lo50) = (outer, crossing);
            }
        }
        ends
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Over axes at many angles and offsets, each row's passing span holds exactly the columns
    /// that pass the width profile's test one by one (within a band across, within the bins
    /// along): the columns that pass form one interval, and the span is it.
    #[test]
    fn a_passing_span_is_the_columns_that_pass_one_by_one() {
        let (along, band) = ((-37.5f32, 41.0f32), 3.7f32);
        let mut spans = 0;
        for k in 0..72 {
            let angle = k as f32 * 5.0_f32.to_radians() + 0.013;
            let axis = Axis {
                centre: ImagePoint::new(60.3, 47.8),
                dir: ImagePoint::new(libm::cosf(angle), libm::sinf(angle)),
            };
            let passes = |x: usize, y: usize| {
                let (t, across) = axis.local(x as f32, y as f32);
                !(libm::fabsf(across) > band || t < along.0 || t >= along.1)
            };
            for y in 0..100 {
                let (start, end) = passing_span(
                    row_span(axis.centre, axis.dir, y, along, band, (0, 120)),
                    |x| passes(x, y),
                );
                let one_by_one: heapless::Vec<usize, 120> =
                    (0..120).filter(|&x| passes(x, y)).collect();
                let spanned: heapless::Vec<usize, 120> = (start..end).collect();
                assert_eq!(spanned, one_by_one, "angle {k} x 5 deg, row {y}");
                spans += usize::from(start < end);
            }
        }
        // Most rows of most axes cross the band.
        assert!(spans > 2000, "{spans}");
    }
}
