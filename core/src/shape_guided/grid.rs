//! An oriented sampling grid over the prior's region, and bilinear sampling of the chip and of
//! grid fields.
//!
//! The body is long and thin, so the grid is aligned with the prior's principal axis: cell
//! (i, j) lies at `origin + step (i u + j v)` in chip px, i along the axis u, j across it. Its
//! step is 1 px, or coarser when the region would need more than the capacity's cells.

use super::prior::PriorShape;
use crate::chip::ChipView;
use crate::math::bilinear_blend;
use nalgebra::Vector2;

/// A `width` x `height` grid of cells `step` px apart, aligned with a prior's axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    origin: Vector2<f32>,
    axis: Vector2<f32>,
    step: f32,
    width: usize,
    height: usize,
}

impl Grid {
    /// The grid covering the prior's extent box grown by `margin_px` on every side, in at most
    /// `capacity` cells of at least 2 x 2; `None` for a non-finite shape or margin.
    pub fn around(shape: &PriorShape, margin_px: f32, capacity: usize) -> Option<Grid> {
        let [u0, u1, v0, v1] = shape.extent;
        let margin = margin_px.max(0.0);
        let (len_u, len_v) = (u1 - u0 + 2.0 * margin, v1 - v0 + 2.0 * margin);
        if !(len_u.is_finite() && len_v.is_finite() && shape.centre.x.is_finite()) || capacity < 4 {
            return None;
        }
        let mut step = libm::sqrtf(len_u.max(1.0) * len_v.max(1.0) / capacity as f32).max(1.0);
        let cells_along = |len: f32, step: f32| {
            (libm::ceilf(len.max(0.0) / step) as usize)
                .saturating_add(1)
                .max(2)
        };
        // The product of the rounded-up sides can exceed the capacity by a few rows: grow the
        // step until it fits (each 2 % step shrinks both sides, so this ends).
        let (width, height) = loop {
            let (w, h) = (cells_along(len_u, step), cells_along(len_v, step));
            if w.saturating_mul(h) <= capacity {
                break (w, h);
            }
            step *= 1.02;
        };
        let e = shape.frame();
        Some(Grid {
            origin: shape.centre + e * Vector2::new(u0 - margin, v0 - margin),
            axis: shape.axis,
            step,
            width,
            height,
        })
    }

    /// Cells along the axis.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Cells across the axis.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Distance between neighbouring cells, px.
    pub fn step(&self) -> f32 {
        self.step
    }

    /// Number of cells.
    pub fn cells(&self) -> usize {
        self.width * self.height
    }

    /// Index of cell (i, j) in a row-major buffer (rows along the axis).
    #[inline]
    pub fn index(&self, i: usize, j: usize) -> usize {
        j * self.width + i
    }

    /// Chip position of cell (i, j), px.
    #[inline]
    pub fn to_chip(&self, i: usize, j: usize) -> Vector2<f32> {
        self.origin + self.cell_vector_to_chip(Vector2::new(i as f32, j as f32))
    }

    /// Fractional cell coordinates (i, j) of chip position `p`.
    #[inline]
    pub fn to_cell(&self, p: Vector2<f32>) -> Vector2<f32> {
        let d = (p - self.origin) / self.step;
        Vector2::new(
            d.x * self.axis.x + d.y * self.axis.y,
            -d.x * self.axis.y + d.y * self.axis.x,
        )
    }

    /// A vector of `c.x` cells along the axis and `c.y` across it, in chip px.
    #[inline]
    pub fn cell_vector_to_chip(&self, c: Vector2<f32>) -> Vector2<f32> {
        let across = Vector2::new(-self.axis.y, self.axis.x);
        (self.axis * c.x + across * c.y) * self.step
    }

    /// Bilinear interpolation of a field stored on this grid (row-major, [`Grid::index`]) at
    /// fractional cell `c`; `None` outside the grid or for a short buffer.
    pub fn interpolate(&self, field: &[f32], c: Vector2<f32>) -> Option<f32> {
        bilinear(self.width, self.height, c, |i, j| {
            field.get(self.index(i, j)).copied()
        })
    }
}

/// The chip's grey level at chip position `p` (px, pixel centres at integers), interpolated
/// bilinearly; `None` outside the span of pixel centres.
#[inline]
pub fn sample_chip(chip: &ChipView, p: Vector2<f32>) -> Option<f32> {
    bilinear(chip.width(), chip.height(), p, |x, y| {
        Some(f32::from(chip.get(x, y)))
    })
}

/// Bilinear interpolation of `value(x, y)` on a `width` x `height` lattice at `p`.
#[inline]
fn bilinear(
    width: usize,
    height: usize,
    p: Vector2<f32>,
    value: impl Fn(usize, usize) -> Option<f32>,
) -> Option<f32> {
    let (max_x, max_y) = (width.checked_sub(1)? as f32, height.checked_sub(1)? as f32);
    // Also rejects NaN.
    if !(p.x >= 0.0 && p.y >= 0.0 && p.x <= max_x && p.y <= max_y) {
        return None;
    }
    let (x0, y0) = (p.x as usize, p.y as usize);
    let (fx, fy) = (p.x - x0 as f32, p.y - y0 as f32);
    let (x1, y1) = ((x0 + 1).min(width - 1), (y0 + 1).min(height - 1));
    let corners = [
        value(x0, y0)?,
        value(x1, y0)?,
        value(x0, y1)?,
        value(x1, y1)?,
    ];
    Some(bilinear_blend(corners, fx, fy))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_covers_the_region_within_capacity() {
        let shape = PriorShape::for_tests(Vector2::new(40.0, 30.0), 0.5);
        let g = Grid::around(&shape, 3.0, 64).expect("grid");
        assert!(g.cells() <= 64 && g.width() >= g.height());
        // (20 + 6) x (4 + 6) px does not fit 64 cells at 1 px: the step grows.
        assert!(g.step() > 1.0);
        // Round trip and the far corner reaching past the grown extent.
        let p = g.to_chip(3, 2);
        assert!((g.to_cell(p) - Vector2::new(3.0, 2.0)).norm() < 1e-4);
        let far = g.to_cell(shape.centre + shape.frame() * Vector2::new(13.0, 5.0));
        assert!(far.x <= (g.width() - 1) as f32 && far.y <= (g.height() - 1) as f32);
        let fine = Grid::around(&shape, 3.0, 4096).expect("grid");
        assert_eq!(fine.step(), 1.0);
    }

    #[test]
    fn bilinear_sampling_of_chip_and_field() {
        let data: [u8; 6] = [0, 10, 20, 30, 40, 50];
        let chip = ChipView::gray8(&data, 3, 2, 3, 0, 0).unwrap();
        assert_eq!(sample_chip(&chip, Vector2::new(0.5, 0.5)), Some(20.0));
        assert_eq!(sample_chip(&chip, Vector2::new(2.0, 1.0)), Some(50.0));
        assert_eq!(sample_chip(&chip, Vector2::new(2.01, 0.0)), None);
        assert_eq!(sample_chip(&chip, Vector2::new(f32::NAN, 0.0)), None);
        let shape = PriorShape::for_tests(Vector2::new(0.0, 0.0), 0.0);
        let g = Grid::around(&shape, 0.0, 4096).unwrap();
        let field: [f32; 4096] = core::array::from_fn(|k| (k % g.width()) as f32);
        assert_eq!(g.interpolate(&field, Vector2::new(2.25, 1.0)), Some(2.25));
        assert_eq!(g.interpolate(&field[..3], Vector2::new(2.25, 1.0)), None);
    }
}
