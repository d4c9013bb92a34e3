//! The transformed prior as a chip mask: each chip pixel takes the prior's pixel nearest to its
//! pre-image under the transform.

use super::affine::Affine2;
use super::prior::PriorShape;
use crate::mask::{BitMask, MaskTooLarge};
use nalgebra::Vector2;

/// Why a warp could not be drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WarpError {
    /// The transform is singular or not finite.
    Singular,
    /// The output does not fit its capacity.
    TooLarge(MaskTooLarge),
}

/// Writes `transform(prior)` into `out` (resized to the prior's size); returns its set pixels.
pub fn warp_prior<const W: usize>(
    prior: &BitMask<W>,
    shape: &PriorShape,
    transform: &Affine2,
    out: &mut BitMask<W>,
) -> Result<usize, WarpError> {
    let inverse = transform.inverse().ok_or(WarpError::Singular)?;
    let (w, h) = (prior.width(), prior.height());
    out.reset(w, h).map_err(WarpError::TooLarge)?;
    // The image of the prior's bounding box (pixel squares included), clipped to the chip.
    let [x0, x1, y0, y1] = shape.bbox;
    let corners = [
        (x0 as f32 - 0.5, y0 as f32 - 0.5),
        (x1 as f32 + 0.5, y0 as f32 - 0.5),
        (x0 as f32 - 0.5, y1 as f32 + 0.5),
        (x1 as f32 + 0.5, y1 as f32 + 0.5),
    ]
    .map(|(x, y)| transform.apply(Vector2::new(x, y)));
    let lo = |f: fn(&Vector2<f32>) -> f32| corners.iter().map(f).fold(f32::MAX, f32::min);
    let hi = |f: fn(&Vector2<f32>) -> f32| corners.iter().map(f).fold(f32::MIN, f32::max);
    let span = |a: f32, b: f32, n: usize| {
        let first = libm::floorf(a).max(0.0) as usize;
        let last = (libm::ceilf(b).max(0.0) as usize).min(n.saturating_sub(1));
        (first, last)
    };
    let (cx0, cx1) = span(lo(|p| p.x), hi(|p| p.x), w);
    let (cy0, cy1) = span(lo(|p| p.y), hi(|p| p.y), h);
    let mut count = 0;
    for y in cy0..=cy1.min(h.saturating_sub(1)) {
        for x in cx0..=cx1 {
            if warped_at(prior, &inverse, x, y) {
                out.set(x, y, true);
                count += 1;
            }
        }
    }
    Ok(count)
}

/// Whether the warped prior holds chip pixel `(x, y)`: the prior's pixel nearest to its
/// pre-image under the warp (`inverse` maps the warped prior's px to the prior's).
pub fn warped_at<const W: usize>(
    prior: &BitMask<W>,
    inverse: &Affine2,
    x: usize,
    y: usize,
) -> bool {
    let q = inverse.apply(Vector2::new(x as f32, y as f32));
    let (qx, qy) = (libm::roundf(q.x), libm::roundf(q.y));
    qx >= 0.0 && qy >= 0.0 && prior.get(qx as usize, qy as usize)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mask::ChipMask;
    use nalgebra::Matrix2;

    fn rectangle(x0: usize, x1: usize, y0: usize, y1: usize) -> ChipMask {
        let mut m = ChipMask::new();
        m.reset(64, 48).unwrap();
        for y in y0..=y1 {
            m.set_run(y, x0, x1);
        }
        m
    }

    #[test]
    fn identity_copies_and_shift_moves() {
        let prior = rectangle(10, 29, 20, 23);
        let shape = PriorShape::measure(&prior).unwrap();
        let mut out = ChipMask::new();
        assert_eq!(
            warp_prior(&prior, &shape, &Affine2::IDENTITY, &mut out),
            Ok(80)
        );
        assert!((0..48).all(|y| (0..64).all(|x| out.get(x, y) == prior.get(x, y))));
        let shift = Affine2::about(
            Vector2::zeros(),
            Matrix2::identity(),
            Vector2::new(3.0, -2.0),
        );
        warp_prior(&prior, &shape, &shift, &mut out).unwrap();
        let moved = rectangle(13, 32, 18, 21);
        assert!((0..48).all(|y| (0..64).all(|x| out.get(x, y) == moved.get(x, y))));
    }

    #[test]
    fn scaling_about_the_centre_grows_and_clips_at_the_border() {
        let prior = rectangle(10, 29, 20, 23);
        let shape = PriorShape::measure(&prior).unwrap();
        let grow = Affine2::about(shape.centre, Matrix2::identity() * 2.0, Vector2::zeros());
        let mut out = ChipMask::new();
        let n = warp_prior(&prior, &shape, &grow, &mut out).unwrap();
        assert!((n as i64 - 320).abs() <= 24, "{n}");
        let huge = Affine2::about(shape.centre, Matrix2::identity() * 10.0, Vector2::zeros());
        let n = warp_prior(&prior, &shape, &huge, &mut out).unwrap();
        assert!(n <= 64 * 48 && out.width() == 64);
        let flat = Affine2::about(shape.centre, Matrix2::zeros(), Vector2::zeros());
        assert_eq!(
            warp_prior(&prior, &shape, &flat, &mut out),
            Err(WarpError::Singular)
        );
    }
}
