//! The body's image: an outline filled with a shaded radiance and blurred by the optics.
//!
//! Across each column of the [`Outline`], between its lower edge `a` and upper edge `b`, the
//! body's contrast against the sky is a quadratic in `w`, the surface normal's part across the
//! axis: `c0 + c1 w + c2 w²`. It stands for Lambertian shading, which is linear in the surface
//! normal: over the body's own stretch of the column (its edges without the fins,
//! [`Outline::body_edges`]) `w = (v - m) / h` (`m` the body's middle there, `h` its half width),
//! as on a cylinder, and `w²` follows the darkening towards the limbs; over a fin's face beyond
//! the body `w` is that face's own ([`Outline::fin_faces`]: a fin is a flat plate whose normal
//! lies across the axis, so it is as bright as the body where the body turns the same way). An
//! outline built without the fins apart is shaded as one quadratic across the whole column. The
//! optics blur it with an isotropic Gaussian of `sigma` (the lens's PSF and the pixel's own width
//! together). Across the column the blurred contrast is exact, from the normal's CDF and density
//! at the stretches' edges (the moments of a truncated normal); along the axis it is the sum over
//! the columns within `REACH` sigmas, weighted by the Gaussian. The image is linear in `c0, c1,
//! c2`, so it is handed over as their three coefficients.

use super::outline::Outline;
use crate::math::normal;

/// Columns farther than this many sigmas along the axis are not summed.
const REACH: f32 = 4.0;
/// A column whose edges both lie farther than this many sigmas to one side of the point adds
/// nothing (the normal's tail beyond it is 3e-7).
const EDGE_REACH: f32 = 5.0;

/// The contrast `c0 + c1 w + c2 w²` (`shading`) from its coefficients `basis`, grey levels.
pub fn contrast(shading: [f32; 3], basis: [f32; 3]) -> f32 {
    shading[0] * basis[0] + shading[1] * basis[1] + shading[2] * basis[2]
}

/// An edge across a column, in sigmas from the point, with the normal's CDF and density there.
#[derive(Debug, Clone, Copy)]
struct Edge {
    x: f32,
    cdf: f32,
    pdf: f32,
}

impl Edge {
    #[inline]
    fn at(x: f32) -> Edge {
        let (cdf, pdf) = normal::cdf_pdf(x);
        Edge { x, cdf, pdf }
    }

    /// The edge at `x`, `near` itself where it lies there (a stretch of no width).
    #[inline]
    fn at_or(x: f32, near: Edge) -> Edge {
        if x == near.x { near } else { Edge::at(x) }
    }
}

/// The blur's weight over one stretch of a column from edge `a` to edge `b`: `∫ phi`,
/// `∫ x phi` (as `phi(a) - phi(b)`) and `[x phi]` from `a` to `b` (all zero where `b` is not
/// above `a`).
#[derive(Debug, Clone, Copy, Default)]
struct Stretch {
    m0: f32,
    m1: f32,
    n1: f32,
}

impl Stretch {
    /// Adds `stretch` weighted by `weight`.
    fn add(&mut self, stretch: &Stretch, weight: f32) {
        self.m0 += weight * stretch.m0;
        self.m1 += weight * stretch.m1;
        self.n1 += weight * stretch.n1;
    }

    #[inline]
    fn between(a: Edge, b: Edge) -> Stretch {
        if b.x <= a.x {
            return Stretch::default();
        }
        Stretch {
            m0: b.cdf - a.cdf,
            m1: a.pdf - b.pdf,
            n1: b.x * b.pdf - a.x * a.pdf,
        }
    }
}

/// One column's blur across at a point: everything of its share of the blurred contrast but the
/// Gaussian's weight along the axis. It depends on the column's edges and the point's `v` only,
/// so the columns that repeat their neighbour's edges ([`Outline::repeats_previous`]: most of a
/// body's cylinder) share it.
#[derive(Debug, Clone, Copy)]
struct Across {
    /// The whole column.
    whole: Stretch,
    /// The fins' faces' stretches summed, weighted by their `w` and by `w²`.
    faces: [Stretch; 2],
    /// The body's edges' offsets from the point across, in sigmas, and the normal's density
    /// there (all zero where only fins cross the column).
    alpha: f32,
    beta: f32,
    pdf_a: f32,
    pdf_b: f32,
    /// Moments of the blur's weight over the body: `∫ x^k phi(x) dx` over `alpha..beta`.
    m0: f32,
    m1: f32,
    m2: f32,
    /// The point's place across the body in its half widths, the blur in half widths, and the
    /// half width, m.
    w: f32,
    s: f32,
    half: f32,
    /// The column's blurred `1, w, w²` (before the weight): `1` over the column, `w` and `w²`
    /// across the body and at each fin face's own `w`.
    terms: [f32; 3],
}

impl Across {
    /// Column `j`'s blur across at `v` for blur `sigma`, m; None where it adds nothing.
    #[inline]
    fn of<const C: usize>(outline: &Outline<C>, j: usize, v: f32, sigma: f32) -> Option<Across> {
        let (lower, upper) = outline.edges(j)?;
        let inv_sigma = 1.0 / sigma;
        let in_sigmas = |edge: f32| (edge - v) * inv_sigma;
        let (alpha, beta) = (in_sigmas(lower), in_sigmas(upper));
        if alpha > EDGE_REACH || beta < -EDGE_REACH {
            // Beyond the column's reach across: nothing of it is blurred this far.
            return None;
        }
        let (bottom, top) = (Edge::at(alpha), Edge::at(beta));
        let whole = Stretch::between(bottom, top);
        let mut across = Across {
            whole,
            faces: [Stretch::default(); 2],
            alpha: 0.0,
            beta: 0.0,
            pdf_a: 0.0,
            pdf_b: 0.0,
            m0: 0.0,
            m1: 0.0,
            m2: 0.0,
            w: 0.0,
            s: 0.0,
            half: 1.0,
            terms: [whole.m0, 0.0, 0.0],
        };
        // The body's own stretch (none where only fins cross the column) and the fins' faces
        // beyond it, their edges shared where they meet.
        let Some((body_lower, body_upper)) = outline.body_edges(j) else {
            return Some(across);
        };
        let a = Edge::at_or(in_sigmas(body_lower), bottom);
        let b = Edge::at_or(in_sigmas(body_upper), top);
        if let Some([front_above, outer_above, front_below, outer_below]) = outline.fin_faces(j) {
            let split_above = Edge::at_or(in_sigmas(front_above.upper), b);
            let split_below = Edge::at_or(in_sigmas(front_below.lower), a);
            for (stretch, w) in [
                (Stretch::between(b, split_above), front_above.w),
                (Stretch::between(split_above, top), outer_above.w),
                (Stretch::between(split_below, a), front_below.w),
                (Stretch::between(bottom, split_below), outer_below.w),
            ] {
                across.faces[0].add(&stretch, w);
                across.faces[1].add(&stretch, w * w);
            }
        }
        let m0 = b.cdf - a.cdf;
        let half = (0.5 * (body_upper - body_lower)).max(f32::MIN_POSITIVE);
        let across = Across {
            alpha: a.x,
            beta: b.x,
            pdf_a: a.pdf,
            pdf_b: b.pdf,
            m0,
            m1: a.pdf - b.pdf,
            m2: m0 - (b.x * b.pdf - a.x * a.pdf),
            w: (v - 0.5 * (body_upper + body_lower)) / half,
            s: sigma / half,
            half,
            ..across
        };
        Some(Across {
            terms: across.body_terms(),
            ..across
        })
    }

    /// The blurred `1, w, w²` of a column the body crosses.
    #[inline]
    fn body_terms(&self) -> [f32; 3] {
        let (w, s) = (self.w, self.s);
        let mut terms = [
            self.whole.m0,
            w * self.m0 + s * self.m1,
            w * w * self.m0 + 2.0 * w * s * self.m1 + s * s * self.m2,
        ];
        terms[1] += self.faces[0].m0;
        terms[2] += self.faces[1].m0;
        terms
    }
}

/// One column's share of the blurred contrast at a point.
struct Share {
    /// The Gaussian's weight along the axis, and the column's offset from the point in sigmas.
    weight: f32,
    along: f32,
    /// The column's blur across.
    across: Across,
    /// Whether `across` is the previous share's (the column repeats its neighbour's edges).
    repeats: bool,
}

/// The columns summed at `(u, v)` for blur `sigma`, m.
fn shares<const C: usize>(
    outline: &Outline<C>,
    u: f32,
    v: f32,
    sigma: f32,
) -> impl Iterator<Item = Share> + '_ {
    let inv_sigma = 1.0 / sigma;
    // The previous column's blur across (None: it added nothing), once there is one.
    let mut previous: Option<Option<Across>> = None;
    outline
        .columns_within(u - REACH * sigma, u + REACH * sigma)
        .filter_map(move |j| {
            let repeats = previous.is_some() && outline.repeats_previous(j);
            let across = match previous {
                Some(across) if repeats => across,
                _ => Across::of(outline, j, v, sigma),
            };
            previous = Some(across);
            let along = (outline.u_m(j) - u) * inv_sigma;
            across.map(|across| Share {
                weight: normal::pdf(along),
                along,
                across,
                repeats,
            })
        })
}

/// The coefficients of `c0, c1, c2` in the blurred contrast at silhouette-frame point `(u, v)`,
/// m, for a Gaussian blur of `sigma` m (positive).
pub fn body_basis<const C: usize>(outline: &Outline<C>, u: f32, v: f32, sigma: f32) -> [f32; 3] {
    let mut basis = [0.0f32; 3];
    for share in shares(outline, u, v, sigma) {
        for (b, t) in basis.iter_mut().zip(share.across.terms) {
            *b += share.weight * t;
        }
    }
    // The Gaussian's weights summed at the column spacing integrate to 1 / (step / sigma).
    let scale = outline.step_m() * (1.0 / sigma);
    basis.map(|b| b * scale)
}

/// The blurred contrast at a point with its derivatives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyImage {
    /// The coefficients of `c0, c1, c2` ([`body_basis`]).
    pub basis: [f32; 3],
    /// The contrast's derivatives in the point's `u` and `v` and in the blur `sigma`, grey
    /// levels per m.
    pub d_u: f32,
    /// See `d_u`.
    pub d_v: f32,
    /// See `d_u`.
    pub d_sigma: f32,
}

/// A column's blurred contrast `c0 + c1 w + c2 w²` (before the Gaussian's weight along the
/// axis) and its derivatives across and in the blur, grey levels (per m).
#[derive(Debug, Clone, Copy)]
struct ColumnContrast {
    value: f32,
    across: f32,
    blur: f32,
}

impl ColumnContrast {
    /// Of the column blurred as `c` across, shaded by `shading`, for a blur of `1 / inv_sigma` m.
    #[inline]
    fn of(c: &Across, shading: [f32; 3], inv_sigma: f32) -> ColumnContrast {
        let (a, b, w, s, h) = (c.alpha, c.beta, c.w, c.s, c.half);
        let (m0, m1, m2) = (c.m0, c.m1, c.m2);
        // x phi(x), x² phi(x) and (1 - x²) phi(x) between the edges.
        let n1 = b * c.pdf_b - a * c.pdf_a;
        let n2 = (1.0 - b * b) * c.pdf_b - (1.0 - a * a) * c.pdf_a;
        let q = b * b * c.pdf_b - a * a * c.pdf_a;
        let r = (1.0 - b * b) * b * c.pdf_b - (1.0 - a * a) * a * c.pdf_a;
        // The fins' faces: stretches of a fixed `w` whose edges move as the body's do.
        let [by_w, by_w2] = c.faces;
        // Across (the edges move by -1/sigma in sigmas, w by 1/h).
        let across = [
            c.whole.m1 * inv_sigma,
            m0 / h + (w * m1 - s * n1 + by_w.m1) * inv_sigma,
            2.0 * w / h * m0
                + 2.0 * s / h * m1
                + (w * w * m1 - 2.0 * w * s * n1 + s * s * (m1 + n2) + by_w2.m1) * inv_sigma,
        ];
        // In the blur (the edges in sigmas shrink, s grows by 1/h).
        let blur = [
            -c.whole.n1 * inv_sigma,
            m1 / h - (w * n1 + s * q + by_w.n1) * inv_sigma,
            2.0 * w / h * m1
                + 2.0 * s / h * m2
                + (-w * w * n1 - 2.0 * w * s * q + s * s * (r - n1) - by_w2.n1) * inv_sigma,
        ];
        ColumnContrast {
            value: contrast(shading, c.terms),
            across: contrast(shading, across),
            blur: contrast(shading, blur),
        }
    }
}

/// [`body_basis`] with the derivatives of the contrast `c0 + c1 w + c2 w²` (`shading`) in `u`,
/// `v` and `sigma`, by differentiating the moments of the truncated normal.
pub fn body_image<const C: usize>(
    outline: &Outline<C>,
    u: f32,
    v: f32,
    sigma: f32,
    shading: [f32; 3],
) -> BodyImage {
    let inv_sigma = 1.0 / sigma;
    let (mut basis, mut d_u, mut d_v, mut d_sigma) = ([0.0f32; 3], 0.0, 0.0, 0.0);
    // The last column's contrasts, which a column that repeats its edges shares.
    let mut last: Option<ColumnContrast> = None;
    for c in shares(outline, u, v, sigma) {
        for (b, t) in basis.iter_mut().zip(c.across.terms) {
            *b += c.weight * t;
        }
        let column = match last {
            Some(column) if c.repeats => column,
            _ => ColumnContrast::of(&c.across, shading, inv_sigma),
        };
        last = Some(column);
        // The weight phi((u_j - u) / sigma) in u and in sigma.
        let x = c.along;
        d_u += x * c.weight * inv_sigma * column.value;
        d_v += c.weight * column.across;
        d_sigma += x * x * c.weight * inv_sigma * column.value + c.weight * column.blur;
    }
    let scale = outline.step_m() * inv_sigma;
    let basis = basis.map(|b| b * scale);
    // The scale's own derivative in sigma: -1/sigma times the contrast.
    let d_sigma = scale * d_sigma - contrast(shading, basis) * inv_sigma;
    BodyImage {
        basis,
        d_u: scale * d_u,
        d_v: scale * d_v,
        d_sigma,
    }
}

#[cfg(test)]
mod tests {
    use super::super::outline::NOSE_AWAY;
    use super::*;
    use crate::lut::render::View;
    use crate::model::testing::reference;

    fn broadside() -> Outline<512> {
        let view = View {
            tilt_deg: 0.0,
            roll_deg: 0.0,
        };
        Outline::build(&reference(), &view, 500, NOSE_AWAY).unwrap()
    }

    /// Mid-body, far from the ends, the blur across a uniform cylinder of radius 40 mm is
    /// `Phi((r - v) / s) - Phi((-r - v) / s)` (worked by hand): 1 on the axis, 1/2 on the edge.
    #[test]
    fn across_a_cylinder_the_blur_is_the_normal_cdf() {
        let outline = broadside();
        let sigma = 0.01;
        let on_axis = body_basis(&outline, 0.0, 0.0, sigma);
        assert!((on_axis[0] - 1.0).abs() < 2e-3, "{on_axis:?}");
        let on_edge = body_basis(&outline, 0.0, 0.04, sigma);
        assert!((on_edge[0] - 0.5).abs() < 2e-3, "{on_edge:?}");
        // One sigma outside: Phi(-1) = 0.1587.
        let outside = body_basis(&outline, 0.0, 0.05, sigma);
        assert!((outside[0] - 0.1587).abs() < 2e-3, "{outside:?}");
        // The gradient term is odd across the axis, the quadratic one even.
        let (up, down) = (
            body_basis(&outline, 0.0, 0.02, sigma),
            body_basis(&outline, 0.0, -0.02, sigma),
        );
        assert!((up[1] + down[1]).abs() < 1e-4 && up[1] > 0.0);
        assert!((up[2] - down[2]).abs() < 1e-4 && up[2] > 0.0);
    }

    /// Well inside the body the blurred quadratic is its mean under the blur: `w` for the
    /// gradient and `w² + s²` for the square (`s` the blur in half widths), by hand.
    #[test]
    fn inside_the_body_the_shading_terms_are_the_blurred_normal() {
        let outline = broadside();
        let sigma = 0.008;
        let b = body_basis(&outline, 0.1, 0.01, sigma);
        let (w, s) = (0.01 / 0.04, sigma / 0.04);
        assert!((b[0] - 1.0).abs() < 2e-3, "{b:?}");
        assert!((b[1] - w).abs() < 2e-3, "{b:?}");
        assert!((b[2] - (w * w + s * s)).abs() < 2e-3, "{b:?}");
    }

    /// Along the reference's cylinder most columns repeat their neighbour's edges, and the
    /// image made from the repeated columns' shared blur is, bit for bit, the image with every
    /// column worked out afresh: at the tail, the fins, mid-body, the nose and off the body,
    /// with the fins' faces apart and as the body.
    #[test]
    fn repeated_columns_give_the_image_of_every_column_afresh() {
        let view = View {
            tilt_deg: 25.0,
            roll_deg: 30.0,
        };
        for fins in [NOSE_AWAY, super::super::outline::Fins::AsBody] {
            let outline = Outline::<512>::build(&reference(), &view, 400, fins).unwrap();
            let repeating = (0..outline.columns())
                .filter(|&j| outline.repeats_previous(j))
                .count();
            assert!(repeating > 200, "{repeating} of 400 columns repeat");
            let afresh = outline.without_repeats();
            let shading = [-120.0, 20.0, -15.0];
            let sigma = 0.012;
            for (u, v) in [
                (-0.62, 0.03),
                (-0.55, 0.09),
                (0.1, 0.041),
                (0.2, -0.01),
                (0.6, 0.015),
                (0.3, 0.3),
            ] {
                assert_eq!(
                    body_image(&outline, u, v, sigma, shading),
                    body_image(&afresh, u, v, sigma, shading),
                    "({u}, {v})"
                );
                assert_eq!(
                    body_basis(&outline, u, v, sigma),
                    body_basis(&afresh, u, v, sigma),
                    "({u}, {v})"
                );
            }
        }
    }

    /// The derivatives agree with central differences of the image itself, near the base,
    /// on an edge and inside, for a tilted, rolled outline (to 2 % and 10 grey levels per m of
    /// some 300-3800: the differences themselves scatter that much, as columns enter and leave
    /// the 4 sigmas summed).
    #[test]
    fn the_derivatives_are_those_of_the_image() {
        let view = View {
            tilt_deg: 25.0,
            roll_deg: 30.0,
        };
        let outline = Outline::<512>::build(&reference(), &view, 500, NOSE_AWAY).unwrap();
        let shading = [-120.0, 20.0, -15.0];
        let contrast =
            |u: f32, v: f32, sigma: f32| contrast(shading, body_basis(&outline, u, v, sigma));
        let sigma = 0.012;
        let h = 1e-4;
        for (u, v) in [
            (0.1, 0.041),
            (0.2, -0.01),
            (0.55, 0.015),
            (-0.62, 0.09),
            (-0.6, 0.03),
        ] {
            let image = body_image(&outline, u, v, sigma, shading);
            let b = body_basis(&outline, u, v, sigma);
            assert_eq!(image.basis, b);
            let d_u = (contrast(u + h, v, sigma) - contrast(u - h, v, sigma)) / (2.0 * h);
            let d_v = (contrast(u, v + h, sigma) - contrast(u, v - h, sigma)) / (2.0 * h);
            // The columns summed end at 4 sigmas: a wider step in sigma keeps the few that
            // enter or leave from dominating the difference.
            let hs = 1e-3;
            let d_s = (contrast(u, v, sigma + hs) - contrast(u, v, sigma - hs)) / (2.0 * hs);
            for (name, analytic, numeric) in [
                ("u", image.d_u, d_u),
                ("v", image.d_v, d_v),
                ("sigma", image.d_sigma, d_s),
            ] {
                let tolerance = 0.02 * numeric.abs() + 10.0;
                assert!(
                    (analytic - numeric).abs() < tolerance,
                    "({u}, {v}) d/d{name}: {analytic} vs {numeric}"
                );
            }
        }
    }

    /// At the base (broadside: a straight edge across the axis) the blur along the axis is a
    /// normal CDF too: half the contrast on the base line.
    #[test]
    fn along_the_axis_the_base_blurs_to_half() {
        let outline = broadside();
        let (tail, _) = outline.u_range_m();
        let sigma = 0.01;
        let at = |u: f32| body_basis(&outline, u, 0.0, sigma)[0];
        assert!((at(tail) - 0.5).abs() < 0.01, "{}", at(tail));
        assert!(
            (at(tail - sigma) - 0.1587).abs() < 0.01,
            "{}",
            at(tail - sigma)
        );
        assert!((at(tail + 3.0 * sigma) - 0.9987).abs() < 0.01);
    }
}
