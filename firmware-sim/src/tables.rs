//! The bundled silhouette tables (imade-lut/1), in flash: the same files `imade run --lut
//! bundled` reads from `fixtures/lut/`.

use imade_core::ProjectileModel;
use imade_core::lut::table::{Table, TableError};

/// Bundled tables by model id.
static BUNDLED: [(&str, &[u8]); 1] = [(
    "ref-1378x80",
    include_bytes!("../../fixtures/lut/ref-1378x80.lut"),
)];

/// The bundled table of `model`, validated (checksum included); `None` when there is none.
pub fn bundled(model: &ProjectileModel) -> Option<Result<Table<'static>, TableError>> {
    BUNDLED
        .iter()
        .find(|(id, _)| *id == model.id)
        .map(|(_, bytes)| Table::parse_for(bytes, model))
}
