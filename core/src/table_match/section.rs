//! The body's cross-section with Lambertian shading: an unbiased diameter under sunlight.
//!
//! A sunlit body of revolution is not uniformly dark: its radiance follows the surface normal,
//! which across the silhouette at `w = (s - s0) / r` (in -1..1, `r` the radius in px) is
//! `(w, sqrt(1 - w²))` in the plane across the axis. A contrast linear in the normal,
//!
//! `A(w) = c0 + c1 w + c2 sqrt(1 - w²)`,
//!
//! blurred by a Gaussian of `sigma` px, is fitted to the binned cross-section by Levenberg-
//! Marquardt. The blur is exact for a contrast linear in `w`: a linear piece between two edges
//! `w = e0..e1`, blurred, is the normal distribution's CDF and density at the edges (`Ramp`).
//! So `c0 + c1 w` takes the two outer edges, and the curvature term `sqrt(1 - w²)` is taken as
//! six slices (`INTERVALS`), each the straight line nearest it over the slice (its mean and its
//! first moment there exact): 7 evaluations of the normal distribution a point, against 13 when each
//! slice held the term constant, and 3-12 times closer to the exactly blurred term (0.3-2.9e-3
//! of `c2` against 5-7e-3, radius 2-5 px, blur 0.3-1.0 px). A box with a linear term only (the
//! closed form's model) reads the sunlit edge too far out and over-estimates the diameter by
//! 10-15 % on shaded bodies at 5-8 px.

use crate::extremes::cross_profile::Binned;
use crate::extremes::cross_profile::{CrossSection, DiameterBounds};
use crate::math::least_squares::{self, Normal};
use crate::math::normal;
use nalgebra::SVector;

/// Slices of the section's curvature term.
const INTERVALS: usize = 6;

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
/// Indices of the centre, the radius and the blur: the geometry.
const GEOMETRY: [usize; 3] = [4, 5, 6];

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

/// One edge of a piece of the section, `w = e` (-1..1), seen from the point `s` px across: its
/// distance from the point in blur sigmas (`z = (s - s0 - r e) / sigma`), the normal
/// distribution's CDF and density there.
#[derive(Clone, Copy)]
struct Edge {
    e: f32,
    z: f32,
    cdf: f32,
    pdf: f32,
}

impl Edge {
    fn at(e: f32, s: f32, p: &Params) -> Edge {
        let (s0, r, sigma) = (p[4], p[5], p[6]);
        let z = (s - s0 - r * e) / sigma;
        let (cdf, pdf) = normal::cdf_pdf(z);
        Edge { e, z, cdf, pdf }
    }
}

/// A piece of the section between two edges, blurred, as its contrast `a + b w` sees it.
/// With `w = u - (sigma / r) z` (`u = (s - s0) / r`), its value at the point is
/// `(a + b u) coverage - (b sigma / r) density`: `coverage` the blur's weight between the
/// edges (the CDF's difference), `density` the density's difference (the blur's first moment
/// there). Both come with their derivatives in the centre, the radius and the blur.
struct Ramp {
    coverage: f32,
    density: f32,
    d_coverage: [f32; 3],
    d_density: [f32; 3],
    /// `u`, and its derivatives in the centre, the radius and the blur.
    u: f32,
    d_u: [f32; 3],
    /// `sigma / r`, and its derivatives likewise.
    sigma_r: f32,
    d_sigma_r: [f32; 3],
}

impl Ramp {
    /// The piece from edge `low` to `high` (`low.e < high.e`, so `low.z > high.z`) at `s` px
    /// across.
    fn between(low: &Edge, high: &Edge, s: f32, p: &Params) -> Ramp {
        let (s0, r, sigma) = (p[4], p[5], p[6]);
        let (inv_r, inv_sigma) = (1.0 / r, 1.0 / sigma);
        // An edge's z moves by -1/sigma with the centre, -e/sigma with the radius and
        // -z/sigma with the blur; the CDF by the density times that, the density by -z
        // times it.
        let dz = |edge: &Edge| [-inv_sigma, -edge.e * inv_sigma, -edge.z * inv_sigma];
        let (dz_low, dz_high) = (dz(low), dz(high));
        let u = (s - s0) * inv_r;
        let sigma_r = sigma * inv_r;
        Ramp {
            coverage: low.cdf - high.cdf,
            density: high.pdf - low.pdf,
            d_coverage: core::array::from_fn(|k| low.pdf * dz_low[k] - high.pdf * dz_high[k]),
            d_density: core::array::from_fn(|k| {
                low.z * low.pdf * dz_low[k] - high.z * high.pdf * dz_high[k]
            }),
            u,
            d_u: [-inv_r, -u * inv_r, 0.0],
            sigma_r,
            d_sigma_r: [0.0, -sigma_r * inv_r, inv_r],
        }
    }

    /// The piece's value for the contrast `a + b w`, and its derivatives in the centre, the
    /// radius and the blur.
    fn value(&self, a: f32, b: f32) -> (f32, [f32; 3]) {
        let level = a + b * self.u;
        let value = level * self.coverage - b * self.sigma_r * self.density;
        let gradient = core::array::from_fn(|k| {
            b * self.d_u[k] * self.coverage + level * self.d_coverage[k]
                - b * (self.d_sigma_r[k] * self.density + self.sigma_r * self.d_density[k])
        });
        (value, gradient)
    }
}

/// The slices of the curvature term: boundaries in `w` (Chebyshev-spaced, fine at the edges
/// where `sqrt(1 - w²)` bends), and on each the line `a + b w` nearest the term (least
/// squares over the slice: its mean and first moment).
struct Slices {
    edges: [f32; INTERVALS + 1],
    lines: [(f32, f32); INTERVALS],
}

impl Slices {
    fn new() -> Slices {
        let edges: [f32; INTERVALS + 1] = core::array::from_fn(|i| {
            -libm::cosf(core::f32::consts::PI * i as f32 / INTERVALS as f32)
        });
        // Antiderivatives of sqrt(1 - w²) and of w sqrt(1 - w²).
        let area = |w: f32| 0.5 * (w * libm::sqrtf((1.0 - w * w).max(0.0)) + libm::asinf(w));
        let moment = |w: f32| {
            let rest = (1.0 - w * w).max(0.0);
            -rest * libm::sqrtf(rest) / 3.0
        };
        let lines = core::array::from_fn(|j| {
            let (lo, hi) = (edges[j], edges[j + 1]);
            let width = (hi - lo).max(1e-6);
            let mean_w = 0.5 * (lo + hi);
            let mean = (area(hi) - area(lo)) / width;
            let mean_wf = (moment(hi) - moment(lo)) / width;
            let slope = (mean_wf - mean_w * mean) / (width * width / 12.0);
            (mean - slope * mean_w, slope)
        });
        Slices { edges, lines }
    }

    /// Model value and gradient at `s` px across; without `curved`, `c2`'s term is left out
    /// (two edges, not all of them) and its gradient is zero.
    fn model(&self, s: f32, p: &Params, curved: bool) -> (f32, Params) {
        let (b, c0, c1, c2) = (p[0], p[1], p[2], p[3]);
        let mut g = Params::zeros();
        g[0] = 1.0;
        let first = Edge::at(-1.0, s, p);
        let last = Edge::at(1.0, s, p);
        let whole = Ramp::between(&first, &last, s, p);
        let (constant, d_constant) = whole.value(1.0, 0.0);
        let (linear, d_linear) = whole.value(0.0, 1.0);
        let mut value = b + c0 * constant + c1 * linear;
        g[1] = constant;
        g[2] = linear;
        for (k, &i) in GEOMETRY.iter().enumerate() {
            g[i] = c0 * d_constant[k] + c1 * d_linear[k];
        }
        if curved {
            // Slice `j` lies between edges `j` and `j + 1`: each edge is evaluated once and
            // carried to the next slice (the outer two are those above).
            let mut low = first;
            for (j, &(a, slope)) in self.lines.iter().enumerate() {
                let high = match self.edges.get(j + 1) {
                    Some(&e) if j + 1 < INTERVALS => Edge::at(e, s, p),
                    _ => last,
                };
                let (term, d_term) = Ramp::between(&low, &high, s, p).value(a, slope);
                value += c2 * term;
                g[3] += term;
                for (k, &i) in GEOMETRY.iter().enumerate() {
                    g[i] += c2 * d_term[k];
                }
                low = high;
            }
        }
        (value, g)
    }
}

/// The shaded section fitted to a binned profile; `c2` held at zero unless `free_c2`.
struct SectionFit<'a> {
    slices: &'a Slices,
    binned: &'a Binned,
    free_c2: bool,
    bounds: Option<DiameterBounds>,
}

impl least_squares::Problem<7> for SectionFit<'_> {
    /// The weighted squared residual and the normal equations (`JᵀWJ`, `JᵀWr`) at `p`, from
    /// one evaluation of the model per point; `c2`'s column is zero unless `free_c2`.
    fn evaluate(&self, p: &Params) -> Option<Normal<7>> {
        let mut normal = Normal::zeros();
        for (s, v, w) in self.binned.points() {
            let (value, g) = self.slices.model(s, p, self.free_c2);
            normal.add(&g, w, v - value);
        }
        Some(normal.complete())
    }

    /// Radius within the bounds where given and at least [`MIN_RADIUS_PX`], blur between
    /// [`MIN_SIGMA_PX`] and the profile's half width (at least [`MIN_SIGMA_PX`], so the clamp
    /// cannot panic).
    fn constrain(&self, _: &Params, trial: &mut Params) {
        if let Some(b) = self.bounds {
            trial[5] = trial[5].max(0.5 * b.min_px).min(0.5 * b.max_px);
        }
        trial[5] = trial[5].max(MIN_RADIUS_PX);
        trial[6] = trial[6].clamp(MIN_SIGMA_PX, self.binned.half_width.max(MIN_SIGMA_PX));
    }
}

/// Levenberg-Marquardt from `p`; `c2` stays fixed unless `free_c2`. Returns the parameters and
/// their cost: `p` and NaN where the cost at `p` is not finite.
fn minimize(
    slices: &Slices,
    binned: &Binned,
    p: Params,
    free_c2: bool,
    bounds: Option<DiameterBounds>,
) -> (Params, f32) {
    let problem = SectionFit {
        slices,
        binned,
        free_c2,
        bounds,
    };
    least_squares::minimize(&problem, p, &SOLVER).map_or((p, f32::NAN), |s| (s.params, s.cost))
}

/// Fits the shaded section to `binned`, starting from the box fit `start` of the same pixels,
/// its diameter within `bounds` where given.
/// The curvature term `c2` is kept only where it reduces the cost significantly: on a
/// uniformly dark body it would only trade with the diameter and add noise.
pub fn fit(
    binned: &Binned,
    start: &CrossSection,
    bounds: Option<DiameterBounds>,
) -> Option<LambertSection> {
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
    let (linear, linear_cost) = minimize(&slices, binned, p, false, bounds);
    let (curved, curved_cost) = minimize(&slices, binned, linear, true, bounds);
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
        let binned = Binned::sampled(12.0, 0.25, 4, |s| slices.model(s, &truth, true).0);
        let start = cross_profile::fit_binned(&binned, None).unwrap();
        assert!((start.diameter_px - 7.0).abs() > 0.5, "{start:?}");
        let section = fit(&binned, &start, None).unwrap();
        assert!(
            (section.diameter_px - 7.0).abs() < 0.02,
            "{section:?} from {start:?}"
        );
        assert!((section.offset_px - 0.3).abs() < 0.02, "{section:?}");
        assert!((section.sigma_px - 0.8).abs() < 0.02, "{section:?}");
        let mean = 20.0 + core::f32::consts::FRAC_PI_4 * 80.0;
        assert!((section.mean_contrast - mean).abs() < 0.5, "{section:?}");
    }

    /// The model against the Lambertian section blurred by numerical integration (20,000
    /// strips across the body): exact without the curvature term, within 3e-3 of `c2` with it;
    /// and its gradient against central differences of the model.
    #[test]
    fn the_model_is_the_blurred_lambertian_section() {
        let slices = Slices::new();
        let integrated = |s: f32, p: &Params, curved: bool| {
            let [b, c0, c1, c2, s0, r, sigma] = [0, 1, 2, 3, 4, 5, 6].map(|i| f64::from(p[i]));
            let c2 = if curved { c2 } else { 0.0 };
            let strips = 20_000;
            let dw = 2.0 / strips as f64;
            let mut sum = 0.0f64;
            for i in 0..strips {
                let w = -1.0 + (i as f64 + 0.5) * dw;
                let x = (f64::from(s) - s0 - r * w) / sigma;
                let density = libm::exp(-0.5 * x * x) / libm::sqrt(2.0 * core::f64::consts::PI);
                let contrast = c0 + c1 * w + c2 * libm::sqrt(1.0 - w * w);
                sum += contrast * density * dw * r / sigma;
            }
            b + sum
        };
        for (p, tolerance) in [
            (Params::from([1.5, 20.0, -12.0, 0.0, 0.3, 3.5, 0.8]), 1e-3),
            (
                Params::from([-2.0, 10.0, 25.0, 30.0, -0.4, 2.0, 0.5]),
                3e-3 * 30.0,
            ),
            (
                Params::from([0.0, -5.0, 4.0, 60.0, 0.0, 5.0, 1.0]),
                3e-3 * 60.0,
            ),
        ] {
            for curved in [false, true] {
                for s in [-6.0f32, -3.6, -2.0, 0.0, 0.7, 3.2, 3.9, 5.5] {
                    let (value, g) = slices.model(s, &p, curved);
                    let truth = integrated(s, &p, curved);
                    let error = (f64::from(value) - truth).abs();
                    assert!(error < tolerance, "{s}, {curved}: {value} against {truth}");
                    for k in 0..7 {
                        let h = 1e-2;
                        let (mut up, mut down) = (p, p);
                        up[k] += h;
                        down[k] -= h;
                        let numeric = (slices.model(s, &up, curved).0
                            - slices.model(s, &down, curved).0)
                            / (2.0 * h);
                        assert!(
                            (g[k] - numeric).abs() < 1e-2 * (1.0 + numeric.abs()),
                            "{s}, {curved}, parameter {k}: {} against {numeric}",
                            g[k]
                        );
                    }
                }
            }
        }
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
            let mut binned = Binned::sampled(6.0, 0.25, 1, |s| slices.model(s, &truth, true).0);
            binned.half_width = half_width;
            let _ = fit(&binned, &start, None);
        }
    }
}
