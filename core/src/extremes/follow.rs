//! A faint body followed outwards past where its width profile ends, stretch by stretch, by its
//! own cross-section.
//!
//! A body's contrast is its radiance against what lies behind it. Where a cloud darkens the sky
//! behind a dark body, its contrast falls (to a third in the simulator's clutter scenes), and the
//! width profile, which divides by the contrast of the body's middle, reads that stretch as
//! narrower than half a diameter and ends the body there: a nose lost in a cloud leaves a body
//! read at a third of its length, and a pose tilted far out of the image plane. A cross-section
//! fitted on a stretch just beyond the end, of the body's diameter, on its axis and standing out
//! of the noise, says the body goes on; its contrast there says where its half-width edge lies.

use super::Axis;
use super::cross_profile::{self, CrossSection, DiameterBounds, Stretch};
use crate::chip::ChipView;
use crate::config::BodyPolarity;
use crate::segment::background::Background;
use crate::segment::select::Shape;

/// The follow's tunables.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FollowConfig {
    /// Length of a stretch, in body diameters.
    pub stretch_diameters: f32,
    /// A stretch is the body's where its fitted diameter is within this factor of the body's,
    /// ...
    pub diameter_tolerance: f32,
    /// ... its axis within this fraction of a diameter of the body's, ...
    pub max_offset_diameters: f32,
    /// ... its contrast at least this fraction of the body's middle's ...
    pub min_contrast_fraction: f32,
    /// ... and, summed over the body's pixels in the stretch, at least this many noise sigmas.
    pub min_sigma: f32,
}

impl FollowConfig {
    /// The defaults.
    pub const DEFAULT: FollowConfig = FollowConfig {
        stretch_diameters: 2.0,
        diameter_tolerance: 1.4,
        max_offset_diameters: 0.5,
        min_contrast_fraction: 0.15,
        min_sigma: 5.0,
    };
}

impl Default for FollowConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// How far a body was followed beyond an end.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Followed {
    /// The outer end of the last stretch that was the body's, px along the axis.
    pub outer_t: f32,
    /// That stretch's contrast as a fraction of the body's middle's.
    pub contrast_fraction: f32,
}

/// What a body is followed with: where, what its middle looks like, and how.
pub struct Follower<'a> {
    /// The chip and its sky.
    pub chip: &'a ChipView<'a>,
    /// The sky model.
    pub background: &'a Background,
    /// The body's axis.
    pub axis: &'a Axis,
    /// The body's polarity.
    pub polarity: BodyPolarity,
    /// The cross-section of its middle.
    pub middle: &'a CrossSection,
    /// Half the extent across the axis of a stretch's profile, px.
    pub half_width: f32,
    /// The tunables.
    pub config: &'a FollowConfig,
}

impl Follower<'_> {
    /// The body followed from `end_t` (px along the axis) outwards (`outward` +1 or -1), no
    /// farther than `limit_px` beyond it; None where the first stretch is not the body's.
    pub fn follow(&self, end_t: f32, outward: f32, limit_px: f32) -> Option<Followed> {
        let Follower {
            chip,
            background,
            axis,
            polarity,
            middle,
            half_width,
            config,
        } = *self;
        let d = middle.diameter_px;
        let step = config.stretch_diameters * d;
        if !(step >= 1.0 && limit_px.is_finite() && middle.contrast > 0.0) {
            return None;
        }
        let shape = Shape {
            centre: axis.centre,
            axis: axis.dir,
            major_sd: 0.0,
            minor_sd: 0.0,
        };
        // Fitted within the tolerance squared, so that a stretch that fits wider or narrower
        // shows as such rather than at the bound.
        let tolerance = config.diameter_tolerance;
        let bounds = DiameterBounds {
            min_px: d / (tolerance * tolerance),
            max_px: d * tolerance * tolerance,
        };
        let noise = background.sigma().max(1e-3);
        let mut followed: Option<Followed> = None;
        let mut previous: Option<f32> = None;
        let mut t = end_t;
        // At most a stretch per diameter of the chip's diagonal: the limit is finite but
        // may be large.
        for _ in 0..((limit_px / step) as usize).min(MAX_STRETCHES) {
            let next = t + outward * step;
            let stretch = Stretch {
                t0: t.min(next),
                t1: t.max(next),
            };
            let Some(section) = cross_profile::fit(
                chip,
                background,
                &shape,
                polarity,
                stretch,
                half_width,
                Some(bounds),
            ) else {
                break;
            };
            let fraction = section.contrast / middle.contrast;
            let significance = section.contrast * libm::sqrtf(step * d) / noise;
            let on_axis = libm::fabsf(section.offset_px) <= config.max_offset_diameters * d;
            let of_body = section.diameter_px >= d / tolerance
                && section.diameter_px <= d * tolerance
                && on_axis
                && fraction >= config.min_contrast_fraction
                && significance >= config.min_sigma;
            if !of_body {
                break;
            }
            t = next;
            // The last stretch may reach past the body's end, and read its contrast low: the
            // one before it, wholly on the body, tells the contrast there.
            followed = Some(Followed {
                outer_t: t,
                contrast_fraction: previous.unwrap_or(fraction).min(1.0),
            });
            previous = Some(fraction);
        }
        followed
    }
}

/// Most stretches followed from one end.
const MAX_STRETCHES: usize = 64;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::point::ImagePoint;
    use crate::testing::noise_sequence;

    const SIDE: usize = 192;

    /// A sky of 120 grey levels with noise 3 and a dark body 7 px wide along the middle row from
    /// x = 40 to 150: 12 grey levels dark up to x = 95, `far` beyond (the sky behind it darker).
    fn chip_with_far_half(far: f32) -> [u8; SIDE * SIDE] {
        let mut noise = noise_sequence(SIDE * SIDE, 3);
        let mut data = [0u8; SIDE * SIDE];
        for (i, v) in data.iter_mut().enumerate() {
            let (x, y) = (i % SIDE, i / SIDE);
            let on_body = (93..100).contains(&y) && (40..150).contains(&x);
            let dark = match (on_body, x < 95) {
                (false, _) => 0.0,
                (true, true) => 12.0,
                (true, false) => far,
            };
            *v = (120.0 - dark + 3.0 * noise.next().unwrap_or(0.0)).clamp(0.0, 255.0) as u8;
        }
        data
    }

    /// Follows the body of `data` from x = 95 towards +x, with 100 px to spare.
    fn follow_far_half(data: &[u8; SIDE * SIDE]) -> Option<Followed> {
        let chip = ChipView::gray8(data, SIDE, SIDE, SIDE, 0, 0).unwrap();
        let mut background = Background::new();
        background.estimate(&chip);
        let axis = Axis {
            centre: ImagePoint::new(95.0, 96.0),
            dir: ImagePoint::new(1.0, 0.0),
        };
        let middle = CrossSection {
            diameter_px: 7.0,
            contrast: 12.0,
            shading: 0.0,
            sigma_px: 0.5,
            offset_px: 0.0,
            pixels: 0,
        };
        let follower = Follower {
            chip: &chip,
            background: &background,
            axis: &axis,
            polarity: BodyPolarity::Dark,
            middle: &middle,
            half_width: 12.0,
            config: &FollowConfig::DEFAULT,
        };
        follower.follow(0.0, 1.0, 100.0)
    }

    /// The far half at a third of the contrast (1.3 noise sigmas a pixel) is followed to its
    /// end at x = 150 (55 px out), within a stretch (14 px), at about its contrast.
    #[test]
    fn a_body_fading_against_a_darker_sky_is_followed_to_its_end() {
        let followed = follow_far_half(&chip_with_far_half(4.0)).expect("followed");
        assert!(
            (55.0..=55.0 + 14.0).contains(&followed.outer_t),
            "{followed:?}"
        );
        assert!(
            (0.2..=0.5).contains(&followed.contrast_fraction),
            "{followed:?}"
        );
    }

    /// Where the body ends (nothing beyond x = 95), nothing is followed.
    #[test]
    fn sky_beyond_an_end_is_not_followed() {
        assert_eq!(follow_far_half(&chip_with_far_half(0.0)), None);
    }
}
