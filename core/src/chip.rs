//! The chip: a borrowed 8-bit or 16-bit grayscale view, with its place in the full frame.

use crate::capacity::MAX_CHIP_SIDE;

/// Why a chip view could not be made.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ChipError {
    /// Width or height is zero.
    Empty,
    /// Width or height exceeds [`MAX_CHIP_SIDE`].
    TooLarge,
    /// The stride is smaller than the width.
    BadStride,
    /// The buffer is shorter than `stride * (height - 1) + width` samples.
    ShortBuffer,
}

/// The samples of a chip.
#[derive(Debug, Clone, Copy)]
enum Samples<'a> {
    Gray8(&'a [u8]),
    Gray16(&'a [u16]),
}

/// A borrowed grayscale chip: `width` x `height` samples, rows `stride` samples apart, whose
/// top-left pixel is full-frame pixel (`x0`, `y0`).
#[derive(Debug, Clone, Copy)]
pub struct ChipView<'a> {
    samples: Samples<'a>,
    width: usize,
    height: usize,
    stride: usize,
    x0: i32,
    y0: i32,
}

impl<'a> ChipView<'a> {
    /// An 8-bit chip view.
    pub fn gray8(
        data: &'a [u8],
        width: usize,
        height: usize,
        stride: usize,
        x0: i32,
        y0: i32,
    ) -> Result<Self, ChipError> {
        Self::checked(
            Samples::Gray8(data),
            data.len(),
            width,
            height,
            stride,
            x0,
            y0,
        )
    }

    /// A 16-bit chip view.
    pub fn gray16(
        data: &'a [u16],
        width: usize,
        height: usize,
        stride: usize,
        x0: i32,
        y0: i32,
    ) -> Result<Self, ChipError> {
        Self::checked(
            Samples::Gray16(data),
            data.len(),
            width,
            height,
            stride,
            x0,
            y0,
        )
    }

    fn checked(
        samples: Samples<'a>,
        len: usize,
        width: usize,
        height: usize,
        stride: usize,
        x0: i32,
        y0: i32,
    ) -> Result<Self, ChipError> {
        if width == 0 || height == 0 {
            return Err(ChipError::Empty);
        }
        if width > MAX_CHIP_SIDE || height > MAX_CHIP_SIDE {
            return Err(ChipError::TooLarge);
        }
        if stride < width {
            return Err(ChipError::BadStride);
        }
        // Cannot overflow: height, width <= MAX_CHIP_SIDE and stride < len + 1 is checked below.
        let needed = stride
            .checked_mul(height - 1)
            .and_then(|n| n.checked_add(width))
            .ok_or(ChipError::ShortBuffer)?;
        if len < needed {
            return Err(ChipError::ShortBuffer);
        }
        Ok(ChipView {
            samples,
            width,
            height,
            stride,
            x0,
            y0,
        })
    }

    /// Width, px.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height, px.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Full-frame x of the chip's left column, px.
    pub fn x0(&self) -> i32 {
        self.x0
    }

    /// Full-frame y of the chip's top row, px.
    pub fn y0(&self) -> i32 {
        self.y0
    }

    /// True for 16-bit samples.
    pub fn is_16bit(&self) -> bool {
        matches!(self.samples, Samples::Gray16(_))
    }

    /// The largest sample the chip's depth holds: a pixel at it is saturated (its radiance is
    /// only known to be at least that).
    pub fn full_scale(&self) -> u16 {
        match self.samples {
            Samples::Gray8(_) => u16::from(u8::MAX),
            Samples::Gray16(_) => u16::MAX,
        }
    }

    /// The sample at column `x`, row `y`, or 0 outside the chip.
    #[inline]
    pub fn get(&self, x: usize, y: usize) -> u16 {
        if x >= self.width || y >= self.height {
            return 0;
        }
        let i = y * self.stride + x;
        match self.samples {
            Samples::Gray8(d) => d.get(i).map_or(0, |&v| u16::from(v)),
            Samples::Gray16(d) => d.get(i).copied().unwrap_or(0),
        }
    }

    /// Calls `f(x, value)` for every sample of row `y` (nothing for a row outside the chip).
    #[inline]
    pub fn for_each_in_row(&self, y: usize, f: impl FnMut(usize, u16)) {
        self.for_each_in_span(y, 0, self.width, f);
    }

    /// Calls `f(value, slot)` for the samples of row `y` from column `x_start` on, each with the
    /// next of `slots`, as far as both go (no index to check: the per-pixel loops that fill
    /// buffers along a row). [`ChipView::for_each_in_span`] is not written as this zipped with
    /// its columns: measured so, the firmware took 5 % more instructions a frame.
    #[inline]
    pub fn zip_span<I: IntoIterator>(
        &self,
        y: usize,
        x_start: usize,
        slots: I,
        mut f: impl FnMut(u16, I::Item),
    ) {
        if y >= self.height || x_start >= self.width {
            return;
        }
        let start = y * self.stride;
        let span = start + x_start..start + self.width;
        match self.samples {
            Samples::Gray8(d) => {
                if let Some(row) = d.get(span) {
                    row.iter()
                        .zip(slots)
                        .for_each(|(&v, slot)| f(u16::from(v), slot));
                }
            }
            Samples::Gray16(d) => {
                if let Some(row) = d.get(span) {
                    row.iter().zip(slots).for_each(|(&v, slot)| f(v, slot));
                }
            }
        }
    }

    /// The samples of row `y` in columns `x_start..x_end` (clipped to the chip) of an 8-bit
    /// chip; None for a 16-bit chip or where that holds no sample.
    #[inline]
    pub fn gray8_span(&self, y: usize, x_start: usize, x_end: usize) -> Option<&'a [u8]> {
        let x_end = x_end.min(self.width);
        if y >= self.height || x_start >= x_end {
            return None;
        }
        let start = y * self.stride;
        match self.samples {
            Samples::Gray8(d) => d.get(start + x_start..start + x_end),
            Samples::Gray16(_) => None,
        }
    }

    /// The lowest and highest sample of row `y` in columns `x_start..x_end` (clipped to the
    /// chip); None where that holds no sample.
    #[inline]
    pub fn span_range(&self, y: usize, x_start: usize, x_end: usize) -> Option<(u16, u16)> {
        let x_end = x_end.min(self.width);
        if y >= self.height || x_start >= x_end {
            return None;
        }
        let start = y * self.stride;
        let span = start + x_start..start + x_end;
        match self.samples {
            Samples::Gray8(d) => {
                let (low, high) = byte_extremes(d.get(span)?);
                Some((u16::from(low), u16::from(high)))
            }
            Samples::Gray16(d) => Some(
                d.get(span)?
                    .iter()
                    .fold((u16::MAX, 0), |(low, high), &v| (low.min(v), high.max(v))),
            ),
        }
    }

    /// Calls `f(x, value)` for the samples of row `y` in columns `x_start..x_end` (clipped to
    /// the chip).
    #[inline]
    pub fn for_each_in_span(
        &self,
        y: usize,
        x_start: usize,
        x_end: usize,
        mut f: impl FnMut(usize, u16),
    ) {
        let x_end = x_end.min(self.width);
        if y >= self.height || x_start >= x_end {
            return;
        }
        let start = y * self.stride;
        let span = start + x_start..start + x_end;
        match self.samples {
            Samples::Gray8(d) => {
                if let Some(row) = d.get(span) {
                    row.iter()
                        .enumerate()
                        .for_each(|(i, &v)| f(x_start + i, u16::from(v)));
                }
            }
            Samples::Gray16(d) => {
                if let Some(row) = d.get(span) {
                    row.iter().enumerate().for_each(|(i, &v)| f(x_start + i, v));
                }
            }
        }
    }
}

/// The lowest and highest of `bytes` (`(255, 0)` for none). Sixteen at a time as four words,
/// compared byte by byte within each word ([`byte_max_min`]): the labeler's screen reads most
/// of a chip's rows sixteen samples at a time, and on the Cortex-M4F this takes about half the
/// instructions of comparing each byte.
fn byte_extremes(bytes: &[u8]) -> (u8, u8) {
    let (mut high, mut low) = (0u32, u32::MAX);
    let mut chunks = bytes.chunks_exact(16);
    for chunk in &mut chunks {
        let word = |k: usize| {
            chunk
                .get(4 * k..4 * k + 4)
                .and_then(|b| <[u8; 4]>::try_from(b).ok())
                .map_or(0, u32::from_le_bytes)
        };
        let (high01, low01) = byte_max_min(word(0), word(1));
        let (high23, low23) = byte_max_min(word(2), word(3));
        high = byte_max_min(high, byte_max_min(high01, high23).0).0;
        low = byte_max_min(low, byte_max_min(low01, low23).1).1;
    }
    let [h0, h1, h2, h3] = high.to_le_bytes();
    let [l0, l1, l2, l3] = low.to_le_bytes();
    chunks.remainder().iter().fold(
        (l0.min(l1).min(l2).min(l3), h0.max(h1).max(h2).max(h3)),
        |(low, high), &v| (low.min(v), high.max(v)),
    )
}

/// The larger and the smaller of each of the four byte pairs packed in `a` and `b` (unsigned).
#[inline]
fn byte_max_min(a: u32, b: u32) -> (u32, u32) {
    const HIGH_BITS: u32 = 0x8080_8080;
    const LOW_BITS: u32 = 0x7F7F_7F7F;
    // Each byte's low seven bits subtracted with the byte's high bit set, so that no borrow
    // crosses into the next byte: the high bit stays where a's low bits are not below b's.
    let low_not_below = (a | HIGH_BITS).wrapping_sub(b & LOW_BITS);
    // a's byte is not below b's where its high bit is set and b's is not, or where their high
    // bits agree and the low bits decide.
    let not_below = ((a & !b) | (!(a ^ b) & low_not_below)) & HIGH_BITS;
    let mask = (not_below >> 7).wrapping_mul(0xFF);
    let swap = (a ^ b) & mask;
    (b ^ swap, a ^ swap)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against each byte compared alone: every pair of bytes that differ in their high bit, in
    /// their low bits or not at all, in every lane; then runs of every length up to 40 from a
    /// scrambled sequence, which end in every remainder.
    #[test]
    fn packed_bytes_compare_as_each_byte_alone() {
        let values = [0u8, 1, 2, 63, 64, 126, 127, 128, 129, 191, 200, 254, 255];
        for &x in &values {
            for &y in &values {
                for lane in 0..4 {
                    let (a, b) = (u32::from(x) << (8 * lane), u32::from(y) << (8 * lane));
                    let (high, low) = byte_max_min(a | 0x5A5A_5A5A & !(0xFF << (8 * lane)), b);
                    assert_eq!((high >> (8 * lane)) as u8, x.max(y), "{x} {y} lane {lane}");
                    assert_eq!((low >> (8 * lane)) as u8, x.min(y), "{x} {y} lane {lane}");
                }
            }
        }
        let bytes: [u8; 40] = core::array::from_fn(|i| ((i * 97 + 31) % 256) as u8);
        for start in 0..8 {
            for end in start..=40 {
                let run = &bytes[start..end];
                let expected = run
                    .iter()
                    .fold((255, 0), |(lo, hi), &v| (v.min(lo), v.max(hi)));
                assert_eq!(byte_extremes(run), expected, "{start}..{end}");
            }
        }
    }

    /// `zip_span` hands over the row's samples from `x_start`, each with the next slot, and
    /// stops at the end of the row or of the slots, whichever comes first; a row outside the
    /// chip gives nothing. Checked by hand on a 4 x 2 chip with a stride of 5.
    #[test]
    fn zip_span_pairs_samples_with_slots_up_to_the_shorter() {
        let data: [u16; 10] = [1, 2, 3, 4, 99, 5, 6, 7, 8, 99];
        let chip = ChipView::gray16(&data, 4, 2, 5, 0, 0).unwrap();
        let mut slots = [0u16; 8];
        chip.zip_span(1, 1, slots.iter_mut(), |v, slot| *slot = v);
        assert_eq!(slots, [6, 7, 8, 0, 0, 0, 0, 0], "stops at the row's end");
        let mut short = [0u16; 2];
        chip.zip_span(0, 0, short.iter_mut(), |v, slot| *slot = v);
        assert_eq!(short, [1, 2], "stops at the slots' end");
        let bytes: [u8; 10] = [1, 2, 3, 4, 99, 5, 6, 7, 8, 99];
        let chip8 = ChipView::gray8(&bytes, 4, 2, 5, 0, 0).unwrap();
        let mut seen = 0;
        chip8.zip_span(2, 0, 0..8, |_, _| seen += 1);
        chip8.zip_span(0, 4, 0..8, |_, _| seen += 1);
        assert_eq!(seen, 0, "nothing outside the chip");
        let mut sum = 0u32;
        chip8.zip_span(1, 0, 0..8u32, |v, i| sum += u32::from(v) * (i + 1));
        assert_eq!(sum, 5 + 2 * 6 + 3 * 7 + 4 * 8);
    }
}
