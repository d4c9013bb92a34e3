//! Lookup tables for the table targets: assembled from fuzzer-chosen header fields and entries
//! with their checksum right (so that the checks behind the checksum are reached), and read
//! through every accessor once parsed.

use arbitrary::Arbitrary;
use imade_core::lut::table::{CRC, HEADER_LEN, MAGIC, MODEL_ID_LEN, Table, VERSION, entry_len};

/// The header fields of an assembled table; `None` fields take the valid value.
#[derive(Arbitrary, Debug)]
pub struct Header {
    /// Format version; `None` for the current one.
    pub version: Option<u16>,
    /// Header length, bytes; `None` for the right one.
    pub header_len: Option<u16>,
    /// A model id other than the reference projectile's.
    pub other_model: bool,
    /// Body diameter, m; `None` for the model's.
    pub diameter_m: Option<f32>,
    /// Overall length, m; `None` for the model's.
    pub length_m: Option<f32>,
    /// Grid, modulo 40 tilts, 24 rolls and 260 stations: tilts.
    pub tilts: u8,
    /// Rolls (modulo 24).
    pub rolls: u8,
    /// Stations per entry (modulo 260).
    pub stations: u16,
    /// Quantum of the stored edges.
    pub v_quantum: f32,
    /// Bytes added to (positive) or cut from (negative) the implied length.
    pub length_error: i8,
}

/// Assembles a table from `header` and `entries` and writes its checksum.
pub fn build(header: &Header, entries: &[u8]) -> Vec<u8> {
    let (tilts, rolls) = (
        usize::from(header.tilts % 40),
        usize::from(header.rolls % 24),
    );
    let stations = usize::from(header.stations % 260);
    let mut bytes = vec![0u8; HEADER_LEN];
    bytes[..8].copy_from_slice(&MAGIC);
    let put16 =
        |b: &mut Vec<u8>, at: usize, v: u16| b[at..at + 2].copy_from_slice(&v.to_le_bytes());
    let put32 =
        |b: &mut Vec<u8>, at: usize, v: f32| b[at..at + 4].copy_from_slice(&v.to_le_bytes());
    put16(&mut bytes, 8, header.version.unwrap_or(VERSION));
    put16(
        &mut bytes,
        10,
        header.header_len.unwrap_or(HEADER_LEN as u16),
    );
    let id = if header.other_model {
        "other"
    } else {
        crate::reference().id()
    };
    let id = &id.as_bytes()[..id.len().min(MODEL_ID_LEN)];
    bytes[12..12 + id.len()].copy_from_slice(id);
    put32(
        &mut bytes,
        44,
        header.diameter_m.unwrap_or(crate::reference().diameter_m),
    );
    put32(
        &mut bytes,
        48,
        header.length_m.unwrap_or(crate::reference().length_m),
    );
    put16(&mut bytes, 52, tilts as u16);
    put16(&mut bytes, 54, rolls as u16);
    put16(&mut bytes, 56, stations as u16);
    put32(&mut bytes, 60, header.v_quantum);
    let body =
        (tilts * rolls * entry_len(stations)).saturating_add_signed(header.length_error.into());
    bytes.extend(entries.iter().copied().cycle().take(body));
    bytes.resize(HEADER_LEN + body, 0);
    with_checksum(bytes)
}

/// Appends the CRC of `bytes`.
pub fn with_checksum(mut bytes: Vec<u8>) -> Vec<u8> {
    let crc = CRC.checksum(&bytes);
    bytes.extend(crc.to_le_bytes());
    bytes
}

/// Reads every accessor of a parsed table over its grid (and past it: indices are clamped).
pub fn read_all(table: &Table) {
    for i in 0..=table.tilts() {
        let _ = table.tilt_deg(i);
        for j in 0..=table.rolls() {
            let _ = table.roll_deg(j);
            let entry = table.entry(i, j);
            let (lo, hi) = entry.u_range();
            for s in 0..=entry.stations() {
                let _ = entry.edges(s);
            }
            for u in [
                lo,
                hi,
                0.5 * (lo + hi),
                lo - 1.0,
                hi + 1.0,
                f32::NAN,
                f32::INFINITY,
            ] {
                let _ = entry.edges_at(u);
            }
        }
    }
    let _ = table.model_id();
}
