//! Every tunable of the pipeline, with its documented default.

/// Which contrast polarity the projectile's body has against the sky.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BodyPolarity {
    /// Darker than the sky (a body against a bright sky; the source paper's case).
    Dark,
    /// Brighter than the sky (a sunlit body against a dark sky).
    Bright,
    /// Either: the more elongated candidate wins; later frames keep the polarity first chosen.
    Auto,
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

/// The shape-guided segmentation that refines the table match (the source paper's loop: prior,
/// segmentation guided by it, match again). Needs imade-core's `shape-guided` feature (on by
/// default); without it every method runs as `None`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RefineMethod {
    /// No refinement: the first table match is the pose.
    None,
    /// SIS-Cut (the paper's Algorithm 2).
    SisCut,
    /// GVF-ASM (the paper's Algorithm 1).
    GvfAsm,
}

impl RefineMethod {
    /// Every method.
    pub const ALL: [RefineMethod; 3] = [
        RefineMethod::None,
        RefineMethod::SisCut,
        RefineMethod::GvfAsm,
    ];

    /// The name on command lines: `none`, `sis-cut` or `gvf-asm`.
    pub fn as_str(&self) -> &'static str {
        match self {
            RefineMethod::None => "none",
            RefineMethod::SisCut => "sis-cut",
            RefineMethod::GvfAsm => "gvf-asm",
        }
    }
}

/// A name that is not `none`, `sis-cut` or `gvf-asm`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct UnknownRefineMethod;

impl core::str::FromStr for RefineMethod {
    type Err = UnknownRefineMethod;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        RefineMethod::ALL
            .into_iter()
            .find(|m| m.as_str() == s)
            .ok_or(UnknownRefineMethod)
    }
}

/// The refinement loop and its stop rule: each round segments the chip guided by the current
/// prior, carries the segmentation's transform to the table match's axis and ends, matches
/// again, and keeps the new match only when it agrees with the current one and fits the width
/// profile no worse.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RefineConfig {
    /// The segmentation method.
    pub method: RefineMethod,
    /// Most rounds (segmentations) a frame.
    pub max_rounds: u8,
    /// Stop when the segmentation moves the prior's box corners less than this, px.
    pub identity_px: f32,
    /// Reject a re-match whose tilt differs from the current one's by more, deg.
    pub max_tilt_change_deg: f32,
    /// Reject a re-match whose projected nose tip or tail base moved more, px.
    pub max_end_shift_px: f32,
}

impl RefineConfig {
    /// The defaults: no refinement; when a method is chosen, at most 2 rounds.
    pub const DEFAULT: RefineConfig = RefineConfig {
        method: RefineMethod::None,
        max_rounds: 2,
        identity_px: 0.5,
        max_tilt_change_deg: 5.0,
        max_end_shift_px: 3.0,
    };
}

/// Pipeline configuration. [`Config::DEFAULT`] holds the defaults.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// Detection threshold on the background-subtracted chip, in noise standard deviations.
    pub detect_sigma: f32,
    /// Times the detection threshold is doubled and the chip labeled again when a table of the
    /// labeler runs out (clutter); a `capacity` status only after the last.
    pub detect_retries: u8,
    /// Smallest component kept for target selection, px.
    pub min_area_px: u32,
    /// The body's contrast polarity.
    pub polarity: BodyPolarity,
    /// Fraction of the body's full contrast at which the final mask is cut: 0.5 keeps pixels at
    /// least half covered, as the ground-truth masks of ../shared/spec/projectile.md.
    pub mask_level: f32,
    /// Lowest mask cut, in noise standard deviations (guards low-contrast targets against noise).
    pub mask_min_sigma: f32,
    /// Weight `r` of the source paper's Eq. 5 Tz smoothing, in (0, 1]; 1 disables smoothing.
    pub tz_smoothing_r: f32,
    /// Frames in the temporal window for the Tz trend (at most [`crate::capacity::MAX_WINDOW`]).
    pub window_frames: usize,
    /// Fewest frames in the window before the yaw choice can be resolved.
    pub min_trend_frames: usize,
    /// Significance of the Tz trend, in standard errors, needed to resolve the yaw choice.
    pub trend_sigma: f32,
    /// A gap between frames longer than this, s, resets the temporal state.
    pub max_gap_s: f32,
    /// How a range measurement is used.
    pub range_use: RangeUse,
    /// Shape-guided refinement of the table match.
    pub refine: RefineConfig,
    /// Draw the shape prior ([`crate::Pipeline::prior`]) of every frame with a table match, for
    /// display and evaluation (the results do not depend on it). The refinement loop draws it
    /// whatever this says; the firmware, which displays nothing, turns it off.
    pub shape_prior: bool,
}

impl Config {
    /// The defaults.
    pub const DEFAULT: Config = Config {
        detect_sigma: 4.5,
        detect_retries: 2,
        min_area_px: 6,
        polarity: BodyPolarity::Dark,
        mask_level: 0.5,
        mask_min_sigma: 2.0,
        tz_smoothing_r: 0.1,
        window_frames: 15,
        min_trend_frames: 4,
        trend_sigma: 3.0,
        max_gap_s: 1.0,
        range_use: RangeUse::Auto,
        refine: RefineConfig::DEFAULT,
        shape_prior: true,
    };
}

impl Default for Config {
    fn default() -> Self {
        Self::DEFAULT
    }
}
