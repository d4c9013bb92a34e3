//! The imade harness: everything around the no_std core that needs `std`.
//!
//! - [`clip`]: the `imade-clip/1` recorded-clip format, read and written.
//! - [`run`]: `imade run`, the core's pipeline over clips.
//! - [`sim`]: the clip simulator (`imade simulate`), with its own renderer, independent of the core.

pub mod clip;
pub mod run;
pub mod sim;
