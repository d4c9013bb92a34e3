//! The prior's boundary as points: the contour GVF-ASM moves.

use super::prior::{PriorShape, for_each_set};
use crate::capacity::SHAPE_BOUNDARY_POINTS;
use crate::mask::BitMask;
use nalgebra::Vector2;

/// Up to [`SHAPE_BOUNDARY_POINTS`] points on the prior's outline, chip px.
#[derive(Debug, Clone)]
pub struct Boundary {
    points: [Vector2<f32>; SHAPE_BOUNDARY_POINTS],
    len: usize,
}

impl Default for Boundary {
    fn default() -> Self {
        Self::new()
    }
}

impl Boundary {
    /// No points.
    pub const fn new() -> Self {
        Boundary {
            points: [Vector2::new(0.0, 0.0); SHAPE_BOUNDARY_POINTS],
            len: 0,
        }
    }

    /// The points.
    pub fn points(&self) -> &[Vector2<f32>] {
        self.points.get(..self.len).unwrap_or(&[])
    }

    /// Collects the outline of `prior`: each set pixel with a 4-neighbour that is not set
    /// gives one point half a pixel outwards from its centre (towards the unset neighbours), so
    /// the points lie on the pixel edges of the silhouette. A longer outline than the capacity is
    /// taken every k-th pixel, in raster order.
    pub fn collect<const W: usize>(&mut self, prior: &BitMask<W>, shape: &PriorShape) {
        let [x0, x1, y0, y1] = shape.bbox;
        let window = [x0, x1 + 1, y0, y1 + 1];
        let mut total = 0usize;
        for_each_set(prior, window, |x, y| {
            if outward(prior, x, y).is_some() {
                total += 1;
            }
        });
        let stride = total.div_ceil(SHAPE_BOUNDARY_POINTS).max(1);
        self.len = 0;
        let mut k = 0usize;
        for_each_set(prior, window, |x, y| {
            if let Some(normal) = outward(prior, x, y) {
                if k % stride == 0
                    && let Some(slot) = self.points.get_mut(self.len)
                {
                    *slot = Vector2::new(x as f32, y as f32) + 0.5 * normal;
                    self.len += 1;
                }
                k += 1;
            }
        });
    }
}

/// For a set pixel (x, y) with an unset 4-neighbour (pixels outside the mask count as unset):
/// the unit direction towards its unset neighbours, or zero where they cancel out (a line one
/// pixel thin); `None` for an interior pixel.
fn outward<const W: usize>(mask: &BitMask<W>, x: usize, y: usize) -> Option<Vector2<f32>> {
    let unset = |dx: i64, dy: i64| -> f32 {
        let (nx, ny) = (x as i64 + dx, y as i64 + dy);
        let inside = nx >= 0 && ny >= 0 && mask.get(nx as usize, ny as usize);
        if inside { 0.0 } else { 1.0 }
    };
    let (right, left, down, up) = (unset(1, 0), unset(-1, 0), unset(0, 1), unset(0, -1));
    if right + left + down + up == 0.0 {
        return None;
    }
    let d = Vector2::new(right - left, down - up);
    let n = d.norm();
    Some(if n > 0.0 { d / n } else { d })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mask::ChipMask;

    #[test]
    fn outline_of_a_rectangle_lies_on_its_pixel_edges() {
        let mut m = ChipMask::new();
        m.reset(32, 32).unwrap();
        for y in 10..14 {
            m.set_run(y, 5, 24); // 20 x 4 px: x in [4.5, 24.5], y in [9.5, 13.5]
        }
        let shape = PriorShape::measure(&m).unwrap();
        let mut b = Boundary::new();
        b.collect(&m, &shape);
        // Perimeter pixels: 2 x 20 + 2 x 2.
        assert_eq!(b.points().len(), 44);
        for p in b.points() {
            let inside = (4.5..=24.5).contains(&p.x) && (9.5..=13.5).contains(&p.y);
            let to_edge = [p.x - 4.5, 24.5 - p.x, p.y - 9.5, 13.5 - p.y]
                .into_iter()
                .fold(f32::MAX, f32::min);
            // Edge pixels land on the edge; the corner pixels 0.15 px inside the corner.
            assert!(inside && to_edge < 0.2, "{p:?}");
        }
    }

    #[test]
    fn long_outlines_are_strided_to_capacity() {
        let mut m = ChipMask::new();
        m.reset(512, 512).unwrap();
        for y in 100..400 {
            m.set_run(y, 100, 399); // 300 x 300 px: 1196 outline pixels
        }
        let shape = PriorShape::measure(&m).unwrap();
        let mut b = Boundary::new();
        b.collect(&m, &shape);
        assert!(b.points().len() > SHAPE_BOUNDARY_POINTS / 2);
        assert!(b.points().len() <= SHAPE_BOUNDARY_POINTS);
    }
}
