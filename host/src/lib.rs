//! The imade harness: everything around the no_std core that needs `std`.
//!
//! - [`clip`]: the `imade-clip/1` recorded-clip format, read and written, and imade-results/1 read.
//! - [`demo`]: `imade demo`, the main job: the Table 1 test clip run, scored and plotted.
//! - [`eval`]: `imade eval`, results against ground truth beside the paper's figures.
//! - [`exit`]: the binary's exit codes.
//! - [`lut`]: the silhouette tables of the core's table match, built from a model or a mesh.
//! - [`model`]: `imade model` (also `imade lut`), model files: the projectile's geometry and
//!   table, from the built-in reference or the user's mesh ([`mesh_model`]).
//! - [`run`]: `imade run`, the core's pipeline over clips; [`summary`] its JSON summary, [`stages`]
//!   the segmentation stages whose masks it saves.
//! - [`plot`]: `imade plot`, figures like the paper's.
//! - [`pack`]: `imade pack`, a clip packed for the firmware (`firmware-sim/`).
//! - [`sim`]: the clip simulator (`imade simulate`), with its own renderer, independent of the core.
//! - [`tetris_weights`]: TETRIS's weights for `imade run --refine tetris`.
//! - [`train`]: `imade train tetris`, the shape-guided segmentation's network trained on simulated
//!   chips (candle, on the CPU).

pub mod clip;
pub mod demo;
pub mod eval;
pub mod exit;
pub mod fuse;
pub mod lut;
pub mod mesh_model;
pub mod model;
pub mod pack;
pub mod plot;
pub mod run;
pub mod sim;
pub mod smooth;
pub mod stages;
pub mod summary;
pub mod tetris_weights;
pub mod train;
