//! Shared helpers of the cross-crate integration tests (the tests are the `[[test]]` targets).
//!
//! [`render`] is an exact ray-casting renderer of `ref-1378x80`, written from
//! ../shared/spec/projectile.md and geometry.md in f64 without any code of the core, so that the
//! core's estimates are checked against an independent truth.

pub mod render;
