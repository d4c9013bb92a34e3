//! Shared by the fuzz targets: chips synthesized from a few fuzzer-chosen numbers ([`synth`]),
//! and the invariants every frame result must keep ([`oracle`]).

pub mod oracle;
pub mod synth;
