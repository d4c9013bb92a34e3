//! The model's silhouette at one view as an outline: its upper and lower edge across the
//! projected axis, column by column along it, the body's own edges (without the fins) and the
//! fins' faces beyond them.
//!
//! A fin is a flat plate whose plane holds the axis, so its face's normal lies across the axis,
//! as the body's surface normals do: under any distant light a fin's face is as bright as the
//! body where its surface has the same normal. A body of revolution's normal at `w` (the place
//! across its image in half widths) has `w` as its part across the axis in the image, so each
//! face beyond the body is kept with its own `w` ([`FinFace`]): a fin at angle `psi` around the
//! axis shows its face turned to the camera, whose normal's part across is
//! `sin psi sign(cos psi)`.
//!
//! The outline is built from the same triangles as the shape prior
//! ([`crate::lut::render::for_each_triangle`]: the cross-sections' ellipses, the quads between
//! them and the fins' planforms), in the silhouette frame (m: `u` along the projected axis from
//! the body origin towards the nose, `v` across it). Its columns tile the silhouette's extent
//! along `u` exactly, so the first and last columns sit on the silhouette's ends whatever the
//! view: the blurred image made from them moves smoothly with the view and the scale.

use crate::lut::render::{View, for_each_part};
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
    /// The body's own upper edge in each column (the fins left out), m ...
    body_upper: [f32; C],
    /// ... and its lower edge, m.
    body_lower: [f32; C],
    /// Whether the fins' faces are kept apart ([`Fins::Faces`]) ...
    faces_apart: bool,
    /// ... and, then, those beyond the body in each column: above it and below it.
    faces: [[FinFaces; 2]; C],
    /// Whether each column's edges, body edges and fins' faces are the previous column's
    /// (along a cylinder most are), so that its image is too.
    repeats: [bool; C],
}

/// Widens column `j` of the edges `lower` and `upper` to take in `span` (lower, upper `v`, m).
fn widen(lower: &mut [f32], upper: &mut [f32], j: usize, span: (f32, f32)) {
    if let (Some(lower), Some(upper)) = (lower.get_mut(j), upper.get_mut(j)) {
        *lower = lower.min(span.0);
        *upper = upper.max(span.1);
    }
}

/// How an outline shades the fins.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fins {
    /// As the body: their stretches are part of the body's across each column.
    AsBody,
    /// Each face with its own normal, for the body with its nose pointing away from the camera
    /// (the silhouette frame's own sense: the axis's part along the line of sight is
    /// `sin(tilt)`) or, `nose_towards`, for its mirror image through the image plane (the other
    /// yaw candidate, whose silhouette is the same but whose fins turn the other face to the
    /// camera).
    Faces {
        /// Whether the nose points towards the camera.
        nose_towards: bool,
    },
}

/// The fins' faces of a body whose nose points away from the camera (the tests' usual
/// outline).
#[cfg(test)]
pub const NOSE_AWAY: Fins = Fins::Faces {
    nose_towards: false,
};

/// The fins' faces beyond the body on one side of a column: the face of the fin nearest the
/// camera from the body's edge to that fin's edge, and beyond it, up to the outline's edge, the
/// face of the fin that reaches farthest (the same fin where the nearest reaches farthest; a
/// third fin between them is taken as the farthest's).
#[derive(Debug, Clone, Copy, PartialEq)]
struct FinFaces {
    /// The farthest-reaching fin's face normal across the axis, as the body's `w`.
    outer_w: f32,
    /// The nearest fin's edge `v`, m ...
    front_edge: f32,
    /// ... and its face normal across the axis (its depth, [`Outline::cover_fin`], above the
    /// body, and less its depth below it).
    front_w: f32,
}

impl FinFaces {
    /// The nearest fin's face normal across, 0 where there is none (its stretch is empty).
    fn front_w_or_none(&self) -> f32 {
        if self.front_w.is_nan() {
            0.0
        } else {
            self.front_w
        }
    }

    /// No fin beyond the body.
    const NONE: FinFaces = FinFaces {
        outer_w: 0.0,
        front_edge: f32::NAN,
        front_w: f32::NAN,
    };
}

/// A stretch of a column that one surface fills, across the axis from `lower` to `upper` (m),
/// its normal's part across the axis `w`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FinFace {
    /// The stretch's lower edge `v`, m ...
    pub lower: f32,
    /// ... and its upper edge (not above `lower` where the stretch is empty).
    pub upper: f32,
    /// The face's normal across the axis, as the body's `w`.
    pub w: f32,
}

impl<const C: usize> Outline<C> {
    /// The outline of `model` seen at `view` in `columns` columns (clamped to
    /// `MIN_COLUMNS..=C`), the body's own edges and the fins' faces kept apart as `fins` says
    /// (else the body's edges are the outline's). `None` for a view whose silhouette has no
    /// finite extent.
    pub fn build(
        model: &ProjectileModel,
        view: &View,
        columns: usize,
        fins: Fins,
    ) -> Option<Outline<C>> {
        let columns = columns.clamp(MIN_COLUMNS, C.max(MIN_COLUMNS));
        if columns > C {
            return None;
        }
        let (lo, hi) = crate::lut::render::u_extent(model, view);
        let step_m = (hi - lo) / columns as f32;
        if !(step_m.is_finite() && step_m > 0.0) {
            return None;
        }
        // A fin's direction's part along the line of sight has the sign of `sin psi` with the
        // nose away, the other with it towards the camera.
        let depth_sign = match fins {
            Fins::AsBody => None,
            Fins::Faces { nose_towards } => Some(if nose_towards { -1.0 } else { 1.0 }),
        };
        let mut outline = Outline {
            first_u_m: lo + 0.5 * step_m,
            step_m,
            columns,
            upper: [f32::NEG_INFINITY; C],
            lower: [f32::INFINITY; C],
            body_upper: [f32::NEG_INFINITY; C],
            body_lower: [f32::INFINITY; C],
            faces_apart: depth_sign.is_some(),
            faces: [[FinFaces::NONE; 2]; C],
            repeats: [false; C],
        };
        for_each_part(model, view, |t, fin| {
            let fin = fin.zip(depth_sign).map(|((sin, cos), d)| (d * sin, cos));
            outline.cover(t, fin);
        });
        let mut previous = outline.column(0);
        for j in 1..columns {
            let column = outline.column(j);
            if let Some(slot) = outline.repeats.get_mut(j) {
                *slot = column == previous;
            }
            previous = column;
        }
        Some(outline)
    }

    /// Widens the columns whose centres the triangle `t` (silhouette frame, m) spans to its
    /// extent across them: the body's own edges too where it is the body's, else the faces of
    /// the fin (its depth and `cos psi`, [`Outline::cover_fin`]; every body triangle comes
    /// before the fins').
    fn cover(&mut self, t: [(f32, f32); 3], fin: Option<(f32, f32)>) {
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
            match fin {
                Some(psi) => self.cover_fin(j, span, psi),
                None => widen(&mut self.body_lower, &mut self.body_upper, j, span),
            }
            widen(&mut self.lower, &mut self.upper, j, span);
        }
    }

    /// Column `j`'s faces on the side of a fin that spans `span` (lower, upper `v`, m) across
    /// it, before the outline's edges take it in: the fin at angle `psi` around the axis, its
    /// `depth` its direction's part along the line of sight (away from the camera) over
    /// `cos(tilt)`, `± sin psi`. Its face turned to the camera has the normal's part across
    /// `depth sign(cos psi)`.
    fn cover_fin(&mut self, j: usize, span: (f32, f32), (depth, cos_psi): (f32, f32)) {
        let (Some(&body_lower), Some(&body_upper), Some(&lower), Some(&upper)) = (
            self.body_lower.get(j),
            self.body_upper.get(j),
            self.lower.get(j),
            self.upper.get(j),
        ) else {
            return;
        };
        // Above the body (side 0) a fin reaches with its upper end, and beyond is upwards.
        let (side, reach, body_edge, edge, beyond) = if cos_psi > 0.0 {
            (0, span.1, body_upper, upper, 1.0)
        } else if cos_psi < 0.0 {
            (1, span.0, body_lower, lower, -1.0)
        } else {
            return; // edge-on: it shows no face
        };
        let Some(faces) = self.faces.get_mut(j).and_then(|f| f.get_mut(side)) else {
            return;
        };
        if (reach - body_edge) * beyond <= 0.0 {
            return; // hidden behind the body
        }
        let w = if cos_psi > 0.0 { depth } else { -depth };
        if (reach - edge) * beyond > 0.0 {
            faces.outer_w = w;
        }
        // The nearest fin so far's depth (none yet: NaN, and any fin is nearer).
        let front_depth = faces.front_w * beyond;
        if front_depth.is_nan() || depth < front_depth {
            *faces = FinFaces {
                front_w: w,
                front_edge: reach,
                ..*faces
            };
        } else if depth == front_depth && (reach - faces.front_edge) * beyond > 0.0 {
            faces.front_edge = reach;
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
    #[inline]
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

    /// Whether column `j`'s edges, body edges and fins' faces are those of column `j - 1`
    /// (exactly: a NaN anywhere makes them differ).
    #[inline]
    pub fn repeats_previous(&self, j: usize) -> bool {
        self.repeats.get(j).copied().unwrap_or(false)
    }

    /// What column `j` holds: its edges, its body's edges and the fins' faces beyond it.
    #[allow(clippy::type_complexity)]
    fn column(&self, j: usize) -> (Option<(f32, f32)>, Option<(f32, f32)>, Option<[FinFace; 4]>) {
        (self.edges(j), self.body_edges(j), self.fin_faces(j))
    }

    /// The same outline with no column marked as repeating its neighbour (every column's image
    /// worked out afresh).
    #[cfg(test)]
    pub fn without_repeats(&self) -> Outline<C> {
        Outline {
            repeats: [false; C],
            ..self.clone()
        }
    }

    /// Column `j`'s (lower, upper) edge `v`, m; None where it crosses nothing.
    #[inline]
    pub fn edges(&self, j: usize) -> Option<(f32, f32)> {
        let (lower, upper) = (*self.lower.get(j)?, *self.upper.get(j)?);
        (upper > lower).then_some((lower, upper))
    }

    /// Column `j`'s body edges without the fins (lower, upper), m; None where only fins cross it.
    #[inline]
    pub fn body_edges(&self, j: usize) -> Option<(f32, f32)> {
        let (lower, upper) = (*self.body_lower.get(j)?, *self.body_upper.get(j)?);
        (upper > lower).then_some((lower, upper))
    }

    /// Column `j`'s fins' faces beyond the body: above it the nearest fin's and the
    /// farthest-reaching's, then below it the same (empty stretches where there is none); None
    /// where the fins are not kept apart or the column crosses no body.
    #[inline]
    pub fn fin_faces(&self, j: usize) -> Option<[FinFace; 4]> {
        if !self.faces_apart {
            return None;
        }
        let ((lower, upper), (body_lower, body_upper), [above, below]) =
            (self.edges(j)?, self.body_edges(j)?, self.faces.get(j)?);
        // Where the nearest fin's face gives way to the farthest's, between the body's edge and
        // the outline's (a NaN front edge, no fin on that side, is the body's edge).
        let split_above = above.front_edge.max(body_upper).min(upper.max(body_upper));
        let split_below = below.front_edge.min(body_lower).max(lower.min(body_lower));
        Some([
            FinFace {
                lower: body_upper,
                upper: split_above,
                w: above.front_w_or_none(),
            },
            FinFace {
                lower: split_above,
                upper,
                w: above.outer_w,
            },
            FinFace {
                lower: split_below,
                upper: body_lower,
                w: below.front_w_or_none(),
            },
            FinFace {
                lower,
                upper: split_below,
                w: below.outer_w,
            },
        ])
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
        let outline = Outline::<512>::build(&m, &view, 400, NOSE_AWAY).unwrap();
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
        let outline = Outline::<512>::build(&m, &view, 300, NOSE_AWAY).unwrap();
        let (lo, hi) = outline.u_range_m();
        let half = 0.689 * libm::cosf(30.0 * crate::pose::RAD);
        assert!((hi - half).abs() < 1e-3, "{hi} vs {half}");
        // The base ellipse or the fins' trailing corners at roll 45 deg reach behind the base.
        assert!(lo < -half - 0.02 + 1e-3, "{lo} vs {}", -half);
    }

    /// The nearest and the farthest-reaching fin's `w` above the body and below it, in the
    /// columns where both faces show (the same in each such column), and whether every face
    /// shown has one of the fins' `w` on that side.
    fn two_faced(outline: &Outline<512>, fins_w: [[f32; 2]; 2]) -> [Option<(f32, f32)>; 2] {
        let shows = |face: &FinFace| face.upper > face.lower + 1e-4;
        let mut pairs: [Option<(f32, f32)>; 2] = [None; 2];
        for j in 0..outline.columns() {
            let Some(faces) = outline.fin_faces(j) else {
                continue;
            };
            for (side, pair) in pairs.iter_mut().enumerate() {
                let [front, outer] = [faces[2 * side], faces[2 * side + 1]];
                for face in [front, outer].iter().filter(|f| shows(f)) {
                    let known = fins_w[side].iter().any(|w| (w - face.w).abs() < 1e-3);
                    assert!(known, "column {j}: {faces:?}");
                }
                if shows(&front) && shows(&outer) {
                    assert!(
                        pair.is_none_or(|(f, o)| f == front.w && o == outer.w),
                        "column {j}: {faces:?}"
                    );
                    *pair = Some((front.w, outer.w));
                }
            }
        }
        pairs
    }

    /// At roll 30 deg the reference's fins stand at 30, 120, 210 and 300 deg from `+v`
    /// (`v = r cos psi`; away from the camera `r sin psi cos(tilt)` with the nose away). Worked
    /// by hand: a face's normal across is `sin psi sign(cos psi)`. Above the body the fins at
    /// 30 (`w = 0.5`, behind) and 300 (`-0.866`, in front); where both show in a column, the
    /// front one from the body's edge and the other beyond it. Below, 120 (`-0.866`, behind)
    /// and 210 (`0.5`, in front). Nose towards the camera (the mirror image), the depths and
    /// the faces turn over: above 30 in front (`-0.5`) and 300 behind (`0.866`), which it hides
    /// since it reaches farther; below 120 in front (`0.866`) and 210 behind (`-0.5`).
    #[test]
    fn each_fin_shows_the_face_turned_to_the_camera() {
        let view = View {
            tilt_deg: 20.0,
            roll_deg: 30.0,
        };
        let close = |pair: Option<(f32, f32)>, expected: (f32, f32)| {
            pair.is_some_and(|(f, o)| {
                (f - expected.0).abs() < 1e-3 && (o - expected.1).abs() < 1e-3
            })
        };
        let away = Outline::<512>::build(&reference(), &view, 500, NOSE_AWAY).unwrap();
        let [above, below] = two_faced(&away, [[0.5, -0.866], [-0.866, 0.5]]);
        assert!(close(above, (-0.866, 0.5)), "{above:?}");
        assert!(close(below, (0.5, -0.866)), "{below:?}");
        let towards = Fins::Faces { nose_towards: true };
        let mirror = Outline::<512>::build(&reference(), &view, 500, towards).unwrap();
        let [above, below] = two_faced(&mirror, [[-0.5, 0.866], [0.866, -0.5]]);
        assert!(above.is_none(), "{above:?}");
        assert!(close(below, (0.866, -0.5)), "{below:?}");
        // The outline itself is the same either way, and without the faces apart.
        let plain = Outline::<512>::build(&reference(), &view, 500, Fins::AsBody).unwrap();
        for j in 0..away.columns() {
            assert_eq!(away.edges(j), mirror.edges(j));
            assert_eq!(away.edges(j), plain.edges(j));
            assert_eq!(plain.edges(j), plain.body_edges(j));
        }
    }
}
