//! Target selection: which component is the projectile, not the exhaust plume or clutter, and
//! which other components are fragments of its broken silhouette.

use super::label::Moments;
use crate::capacity::{MAX_COMPONENTS, MAX_TARGET_PARTS};
use crate::config::BodyPolarity;
use crate::extremes::Axis;
use crate::point::ImagePoint;

/// A candidate component: its root label and statistics.
#[derive(Debug, Clone, Copy)]
pub struct Candidate {
    /// Root label in the labeler.
    pub label: u16,
    /// Statistics.
    pub moments: Moments,
}

/// Shape figures of a component derived from its second moments.
#[derive(Debug, Clone, Copy)]
pub struct Shape {
    /// Centroid, chip px.
    pub centre: ImagePoint,
    /// Unit vector of the major axis.
    pub axis: ImagePoint,
    /// Standard deviation along the major axis, px.
    pub major_sd: f32,
    /// Standard deviation across it, px.
    pub minor_sd: f32,
}

/// How far a set of moments spreads along and across its major axis: [`Shape`] without the
/// centroid and the axis, whose trigonometry (`atan2f`, `cosf`, `sinf`: `f64` inside libm,
/// software floating point on the Cortex-M4F) the size tests on every candidate do not need.
#[derive(Debug, Clone, Copy)]
pub struct Spread {
    /// Standard deviation along the major axis, px.
    pub major_sd: f32,
    /// Standard deviation across it, px.
    pub minor_sd: f32,
}

impl Spread {
    /// The spread of a set of moments.
    pub fn of(m: &Moments) -> Spread {
        Self::of_covariance(m.covariance())
    }

    /// The spread of central second moments `(xx, yy, xy)`, px².
    fn of_covariance((xx, yy, xy): (f32, f32, f32)) -> Spread {
        let half_diff = 0.5 * (xx - yy);
        let root = libm::sqrtf(half_diff * half_diff + xy * xy);
        let mean = 0.5 * (xx + yy);
        Spread {
            major_sd: libm::sqrtf((mean + root).max(0.0)),
            minor_sd: libm::sqrtf((mean - root).max(1.0 / 12.0)),
        }
    }

    /// Major over minor standard deviation (1 for a disc).
    pub fn elongation(&self) -> f32 {
        self.major_sd / self.minor_sd.max(1e-3)
    }
}

impl Shape {
    /// The shape of a set of moments.
    pub fn of(m: &Moments) -> Shape {
        let (xx, yy, xy) = m.covariance();
        let Spread { major_sd, minor_sd } = Spread::of_covariance((xx, yy, xy));
        let angle = 0.5 * libm::atan2f(2.0 * xy, xx - yy);
        Shape {
            centre: m.centroid(),
            axis: ImagePoint::new(libm::cosf(angle), libm::sinf(angle)),
            major_sd,
            minor_sd,
        }
    }

    /// Major over minor standard deviation (1 for a disc).
    pub fn elongation(&self) -> f32 {
        Spread {
            major_sd: self.major_sd,
            minor_sd: self.minor_sd,
        }
        .elongation()
    }

    /// How far it reaches from its centroid along unit vector `dir`, px: the half-length of
    /// a uniform ellipse of its second moments in that direction.
    pub fn reach_along(&self, dir: ImagePoint) -> f32 {
        let (along, across) = (
            self.axis.dot(dir) * self.major_sd,
            self.axis.perpendicular().dot(dir) * self.minor_sd,
        );
        UNIFORM_BAR_HALF_SDS * libm::sqrtf(along * along + across * across)
    }

    /// The major axis as a line through the centroid.
    pub fn line(&self) -> Axis {
        Axis {
            centre: self.centre,
            dir: self.axis,
        }
    }
}

/// The body's expected size in the chip, from the model, the camera and a range (the range
/// sensor's or the track's): what a candidate must look like to be the projectile.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ExpectedBody {
    /// Body diameter, px.
    pub diameter_px: f32,
    /// Largest width, fins included, px.
    pub span_px: f32,
    /// Overall length seen broadside (the longest it can look), px.
    pub length_px: f32,
}

/// The body's shape in diameters: its size in the chip at any scale.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Proportions {
    /// Largest width, fins included, in body diameters.
    pub span_diameters: f32,
    /// Overall length, in body diameters.
    pub length_diameters: f32,
}

impl Proportions {
    /// The body's size in the chip where its diameter is `diameter_px`.
    pub fn at(&self, diameter_px: f32) -> ExpectedBody {
        ExpectedBody {
            diameter_px,
            span_px: self.span_diameters * diameter_px,
            length_px: self.length_diameters * diameter_px,
        }
    }
}

/// How far a candidate's size may stray from the expected body's and still be it.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SizeTolerance {
    /// Narrowest: this fraction of the body diameter.
    pub min_width: f32,
    /// Widest: this fraction of the span (fins included) ...
    pub max_width: f32,
    /// Longest: this fraction of the broadside length ...
    pub max_length: f32,
    /// ... each plus this many px (the blur and the threshold's reach beyond the edge).
    pub margin_px: f32,
}

impl ExpectedBody {
    /// Whether a component of these `moments` has the body's size, within `tolerance`: its
    /// width and length are those of a uniform bar with its standard deviations.
    pub fn fits(&self, moments: &Moments, tolerance: &SizeTolerance) -> bool {
        let spread = Spread::of(moments);
        let width = 2.0 * UNIFORM_BAR_HALF_SDS * spread.minor_sd;
        let length = 2.0 * UNIFORM_BAR_HALF_SDS * spread.major_sd;
        width >= tolerance.min_width * self.diameter_px
            && width <= tolerance.max_width * self.span_px + tolerance.margin_px
            && length <= tolerance.max_length * self.length_px + tolerance.margin_px
    }
}

impl ExpectedBody {
    /// How well a component's width agrees with the body's, for the selection's score: 0 at
    /// the body's diameter plus `margin_px` (the blur and the threshold's reach beyond the
    /// edge), falling with the square of the log of the ratio, `weight` per unit of it.
    pub fn width_agreement(&self, moments: &Moments, margin_px: f32, weight: f32) -> f32 {
        let width = 2.0 * UNIFORM_BAR_HALF_SDS * Spread::of(moments).minor_sd;
        let ratio = libm::logf(width.max(1e-3) / (self.diameter_px + margin_px).max(1e-3));
        -weight * ratio * ratio
    }
}

/// A uniform bar's half-length (or half-width) in standard deviations of its mask: sqrt 3.
pub const UNIFORM_BAR_HALF_SDS: f32 = 1.732;

/// The selected target: its parts and their combined statistics.
#[derive(Debug, Clone)]
pub struct Selection {
    /// Root labels of the parts (the main component first).
    pub parts: heapless::Vec<u16, MAX_TARGET_PARTS>,
    /// Combined statistics.
    pub moments: Moments,
}

/// Score of a candidate: significance (|sum of residuals| over noise), elongation, and nearness
/// to the aim point. Larger is better.
fn score(c: &Candidate, sigma: f32, aim: ImagePoint, chip_diag: f32) -> f32 {
    let m = &c.moments;
    let significance = m.sum_residual.abs() / (sigma.max(1e-3) * libm::sqrtf(m.n as f32));
    significance_and_nearness(significance, m.centroid(), aim, chip_diag)
        + 0.5 * libm::logf(Spread::of(m).elongation())
}

/// The selection's score terms of a candidate of `significance` (noise sigmas) centred at
/// `centre`: the log of its significance, less the square of its distance from `aim` in chip
/// diagonals (`chip_diag` px) times 4 (the tracker keeps the body near the chip's centre).
pub fn significance_and_nearness(
    significance: f32,
    centre: ImagePoint,
    aim: ImagePoint,
    chip_diag: f32,
) -> f32 {
    let (dx, dy) = (centre.x - aim.x, centre.y - aim.y);
    let distance = libm::sqrtf(dx * dx + dy * dy) / chip_diag.max(1.0);
    libm::logf(1.0 + significance) - 4.0 * distance * distance
}

/// Whether candidate `c` should be preferred over `other` as the body, by polarity.
fn more_body_like(c: &Candidate, other: &Candidate, polarity: Option<BodyPolarity>) -> bool {
    match polarity {
        Some(BodyPolarity::Dark) => c.moments.mean_value() < other.moments.mean_value(),
        Some(BodyPolarity::Bright) => c.moments.mean_value() > other.moments.mean_value(),
        None => Spread::of(&c.moments).elongation() > Spread::of(&other.moments).elongation(),
    }
}

/// True when two components lie close together: the gap between their boxes is within
/// `gap` px.
fn adjacent(a: &Moments, b: &Moments, gap: f32) -> bool {
    let dx = (f32::from(a.bbox.x0) - f32::from(b.bbox.x1))
        .max(f32::from(b.bbox.x0) - f32::from(a.bbox.x1))
        .max(0.0);
    let dy = (f32::from(a.bbox.y0) - f32::from(b.bbox.y1))
        .max(f32::from(b.bbox.y0) - f32::from(a.bbox.y1))
        .max(0.0);
    dx * dx + dy * dy <= gap * gap
}

/// Selects the projectile among the `candidates` (at most [`MAX_COMPONENTS`]) that `judge`
/// takes: it gives a candidate's bonus to its score, or None to leave it out.
///
/// The two best-scoring candidates are compared as in the source paper (Section 5.2.2): when they
/// lie close together (the plume trails the tail), the one whose mean intensity fits the body's
/// polarity wins (the darker one for a dark body). Components of the winner's polarity lying
/// along its axis, with a gap to it of at most half its length, are merged as fragments.
pub fn select(
    candidates: &heapless::Vec<Candidate, MAX_COMPONENTS>,
    sigma: f32,
    aim: ImagePoint,
    chip_diag: f32,
    polarity: Option<BodyPolarity>,
    judge: impl Fn(&Moments) -> Option<f32>,
) -> Option<Selection> {
    let mut best: Option<(f32, &Candidate)> = None;
    let mut second: Option<(f32, &Candidate)> = None;
    for (c, bonus) in candidates
        .iter()
        .filter_map(|c| judge(&c.moments).map(|b| (c, b)))
    {
        let s = score(c, sigma, aim, chip_diag) + bonus;
        if best.is_none_or(|(b, _)| s > b) {
            second = best;
            best = Some((s, c));
        } else if second.is_none_or(|(b, _)| s > b) {
            second = Some((s, c));
        }
    }
    let (_, mut main) = best?;
    if let Some((_, other)) = second {
        let reach = 2.0
            * Spread::of(&main.moments)
                .major_sd
                .max(Spread::of(&other.moments).major_sd);
        if adjacent(&main.moments, &other.moments, reach) && more_body_like(other, main, polarity) {
            main = other;
        }
    }
    let mut selection = Selection {
        parts: heapless::Vec::new(),
        moments: main.moments,
    };
    // `parts` has room for MAX_TARGET_PARTS >= 1 labels.
    let _ = selection.parts.push(main.label);
    let shape = Shape::of(&main.moments);
    let half_length = UNIFORM_BAR_HALF_SDS * shape.major_sd;
    for c in candidates.iter() {
        if c.label == main.label || c.moments.class != main.moments.class {
            continue;
        }
        let centroid = c.moments.centroid();
        let (along, across) = shape.line().local(centroid.x, centroid.y);
        let lateral_limit = (3.0 * shape.minor_sd).max(2.0);
        // The gap between the two pieces' extents along the axis.
        let fragment_half_length = UNIFORM_BAR_HALF_SDS * Spread::of(&c.moments).major_sd;
        let gap = along.abs() - half_length - fragment_half_length;
        let on_axis = across.abs() <= lateral_limit && gap <= half_length.max(6.0);
        if on_axis && selection.parts.push(c.label).is_ok() {
            selection.moments.merge(&c.moments);
        }
    }
    Some(selection)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bar of 6 x 2 pixels (x 20..=25 on rows 10 and 11): as a uniform bar, its standard
    /// deviations are sqrt(3) along (variance (6² - 1) / 12 plus a pixel's 1/12) and
    /// sqrt(1/3) across ((2² - 1) / 12 + 1/12), so that the bar's half-sds give back its 6 px
    /// length and 2 px width.
    #[test]
    fn a_bar_spreads_as_its_pixels_and_lies_along_x() {
        let mut bar = Moments::empty(-1);
        for y in [10, 11] {
            bar.add_run(y, 20, 25, 0.0, 0);
        }
        let spread = Spread::of(&bar);
        assert!((spread.major_sd - libm::sqrtf(3.0)).abs() < 1e-5);
        assert!((spread.minor_sd - libm::sqrtf(1.0 / 3.0)).abs() < 1e-5);
        assert!((spread.elongation() - 3.0).abs() < 1e-4);
        assert!((2.0 * UNIFORM_BAR_HALF_SDS * spread.major_sd - 6.0).abs() < 1e-3);
        assert!((2.0 * UNIFORM_BAR_HALF_SDS * spread.minor_sd - 2.0).abs() < 1e-3);
        // The shape adds the centroid and the axis to the same spread.
        let shape = Shape::of(&bar);
        assert_eq!(
            (shape.major_sd, shape.minor_sd),
            (spread.major_sd, spread.minor_sd)
        );
        assert!((shape.centre.x - 22.5).abs() < 1e-5 && (shape.centre.y - 10.5).abs() < 1e-5);
        assert!((shape.axis.x.abs() - 1.0).abs() < 1e-6 && shape.axis.y.abs() < 1e-6);
    }
}
