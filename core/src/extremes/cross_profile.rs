//! The body's cross-section profile: diameter, contrast and blur, measured subpixel.
//!
//! Pixels of a stretch of the cylindrical body are binned by their signed distance across the
//! axis into a finely sampled 1D profile (many pixels at different subpixel offsets give a
//! super-resolved edge). A blurred box with a linear shading term is fitted to it by
//! Levenberg-Marquardt:
//!
//! `f(s) = b + (C0 + C1 (s - s0)) [Phi((s - s0 + d/2) / sigma) - Phi((s - s0 - d/2) / sigma)]`
//!
//! giving the diameter `d` in px (blur-free: the box edges sit where the blurred profile crosses
//! half the contrast), the contrast `C0` at the axis, the blur `sigma` and the axis offset `s0`.

use super::{passing_span, row_span};
use crate::chip::ChipView;
use crate::config::BodyPolarity;
use crate::math::least_squares::{self, Normal};
use crate::math::normal;
use crate::point::ImagePoint;
use crate::segment::background::{Background, SkySpans};
use crate::segment::select::Shape;
use nalgebra::SVector;

/// Bins of the cross-section profile.
pub const CROSS_BINS: usize = 256;
/// Bin width of the profile fitted by [`fit`], px: fine enough for a super-resolved edge, coarse
/// enough to keep the fit's model evaluations few.
const BIN_PX: f32 = 0.25;

/// One stretch of the body along the axis, `t0..t1` px from the shape centre.
#[derive(Debug, Clone, Copy)]
pub struct Stretch {
    /// Start along the axis, px.
    pub t0: f32,
    /// End along the axis, px.
    pub t1: f32,
}

/// A fitted cross-section.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CrossSection {
    /// Diameter across the axis, px.
    pub diameter_px: f32,
    /// Body contrast at the axis (sign-corrected: positive), grey levels.
    pub contrast: f32,
    /// Shading slope across the axis, grey levels per px.
    pub shading: f32,
    /// Gaussian blur standard deviation (PSF and pixel), px.
    pub sigma_px: f32,
    /// Offset of the body's axis from the shape's axis, px across.
    pub offset_px: f32,
    /// Pixels that went into the fit.
    pub pixels: u32,
}

type Params = SVector<f32, 6>;

/// A cross-section profile binned across the axis: `sum[i] / count[i]` is the mean contrast (of
/// the body's polarity, background removed) of the pixels at `s = -half_width + (i + 0.5) *
/// bin_width` px across the axis.
pub struct Binned {
    sum: [f32; CROSS_BINS],
    count: [u16; CROSS_BINS],
    /// Half the profile's extent across the axis, px.
    pub half_width: f32,
    /// Bin width, px.
    pub bin_width: f32,
    /// Pixels binned.
    pub pixels: u32,
}

impl Binned {
    /// An empty profile `half_width` px either side of the axis in bins of `bin_width` px.
    fn empty(half_width: f32, bin_width: f32) -> Binned {
        Binned {
            sum: [0.0; CROSS_BINS],
            count: [0; CROSS_BINS],
            half_width,
            bin_width,
            pixels: 0,
        }
    }

    /// The profile's points: bin centre (px across), mean contrast, weight (pixel count).
    pub fn point(&self, i: usize) -> Option<(f32, f32, f32)> {
        let c = *self.count.get(i)?;
        if c == 0 {
            return None;
        }
        let s = -self.half_width + (i as f32 + 0.5) * self.bin_width;
        Some((s, *self.sum.get(i)? / f32::from(c), f32::from(c)))
    }

    /// All non-empty points.
    pub fn points(&self) -> impl Iterator<Item = (f32, f32, f32)> + '_ {
        (0..CROSS_BINS).filter_map(|i| self.point(i))
    }
}

/// Bins the pixels of `stretch` by their distance across `shape`'s axis, within `half_width` px
/// of it, for a body of contrast polarity `polarity`; `bin_width` px (at least `2 half_width /
/// CROSS_BINS`).
pub fn bin(
    chip: &ChipView,
    background: &Background,
    shape: &Shape,
    polarity: BodyPolarity,
    stretch: Stretch,
    half_width: f32,
    bin_width: f32,
) -> Binned {
    let half_width = half_width.max(3.0);
    let bin_width = bin_width.max(2.0 * half_width / CROSS_BINS as f32);
    let mut binned = Binned::empty(half_width, bin_width);
    let sign = polarity.sign();
    // The pixels around the stretch: its bounding box in chip coordinates.
    let reach = libm::fabsf(stretch.t0).max(libm::fabsf(stretch.t1)) + half_width + 1.0;
    let ImagePoint { x: cx, y: cy } = shape.centre;
    let x_lo = (cx - reach).max(0.0) as usize;
    let x_hi = ((cx + reach).max(0.0) as usize + 1).min(chip.width());
    let y_lo = (cy - reach).max(0.0) as usize;
    let y_hi = ((cy + reach).max(0.0) as usize + 1).min(chip.height());
    let mut spans = SkySpans::new();
    let line = shape.line();
    // The pixel's place across, and whether it lies in the stretch within `half_width` of it.
    let across_at = |x: usize, y: usize| {
        let (along, across) = line.local(x as f32, y as f32);
        let inside =
            !(along < stretch.t0 || along >= stretch.t1 || libm::fabsf(across) >= half_width);
        (across, inside)
    };
    for y in y_lo..y_hi {
        let (x0, x1) = passing_span(
            row_span(
                shape.centre,
                shape.axis,
                y,
                (stretch.t0, stretch.t1),
                half_width,
                (x_lo, x_hi),
            ),
            |x| across_at(x, y).1,
        );
        spans.for_each_in_span(&background.row(y), chip, x0, x1, |x, v, sky| {
            let (across, _) = across_at(x, y);
            let i = ((across + half_width) / bin_width) as usize;
            if let (Some(s), Some(c)) = (binned.sum.get_mut(i), binned.count.get_mut(i)) {
                *s += sign * (f32::from(v) - sky);
                *c = c.saturating_add(1);
                binned.pixels += 1;
            }
        });
    }
    binned
}

/// Where the body's diameter is known beforehand (from the range), the diameters a fit may take,
/// px: a faint body among clutter otherwise fits a wide, shallow box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiameterBounds {
    /// Smallest, px.
    pub min_px: f32,
    /// Largest, px.
    pub max_px: f32,
}

impl DiameterBounds {
    /// The diameters within `factor` times `diameter_px` either way.
    pub fn around(diameter_px: f32, factor: f32) -> DiameterBounds {
        DiameterBounds {
            min_px: diameter_px / factor,
            max_px: diameter_px * factor,
        }
    }
}

/// The most stretches [`ClutterWidth`] fits.
pub const MAX_CLUTTER_STRETCHES: usize = 8;

/// The body's diameter read where the sky beside it is cluttered and its size is not expected
/// (no range): clouds, filaments and haze beside a faint body only ever widen a cross-section
/// (without its range, a fit over half the body read 12-110 px for a 7.0-7.6-px body in 14 of
/// the 20 frames of `fixtures/small-clutter-plume`), while short stretches along it read the body's
/// own width wherever the sky beside them is clear. So the body is cut into `stretches`, each
/// fitted on its own, and the diameter is their lower quantile `quantile`, leaving out those
/// below `min_fraction_of_median` of the median (noise, a faded end).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ClutterWidth {
    /// Stretches along the body (at most [`MAX_CLUTTER_STRETCHES`]).
    pub stretches: usize,
    /// The quantile of their diameters taken, 0..1.
    pub quantile: f32,
    /// A diameter below this fraction of the stretches' median is left out.
    pub min_fraction_of_median: f32,
}

impl ClutterWidth {
    /// The defaults.
    pub const DEFAULT: ClutterWidth = ClutterWidth {
        stretches: 8,
        quantile: 0.25,
        min_fraction_of_median: 0.3,
    };

    /// The diameter of the body along `shape` from `-half_length..half_length` px, px: None
    /// where fewer than three stretches fit.
    #[allow(clippy::too_many_arguments)]
    pub fn diameter_px(
        &self,
        chip: &ChipView,
        background: &Background,
        shape: &Shape,
        polarity: BodyPolarity,
        half_length: f32,
        half_width: f32,
    ) -> Option<f32> {
        let count = self.stretches.clamp(1, MAX_CLUTTER_STRETCHES);
        let step = 2.0 * half_length / count as f32;
        let mut diameters = heapless::Vec::<f32, MAX_CLUTTER_STRETCHES>::new();
        for k in 0..count {
            let t0 = -half_length + k as f32 * step;
            let stretch = Stretch { t0, t1: t0 + step };
            if let Some(section) = fit(chip, background, shape, polarity, stretch, half_width, None)
            {
                // Room for every stretch: `count` is at most the capacity.
                let _ = diameters.push(section.diameter_px);
            }
        }
        diameters.sort_unstable_by(f32::total_cmp);
        let median = *diameters.get(diameters.len() / 2)?;
        let floor = self.min_fraction_of_median * median;
        let first = diameters.iter().position(|&d| d >= floor)?;
        let kept = diameters.get(first..)?;
        if kept.len() < 3 {
            return None;
        }
        let index = (self.quantile.clamp(0.0, 1.0) * (kept.len() - 1) as f32) as usize;
        kept.get(index).copied()
    }
}

/// Fits the cross-section of `stretch`, where the shape's axis is `shape` and the body's pixels
/// have contrast polarity `polarity`, with a diameter within `bounds` where given. `half_width`
/// bounds the profile across the axis, px.
pub fn fit(
    chip: &ChipView,
    background: &Background,
    shape: &Shape,
    polarity: BodyPolarity,
    stretch: Stretch,
    half_width: f32,
    bounds: Option<DiameterBounds>,
) -> Option<CrossSection> {
    fit_binned(
        &bin(
            chip, background, shape, polarity, stretch, half_width, BIN_PX,
        ),
        bounds,
    )
}

/// The box fit's Levenberg-Marquardt settings: the core's damping schedule, at most 30
/// iterations, converged when a step lowers the cost by at most 1e-7 of it or moves the
/// parameters by at most 1e-6 of their size. Their size is mostly the contrast's, so a body of
/// 100 grey levels stops once a step moves its diameter by less than 1e-4 px. On a clear sky the
/// cost's test alone reached the minimum in 5-6 iterations and then spent as many again on trials
/// rejected or lowering the cost by rounding (small-known-range: 11.2 iterations a fit, 5.9 with
/// the step's test; `docs/firmware.md`, item 21).
const SOLVER: least_squares::Config = least_squares::Config {
    max_iterations: 30,
    relative_tolerance: 1e-7,
    step_tolerance: 1e-6,
    ..least_squares::Config::DEFAULT
};

/// Diameter and blur below this are clamped, px.
const MIN_WIDTH_PX: f32 = 0.2;

/// Fits the blurred box to a binned cross-section, with a diameter within `bounds` where given.
pub fn fit_binned(binned: &Binned, bounds: Option<DiameterBounds>) -> Option<CrossSection> {
    let pixels = binned.pixels;
    if pixels < 8 {
        return None;
    }
    let fit = BoxFit { binned, bounds };
    let mut start = initial_guess(&|i| binned.point(i), binned.half_width)?;
    fit.constrain_diameter(&mut start);
    // A start whose cost is not finite is kept as it is.
    let p = least_squares::minimize(&fit, start, &SOLVER).map_or(start, |s| s.params);
    let section = CrossSection {
        diameter_px: p[4],
        contrast: p[1],
        shading: p[2],
        sigma_px: p[5],
        offset_px: p[3],
        pixels,
    };
    (section.contrast > 0.0 && section.diameter_px.is_finite() && section.offset_px.is_finite())
        .then_some(section)
}

/// Background offset, peak, zero slope, centroid, integral over peak, and a unit blur.
fn initial_guess(
    point: &impl Fn(usize) -> Option<(f32, f32, f32)>,
    half_width: f32,
) -> Option<Params> {
    let (mut area, mut first, mut peak, mut edge_sum, mut edge_n) =
        (0.0f32, 0.0f32, 0.0f32, 0.0f32, 0.0f32);
    for i in 0..CROSS_BINS {
        let Some((s, v, _)) = point(i) else { continue };
        if libm::fabsf(s) > 0.75 * half_width {
            edge_sum += v;
            edge_n += 1.0;
        }
        peak = peak.max(v);
    }
    let b = if edge_n > 0.0 { edge_sum / edge_n } else { 0.0 };
    let mut last_s: Option<f32> = None;
    for i in 0..CROSS_BINS {
        let Some((s, v, _)) = point(i) else { continue };
        let ds = last_s.map_or(0.0, |l| s - l);
        last_s = Some(s);
        let v = (v - b).max(0.0);
        area += v * ds;
        first += v * s * ds;
    }
    let peak = peak - b;
    if !(peak > 0.0 && area > 0.0) {
        return None;
    }
    let centre = first / area;
    // At most twice the half width, or 0.5 px where that is smaller (the clamp cannot panic).
    let diameter = (area / peak).clamp(0.5, (2.0 * half_width).max(0.5));
    Some(Params::from([b, peak, 0.0, centre, diameter, 0.8]))
}

/// Model value and its gradient with respect to the parameters at `s`.
fn model(s: f32, p: &Params) -> (f32, Params) {
    let (b, c0, c1, s0, d, sigma) = (p[0], p[1], p[2], p[3], p[4], p[5]);
    let x = s - s0;
    let u1 = (x + 0.5 * d) / sigma;
    let u2 = (x - 0.5 * d) / sigma;
    let ((cdf1, g1), (cdf2, g2)) = (normal::cdf_pdf(u1), normal::cdf_pdf(u2));
    let box_ = cdf1 - cdf2;
    let amplitude = c0 + c1 * x;
    let value = b + amplitude * box_;
    let gradient = Params::from([
        1.0,
        box_,
        x * box_,
        -c1 * box_ + amplitude * (g2 - g1) / sigma,
        amplitude * 0.5 * (g1 + g2) / sigma,
        amplitude * (g2 * u2 - g1 * u1) / sigma,
    ]);
    (value, gradient)
}

/// The blurred box fitted to a binned profile, its diameter within `bounds` where given.
struct BoxFit<'b> {
    binned: &'b Binned,
    bounds: Option<DiameterBounds>,
}

impl BoxFit<'_> {
    /// Diameter at least [`MIN_WIDTH_PX`] and within the bounds (where they are a range).
    fn constrain_diameter(&self, p: &mut Params) {
        if let Some(b) = self.bounds
            && b.min_px <= b.max_px
        {
            p[4] = p[4].clamp(b.min_px, b.max_px);
        }
        p[4] = p[4].max(MIN_WIDTH_PX);
    }
}

impl least_squares::Problem<6> for BoxFit<'_> {
    /// The weighted squared residual and the normal equations (`JᵀWJ`, `JᵀWr`) at `p`, from one
    /// evaluation of the model per point (its erf and exp dominate the fit's time).
    fn evaluate(&self, p: &Params) -> Option<Normal<6>> {
        let mut normal = Normal::zeros();
        for (s, v, w) in self.binned.points() {
            let (value, g) = model(s, p);
            normal.add(&g, w, v - value);
        }
        Some(normal.complete())
    }

    /// Diameter at least [`MIN_WIDTH_PX`] and within the bounds, blur between it and the
    /// profile's half width (at least [`MIN_WIDTH_PX`], so the clamp cannot panic).
    fn constrain(&self, _: &Params, trial: &mut Params) {
        self.constrain_diameter(trial);
        trial[5] = trial[5].clamp(MIN_WIDTH_PX, self.binned.half_width.max(MIN_WIDTH_PX));
    }
}

#[cfg(test)]
impl Binned {
    /// A profile of `f(s)` at every bin centre, each of `weight` pixels.
    pub(crate) fn sampled(
        half_width: f32,
        bin_width: f32,
        weight: u16,
        f: impl Fn(f32) -> f32,
    ) -> Binned {
        let mut binned = Binned::empty(half_width, bin_width);
        let bins = ((2.0 * half_width / bin_width) as usize).min(CROSS_BINS);
        for i in 0..bins {
            let s = -half_width + (i as f32 + 0.5) * bin_width;
            binned.sum[i] = f(s) * f32::from(weight);
            binned.count[i] = weight;
            binned.pixels += u32::from(weight);
        }
        binned
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The blurred box's own profile, sampled exactly, is fitted back.
    #[test]
    fn an_exact_blurred_box_is_recovered() {
        let truth = Params::from([3.0, 100.0, 2.0, 0.4, 6.0, 0.9]);
        let binned = Binned::sampled(12.0, BIN_PX, 4, |s| model(s, &truth).0);
        let section = fit_binned(&binned, None).unwrap();
        assert!((section.diameter_px - 6.0).abs() < 1e-3, "{section:?}");
        assert!((section.contrast - 100.0).abs() < 1e-2, "{section:?}");
        assert!((section.shading - 2.0).abs() < 1e-3, "{section:?}");
        assert!((section.sigma_px - 0.9).abs() < 1e-3, "{section:?}");
        assert!((section.offset_px - 0.4).abs() < 1e-3, "{section:?}");
        assert_eq!(section.pixels, 4 * 96);
    }

    /// A 7-px bar 176 px long with a 12-px cloud against its back half: the fit over that half
    /// reads the cloud into the diameter, the stretches' lower quartile reads the bar.
    #[test]
    fn short_stretches_read_a_body_beside_a_cloud() {
        const W: usize = 256;
        const H: usize = 96;
        let mut data = [0u8; W * H];
        for y in 0..H {
            for x in 0..W {
                let bar = (40..216).contains(&x) && (45..52).contains(&y);
                let cloud = (40..128).contains(&x) && (52..64).contains(&y);
                data[y * W + x] = if bar {
                    60
                } else if cloud {
                    50
                } else {
                    0
                };
            }
        }
        let chip = ChipView::gray8(&data, W, H, W, 0, 0).unwrap();
        let background = Background::new();
        let shape = Shape {
            centre: ImagePoint::new(128.0, 48.5),
            axis: ImagePoint::new(1.0, 0.0),
            major_sd: 176.0 / libm::sqrtf(12.0),
            minor_sd: 2.0,
        };
        let (half_length, half_width) = (1.732 * shape.major_sd, 12.0);
        let polarity = BodyPolarity::Bright;
        let stretch = Stretch {
            t0: -0.5 * half_length,
            t1: 0.0,
        };
        let half = fit(
            &chip,
            &background,
            &shape,
            polarity,
            stretch,
            half_width,
            None,
        )
        .unwrap();
        assert!(half.diameter_px > 9.0, "{half:?}");
        let d = ClutterWidth::DEFAULT
            .diameter_px(
                &chip,
                &background,
                &shape,
                polarity,
                half_length,
                half_width,
            )
            .unwrap();
        assert!((d - 7.0).abs() < 0.3, "{d}");
    }

    /// A profile whose half width is below the smallest blur, or not a number, is fitted
    /// without a panic (the clamps of the start's diameter and of the blur).
    #[test]
    fn a_degenerate_half_width_does_not_panic() {
        let truth = Params::from([0.0, 50.0, 0.0, 0.0, 3.0, 0.8]);
        for half_width in [0.1, f32::NAN] {
            let mut binned = Binned::sampled(6.0, BIN_PX, 1, |s| model(s, &truth).0);
            binned.half_width = half_width;
            let _ = fit_binned(&binned, None);
        }
    }
}
