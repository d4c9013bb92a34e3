//! The grey-level fit: the model's whole image fitted to the chip's grey levels.
//!
//! Starting from the table match, the fit moves the model's silhouette (its origin along and
//! across the axis, the axis's angle, the scale, the tilt out of the image plane and the roll),
//! the optics' blur and the lighting until the rendered image ([`appearance`]: the outline of
//! [`outline`], shaded, blurred) best matches the chip's grey levels over a window around the
//! body. Every pixel counts, the body's length, its fins and its base outline included: that is
//! what carries the scale where a diameter of 4 px cannot, and what separates the blur from the
//! width.
//!
//! The sky is the detection's sky model plus a correction fitted with the body: a slope across
//! the axis and a level in bins along the window, linear between the bins' middles.
//! How the body meets it depends on the sky beside the body ([`FitInput::cluttered_sky`], the
//! detection's judgement, [`Background::follows_corridor`]):
//! - Where it varies faster than the detection's tiles follow (a cloud's texture, a band or a
//!   filament beside a faint body), the bins are about a body diameter long
//!   ([`GreyFitConfig::sky_bin_diameters`], at most [`SKY_BINS`]) and the body is opaque: it
//!   hides the sky behind it and shows its own radiance, the same all along it (shaded across
//!   by the sun). The image is `sky (1 - a) + B a`, with `a` the blurred silhouette
//!   ([`appearance`]) and `B` the body's radiance ([`GreyFitted::shading`]), as a camera sees
//!   it: where a cloud darker than the body lies behind its tail and a brighter one behind its
//!   nose, the tail reads brighter than its sky and the nose darker. Fitted as a constant
//!   contrast over the sky, a faint body among clouds lost its nose or its tail where the sky
//!   behind it changed.
//! - On a uniform sky, two bins (a plane over the window), added to the body's image as well:
//!   there the detection's sky misses next to the body mostly a plume's glow, which lies in
//!   front of the tail as much as behind it. (Taken as a sky behind the body, the glow of a
//!   bright plume in the detection's tiles moved a wide shell's fitted base 0.15 px into the
//!   body, and its yaw error from 0.80 to 1.3 deg/km.)
//!
//! Where the sky is cluttered, the table match's length may be far off: a faint nose lost among
//! clouds (the match then tilts the body 40-80 deg out of the image plane), or a filament taken
//! for it. Where the world stage knows the body's velocity ([`FitInput::flight_tilt_deg`]; the
//! mount's pointing and a range sensor), the fit also starts at the velocity's tilt (a projectile
//! flies within a few degrees of its velocity), the silhouette's tail end held where a plume
//! marks it, else either end; of the starts, the one of least cost after
//! [`GreyFitConfig::probe_iterations`] in one window over all goes on. Over 780 frames of 21
//! simulated clutter clips the median pitch error went 0.88 -> 0.68 deg/km and the chosen yaw's
//! 8.8 -> 7.1, the upper quartile of the pitch's 6.2 -> 4.4 (`docs/benchmarks.md`). There the
//! fitted tilt is also drawn to the velocity's, as to a measurement of one sigma
//! [`GreyFitConfig::flight_tilt_sd_deg`]: near broadside the image shows the tilt only in the
//! length (`L cos tilt`, a pixel of a 130-px body is 8 deg at 5 deg), so where the image does
//! not tell the tilt the velocity does (555 clutter frames: pitch 0.59 -> 0.40, chosen yaw
//! 6.4 -> 3.8 deg/km); where it does, the image wins.
//!
//! On 13 simulated clutter clips (faint bodies among clouds, filaments and terrain, with plumes),
//! against the earlier fit (a constant contrast over the detection's sky and a plane), the
//! clips' median pitch and yaw errors came to 0.60 and 0.74 of what they were (the geometric
//! mean of the ratios; `docs/benchmarks.md`).
//!
//! The fit is Levenberg-Marquardt ([`crate::math::least_squares`]) over 14 parameters of the
//! body and up to `1 + SKY_BINS` of the sky: 7 of the geometry and optics (the placement's and
//! the blur's derivatives analytic, [`appearance::body_image`]; the tilt's and the roll's by
//! forward difference, so each evaluation renders the window 3 times), the 3 of the body's
//! radiance, which the image is linear in, and where a plume marks the tail the 4 of its glow
//! next to the base ([`glow`]: two peaks, the one the body hides and the one in front of it, and
//! two sigmas; held at zero without a plume), then the sky's. Each pixel touches the body's
//! parameters, the slope and two bins' levels ([`crate::math::accumulate_at`]). Saturated pixels
//! (at the chip's full scale: a bright plume's) are left out.
//! Residuals beyond [`GreyFitConfig::huber_sigmas`] noise sigmas count linearly (Huber), so a
//! star, a filament or plume glow in the window pulls less. Where the range is known the scale is
//! held at it. The window's pixels are chosen from the start, so that every evaluation sums over
//! the same pixels; where the sky is cluttered it reaches along the axis as far as the body can
//! from the start's far end (a faint nose read short at the start is otherwise never seen; a
//! clear body's ends are read well at the start, and the larger window, thinned, would sum fewer
//! of its pixels: a six-finned body's yaw 0.41 -> 0.57 deg/km); where a plume marks the tail the
//! window ends just beyond the base, and the fit goes once more in the window at its solution's
//! base (a faint tail read short at the start, likewise). A window larger than
//! [`GreyFitConfig::max_pixels`] is thinned on a regular lattice.
//!
//! The glow is fitted wherever a plume marks the tail, and the plume's end is the tail: with the
//! second window, over 120 simulated frames each, a faint body (3-5 noise sigmas) under a plume
//! on a clear sky went from pitch 0.27 to 0.17 and yaw 4.5 to 2.6 deg/km, and bright bodies'
//! yaw came out 20-35 % smaller. The glow only brightens the sky beyond the base (an outside
//! renderer's terrain beyond the tail was fitted as a dark glow; bounded, that clip's pitch went
//! from 1.7 to 1.3 deg/km).

pub mod appearance;
pub mod glow;
pub mod outline;

use crate::camera::Camera;
use crate::chip::ChipView;
use crate::config::BodyPolarity;
use crate::extremes::Axis;
use crate::lut::render::{Placement, View};
use crate::math::least_squares::{self, Normal, Problem};
use crate::model::ProjectileModel;
use crate::point::ImagePoint;
use crate::segment::background::Background;
use crate::table_match::MatchedPose;
use nalgebra::SVector;
use outline::{Fins, Outline};

/// The fit's parameters, as offsets from the start where they move the silhouette: along and
/// across the start's axis (px), the axis's turn (rad), the log of the scale, tilt and roll
/// (deg), blur sigma (px); then the body's radiance `c0, c1, c2` (grey levels, `c0` against the
/// detection's sky at the start's origin); then the plume's glow next to the tail ([`glow`];
/// held at zero without a plume): its peak where the body hides it (grey levels), the logs of
/// its sigmas along and across the axis in body diameters, and its peak in front of the body;
/// then the sky's slope across the axis and its level in each bin (grey levels
/// over the detection's sky).
type Params = SVector<f32, PARAMS>;
/// The most bins of the sky along the window ([`GreyFitConfig::sky_bin_diameters`]).
pub const SKY_BINS: usize = 24;
/// Parameters: 14 of the body, its optics and the glow, then the sky's slope across and its
/// level in each bin.
const PARAMS: usize = SKY + 1 + SKY_BINS;
/// Index of the log scale.
const LOG_SCALE: usize = 3;
/// Index of the tilt.
const TILT: usize = 4;
/// Index of the roll.
const ROLL: usize = 5;
/// Index of the blur.
const SIGMA: usize = 6;
/// Index of `c0`.
const SHADING: usize = 7;
/// Index of the hidden glow's peak; the logs of its sigmas and the peak in front follow.
const GLOW: usize = 10;
/// Index of the glow's peak in front of the body.
const GLOW_FRONT: usize = 13;
/// Index of the sky's slope across the axis; the bins' levels follow.
const SKY: usize = 14;

/// Forward-difference steps of the tilt and the roll, deg (the outline's derivatives in them are
/// rendered; those in the placement and the blur are analytic, [`appearance::body_image`]).
const TILT_STEP_DEG: f32 = 0.5;
/// See [`TILT_STEP_DEG`].
const ROLL_STEP_DEG: f32 = 1.0;

/// The smallest and largest blur sigma fitted, px.
const SIGMA_RANGE_PX: (f32, f32) = (0.3, 4.0);
/// The largest tilt, deg (the silhouette of a body seen end-on has no axis to fit).
const MAX_TILT_DEG: f32 = 89.0;
/// The least tilt the fit starts from, deg. The image is even in the tilt (a body tilted either
/// way out of the image plane casts nearly the same silhouette), so broadside is a stationary
/// point of the cost that a start there never leaves: the table's broadside match held the shell
/// at 0 deg where it flew 7-10 deg out of the plane.
const MIN_START_TILT_DEG: f32 = 3.0;

/// The grey-level fit's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GreyFitConfig {
    /// Whether the fit runs (after a table match).
    pub enabled: bool,
    /// The most pixels the fit sums over; a larger window is thinned on a regular lattice.
    pub max_pixels: usize,
    /// Outline columns per blur sigma along the axis (fewer where the outline's capacity ends).
    pub columns_per_sigma: f32,
    /// The window reaches this many blur sigmas beyond the silhouette ...
    pub margin_sigmas: f32,
    /// ... plus this many px.
    pub margin_px: f32,
    /// Residuals beyond this many noise sigmas count linearly (Huber).
    pub huber_sigmas: f32,
    /// Rolls evenly spaced over the model's distinct rolls from the table match's (a fin's place
    /// is a local minimum of the cost; models without fins take the match's), each rendered
    /// once from the start and from it turned end for end: the way round with the least cost
    /// tells the nose from the tail ...
    pub roll_starts: u32,
    /// ... where it is lower than the other way's by more than this fraction; else both ways
    /// go on ...
    pub orientation_margin: f32,
    /// ... and from it the match's roll and the other roll of least cost go this many
    /// Levenberg-Marquardt iterations ...
    pub probe_iterations: u32,
    /// ... and the better goes on to this iteration limit.
    pub max_iterations: u32,

    /// The fitted scale stays within this fraction of the start's.
    pub max_scale_change: f32,
    /// The fitted origin stays within this many px of the start's.
    pub max_shift_px: f32,
    /// Where the range is not known, a body without fins, or one whose diameter spans at least
    /// this many blur sigmas (wide), has its scale fitted. A narrow finned body's fin span shows
    /// with the roll and the scale together: its fitted scale wandered by 2-15 % (the reference
    /// at 5-8 px; an outside renderer's mortar, Tz 1.8 -> 9.3 m/km). A finless body's scale and
    /// tail have only the outline to fit (an outside renderer's 8-10 px shell: Tz 12.1 -> 3.2
    /// m/km), and a wide body's width fixes its scale (the shell at 21 px: 0.1-0.2 %).
    pub wide_body_sigmas: f32,
    /// ... or one narrower than this many px (a pixel is a fifth of its diameter, which trades
    /// against the blur: the table match's scale read 3-5 % short on a 4-6 px body at a 0.6 px
    /// blur) ...
    pub narrow_body_px: f32,
    /// ... that spans at least this many blur sigmas (its base and fins, which carry the scale,
    /// are resolved: an outside renderer's 4.7 px body under a 1.2 px blur, 3.8 sigmas, fitted
    /// its scale 3-7 % long).
    pub sharp_body_sigmas: f32,
    /// Where the glow is fitted, the window reaches this many blur sigmas beyond the base (the
    /// blurred edge between the body and the plume; the plume beyond is left out).
    pub plume_margin_sigmas: f32,
    /// The sky's bins along the window are about this many body diameters long (at most
    /// [`SKY_BINS`] of them).
    pub sky_bin_diameters: f32,
    /// Where the sky is cluttered and the velocity's tilt is known, the fitted tilt is drawn
    /// to it as to a measurement of this one-sigma, deg (the angle of attack's share).
    pub flight_tilt_sd_deg: f32,
    /// The fins' faces are shaded as their own (with the body's shading at their normal) where
    /// the body's contrast is at least this many noise sigmas; a fainter body's shading is
    /// mostly noise, and the fins are shaded as the body (19 simulated clutter clips with faint
    /// bodies: chosen yaw 3.5 % worse, geometric mean, with the faces at any contrast).
    pub fin_faces_min_contrast_sigmas: f32,
}

impl GreyFitConfig {
    /// The defaults.
    pub const DEFAULT: GreyFitConfig = GreyFitConfig {
        enabled: true,
        max_pixels: 2500,
        columns_per_sigma: 3.0,
        margin_sigmas: 3.0,
        margin_px: 2.0,
        huber_sigmas: 3.0,
        roll_starts: 6,
        orientation_margin: 0.2,
        probe_iterations: 3,
        max_iterations: 12,
        max_scale_change: 0.15,
        max_shift_px: 8.0,
        wide_body_sigmas: 12.0,
        narrow_body_px: 5.0,
        sharp_body_sigmas: 5.0,
        plume_margin_sigmas: 1.0,
        sky_bin_diameters: 1.0,
        flight_tilt_sd_deg: 3.0,
        fin_faces_min_contrast_sigmas: 8.0,
    };
}

/// Parameters `p` of a solution restated for a problem started at the solution's own frame
/// ([`GreyProblem::frame`]): no shift, turn or scale left, and the sky plane again to be found
/// (its basis is the new window's).
fn relative_to_start(p: &Params) -> Params {
    let mut q = *p;
    for k in [0, 1, 2, LOG_SCALE].into_iter().chain(SKY..PARAMS) {
        q[k] = 0.0;
    }
    q
}

/// Why the fit gave no result.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GreyFitError {
    /// The start's silhouette has no outline (an absurd scale or view).
    NoOutline,
    /// The window holds too few pixels to fit.
    TooFewPixels,
    /// The fit could not be evaluated at its start.
    NoStart,
    /// The fit ended at its bounds: the model does not describe the image there.
    AtBound,
}

/// How well the grey-level fit saw the fins, which the roll read from them follows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FinsSeen {
    /// Their faces shaded as their own ([`Fins::Faces`]: a true scale, a clear sky, a body of
    /// [`GreyFitConfig::fin_faces_min_contrast_sigmas`]).
    Faces,
    /// Shaded as the body, on a clear sky and a body of that contrast (at the table match's
    /// scale).
    AsBody,
    /// On a fainter body or against a cluttered sky, where they barely show.
    Barely,
}

/// What the grey-level fit measured.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GreyFitted {
    /// The projected nose tip and tail base centre, full-frame px.
    pub ends: [ImagePoint; 2],
    /// Scale, px per metre across the axis.
    pub px_per_m: f32,
    /// Slant range of the scale, m (the given one where the range is known).
    pub range_m: f32,
    /// Fractional one-sigma of the scale from the fit's covariance (0 where it was held).
    pub scale_sd: f32,
    /// One sigma of the apparent length nose to tail, px, and of the projected axis's angle, rad,
    /// from the fit's covariance (NaN where it has none).
    pub length_sd_px: f32,
    /// See `length_sd_px`.
    pub turn_sd_rad: f32,
    /// One sigma of the view's roll, deg, from the fit's covariance (NaN on a model without
    /// fins, whose roll the image does not show, or without a covariance).
    pub roll_sd_deg: f32,
    /// How well the fins showed.
    pub fins_seen: FinsSeen,
    /// The fitted view.
    pub view: View,
    /// Blur sigma, px (the PSF and the pixel's width together).
    pub sigma_px: f32,
    /// The body's radiance across its outline, `c0 + c1 w + c2 w²` with `w` from -1 on the
    /// lower edge to 1 on the upper ([`appearance`]), grey levels; `c0` against the detection's
    /// sky at the start's origin (its contrast there).
    pub shading: [f32; 3],
    /// The plume's glow next to the tail ([`glow`]): its peak where the body hides it and in
    /// front of the body, grey levels, and its sigmas along and across the axis, m (zero peaks
    /// without a plume).
    pub glow: [f32; 4],
    /// Root-mean-square residual, grey levels.
    pub rms: f32,
    /// Pixels summed.
    pub pixels: u32,
    /// Levenberg-Marquardt iterations spent.
    pub iterations: u32,
}

impl GreyFitted {
    /// The projected axis, unit, tail to nose.
    pub fn nose_dir(&self) -> ImagePoint {
        let [nose, tail] = self.ends;
        let d = nose - tail;
        d * (1.0 / d.norm().max(f32::MIN_POSITIVE))
    }

    /// The fitted silhouette's placement on the chip whose top-left pixel is the full-frame
    /// pixel `origin`, in px per body diameter (`diameter_m`, m): a table entry's unit. The body
    /// origin lies halfway between the ends.
    pub fn placement_in_chip(&self, origin: (i32, i32), diameter_m: f32) -> Placement {
        let [nose, tail] = self.ends;
        Placement {
            origin: (nose + tail) * 0.5 - ImagePoint::of_pixel(origin),
            dir: self.nose_dir(),
            px_per_unit: self.px_per_m * diameter_m,
        }
    }
}

/// One frame's data for the fit.
pub struct FitInput<'a> {
    /// The chip.
    pub chip: &'a ChipView<'a>,
    /// Its sky model.
    pub background: &'a Background,
    /// Full-frame pixel of the chip's top-left.
    pub origin: (i32, i32),
    /// The range, where it is known, m.
    pub range_m: Option<f32>,
    /// Whether `range_m` is a range sensor's reading (not the flight filter's prediction).
    pub range_sensed: bool,
    /// Whether the nose points towards the camera, where the recent frames have told the yaw
    /// candidate: the fins' faces are shaded for it. Where None, the fit goes on with both and
    /// the better stays.
    pub nose_towards: Option<bool>,
    /// Whether a plume glows beyond the start's tail ([`crate::Silhouette::plume_at_tail`]):
    /// the pixels behind the base are then left out.
    pub plume_at_tail: bool,
    /// Whether the sky beside the body varies faster than the detection's sky model follows
    /// ([`Background::follows_corridor`]): the sky is then fitted in bins about a body diameter
    /// long and the body hides it; else the sky is a plane over the window, added to the body's
    /// image.
    pub cluttered_sky: bool,
    /// The tilt out of the image plane of the body's velocity, deg, where the world stage knows
    /// it ([`crate::world::Flight::tilt_deg`]): a projectile flies within a few degrees of its
    /// velocity, so where the sky is cluttered the fit also starts there.
    pub flight_tilt_deg: Option<f32>,
}

/// Where the fit starts: the table match's silhouette, blur and contrast.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitStart {
    /// The body origin's chip pixel, the projected axis (tail to nose) and the scale in px per
    /// metre.
    pub placement: Placement,
    /// The view.
    pub view: View,
    /// Blur sigma, px.
    pub sigma_px: f32,
    /// The body's mean contrast against the sky, signed (negative for a dark body), grey levels.
    pub contrast: f32,
}

impl FitStart {
    /// The start at the table match `matched` of a body `model` whose contrast has `polarity`.
    pub fn of_match(
        matched: &MatchedPose,
        model: &ProjectileModel,
        polarity: BodyPolarity,
    ) -> FitStart {
        FitStart {
            placement: Placement {
                px_per_unit: matched.placement.px_per_unit / model.diameter_m,
                ..matched.placement
            },
            view: matched.view,
            sigma_px: matched.section.sigma_px,
            contrast: polarity.sign() * matched.section.mean_contrast,
        }
    }
}

/// The silhouette's placement on the chip at parameters `p`: the projected axis through the
/// body origin (`Axis::centre`), tail to nose, and the scale.
#[derive(Debug, Clone, Copy)]
struct Frame {
    axis: Axis,
    px_per_m: f32,
}

impl Frame {
    /// Silhouette-frame coordinates of chip point `(x, y)`, m.
    fn local(&self, x: f32, y: f32) -> (f32, f32) {
        let (u, v) = self.axis.local(x, y);
        let inv = 1.0 / self.px_per_m;
        (u * inv, v * inv)
    }
}

/// The base centre's distance from the body origin along the projected axis, m, for a body of
/// `model` at `tilt_deg`: half its length, foreshortened.
fn base_distance_m(model: &ProjectileModel, tilt_deg: f32) -> f32 {
    0.5 * model.length_m * libm::cosf(tilt_deg * crate::pose::RAD)
}

/// The pixels summed: those on a lattice of `stride` px within a rectangle along the start's
/// axis.
#[derive(Debug, Clone, Copy)]
struct Window {
    /// The start's placement.
    frame: Frame,
    /// Extent along the axis, px from the start's origin.
    along: (f32, f32),
    /// Half extent across, px.
    across: f32,
    /// Chip box holding the rectangle: columns and rows `start..end`.
    columns: (usize, usize),
    rows: (usize, usize),
    stride: usize,
    /// Pixels summed.
    pixels: usize,
    /// The sky's bins along the rectangle.
    sky: SkyBins,
}

/// The sky's correction as the fit sees it: over the detection's sky model, a slope across the
/// axis and, in each of `count` bins of `length` px along the window, a level, linear along
/// between the bins' middles. A cloud's texture, a filament or a band beside the body varies
/// faster along it than the detection's tiles follow, and the pixels beside the body in the
/// window measure it where the body's edges need it.
#[derive(Debug, Clone, Copy)]
struct SkyBins {
    /// Where the first bin starts along the axis, px from the start's origin.
    first: f32,
    /// Bin length, px.
    length: f32,
    /// Bins (2 to [`SKY_BINS`]).
    count: usize,
    /// The across coordinate's scale: the window's half width, px.
    half_width: f32,
}

/// Where a pixel lies among the sky's bins: the two bins it takes its sky from, with their
/// weights, and its place across in half widths.
#[derive(Debug, Clone, Copy)]
struct SkyPoint {
    bins: [usize; 2],
    weights: [f32; 2],
    across: f32,
}

impl SkyBins {
    /// The bins over `along` (px from the origin), each about `length` px long (at least
    /// two, at most [`SKY_BINS`]), across a window `half_width` px either side.
    fn new(along: (f32, f32), length: f32, half_width: f32) -> SkyBins {
        let span = (along.1 - along.0).max(f32::MIN_POSITIVE);
        let wanted = libm::ceilf(span / length.max(f32::MIN_POSITIVE));
        // NaN-safe: `max` then `min` give 2 for a NaN.
        let count = wanted.max(2.0).min(SKY_BINS as f32) as usize;
        SkyBins {
            first: along.0,
            length: span / count as f32,
            count,
            half_width: half_width.max(f32::MIN_POSITIVE),
        }
    }

    /// The pixel at `t` along and `s` across the start's axis, px.
    /// Linear between the bins' middles, and beyond the first and the last middle along the
    /// line through the two nearest (two bins make a plane).
    fn point(&self, t: f32, s: f32) -> SkyPoint {
        let position = (t - self.first) / self.length - 0.5;
        // `count` is at least 2; NaN-safe (`max` then `min`).
        let i0 = libm::floorf(position).max(0.0).min((self.count - 2) as f32) as usize;
        let w1 = position - i0 as f32;
        SkyPoint {
            bins: [i0, i0 + 1],
            weights: [1.0 - w1, w1],
            across: s / self.half_width,
        }
    }

    /// The sky at `point` for the parameters `p`, grey levels (over the detection's).
    fn at(point: &SkyPoint, p: &Params) -> f32 {
        let mut sky = p[SKY] * point.across;
        for (bin, weight) in point.bins.iter().zip(point.weights) {
            sky += weight * p[SKY + 1 + bin];
        }
        sky
    }
}

impl Window {
    fn new(
        frame: Frame,
        along: (f32, f32),
        across: f32,
        sky_bin_px: f32,
        chip: &ChipView,
        max: usize,
    ) -> Window {
        let corners = [
            (along.0, -across),
            (along.0, across),
            (along.1, -across),
            (along.1, across),
        ]
        .map(|(t, s)| frame.axis.point(t) + frame.axis.dir.perpendicular() * s);
        let (w, h) = (chip.width() as f32, chip.height() as f32);
        let span = |f: fn(&ImagePoint) -> f32, limit: f32| {
            let lo = corners.iter().map(f).fold(f32::INFINITY, f32::min);
            let hi = corners.iter().map(f).fold(f32::NEG_INFINITY, f32::max);
            let lo = libm::floorf(lo).clamp(0.0, limit) as usize;
            let hi = (libm::ceilf(hi) + 1.0).clamp(0.0, limit) as usize;
            (lo, hi.max(lo))
        };
        let columns = span(|p| p.x, w);
        let rows = span(|p| p.y, h);
        let mut window = Window {
            frame,
            along,
            across,
            columns,
            rows,
            stride: 1,
            pixels: 0,
            sky: SkyBins::new(along, sky_bin_px, across),
        };
        let count = window.count(chip);
        if count > max {
            window.stride =
                (libm::ceilf(libm::sqrtf(count as f32 / max.max(1) as f32)) as usize).max(1);
        }
        window.pixels = window.count(chip);
        window
    }

    /// Calls `f` with every pixel of `chip` summed and its place among the sky's bins: those
    /// on the lattice within the rectangle, but for saturated ones (at the chip's full scale, a
    /// bright plume's: their radiance is only known to be at least that).
    fn for_each(&self, chip: &ChipView, mut f: impl FnMut(usize, usize, &SkyPoint)) {
        let full_scale = chip.full_scale();
        for y in (self.rows.0..self.rows.1).step_by(self.stride) {
            for x in (self.columns.0..self.columns.1).step_by(self.stride) {
                let (t, s) = self.frame.axis.local(x as f32, y as f32);
                let inside =
                    t >= self.along.0 && t <= self.along.1 && libm::fabsf(s) <= self.across;
                if inside && chip.get(x, y) < full_scale {
                    f(x, y, &self.sky.point(t, s));
                }
            }
        }
    }

    /// The pixels of `chip` summed.
    fn count(&self, chip: &ChipView) -> usize {
        let mut n = 0;
        self.for_each(chip, |_, _, _| n += 1);
        n
    }
}

/// The fit as the solver sees it.
struct GreyProblem<'a, const C: usize> {
    input: &'a FitInput<'a>,
    model: &'a ProjectileModel<'a>,
    start: Frame,
    window: Window,
    /// Outline columns.
    columns: usize,
    /// Whether the scale is held (the range known).
    scale_held: bool,
    /// Whether the roll changes the outline (the model has fins).
    has_fins: bool,
    /// How the outline shades the fins: each face with its own normal (under an outside
    /// renderer's strong sun, the fins shaded as the body turned the roll 4-9 deg) at a true
    /// scale (a range sensor's, or a wide body's fitted one), on a clear sky and where the
    /// body's contrast shows its shading ([`GreyFitConfig::fin_faces_min_contrast_sigmas`]);
    /// else as the body (at the table match's scale the fins' outline is off by its error:
    /// small-unknown-range's yaw 0.44 -> 0.73 deg/km with the fins' own radiance free; among
    /// clouds a faint body's fins barely show).
    fins: Fins,
    /// Residuals beyond this count linearly, grey levels.
    huber: f32,
    /// The detection's sky at the fit's first start's origin, grey levels: the body's radiance
    /// is fitted against it.
    sky_reference: f32,
    /// The velocity's tilt out of the image plane, deg, and the weight of the fitted tilt's
    /// squared difference from it, cost per deg² (none where the velocity is not known).
    flight_tilt: Option<(f32, f32)>,
    config: &'a GreyFitConfig,
}

impl<const C: usize> GreyProblem<'_, C> {
    /// The placement at `p`.
    fn frame(&self, p: &Params) -> Frame {
        let (sin, cos) = (libm::sinf(p[2]), libm::cosf(p[2]));
        let d0 = self.start.axis.dir;
        let dir = ImagePoint::new(cos * d0.x - sin * d0.y, sin * d0.x + cos * d0.y);
        Frame {
            axis: Axis {
                centre: self.start.axis.centre + d0 * p[0] + d0.perpendicular() * p[1],
                dir,
            },
            px_per_m: self.start.px_per_m * libm::expf(p[LOG_SCALE]),
        }
    }

    fn outline(&self, tilt_deg: f32, roll_deg: f32) -> Option<Outline<C>> {
        let view = View { tilt_deg, roll_deg };
        Outline::build(self.model, &view, self.columns, self.fins)
    }

    /// Chip pixel `(x, y)` less the detection's sky model, and that sky's level there against
    /// its level at the fit's reference point.
    fn data(&self, x: usize, y: usize) -> (f32, f32) {
        let sky = self.input.background.at(x as f32, y as f32);
        let data = f32::from(self.input.chip.get(x, y)) - sky;
        (data, sky - self.sky_reference)
    }

    /// `value` where the fitted sky lies behind the body (cluttered: the body hides it), else
    /// zero (a uniform sky's correction is added to the body's image too).
    fn behind(&self, value: f32) -> f32 {
        if self.input.cluttered_sky { value } else { 0.0 }
    }

    /// The Huber cost of residual `r` and its weight in the normal equations.
    fn huber(&self, r: f32) -> (f32, f32) {
        let a = libm::fabsf(r);
        if a <= self.huber {
            (r * r, 1.0)
        } else {
            (
                2.0 * self.huber * a - self.huber * self.huber,
                self.huber / a,
            )
        }
    }

    /// Where the glow of unit peak next to the tail lies at `p` and `tilt_deg` (None without a
    /// plume).
    fn glow_place(&self, p: &Params, tilt_deg: f32) -> Option<glow::GlowPlace> {
        self.input.plume_at_tail.then(|| {
            let d = self.model.diameter_m;
            glow::GlowPlace {
                sigmas_m: [d * libm::expf(p[GLOW + 1]), d * libm::expf(p[GLOW + 2])],
                base_u_m: -base_distance_m(self.model, tilt_deg),
            }
        })
    }

    /// The body's contrast at `p` against the sky `sky_here` (grey levels over the fit's
    /// reference) where the hidden glow of unit value `glow` lies behind it: its radiance less
    /// the sky and the glow behind it.
    fn shading_over(p: &Params, glow: Option<&glow::GlowImage>, sky_here: f32) -> [f32; 3] {
        let hidden = glow.map_or(0.0, |g| p[GLOW] * g.shape);
        [
            p[SHADING] - sky_here - hidden,
            p[SHADING + 1],
            p[SHADING + 2],
        ]
    }

    /// Both glows' value of unit shape, grey levels: the hidden one and the one in front.
    fn glow_peaks(p: &Params) -> f32 {
        p[GLOW] + p[GLOW_FRONT]
    }

    /// The body and the glow over the sky at `p` with the outline `outline` and the glow at
    /// `glow_place` (of the same tilt), at the silhouette-frame point `(u, v)` (m) and blur
    /// `sigma_m` (m), where the sky is `sky_here` (over the fit's reference), grey levels.
    fn image(
        p: &Params,
        (outline, glow_place): (&Outline<C>, Option<&glow::GlowPlace>),
        (u, v): (f32, f32),
        sigma_m: f32,
        sky_here: f32,
    ) -> f32 {
        let glow = glow_place.map(|g| g.image(u, v));
        let b = appearance::body_basis(outline, u, v, sigma_m);
        let shading = Self::shading_over(p, glow.as_ref(), sky_here);
        appearance::contrast(shading, b) + glow.map_or(0.0, |g| Self::glow_peaks(p) * g.shape)
    }

    /// The velocity's tilt less the fitted tilt at `p`, deg, and its weight, cost per deg²
    /// (None where the velocity is not known).
    fn flight_residual(&self, p: &Params) -> Option<(f32, f32)> {
        self.flight_tilt
            .map(|(tilt, weight)| (tilt - p[TILT], weight))
    }

    /// The cost alone at `p` (no derivatives: one rendering of the window).
    fn cost(&self, p: &Params) -> Option<f32> {
        let outline = self.outline(p[TILT], p[ROLL])?;
        let glow_place = self.glow_place(p, p[TILT]);
        let frame = self.frame(p);
        let sigma_m = p[SIGMA] / frame.px_per_m;
        let mut cost = 0.0;
        self.window.for_each(self.input.chip, |x, y, point| {
            let (data, offset) = self.data(x, y);
            let local = frame.local(x as f32, y as f32);
            let sky = SkyBins::at(point, p);
            let image = Self::image(
                p,
                (&outline, glow_place.as_ref()),
                local,
                sigma_m,
                self.behind(offset + sky),
            );
            cost += self.huber(data - image - sky).0;
        });
        if let Some((r, weight)) = self.flight_residual(p) {
            cost += weight * r * r;
        }
        cost.is_finite().then_some(cost)
    }
}

impl<const C: usize> Problem<PARAMS> for GreyProblem<'_, C> {
    fn evaluate(&self, p: &Params) -> Option<Normal<PARAMS>> {
        let base = self.outline(p[TILT], p[ROLL])?;
        let tilted = self.outline(p[TILT] + TILT_STEP_DEG, p[ROLL])?;
        let rolled = if self.has_fins {
            Some(self.outline(p[TILT], p[ROLL] + ROLL_STEP_DEG)?)
        } else {
            None
        };
        let glow_place = self.glow_place(p, p[TILT]);
        let tilted_glow_place = self.glow_place(p, p[TILT] + TILT_STEP_DEG);
        let frame = self.frame(p);
        let sigma_m = p[SIGMA] / frame.px_per_m;
        // The start's axis and its normal in the current one's frame: how moving the origin
        // along and across the start's axis moves a pixel's (u, v).
        let (d0, n0) = (self.start.axis.dir, self.start.axis.dir.perpendicular());
        let (d, n) = (frame.axis.dir, frame.axis.dir.perpendicular());
        let inv_k = 1.0 / frame.px_per_m;
        let along = (d0.dot(d) * inv_k, d0.dot(n) * inv_k);
        let across = (n0.dot(d) * inv_k, n0.dot(n) * inv_k);
        let mut normal = Normal::<PARAMS>::zeros();
        self.window.for_each(self.input.chip, |x, y, point| {
            let (data, offset) = self.data(x, y);
            let (u, v) = frame.local(x as f32, y as f32);
            let glow = glow_place.map(|g| g.image(u, v));
            let sky = SkyBins::at(point, p);
            let sky_here = self.behind(offset + sky);
            // The hidden glow darkens the body's contrast as much as it lights the sky beside
            // it, so the body's image (and its derivatives) carry it through its shading.
            let shading = Self::shading_over(p, glow.as_ref(), sky_here);
            let image = appearance::body_image(&base, u, v, sigma_m, shading);
            let contrast = appearance::contrast(shading, image.basis);
            let mut g = Params::zeros();
            let (mut d_u, mut d_v) = (image.d_u, image.d_v);
            let mut value = contrast;
            if let Some(glow) = &glow {
                let uncovered = 1.0 - image.basis[0];
                let peaks = p[GLOW] * uncovered + p[GLOW_FRONT];
                value += Self::glow_peaks(p) * glow.shape;
                d_u += peaks * glow.d_u;
                d_v += peaks * glow.d_v;
                g[GLOW] = glow.shape * uncovered;
                g[GLOW + 1] = peaks * glow.d_log_sigmas[0];
                g[GLOW + 2] = peaks * glow.d_log_sigmas[1];
                g[GLOW_FRONT] = glow.shape;
            }
            g[0] = -(d_u * along.0 + d_v * along.1);
            g[1] = -(d_u * across.0 + d_v * across.1);
            // Turning the axis about the origin moves (u, v) by (v, -u) per radian.
            g[2] = d_u * v - d_v * u;
            if !self.scale_held {
                // Growing the scale shrinks (u, v) and the blur in metres alike.
                g[LOG_SCALE] = -(d_u * u + d_v * v + image.d_sigma * sigma_m);
            }
            g[SIGMA] = image.d_sigma * inv_k;
            let tilted = (&tilted, tilted_glow_place.as_ref());
            g[TILT] = (Self::image(p, tilted, (u, v), sigma_m, sky_here) - value) / TILT_STEP_DEG;
            if let Some(rolled) = &rolled {
                let br = appearance::body_basis(rolled, u, v, sigma_m);
                g[ROLL] = (appearance::contrast(shading, br) - contrast) / ROLL_STEP_DEG;
            }
            for i in 0..3 {
                g[SHADING + i] = image.basis[i];
            }
            // The body hides the sky it covers (where the sky is that behind it).
            let open = 1.0 - self.behind(image.basis[0]);
            g[SKY] = open * point.across;
            for (bin, weight) in point.bins.iter().zip(point.weights) {
                g[SKY + 1 + bin] += weight * open;
            }
            let r = data - value - sky;
            let (cost, weight) = self.huber(r);
            normal.cost += cost;
            let [b0, b1] = point.bins;
            let indices = (0..=SKY).chain([SKY + 1 + b0, SKY + 1 + b1]);
            crate::math::accumulate_at(&mut normal.jtj, &mut normal.jtr, &g, indices, weight, r);
        });
        if let Some((r, weight)) = self.flight_residual(p) {
            normal.cost += weight * r * r;
            let mut g = Params::zeros();
            g[TILT] = 1.0;
            crate::math::accumulate_at(
                &mut normal.jtj,
                &mut normal.jtr,
                &g,
                core::iter::once(TILT),
                weight,
                r,
            );
        }
        Some(normal.complete())
    }

    fn constrain(&self, from: &Params, trial: &mut Params) {
        // `max` then `min`, not `clamp`: bounds from the configuration may be NaN or crossed,
        // and `clamp` panics on those.
        let within = |v: f32, lo: f32, hi: f32| v.max(lo).min(hi);
        let shift = self.config.max_shift_px;
        trial[0] = within(trial[0], -shift, shift);
        trial[1] = within(trial[1], -shift, shift);
        let scale = libm::logf(1.0 + self.config.max_scale_change);
        trial[LOG_SCALE] = within(trial[LOG_SCALE], -scale, scale);
        trial[TILT] = within(trial[TILT], 0.0, MAX_TILT_DEG);
        // The roll and the turn move at most 10 and 2 deg a step.
        trial[ROLL] = within(trial[ROLL], from[ROLL] - 10.0, from[ROLL] + 10.0);
        let turn = 2.0 * crate::pose::RAD;
        trial[2] = within(trial[2], from[2] - turn, from[2] + turn);
        trial[SIGMA] = within(trial[SIGMA], SIGMA_RANGE_PX.0, SIGMA_RANGE_PX.1);
        let (narrowest, widest) = glow::WIDTH_RANGE_DIAMETERS;
        let diameter_px = self.model.diameter_m * self.start.px_per_m;
        let blurs = glow::MIN_SIGMA_BLURS * trial[SIGMA] / diameter_px;
        let narrowest = libm::logf(narrowest.max(blurs));
        for k in [GLOW + 1, GLOW + 2] {
            trial[k] = within(trial[k], narrowest, libm::logf(widest));
        }
        // A plume's light only brightens the sky beyond the base: the glow there, both peaks,
        // is never dark (the terrain or a cloud beyond the tail is not a glow).
        trial[GLOW_FRONT] = trial[GLOW_FRONT].max(0.0);
        trial[GLOW] = trial[GLOW].max(-trial[GLOW_FRONT]);
    }
}

/// Fits the model's image to the chip from `from` (usually [`FitStart::of_match`]), with
/// outlines of at most `C` columns. Never inlined: its outlines (8 bytes a column each) then
/// take stack only while it runs, not in every caller's frame (the firmware, which does not
/// run it, kept 11 KB more stack when it was).
#[inline(never)]
pub fn fit<const C: usize>(
    input: &FitInput,
    from: &FitStart,
    model: &ProjectileModel,
    camera: &Camera,
    config: &GreyFitConfig,
) -> Result<GreyFitted, GreyFitError> {
    let start = Frame {
        axis: Axis {
            centre: from.placement.origin,
            dir: from.placement.dir,
        },
        px_per_m: from.placement.px_per_unit,
    };
    let view = from.view;
    let sigma = from.sigma_px.clamp(SIGMA_RANGE_PX.0, SIGMA_RANGE_PX.1);
    // The velocity's tilt, where the fit may start from it (below).
    let flight_tilt = input.flight_tilt_deg.filter(|_| input.cluttered_sky);
    // The outline's columns for the longer of the starts.
    let longest = View {
        tilt_deg: flight_tilt.map_or(view.tilt_deg, |t| t.min(view.tilt_deg)),
        ..view
    };
    let (lo, hi) = crate::lut::render::u_extent(model, &longest);
    let length_px = (hi - lo) * start.px_per_m;
    let columns = libm::ceilf(length_px * config.columns_per_sigma / sigma);
    if !columns.is_finite() {
        return Err(GreyFitError::NoOutline);
    }
    // Whether the scale is fitted (range unknown). NaN-safe: a NaN threshold makes no body wide.
    let diameter_px = model.diameter_m * start.px_per_m;
    let wide = diameter_px >= config.wide_body_sigmas * sigma;
    let narrow =
        diameter_px < config.narrow_body_px && diameter_px >= config.sharp_body_sigmas * sigma;
    let fit_scale = input.range_m.is_none() && (wide || narrow || model.fins().is_none());
    // The fins' faces where the scale is true, the sky clear and the body bright enough for
    // its shading to tell ([`GreyProblem::fins`]).
    let shading_shows = libm::fabsf(from.contrast)
        >= config.fin_faces_min_contrast_sigmas * input.background.sigma();
    let fins_seen = if !shading_shows || input.cluttered_sky {
        FinsSeen::Barely
    } else if input.range_sensed || wide {
        FinsSeen::Faces
    } else {
        FinsSeen::AsBody
    };
    let faces = model.fins().is_some() && fins_seen == FinsSeen::Faces;
    // Which face a fin turns to the camera depends on the yaw candidate (the silhouettes are
    // the same): the starts shade the fins for the recent frames' candidate, or as the body
    // before one is told; the fit then goes on with that candidate's faces, or with both
    // candidates' and the better stays.
    let (fins, facings) = match (faces, input.nose_towards) {
        (false, _) => (Fins::AsBody, [Some(Fins::AsBody), None]),
        (true, Some(nose_towards)) => {
            let told = Fins::Faces { nose_towards };
            (told, [Some(told), None])
        }
        (true, None) => (
            Fins::AsBody,
            [false, true].map(|nose_towards| Some(Fins::Faces { nose_towards })),
        ),
    };
    // The outline's columns and half span for the window (the outline itself is not kept: on
    // the firmware its 20 KiB are better left to the evaluations' own).
    let (outline_columns, half_span_m) =
        Outline::<C>::build(model, &longest, columns as usize, fins)
            .map(|first| (first.columns(), first.half_span_m()))
            .ok_or(GreyFitError::NoOutline)?;
    let margin = config.margin_sigmas * sigma + config.margin_px;
    let across = half_span_m * start.px_per_m + margin;
    // On a uniform sky two bins: the plane.
    let sky_bin_px = if input.cluttered_sky {
        config.sky_bin_diameters * model.diameter_m * start.px_per_m
    } else {
        f32::INFINITY
    };
    let sky_reference = input
        .background
        .at(start.axis.centre.x, start.axis.centre.y);
    let window = |start: Frame, along: (f32, f32)| {
        Window::new(
            start,
            along,
            across,
            sky_bin_px,
            input.chip,
            config.max_pixels,
        )
    };
    let problem_at = |start: Frame, window: Window| GreyProblem::<C> {
        input,
        model,
        start,
        window,
        columns: outline_columns,
        scale_held: !fit_scale,
        fins,
        has_fins: model.fins().is_some(),
        huber: config.huber_sigmas * input.background.sigma().max(f32::MIN_POSITIVE),
        sky_reference,
        flight_tilt: flight_tilt.map(|t| {
            let noise = input.background.sigma();
            (
                t,
                noise * noise / (config.flight_tilt_sd_deg * config.flight_tilt_sd_deg),
            )
        }),
        config,
    };
    // The parameters at the start of `view` and blur `sigma_px`: no shift, turn or scale, the
    // start's contrast, no sky correction, the glow at its starting width.
    let start_params = |view: &View, sigma_px: f32| {
        let mut p = Params::zeros();
        p[TILT] = view.tilt_deg.clamp(MIN_START_TILT_DEG, MAX_TILT_DEG);
        p[ROLL] = view.roll_deg;
        p[SIGMA] = sigma_px;
        p[SHADING] = from.contrast;
        p[GLOW + 1] = libm::logf(glow::START_WIDTH_DIAMETERS);
        p[GLOW + 2] = p[GLOW + 1];
        p
    };
    let solver = |max_iterations| least_squares::Config {
        max_iterations,
        relative_tolerance: 1e-5,
        ..least_squares::Config::DEFAULT
    };
    let probe = solver(config.probe_iterations);
    // Where the sky is cluttered, the start's length may be far off (a faint nose lost among
    // clouds, a filament taken for it): where the velocity's tilt is known, the fit starts from
    // whichever of the match's start and one at that tilt fits better after the probe's
    // iterations, in one window over both (a projectile flies within a few degrees of its
    // velocity). The tail stays where a plume marks it, else the middle.
    let (start, view, sigma) = match flight_tilt {
        Some(flight_tilt) => {
            // The silhouette's ends at `tilt`, px from the origin along the axis (the tail's
            // negative).
            let ends_at = |tilt: f32| {
                let view = View {
                    tilt_deg: tilt.clamp(MIN_START_TILT_DEG, MAX_TILT_DEG),
                    ..view
                };
                let (tail, nose) = crate::lut::render::u_extent(model, &view);
                (tail * start.px_per_m, nose * start.px_per_m)
            };
            let (tail, nose) = ends_at(view.tilt_deg);
            let (flight_tail, flight_nose) = ends_at(flight_tilt);
            // The starts: the match's, and at the velocity's tilt with the start's tail held
            // (its origin moved along the start's axis by `shift`, px), and with its nose held.
            let at_flight = |shift: f32| (flight_tilt, shift, (flight_tail, flight_nose));
            let mut starts: heapless::Vec<(f32, f32, (f32, f32)), 3> = heapless::Vec::new();
            starts.extend([
                (view.tilt_deg, 0.0, (tail, nose)),
                at_flight(tail - flight_tail),
            ]);
            if !input.plume_at_tail {
                starts.extend([at_flight(nose - flight_nose)]);
            }
            let behind = if input.plume_at_tail {
                config.plume_margin_sigmas * sigma
            } else {
                margin
            };
            let (first_t, last_t) = starts
                .iter()
                .fold((tail, nose), |(a, b), (_, shift, (t, n))| {
                    (a.min(t + shift), b.max(n + shift))
                });
            let all = window(start, (first_t - behind, last_t + margin));
            let at = |shift: f32| Frame {
                axis: Axis {
                    centre: start.axis.point(shift),
                    ..start.axis
                },
                ..start
            };
            starts
                .iter()
                .filter_map(|(tilt, shift, _)| {
                    let problem = problem_at(at(*shift), all);
                    let from_tilt = start_params(
                        &View {
                            tilt_deg: *tilt,
                            ..view
                        },
                        sigma,
                    );
                    let probed = least_squares::minimize(&problem, from_tilt, &probe)?;
                    Some((problem.frame(&probed.params), probed))
                })
                .min_by(|a, b| a.1.cost.total_cmp(&b.1.cost))
                .map_or((start, view, sigma), |(frame, probed)| {
                    let q = probed.params;
                    let view = View {
                        tilt_deg: q[TILT],
                        roll_deg: q[ROLL],
                    };
                    (frame, view, q[SIGMA])
                })
        }
        None => (start, view, sigma),
    };
    // Symmetric about the origin, so that the reversed start sums over the same pixels.
    let (lo, hi) = crate::lut::render::u_extent(model, &view);
    let half_px = libm::fabsf(lo).max(libm::fabsf(hi)) * start.px_per_m;
    // In clutter, as far as the body can reach from the start's far end.
    let reach_px = if input.cluttered_sky {
        (model.length_m * start.px_per_m - half_px).max(half_px)
    } else {
        half_px
    };
    let reach = reach_px + margin;
    // Where a plume glows beyond the tail, the pixels beyond the base are left out: beyond both
    // ends while nose and tail are told apart (so that both ways round sum over the same
    // pixels), then beyond the chosen tail (but for the blurred edge where the glow is fitted).
    let base_px = base_distance_m(model, view.tilt_deg) * start.px_per_m;
    // Beyond the chosen tail, the window at `frame`'s base where the body is tilted `tilt_deg`
    // and blurred `sigma_px` keeps the blurred edge where the glow is fitted.
    let tail_window = |frame: Frame, tilt_deg: f32, sigma_px: f32| {
        let base = base_distance_m(model, tilt_deg) * frame.px_per_m;
        window(
            frame,
            (-base - config.plume_margin_sigmas * sigma_px, reach),
        )
    };
    let probe_window = if input.plume_at_tail {
        window(start, (-base_px, base_px))
    } else {
        window(start, (-reach, reach))
    };
    if probe_window.pixels < 4 * PARAMS {
        return Err(GreyFitError::TooFewPixels);
    }
    let p = start_params(&view, sigma);
    let reversed = Frame {
        axis: Axis {
            dir: -start.axis.dir,
            ..start.axis
        },
        ..start
    };
    // The fins' silhouette repeats every `distinct_roll_deg`, and the cost has a minimum near
    // each fin's place: rolls evenly spaced from the match's.
    let starts = if model.fins().is_some() {
        config.roll_starts.max(1)
    } else {
        1
    };
    let spacing = model.distinct_roll_deg() / starts as f32;
    let rolled = |i: u32| {
        let mut q = p;
        q[ROLL] += spacing * i as f32;
        q
    };
    // Nose and tail: the way round whose least cost alone over the rolls is lower goes on. With
    // it, its roll whose cost alone is least among the others, and the match's.
    let survey = |s: Frame| {
        let problem = problem_at(s, probe_window);
        let mut least = f32::INFINITY;
        let mut other: Option<(u32, f32)> = None;
        for i in 0..starts {
            let Some(cost) = problem.cost(&rolled(i)) else {
                continue;
            };
            least = least.min(cost);
            if i > 0 && other.is_none_or(|(_, c)| cost < c) {
                other = Some((i, cost));
            }
        }
        (problem, least, other.map(|(i, _)| i))
    };
    // The match's roll and the other both go a few iterations: the cost at the match's tilt
    // and scale alone misleads where the fins barely show (a 4-px body, a plume's glow).
    let probe_rolls = |problem: &GreyProblem<C>, other: Option<u32>| {
        [Some(p), other.map(rolled)]
            .into_iter()
            .flatten()
            .filter_map(|q| least_squares::minimize(problem, q, &probe))
            .min_by(|a, b| a.cost.total_cmp(&b.cost))
    };
    let (forward, backward) = (survey(start), survey(reversed));
    let decisive =
        forward.1.min(backward.1) * (1.0 + config.orientation_margin) < forward.1.max(backward.1);
    // A plume marks the tail (the start's axis runs from it): the cost on a faint body does not
    // overrule it.
    let ways = if input.plume_at_tail {
        [Some(forward), None]
    } else if !decisive {
        [Some(forward), Some(backward)]
    } else if backward.1 < forward.1 {
        [None, Some(backward)]
    } else {
        [Some(forward), None]
    };
    let (problem, probed) = ways
        .into_iter()
        .flatten()
        .filter_map(|(problem, _, other)| {
            let probed = probe_rolls(&problem, other)?;
            Some((problem, probed))
        })
        .min_by(|a, b| a.1.cost.total_cmp(&b.1.cost))
        .ok_or(GreyFitError::NoStart)?;
    let problem = if input.plume_at_tail {
        let chosen = problem.start;
        problem_at(chosen, tail_window(chosen, view.tilt_deg, sigma))
    } else {
        problem
    };
    let pixels = problem.window.pixels;
    let (problem, solution) = facings
        .into_iter()
        .flatten()
        .filter_map(|fins| {
            let problem = GreyProblem { fins, ..problem };
            let solution =
                least_squares::minimize(&problem, probed.params, &solver(config.max_iterations))?;
            Some((problem, solution))
        })
        .min_by(|a, b| a.1.cost.total_cmp(&b.1.cost))
        .ok_or(GreyFitError::NoStart)?;
    // Beyond the tail the window ends at the start's base: where that lay inside the body (a
    // faint tail in the plume's glare read short), the body's own tail was left out and could not
    // pull the fit. Once more from the solution, in the window at its base.
    let (problem, solution) = if input.plume_at_tail {
        let moved = problem.frame(&solution.params);
        let (tilt_deg, sigma_px) = (solution.params[TILT], solution.params[SIGMA]);
        let again = GreyProblem {
            fins: problem.fins,
            ..problem_at(moved, tail_window(moved, tilt_deg, sigma_px))
        };
        match least_squares::minimize(
            &again,
            relative_to_start(&solution.params),
            &solver(config.max_iterations),
        ) {
            Some(settled) => (again, settled),
            None => (problem, solution),
        }
    } else {
        (problem, solution)
    };
    let p = solution.params;
    let scale_bound = libm::logf(1.0 + config.max_scale_change);
    let at_bound = libm::fabsf(p[0]).max(libm::fabsf(p[1])) >= config.max_shift_px
        || (!problem.scale_held && libm::fabsf(p[LOG_SCALE]) >= 0.999 * scale_bound)
        || p[SIGMA] <= SIGMA_RANGE_PX.0
        || p[SIGMA] >= SIGMA_RANGE_PX.1;
    if at_bound {
        return Err(GreyFitError::AtBound);
    }
    let frame = problem.frame(&p);
    let fitted_view = View {
        tilt_deg: p[TILT],
        roll_deg: p[ROLL],
    };
    let half = base_distance_m(model, p[TILT]) * frame.px_per_m;
    let o = ImagePoint::of_pixel(input.origin);
    let (centre, dir) = (frame.axis.centre, frame.axis.dir);
    let ends = [o + centre + dir * half, o + centre - dir * half];
    let range_m = match input.range_m {
        Some(r) => r,
        None => {
            1.0 / camera.normalized_length(frame.px_per_m, frame.axis.dir.perpendicular().into())
        }
    };
    // The parameters' covariance: the residual variance times the inverse normal matrix.
    let mut jtj = solution.jtj;
    // A parameter the image does not depend on (the scale where held, the roll without fins) is
    // held.
    for k in 0..PARAMS {
        if let Some(d) = jtj.get_mut((k, k)).filter(|d| **d <= 0.0) {
            *d = 1.0;
        }
    }
    let covariance = jtj
        .cholesky()
        .map(|c| c.inverse() * (solution.cost / (pixels as f32 - PARAMS as f32).max(1.0)));
    let var = |a: usize, b: usize| covariance.map_or(f32::NAN, |c| c[(a, b)]);
    let scale_sd = if problem.scale_held {
        0.0
    } else {
        libm::sqrtf(var(LOG_SCALE, LOG_SCALE).max(0.0))
    };
    // The length 2 half = L k cos(tilt): its derivatives in the tilt (deg) and the log scale.
    let d_tilt = -2.0 * half * libm::tanf(p[TILT] * crate::pose::RAD) * crate::pose::RAD;
    let d_scale = if problem.scale_held { 0.0 } else { 2.0 * half };
    let length_var = d_tilt * d_tilt * var(TILT, TILT)
        + d_scale * d_scale * var(LOG_SCALE, LOG_SCALE)
        + 2.0 * d_tilt * d_scale * var(TILT, LOG_SCALE);
    Ok(GreyFitted {
        ends,
        px_per_m: frame.px_per_m,
        range_m,
        scale_sd,
        length_sd_px: libm::sqrtf(length_var.max(0.0)),
        turn_sd_rad: libm::sqrtf(var(2, 2).max(0.0)),
        fins_seen,
        roll_sd_deg: if problem.has_fins {
            libm::sqrtf(var(ROLL, ROLL).max(0.0))
        } else {
            f32::NAN
        },
        view: fitted_view,
        sigma_px: p[SIGMA],
        shading: [p[SHADING], p[SHADING + 1], p[SHADING + 2]],
        glow: [
            p[GLOW],
            p[GLOW_FRONT],
            model.diameter_m * libm::expf(p[GLOW + 1]),
            model.diameter_m * libm::expf(p[GLOW + 2]),
        ],
        rms: libm::sqrtf(solution.cost / pixels as f32),
        pixels: pixels as u32,
        iterations: solution.iterations,
    })
}

#[cfg(test)]
mod tests {
    use super::outline::NOSE_AWAY;
    use super::*;
    use crate::model::testing::reference;

    const SIDE: usize = 160;

    /// A chip of the reference body drawn by this module's own image model at `truth`: an
    /// opaque body of radiance `800 + 30 w - 20 w²` over the sky `sky` (at a chip point), its
    /// fins shaded as `fins` says, with a plume's glow next to the base (`glow`: the peaks
    /// hidden and in front, grey levels, and the sigmas along and across, m) and Gaussian noise
    /// of `noise` grey levels.
    fn chip_on(
        truth: &FitStart,
        sky: impl Fn(f32, f32) -> f32,
        fins: Fins,
        glow: [f32; 4],
        noise: f32,
    ) -> [u16; SIDE * SIDE] {
        let model = reference();
        let outline = Outline::<512>::build(&model, &truth.view, 400, fins).unwrap();
        let frame = Frame {
            axis: Axis {
                centre: truth.placement.origin,
                dir: truth.placement.dir,
            },
            px_per_m: truth.placement.px_per_unit,
        };
        let base_u_m = -base_distance_m(&model, truth.view.tilt_deg);
        let mut noise_values = crate::testing::noise_sequence(SIDE * SIDE, 7);
        let mut data = [0u16; SIDE * SIDE];
        for (i, px) in data.iter_mut().enumerate() {
            let (x, y) = ((i % SIDE) as f32, (i / SIDE) as f32);
            let (u, v) = frame.local(x, y);
            let b = appearance::body_basis(&outline, u, v, truth.sigma_px / frame.px_per_m);
            let g = glow::glow_image([glow[2], glow[3]], base_u_m, u, v).shape;
            let behind = sky(x, y) + glow[0] * g;
            let value =
                behind * (1.0 - b[0]) + 800.0 * b[0] + 30.0 * b[1] - 20.0 * b[2] + glow[1] * g;
            *px = (value + noise * noise_values.next().unwrap_or(0.0)) as u16;
        }
        data
    }

    /// [`chip_on`] a uniform sky of 1000, the fins' faces of a body pointing away.
    fn chip_of(truth: &FitStart, glow: [f32; 4], noise: f32) -> [u16; SIDE * SIDE] {
        chip_on(truth, |_, _| 1000.0, NOSE_AWAY, glow, noise)
    }

    /// The test chips' camera: 100,000 px focal length, the chip's centre on the axis.
    fn camera() -> Camera {
        Camera {
            fx: 100_000.0,
            fy: 100_000.0,
            cx: 80.0,
            cy: 80.0,
        }
    }

    /// The detection's sky model of `chip`.
    fn sky_of(chip: &ChipView) -> Background {
        let mut background = Background::new();
        background.estimate(chip);
        background
    }

    fn truth() -> FitStart {
        let angle = 0.5f32;
        FitStart {
            placement: Placement {
                origin: ImagePoint::new(80.3, 79.6),
                dir: ImagePoint::new(libm::cosf(angle), libm::sinf(angle)),
                // A 5-px diameter.
                px_per_unit: 62.5,
            },
            view: View {
                tilt_deg: 25.0,
                roll_deg: 20.0,
            },
            sigma_px: 0.8,
            contrast: -200.0,
        }
    }

    /// A start off `truth`: 0.6 px off its origin, its scale times `scale`, 5 deg off in tilt
    /// and roll, 0.2 px off in blur, with a quarter less contrast.
    fn start_off(truth: &FitStart, scale: f32) -> FitStart {
        FitStart {
            placement: Placement {
                origin: truth.placement.origin + ImagePoint::new(0.6, -0.4),
                px_per_unit: truth.placement.px_per_unit * scale,
                ..truth.placement
            },
            view: View {
                tilt_deg: 20.0,
                roll_deg: 25.0,
            },
            sigma_px: 1.0,
            contrast: -150.0,
        }
    }

    /// The reference fitted from `start` to `chip` (sky `background`) with the range known at
    /// the scale `px_per_m`, where the sky is cluttered and the velocity's tilt is
    /// `flight_tilt_deg`.
    fn fit_in_clutter(
        chip: &ChipView,
        background: &Background,
        start: &FitStart,
        px_per_m: f32,
        flight_tilt_deg: Option<f32>,
    ) -> Result<GreyFitted, GreyFitError> {
        let input = FitInput {
            chip,
            background,
            origin: (0, 0),
            range_m: Some(100_000.0 / px_per_m),
            range_sensed: true,
            nose_towards: None,
            plume_at_tail: false,
            cluttered_sky: true,
            flight_tilt_deg,
        };
        let config = GreyFitConfig::DEFAULT;
        fit::<512>(&input, start, &reference(), &camera(), &config)
    }

    /// From a start 0.6 px off, 4 % off in scale, 5 deg off in tilt and roll and 0.2 px off
    /// in blur, the fit finds the image it was drawn from (the fit's own model: a check of the
    /// solver and the derivatives, not of the physics).
    #[test]
    fn the_fit_recovers_the_pose_its_own_image_was_drawn_at() {
        let truth = truth();
        let data = chip_of(&truth, [0.0, 0.0, 1.0, 1.0], 2.0);
        let chip = ChipView::gray16(&data, SIDE, SIDE, SIDE, 0, 0).unwrap();
        let background = sky_of(&chip);
        let start = start_off(&truth, 1.04);
        let input = FitInput {
            chip: &chip,
            background: &background,
            origin: (0, 0),
            range_m: None,
            range_sensed: false,
            nose_towards: None,
            plume_at_tail: false,
            cluttered_sky: false,
            flight_tilt_deg: None,
        };
        let camera = camera();
        let model = reference();
        let config = GreyFitConfig {
            wide_body_sigmas: 0.0,
            ..GreyFitConfig::DEFAULT
        };
        let fitted = fit::<512>(&input, &start, &model, &camera, &config).unwrap();
        let scale = fitted.px_per_m / truth.placement.px_per_unit - 1.0;
        assert!(scale.abs() < 2e-3, "scale off by {scale}: {fitted:?}");
        assert!((fitted.view.tilt_deg - 25.0).abs() < 0.5, "{fitted:?}");
        assert!((fitted.sigma_px - 0.8).abs() < 0.03, "{fitted:?}");
        let half = base_distance_m(&model, 25.0) * 62.5;
        let nose = truth.placement.origin + truth.placement.dir * half;
        let miss = (fitted.ends[0] - nose).norm();
        assert!(miss < 0.1, "nose {miss} px off: {fitted:?}");
    }

    /// The same body lit from one side (its radiance `800 + 30 w - 20 w²`), its nose towards
    /// the camera, the range known: its fins turn their other faces to the camera, 20-56 grey
    /// levels apart from the nose-away body's at 2 of noise. Told which way the nose points, or
    /// left to try both, the fit reads the roll within 0.2 deg (0.05); told the wrong way, the
    /// fins' brightness turns the roll 1.9 deg off.
    #[test]
    fn the_fins_faces_tell_the_roll_for_the_nose_towards_the_camera() {
        let truth = truth();
        let towards = Fins::Faces { nose_towards: true };
        let data = chip_on(&truth, |_, _| 1000.0, towards, [0.0, 0.0, 1.0, 1.0], 2.0);
        let chip = ChipView::gray16(&data, SIDE, SIDE, SIDE, 0, 0).unwrap();
        let background = sky_of(&chip);
        let start = start_off(&truth, 1.0);
        let roll_off = |nose_towards: Option<bool>| {
            let input = FitInput {
                chip: &chip,
                background: &background,
                origin: (0, 0),
                range_m: Some(100_000.0 / truth.placement.px_per_unit),
                range_sensed: true,
                nose_towards,
                plume_at_tail: false,
                cluttered_sky: false,
                flight_tilt_deg: None,
            };
            let config = GreyFitConfig::DEFAULT;
            let fitted = fit::<512>(&input, &start, &reference(), &camera(), &config).unwrap();
            libm::fabsf(fitted.view.roll_deg - truth.view.roll_deg)
        };
        let (told, both, wrong) = (roll_off(Some(true)), roll_off(None), roll_off(Some(false)));
        assert!(told < 0.2 && both < 0.2, "{told} {both}");
        assert!(wrong > 1.0, "{wrong}");
    }

    /// A body wide enough for the glow (8 px across, blur 0.5 px) with a plume glowing next to
    /// its base, the range known: from a start 0.6 px off, 4 deg off in tilt and roll and with
    /// no glow, the fit places both ends within 0.1 px and finds the glow's peaks within half
    /// (the fit's own model again; what the glow is worth on a rendered plume,
    /// `tests/any_projectile.rs`).
    #[test]
    fn the_fit_finds_the_tail_under_a_plume_glow() {
        let truth = FitStart {
            placement: Placement {
                px_per_unit: 100.0,
                ..truth().placement
            },
            sigma_px: 0.5,
            ..truth()
        };
        let d = reference().diameter_m;
        let glow = [150.0, 40.0, 0.6 * d, 0.4 * d];
        let data = chip_of(&truth, glow, 2.0);
        let chip = ChipView::gray16(&data, SIDE, SIDE, SIDE, 0, 0).unwrap();
        let background = sky_of(&chip);
        let start = FitStart {
            placement: Placement {
                origin: truth.placement.origin + ImagePoint::new(0.6, -0.4),
                ..truth.placement
            },
            view: View {
                tilt_deg: 21.0,
                roll_deg: 24.0,
            },
            sigma_px: 0.6,
            contrast: -150.0,
        };
        let camera = camera();
        let range_m = 100_000.0 / truth.placement.px_per_unit;
        let input = FitInput {
            chip: &chip,
            background: &background,
            origin: (0, 0),
            range_m: Some(range_m),
            range_sensed: true,
            nose_towards: None,
            plume_at_tail: true,
            cluttered_sky: false,
            flight_tilt_deg: None,
        };
        let model = reference();
        let fitted = fit::<512>(&input, &start, &model, &camera, &GreyFitConfig::DEFAULT).unwrap();
        let half = base_distance_m(&model, 25.0) * 100.0;
        let o = truth.placement.origin;
        let ends = [
            o + truth.placement.dir * half,
            o - truth.placement.dir * half,
        ];
        for (fitted_end, end) in fitted.ends.iter().zip(ends) {
            let miss = (*fitted_end - end).norm();
            assert!(miss < 0.2, "an end {miss} px off: {fitted:?}");
        }
        assert!((fitted.view.tilt_deg - 25.0).abs() < 0.3, "{fitted:?}");
        // The peaks show only through the base's blurred edge (the window stops a blur sigma
        // beyond it): found, loosely.
        assert!((fitted.glow[0] / glow[0] - 1.0).abs() < 0.5, "{fitted:?}");
        assert!((fitted.glow[1] / glow[1] - 1.0).abs() < 0.5, "{fitted:?}");
    }

    /// A faint body against a sky that changes along it: a cloud's edge across its middle, the
    /// sky 1000 behind the tail and 700 behind the nose, and sloping across the body by 4 grey
    /// levels a px. The body's radiance, 800 + shading, is darker than the sky behind the tail
    /// and brighter than the sky behind the nose: its contrast changes sign along it. From a
    /// start 0.6 px off and 5 deg off in tilt, the fit places both ends within 0.25 px (the
    /// fit's own model of an opaque body: what it is worth on rendered clutter,
    /// `tests/clutter.rs`; the larger miss here is 0.20 px).
    #[test]
    fn the_fit_reads_an_opaque_body_against_the_sky_behind_it() {
        let truth = truth();
        let (o, dir) = (truth.placement.origin, truth.placement.dir);
        let sky = |x: f32, y: f32| {
            let along = (x - o.x) * dir.x + (y - o.y) * dir.y;
            let across = -(x - o.x) * dir.y + (y - o.y) * dir.x;
            1000.0 - 300.0 / (1.0 + libm::expf(-along / 4.0)) + 4.0 * across
        };
        let data = chip_on(&truth, sky, NOSE_AWAY, [0.0, 0.0, 1.0, 1.0], 4.0);
        let chip = ChipView::gray16(&data, SIDE, SIDE, SIDE, 0, 0).unwrap();
        let background = sky_of(&chip);
        let start = start_off(&truth, 1.0);
        let k = truth.placement.px_per_unit;
        let fitted = fit_in_clutter(&chip, &background, &start, k, None).unwrap();
        let half = base_distance_m(&reference(), 25.0) * k;
        for (fitted_end, end) in fitted.ends.iter().zip([o + dir * half, o - dir * half]) {
            let miss = (*fitted_end - end).norm();
            assert!(miss < 0.25, "an end {miss} px off: {fitted:?}");
        }
    }

    /// The same body and sky, started with the tail where it is but the body tilted 60 deg out
    /// of the image plane instead of 25 (a faint nose lost among clouds: the start half as long
    /// as the body): given the velocity's tilt, 27 deg (2 deg of angle of attack), the fit places
    /// both ends within 0.2 px; without it, it stays more than a pixel short.
    #[test]
    fn the_velocitys_tilt_gives_a_start_short_at_the_nose_its_length() {
        let truth = truth();
        let (o, dir) = (truth.placement.origin, truth.placement.dir);
        let sky = |x: f32, y: f32| {
            let along = (x - o.x) * dir.x + (y - o.y) * dir.y;
            1000.0 - 300.0 / (1.0 + libm::expf(-along / 4.0))
        };
        let data = chip_on(&truth, sky, NOSE_AWAY, [0.0, 0.0, 1.0, 1.0], 4.0);
        let chip = ChipView::gray16(&data, SIDE, SIDE, SIDE, 0, 0).unwrap();
        let background = sky_of(&chip);
        let model = reference();
        let k = truth.placement.px_per_unit;
        let tail_at = |tilt_deg: f32| {
            let view = View {
                tilt_deg,
                ..truth.view
            };
            -crate::lut::render::u_extent(&model, &view).0 * k
        };
        let tail = o - dir * tail_at(25.0);
        let start = FitStart {
            placement: Placement {
                origin: tail + dir * tail_at(60.0),
                ..truth.placement
            },
            view: View {
                tilt_deg: 60.0,
                ..truth.view
            },
            ..start_off(&truth, 1.0)
        };
        let half = base_distance_m(&model, 25.0) * k;
        let ends = [o + dir * half, o - dir * half];
        let worst_miss = |flight_tilt_deg: Option<f32>| {
            let fitted = fit_in_clutter(&chip, &background, &start, k, flight_tilt_deg);
            fitted.map_or(f32::INFINITY, |f| {
                f.ends
                    .iter()
                    .zip(ends)
                    .map(|(a, b)| (*a - b).norm())
                    .fold(0.0, f32::max)
            })
        };
        let (with, without) = (worst_miss(Some(27.0)), worst_miss(None));
        assert!(with < 0.2, "an end {with} px off");
        assert!(
            without > 1.0,
            "without the velocity's tilt an end only {without} px off"
        );
    }

    /// A body near broadside (5 deg out of the image plane) whose ends, a fifth of its length
    /// each, lie against clouds as bright as itself, so that its length, and the tilt with it,
    /// hardly show: given the velocity's tilt, 7 deg (2 deg of angle of attack), the fitted tilt
    /// is within 1.5 deg of it; the image alone leaves it more than 5 deg off the truth.
    #[test]
    fn the_velocitys_tilt_holds_a_body_whose_ends_do_not_show() {
        let truth = FitStart {
            view: View {
                tilt_deg: 5.0,
                ..truth().view
            },
            ..truth()
        };
        let (o, dir) = (truth.placement.origin, truth.placement.dir);
        let model = reference();
        let k = truth.placement.px_per_unit;
        let cloud_from = 0.6 * base_distance_m(&model, 5.0) * k;
        let sky = |x: f32, y: f32| {
            let along = (x - o.x) * dir.x + (y - o.y) * dir.y;
            1000.0 - 200.0 / (1.0 + libm::expf(-(libm::fabsf(along) - cloud_from) / 1.5))
        };
        let data = chip_on(&truth, sky, NOSE_AWAY, [0.0, 0.0, 1.0, 1.0], 20.0);
        let chip = ChipView::gray16(&data, SIDE, SIDE, SIDE, 0, 0).unwrap();
        let background = sky_of(&chip);
        let start = FitStart {
            view: View {
                tilt_deg: 20.0,
                ..truth.view
            },
            ..truth
        };
        let tilt = |flight_tilt_deg: Option<f32>| {
            let fitted = fit_in_clutter(&chip, &background, &start, k, flight_tilt_deg);
            fitted.map_or(f32::NAN, |f| f.view.tilt_deg)
        };
        let (with, without) = (tilt(Some(7.0)), tilt(None));
        assert!(
            (with - 7.0).abs() < 1.5,
            "tilt {with} deg with the velocity's 7"
        );
        assert!((without - 5.0).abs() > 5.0, "tilt {without} deg without it");
    }
}
