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
use crate::math::{self, normal};
use nalgebra::{SMatrix, SVector};

/// Slices of the section.
const INTERVALS: usize = 12;

/// Levenberg-Marquardt iterations at most.
const MAX_ITERATIONS: usize = 25;

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
        let mut cdf = [0.0f32; INTERVALS + 1];
        let mut pdf = [0.0f32; INTERVALS + 1];
        let mut z = [0.0f32; INTERVALS + 1];
        for i in 0..=INTERVALS {
            z[i] = (s - s0 - r * self.edges[i]) / sigma;
            (cdf[i], pdf[i]) = normal::cdf_pdf(z[i]);
        }
        let mut g = Params::zeros();
        let mut value = b;
        g[0] = 1.0;
        for j in 0..INTERVALS {
            let coverage = cdf[j] - cdf[j + 1];
            let amplitude = c0 + c1 * self.mean_w[j] + c2 * self.mean_sqrt[j];
            value += amplitude * coverage;
            g[1] += coverage;
            g[2] += self.mean_w[j] * coverage;
            g[3] += self.mean_sqrt[j] * coverage;
            g[4] += amplitude * (pdf[j + 1] - pdf[j]) / sigma;
            g[5] += amplitude * (self.edges[j + 1] * pdf[j + 1] - self.edges[j] * pdf[j]) / sigma;
            g[6] += amplitude * (z[j + 1] * pdf[j + 1] - z[j] * pdf[j]) / sigma;
        }
        (value, g)
    }

    /// The weighted squared residual and the normal equations (`JᵀWJ`, `JᵀWr`) at `p`, from
    /// one evaluation of the model per point; `c2`'s column is zero unless `free_c2`.
    fn evaluate(&self, binned: &Binned, p: &Params, free_c2: bool) -> Evaluation {
        let mut cost = 0.0f32;
        let mut jtj = SMatrix::<f32, 7, 7>::zeros();
        let mut jtr = Params::zeros();
        for (s, v, w) in binned.points() {
            let (value, mut g) = self.model(s, p);
            if !free_c2 {
                g[3] = 0.0;
            }
            let r = v - value;
            cost += w * r * r;
            math::accumulate(&mut jtj, &mut jtr, &g, w, r);
        }
        jtj.fill_lower_triangle_with_upper_triangle();
        (cost, jtj, jtr)
    }
}

/// The cost and normal equations at a point of the parameter space.
type Evaluation = (f32, SMatrix<f32, 7, 7>, Params);

/// Levenberg-Marquardt from `p`; `c2` stays fixed unless `free_c2`. Returns the parameters and
/// their cost.
fn minimize(slices: &Slices, binned: &Binned, mut p: Params, free_c2: bool) -> (Params, f32) {
    let mut lambda = 1e-2f32;
    // The cost and normal equations at `p`, carried over from an accepted trial.
    let mut at_p = slices.evaluate(binned, &p, free_c2);
    for _ in 0..MAX_ITERATIONS {
        let (cost, jtj, jtr) = at_p;
        let mut damped = jtj;
        for k in 0..7 {
            damped[(k, k)] += lambda * jtj[(k, k)].max(1e-9);
        }
        let Some(step) = damped.cholesky().map(|c| c.solve(&jtr)) else {
            lambda *= 10.0;
            continue;
        };
        let mut trial = p + step;
        trial[5] = trial[5].max(0.1);
        trial[6] = trial[6].clamp(0.2, binned.half_width);
        let at_trial = slices.evaluate(binned, &trial, free_c2);
        let trial_cost = at_trial.0;
        if trial_cost.is_finite() && trial_cost <= cost {
            let converged = (cost - trial_cost) <= 1e-5 * cost.max(1e-12);
            p = trial;
            at_p = at_trial;
            lambda = (lambda * 0.3).max(1e-7);
            if converged {
                break;
            }
        } else {
            lambda *= 10.0;
            if lambda > 1e6 {
                break;
            }
        }
    }
    (p, at_p.0)
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
