//! The body's image: an outline filled with a shaded radiance and blurred by the optics.
//!
//! Across each column of the [`Outline`], between its lower edge `a` and upper edge `b`, the
//! body's contrast against the sky is a quadratic in `w = (v - m) / h` (`m` the column's middle,
//! `h` its half width): `c0 + c1 w + c2 w²`. It stands for Lambertian shading, which is linear
//! in the surface normal: the normal's component across the axis is `w` on a cylinder, and
//! `w²` follows the darkening towards the limbs. The optics blur it with an isotropic Gaussian of
//! `sigma` (the lens's PSF and the pixel's own width together). Across the column the blurred
//! contrast is exact, from the normal's CDF and density at the two edges (the moments of a
//! truncated normal); along the axis it is the sum over the columns within `REACH` sigmas,
//! weighted by the Gaussian. The image is linear in `c0, c1, c2`, so it is handed over as their
//! three coefficients.

use super::outline::Outline;
use crate::math::normal;

/// Columns farther than this many sigmas along the axis are not summed.
const REACH: f32 = 4.0;
/// A column whose edges both lie farther than this many sigmas to one side of the point adds
/// nothing (the normal's tail beyond it is 3e-7).
const EDGE_REACH: f32 = 5.0;

/// The coefficients of `c0, c1, c2` in the blurred contrast at silhouette-frame point `(u, v)`,
/// m, for a Gaussian blur of `sigma` m (positive).
pub fn body_basis<const C: usize>(outline: &Outline<C>, u: f32, v: f32, sigma: f32) -> [f32; 3] {
    let mut basis = [0.0f32; 3];
    let inv_sigma = 1.0 / sigma;
    for j in outline.columns_within(u - REACH * sigma, u + REACH * sigma) {
        let Some((lower, upper)) = outline.edges(j) else {
            continue;
        };
        let (alpha, beta) = ((lower - v) * inv_sigma, (upper - v) * inv_sigma);
        if alpha > EDGE_REACH || beta < -EDGE_REACH {
            // Beyond the column's reach across: nothing of it is blurred this far.
            continue;
        }
        let weight = normal::pdf((outline.u_m(j) - u) * inv_sigma);
        let (cdf_a, pdf_a) = normal::cdf_pdf(alpha);
        let (cdf_b, pdf_b) = normal::cdf_pdf(beta);
        // Moments of the blur's weight over the column: ∫ x^k phi(x) dx over alpha..beta.
        let m0 = cdf_b - cdf_a;
        let m1 = pdf_a - pdf_b;
        let m2 = m0 - (beta * pdf_b - alpha * pdf_a);
        let half = (0.5 * (upper - lower)).max(f32::MIN_POSITIVE);
        let w_here = (v - 0.5 * (upper + lower)) / half;
        let s = sigma / half;
        basis[0] += weight * m0;
        basis[1] += weight * (w_here * m0 + s * m1);
        basis[2] += weight * (w_here * w_here * m0 + 2.0 * w_here * s * m1 + s * s * m2);
    }
    // The Gaussian's weights summed at the column spacing integrate to 1 / (step / sigma).
    let scale = outline.step_m() * inv_sigma;
    basis.map(|b| b * scale)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lut::render::View;
    use crate::model::testing::reference;

    fn broadside() -> Outline<512> {
        let view = View {
            tilt_deg: 0.0,
            roll_deg: 0.0,
        };
        Outline::build(&reference(), &view, 500).unwrap()
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
