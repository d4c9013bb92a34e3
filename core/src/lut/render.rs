//! The model's silhouette as filled triangles: the shape prior on the chip, drawn by the ground-
//! truth masks' rule (a pixel whose centre the silhouette covers, [`fill_triangle_by_centres`]),
//! and at a large scale the source of the table's entries (embedded-graphics' fill,
//! [`fill_triangle`], which also sets the pixels its edges touch).
//!
//! The body of revolution is a chain of cross-section circles along the axis (the ogive's
//! stations, the shoulder, the base); under a narrow field of view each projects to an ellipse
//! with its long axis across the projected axis, and consecutive ones are joined by the quad
//! between their outermost points. Each fin is its flat trapezoid (its 4 mm thickness is left
//! out). Coordinates follow the silhouette frame of [`super::table`].

use super::table::Entry;
use crate::model::ProjectileModel;
use crate::point::ImagePoint;
use crate::pose::RAD;
use embedded_graphics::Drawable;
use embedded_graphics::pixelcolor::BinaryColor;
use embedded_graphics::prelude::{DrawTarget, Point, Primitive, Size};
use embedded_graphics::primitives::Rectangle;
use embedded_graphics::primitives::{PrimitiveStyle, Triangle};

/// Vertices of a cross-section's ellipse.
const ELLIPSE_VERTICES: usize = 16;
/// The largest silhouette drawn, px along either axis (a guard against absurd placements).
const MAX_EXTENT_PX: f32 = 16384.0;

/// The body's attitude relative to the line of sight: tilt and roll of the silhouette frame.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct View {
    /// Angle between the body axis and the image plane, deg (0: broadside, 90: end-on).
    pub tilt_deg: f32,
    /// Fin angle from `+v` towards `n × v`, deg.
    pub roll_deg: f32,
}

/// Where the silhouette is drawn: the silhouette frame mapped to target pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Placement {
    /// Target pixel of the body origin (pixel centres at integers).
    pub origin: ImagePoint,
    /// Unit image vector of the projected axis, tail to nose (`+u`); `+v` is it turned by +90°.
    pub dir: ImagePoint,
    /// Scale, px per unit of the silhouette frame (per metre for the model's triangles, per
    /// body diameter for a table entry).
    pub px_per_unit: f32,
}

impl Placement {
    /// The target point of silhouette-frame point `(u, v)`, px (pixel centres at integers).
    fn point(&self, (u, v): (f32, f32)) -> ImagePoint {
        ImagePoint::new(
            self.origin.x + self.px_per_unit * (u * self.dir.x - v * self.dir.y),
            self.origin.y + self.px_per_unit * (u * self.dir.y + v * self.dir.x),
        )
    }

    /// The target pixel nearest to silhouette-frame point `(u, v)`.
    fn pixel(&self, uv: (f32, f32)) -> Point {
        let p = self.point(uv);
        Point::new(libm::roundf(p.x) as i32, libm::roundf(p.y) as i32)
    }

    /// True when the placement is finite and a shape of `extent` units stays under 16384 px.
    fn is_sane(&self, extent: f32) -> bool {
        [
            self.origin.x,
            self.origin.y,
            self.dir.x,
            self.dir.y,
            self.px_per_unit,
        ]
        .iter()
        .all(|v| v.is_finite() && libm::fabsf(*v) < MAX_EXTENT_PX)
            && self.px_per_unit * extent < MAX_EXTENT_PX
    }
}

/// Fills one silhouette-frame triangle at `placement` (vertices rounded to pixel centres). A
/// triangle with a vertex more than 16384 px (`MAX_EXTENT_PX`) from the target's origin is not
/// drawn: a hostile table's edges can put one anywhere, and embedded-graphics' triangle
/// arithmetic overflows i32 far out (found by fuzzing).
pub fn fill_triangle<D: DrawTarget<Color = BinaryColor>>(
    target: &mut D,
    placement: &Placement,
    [a, b, c]: [(f32, f32); 3],
) -> Result<(), D::Error> {
    let corners = [a, b, c].map(|p| placement.pixel(p));
    let bound = MAX_EXTENT_PX as u32;
    if corners
        .iter()
        .any(|p| p.x.unsigned_abs() > bound || p.y.unsigned_abs() > bound)
    {
        return Ok(());
    }
    let [a, b, c] = corners;
    Triangle::new(a, b, c)
        .into_styled(PrimitiveStyle::with_fill(BinaryColor::On))
        .draw(target)
}

/// Fills one silhouette-frame triangle at `placement` by the ground-truth masks' rule: a pixel is
/// set where its centre (at integers) lies inside the triangle or on its edge, which for a
/// silhouette's straight edges is where at least half of the pixel is covered. Nothing is drawn
/// for a triangle that is degenerate, not finite, or has a vertex more than 16384 px
/// (`MAX_EXTENT_PX`) from the target's origin; rows and columns outside the target are skipped.
pub fn fill_triangle_by_centres<D: DrawTarget<Color = BinaryColor>>(
    target: &mut D,
    placement: &Placement,
    triangle: [(f32, f32); 3],
) -> Result<(), D::Error> {
    let [a, b, c] = triangle.map(|p| placement.point(p));
    let far =
        |p: &ImagePoint| !(libm::fabsf(p.x) <= MAX_EXTENT_PX && libm::fabsf(p.y) <= MAX_EXTENT_PX);
    if [a, b, c].iter().any(far) {
        return Ok(());
    }
    let area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    if area == 0.0 || !area.is_finite() {
        return Ok(());
    }
    // Counter-clockwise in (x, y): each edge's inside is to its left.
    let (b, c) = if area > 0.0 { (b, c) } else { (c, b) };
    let size = target.bounding_box().size;
    let (width, height) = (size.width as f32, size.height as f32);
    let top = libm::ceilf(a.y.min(b.y).min(c.y)).max(0.0);
    let bottom = libm::floorf(a.y.max(b.y).max(c.y)).min(height - 1.0);
    let mut y = top;
    while y <= bottom {
        // The row's span: on each edge p -> q, the inside is (q - p) x (x - p) >= 0, linear in x.
        let (mut lo, mut hi) = (0.0f32, width - 1.0);
        for (p, q) in [(a, b), (b, c), (c, a)] {
            let (dx, dy) = (q.x - p.x, q.y - p.y);
            // dx (y - p.y) - dy (x - p.x) >= 0.
            let at = dx * (y - p.y);
            if dy == 0.0 {
                if at < 0.0 {
                    hi = -1.0;
                }
            } else if dy < 0.0 {
                lo = lo.max(p.x + at / dy);
            } else {
                hi = hi.min(p.x + at / dy);
            }
        }
        let (first, last) = (libm::ceilf(lo), libm::floorf(hi));
        if first <= last {
            let span = Rectangle::new(
                Point::new(first as i32, y as i32),
                Size::new((last - first) as u32 + 1, 1),
            );
            target.fill_solid(&span, BinaryColor::On)?;
        }
        y += 1.0;
    }
    Ok(())
}

/// A point of the body, `x` m along the axis from the origin, `r` m from it at the angle around
/// it whose sine and cosine are `psi_sin_cos`, in the silhouette frame (m).
fn project(view_sin_cos: (f32, f32), x: f32, r: f32, psi_sin_cos: (f32, f32)) -> (f32, f32) {
    let (sin_b, cos_b) = view_sin_cos;
    let (sin_psi, cos_psi) = psi_sin_cos;
    (x * cos_b - r * sin_psi * sin_b, r * cos_psi)
}

/// The sine and cosine of angle `psi`, rad.
fn sin_cos(psi: f32) -> (f32, f32) {
    (libm::sinf(psi), libm::cosf(psi))
}

/// The sine and cosine of angle zero (exact).
const ZERO_ANGLE: (f32, f32) = (0.0, 1.0);

/// Calls `f` with each triangle of the silhouette of `model` seen at `view`, in the silhouette
/// frame (m): the ellipse of every profile station's cross-section, the quads between
/// consecutive stations, and each fin's planform.
pub fn for_each_triangle(model: &ProjectileModel, view: &View, mut f: impl FnMut([(f32, f32); 3])) {
    for_each_part(model, view, |t, _| f(t));
}

/// [`for_each_triangle`], telling `f` also whose the triangle is: the body's (None, every body
/// triangle before the first fin's) or a fin's, as the sine and cosine of its angle `psi` around
/// the axis from `+v` towards `n x v` (`v = r cos psi`; the line of sight's part of the radius,
/// away from the camera, is `r sin psi cos(tilt)`).
pub fn for_each_part(
    model: &ProjectileModel,
    view: &View,
    mut f: impl FnMut([(f32, f32); 3], Option<(f32, f32)>),
) {
    let beta = view.tilt_deg * RAD;
    let sc = (libm::sinf(beta), libm::cosf(beta));
    let half = 0.5 * model.length_m;
    // The ellipses' vertex angles around the axis, their sines and cosines found once (they are
    // the same at every station; on the M4F, libm's sinf and cosf run in software f64).
    let mut around = [ZERO_ANGLE; ELLIPSE_VERTICES + 1];
    let ellipses = sc.0 > 1e-4; // seen broadside, a cross-section is a line
    if ellipses {
        for (k, slot) in around.iter_mut().enumerate() {
            *slot = sin_cos(core::f32::consts::TAU * k as f32 / ELLIPSE_VERTICES as f32);
        }
    }
    // The body of revolution: its profile's stations from the tip (s = 0) to the base (s = L).
    let mut previous: Option<(f32, f32)> = None;
    for i in 0..model.stations() {
        let (s, r) = model.station(i);
        let x = half - s;
        let centre = project(sc, x, 0.0, ZERO_ANGLE);
        // The ellipse of this cross-section, as a triangle fan.
        if r > 0.0 && ellipses {
            for pair in around.windows(2) {
                if let [from, to] = pair {
                    f(
                        [centre, project(sc, x, r, *from), project(sc, x, r, *to)],
                        None,
                    );
                }
            }
        }
        if let Some((px, pr)) = previous {
            let a = project(sc, px, pr, ZERO_ANGLE);
            let b = project(sc, x, r, ZERO_ANGLE);
            let c = project(sc, x, -r, ZERO_ANGLE);
            let d = project(sc, px, -pr, ZERO_ANGLE);
            f([a, b, c], None);
            f([a, c, d], None);
        }
        previous = Some((x, r));
    }
    // The fins: root chord on the body, tip chord at the tip radius.
    let Some(fins) = model.fins() else { return };
    let (root_le, root_te) = fins.root_s;
    let (tip_le, tip_te) = fins.tip_s;
    let root_radius = |s: f32| model.radius_at(s);
    for k in 0..fins.count {
        let psi = sin_cos(
            (view.roll_deg + fins.first_roll_deg) * RAD
                + core::f32::consts::TAU * f32::from(k) / f32::from(fins.count),
        );
        let a = project(sc, half - root_te, root_radius(root_te), psi);
        let b = project(sc, half - root_le, root_radius(root_le), psi);
        let c = project(sc, half - tip_le, fins.tip_radius_m, psi);
        let d = project(sc, half - tip_te, fins.tip_radius_m, psi);
        f([a, b, c], Some(psi));
        f([a, c, d], Some(psi));
    }
}

/// The silhouette's extent along the projected axis, m: (tail end, nose end).
pub fn u_extent(model: &ProjectileModel, view: &View) -> (f32, f32) {
    let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
    for_each_triangle(model, view, |t| {
        for (u, _) in t {
            lo = lo.min(u);
            hi = hi.max(u);
        }
    });
    (lo, hi)
}

/// Draws the silhouette of `model` at `view` into `target` at `placement` (in px per metre),
/// pixels whose centres it covers. Nothing is drawn for a placement that is not finite or would
/// span more than 16384 px.
pub fn draw<D: DrawTarget<Color = BinaryColor>>(
    target: &mut D,
    model: &ProjectileModel,
    view: &View,
    placement: &Placement,
) -> Result<(), D::Error> {
    if !placement.is_sane(model.length_m.max(2.0 * model.max_radius_m())) {
        return Ok(());
    }
    let mut result = Ok(());
    for_each_triangle(model, view, |t| {
        if result.is_ok() {
            result = fill_triangle_by_centres(target, placement, t);
        }
    });
    result
}

/// Draws a table entry's silhouette into `target` at `placement` (in px per body diameter): the
/// quads between consecutive stations' edges, pixels whose centres they cover. This is how the
/// shape prior is drawn, whatever the model the table was built from.
pub fn draw_entry<D: DrawTarget<Color = BinaryColor>>(
    target: &mut D,
    entry: &Entry,
    placement: &Placement,
) -> Result<(), D::Error> {
    let (lo, hi) = entry.u_range();
    if !placement.is_sane(hi - lo) {
        return Ok(());
    }
    let last = entry.stations().saturating_sub(1).max(1) as f32;
    let station = |s: usize| {
        let u = lo + (hi - lo) * s as f32 / last;
        let (v0, v1) = entry.edges(s);
        ((u, v0), (u, v1))
    };
    for s in 1..entry.stations() {
        let ((a0, a1), (b0, b1)) = (station(s - 1), station(s));
        fill_triangle_by_centres(target, placement, [a0, a1, b1])?;
        fill_triangle_by_centres(target, placement, [a0, b1, b0])?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lut::table::Table;
    use crate::mask::BitMask;
    use crate::model::testing::reference;

    /// Broadside silhouette area of the reference projectile, m², from its dimensions in
    /// `docs/projectile.md` (not from the model file): cylinder, tangent ogive (by Simpson's rule
    /// over its radius) and two fins in the image plane.
    fn broadside_area() -> f32 {
        let (length, radius, nose) = (1.378f32, 0.04f32, 0.24f32);
        let (fin_tip_radius, root, tip) = (0.1f32, 0.12f32, 0.06f32);
        let rho = (radius * radius + nose * nose) / (2.0 * radius);
        let ogive_radius = |s: f32| libm::sqrtf(rho * rho - (nose - s) * (nose - s)) + radius - rho;
        let n = 200;
        let h = nose / n as f32;
        let ogive: f32 = (0..=n)
            .map(|i| {
                let w = if i == 0 || i == n {
                    1.0
                } else if i % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                w * 2.0 * ogive_radius(i as f32 * h)
            })
            .sum::<f32>()
            * h
            / 3.0;
        let cylinder = (length - nose) * 2.0 * radius;
        let fins = 2.0 * (fin_tip_radius - radius) * 0.5 * (root + tip);
        ogive + cylinder + fins
    }

    fn drawn_area(draw_it: impl FnOnce(&mut BitMask<8192>, Placement), px_per_unit: f32) -> f32 {
        let mut mask = BitMask::<8192>::new();
        mask.reset(512, 512).unwrap();
        draw_it(
            &mut mask,
            Placement {
                origin: ImagePoint::new(255.0, 255.0),
                dir: ImagePoint::new(0.6, 0.8),
                px_per_unit,
            },
        );
        mask.count() as f32 / (px_per_unit * px_per_unit)
    }

    /// A silhouette is drawn by its pixels' centres, so the count is its area (the ground-truth
    /// masks' half-covered pixels); embedded-graphics' fill, which also sets the pixels the edges
    /// touch, drew half a pixel times the perimeter more (about 5 % here).
    #[test]
    fn the_model_and_its_table_entry_draw_the_broadside_area() {
        let m = reference();
        let px_per_m = 300.0;
        let expected = broadside_area();
        let view = View {
            tilt_deg: 0.0,
            roll_deg: 0.0,
        };
        let model_area = drawn_area(|t, p| draw(t, &m, &view, &p).unwrap(), px_per_m);
        assert!(
            (model_area / expected - 1.0).abs() < 0.02,
            "{model_area} vs {expected}"
        );
        let table = Table::parse(include_bytes!("../../../fixtures/lut/ref-1378x80.lut")).unwrap();
        let d = m.diameter_m;
        let entry_area = drawn_area(
            |t, p| draw_entry(t, &table.entry(0, 0), &p).unwrap(),
            px_per_m * d,
        ) * d
            * d;
        assert!(
            (entry_area / expected - 1.0).abs() < 0.03,
            "{entry_area} vs {expected}"
        );
    }

    /// Hand-counted: the triangle (0, 0), (4, 0), (0, 4) holds the 15 pixel centres with
    /// `x + y <= 4`, its edges included; a pixel half covered (the edge through its centre) is
    /// set, one less than half covered is not.
    #[test]
    fn a_triangle_sets_the_pixels_whose_centres_it_covers() {
        let mut mask = BitMask::<{ crate::capacity::mask_words(16) }>::default();
        mask.reset(16, 16).unwrap();
        let identity = Placement {
            origin: ImagePoint::new(0.0, 0.0),
            dir: ImagePoint::new(1.0, 0.0),
            px_per_unit: 1.0,
        };
        let corner = [(0.0, 0.0), (4.0, 0.0), (0.0, 4.0)];
        fill_triangle_by_centres(&mut mask, &identity, corner).unwrap();
        assert_eq!(mask.count(), 15);
        assert!(mask.get(4, 0) && mask.get(2, 2) && !mask.get(3, 2));
        // Either way round.
        mask.reset(16, 16).unwrap();
        fill_triangle_by_centres(&mut mask, &identity, [corner[0], corner[2], corner[1]]).unwrap();
        assert_eq!(mask.count(), 15);
        // The rectangle 10.5 <= x <= 12.4, 5 <= y <= 8 as two triangles: columns 11 and 12 (the
        // first half covered, the second 0.9 covered), column 10 (covered from 0.5: not set).
        mask.reset(16, 16).unwrap();
        for t in [
            [(10.5, 5.0), (12.4, 5.0), (12.4, 8.0)],
            [(10.5, 5.0), (12.4, 8.0), (10.5, 8.0)],
        ] {
            fill_triangle_by_centres(&mut mask, &identity, t).unwrap();
        }
        assert_eq!(mask.count(), 2 * 4);
        assert!(mask.get(11, 5) && mask.get(12, 8) && !mask.get(10, 6) && !mask.get(13, 6));
        // Off the target's edge: only the pixels inside are set.
        mask.reset(16, 16).unwrap();
        let beyond = [(-8.0, -8.0), (12.0, -8.0), (-8.0, 12.0)];
        fill_triangle_by_centres(&mut mask, &identity, beyond).unwrap();
        assert_eq!(mask.count(), 15);
    }

    #[test]
    fn absurd_placements_draw_nothing() {
        let view = View {
            tilt_deg: 10.0,
            roll_deg: 5.0,
        };
        for px_per_unit in [f32::NAN, f32::INFINITY, 1e9] {
            let area = drawn_area(
                |t, p| draw(t, &reference(), &view, &p).unwrap(),
                px_per_unit,
            );
            assert!(area == 0.0 || area.is_nan(), "{px_per_unit}: {area}");
        }
    }

    #[test]
    fn a_triangle_reaching_past_the_extent_draws_nothing() {
        let mut mask = BitMask::<{ crate::capacity::mask_words(64) }>::default();
        mask.reset(64, 64).unwrap();
        let placement = Placement {
            origin: ImagePoint::new(32.0, 32.0),
            dir: ImagePoint::new(1.0, 0.0),
            px_per_unit: 10.0,
        };
        // A table edge 2e8 units out: the vertex lands near i32::MAX px.
        fill_triangle(
            &mut mask,
            &placement,
            [(-1.0, -1.0), (1.0, -1.0), (0.0, 2e8)],
        )
        .unwrap();
        assert_eq!(mask.count(), 0);
        fill_triangle(
            &mut mask,
            &placement,
            [(-1.0, -1.0), (1.0, -1.0), (0.0, 2.0)],
        )
        .unwrap();
        assert!(mask.count() > 0, "a triangle within the extent is drawn");
    }
}
