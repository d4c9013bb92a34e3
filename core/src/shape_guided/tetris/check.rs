//! The check a warp must pass: the warped prior, as the chip mask the segmentation will be,
//! fits the chip's pixels in the network's crop better than the mask it moves.
//!
//! Each chip pixel whose centre lies in the crop is normalized as the network's input is (the
//! sky 0, the body about +1, by the prior's contrast: [`LevelSums`]), and a mask's residual is
//! the sum of `(grey - bit)²` over them. The warp must lower it by more than the sky's noise
//! explains over the pixels it changes ([`Comparison::candidate_is_better`]): where the body is
//! as faint as the noise, a warp that fits the noise is not kept. (Judged on the crop's
//! resampled planes, as it first was, warps that shrink a right prior read lower and were kept.)

use super::input::{CropFrame, GreyScale, LevelSums};
use crate::chip::ChipView;
use crate::mask::BitMask;
use crate::shape_guided::affine::Affine2;
use crate::shape_guided::warp::warped_at;
use nalgebra::Vector2;

/// Sums of `(grey - bit)²` over the crop's pixels for the mask a pass starts from and the one
/// it proposes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Comparison {
    /// Sum for the current mask.
    pub current: f32,
    /// Sum for the proposed one.
    pub candidate: f32,
    /// Pixels in the crop.
    pub pixels: u32,
    /// Pixels whose bit differs between the two.
    pub changed: u32,
    /// The normalized sky's standard deviation.
    pub sky_sd: f32,
}

impl Comparison {
    /// Mean squared difference of the current mask.
    pub fn current_mean(&self) -> f32 {
        self.current / self.pixels.max(1) as f32
    }

    /// Mean squared difference of the proposed mask.
    pub fn candidate_mean(&self) -> f32 {
        self.candidate / self.pixels.max(1) as f32
    }

    /// Whether the proposed mask fits better by more than noise explains: each changed pixel
    /// moves the sum by `±(1 - 2 grey)`, whose noise has deviation `2 sky_sd`, so the gain must
    /// pass [`SIGNIFICANCE`] times `2 sky_sd sqrt(changed)`. NaN sums never pass.
    pub fn candidate_is_better(&self) -> bool {
        let noise = 2.0 * self.sky_sd * libm::sqrtf(self.changed as f32);
        self.current - self.candidate > SIGNIFICANCE * noise
    }
}

/// How many noise deviations a warp's gain must reach.
pub const SIGNIFICANCE: f32 = 2.0;

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
            let end = (libm::floorf(hi).max(-1.0) + 1.0).max(0.0) as usize;
            (first.min(n), end.min(n))
        };
        let (x0, x1) = extreme(|p| p.x, chip.width());
        let (y0, y1) = extreme(|p| p.y, chip.height());
        let mut check = PixelCheck {
            chip,
            prior,
            frame,
            bounds: [x0, x1, y0, y1],
            scale: LevelSums::default().scale(),
        };
        let mut levels = LevelSums::default();
        check.for_each_pixel(|x, y, level| levels.add(level, prior.get(x, y)));
        check.scale = levels.scale();
        check
    }

    /// The prior warped by `current` against it warped by `candidate` (chip px to chip px;
    /// None where either cannot be inverted).
    pub fn compare(&self, current: &Affine2, candidate: &Affine2) -> Option<Comparison> {
        let (current, candidate) = (current.inverse()?, candidate.inverse()?);
        let mut sums = Comparison {
            current: 0.0,
            candidate: 0.0,
            pixels: 0,
            changed: 0,
            sky_sd: self.scale.sky_sd,
        };
        let bit = |on: bool| if on { 1.0 } else { 0.0 };
        self.for_each_pixel(|x, y, level| {
            let grey = self.scale.normalized(level);
            let (was, is) = (
                warped_at(self.prior, &current, x, y),
                warped_at(self.prior, &candidate, x, y),
            );
            let (d_was, d_is) = (grey - bit(was), grey - bit(is));
            sums.current += d_was * d_was;
            sums.candidate += d_is * d_is;
            sums.pixels += 1;
            sums.changed += u32::from(was != is);
        });
        Some(sums)
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
        // One row off: 2 x 40 pixels changed, each wrong by 1; two rows: 4 x 40.
        let one = check.compare(&Affine2::IDENTITY, &shift(1.0)).unwrap();
        let two = check.compare(&Affine2::IDENTITY, &shift(2.0)).unwrap();
        assert_eq!((one.current, one.candidate, one.changed), (0.0, 80.0, 80));
        assert_eq!((two.candidate, two.changed), (160.0, 160));
        assert_eq!(one.sky_sd, 0.0, "a flat sky");
        assert!(!one.candidate_is_better());
        // Back from one row off: better by 80 against no noise.
        let back = check.compare(&shift(1.0), &Affine2::IDENTITY).unwrap();
        assert_eq!((back.current, back.candidate), (80.0, 0.0));
        assert!(back.candidate_is_better());
    }

    #[test]
    fn a_blurred_bar_scores_its_own_mask_below_a_narrower_or_wider_one() {
        let data = bar_chip((30, 33), 70);
        let chip = ChipView::gray8(&data, W, H, W, 0, 0).unwrap();
        let prior = bar_mask((30, 33));
        let check = check(&chip, &prior);
        let about = |scale: f32| {
            Affine2::about(
                Vector2::new(40.0, 31.5),
                Matrix2::new(1.0, 0.0, 0.0, scale),
                Vector2::zeros(),
            )
        };
        for other in [about(0.75), about(1.5), shift(1.0)] {
            let c = check.compare(&Affine2::IDENTITY, &other).unwrap();
            assert!(c.current < c.candidate, "{other:?}: {c:?}");
            assert!(!c.candidate_is_better());
        }
    }

    /// The gain a warp needs grows with the sky's noise and the pixels it changes: a gain of 10
    /// over 25 changed pixels passes against a normalized noise of 0.4 (2 x 2 x 0.4 x 5 = 8) and
    /// not against 0.6 (12).
    #[test]
    fn a_gain_must_pass_the_noise_over_the_changed_pixels() {
        let at = |sky_sd: f32| Comparison {
            current: 30.0,
            candidate: 20.0,
            pixels: 1000,
            changed: 25,
            sky_sd,
        };
        assert!(at(0.4).candidate_is_better());
        assert!(!at(0.6).candidate_is_better());
        assert!(
            !Comparison {
                candidate: f32::NAN,
                ..at(0.0)
            }
            .candidate_is_better()
        );
    }
}
