//! The pipeline's configuration: one section per stage, each defined beside its stage with every
//! tunable and its documented default, gathered here with the one setting that is the
//! pipeline's own (how a range measurement is used).

pub use crate::extremes::SilhouetteConfig;
pub use crate::grey_fit::GreyFitConfig;
pub use crate::range_filter::RangeFilterConfig;
pub use crate::segment::{DetectConfig, SizeTolerance};
pub use crate::table_match::{GuidedLoopConfig, GuidedMethod, MatchConfig};
pub use crate::temporal::{RangeSmoothing, TemporalConfig};
pub use crate::track::TrackConfig;
pub use crate::uncertainty::UncertaintyConfig;
pub use crate::world::WorldConfig;

/// Which contrast polarity the projectile's body has against the sky.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BodyPolarity {
    /// Darker than the sky (a body against a bright sky; the source paper's case).
    Dark,
    /// Brighter than the sky (a sunlit body against a dark sky).
    Bright,
}

impl BodyPolarity {
    /// The sign of the body's contrast against the sky: -1 dark, +1 bright.
    pub fn sign(self) -> f32 {
        match self {
            BodyPolarity::Dark => -1.0,
            BodyPolarity::Bright => 1.0,
        }
    }
}

/// How a range measurement is used.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RangeUse {
    /// Fix the distance from the range where a frame has one, else measure it from the image.
    Auto,
    /// Always measure the distance from the image.
    Ignore,
}

/// Pipeline configuration, a section per stage. [`Config::DEFAULT`] holds the defaults.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// How a range measurement is used.
    pub range_use: RangeUse,
    /// Detection: sky model, threshold, components, target selection, the mask's cut.
    pub detect: DetectConfig,
    /// Silhouette: axis, ends and diameter.
    pub silhouette: SilhouetteConfig,
    /// Table match, shape prior and the shape-guided loop.
    pub table_match: MatchConfig,
    /// The grey-level fit after the table match.
    pub grey_fit: GreyFitConfig,
    /// Temporal estimate: range smoothing, range trend, yaw choice.
    pub temporal: TemporalConfig,
    /// The detection track: the gate on the next frame's candidates.
    pub track: TrackConfig,
    /// The pose's uncertainties: the ends' precision.
    pub uncertainty: UncertaintyConfig,
    /// The world frame, where a frame comes with the mount's pointing: the velocity's fit and
    /// the yaw choice it makes.
    pub world: WorldConfig,
}

impl Config {
    /// The defaults.
    pub const DEFAULT: Config = Config {
        range_use: RangeUse::Auto,
        detect: DetectConfig::DEFAULT,
        silhouette: SilhouetteConfig::DEFAULT,
        table_match: MatchConfig::DEFAULT,
        grey_fit: GreyFitConfig::DEFAULT,
        temporal: TemporalConfig::DEFAULT,
        track: TrackConfig::DEFAULT,
        uncertainty: UncertaintyConfig::DEFAULT,
        world: WorldConfig::DEFAULT,
    };
}

impl Config {
    /// This configuration with the shape-guided loop's `method` (None: no loop).
    pub const fn with_guided_method(mut self, method: Option<GuidedMethod>) -> Config {
        self.table_match.guided.method = method;
        self
    }
}

impl Default for Config {
    fn default() -> Self {
        Self::DEFAULT
    }
}
