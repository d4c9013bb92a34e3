//! The model's silhouette at one view as an outline: its upper and lower edge across the
//! projected axis, column by column along it.
//!
//! The outline is built from the same triangles as the shape prior
//! ([`crate::lut::render::for_each_triangle`]: the cross-sections' ellipses, the quads between
//! them and the fins' planforms), in the silhouette frame (m: `u` along the projected axis from
//! the body origin towards the nose, `v` across it). Its columns tile the silhouette's extent
//! along `u` exactly, so the first and last columns sit on the silhouette's ends whatever the
//! view: the blurred image made from them moves smoothly with the view and the scale.

use crate::lut::render::{View, for_each_triangle};
use crate::model::ProjectileModel;

/// The fewest columns an outline is built with.
pub const MIN_COLUMNS: usize = 8;

/// The silhouette's edges across the axis in `columns` columns of equal width along it (at most
/// `C`).
#[derive(Debug, Clone, PartialEq)]
pub struct Outline<const C: usize> {
    /// `u` of the first column's centre, m.
    first_u_m: f32,
    /// Column width along `u`, m.
    step_m: f32,
    /// Columns in use.
    columns: usize,
    /// Each column's upper edge `v`, m (below `lower` where the column crosses nothing).
    upper: [f32; C],
    /// Each column's lower edge `v`, m.
    lower: [f32; C],
}

impl<const C: usize> Outline<C> {
    /// The outline of `model` seen at `view` in `columns` columns (clamped to
    /// `MIN_COLUMNS..=C`). `None` for a view whose silhouette has no finite extent.
    pub fn build(model: &ProjectileModel, view: &View, columns: usize) -> Option<Outline<C>> {
        let columns = columns.clamp(MIN_COLUMNS, C.max(MIN_COLUMNS));
        if columns > C {
            return None;
        }
        let (lo, hi) = crate::lut::render::u_extent(model, view);
        let step_m = (hi - lo) / columns as f32;
        if !(step_m.is_finite() && step_m > 0.0) {
            return None;
        }
        let mut outline = Outline {
            first_u_m: lo + 0.5 * step_m,
            step_m,
            columns,
            upper: [f32::NEG_INFINITY; C],
            lower: [f32::INFINITY; C],
        };
        for_each_triangle(model, view, |t| outline.cover(t));
        Some(outline)
    }

    /// Widens the columns whose centres the triangle `t` (silhouette frame, m) spans to its
    /// extent across them.
    fn cover(&mut self, t: [(f32, f32); 3]) {
        let u_min = t.iter().map(|p| p.0).fold(f32::INFINITY, f32::min);
        let u_max = t.iter().map(|p| p.0).fold(f32::NEG_INFINITY, f32::max);
        let first = libm::ceilf((u_min - self.first_u_m) / self.step_m).max(0.0);
        let last = libm::floorf((u_max - self.first_u_m) / self.step_m);
        if !(first.is_finite() && last.is_finite()) || last < first {
            return;
        }
        let last = (last as usize).min(self.columns.saturating_sub(1));
        for j in first as usize..=last {
            let u = self.u_m(j);
            let mut span = (f32::INFINITY, f32::NEG_INFINITY);
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                let crosses = (a.0 - u) * (b.0 - u) <= 0.0;
                if !crosses {
                    continue;
                }
                let v = if a.0 == b.0 {
                    // An edge along the column: both its ends are on it.
                    span = (span.0.min(a.1.min(b.1)), span.1.max(a.1.max(b.1)));
                    continue;
                } else {
                    a.1 + (u - a.0) / (b.0 - a.0) * (b.1 - a.1)
                };
                span = (span.0.min(v), span.1.max(v));
            }
            if let (Some(lower), Some(upper)) = (self.lower.get_mut(j), self.upper.get_mut(j)) {
                *lower = lower.min(span.0);
                *upper = upper.max(span.1);
            }
        }
    }

    /// Columns in use.
    pub fn columns(&self) -> usize {
        self.columns
    }

    /// Column width along `u`, m.
    pub fn step_m(&self) -> f32 {
        self.step_m
    }

    /// `u` of column `j`'s centre, m.
    pub fn u_m(&self, j: usize) -> f32 {
        self.first_u_m + self.step_m * j as f32
    }

    /// The silhouette's extent along `u`, m: (tail end, nose end).
    pub fn u_range_m(&self) -> (f32, f32) {
        let half = 0.5 * self.step_m;
        (self.first_u_m - half, self.u_m(self.columns) - half)
    }

    /// The columns whose centres lie within `u0..=u1` m (possibly empty).
    pub fn columns_within(&self, u0: f32, u1: f32) -> core::ops::Range<usize> {
        let first = libm::ceilf((u0 - self.first_u_m) / self.step_m).max(0.0);
        let last = libm::floorf((u1 - self.first_u_m) / self.step_m) + 1.0;
        if !(first.is_finite() && last.is_finite()) || last <= first {
            return 0..0;
        }
        (first as usize).min(self.columns)..(last as usize).min(self.columns)
    }

    /// Column `j`'s (lower, upper) edge `v`, m; None where it crosses nothing.
    pub fn edges(&self, j: usize) -> Option<(f32, f32)> {
        let (lower, upper) = (*self.lower.get(j)?, *self.upper.get(j)?);
        (upper > lower).then_some((lower, upper))
    }

    /// The largest distance of an edge from the axis, m.
    pub fn half_span_m(&self) -> f32 {
        (0..self.columns)
            .filter_map(|j| self.edges(j))
            .map(|(l, u)| libm::fabsf(l).max(libm::fabsf(u)))
            .fold(0.0, f32::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::testing::reference;

    /// Broadside, the reference body's outline is its radius profile (hand-derived: 40 mm
    /// cylinder radius, 1.378 m long) and its fins reach the tip radius (100 mm) in the image
    /// plane.
    #[test]
    fn the_broadside_outline_is_the_radius_profile_and_the_fins() {
        let m = reference();
        let view = View {
            tilt_deg: 0.0,
            roll_deg: 0.0,
        };
        let outline = Outline::<512>::build(&m, &view, 400).unwrap();
        let (lo, hi) = outline.u_range_m();
        assert!(
            (lo + 0.689).abs() < 1e-4 && (hi - 0.689).abs() < 1e-4,
            "{lo} {hi}"
        );
        // Mid-body: the cylinder.
        let j = outline.columns_within(0.0, 0.01).start;
        let (l, u) = outline.edges(j).unwrap();
        assert!(
            (u - 0.04).abs() < 1e-4 && (l + 0.04).abs() < 1e-4,
            "{l} {u}"
        );
        // Just ahead of the base: the fins, tip radius 100 mm.
        let j = outline.columns_within(lo + 0.01, hi).start;
        let (l, u) = outline.edges(j).unwrap();
        assert!((u - 0.1).abs() < 2e-3 && (l + 0.1).abs() < 2e-3, "{l} {u}");
        assert!((outline.half_span_m() - 0.1).abs() < 1e-3);
        // Near the tip the ogive narrows.
        let (l, u) = outline.edges(outline.columns() - 1).unwrap();
        assert!(u < 0.005 && l > -0.005, "{l} {u}");
    }

    /// Seen 30 deg out of the image plane, the outline is shorter by cos 30 and the base's
    /// ellipse reaches `r sin 30` behind the base centre.
    #[test]
    fn a_tilted_outline_is_foreshortened_and_shows_the_base() {
        let m = reference();
        let view = View {
            tilt_deg: 30.0,
            roll_deg: 45.0,
        };
        let outline = Outline::<512>::build(&m, &view, 300).unwrap();
        let (lo, hi) = outline.u_range_m();
        let half = 0.689 * libm::cosf(30.0 * crate::pose::RAD);
        assert!((hi - half).abs() < 1e-3, "{hi} vs {half}");
        // The base ellipse or the fins' trailing corners at roll 45 deg reach behind the base.
        assert!(lo < -half - 0.02 + 1e-3, "{lo} vs {}", -half);
    }
}
