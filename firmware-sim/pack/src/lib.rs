//! # imade-pack
//!
//! A recorded clip packed for the firmware, and the one way a packed frame is replayed through
//! the core's pipeline.
//!
//! The host (`imade pack`) reads an imade-clip/1 folder exactly as `imade run` does and writes
//! imade-pack/1 ([`format`]): the camera, range use, table use and projectile of the clip, then one record
//! per frame row with its time, range, chip origin and chip samples, or the status the host gave
//! a row it could not use. The firmware reads it over semihosting ([`read`]) and [`replay()`]s each
//! record through the same `Pipeline` as the host, writing the same imade-results/1 row.
//! `no_std`, no heap: it builds for the host and for the Cortex-M4F.
#![no_std]
#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod format;
pub mod read;
pub mod replay;

pub use format::{
    ChipFrame, HEADER_LEN, Header, PackError, RECORD_LEN, Record, SampleDepth, TableUse,
};
pub use read::{ReadError, Source, Truncated, read_header, read_record};
pub use replay::{Outcome, replay};
