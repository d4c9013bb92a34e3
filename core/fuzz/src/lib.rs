//! Shared by the fuzz targets: chips synthesized from a few fuzzer-chosen numbers ([`synth`]),
//! the invariants every frame result must keep ([`oracle`]), and lookup tables and model files
//! assembled from fuzzer-chosen fields ([`table`], [`model`]); the bundled model and TETRIS
//! weights.

use imade_core::ProjectileModel;

pub mod model;
pub mod oracle;
pub mod synth;
pub mod table;

/// The bundled reference model file (with its silhouette table).
pub static REFERENCE_BYTES: &[u8] = include_bytes!("../../../fixtures/models/ref-1378x80.model");

/// The bundled TETRIS weights.
pub static TETRIS_BYTES: &[u8] = include_bytes!("../../../fixtures/tetris/tetris.weights");

/// The bundled TETRIS weights, validated.
pub fn tetris() -> imade_core::shape_guided::TetrisWeights<'static> {
    imade_core::shape_guided::TetrisWeights::new_checked(TETRIS_BYTES)
        .expect("the bundled TETRIS weights are valid")
}

/// The bundled reference projectile, validated.
pub fn reference() -> ProjectileModel<'static> {
    ProjectileModel::parse(REFERENCE_BYTES).expect("the bundled reference model is valid")
}
