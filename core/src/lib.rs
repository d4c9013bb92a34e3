//! # imade-core
//!
//! Projectile attitude from one chip of ground-based imagery, with a priori knowledge of the
//! projectile's 3D shape. `no_std`, no heap, no panic on any input: every buffer is a fixed
//! capacity chosen at compile time ([`capacity`]), and exceeding one is a reported [`Status`].
//!
//! One frame flows one way through the stages, each a module:
//!
//! | stage | module | config | gives |
//! | --- | --- | --- | --- |
//! | detection: background, threshold, components, target selection, final mask cut | [`segment`] | [`DetectConfig`] | the target and its mask |
//! | silhouette: principal axis, nose tip, tail edge, subpixel diameter | [`extremes`] | [`SilhouetteConfig`] | [`Silhouette`] |
//! | closed form: Eq. 1-2 in the line-of-sight frame, range from the diameter | [`closed_form`] | none | [`closed_form::Hypothesis`]: pose, both yaw candidates |
//! | table match: shaded cross-section, width profile matched against the silhouette table ([`lut`]), shape prior, shape-guided loop (`shape_guided`) | [`table_match`] | [`MatchConfig`] | [`table_match::Measurement`], prior and guided masks |
//! | temporal estimate: Eq. 5 range smoothing, range trend, yaw choice | [`temporal`] | [`TemporalConfig`] | [`temporal::Estimate`] |
//!
//! [`Pipeline::process`] passes each stage's result to the next; each stage can also be called
//! alone (the benchmarks and fuzz targets do).
//!
//! Cargo features: `shape-guided` (default) compiles the shape-guided segmentation and the
//! table match's shape-guided loop ([`GuidedLoopConfig`]), about 37 KiB of workspace and a third
//! chip mask in every [`Pipeline`]; without it no loop runs. `defmt` derives `defmt::Format` on
//! the public types, for firmware logging.
#![no_std]
#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod bytes;
pub mod camera;
pub mod capacity;
pub mod chip;
pub mod closed_form;
pub mod config;
pub mod extremes;
pub mod flight_filter;
pub mod frame;
pub mod grey_fit;
pub mod lut;
pub mod mask;
pub mod math;
pub mod model;
pub mod pipeline;
pub mod point;
pub mod pose;
pub mod range_filter;
pub mod results;
pub mod segment;
#[cfg(feature = "shape-guided")]
pub mod shape_guided;
pub mod stations;
pub mod table_match;
pub mod temporal;
#[cfg(test)]
mod testing;
pub mod track;
pub mod uncertainty;
pub mod world;

pub use camera::Camera;
pub use chip::{ChipError, ChipView};
pub use config::{
    BodyPolarity, Config, DetectConfig, GuidedLoopConfig, GuidedMethod, MatchConfig,
    RangeFilterConfig, RangeSmoothing, RangeUse, SilhouetteConfig, SizeTolerance, TemporalConfig,
    TrackConfig, UncertaintyConfig,
};
pub use extremes::Silhouette;
pub use frame::{FrameError, FrameInput, FrameResult, ResultFault, Status};
pub use mask::{BitMask, ChipMask};
pub use model::{Fins, ModelError, ProjectileModel};
pub use pipeline::Pipeline;
pub use point::ImagePoint;
pub use pose::Pose;
