//! A bit-packed binary mask of fixed capacity, also an embedded-graphics draw target.

use crate::capacity::MASK_WORDS;
use embedded_graphics_core::{
    Pixel,
    draw_target::DrawTarget,
    geometry::{Dimensions, OriginDimensions, Size},
    pixelcolor::BinaryColor,
    primitives::Rectangle,
};

/// A `width` x `height` binary mask in `WORDS` 32-bit words, rows padded to whole words.
#[derive(Clone)]
pub struct BitMask<const WORDS: usize = MASK_WORDS> {
    width: usize,
    height: usize,
    words_per_row: usize,
    words: [u32; WORDS],
}

/// The mask of a chip of any supported size.
pub type ChipMask = BitMask<MASK_WORDS>;

/// The mask does not fit its capacity.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MaskTooLarge;

impl<const WORDS: usize> Default for BitMask<WORDS> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const WORDS: usize> BitMask<WORDS> {
    /// An empty 0 x 0 mask.
    pub const fn new() -> Self {
        BitMask {
            width: 0,
            height: 0,
            words_per_row: 0,
            words: [0; WORDS],
        }
    }

    /// Clears the mask and sets its size.
    pub fn reset(&mut self, width: usize, height: usize) -> Result<(), MaskTooLarge> {
        let words_per_row = width.div_ceil(32);
        if words_per_row.checked_mul(height).is_none_or(|n| n > WORDS) {
            return Err(MaskTooLarge);
        }
        self.clear();
        self.width = width;
        self.height = height;
        self.words_per_row = words_per_row;
        Ok(())
    }

    /// Width, px.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height, px.
    pub fn height(&self) -> usize {
        self.height
    }

    #[inline]
    fn index(&self, x: usize, y: usize) -> Option<(usize, u32)> {
        (x < self.width && y < self.height)
            .then(|| (y * self.words_per_row + x / 32, 1u32 << (x % 32)))
    }

    /// The bit at (x, y); false outside the mask.
    #[inline]
    pub fn get(&self, x: usize, y: usize) -> bool {
        self.index(x, y)
            .and_then(|(i, bit)| self.words.get(i).map(|w| w & bit != 0))
            .unwrap_or(false)
    }

    /// Sets or clears the bit at (x, y); ignored outside the mask.
    #[inline]
    pub fn set(&mut self, x: usize, y: usize, on: bool) {
        if let Some((i, bit)) = self.index(x, y)
            && let Some(w) = self.words.get_mut(i)
        {
            if on {
                *w |= bit;
            } else {
                *w &= !bit;
            }
        }
    }

    /// Sets the bits of row `y` from column `x0` to `x1` inclusive (clipped to the mask).
    pub fn set_run(&mut self, y: usize, x0: usize, x1: usize) {
        let x1 = x1.min(self.width.saturating_sub(1));
        for x in x0..=x1 {
            self.set(x, y, true);
        }
    }

    /// True when any bit of row `y` from `x0` to `x1` inclusive is set.
    pub fn any_in_run(&self, y: usize, x0: usize, x1: usize) -> bool {
        (x0..=x1).any(|x| self.get(x, y))
    }

    /// Number of set bits.
    pub fn count(&self) -> usize {
        self.words
            .get(..self.used_words())
            .map_or(0, |w| w.iter().map(|w| w.count_ones() as usize).sum())
    }

    /// Clears every bit, keeping the size. Only the words of the current size are written: a
    /// bit is only ever set inside it, and [`BitMask::reset`] clears before it resizes, so the
    /// words beyond stay zero (a 256 x 256 chip's mask clears 8 KiB, not the capacity's 32).
    pub fn clear(&mut self) {
        let used = self.used_words();
        self.words.iter_mut().take(used).for_each(|w| *w = 0);
    }

    /// The words that hold the mask's rows.
    fn used_words(&self) -> usize {
        self.words_per_row * self.height
    }
}

impl<const WORDS: usize> OriginDimensions for BitMask<WORDS> {
    fn size(&self) -> Size {
        Size::new(self.width as u32, self.height as u32)
    }
}

impl<const WORDS: usize> DrawTarget for BitMask<WORDS> {
    type Color = BinaryColor;
    type Error = core::convert::Infallible;

    fn draw_iter<I>(&mut self, pixels: I) -> Result<(), Self::Error>
    where
        I: IntoIterator<Item = Pixel<Self::Color>>,
    {
        for Pixel(p, color) in pixels {
            if p.x >= 0 && p.y >= 0 {
                self.set(p.x as usize, p.y as usize, color.is_on());
            }
        }
        Ok(())
    }

    /// Fills the part of `area` inside the mask (embedded-graphics fills primitives row by row
    /// through this, so an oversized primitive costs only its rows).
    fn fill_solid(&mut self, area: &Rectangle, color: Self::Color) -> Result<(), Self::Error> {
        let clipped = area.intersection(&self.bounding_box());
        let Some(bottom_right) = clipped.bottom_right() else {
            return Ok(());
        };
        let (x0, y0) = (clipped.top_left.x as usize, clipped.top_left.y as usize);
        let (x1, y1) = (bottom_right.x as usize, bottom_right.y as usize);
        for y in y0..=y1 {
            for x in x0..=x1 {
                self.set(x, y, color.is_on());
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_mask_resized_smaller_then_larger_has_no_stale_bits() {
        let mut mask: BitMask<64> = BitMask::new();
        mask.reset(64, 32).unwrap();
        mask.set_run(31, 0, 63);
        mask.set(5, 3, true);
        assert_eq!(mask.count(), 65);
        mask.reset(40, 8).unwrap();
        assert_eq!(mask.count(), 0);
        mask.set(39, 7, true);
        mask.reset(64, 32).unwrap();
        assert_eq!(mask.count(), 0);
        assert!(!mask.get(63, 31) && !mask.get(5, 3) && !mask.get(39, 7));
        mask.set(1, 1, true);
        mask.clear();
        assert_eq!((mask.count(), mask.width(), mask.height()), (0, 64, 32));
        assert_eq!(mask.reset(65, 32), Err(MaskTooLarge));
    }
}
