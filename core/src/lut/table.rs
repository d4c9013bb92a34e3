//! The silhouette table, `imade-lut/1`: read zero-copy from a byte slice (flash on the firmware).
//!
//! Under a narrow field of view the silhouette's shape depends only on the body's tilt out of the
//! image plane and on its roll; its scale and in-plane angle are measured from the chip. The
//! table holds, for a grid of tilts and rolls, the silhouette's edges across the projected axis
//! at evenly spaced stations along it, in units of the body diameter `D`.
//!
//! The silhouette frame: `u` along the projected axis (tail to nose), `v` across it, rotated
//! +90° from `u` in the image (x right, y down), both in `D`, with the body origin (the middle of
//! its length) at `(0, 0)`. Tilt `β` in `[0, 90]` deg is the angle between the axis and the image
//! plane: the axis is `n = (cos β, 0, sin β)` in the frame (u, v, line of sight). Roll `φ` in `[0,
//! 90)` deg puts the fins at `φ + k 90°` from `+v` towards `n × v`, so that a point at radius `r`
//! and fin angle `ψ` on the axial station `x` is seen at `u = x cos β - r sin ψ sin β`, `v = r cos
//! ψ`. Mirroring the body through the image plane (the two yaw candidates) leaves the silhouette
//! unchanged, which is why tilts beyond 90° are not needed.
//!
//! Layout (little-endian; `docs/lut-format.md` has the full description):
//!
//! | offset | size | field |
//! | --- | --- | --- |
//! | 0 | 8 | magic `IMADELUT` |
//! | 8 | 2 | format version, 1 |
//! | 10 | 2 | header length, 64 |
//! | 12 | 32 | model id, UTF-8, NUL-padded |
//! | 44 | 4 | f32 body diameter `D`, m |
//! | 48 | 4 | f32 overall length, m |
//! | 52 | 2 | tilts `T`: tilt `i` is `90 i / (T - 1)` deg |
//! | 54 | 2 | rolls `R`: roll `j` is `90 j / R` deg |
//! | 56 | 2 | stations per entry `S` |
//! | 58 | 2 | reserved, 0 |
//! | 60 | 4 | f32 `v` quantum, `D` per unit |
//! | 64 | `T R (4 + 2 S)` | entries, tilt-major: i16 `u_lo`, i16 `u_hi` (`D`/1024), then per station i8 `v_lo`, i8 `v_hi` |
//! | end - 4 | 4 | CRC-32 (ISO-HDLC) of everything before it |
//!
//! Station `s` of an entry lies at `u = u_lo + (u_hi - u_lo) s / (S - 1)`.

use super::render::View;
use crate::bytes::{checksum_ok, f32_at, text_at, u16_at};

/// Tilt of index `i` of a grid of `tilts`, deg: `90 i / (tilts - 1)`.
pub fn grid_tilt_deg(i: usize, tilts: usize) -> f32 {
    90.0 * i as f32 / tilts.saturating_sub(1).max(1) as f32
}

/// Roll of index `j` of a grid of `rolls`, deg: `90 j / rolls`.
pub fn grid_roll_deg(j: usize, rolls: usize) -> f32 {
    90.0 * j as f32 / rolls.max(1) as f32
}

/// The magic bytes.
pub const MAGIC: [u8; 8] = *b"IMADELUT";
/// The format version this code reads and writes.
pub const VERSION: u16 = 1;
/// Header length, bytes.
pub const HEADER_LEN: usize = 64;
/// Bytes of the model id field.
pub const MODEL_ID_LEN: usize = 32;
/// Units of `u_lo` and `u_hi` per `D`.
pub const U_UNITS_PER_D: f32 = 1024.0;
/// The most stations an entry may have.
pub const MAX_STATIONS: usize = 256;

/// The CRC of the table's trailer.
pub use crate::bytes::CRC;

/// Why a table was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TableError {
    /// Shorter than its header, or not the length its grid implies.
    Length,
    /// Not an imade table.
    Magic,
    /// A format version this code does not read.
    Version(u16),
    /// The header's fields are out of range.
    Grid,
    /// The checksum does not match.
    Checksum,
}

/// A validated table borrowing its bytes.
#[derive(Debug, Clone, Copy)]
pub struct Table<'a> {
    bytes: &'a [u8],
    tilts: usize,
    rolls: usize,
    stations: usize,
    v_quantum: f32,
    diameter_m: f32,
    length_m: f32,
}

/// Bytes of one entry with `stations` stations.
pub const fn entry_len(stations: usize) -> usize {
    4 + 2 * stations
}

impl<'a> Table<'a> {
    /// Validates `bytes` as a table: magic, version, grid, length and checksum.
    pub fn parse(bytes: &'a [u8]) -> Result<Table<'a>, TableError> {
        if bytes.len() < HEADER_LEN + 4 {
            return Err(TableError::Length);
        }
        if bytes.get(..8) != Some(&MAGIC[..]) {
            return Err(TableError::Magic);
        }
        let version = u16_at(bytes, 8);
        if version != VERSION {
            return Err(TableError::Version(version));
        }
        let tilts = usize::from(u16_at(bytes, 52));
        let rolls = usize::from(u16_at(bytes, 54));
        let stations = usize::from(u16_at(bytes, 56));
        let table = Table {
            bytes,
            tilts,
            rolls,
            stations,
            v_quantum: f32_at(bytes, 60),
            diameter_m: f32_at(bytes, 44),
            length_m: f32_at(bytes, 48),
        };
        let grid_ok = usize::from(u16_at(bytes, 10)) == HEADER_LEN
            && tilts >= 2
            && rolls >= 1
            && (2..=MAX_STATIONS).contains(&stations)
            && table.v_quantum.is_finite()
            && table.v_quantum > 0.0
            && table.diameter_m.is_finite()
            && table.diameter_m > 0.0
            && table.length_m.is_finite()
            && table.length_m > 0.0;
        if !grid_ok {
            return Err(TableError::Grid);
        }
        let expected = tilts
            .checked_mul(rolls)
            .and_then(|n| n.checked_mul(entry_len(stations)))
            .and_then(|n| n.checked_add(HEADER_LEN + 4));
        if expected != Some(bytes.len()) {
            return Err(TableError::Length);
        }
        if !checksum_ok(bytes) {
            return Err(TableError::Checksum);
        }
        Ok(table)
    }

    /// Body diameter `D` of the model the table was built for, m.
    pub fn diameter_m(&self) -> f32 {
        self.diameter_m
    }

    /// Overall length of the model the table was built for, m.
    pub fn length_m(&self) -> f32 {
        self.length_m
    }

    /// The model id the table was built for.
    pub fn model_id(&self) -> &'a str {
        text_at(self.bytes, 12, MODEL_ID_LEN)
    }

    /// Number of tilts.
    pub fn tilts(&self) -> usize {
        self.tilts
    }

    /// Number of rolls.
    pub fn rolls(&self) -> usize {
        self.rolls
    }

    /// Stations per entry.
    pub fn stations(&self) -> usize {
        self.stations
    }

    /// Tilt of grid index `i`, deg.
    pub fn tilt_deg(&self, i: usize) -> f32 {
        grid_tilt_deg(i, self.tilts)
    }

    /// Roll of grid index `j`, deg.
    pub fn roll_deg(&self, j: usize) -> f32 {
        grid_roll_deg(j, self.rolls)
    }

    /// Spacing of the tilt grid, deg.
    pub fn tilt_step_deg(&self) -> f32 {
        90.0 / (self.tilts - 1) as f32
    }

    /// Spacing of the roll grid, deg.
    pub fn roll_step_deg(&self) -> f32 {
        90.0 / self.rolls as f32
    }

    /// The tilt index nearest to `tilt_deg` (clamped to the grid).
    pub fn tilt_index(&self, tilt_deg: f32) -> usize {
        (libm::roundf(tilt_deg.clamp(0.0, 90.0) / self.tilt_step_deg()) as usize)
            .min(self.tilts - 1)
    }

    /// The roll index nearest to `roll_deg` (clamped to the grid).
    pub fn roll_index(&self, roll_deg: f32) -> usize {
        (libm::roundf(roll_deg.clamp(0.0, 90.0) / self.roll_step_deg()) as usize)
            .min(self.rolls - 1)
    }

    /// The entry nearest to `view`.
    pub fn entry_nearest(&self, view: &View) -> Entry<'a> {
        self.entry(
            self.tilt_index(view.tilt_deg),
            self.roll_index(view.roll_deg),
        )
    }

    /// The entry at tilt index `tilt` and roll index `roll` (clamped to the grid).
    pub fn entry(&self, tilt: usize, roll: usize) -> Entry<'a> {
        let index = tilt.min(self.tilts - 1) * self.rolls + roll.min(self.rolls - 1);
        let len = entry_len(self.stations);
        let at = HEADER_LEN + index * len;
        Entry {
            bytes: self.bytes.get(at..at + len).unwrap_or(&[]),
            stations: self.stations,
            v_quantum: self.v_quantum,
        }
    }
}

/// One entry: a silhouette's edges at its stations.
#[derive(Debug, Clone, Copy)]
pub struct Entry<'a> {
    bytes: &'a [u8],
    stations: usize,
    v_quantum: f32,
}

impl Entry<'_> {
    /// The silhouette's extent along the projected axis, `D`: (tail end, nose end).
    pub fn u_range(&self) -> (f32, f32) {
        let lo = u16_at(self.bytes, 0) as i16;
        let hi = u16_at(self.bytes, 2) as i16;
        (f32::from(lo) / U_UNITS_PER_D, f32::from(hi) / U_UNITS_PER_D)
    }

    /// Stations.
    pub fn stations(&self) -> usize {
        self.stations
    }

    /// The edges (`v_lo`, `v_hi`) at station `s`, `D`.
    pub fn edges(&self, s: usize) -> (f32, f32) {
        let at = 4 + 2 * s;
        match self.bytes.get(at..at + 2) {
            Some(&[lo, hi]) => (
                f32::from(lo as i8) * self.v_quantum,
                f32::from(hi as i8) * self.v_quantum,
            ),
            _ => (0.0, 0.0),
        }
    }

    /// The edges at `u` `D` along the axis, interpolated between stations; `(0, 0)` outside.
    pub fn edges_at(&self, u: f32) -> (f32, f32) {
        let (lo, hi) = self.u_range();
        if !(u >= lo && u <= hi) || hi <= lo {
            return (0.0, 0.0);
        }
        let position = (u - lo) / (hi - lo) * (self.stations - 1) as f32;
        let i = (position as usize).min(self.stations - 2);
        let f = position - i as f32;
        let (a0, a1) = self.edges(i);
        let (b0, b1) = self.edges(i + 1);
        (a0 + f * (b0 - a0), a1 + f * (b1 - a1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::testing::reference;

    /// The bundled table, built by `imade lut build --model ref-1378x80`.
    static BUNDLED: &[u8] = include_bytes!("../../../fixtures/lut/ref-1378x80.lut");

    #[test]
    fn the_bundled_table_parses_for_its_model() {
        let t = Table::parse(BUNDLED).unwrap();
        assert!(reference().matches_table(&t));
        assert_eq!(t.model_id(), "ref-1378x80");
        assert_eq!((t.tilts(), t.rolls(), t.stations()), (91, 18, 96));
        assert!(BUNDLED.len() <= 512 * 1024, "the table budget is 512 KiB");
    }

    #[test]
    fn broadside_entry_has_the_models_dimensions() {
        let t = Table::parse(BUNDLED).unwrap();
        let e = t.entry(0, 0);
        let half = 0.5 * reference().length_m / reference().diameter_m;
        let (lo, hi) = e.u_range();
        assert!(
            (lo + half).abs() < 2e-3 && (hi - half).abs() < 2e-3,
            "{lo} {hi}"
        );
        // The cylinder's middle is one diameter wide.
        let (v0, v1) = e.edges_at(0.0);
        assert!(
            (v0 + 0.5).abs() < 0.02 && (v1 - 0.5).abs() < 0.02,
            "{v0} {v1}"
        );
        // At roll 0 two fins lie in the image plane: their tips 1.25 D from the axis.
        let tip = reference().max_radius_m() / reference().diameter_m;
        let (f0, f1) = e.edges_at(-half + 0.5);
        assert!(
            (f0 + tip).abs() < 0.03 && (f1 - tip).abs() < 0.03,
            "{f0} {f1}"
        );
    }

    #[test]
    fn damaged_tables_are_refused() {
        let mut bytes = [0u8; 400_000];
        let n = BUNDLED.len();
        bytes[..n].copy_from_slice(BUNDLED);
        let table = &mut bytes[..n];
        table[1000] ^= 1;
        assert_eq!(Table::parse(table).err(), Some(TableError::Checksum));
        table[1000] ^= 1;
        table[0] = b'X';
        assert_eq!(Table::parse(table).err(), Some(TableError::Magic));
        table[0] = b'I';
        table[8] = 2;
        assert_eq!(Table::parse(table).err(), Some(TableError::Version(2)));
        table[8] = 1;
        assert_eq!(
            Table::parse(&table[..n - 1]).err(),
            Some(TableError::Length)
        );
        assert_eq!(Table::parse(&table[..10]).err(), Some(TableError::Length));
        table[52] = 0;
        table[53] = 0;
        assert_eq!(Table::parse(table).err(), Some(TableError::Grid));
        table[52] = 91;
        assert!(Table::parse(table).is_ok());
    }
}
