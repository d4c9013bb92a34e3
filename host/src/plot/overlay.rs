//! Masks over chips, like the paper's Fig. 17: the blind segmentation mask in green, the shape
//! prior's outline in red, on a contrast-stretched crop around the target, for frames spread
//! over the clip.

use super::font::FAMILY;
use crate::clip::{ChipPixels, Clip, load_chip, load_mask};
use crate::stages::{MASKS_FOLDER, PRIORS_FOLDER, mask_file_name};
use anyhow::Context;
use image::{Rgb, RgbImage};
use plotters::prelude::*;
use std::path::Path;

/// Crop side, chip px, and magnification of each tile.
const CROP: u32 = 160;
const ZOOM: u32 = 2;
/// Tiles per row and rows.
const COLUMNS: u32 = 4;
const ROWS: u32 = 2;

/// Writes a 4 x 2 grid of tiles for frames spread over the clip that have a mask beside the
/// results; false when there is none (nothing is written then).
pub fn plot(clip: &Clip, results_dir: &Path, path: &Path) -> anyhow::Result<bool> {
    let framed: Vec<_> = clip
        .frames
        .iter()
        .filter_map(|f| f.as_ref().ok())
        .filter(|r| {
            results_dir
                .join(MASKS_FOLDER)
                .join(mask_file_name(r.frame))
                .is_file()
        })
        .collect();
    if framed.is_empty() {
        return Ok(false);
    }
    let count = framed.len().min((COLUMNS * ROWS) as usize);
    let tile = CROP * ZOOM;
    let mut sheet = RgbImage::from_pixel(COLUMNS * tile, ROWS * tile, Rgb([255, 255, 255]));
    let mut captions = Vec::new();
    for k in 0..count {
        let row = framed[k * (framed.len() - 1) / (count - 1).max(1)];
        let chip = load_chip(&clip.resolve(&row.chip)?)?;
        let read = |folder: &str| -> anyhow::Result<Option<Vec<bool>>> {
            let p = results_dir.join(folder).join(mask_file_name(row.frame));
            if !p.is_file() {
                return Ok(None);
            }
            let (w, h, m) = load_mask(&p)?;
            anyhow::ensure!(
                (w, h) == (chip.width, chip.height),
                "{} is {w}x{h}, its chip {}x{}",
                p.display(),
                chip.width,
                chip.height
            );
            Ok(Some(m))
        };
        let mask = read(MASKS_FOLDER)?.context("mask vanished")?;
        let prior = read(PRIORS_FOLDER)?;
        let img = compose(
            &chip.pixels,
            chip.width,
            chip.height,
            &mask,
            prior.as_deref(),
        );
        let (cx, cy) = centre(&mask, chip.width);
        let x0 = cx
            .saturating_sub(CROP / 2)
            .min(chip.width.saturating_sub(CROP));
        let y0 = cy
            .saturating_sub(CROP / 2)
            .min(chip.height.saturating_sub(CROP));
        let (ox, oy) = ((k as u32 % COLUMNS) * tile, (k as u32 / COLUMNS) * tile);
        for y in 0..tile {
            for x in 0..tile {
                if let Some(p) = img.get_pixel_checked(x0 + x / ZOOM, y0 + y / ZOOM) {
                    sheet.put_pixel(ox + x, oy + y, *p);
                }
            }
        }
        captions.push((ox, oy, format!("frame {}", row.frame)));
    }
    let (w, h) = sheet.dimensions();
    {
        let root = BitMapBackend::with_buffer(&mut sheet, (w, h)).into_drawing_area();
        for (x, y, text) in &captions {
            root.draw(&Text::new(
                text.as_str(),
                (*x as i32 + 6, *y as i32 + 4),
                (FAMILY, 20).into_font().color(&YELLOW),
            ))?;
        }
        root.present()?;
    }
    sheet
        .save(path)
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(true)
}

/// The chip stretched to 0-255 between its extremes, the mask blended green, the prior's
/// outline red.
fn compose(pixels: &ChipPixels, w: u32, h: u32, mask: &[bool], prior: Option<&[bool]>) -> RgbImage {
    let values: Vec<f64> = match pixels {
        ChipPixels::U8(p) => p.iter().map(|&v| f64::from(v)).collect(),
        ChipPixels::U16(p) => p.iter().map(|&v| f64::from(v)).collect(),
    };
    let (lo, hi) = values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let scale = if hi > lo { 255.0 / (hi - lo) } else { 0.0 };
    let at = |m: &[bool], x: i64, y: i64| {
        x >= 0 && y >= 0 && x < w as i64 && y < h as i64 && m[(y * w as i64 + x) as usize]
    };
    RgbImage::from_fn(w, h, |x, y| {
        let i = (y * w + x) as usize;
        let g = ((values[i] - lo) * scale) as u8;
        let (xi, yi) = (x as i64, y as i64);
        let edge = |m: &[bool]| {
            at(m, xi, yi)
                && !(at(m, xi - 1, yi)
                    && at(m, xi + 1, yi)
                    && at(m, xi, yi - 1)
                    && at(m, xi, yi + 1))
        };
        if prior.is_some_and(edge) {
            Rgb([255, 0, 0])
        } else if mask[i] {
            Rgb([g / 2, g / 2 + 110, g / 2])
        } else {
            Rgb([g, g, g])
        }
    })
}

/// The centre of the mask's bounding box, chip px.
fn centre(mask: &[bool], w: u32) -> (u32, u32) {
    let on = mask
        .iter()
        .enumerate()
        .filter(|(_, m)| **m)
        .map(|(i, _)| (i as u32 % w, i as u32 / w));
    let (x0, y0, x1, y1) = on.fold((u32::MAX, u32::MAX, 0, 0), |(a, b, c, d), (x, y)| {
        (a.min(x), b.min(y), c.max(x), d.max(y))
    });
    ((x0 + x1) / 2, (y0 + y1) / 2)
}
