//! The model files (imade-model/1, each with its silhouette table) in flash: by default the same
//! files `imade run --lut bundled` reads from `fixtures/models/`; a build with
//! `IMADE_FIRMWARE_MODELS` set carries the files it names instead (`build.rs`; `firmware-sim/run
//! --lut FILE` builds with the user's file).

use imade_core::{ModelError, ProjectileModel};

include!(concat!(env!("OUT_DIR"), "/models.rs"));

/// The model in flash with id `id`, validated (checksum and table included); `None` when there
/// is none.
pub fn bundled(id: &str) -> Option<Result<ProjectileModel<'static>, ModelError>> {
    BUNDLED
        .iter()
        .map(|bytes| ProjectileModel::parse(bytes))
        .find(|model| model.as_ref().map_or(true, |m| m.id() == id))
}
