//! The lookup-table parser alone, fast: `Table::parse` and `Table::parse_for` on raw bytes and on
//! small tables assembled from fuzzer-chosen header fields and entries with their checksum right;
//! a table that parses has every accessor read over its whole grid and past it. (`lut_table`
//! adds the patched bundled table and the table match, at milliseconds an input.)
#![no_main]

use arbitrary::Arbitrary;
use imade_core::REF_1378X80;
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
    if let Ok(table) = Table::parse_for(&bytes, &REF_1378X80) {
        read_all(&table);
    }
});
