//! The track's gate on detection's candidates: where the body should be in this chip, which way
//! it should lie and its polarity, from recent frames ([`crate::track`]).

use super::label::Moments;
use super::select::Shape;
use crate::config::BodyPolarity;
use crate::point::ImagePoint;

/// What the track admits in this frame's chip.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TrackGate {
    /// The body's predicted centre, chip px.
    pub centre: ImagePoint,
    /// Its axis in the last frames (either direction).
    pub axis: ImagePoint,
    /// How far from `centre` a candidate's centre may lie, px.
    pub radius_px: f32,
    /// The smallest |cosine| between a candidate's axis and `axis`.
    pub min_axis_cos: f32,
    /// The body's polarity in the last frames.
    pub polarity: BodyPolarity,
}

impl TrackGate {
    /// Whether a component of these `moments` is where the track expects the body, lying its
    /// way, of its polarity.
    pub fn admits(&self, moments: &Moments) -> bool {
        let shape = Shape::of(moments);
        let polarity = if moments.class > 0 {
            BodyPolarity::Bright
        } else {
            BodyPolarity::Dark
        };
        self.admits_line(shape.centre, shape.axis, polarity)
    }

    /// Whether a body centred at `centre` (chip px), lying along `axis`, of `polarity` is where
    /// the track expects it.
    pub fn admits_line(
        &self,
        centre: ImagePoint,
        axis: ImagePoint,
        polarity: BodyPolarity,
    ) -> bool {
        let (dx, dy) = (centre.x - self.centre.x, centre.y - self.centre.y);
        let near = dx * dx + dy * dy <= self.radius_px * self.radius_px;
        let aligned = libm::fabsf(axis.dot(self.axis)) >= self.min_axis_cos;
        near && aligned && self.polarity == polarity
    }
}

/// How detection used the track in a frame (the results' `track` column).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TrackUse {
    /// The best candidate was where the track expected it.
    Gated,
    /// The best candidate was not; the best one that was is the target.
    Reexamined,
    /// No track, or no candidate where it expected the body: detection started afresh.
    Fresh,
}

impl TrackUse {
    /// The results column's word.
    pub fn as_str(self) -> &'static str {
        match self {
            TrackUse::Gated => "gated",
            TrackUse::Reexamined => "reexamined",
            TrackUse::Fresh => "fresh",
        }
    }
}
