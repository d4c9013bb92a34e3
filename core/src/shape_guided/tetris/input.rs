//! The network's input: the chip and the prior resampled on a grid aligned with the prior's axis
//! and sized to it, and the map between that grid and the chip.
//!
//! The crop frame: normalized coordinates `p = (s, t)` in `[-1, 1]²`, `s` along the prior's
//! principal axis, `t` across it, centred on the prior's extent box; the crop spans
//! [`TetrisWeights::crop_lengths`] prior lengths along and [`TetrisWeights::crop_widths`] prior
//! widths across (at least 8 px each way). Sample `(row j, column i)` lies at
//! `s = (i + 0.5) / 32 - 1`, `t = (j + 0.5) / 16 - 1`.
//!
//! Channel 0 is the chip, bilinear between pixel centres, minus the mean of the samples off the
//! prior and divided by the contrast under it (mean on the prior minus that mean, at least the
//! off-prior samples' standard deviation and one grey level, with its sign): the body reads
//! about +1 whatever its polarity and brightness, the sky 0; clamped to `[-4, 4]`. Channel 1 is
//! the prior, bilinear between pixel centres (0 off it, 1 on it).

use super::network::{INPUT_COLUMNS, INPUT_LEN, INPUT_ROWS};
use super::weights::TetrisWeights;
use crate::chip::ChipView;
use crate::mask::BitMask;
use crate::shape_guided::affine::Affine2;
use crate::shape_guided::prior::PriorShape;
use nalgebra::{Matrix2, Vector2};

/// Normalized chip values are clamped to this magnitude.
pub const CLAMP: f32 = 4.0;
/// Samples of one channel.
pub const PLANE: usize = INPUT_ROWS * INPUT_COLUMNS;
/// The crop's least half-extent either way, px.
pub const MIN_HALF_PX: f32 = 4.0;

/// The crop frame in the chip.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CropFrame {
    /// Centre of the prior's extent box, chip px.
    pub centre: Vector2<f32>,
    /// Unit vector along the prior's axis; across it is `(-axis.y, axis.x)`.
    pub axis: Vector2<f32>,
    /// Half the crop's length along the axis, px (`s = 1`).
    pub half_along_px: f32,
    /// Half its width across, px (`t = 1`).
    pub half_across_px: f32,
}

impl CropFrame {
    /// The crop around `shape` with the proportions of `weights`.
    pub fn around(shape: &PriorShape, weights: &TetrisWeights) -> CropFrame {
        Self::with_proportions(shape, weights.crop_lengths(), weights.crop_widths())
    }

    /// The crop around `shape` spanning `lengths` of its lengths along its axis and `widths`
    /// of its widths across (the trainer's, before there are weights).
    pub fn with_proportions(shape: &PriorShape, lengths: f32, widths: f32) -> CropFrame {
        let [u0, u1, v0, v1] = shape.extent;
        let centre = shape.centre + shape.frame() * Vector2::new(0.5 * (u0 + u1), 0.5 * (v0 + v1));
        CropFrame {
            centre,
            axis: shape.axis,
            half_along_px: (0.5 * lengths * (u1 - u0)).max(MIN_HALF_PX),
            half_across_px: (0.5 * widths * (v1 - v0)).max(MIN_HALF_PX),
        }
    }

    /// `E S`: crop-normalized vectors to chip px vectors.
    fn scale_frame(&self) -> Matrix2<f32> {
        let (u, v) = (self.axis, Vector2::new(-self.axis.y, self.axis.x));
        Matrix2::from_columns(&[u * self.half_along_px, v * self.half_across_px])
    }

    /// The chip px of crop-normalized point `p`.
    pub fn to_chip(&self, p: Vector2<f32>) -> Vector2<f32> {
        self.centre + self.scale_frame() * p
    }

    /// The chip px of sample `(row, column)`.
    pub fn sample_px(&self, row: usize, column: usize) -> Vector2<f32> {
        self.to_chip(sample_point(row, column))
    }

    /// The chip-px map of the crop-normalized map `p -> linear p + offset`:
    /// `x -> C(linear C⁻¹(x) + offset)`, with `C` the crop frame ([`CropFrame::to_chip`]).
    pub fn chip_map(&self, linear: Matrix2<f32>, offset: Vector2<f32>) -> Option<Affine2> {
        let es = self.scale_frame();
        let inverse = es.try_inverse()?;
        Some(Affine2::about(
            self.centre,
            es * linear * inverse,
            es * offset,
        ))
    }

    /// Fills `input` (`[channel][row][column]`) from `chip` and `prior` moved by the inverse
    /// of `pull` (chip px to the prior's px: the identity for the prior as drawn).
    pub fn fill<const W: usize>(
        &self,
        chip: &ChipView,
        prior: &BitMask<W>,
        pull: &Affine2,
        input: &mut [f32; INPUT_LEN],
    ) {
        let (grey, cover) = input.split_at_mut(PLANE);
        self.sample_mask_through(prior, pull, cover);
        self.sample_chip(chip, cover, grey);
    }

    /// `mask` at every sample, bilinear between pixel centres (0 off it, 1 on it), into the
    /// plane `out` (`[row][column]`): the prior's channel, and the trainer's target.
    pub fn sample_mask<const W: usize>(&self, mask: &BitMask<W>, out: &mut [f32]) {
        self.sample_mask_through(mask, &Affine2::IDENTITY, out);
    }

    /// `mask` at the image under `pull` of every sample.
    fn sample_mask_through<const W: usize>(
        &self,
        mask: &BitMask<W>,
        pull: &Affine2,
        out: &mut [f32],
    ) {
        for (k, value) in out.iter_mut().enumerate().take(PLANE) {
            let p = pull.apply(self.sample_px(k / INPUT_COLUMNS, k % INPUT_COLUMNS));
            *value = bilinear(p, mask.width(), mask.height(), |x, y| {
                if mask.get(x, y) { 1.0 } else { 0.0 }
            });
        }
    }

    /// The chip at every sample, normalized by the prior's contrast (the module's doc), into
    /// the plane `grey`; `cover` is the prior's plane.
    fn sample_chip(&self, chip: &ChipView, cover: &[f32], grey: &mut [f32]) {
        let mut levels = LevelSums::default();
        for (k, (value, &c)) in grey.iter_mut().zip(cover).enumerate() {
            let p = self.sample_px(k / INPUT_COLUMNS, k % INPUT_COLUMNS);
            let level = bilinear(p, chip.width(), chip.height(), |x, y| {
                f32::from(chip.get(x, y))
            });
            *value = level;
            levels.add(level, c >= 0.5);
        }
        let scale = levels.scale();
        for g in grey.iter_mut() {
            *g = scale.normalized(*g);
        }
    }
}

/// Sums of the grey levels on and off the prior, from which the chip is normalized.
#[derive(Debug, Default, Clone, Copy)]
pub struct LevelSums {
    on: f32,
    on_sum: f32,
    off: f32,
    off_sum: f32,
    off_squares: f32,
}

impl LevelSums {
    /// Adds `level`, on the prior or off it.
    pub fn add(&mut self, level: f32, on_prior: bool) {
        if on_prior {
            self.on += 1.0;
            self.on_sum += level;
        } else {
            self.off += 1.0;
            self.off_sum += level;
            self.off_squares += level * level;
        }
    }

    /// The normalization (the module's doc): the sky the mean off the prior, the scale the
    /// contrast under it, at least the sky's standard deviation and one grey level.
    pub fn scale(&self) -> GreyScale {
        let sky = if self.off > 0.0 {
            self.off_sum / self.off
        } else {
            0.0
        };
        let sky_sd = if self.off > 1.0 {
            libm::sqrtf(((self.off_squares - self.off_sum * sky) / (self.off - 1.0)).max(0.0))
        } else {
            0.0
        };
        let contrast = if self.on > 0.0 {
            self.on_sum / self.on - sky
        } else {
            0.0
        };
        let scale = contrast.abs().max(sky_sd).max(1.0);
        GreyScale {
            sky,
            scale: libm::copysignf(scale, contrast),
            sky_sd: sky_sd / scale,
        }
    }
}

/// A grey level to the normalized one: the sky 0, the body about +1.
#[derive(Debug, Clone, Copy)]
pub struct GreyScale {
    sky: f32,
    scale: f32,
    /// The standard deviation of the levels off the prior, normalized (at most 1).
    pub sky_sd: f32,
}

impl GreyScale {
    /// `level` normalized, clamped to `[-CLAMP, CLAMP]`.
    pub fn normalized(&self, level: f32) -> f32 {
        ((level - self.sky) / self.scale).clamp(-CLAMP, CLAMP)
    }
}

/// Crop-normalized point of sample `(row, column)`.
pub fn sample_point(row: usize, column: usize) -> Vector2<f32> {
    Vector2::new(
        (column as f32 + 0.5) / (0.5 * INPUT_COLUMNS as f32) - 1.0,
        (row as f32 + 0.5) / (0.5 * INPUT_ROWS as f32) - 1.0,
    )
}

/// The bilinear interpolation at `p` (px, pixel centres at integers) of `value(x, y)` on a
/// `width` x `height` grid, the point clamped to the grid.
fn bilinear(
    p: Vector2<f32>,
    width: usize,
    height: usize,
    value: impl Fn(usize, usize) -> f32,
) -> f32 {
    if width == 0 || height == 0 {
        return 0.0;
    }
    let clamp = |v: f32, n: usize| {
        if v.is_nan() {
            0.0
        } else {
            v.clamp(0.0, (n - 1) as f32)
        }
    };
    let (x, y) = (clamp(p.x, width), clamp(p.y, height));
    let (x0, y0) = (libm::floorf(x) as usize, libm::floorf(y) as usize);
    let (x1, y1) = ((x0 + 1).min(width - 1), (y0 + 1).min(height - 1));
    let (fx, fy) = (x - x0 as f32, y - y0 as f32);
    // Each corner read once; the blend in this form (not `math::bilinear_blend`'s) is the one
    // the bundled weights were trained on.
    let (top_left, top_right) = (value(x0, y0), value(x1, y0));
    let (bottom_left, bottom_right) = (value(x0, y1), value(x1, y1));
    let top = top_left + fx * (top_right - top_left);
    let bottom = bottom_left + fx * (bottom_right - bottom_left);
    top + fy * (bottom - top)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mask::ChipMask;
    use crate::shape_guided::tetris::network::PARAMETERS;
    use crate::shape_guided::tetris::weights::{FILE_LEN, write};

    /// A 40 x 4 px bar along x, its pixels 20..=59 and rows 30..=33, on a 96 x 64 chip of sky
    /// level 100 where the bar reads 40.
    fn scene() -> ([u8; 96 * 64], ChipMask) {
        let mut data = [100u8; 96 * 64];
        let mut prior = ChipMask::new();
        prior.reset(96, 64).unwrap();
        for y in 30..=33 {
            prior.set_run(y, 20, 59);
            data[y * 96 + 20..=y * 96 + 59].fill(40);
        }
        (data, prior)
    }

    #[test]
    fn the_crop_spans_its_proportions_of_the_prior_and_maps_back() {
        let (data, prior) = scene();
        let mut bytes = [0u8; FILE_LEN];
        write(&[0.0; PARAMETERS], 1.5, 4.0, 0, &mut bytes).unwrap();
        let weights = TetrisWeights::new_checked(&bytes).unwrap();
        let shape = PriorShape::measure(&prior).unwrap();
        let frame = CropFrame::around(&shape, &weights);
        // The bar's pixel squares span x 19.5..59.5 and y 29.5..33.5.
        assert!((frame.centre - Vector2::new(39.5, 31.5)).norm() < 1e-3);
        assert!((frame.half_along_px - 30.0).abs() < 1e-3);
        assert!((frame.half_across_px - 8.0).abs() < 1e-3);
        let corner = frame.sample_px(0, 0);
        let expected = Vector2::new(
            39.5 - 30.0 * (1.0 - 1.0 / 64.0),
            31.5 - 8.0 * (1.0 - 1.0 / 32.0),
        );
        assert!((corner - expected).norm() < 1e-3, "{corner:?}");
        // The segmentation at x is the prior at x + (3, 0) px: the prior moves 3 px back.
        let g = frame
            .chip_map(Matrix2::identity(), Vector2::new(0.1, 0.0))
            .unwrap();
        let moved = g.inverse().unwrap().apply(Vector2::new(30.0, 31.0));
        assert!(
            (moved - Vector2::new(27.0, 31.0)).norm() < 1e-3,
            "{moved:?}"
        );
        // The dark bar reads about +1 (its edge samples, half on it, lower the contrast under
        // the prior by a few per cent), the sky 0.
        let chip = ChipView::gray8(&data, 96, 64, 96, 0, 0).unwrap();
        let mut input = [0.0f32; INPUT_LEN];
        frame.fill(&chip, &prior, &Affine2::IDENTITY, &mut input);
        let plane = PLANE;
        let middle = (INPUT_ROWS / 2) * INPUT_COLUMNS + INPUT_COLUMNS / 2;
        assert!((input[middle] - 1.0).abs() < 0.1, "{}", input[middle]);
        assert!((input[plane + middle] - 1.0).abs() < 1e-6);
        assert!(input[0].abs() < 0.05 && input[plane].abs() < 1e-6);
    }
}
