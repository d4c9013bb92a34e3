//! The body's cross-section with Lambertian shading: an unbiased diameter under sunlight.
//!
//! A sunlit body of revolution is not uniformly dark: its radiance follows the surface normal,
//! which across the silhouette at `w = (s - s0) / r` (in -1..1, `r` the radius in px) is
//! `(w, sqrt(1 - w²))` in the plane across the axis. A contrast linear in the normal,
//!
//! `A(w) = c0 + c1 w + c2 sqrt(1 - w²)`,
//!
//! blurred by a Gaussian of `sigma` px, is fitted to the binned cross-section by Levenberg-
//! Marquardt. The blur is exact: `A` is averaged over `INTERVALS` slices of the section, each a
//! blurred box. A box with a linear term only (the closed form's model) reads the sunlit edge
//! too far out and over-estimates the diameter by 10-15 % on shaded bodies at 5-8 px.

use crate::extremes::cross_profile::Binned;
use crate::extremes::cross_profile::CrossSection;
use crate::math::least_squares::{self, Normal};
use crate::math::normal;
use nalgebra::SVector;

/// Slices of the section.
const INTERVALS: usize = 12;

/// The Lambertian fit's Levenberg-Marquardt settings: the core's damping schedule, at most 25
/// iterations, converged when a step lowers the cost by at most 1e-5 of it.
const SOLVER: least_squares::Config = least_squares::Config {
    max_iterations: 25,
    relative_tolerance: 1e-5,
    ..least_squares::Config::DEFAULT
};

/// Smallest radius, px.
const MIN_RADIUS_PX: f32 = 0.1;
/// Smallest blur, px.
const MIN_SIGMA_PX: f32 = 0.2;

/// Cost reduction, in residual variances per pixel, for the shading terms to be kept.
const SIGNIFICANCE: f32 = 20.0;
/// The largest relative change of the diameter from the box's that is believed.
const MAX_CHANGE: f32 = 0.25;

/// Parameters: background, c0, c1, c2, centre s0 (px), radius r (px), sigma (px).
type Params = SVector<f32, 7>;

/// A fitted cross-section with Lambertian shading.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LambertSection {
    /// Diameter across the axis, px.
    pub diameter_px: f32,
    /// Mean contrast across the section (of the body's polarity), grey levels: the integral of
    /// the contrast across the axis is `diameter_px * mean_contrast`.
    pub mean_contrast: f32,
    /// Gaussian blur standard deviation, px.
    pub sigma_px: f32,
    /// Offset of the body's axis from the binned axis, px across.
    pub offset_px: f32,
}

/// The slices: boundaries in `w` (Chebyshev-spaced, fine at the edges where `sqrt(1 - w²)`
/// bends) and the mean of `w` and of `sqrt(1 - w²)` over each.
struct Slices {
    edges: [f32; INTERVALS + 1],
    mean_w: [f32; INTERVALS],
    mean_sqrt: [f32; INTERVALS],
}

impl Slices {
    fn new() -> Slices {
        let mut edges = [0.0f32; INTERVALS + 1];
        for (i, e) in edges.iter_mut().enumerate() {
            *e = -libm::cosf(core::f32::consts::PI * i as f32 / INTERVALS as f32);
        }
        // Antiderivative of sqrt(1 - w²).
        let area = |w: f32| 0.5 * (w * libm::sqrtf((1.0 - w * w).max(0.0)) + libm::asinf(w));
        let mut mean_w = [0.0f32; INTERVALS];
        let mut mean_sqrt = [0.0f32; INTERVALS];
        for j in 0..INTERVALS {
            let (a, b) = (edges[j], edges[j + 1]);
            mean_w[j] = 0.5 * (a + b);
            mean_sqrt[j] = (area(b) - area(a)) / (b - a).max(1e-6);
        }
        Slices {
            edges,
            mean_w,
            mean_sqrt,
        }
    }

    /// Model value and gradient at `s` px across.
    fn model(&self, s: f32, p: &Params) -> (f32, Params) {
        let (b, c0, c1, c2, s0, r, sigma) = (p[0], p[1], p[2], p[3], p[4], p[5], p[6]);
        let node = |i: usize| {
            let z = (s - s0 - r * self.edges[i]) / sigma;
            let (cdf, pdf) = normal::cdf_pdf(z);
            (z, cdf, pdf)
        };
        let mut g = Params::zeros();
        let mut value = b;
        g[0] = 1.0;
        // Slice `j` lies between nodes `j` and `j + 1`: each node is evaluated once, carried
        // over to the next slice (no arrays of nodes: their zeroing was a memset a call on the
        // M4F).
        let mut lower = node(0);
        for j in 0..INTERVALS {
            let upper = node(j + 1);
            let ((z0, cdf0, pdf0), (z1, cdf1, pdf1)) = (lower, upper);
            let coverage = cdf0 - cdf1;
            let amplitude = c0 + c1 * self.mean_w[j] + c2 * self.mean_sqrt[j];
            value += amplitude * coverage;
            g[1] += coverage;
            g[2] += self.mean_w[j] * coverage;
            g[3] += self.mean_sqrt[j] * coverage;
            g[4] += amplitude * (pdf1 - pdf0) / sigma;
            g[5] += amplitude * (self.edges[j + 1] * pdf1 - self.edges[j] * pdf0) / sigma;
            g[6] += amplitude * (z1 * pdf1 - z0 * pdf0) / sigma;
            lower = upper;
        }
        (value, g)
    }
}

/// The shaded section fitted to a binned profile, `c2` fixed unless `free_c2`.
struct SectionFit<'a> {
    slices: &'a Slices,
    binned: &'a Binned,
    free_c2: bool,
}

impl least_squares::Problem<7> for SectionFit<'_> {
    /// The weighted squared residual and the normal equations (`JᵀWJ`, `JᵀWr`) at `p`, from
    /// one evaluation of the model per point; `c2`'s column is zero unless `free_c2`.
    fn evaluate(&self, p: &Params) -> Option<Normal<7>> {
        let mut normal = Normal::zeros();
        for (s, v, w) in self.binned.points() {
            let (value, mut g) = self.slices.model(s, p);
            if !self.free_c2 {
                g[3] = 0.0;
            }
            normal.add(&g, w, v - value);
        }
        Some(normal.complete())
    }

    /// Radius at least [`MIN_RADIUS_PX`], blur between [`MIN_SIGMA_PX`] and the profile's half
    /// width (at least [`MIN_SIGMA_PX`], so the clamp cannot panic).
    fn constrain(&self, _: &Params, trial: &mut Params) {
        trial[5] = trial[5].max(MIN_RADIUS_PX);
        trial[6] = trial[6].clamp(MIN_SIGMA_PX, self.binned.half_width.max(MIN_SIGMA_PX));
    }
}

/// Levenberg-Marquardt from `p`; `c2` stays fixed unless `free_c2`. Returns the parameters and
/// their cost: `p` and NaN where the cost at `p` is not finite.
fn minimize(slices: &Slices, binned: &Binned, p: Params, free_c2: bool) -> (Params, f32) {
    let problem = SectionFit {
        slices,
        binned,
        free_c2,
    };
    least_squares::minimize(&problem, p, &SOLVER).map_or((p, f32::NAN), |s| (s.params, s.cost))
}

/// Fits the shaded section to `binned`, starting from the box fit `start` of the same pixels.
/// The curvature term `c2` is kept only where it reduces the cost significantly: on a
/// uniformly dark body it would only trade with the diameter and add noise.
pub fn fit(binned: &Binned, start: &CrossSection) -> Option<LambertSection> {
    let slices = Slices::new();
    // Start from the box: a uniform section with the box's linear shading.
    let p = Params::from([
        0.0,
        start.contrast,
        start.shading * 0.5 * start.diameter_px,
        0.0,
        start.offset_px,
        0.5 * start.diameter_px,
        start.sigma_px,
    ]);
    let (linear, linear_cost) = minimize(&slices, binned, p, false);
    let (curved, curved_cost) = minimize(&slices, binned, linear, true);
    let noise = curved_cost / binned.pixels.max(1) as f32;
    let plausible = libm::fabsf(curved[5] / linear[5].max(1e-6) - 1.0) < MAX_CHANGE;
    let p = if linear_cost - curved_cost > SIGNIFICANCE * noise && plausible {
        curved
    } else {
        linear
    };
    let section = LambertSection {
        diameter_px: 2.0 * p[5],
        mean_contrast: p[1] + core::f32::consts::FRAC_PI_4 * p[3],
        sigma_px: p[6],
        offset_px: p[4],
    };
    (section.mean_contrast > 0.0
        && section.diameter_px.is_finite()
        && section.offset_px.is_finite()
        && section.diameter_px < 2.0 * binned.half_width)
        .then_some(section)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::extremes::cross_profile;

    /// A shaded section sampled exactly from the model: the box fit starts the Lambertian fit,
    /// which recovers the diameter the box misreads (6.0 px of 7, the dim edges of a body
    /// lit face-on).
    #[test]
    fn an_exact_shaded_section_is_recovered() {
        let slices = Slices::new();
        // Background 2, a strongly shaded body of diameter 7 px, blur 0.8 px, 0.3 px off axis.
        let truth = Params::from([2.0, 20.0, 30.0, 80.0, 0.3, 3.5, 0.8]);
        let binned = Binned::sampled(12.0, 0.25, 4, |s| slices.model(s, &truth).0);
        let start = cross_profile::fit_binned(&binned, None).unwrap();
        assert!((start.diameter_px - 7.0).abs() > 0.5, "{start:?}");
        let section = fit(&binned, &start).unwrap();
        assert!(
            (section.diameter_px - 7.0).abs() < 0.02,
            "{section:?} from {start:?}"
        );
        assert!((section.offset_px - 0.3).abs() < 0.02, "{section:?}");
        assert!((section.sigma_px - 0.8).abs() < 0.02, "{section:?}");
        let mean = 20.0 + core::f32::consts::FRAC_PI_4 * 80.0;
        assert!((section.mean_contrast - mean).abs() < 0.5, "{section:?}");
    }

    /// A profile whose half width is below the smallest blur, or not a number, is fitted
    /// without a panic (the blur's clamp).
    #[test]
    fn a_degenerate_half_width_does_not_panic() {
        let slices = Slices::new();
        let truth = Params::from([0.0, 50.0, 0.0, 0.0, 0.0, 1.5, 0.8]);
        let start = CrossSection {
            diameter_px: 3.0,
            contrast: 50.0,
            shading: 0.0,
            sigma_px: 0.8,
            offset_px: 0.0,
            pixels: 48,
        };
        for half_width in [0.1, f32::NAN] {
            let mut binned = Binned::sampled(6.0, 0.25, 1, |s| slices.model(s, &truth).0);
            binned.half_width = half_width;
            let _ = fit(&binned, &start);
        }
    }
}
