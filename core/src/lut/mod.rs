//! The model's silhouette table, `imade-lut/1` ([`table`]), and the drawing of its silhouettes and
//! of the model's triangles with embedded-graphics ([`render`]). The table-match stage
//! ([`crate::table_match`]) matches chips against it; the host builds it (`imade lut build`).

pub mod render;
pub mod table;
