//! The trained network's weights, `imade-tetris/1`: read in place from a byte slice (flash on
//! the firmware), validated once by [`TetrisWeights::new_checked`].
//!
//! Layout (little-endian; `docs/shape-guided.md` describes it for users):
//!
//! | offset | size | field |
//! | --- | --- | --- |
//! | 0 | 8 | magic `IMADETNW` |
//! | 8 | 2 | format version, 1 |
//! | 10 | 2 | header length, 64 |
//! | 12 | 2 | input channels, 2 (the chip, the prior) |
//! | 14 | 2 | input rows (across the prior's axis), 32 |
//! | 16 | 2 | input columns (along it), 64 |
//! | 18 | 6 | three u16: the convolutions' output channels, 8, 16, 32 |
//! | 24 | 2 | hidden units of the first dense layer, 32 |
//! | 26 | 2 | outputs, 6 (the warp) |
//! | 28 | 4 | u32 parameter count |
//! | 32 | 4 | f32 the crop's length along the axis, in prior lengths |
//! | 36 | 4 | f32 the crop's width across it, in prior widths |
//! | 40 | 8 | u64 the training seed (for the record) |
//! | 48 | 16 | reserved, 0 |
//! | 64 | 4 n | f32 parameters, layer by layer: each layer's weights (output-major: out, in, row, column) then its biases |
//! | end - 4 | 4 | CRC-32 (ISO-HDLC) of everything before it |

use super::network::{ARCHITECTURE, Architecture, PARAMETERS};
use crate::bytes::{checksum_ok, f32_at, u16_at, u32_at};

/// The magic bytes.
pub const MAGIC: [u8; 8] = *b"IMADETNW";
/// The format version this code reads and writes.
pub const VERSION: u16 = 1;
/// Header length, bytes.
pub const HEADER_LEN: usize = 64;
/// Bytes of a whole file of the compiled architecture.
pub const FILE_LEN: usize = HEADER_LEN + 4 * PARAMETERS + 4;

/// Why weights were refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum WeightsError {
    /// Not the length the header implies.
    Length,
    /// Not imade TETRIS weights.
    Magic,
    /// A format version this code does not read.
    Version(u16),
    /// The layer sizes are not the compiled network's.
    Architecture,
    /// The crop's proportions are not finite and positive.
    Crop,
    /// The checksum does not match.
    Checksum,
    /// A parameter is not finite.
    NotFinite,
}

/// Validated weights borrowing their bytes.
#[derive(Debug, Clone, Copy)]
pub struct TetrisWeights<'a> {
    parameters: &'a [u8],
    crop_lengths: f32,
    crop_widths: f32,
    seed: u64,
}

impl<'a> TetrisWeights<'a> {
    /// Validates `bytes`: magic, version, architecture, length, checksum, finite parameters.
    pub fn new_checked(bytes: &'a [u8]) -> Result<TetrisWeights<'a>, WeightsError> {
        if bytes.len() < HEADER_LEN + 4 {
            return Err(WeightsError::Length);
        }
        if bytes.get(..8) != Some(&MAGIC[..]) {
            return Err(WeightsError::Magic);
        }
        let version = u16_at(bytes, 8);
        if version != VERSION {
            return Err(WeightsError::Version(version));
        }
        if usize::from(u16_at(bytes, 10)) != HEADER_LEN || read_architecture(bytes) != ARCHITECTURE
        {
            return Err(WeightsError::Architecture);
        }
        if u32_at(bytes, 28) as usize != PARAMETERS || bytes.len() != FILE_LEN {
            return Err(WeightsError::Length);
        }
        let (crop_lengths, crop_widths) = (f32_at(bytes, 32), f32_at(bytes, 36));
        let sane = |v: f32| v.is_finite() && (0.5..=16.0).contains(&v);
        if !(sane(crop_lengths) && sane(crop_widths)) {
            return Err(WeightsError::Crop);
        }
        if !checksum_ok(bytes) {
            return Err(WeightsError::Checksum);
        }
        let parameters = bytes
            .get(HEADER_LEN..FILE_LEN - 4)
            .ok_or(WeightsError::Length)?;
        let seed = u64::from(u32_at(bytes, 40)) | (u64::from(u32_at(bytes, 44)) << 32);
        let weights = TetrisWeights {
            parameters,
            crop_lengths,
            crop_widths,
            seed,
        };
        if (0..PARAMETERS).any(|i| !weights.parameter(i).is_finite()) {
            return Err(WeightsError::NotFinite);
        }
        Ok(weights)
    }

    /// Parameter `index` in file order (0 past the end, which validation rules out).
    #[inline]
    pub fn parameter(&self, index: usize) -> f32 {
        let at = 4 * index;
        match self.parameters.get(at..at + 4) {
            Some(&[a, b, c, d]) => f32::from_le_bytes([a, b, c, d]),
            _ => 0.0,
        }
    }

    /// The crop's length along the prior's axis, in prior lengths.
    pub fn crop_lengths(&self) -> f32 {
        self.crop_lengths
    }

    /// The crop's width across the prior's axis, in prior widths.
    pub fn crop_widths(&self) -> f32 {
        self.crop_widths
    }

    /// The seed the weights were trained from.
    pub fn seed(&self) -> u64 {
        self.seed
    }
}

fn read_architecture(bytes: &[u8]) -> Architecture {
    let at = |offset: usize| usize::from(u16_at(bytes, offset));
    Architecture {
        channels: at(12),
        rows: at(14),
        columns: at(16),
        convolutions: [at(18), at(20), at(22)],
        hidden: at(24),
        outputs: at(26),
    }
}

/// Writes a file of the compiled architecture holding `parameters` (file order) with the crop's
/// proportions and the training seed into `out` (at least [`FILE_LEN`] bytes); returns the
/// bytes written, or `None` when `out` is short or `parameters` is not [`PARAMETERS`] long. The
/// host's trainer writes the shipped weights with it.
pub fn write(
    parameters: &[f32],
    crop_lengths: f32,
    crop_widths: f32,
    seed: u64,
    out: &mut [u8],
) -> Option<usize> {
    if parameters.len() != PARAMETERS {
        return None;
    }
    let out = out.get_mut(..FILE_LEN)?;
    out.fill(0);
    let (header, rest) = out.split_at_mut_checked(HEADER_LEN)?;
    let (body, trailer) = rest.split_at_mut_checked(4 * PARAMETERS)?;
    let a = ARCHITECTURE;
    let u16s = [
        VERSION,
        HEADER_LEN as u16,
        a.channels as u16,
        a.rows as u16,
        a.columns as u16,
        a.convolutions[0] as u16,
        a.convolutions[1] as u16,
        a.convolutions[2] as u16,
        a.hidden as u16,
        a.outputs as u16,
    ];
    let fields = MAGIC
        .into_iter()
        .chain(u16s.iter().flat_map(|v| v.to_le_bytes()))
        .chain((PARAMETERS as u32).to_le_bytes())
        .chain(crop_lengths.to_le_bytes())
        .chain(crop_widths.to_le_bytes())
        .chain(seed.to_le_bytes());
    // Offsets 0-47 in the layout's order; the reserved 48-63 stay 0.
    for (slot, byte) in header.iter_mut().zip(fields) {
        *slot = byte;
    }
    for (chunk, value) in body.chunks_exact_mut(4).zip(parameters) {
        chunk.copy_from_slice(&value.to_le_bytes());
    }
    let mut digest = crate::bytes::CRC.digest();
    digest.update(header);
    digest.update(body);
    for (slot, byte) in trailer.iter_mut().zip(digest.finalize().to_le_bytes()) {
        *slot = byte;
    }
    Some(FILE_LEN)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(parameters: &[f32; PARAMETERS]) -> [u8; FILE_LEN] {
        let mut out = [0u8; FILE_LEN];
        assert_eq!(write(parameters, 1.5, 4.0, 7, &mut out), Some(FILE_LEN));
        out
    }

    fn ramp() -> [f32; PARAMETERS] {
        core::array::from_fn(|i| i as f32 * 0.5 - 3.0)
    }

    #[test]
    fn written_weights_read_back() {
        let parameters = ramp();
        let bytes = file(&parameters);
        let w = TetrisWeights::new_checked(&bytes).unwrap();
        assert!((0..PARAMETERS).all(|i| w.parameter(i) == parameters[i]));
        assert_eq!((w.crop_lengths(), w.crop_widths(), w.seed()), (1.5, 4.0, 7));
        assert_eq!(
            write(&parameters[1..], 1.5, 4.0, 7, &mut [0u8; FILE_LEN]),
            None
        );
    }

    #[test]
    fn damaged_weights_are_refused() {
        let good = file(&ramp());
        let refused = |bytes: &[u8]| TetrisWeights::new_checked(bytes).err();
        let mut flipped = good;
        flipped[HEADER_LEN + 17] ^= 1;
        assert_eq!(refused(&flipped), Some(WeightsError::Checksum));
        assert_eq!(refused(&good[..FILE_LEN - 1]), Some(WeightsError::Length));
        assert_eq!(refused(&good[..10]), Some(WeightsError::Length));
        let mut magic = good;
        magic[0] = b'X';
        assert_eq!(refused(&magic), Some(WeightsError::Magic));
        let mut version = good;
        version[8] = 2;
        assert_eq!(refused(&version), Some(WeightsError::Version(2)));
        let mut wider = good;
        wider[18] = 9;
        assert_eq!(refused(&wider), Some(WeightsError::Architecture));
        let mut nan = ramp();
        nan[3] = f32::NAN;
        assert_eq!(refused(&file(&nan)), Some(WeightsError::NotFinite));
        let mut narrow = [0u8; FILE_LEN];
        assert_eq!(write(&ramp(), 0.1, 4.0, 0, &mut narrow), Some(FILE_LEN));
        assert_eq!(refused(&narrow), Some(WeightsError::Crop));
    }
}
