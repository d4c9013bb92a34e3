//! Profile matching: the measured width profile along the axis against the table's entries.
//!
//! The measured profile is the body's contrast summed across the axis per 1-px bin along it,
//! divided by the section's mean contrast: the silhouette's width in px, blurred only along the
//! axis (blur moves no contrast across it). An entry predicts it as `k (v_hi - v_lo)((t - t0) /
//! k)`, `k` the scale in px per body diameter and `t0` the body origin along the axis, blurred
//! along by the PSF. `k` is fixed (by the range, or by the shaded section's diameter); for each
//! candidate entry `t0` is fitted by Gauss-Newton with the derivatives of the entry's
//! piecewise-linear width, and the entries are searched coarse to fine: tilts around the closed
//! form's, then rolls, then the neighbouring tilts for a parabolic refinement.

use crate::extremes::axial_profile::WidthProfile;
use crate::lut::table::{Entry, MAX_STATIONS, Table};

/// Gauss-Hermite nodes (in sigma) and weights of the along-axis blur: the three-point rule
/// (exact for cubics; the five-point rule cost 40 % more and moved no result beyond the tests'
/// bounds).
const BLUR_NODES: [(f32, f32); 3] = [
    (0.0, 0.666_666_7),
    (1.732_050_8, 0.166_666_67),
    (-1.732_050_8, 0.166_666_67),
];
/// Gauss-Newton iterations per entry.
const ITERATIONS: usize = 4;
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
    fn of(entry: &Entry) -> Widths {
        let (lo, hi) = entry.u_range();
        let stations = entry.stations().min(MAX_STATIONS);
        let mut at = [0.0f32; MAX_STATIONS];
        for (s, w) in at.iter_mut().enumerate().take(stations) {
            let (v_lo, v_hi) = entry.edges(s);
            *w = v_hi - v_lo;
        }
        let usable = stations >= 2 && hi > lo;
        Widths {
            at,
            last: if usable { stations - 1 } else { 0 },
            lo,
            hi,
            per_d: if usable {
                (stations - 1) as f32 / (hi - lo)
            } else {
                0.0
            },
        }
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

/// The cost of a placement, and its gradient and Gauss-Newton matrix in (px_per_d, origin_t).
type Evaluation = (f32, [f32; 2], [[f32; 2]; 2]);

impl Measured<'_> {
    /// The predicted width at `t` px along the axis, px, and its derivatives in `px_per_d` and
    /// `origin_t`, for an entry's `widths` at scale `k` px per `D` (`inv_k` its inverse) and
    /// origin `t0` px.
    fn predicted(&self, widths: &Widths, k: f32, inv_k: f32, t0: f32, t: f32) -> (f32, [f32; 2]) {
        let (mut value, mut dk, mut dt) = (0.0f32, 0.0f32, 0.0f32);
        for (node, weight) in BLUR_NODES {
            let u = (t + node * self.sigma_px - t0) * inv_k;
            let (w, slope) = widths.at(u);
            value += weight * w;
            dk += weight * (w - u * slope);
            dt -= weight * slope;
        }
        (value * k, [dk, dt])
    }

    /// The extreme-point residuals (measured minus the entry's nose and tail) and their
    /// derivatives in (px_per_d, origin_t), for an entry of tilt cosine `cos_tilt`.
    fn end_residuals(&self, cos_tilt: f32, k: f32, t0: f32) -> [(f32, [f32; 2]); 2] {
        let h = self.half_length_d * cos_tilt;
        [
            (self.ends_t.0 - (t0 + k * h), [h, 1.0]),
            (self.ends_t.1 - (t0 - k * h), [-h, 1.0]),
        ]
    }

    /// Robust cost, and its gradient and Gauss-Newton matrix in (px_per_d, origin_t), from one
    /// interpolation of the entry per blur node and bin (analytic derivatives).
    fn evaluate(&self, widths: &Widths, cos_tilt: f32, k: f32, t0: f32) -> Evaluation {
        let (mut cost, mut g, mut h) = (0.0f32, [0.0f32; 2], [[0.0f32; 2]; 2]);
        let mut add = |weight: f32, r: f32, j: [f32; 2]| {
            for a in 0..2 {
                g[a] += weight * j[a] * r;
                for b in 0..2 {
                    h[a][b] += weight * j[a] * j[b];
                }
            }
        };
        for (r, j) in self.end_residuals(cos_tilt, k, t0) {
            cost += self.end_weight * r * r;
            add(self.end_weight, r, j);
        }
        let inv_k = 1.0 / k;
        for i in self.bins.0..self.bins.1 {
            let (p, j) = self.predicted(widths, k, inv_k, t0, self.profile.t_of(i));
            let r = self.profile.at(i) - p;
            let a = libm::fabsf(r);
            // Huber: the weight times r² is r² within HUBER_PX, HUBER_PX |r| beyond.
            let weight = if a <= HUBER_PX { 1.0 } else { HUBER_PX / a };
            cost += weight * r * r;
            add(weight, r, j);
        }
        (cost, g, h)
    }

    /// Fits the origin of `entry` at `start`'s scale (the range's, or the shaded section's
    /// diameter: `pose::match_pose` never fits the scale), from `start`.
    pub fn fit(&self, entry: &Entry, cos_tilt: f32, start: Fit) -> Fit {
        let widths = Widths::of(entry);
        let mut at_best = self.evaluate(&widths, cos_tilt, start.px_per_d, start.origin_t);
        let mut best = Fit {
            cost: at_best.0,
            ..start
        };
        for _ in 0..ITERATIONS {
            let (_, g, h) = at_best;
            if h[1][1].is_nan() || h[1][1] <= 0.0 {
                break;
            }
            // Keep steps modest: the profile is piecewise linear.
            let st = (g[1] / h[1][1]).clamp(-3.0, 3.0);
            let trial = Fit {
                origin_t: best.origin_t + st,
                cost: 0.0,
                ..best
            };
            let at_trial = self.evaluate(&widths, cos_tilt, trial.px_per_d, trial.origin_t);
            let cost = at_trial.0;
            if !(cost.is_finite() && cost < best.cost && trial.px_per_d > 0.0) {
                break;
            }
            best = Fit { cost, ..trial };
            at_best = at_trial;
        }
        best
    }
}

/// Rolls of the table folded to `[0, 45]` deg: the indices searched.
fn folded_rolls<'t>(table: &'t Table<'t>) -> impl Iterator<Item = usize> + 't {
    (0..table.rolls()).filter(|&j| table.roll_deg(j) <= 45.0 + 1e-3)
}

/// Searches `table` for the entry that best explains `measured`, starting from the closed form's
/// tilt `tilt_deg` and `start` (scale and origin; the scale stays).
pub fn search(table: &Table, measured: &Measured, tilt_deg: f32, start: Fit) -> Option<Match> {
    let step = table.tilt_step_deg();
    let centre = table.tilt_index(tilt_deg);
    let lo = centre.saturating_sub(TILT_REACH);
    let hi = (centre + TILT_REACH).min(table.tilts() - 1);
    let mid_roll = folded_rolls(table).last().unwrap_or(0) / 2;
    let fit_at = |i: usize, j: usize, from: Fit| {
        let cos_tilt = libm::cosf(table.tilt_deg(i) * crate::pose::RAD);
        measured.fit(&table.entry(i, j), cos_tilt, from)
    };
    // 1. Tilts around the closed form's, at a middle roll: every other one, then the two
    //    beside the best of those.
    let mut best: Option<(usize, Fit)> = None;
    let consider = |best: &mut Option<(usize, Fit)>, i: usize| {
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
    for j in folded_rolls(table) {
        let f = fit_at(tilt, j, fit);
        worst_cost = worst_cost.max(f.cost);
        if f.cost < best_roll.1.cost {
            best_roll = (j, f);
        }
    }
    let (roll, fit) = best_roll;
    // 3. The neighbouring tilts at that roll, and a parabola through the three costs.
    let at = |i: usize| fit_at(i, roll, fit);
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
