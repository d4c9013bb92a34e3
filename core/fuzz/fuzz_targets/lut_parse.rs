//! The lookup-table and model-file parsers alone, fast: `Table::parse` and `ProjectileModel::parse` on raw bytes and on
//! small tables assembled from fuzzer-chosen header fields and entries with their checksum right;
//! a table that parses has every accessor read over its whole grid and past it. (`lut_table`
//! adds the patched bundled table and the table match, at milliseconds an input.)
#![no_main]

use arbitrary::Arbitrary;
use imade_core::ProjectileModel;
use imade_core::lut::table::Table;
use imade_core_fuzz::table::{Header, build, read_all};
use libfuzzer_sys::fuzz_target;

#[derive(Arbitrary, Debug)]
enum Input {
    /// Bytes parsed as they are.
    Raw(Vec<u8>),
    /// A table assembled from fields, its entries repeating `entries`, its checksum right.
    Built { header: Header, entries: Vec<u8> },
}

fuzz_target!(|input: Input| {
    let bytes = match input {
        Input::Raw(bytes) => bytes,
        Input::Built { header, entries } => build(&header, &entries),
    };
    if let Ok(table) = Table::parse(&bytes) {
        read_all(&table);
    }
    // The same bytes as a model file (the model parser validates its embedded table too).
    if let Ok(model) = ProjectileModel::parse(&bytes) {
        let _ = (
            model.id(),
            model.fins(),
            model.cylinder_s(),
            model.max_radius_m(),
        );
        for i in 0..model.stations() {
            let (s, _) = model.station(i);
            let _ = model.radius_at(s);
        }
        let _ = model.nose_ramp_zero_offset_m(0.2, 0.65);
        if let Some(table) = model.table() {
            read_all(&table);
        }
    }
});
