//! The check a warp must pass: the warped prior, as the chip mask the segmentation will be,
//! fits the chip's pixels in the network's crop better than the mask it moves.
//!
//! Each chip pixel whose centre lies in the crop is normalized as the network's input is (the
//! sky 0, the body about +1, by the prior's contrast: [`LevelSums`]), and a mask's residual is
//! the mean of `(grey - bit)²` over them. Judged on the crop's resampled planes instead, a warp
//! that shrinks a right prior around a blurred, shaded body read lower and was kept.

use super::input::{CropFrame, GreyScale, LevelSums};
use crate::chip::ChipView;
use crate::mask::BitMask;
use crate::shape_guided::affine::Affine2;
use crate::shape_guided::warp::warped_at;
use nalgebra::Vector2;

/// The crop's chip pixels, normalized by the prior.
pub struct PixelCheck<'a, const W: usize> {
    chip: &'a ChipView<'a>,
    prior: &'a BitMask<W>,
    frame: CropFrame,
    /// Chip px box holding the crop: `[x0, x1) x [y0, y1)`.
    bounds: [usize; 4],
    scale: GreyScale,
}

impl<'a, const W: usize> PixelCheck<'a, W> {
    /// The check over `frame`'s pixels of `chip`, normalized by `prior`.
    pub fn new(chip: &'a ChipView<'a>, prior: &'a BitMask<W>, frame: CropFrame) -> Self {
        let corners = [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)]
            .map(|(s, t)| frame.to_chip(Vector2::new(s, t)));
        let extreme = |f: fn(&Vector2<f32>) -> f32, n: usize| {
            let lo = corners.iter().map(f).fold(f32::MAX, f32::min);
            let hi = corners.iter().map(f).fold(f32::MIN, f32::max);
            let first = libm::ceilf(lo).max(0.0) as usize;
            (
                (first).min(n),
                (libm::floorf(hi).max(-1.0) + 1.0).max(0.0) as usize,
            )
        };
        let (x0, x1) = extreme(|p| p.x, chip.width());
        let (y0, y1) = extreme(|p| p.y, chip.height());
        let mut check = PixelCheck {
            chip,
            prior,
            frame,
            bounds: [x0, x1.min(chip.width()), y0, y1.min(chip.height())],
            scale: LevelSums::default().scale(),
        };
        let mut levels = LevelSums::default();
        check.for_each_pixel(|x, y, level| levels.add(level, prior.get(x, y)));
        check.scale = levels.scale();
        check
    }

    /// The mean squared difference between the normalized pixels and the prior warped by
    /// `transform` (chip px to chip px; None where it cannot be inverted).
    pub fn residual(&self, transform: &Affine2) -> Option<f32> {
        let inverse = transform.inverse()?;
        let (mut sum, mut count) = (0.0f32, 0.0f32);
        self.for_each_pixel(|x, y, level| {
            let bit = if warped_at(self.prior, &inverse, x, y) {
                1.0
            } else {
                0.0
            };
            let d = self.scale.normalized(level) - bit;
            sum += d * d;
            count += 1.0;
        });
        Some(sum / count.max(1.0))
    }

    /// Calls `visit(x, y, grey level)` for every chip pixel whose centre is in the crop.
    fn for_each_pixel(&self, mut visit: impl FnMut(usize, usize, f32)) {
        let [x0, x1, y0, y1] = self.bounds;
        let (u, v) = (
            self.frame.axis,
            Vector2::new(-self.frame.axis.y, self.frame.axis.x),
        );
        for y in y0..y1 {
            for x in x0..x1 {
                let d = Vector2::new(x as f32, y as f32) - self.frame.centre;
                let inside = libm::fabsf(d.dot(&u)) <= self.frame.half_along_px
                    && libm::fabsf(d.dot(&v)) <= self.frame.half_across_px;
                if inside {
                    visit(x, y, f32::from(self.chip.get(x, y)));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mask::ChipMask;
    use crate::shape_guided::prior::PriorShape;
    use nalgebra::Matrix2;

    const W: usize = 96;
    const H: usize = 64;

    /// A dark bar over columns 20..=59 and rows `rows` on a sky of 100, with the rows beside it
    /// at `edge` (a blurred edge).
    fn bar_chip(rows: (usize, usize), edge: u8) -> [u8; W * H] {
        let mut data = [100u8; W * H];
        for y in rows.0 - 1..=rows.1 + 1 {
            let level = if y < rows.0 || y > rows.1 { edge } else { 40 };
            data[y * W + 20..=y * W + 59].fill(level);
        }
        data
    }

    fn bar_mask(rows: (usize, usize)) -> ChipMask {
        let mut m = ChipMask::new();
        m.reset(W, H).unwrap();
        for y in rows.0..=rows.1 {
            m.set_run(y, 20, 59);
        }
        m
    }

    fn shift(dy: f32) -> Affine2 {
        Affine2::about(Vector2::zeros(), Matrix2::identity(), Vector2::new(0.0, dy))
    }

    fn check<'a>(
        chip: &'a ChipView<'a>,
        prior: &'a ChipMask,
    ) -> PixelCheck<'a, { crate::capacity::MASK_WORDS }> {
        let shape = PriorShape::measure(prior).unwrap();
        PixelCheck::new(chip, prior, CropFrame::with_proportions(&shape, 1.5, 4.0))
    }

    #[test]
    fn a_sharp_bar_scores_its_own_mask_zero_and_a_shift_by_its_mismatched_pixels() {
        let data = bar_chip((30, 33), 100);
        let chip = ChipView::gray8(&data, W, H, W, 0, 0).unwrap();
        let prior = bar_mask((30, 33));
        let check = check(&chip, &prior);
        assert_eq!(check.residual(&Affine2::IDENTITY), Some(0.0));
        // One row off: 2 x 40 pixels wrong by 1; two rows: 4 x 40.
        let one = check.residual(&shift(1.0)).unwrap();
        let two = check.residual(&shift(2.0)).unwrap();
        assert!(one > 0.0);
        assert!((two / one - 2.0).abs() < 1e-5, "{one} {two}");
    }

    #[test]
    fn a_blurred_bar_scores_its_own_mask_below_a_narrower_or_wider_one() {
        let data = bar_chip((30, 33), 70);
        let chip = ChipView::gray8(&data, W, H, W, 0, 0).unwrap();
        let prior = bar_mask((30, 33));
        let check = check(&chip, &prior);
        let right = check.residual(&Affine2::IDENTITY).unwrap();
        let thinner = Affine2::about(
            Vector2::new(40.0, 31.5),
            Matrix2::new(1.0, 0.0, 0.0, 0.75),
            Vector2::zeros(),
        );
        let wider = Affine2::about(
            Vector2::new(40.0, 31.5),
            Matrix2::new(1.0, 0.0, 0.0, 1.5),
            Vector2::zeros(),
        );
        for other in [thinner, wider, shift(1.0)] {
            assert!(right < check.residual(&other).unwrap(), "{other:?}");
        }
    }
}
