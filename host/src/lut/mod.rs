//! Silhouette tables (`imade-lut/1`) for the core's table match: building one from a model's
//! geometry or from a mesh ([`build`]). A table travels inside its model file (`crate::model`);
//! `imade lut build` is `imade model build`.

pub mod build;
