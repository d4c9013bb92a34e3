//! Profile matching: the measured width profile along the axis against the table's entries.
//!
//! The measured profile is the body's contrast summed across the axis per 1-px bin along it,
//! divided by the section's mean contrast: the silhouette's width in px, blurred only along the
//! axis (blur moves no contrast across it). An entry predicts it as `k (v_hi - v_lo)((t - t0) /
//! k)`, `k` the scale in px per body diameter and `t0` the body origin along the axis, blurred
//! along by the PSF. `k` is fixed (by the range, or by the shaded section's diameter); for each
//! candidate entry `t0` is fitted by Gauss-Newton ([`crate::math::least_squares`] with its
//! damping held at a floor) with the derivatives of the entry's piecewise-linear width, and the
//! entries are searched coarse to fine: tilts around the closed form's, then rolls, then the
//! neighbouring tilts for a parabolic refinement.

use crate::extremes::axial_profile::WidthProfile;
use crate::lut::table::{Entry, MAX_STATIONS, Table};
use crate::math::least_squares::{self, Normal};
use nalgebra::SVector;

/// Gauss-Hermite nodes (in sigma) and weights of the along-axis blur: the three-point rule
/// (exact for cubics; the five-point rule cost 40 % more and moved no result beyond the tests'
/// bounds).
const BLUR_NODES: [(f32, f32); 3] = [
    (0.0, 0.666_666_7),
    (1.732_050_8, 0.166_666_67),
    (-1.732_050_8, 0.166_666_67),
];
/// Gauss-Newton iterations per entry, at most.
const MAX_ITERATIONS: u32 = 4;
/// Damping, fixed (initial, smallest and largest): the fraction of the Gauss-Newton matrix's
/// diagonal added to it. Small, so the steps are Gauss-Newton's.
const DAMPING: f32 = 1e-7;
/// Damping factor after a rejected step: past [`DAMPING`], so the first step that does not lower
/// the cost ends the fit (no retry with a shorter step; the profile is piecewise linear).
const DAMPING_UP: f32 = 10.0;
/// Damping factor after an accepted step: none.
const DAMPING_DOWN: f32 = 1.0;
/// Smallest diagonal element of the Gauss-Newton matrix the damping scales by, px² per px².
const DIAGONAL_FLOOR: f32 = 1e-9;
/// Converged when a step lowers the cost by at most this fraction of it: only a step that does
/// not lower it at all.
const RELATIVE_TOLERANCE: f32 = 0.0;
/// The placement fit's settings: Gauss-Newton until a step does not lower the cost.
const SOLVER: least_squares::Config = least_squares::Config {
    max_iterations: MAX_ITERATIONS,
    initial_damping: DAMPING,
    damping_up: DAMPING_UP,
    damping_down: DAMPING_DOWN,
    min_damping: DAMPING,
    max_damping: DAMPING,
    diagonal_floor: DIAGONAL_FLOOR,
    relative_tolerance: RELATIVE_TOLERANCE,
    step_tolerance: 0.0,
};
/// Largest origin step, px: steps stay modest, the profile is piecewise linear.
const MAX_ORIGIN_STEP_PX: f32 = 3.0;
/// Tilts searched on either side of the closed form's, grid steps.
const TILT_REACH: usize = 6;
/// Residuals beyond this many px of width count linearly (Huber), so a plume or a cloud edge on
/// a few bins cannot drag the fit.
const HUBER_PX: f32 = 1.0;

/// What the measured profile is matched with.
pub struct Measured<'p> {
    /// The width profile, px, along the axis from tail to nose.
    pub profile: &'p WidthProfile,
    /// Bins used: `first..last`.
    pub bins: (usize, usize),
    /// Blur along the axis, px (PSF and the profile's binning).
    pub sigma_px: f32,
    /// The measured nose tip and tail base along the axis, px (the closed form's corrected
    /// ends): the extreme-point term of the loss, as in the source paper's.
    pub ends_t: (f32, f32),
    /// Weight of each end's squared distance, in width bins.
    pub end_weight: f32,
    /// Half the body's length over its diameter.
    pub half_length_d: f32,
    /// The rolls that look different, from 0 to this, deg ([`crate::model::ProjectileModel::distinct_roll_deg`]).
    pub max_roll_deg: f32,
}

/// The scale and position of an entry on the profile.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fit {
    /// Scale, px per body diameter.
    pub px_per_d: f32,
    /// Body origin along the axis, px.
    pub origin_t: f32,
    /// Robust cost: sum of Huber-weighted squared width residuals, px².
    pub cost: f32,
}

/// The best entry and its refinement.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Match {
    /// Tilt out of the image plane, deg, refined between grid points.
    pub tilt_deg: f32,
    /// Roll of the best entry, deg, folded to `[0, 45]`: the width profile does not tell `φ`
    /// from `-φ`.
    pub roll_deg: f32,
    /// How much better the best roll fits than the worst, as a fraction of the worst's cost
    /// (0: the fins are not resolved).
    pub roll_confidence: f32,
    /// Scale, px per body diameter.
    pub px_per_d: f32,
    /// Body origin along the axis, px.
    pub origin_t: f32,
    /// RMS width residual per bin, px.
    pub rms_px: f32,
}

/// An entry's width `v_hi - v_lo` at its stations, read once per fit for the many
/// interpolations of the fit.
struct Widths {
    at: [f32; MAX_STATIONS],
    /// Last station index.
    last: usize,
    /// The entry's extent along the axis, `D`.
    lo: f32,
    hi: f32,
    /// Stations per `D`.
    per_d: f32,
}

impl Widths {
    /// Room for an entry's widths, none loaded: one per search, loaded for each entry fitted
    /// (not made and returned for each: 1 KiB cleared and copied twice, 75,000 instructions a
    /// frame on the Cortex-M4F).
    fn new() -> Widths {
        Widths {
            at: [0.0; MAX_STATIONS],
            last: 0,
            lo: 0.0,
            hi: 0.0,
            per_d: 0.0,
        }
    }

    /// Reads `entry`'s widths. Stations beyond its count keep an earlier entry's: [`Widths::at`]
    /// reads none past `last`.
    fn load(&mut self, entry: &Entry) {
        let (lo, hi) = entry.u_range();
        let stations = entry.stations().min(MAX_STATIONS);
        for (s, w) in self.at.iter_mut().enumerate().take(stations) {
            let (v_lo, v_hi) = entry.edges(s);
            *w = v_hi - v_lo;
        }
        let usable = stations >= 2 && hi > lo;
        self.last = if usable { stations - 1 } else { 0 };
        self.lo = lo;
        self.hi = hi;
        self.per_d = if usable {
            (stations - 1) as f32 / (hi - lo)
        } else {
            0.0
        };
    }

    /// The width at `u` `D` along the axis and its slope, linear between stations; zero outside.
    #[inline]
    fn at(&self, u: f32) -> (f32, f32) {
        if self.last == 0 || !(u >= self.lo && u <= self.hi) {
            return (0.0, 0.0);
        }
        let position = (u - self.lo) * self.per_d;
        let i = (position as usize).min(self.last - 1);
        let (Some(&a), Some(&b)) = (self.at.get(i), self.at.get(i + 1)) else {
            return (0.0, 0.0);
        };
        let rise = b - a;
        (a + (position - i as f32) * rise, rise * self.per_d)
    }
}

/// An entry placed on the measured profile: scale `px_per_d` and origin `origin_t`, fitted
/// to the width residuals (Huber-weighted, the weights recomputed at every evaluation) and the
/// two extreme-point residuals.
struct Placement<'a, 'p> {
    measured: &'a Measured<'p>,
    widths: &'a Widths,
    cos_tilt: f32,
    /// The scale, px per `D`: positive.
    px_per_d: f32,
}

impl least_squares::Problem<1> for Placement<'_, '_> {
    /// Robust cost and normal equations at origin `p[0]` px, from one interpolation of the entry
    /// per blur node and bin (analytic derivatives).
    fn evaluate(&self, p: &SVector<f32, 1>) -> Option<Normal<1>> {
        let (k, t0) = (self.px_per_d, p[0]);
        let m = self.measured;
        let mut normal = Normal::zeros();
        for (r, dt) in m.end_residuals(self.cos_tilt, k, t0) {
            normal.add(&SVector::from([dt]), m.end_weight, r);
        }
        let inv_k = 1.0 / k;
        for i in m.bins.0..m.bins.1 {
            let (predicted, dt) = m.predicted(self.widths, k, inv_k, t0, m.profile.t_of(i));
            let r = m.profile.at(i) - predicted;
            let a = libm::fabsf(r);
            // Huber: the weight times r² is r² within HUBER_PX, HUBER_PX |r| beyond.
            let weight = if a <= HUBER_PX { 1.0 } else { HUBER_PX / a };
            normal.add(&SVector::from([dt]), weight, r);
        }
        Some(normal.complete())
    }

    /// The step from `from` limited to [`MAX_ORIGIN_STEP_PX`].
    fn constrain(&self, from: &SVector<f32, 1>, trial: &mut SVector<f32, 1>) {
        trial[0] = from[0] + (trial[0] - from[0]).clamp(-MAX_ORIGIN_STEP_PX, MAX_ORIGIN_STEP_PX);
    }
}

impl Measured<'_> {
    /// The predicted width at `t` px along the axis, px, and its derivative in `origin_t`, for
    /// an entry's `widths` at scale `k` px per `D` (`inv_k` its inverse) and origin `t0` px.
    fn predicted(&self, widths: &Widths, k: f32, inv_k: f32, t0: f32, t: f32) -> (f32, f32) {
        let (mut value, mut dt) = (0.0f32, 0.0f32);
        for (node, weight) in BLUR_NODES {
            let u = (t + node * self.sigma_px - t0) * inv_k;
            let (w, slope) = widths.at(u);
            value += weight * w;
            dt -= weight * slope;
        }
        (value * k, dt)
    }

    /// The extreme-point residuals (measured minus the entry's nose and tail) and their
    /// derivatives in `origin_t`, for an entry of tilt cosine `cos_tilt`.
    fn end_residuals(&self, cos_tilt: f32, k: f32, t0: f32) -> [(f32, f32); 2] {
        let h = self.half_length_d * cos_tilt;
        [
            (self.ends_t.0 - (t0 + k * h), 1.0),
            (self.ends_t.1 - (t0 - k * h), 1.0),
        ]
    }

    /// Fits the origin of `entry` (its widths read into `widths`) at `start`'s scale (the
    /// range's, or the shaded section's diameter: `pose::match_pose` never fits the scale),
    /// from `start`; its cost is NaN where the scale is not positive or the fit cannot be
    /// evaluated at `start`.
    fn fit(&self, widths: &mut Widths, entry: &Entry, cos_tilt: f32, start: Fit) -> Fit {
        let failed = Fit {
            cost: f32::NAN,
            ..start
        };
        if start.px_per_d.is_nan() || start.px_per_d <= 0.0 {
            return failed;
        }
        widths.load(entry);
        let problem = Placement {
            measured: self,
            widths,
            cos_tilt,
            px_per_d: start.px_per_d,
        };
        let p = SVector::from([start.origin_t]);
        match least_squares::minimize(&problem, p, &SOLVER) {
            Some(s) => Fit {
                px_per_d: start.px_per_d,
                origin_t: s.params[0],
                cost: s.cost,
            },
            None => failed,
        }
    }
}

/// The table's rolls up to `max_roll_deg`: the indices searched.
fn folded_rolls<'t>(table: &'t Table<'t>, max_roll_deg: f32) -> impl Iterator<Item = usize> + 't {
    (0..table.rolls()).filter(move |&j| table.roll_deg(j) <= max_roll_deg + 1e-3)
}

/// Searches `table` for the entry that best explains `measured`, starting from the closed form's
/// tilt `tilt_deg` and `start` (scale and origin; the scale stays).
pub fn search(table: &Table, measured: &Measured, tilt_deg: f32, start: Fit) -> Option<Match> {
    let step = table.tilt_step_deg();
    let centre = table.tilt_index(tilt_deg);
    let lo = centre.saturating_sub(TILT_REACH);
    let hi = (centre + TILT_REACH).min(table.tilts() - 1);
    let mid_roll = folded_rolls(table, measured.max_roll_deg)
        .last()
        .unwrap_or(0)
        / 2;
    let mut widths = Widths::new();
    let mut fit_at = |i: usize, j: usize, from: Fit| {
        let cos_tilt = libm::cosf(table.tilt_deg(i) * crate::pose::RAD);
        measured.fit(&mut widths, &table.entry(i, j), cos_tilt, from)
    };
    // 1. Tilts around the closed form's, at a middle roll: every other one, then the two
    //    beside the best of those.
    let mut best: Option<(usize, Fit)> = None;
    let mut consider = |best: &mut Option<(usize, Fit)>, i: usize| {
        let fit = fit_at(i, mid_roll, start);
        if best.is_none_or(|(_, b)| fit.cost < b.cost) {
            *best = Some((i, fit));
        }
    };
    for i in (lo..=hi).step_by(2) {
        consider(&mut best, i);
    }
    let (coarse, _) = best?;
    for i in [coarse.wrapping_sub(1), coarse + 1] {
        if (lo..=hi).contains(&i) {
            consider(&mut best, i);
        }
    }
    let (tilt, fit) = best?;
    // 2. Rolls at that tilt.
    let mut worst_cost = 0.0f32;
    let mut best_roll = (mid_roll, fit);
    for j in folded_rolls(table, measured.max_roll_deg) {
        let f = fit_at(tilt, j, fit);
        worst_cost = worst_cost.max(f.cost);
        if f.cost < best_roll.1.cost {
            best_roll = (j, f);
        }
    }
    let (roll, fit) = best_roll;
    // 3. The neighbouring tilts at that roll, and a parabola through the three costs.
    let mut at = |i: usize| fit_at(i, roll, fit);
    let (below, above) = (
        (tilt > 0).then(|| at(tilt - 1)),
        (tilt + 1 < table.tilts()).then(|| at(tilt + 1)),
    );
    let mut offset = 0.0f32;
    let mut refined = fit;
    match (below, above) {
        (Some(b), Some(a)) => {
            let curvature = a.cost + b.cost - 2.0 * fit.cost;
            if curvature > 0.0 {
                offset = (0.5 * (b.cost - a.cost) / curvature).clamp(-1.0, 1.0);
            }
            refined.px_per_d = interpolate(b.px_per_d, fit.px_per_d, a.px_per_d, offset);
            refined.origin_t = interpolate(b.origin_t, fit.origin_t, a.origin_t, offset);
        }
        (Some(b), None) if b.cost < fit.cost => offset = -0.5,
        (None, Some(a)) if a.cost < fit.cost => offset = 0.5,
        _ => {}
    }
    let bins = (measured.bins.1 - measured.bins.0).max(1) as f32;
    Some(Match {
        tilt_deg: ((tilt as f32 + offset) * step).clamp(0.0, 90.0),
        roll_deg: table.roll_deg(roll),
        roll_confidence: if worst_cost > 0.0 {
            1.0 - fit.cost / worst_cost
        } else {
            0.0
        },
        px_per_d: refined.px_per_d,
        origin_t: refined.origin_t,
        rms_px: libm::sqrtf(fit.cost / bins),
    })
}

/// The value at `offset` in [-1, 1] of the parabola through (-1, `below`), (0, `at`), (1, `above`).
fn interpolate(below: f32, at: f32, above: f32, offset: f32) -> f32 {
    at + 0.5 * offset * (above - below) + 0.5 * offset * offset * (above + below - 2.0 * at)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chip::ChipView;
    use crate::config::BodyPolarity;
    use crate::extremes::Axis;
    use crate::model::testing::reference;
    use crate::point::ImagePoint;
    use crate::segment::background::Background;

    /// The bundled table, built by `imade lut build --model ref-1378x80`.
    static BUNDLED: &[u8] = include_bytes!("../../../fixtures/lut/ref-1378x80.lut");

    const W: usize = 160;
    const H: usize = 48;
    /// The body's grey level over a zero background.
    const LEVEL: f32 = 200.0;

    /// A chip of `entry`'s silhouette along x through the chip's centre at `k` px per `D`, its
    /// origin `t0` px right of the centre: each pixel is the body's cover of its column's span
    /// across (anti-aliased), at its centre along.
    fn render(entry: &Entry, k: f32, t0: f32) -> [u8; W * H] {
        let mut chip = [0u8; W * H];
        let (cx, cy) = ((W / 2) as f32, (H / 2) as f32);
        let (lo, hi) = entry.u_range();
        for (i, pixel) in chip.iter_mut().enumerate() {
            let (x, y) = ((i % W) as f32, (i / W) as f32);
            let u = (x - cx - t0) / k;
            if !(lo..=hi).contains(&u) {
                continue;
            }
            let (v_lo, v_hi) = entry.edges_at(u);
            let (a, b) = (cy + k * v_lo, cy + k * v_hi);
            let cover = ((y + 0.5).min(b) - (y - 0.5).max(a)).clamp(0.0, 1.0);
            *pixel = libm::roundf(LEVEL * cover) as u8;
        }
        chip
    }

    /// Fits the broadside entry to its own rendering from an origin 2 px off; a scale that is
    /// not positive keeps the start, with a NaN cost.
    #[test]
    fn an_entry_is_placed_on_its_own_profile() {
        let table = Table::parse(BUNDLED).unwrap();
        let entry = table.entry(0, 0);
        let (k, t0) = (6.0, 1.3);
        let data = render(&entry, k, t0);
        let chip = ChipView::gray8(&data, W, H, W, 0, 0).unwrap();
        let axis = Axis {
            centre: ImagePoint::new((W / 2) as f32, (H / 2) as f32),
            dir: ImagePoint::new(1.0, 0.0),
        };
        let profile = WidthProfile::build(
            &chip,
            &Background::new(),
            &axis,
            BodyPolarity::Bright,
            LEVEL,
            70.0,
            20.0,
        );
        let half_length_d = 0.5 * reference().length_m / reference().diameter_m;
        let (nose, tail) = (t0 + k * half_length_d, t0 - k * half_length_d);
        let measured = Measured {
            profile: &profile,
            bins: (profile.bin_of(tail - 5.0), profile.bin_of(nose + 5.0) + 1),
            // The profile's linear split between bins: variance 1/6.
            sigma_px: libm::sqrtf(1.0 / 6.0),
            ends_t: (nose, tail),
            end_weight: 10.0,
            half_length_d,
            max_roll_deg: 45.0,
        };
        let start = |px_per_d: f32, origin_t: f32| Fit {
            px_per_d,
            origin_t,
            cost: 0.0,
        };
        let from = start(k, t0 + 2.0);
        let mut widths = Widths::new();
        let held = measured.fit(&mut widths, &entry, 1.0, from);
        assert_eq!(held.px_per_d, k, "{held:?}");
        assert!((held.origin_t - t0).abs() < 0.02, "{held:?}");
        // It lowers the cost it started from.
        let problem = Placement {
            measured: &measured,
            widths: &widths,
            cos_tilt: 1.0,
            px_per_d: k,
        };
        let p = SVector::from([from.origin_t]);
        let at_start = least_squares::Problem::evaluate(&problem, &p).unwrap();
        assert!(
            held.cost < 0.5 * at_start.cost,
            "{held:?} from {}",
            at_start.cost
        );
        for bad in [0.0, -k, f32::NAN] {
            let fit = measured.fit(&mut widths, &entry, 1.0, start(bad, t0));
            assert!(fit.cost.is_nan() && fit.origin_t == t0, "{fit:?}");
        }
    }
}
