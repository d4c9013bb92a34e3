//! # imade-core
//!
//! Projectile attitude from one chip of ground-based imagery, with a priori knowledge of the
//! projectile's 3D shape. `no_std`, no heap, no panic on any input: every buffer is a fixed
//! capacity chosen at compile time ([`capacity`]), and exceeding one is a reported [`Status`].
#![no_std]
#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod camera;
pub mod capacity;
pub mod chip;
pub mod mask;
pub mod model;
pub mod pose;

pub use camera::Camera;
pub use chip::{ChipError, ChipView};
pub use mask::{BitMask, ChipMask};
pub use model::{ProjectileModel, REF_1378X80, built_in_model};
pub use pose::Pose;
