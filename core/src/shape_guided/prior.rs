//! The shape prior's placement: bounding box, centroid, principal axis and extents along it.

use super::affine::Affine2;
use crate::mask::BitMask;
use nalgebra::{Matrix2, Vector2};

/// Where the prior lies in the chip (px, pixel centres at integers).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PriorShape {
    /// Set pixels.
    pub count: usize,
    /// Bounding box of the set pixels: first and last column, first and last row.
    pub bbox: [usize; 4],
    /// Centroid, px.
    pub centre: Vector2<f32>,
    /// Unit principal (long) axis u; v = (-u.y, u.x) is across it.
    pub axis: Vector2<f32>,
    /// Extent of the pixel squares along u and v from the centroid: `[u_min, u_max, v_min,
    /// v_max]`, px.
    pub extent: [f32; 4],
}

impl PriorShape {
    /// Measures the set pixels of `prior`; `None` when it has none.
    pub fn measure<const W: usize>(prior: &BitMask<W>) -> Option<PriorShape> {
        let (mut n, mut sx, mut sy) = (0usize, 0.0f32, 0.0f32);
        let mut bbox = [usize::MAX, 0, usize::MAX, 0];
        for_each_set(prior, [0, prior.width(), 0, prior.height()], |x, y| {
            n += 1;
            sx += x as f32;
            sy += y as f32;
            bbox = [
                bbox[0].min(x),
                bbox[1].max(x),
                bbox[2].min(y),
                bbox[3].max(y),
            ];
        });
        if n == 0 {
            return None;
        }
        let centre = Vector2::new(sx / n as f32, sy / n as f32);
        let (mut sxx, mut sxy, mut syy) = (0.0f32, 0.0f32, 0.0f32);
        let window = [bbox[0], bbox[1] + 1, bbox[2], bbox[3] + 1];
        for_each_set(prior, window, |x, y| {
            let (dx, dy) = (x as f32 - centre.x, y as f32 - centre.y);
            sxx += dx * dx;
            sxy += dx * dy;
            syy += dy * dy;
        });
        let angle = 0.5 * libm::atan2f(2.0 * sxy, sxx - syy);
        let (s, c) = libm::sincosf(angle);
        let mut shape = PriorShape {
            count: n,
            bbox,
            centre,
            axis: Vector2::new(c, s),
            extent: [f32::MAX, f32::MIN, f32::MAX, f32::MIN],
        };
        // A pixel square reaches 0.5 (|u_x| + |u_y|) px beyond its centre along either axis.
        let reach = 0.5 * (c.abs() + s.abs());
        let frame = shape.frame();
        let mut extent = shape.extent;
        for_each_set(prior, window, |x, y| {
            let local = frame.transpose() * (Vector2::new(x as f32, y as f32) - centre);
            extent = [
                extent[0].min(local.x - reach),
                extent[1].max(local.x + reach),
                extent[2].min(local.y - reach),
                extent[3].max(local.y + reach),
            ];
        });
        shape.extent = extent;
        Some(shape)
    }

    /// The frame `E = [u v]`: columns are the unit axis and its perpendicular.
    pub fn frame(&self) -> Matrix2<f32> {
        Matrix2::new(self.axis.x, -self.axis.y, self.axis.y, self.axis.x)
    }

    /// Corners of the extent box in chip px.
    pub fn corners(&self) -> [Vector2<f32>; 4] {
        let e = self.frame();
        let [u0, u1, v0, v1] = self.extent;
        [(u0, v0), (u1, v0), (u1, v1), (u0, v1)].map(|(u, v)| self.centre + e * Vector2::new(u, v))
    }

    /// The shape of the prior moved by `transform` (chip px to chip px), from its extent box:
    /// the centroid moved, the axis turned and the box's moved corners measured along and
    /// across it (exact for a move that keeps right angles, a bound otherwise). `None` where the
    /// move collapses the axis.
    pub fn moved(&self, transform: &Affine2) -> Option<PriorShape> {
        let axis = transform.matrix() * self.axis;
        let length = axis.norm();
        if !(length.is_finite() && length > 1e-6) {
            return None;
        }
        let axis = axis / length;
        let centre = transform.apply(self.centre);
        let across = Vector2::new(-axis.y, axis.x);
        let mut extent = [f32::MAX, f32::MIN, f32::MAX, f32::MIN];
        let mut bbox = [f32::MAX, f32::MIN, f32::MAX, f32::MIN];
        for corner in self.corners().map(|c| transform.apply(c)) {
            let (u, v) = ((corner - centre).dot(&axis), (corner - centre).dot(&across));
            extent = [
                extent[0].min(u),
                extent[1].max(u),
                extent[2].min(v),
                extent[3].max(v),
            ];
            bbox = [
                bbox[0].min(corner.x),
                bbox[1].max(corner.x),
                bbox[2].min(corner.y),
                bbox[3].max(corner.y),
            ];
        }
        let pixel = |v: f32| libm::roundf(v).max(0.0) as usize;
        Some(PriorShape {
            count: self.count,
            bbox: bbox.map(pixel),
            centre,
            axis,
            extent,
        })
    }

    /// A shape with this centre and axis angle and a 20 x 4 px extent, for tests.
    #[cfg(test)]
    pub fn for_tests(centre: Vector2<f32>, angle_rad: f32) -> PriorShape {
        let (s, c) = libm::sincosf(angle_rad);
        PriorShape {
            count: 80,
            bbox: [0, 0, 0, 0],
            centre,
            axis: Vector2::new(c, s),
            extent: [-10.0, 10.0, -2.0, 2.0],
        }
    }
}

/// Calls `f(x, y)` for every set pixel of `mask` in columns `window[0]..window[1]` and rows
/// `window[2]..window[3]`.
pub fn for_each_set<const W: usize>(
    mask: &BitMask<W>,
    window: [usize; 4],
    mut f: impl FnMut(usize, usize),
) {
    let [x0, x1, y0, y1] = window;
    for y in y0..y1.min(mask.height()) {
        for x in x0..x1.min(mask.width()) {
            if mask.get(x, y) {
                f(x, y);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mask::ChipMask;

    #[test]
    fn measures_a_diagonal_bar() {
        let mut m = ChipMask::new();
        m.reset(64, 64).unwrap();
        // A 3-px-thick bar along the diagonal from (10, 10) to (40, 40).
        for k in 10..=40 {
            for d in 0..3 {
                m.set(k + d, k, true);
            }
        }
        let s = PriorShape::measure(&m).expect("pixels");
        assert_eq!(s.count, 93);
        assert_eq!(s.bbox, [10, 42, 10, 40]);
        assert!((s.centre - Vector2::new(26.0, 25.0)).norm() < 1e-3);
        let diag = core::f32::consts::FRAC_1_SQRT_2;
        assert!(s.axis.x.abs() > 0.99 * diag && (s.axis.x * s.axis.y) > 0.0);
        let length = s.extent[1] - s.extent[0];
        assert!(
            (length - 30.0 * core::f32::consts::SQRT_2 - 2.0).abs() < 2.0,
            "{length}"
        );
        let corners = s.corners();
        assert!(((corners[1] - corners[0]).norm() - length).abs() < 1e-3);
    }

    #[test]
    fn a_moved_shape_keeps_its_box_in_the_moved_frame() {
        let shape = PriorShape::for_tests(Vector2::new(30.0, 20.0), 0.0);
        let quarter = core::f32::consts::FRAC_PI_2;
        let (s, c) = libm::sincosf(quarter);
        let turn = Affine2::about(
            shape.centre,
            nalgebra::Matrix2::new(c, -s, s, c),
            Vector2::new(5.0, -3.0),
        );
        let moved = shape.moved(&turn).expect("a move that keeps the axis");
        assert!((moved.centre - Vector2::new(35.0, 17.0)).norm() < 1e-4);
        assert!(
            (moved.axis - Vector2::new(0.0, 1.0)).norm() < 1e-5,
            "{:?}",
            moved.axis
        );
        for (a, b) in moved.extent.iter().zip([-10.0, 10.0, -2.0, 2.0]) {
            assert!((a - b).abs() < 1e-4, "{:?}", moved.extent);
        }
        // Doubling along x doubles the length.
        let stretch = Affine2::about(
            shape.centre,
            nalgebra::Matrix2::new(2.0, 0.0, 0.0, 1.0),
            Vector2::zeros(),
        );
        let long = shape.moved(&stretch).unwrap();
        assert!((long.extent[1] - long.extent[0] - 40.0).abs() < 1e-4);
        let flat = Affine2::about(shape.centre, nalgebra::Matrix2::zeros(), Vector2::zeros());
        assert_eq!(shape.moved(&flat), None);
    }

    #[test]
    fn empty_prior_has_no_shape() {
        let mut m = ChipMask::new();
        m.reset(8, 8).unwrap();
        assert_eq!(PriorShape::measure(&m), None);
    }
}
