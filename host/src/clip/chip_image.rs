//! Chip and mask PNGs: 8-bit or 16-bit grayscale.

use anyhow::{Context, bail};
use image::DynamicImage;
use std::path::Path;

/// Pixel samples of a chip, row-major, no padding.
#[derive(Debug, Clone, PartialEq)]
pub enum ChipPixels {
    /// 8-bit samples.
    U8(Vec<u8>),
    /// 16-bit samples.
    U16(Vec<u16>),
}

/// A decoded chip.
#[derive(Debug, Clone, PartialEq)]
pub struct ChipImage {
    /// Width, px.
    pub width: u32,
    /// Height, px.
    pub height: u32,
    /// The samples.
    pub pixels: ChipPixels,
}

impl ChipImage {
    /// Borrows the chip as a core view with the chip's full-frame origin.
    pub fn view(
        &self,
        x0: i32,
        y0: i32,
    ) -> Result<imade_core::ChipView<'_>, imade_core::ChipError> {
        let (w, h) = (self.width as usize, self.height as usize);
        match &self.pixels {
            ChipPixels::U8(p) => imade_core::ChipView::gray8(p, w, h, w, x0, y0),
            ChipPixels::U16(p) => imade_core::ChipView::gray16(p, w, h, w, x0, y0),
        }
    }

    /// Encodes the chip as a PNG at `path`.
    pub fn save_png(&self, path: &Path) -> anyhow::Result<()> {
        let image = match &self.pixels {
            ChipPixels::U8(p) => DynamicImage::ImageLuma8(
                image::GrayImage::from_raw(self.width, self.height, p.clone())
                    .context("8-bit chip buffer does not match its size")?,
            ),
            ChipPixels::U16(p) => DynamicImage::ImageLuma16(
                image::ImageBuffer::from_raw(self.width, self.height, p.clone())
                    .context("16-bit chip buffer does not match its size")?,
            ),
        };
        image
            .save_with_format(path, image::ImageFormat::Png)
            .with_context(|| format!("writing {}", path.display()))
    }
}

/// Decodes a chip PNG. Grayscale 8-bit and 16-bit are accepted as they are; anything else is an
/// error (a chip must not be silently converted from colour).
pub fn load_chip(path: &Path) -> anyhow::Result<ChipImage> {
    let image = image::open(path).with_context(|| format!("decoding {}", path.display()))?;
    let (width, height) = (image.width(), image.height());
    let pixels = match image {
        DynamicImage::ImageLuma8(buf) => ChipPixels::U8(buf.into_raw()),
        DynamicImage::ImageLuma16(buf) => ChipPixels::U16(buf.into_raw()),
        other => bail!(
            "{}: chip must be 8-bit or 16-bit grayscale, found {:?}",
            path.display(),
            other.color()
        ),
    };
    Ok(ChipImage {
        width,
        height,
        pixels,
    })
}

/// Decodes a mask PNG (8-bit, 0 = background, nonzero = projectile) into width, height and one
/// bool per pixel, row-major.
pub fn load_mask(path: &Path) -> anyhow::Result<(u32, u32, Vec<bool>)> {
    let image = image::open(path).with_context(|| format!("decoding {}", path.display()))?;
    let gray = image.to_luma8();
    let (w, h) = gray.dimensions();
    Ok((
        w,
        h,
        gray.into_raw().into_iter().map(|v| v >= 128).collect(),
    ))
}
