//! Writing a core mask as an 8-bit PNG (0 = background, 255 = projectile).

use anyhow::Context;
use imade_core::ChipMask;
use std::path::Path;

/// The mask as an 8-bit image, 0 or 255 per pixel.
pub fn mask_image(mask: &ChipMask) -> image::GrayImage {
    let (w, h) = (mask.width() as u32, mask.height() as u32);
    image::GrayImage::from_fn(w, h, |x, y| {
        image::Luma([if mask.get(x as usize, y as usize) {
            255
        } else {
            0
        }])
    })
}

/// Writes the mask as an 8-bit PNG at `path`.
pub fn save_mask(mask: &ChipMask, path: &Path) -> anyhow::Result<()> {
    mask_image(mask)
        .save_with_format(path, image::ImageFormat::Png)
        .with_context(|| format!("writing {}", path.display()))
}
