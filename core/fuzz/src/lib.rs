//! Shared by the fuzz targets: chips synthesized from a few fuzzer-chosen numbers ([`synth`]),
//! the invariants every frame result must keep ([`oracle`]), and lookup tables assembled
//! from fuzzer-chosen fields ([`table`]).

pub mod oracle;
pub mod synth;
pub mod table;
