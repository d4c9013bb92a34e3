//! The model file, `imade-model/1` (`docs/model-format.md` has the full description).
//!
//! Little-endian; offsets in bytes:
//!
//! | offset | size | field |
//! | --- | --- | --- |
//! | 0 | 8 | magic `IMADEMDL` |
//! | 8 | 2 | format version, 1 |
//! | 10 | 2 | header length, 128 |
//! | 12 | 32 | model id, UTF-8, NUL-padded |
//! | 44 | 4 | f32 overall length `L`, m |
//! | 48 | 4 | f32 body diameter (the largest of the profile), m |
//! | 52 | 2 | profile stations `P`, 2 to 64 |
//! | 54 | 2 | fins `F`, 0 to 16 |
//! | 56 | 4 x 4 | f32 fin root leading and trailing edge, tip leading and trailing edge, m aft of the tip |
//! | 72 | 4 | f32 fin tip radius, m |
//! | 76 | 4 | f32 fin thickness, m |
//! | 80 | 4 | f32 roll of fin 0 from +y_B towards +z_B, deg |
//! | 84 | 4 | u32 length `T` of the embedded table, bytes (0: none) |
//! | 88 | 40 | reserved, 0 |
//! | 128 | 8 `P` | profile: f32 `s` (m aft of the tip, from 0 to `L`, increasing), f32 radius (m) |
//! | 128 + 8 `P` | `T` | the silhouette table, `imade-lut/1` |
//! | end - 4 | 4 | CRC-32 (ISO-HDLC) of everything before it |

use crate::bytes::{checksum_ok, f32_at, u16_at, u32_at};
use crate::lut::table::TableError;
use core::ops::Range;

/// The magic bytes.
pub const MAGIC: [u8; 8] = *b"IMADEMDL";
/// The format version this code reads and writes.
pub const VERSION: u16 = 1;
/// Header length, bytes.
pub const HEADER_LEN: usize = 128;
/// Bytes of the model id field.
pub const MODEL_ID_LEN: usize = 32;
/// The most profile stations.
pub const MAX_STATIONS: usize = 64;
/// The most fins.
pub const MAX_FINS: u16 = 16;
/// The longest model accepted, m (and the shortest: [`MIN_LENGTH_M`]).
pub const MAX_LENGTH_M: f32 = 100.0;
/// The shortest model accepted, m.
pub const MIN_LENGTH_M: f32 = 0.01;

/// Byte offsets of the header's fields.
#[derive(Debug)]
pub struct Fields {
    /// Model id.
    pub id: usize,
    /// Overall length.
    pub length: usize,
    /// Body diameter.
    pub diameter: usize,
    /// Profile stations.
    pub stations: usize,
    /// Fin count.
    pub fin_count: usize,
    /// Fin root leading edge.
    pub fin_root_le: usize,
    /// Fin root trailing edge.
    pub fin_root_te: usize,
    /// Fin tip leading edge.
    pub fin_tip_le: usize,
    /// Fin tip trailing edge.
    pub fin_tip_te: usize,
    /// Fin tip radius.
    pub fin_tip_radius: usize,
    /// Fin thickness.
    pub fin_thickness: usize,
    /// Roll of fin 0.
    pub fin_first_roll: usize,
    /// Length of the embedded table.
    pub table_len: usize,
}

/// The header's field offsets.
pub const FIELD: Fields = Fields {
    id: 12,
    length: 44,
    diameter: 48,
    stations: 52,
    fin_count: 54,
    fin_root_le: 56,
    fin_root_te: 60,
    fin_tip_le: 64,
    fin_tip_te: 68,
    fin_tip_radius: 72,
    fin_thickness: 76,
    fin_first_roll: 80,
    table_len: 84,
};

/// Why a model file was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ModelError {
    /// Not the length its header implies.
    Length,
    /// Not an imade model file.
    Magic,
    /// A format version this code does not read.
    Version(u16),
    /// The id is empty or not UTF-8.
    Id,
    /// Length or diameter not finite, or out of range.
    Dimensions,
    /// The profile does not run from the tip (0) to the length with increasing stations and
    /// radii within the diameter, or has too few or too many stations.
    Profile,
    /// The fins' count or planform is out of range.
    Fins,
    /// The checksum does not match.
    Checksum,
    /// The embedded table is not a valid table.
    Table(TableError),
    /// The embedded table was built for another model.
    TableModel,
}

/// Where a checked file's parts lie.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Layout {
    /// Profile stations.
    pub stations: usize,
    /// The embedded table's bytes, if any.
    pub table: Option<Range<usize>>,
}

/// Checks `bytes` as a model file, all but the embedded table's contents.
pub fn check(bytes: &[u8]) -> Result<Layout, ModelError> {
    if bytes.len() < HEADER_LEN + 4 {
        return Err(ModelError::Length);
    }
    if bytes.get(..8) != Some(&MAGIC[..]) {
        return Err(ModelError::Magic);
    }
    let version = u16_at(bytes, 8);
    if version != VERSION || usize::from(u16_at(bytes, 10)) != HEADER_LEN {
        return Err(ModelError::Version(version));
    }
    let stations = usize::from(u16_at(bytes, FIELD.stations));
    let table_len = u32_at(bytes, FIELD.table_len) as usize;
    let profile_end = HEADER_LEN + 8 * stations.min(MAX_STATIONS + 1);
    let expected = profile_end
        .checked_add(table_len)
        .and_then(|n| n.checked_add(4));
    if expected != Some(bytes.len()) {
        return Err(ModelError::Length);
    }
    if !checksum_ok(bytes) {
        return Err(ModelError::Checksum);
    }
    let id = bytes.get(FIELD.id..FIELD.id + MODEL_ID_LEN).unwrap_or(&[]);
    let id_len = id.iter().position(|&c| c == 0).unwrap_or(id.len());
    if id_len == 0 || core::str::from_utf8(id.get(..id_len).unwrap_or(&[])).is_err() {
        return Err(ModelError::Id);
    }
    let length = f32_at(bytes, FIELD.length);
    let diameter = f32_at(bytes, FIELD.diameter);
    let dimensions_ok =
        (MIN_LENGTH_M..=MAX_LENGTH_M).contains(&length) && diameter > 0.0 && diameter <= length;
    if !dimensions_ok {
        return Err(ModelError::Dimensions);
    }
    check_profile(bytes, stations, length, diameter)?;
    check_fins(bytes, length)?;
    Ok(Layout {
        stations,
        table: (table_len > 0).then_some(profile_end..profile_end + table_len),
    })
}

/// Stations from the tip (s = 0) to the base (s = `length`), increasing, radii in [0, D/2] and
/// reaching it.
fn check_profile(
    bytes: &[u8],
    stations: usize,
    length: f32,
    diameter: f32,
) -> Result<(), ModelError> {
    if !(2..=MAX_STATIONS).contains(&stations) {
        return Err(ModelError::Profile);
    }
    let radius = 0.5 * diameter;
    let mut previous = -1.0f32;
    let mut widest = 0.0f32;
    for i in 0..stations {
        let at = HEADER_LEN + 8 * i;
        let (s, r) = (f32_at(bytes, at), f32_at(bytes, at + 4));
        let first_or_last_ok = match i {
            0 => s == 0.0,
            _ if i + 1 == stations => s == length,
            _ => true,
        };
        // A radius a part in 10^5 over the body's (rounding) is the body's.
        if !(first_or_last_ok && s > previous && (0.0..=radius * 1.00001).contains(&r)) {
            return Err(ModelError::Profile);
        }
        previous = s;
        widest = widest.max(r);
    }
    if widest < radius * 0.99999 {
        return Err(ModelError::Profile);
    }
    Ok(())
}

/// No fins, or up to [`MAX_FINS`] with chords inside the body's length (leading edge ahead of
/// the trailing edge), a tip beyond the body's axis and a positive thickness.
fn check_fins(bytes: &[u8], length: f32) -> Result<(), ModelError> {
    let count = u16_at(bytes, FIELD.fin_count);
    if count == 0 {
        return Ok(());
    }
    let f = |at| f32_at(bytes, at);
    let within = |le: f32, te: f32| 0.0 <= le && le < te && te <= length;
    let ok = count <= MAX_FINS
        && within(f(FIELD.fin_root_le), f(FIELD.fin_root_te))
        && within(f(FIELD.fin_tip_le), f(FIELD.fin_tip_te))
        && f(FIELD.fin_tip_radius) > 0.0
        && f(FIELD.fin_tip_radius) <= length
        && f(FIELD.fin_thickness) > 0.0
        && f(FIELD.fin_thickness) <= length
        && f(FIELD.fin_first_roll).is_finite();
    if ok { Ok(()) } else { Err(ModelError::Fins) }
}
