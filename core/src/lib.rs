//! # imade-core
//!
//! Projectile attitude from one chip of ground-based imagery, with a priori knowledge of the
//! projectile's 3D shape. `no_std`, no heap, no panic on any input: every buffer is a fixed
//! capacity chosen at compile time ([`capacity`]), and exceeding one is a reported [`Status`].
//!
//! One frame flows one way through the stages, each a module:
//!
//! | stage | module | gives |
//! | --- | --- | --- |
//! | background, threshold, components, target selection | [`segment`] | the target and its mask |
//! | principal axis, nose tip, tail edge, subpixel diameter | [`extremes`] | [`Silhouette`] |
//! | Eq. 1-2 in the line-of-sight frame, range from the diameter | [`closed_form`] | pose, both yaw candidates |
//! | shaded cross-section, width profile matched against the silhouette table, shape prior | [`lut`] | refined pose, prior mask |
//! | segmentation guided by the prior, table match again (feature `shape-guided`) | `shape_guided` | refined mask, pose kept only when the re-match agrees |
//! | Eq. 5 range smoothing, range trend, yaw choice | [`temporal`] | the chosen candidate |
//!
//! [`Pipeline::process`] runs them all.
//!
//! Cargo features: `shape-guided` (default) compiles the shape-guided segmentation and the
//! pipeline's refinement loop (`Config.refine`), about 37 KiB of workspace and a third chip mask
//! in every [`Pipeline`]; without it `Config.refine` is ignored. `defmt` derives `defmt::Format`
//! on the public types, for firmware logging.
#![no_std]
#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod camera;
pub mod capacity;
pub mod chip;
pub mod closed_form;
pub mod config;
pub mod extremes;
pub mod lut;
pub mod mask;
pub mod math;
pub mod model;
pub mod pipeline;
pub mod pose;
pub mod results;
pub mod segment;
#[cfg(feature = "shape-guided")]
pub mod shape_guided;
pub mod temporal;

pub use camera::Camera;
pub use chip::{ChipError, ChipView};
pub use config::{BodyPolarity, Config, RangeUse, RefineConfig, RefineMethod};
pub use extremes::Silhouette;
pub use mask::{BitMask, ChipMask};
pub use model::{ProjectileModel, REF_1378X80, built_in_model};
pub use pipeline::{FrameInput, FrameResult, Pipeline, Status};
pub use pose::Pose;
