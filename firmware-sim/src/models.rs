//! The bundled model files (imade-model/1, each with its silhouette table), in flash: the same
//! files `imade run --lut bundled` reads from `fixtures/models/`.

use imade_core::{ModelError, ProjectileModel};

/// Bundled model files.
static BUNDLED: [&[u8]; 1] = [include_bytes!("../../fixtures/models/ref-1378x80.model")];

/// The bundled model with id `id`, validated (checksum and table included); `None` when there
/// is none.
pub fn bundled(id: &str) -> Option<Result<ProjectileModel<'static>, ModelError>> {
    BUNDLED
        .iter()
        .map(|bytes| ProjectileModel::parse(bytes))
        .find(|model| model.as_ref().map_or(true, |m| m.id() == id))
}
