//! Which end is the nose: an exhaust plume at one end, else the measured width profile against
//! the model's, both ways round.
//!
//! A plume of the opposite polarity (bright exhaust behind a dark body) shows beyond the tail in
//! the width profile's opposite-polarity sum; where one end has a clear one and the other not,
//! that end is the tail ([`plume_at_high`]).
//!
//! Between the two ends' half-diameter crossings, the profile is sampled at [`SAMPLES`] points
//! and compared with the model's silhouette width at the same fractions of its own length
//! between its half-diameter points, once with the nose at the high end and once at the low end.
//! The model says what each end looks like (a long ogive, a boat tail, fins), so nothing here
//! assumes a shape. Where the model has fins, its body width is only a lower bound (the fins'
//! width depends on roll), so only a profile narrower than the body counts there.

use super::axial_profile::WidthProfile;
use crate::model::ProjectileModel;

/// Points at which [`nose_by_model`] samples the body's contrast along the profile.
const CONTRAST_SAMPLES: usize = 64;

/// Points at which the two profiles are compared.
pub const SAMPLES: usize = 32;

/// The model's width profile between its half-diameter points, normalized for the comparison.
struct ModelWidths {
    /// Width at sample k from the nose's half-diameter point, in body diameters.
    width: [f32; SAMPLES],
    /// Whether sample k lies where the model has fins (its width there is a lower bound).
    finned: [bool; SAMPLES],
    /// The tip's distance ahead of the nose's half-diameter point, in lengths between the two
    /// half-diameter points.
    tip_ahead: f32,
}

impl ModelWidths {
    fn of(model: &ProjectileModel) -> ModelWidths {
        let diameter = model.diameter_m;
        let half = 0.25 * diameter;
        // The half-diameter points: where the radius first and last reaches R/2 (stations).
        let (mut nose50, mut tail50) = (0.0f32, model.length_m);
        let mut seen = false;
        for i in 0..model.stations() {
            let (s, r) = model.station(i);
            if r >= half {
                if !seen {
                    nose50 = s;
                    seen = true;
                }
                tail50 = s;
            }
        }
        if model.base_radius_m() >= half {
            tail50 = model.length_m;
        }
        let fins_from = model.fins().map_or(f32::INFINITY, |f| f.root_s.0);
        let mut width = [0.0f32; SAMPLES];
        let mut finned = [false; SAMPLES];
        for (k, (w, f)) in width.iter_mut().zip(finned.iter_mut()).enumerate() {
            let s = nose50 + (tail50 - nose50) * fraction(k);
            *w = 2.0 * model.radius_at(s) / diameter;
            *f = s >= fins_from;
        }
        let tip_ahead = nose50 / (tail50 - nose50).max(f32::EPSILON);
        ModelWidths {
            width,
            finned,
            tip_ahead,
        }
    }

    /// Squared difference, in diameters squared, of a measured width `measured` (diameters) at
    /// fraction `u` of the length from the nose's half-diameter point, and the model's there
    /// seen at `contrast` of the profile's contrast.
    fn miss_at(&self, u: f32, measured: f32, contrast: f32) -> f32 {
        let k = ((u * SAMPLES as f32) as usize).min(SAMPLES - 1);
        squared_miss(
            measured,
            contrast * self.width.get(k).copied().unwrap_or(1.0),
            self.finned.get(k).copied().unwrap_or(false),
        )
    }

    /// Mean squared difference, in diameters squared, of the measured widths (from the nose
    /// end) and the model's.
    fn misfit(&self, measured: impl Iterator<Item = f32>) -> f32 {
        let mut sum = 0.0f32;
        for ((m, &e), &finned) in measured.zip(&self.width).zip(&self.finned) {
            sum += squared_miss(m, e, finned);
        }
        sum / SAMPLES as f32
    }
}

/// The squared difference of a measured width and the model's `expected` one; where the model
/// has fins (`finned`) its width is a lower bound, and only a narrower measure counts.
fn squared_miss(measured: f32, expected: f32, finned: bool) -> f32 {
    let miss = if finned {
        (measured - expected).min(0.0)
    } else {
        measured - expected
    };
    miss * miss
}

/// The fraction of the length at which sample `k` lies.
fn fraction(k: usize) -> f32 {
    (k as f32 + 0.5) / SAMPLES as f32
}

/// How much better the profile fits the model with the nose at `hi50` than at `lo50`: the
/// misfit with the nose low minus the misfit with the nose high, in diameters squared (> 0: the
/// nose is at the high end). `lo50` and `hi50` are the ends' half-diameter crossings, px along
/// the axis; `diameter_px` the body's diameter.
pub fn nose_high_evidence(
    profile: &WidthProfile,
    lo50: f32,
    hi50: f32,
    diameter_px: f32,
    model: &ProjectileModel,
) -> f32 {
    let expected = ModelWidths::of(model);
    let scale = 1.0 / diameter_px.max(1e-6);
    // The mean measured width over sample k's stretch, counted from the end at `from`.
    let stretch = (hi50 - lo50) / SAMPLES as f32;
    let width_from = |from: f32, step: f32| {
        move |k: usize| {
            let t0 = from + step * k as f32;
            profile.mean_between(t0, t0 + step) * scale
        }
    };
    let from_high = (0..SAMPLES).map(width_from(hi50, -stretch));
    let from_low = (0..SAMPLES).map(width_from(lo50, stretch));
    expected.misfit(from_low) - expected.misfit(from_high)
}

/// Where a plume marks the tail: `Some(true)` when the high end has one of at least
/// `min_area_d2` body diameters squared (at the body's contrast, of the opposite polarity, from
/// half the length beyond the end to a tenth inside it) and at least `dominance` times the
/// other end's, `Some(false)` for the low end, `None` when neither does.
pub fn plume_at_high(
    profile: &WidthProfile,
    lo50: f32,
    hi50: f32,
    diameter_px: f32,
    min_area_d2: f32,
    dominance: f32,
) -> Option<bool> {
    let length = hi50 - lo50;
    let unit = diameter_px * diameter_px;
    let low = profile.opposite_area_between(lo50 - 0.5 * length, lo50 + 0.1 * length) / unit;
    let high = profile.opposite_area_between(hi50 + 0.5 * length, hi50 - 0.1 * length) / unit;
    if high >= min_area_d2 && high >= dominance * low {
        Some(true)
    } else if low >= min_area_d2 && low >= dominance * high {
        Some(false)
    } else {
        None
    }
}

/// Where the nose's half-diameter point lies for a body whose tail's lies at `tail50` px along
/// the axis and whose nose lies towards `toward` (+1 or -1): the point between `shortest_px`
/// and `longest_px` from the tail at which the width profile best matches the model's silhouette
/// of that length (`diameter_px` wide, its width at `t` px along the axis seen at
/// `contrast_at(t)` of the contrast the profile was measured at: where the sky behind the body
/// is as bright as the body, nothing of it shows) with nothing of the body beyond its tip, up
/// to `longest_px` plus `beyond_px` from the tail. A measured width counts at most 1.5 diameters
/// (a filament or a cloud crossing the body), and a filament going on beyond the nose, narrower
/// than the body, costs less than the body's own width missing. Returns the nose's
/// half-diameter point and its tip, px along the axis; None where no length fits.
#[allow(clippy::too_many_arguments)]
pub fn nose_by_model(
    profile: &WidthProfile,
    tail50: f32,
    toward: f32,
    diameter_px: f32,
    shortest_px: f32,
    longest_px: f32,
    beyond_px: f32,
    model: &ProjectileModel,
    contrast_at: impl Fn(f32) -> f32,
) -> Option<(f32, f32)> {
    let expected = ModelWidths::of(model);
    let scale = 1.0 / diameter_px.max(1e-6);
    let first = profile.bin_of(tail50);
    let last = profile.bin_of(tail50 + toward * (longest_px + beyond_px));
    let (lo, hi) = (first.min(last), first.max(last));
    let measured = |i: usize| (profile.at(i) * scale).clamp(-0.5, 1.5);
    // The contrast changes with the sky model, smoothly: sampled at CONTRAST_SAMPLES points
    // over the bins and read at the nearest.
    let mut contrast = [1.0f32; CONTRAST_SAMPLES];
    let per_sample = (hi - lo + 1).div_ceil(CONTRAST_SAMPLES).max(1);
    for (k, c) in contrast.iter_mut().enumerate() {
        let i = lo + k * per_sample + per_sample / 2;
        *c = contrast_at(profile.t_of(i.min(hi)));
    }
    let contrast_of = |i: usize| contrast.get((i - lo) / per_sample).copied().unwrap_or(1.0);
    let tip_of = |length: f32| length * (1.0 + expected.tip_ahead);
    let mut best: Option<(f32, f32)> = None;
    let mut length = shortest_px.max(1.0);
    while length <= longest_px {
        let tip = tip_of(length);
        let cost: f32 = (lo..=hi)
            .map(|i| {
                let along = (profile.t_of(i) - tail50) * toward;
                let m = measured(i);
                if (0.0..length).contains(&along) {
                    expected.miss_at(1.0 - along / length, m, contrast_of(i))
                } else if along >= tip + 1.0 {
                    let beyond = m.max(0.0);
                    beyond * beyond
                } else {
                    0.0
                }
            })
            .sum();
        if best.is_none_or(|(c, _)| cost < c) {
            best = Some((cost, length));
        }
        length += 1.0;
    }
    best.map(|(_, length)| (tail50 + toward * length, tail50 + toward * tip_of(length)))
}

/// What [`plume_beyond_fade`] needs of the plume and of the stretch it bridges.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FadeBridge {
    /// The plume begins where the opposite polarity's width reaches this many body diameters
    /// ...
    pub onset_diameters: f32,
    /// ... and it covers at least this many body diameters squared.
    pub min_plume_area: f32,
    /// The faded stretch between the found end and the plume has a mean width of at least this
    /// many body diameters (of the body's polarity: the body goes on, faint).
    pub min_fill_diameters: f32,
    /// Where a plume already marks the tail, a faded stretch before it is looked for only on a
    /// body at most this many noise sigmas from the sky (a fade needs the sky behind to change
    /// by the body's whole contrast; a bright body's plume can begin a little beyond its base).
    pub max_contrast_sigmas: f32,
}

/// Where a faint body fades before its tail (the sky behind the tail as dark as the body) and
/// its plume lies beyond the faded stretch: the found ends `lo50..hi50` (px along the axis) are
/// those of the body's front, the tail lies at the plume. Looks beyond each end for a plume
/// (see [`FadeBridge`]) no farther than a body `longest_px` long reaches, and returns which end
/// it lies beyond (`true`: the high one) and where it begins; None where neither end has one,
/// or both.
pub fn plume_beyond_fade(
    profile: &WidthProfile,
    lo50: f32,
    hi50: f32,
    diameter_px: f32,
    longest_px: f32,
    bridge: &FadeBridge,
) -> Option<(bool, f32)> {
    let reach = longest_px - (hi50 - lo50);
    if reach.is_nan() || reach <= 0.0 {
        return None;
    }
    let unit = diameter_px * diameter_px;
    let beyond = |end: f32, outward: isize| {
        let way = outward as f32;
        let onset =
            profile.opposite_onset(end, outward, reach, bridge.onset_diameters * diameter_px)?;
        let gap = way * (onset - end);
        let area = profile.opposite_area_between(onset, onset + way * 0.5 * (hi50 - lo50 + gap));
        let fill = profile.signed_mean_between(end, onset - way * 1.0);
        (area >= bridge.min_plume_area * unit && fill >= bridge.min_fill_diameters * diameter_px)
            .then_some(onset)
    };
    match (beyond(hi50, 1), beyond(lo50, -1)) {
        (Some(onset), None) => Some((true, onset)),
        (None, Some(onset)) => Some((false, onset)),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::extremes::axial_profile::testing::{Band, profile_of};
    use crate::model::testing::reference;

    #[test]
    fn the_reference_model_widths_taper_at_the_nose_and_carry_fins_at_the_tail() {
        let widths = ModelWidths::of(&reference());
        // The ogive (0.24 m of 1.378 m) is narrower than the body near the nose's end ...
        assert!(widths.width[0] < 0.9, "{}", widths.width[0]);
        assert!(!widths.finned[0]);
        // ... the body is full in the middle, and the last 0.12 m carry fins.
        assert!((widths.width[SAMPLES / 2] - 1.0).abs() < 1e-4);
        assert!(widths.finned[SAMPLES - 1]);
        assert!(!widths.finned[SAMPLES - 4]);
    }

    /// A dark bar 9 px wide from x = 40 to 160 on a flat sky, with a bright blob beyond its
    /// right end: the right end is the tail; without the blob, no end is.
    #[test]
    fn a_bright_blob_beyond_one_end_marks_the_tail() {
        for with_plume in [true, false] {
            let plume = with_plume.then(|| Band::plume(160, 190));
            let profile = profile_of(
                [Some(Band::dark(40, 160)), plume].into_iter().flatten(),
                95.0,
            );
            let tail = plume_at_high(&profile, -60.0, 60.0, 9.0, 1.0, 4.0);
            assert_eq!(tail, with_plume.then_some(true), "plume {with_plume}");
        }
    }

    /// A dark bar 9 px wide, full contrast from x = 20 to 95 and a sixth of it from 95 to 170
    /// (the sky behind the tail as dark as the body), a bright plume from 170 to 195: the found
    /// ends (x = 20 to 95) bridge to the plume only where the faded stretch is there, the plume
    /// is, and a body as long as that can be.
    #[test]
    fn a_plume_beyond_a_faded_tail_marks_it() {
        let bridge = FadeBridge {
            onset_diameters: 0.5,
            min_plume_area: 1.0,
            min_fill_diameters: 0.1,
            max_contrast_sigmas: 10.0,
        };
        let onset = |faded: bool, plume: bool, longest_px: f32| {
            let bands = [
                Some(Band::dark(20, 95)),
                faded.then(|| Band::faded(95, 170)),
                plume.then(|| Band::plume(170, 195)),
            ];
            let profile = profile_of(bands.into_iter().flatten(), 99.0);
            plume_beyond_fade(&profile, -80.0, -5.0, 9.0, longest_px, &bridge)
        };
        let (high, t) = onset(true, true, 160.0).expect("bridged");
        assert!(high);
        assert!(
            (t - 70.0).abs() <= 1.5,
            "plume begins at x = 170, t = 70: {t}"
        );
        assert_eq!(
            onset(false, true, 160.0),
            None,
            "nothing of the body between"
        );
        assert_eq!(onset(true, false, 160.0), None, "no plume");
        assert_eq!(
            onset(true, true, 120.0),
            None,
            "longer than the body can be"
        );
    }

    /// A dark bar 9 px wide from x = 40 to 160 (its tail at 160), the reference model's
    /// diameter 9 px: the model's nose lies at the bar's end, also where a filament a third as
    /// wide goes on along the axis beyond it, and where the bar's first 40 px are faded to a
    /// sixth of its contrast (the sky behind as dark), told by the contrast along the axis;
    /// never beyond the longest the body can look.
    #[test]
    fn the_model_finds_the_nose_past_a_filament_and_a_fade() {
        let model = reference();
        for (filament, faded) in [(false, false), (true, false), (false, true)] {
            let bands = [
                filament.then_some(Band {
                    x: (0, 40),
                    half_width: 1.0,
                    grey: 40,
                }),
                Some(Band::dark(40, 160)),
                faded.then(|| Band::faded(40, 80)),
            ];
            let profile = profile_of(bands.into_iter().flatten(), 99.0);
            // x = 80 is t = -20.
            let contrast = |t: f32| if faded && t < -20.0 { 1.0 / 6.0 } else { 1.0 };
            let fit = |longest: f32| {
                nose_by_model(
                    &profile, 60.0, -1.0, 9.0, 30.0, longest, 40.0, &model, contrast,
                )
                .unwrap()
            };
            let (nose50, tip) = fit(150.0);
            // x = 40 is t = -60. The model's tapering nose fits part of a filament a third of
            // its width (up to 7 px of the 100 px filament), never the filament's whole length.
            let reach = if filament { 7.0 } else { 4.0 };
            let case = (filament, faded);
            assert!(
                (nose50 + 60.0).abs() <= reach,
                "(filament, faded) {case:?}: {nose50}"
            );
            assert!(
                tip < nose50 && tip > nose50 - 8.0,
                "(filament, faded) {case:?}: tip {tip}"
            );
            let (short, _) = fit(80.0);
            assert!(
                (short + 20.0).abs() <= 0.5,
                "(filament, faded) {case:?}: at most 80 px: {short}"
            );
        }
    }

    #[test]
    fn a_body_profile_is_matched_the_right_way_round() {
        let widths = ModelWidths::of(&reference());
        let nose_first = widths.width.iter().copied();
        let tail_first = widths.width.iter().rev().copied();
        assert_eq!(widths.misfit(nose_first), 0.0);
        assert!(widths.misfit(tail_first) > 0.005);
    }
}
