//! Little-endian fields read in place from a borrowed byte slice (a file in flash or in memory):
//! the one reader of the core's binary formats ([`crate::model`], [`crate::lut::table`]). Out of
//! range reads give a value the format's validation refuses (0, or NaN for floats), never a panic.

/// The `u16` at byte `at`, or 0 past the end.
pub fn u16_at(b: &[u8], at: usize) -> u16 {
    match b.get(at..at.saturating_add(2)) {
        Some(&[x, y]) => u16::from_le_bytes([x, y]),
        _ => 0,
    }
}

/// The `u32` at byte `at`, or 0 past the end.
pub fn u32_at(b: &[u8], at: usize) -> u32 {
    match b.get(at..at.saturating_add(4)) {
        Some(&[w, x, y, z]) => u32::from_le_bytes([w, x, y, z]),
        _ => 0,
    }
}

/// The `f32` at byte `at`, or NaN past the end.
pub fn f32_at(b: &[u8], at: usize) -> f32 {
    match b.get(at..at.saturating_add(4)) {
        Some(&[w, x, y, z]) => f32::from_le_bytes([w, x, y, z]),
        _ => f32::NAN,
    }
}

/// The NUL-padded UTF-8 text of `len` bytes at `at` (empty when it is not UTF-8).
pub fn text_at(b: &[u8], at: usize, len: usize) -> &str {
    let field = b.get(at..at.saturating_add(len)).unwrap_or(&[]);
    let end = field.iter().position(|&c| c == 0).unwrap_or(field.len());
    core::str::from_utf8(field.get(..end).unwrap_or(&[])).unwrap_or("")
}

/// The CRC-32 (ISO-HDLC) that closes every format: of everything before the last 4 bytes,
/// compared with them.
pub fn checksum_ok(bytes: &[u8]) -> bool {
    let Some(body) = bytes.len().checked_sub(4) else {
        return false;
    };
    u32_at(bytes, body) == CRC.checksum(bytes.get(..body).unwrap_or(&[]))
}

/// The formats' CRC.
pub const CRC: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);
