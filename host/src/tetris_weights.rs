//! TETRIS's weights (`imade-tetris/1`) for `imade run --refine tetris`: the bundled ones
//! (`fixtures/tetris/tetris.weights`, trained by `imade train tetris`) or a file of the user's.

use anyhow::Context;
use imade_core::shape_guided::TetrisWeights;
use std::path::{Path, PathBuf};

/// The bundled weights: `fixtures/tetris/tetris.weights` of the source tree.
pub fn bundled_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/tetris/tetris.weights")
}

/// Reads and validates the weights at `path`, keeping their bytes for the life of the process
/// (the core borrows them as `&'static [u8]`, as from flash).
pub fn load(path: &Path) -> anyhow::Result<TetrisWeights<'static>> {
    let bytes = std::fs::read(path)
        .with_context(|| format!("reading TETRIS weights {}", path.display()))?;
    let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
    TetrisWeights::new_checked(bytes)
        .map_err(|e| anyhow::anyhow!("{}: not valid TETRIS weights: {e:?}", path.display()))
}
