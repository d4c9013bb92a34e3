//! Reading a packed clip from any byte source: the header, then record by record with each chip's
//! samples read into a caller's fixed buffer.

use crate::format::{HEADER_LEN, Header, PackError, RECORD_LEN, Record};

/// A byte source (a semihosting file on the firmware, a byte slice on the host).
pub trait Source {
    /// The source's error.
    type Error;
    /// Fills `buf` completely, or fails.
    fn read_exact(&mut self, buf: &mut [u8]) -> Result<(), Self::Error>;
}

/// A byte slice as a source; it fails with `Truncated` when too short.
impl Source for &[u8] {
    type Error = Truncated;
    fn read_exact(&mut self, buf: &mut [u8]) -> Result<(), Truncated> {
        let (head, rest) = self.split_at_checked(buf.len()).ok_or(Truncated)?;
        buf.copy_from_slice(head);
        *self = rest;
        Ok(())
    }
}

/// A byte slice ended before the data it should hold.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Truncated;

/// Why the next part of a packed clip could not be read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ReadError<E> {
    /// The source failed.
    Source(E),
    /// The bytes are not imade-pack/1.
    Format(PackError),
    /// A chip's samples do not fit the buffer.
    ChipTooLarge {
        /// Bytes of the chip's samples.
        needed: usize,
        /// Bytes of the buffer.
        capacity: usize,
    },
}

/// Reads and parses the header.
pub fn read_header<S: Source>(source: &mut S) -> Result<Header, ReadError<S::Error>> {
    let mut bytes = [0u8; HEADER_LEN];
    source.read_exact(&mut bytes).map_err(ReadError::Source)?;
    Header::decode(&bytes).map_err(ReadError::Format)
}

/// Reads the next record and, for a chip record, its samples into the start of `chip` (16-bit
/// words so that 16-bit samples are aligned; 8-bit samples are packed two to a word).
pub fn read_record<S: Source>(
    source: &mut S,
    chip: &mut [u16],
) -> Result<Record, ReadError<S::Error>> {
    let mut bytes = [0u8; RECORD_LEN];
    source.read_exact(&mut bytes).map_err(ReadError::Source)?;
    let record = Record::decode(&bytes).map_err(ReadError::Format)?;
    let needed = record.payload_len();
    let buffer: &mut [u8] = bytemuck::cast_slice_mut(chip);
    let capacity = buffer.len();
    let payload = buffer
        .get_mut(..needed)
        .ok_or(ReadError::ChipTooLarge { needed, capacity })?;
    source.read_exact(payload).map_err(ReadError::Source)?;
    Ok(record)
}
