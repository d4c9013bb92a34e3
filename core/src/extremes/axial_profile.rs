//! The body's width profile along its axis, and the ends read from it.
//!
//! Every pixel in a band around the axis adds its contrast (of the body's polarity) to 1-px bins
//! along the axis, split linearly between the two nearest bins. Divided by the body contrast, a
//! bin holds the silhouette's width there in px; blur moves no contrast across the axis, so the
//! profile is the true width profile blurred only along the axis.

use super::{Axis, passing_span, row_span};
use crate::capacity::PROFILE_BINS;
use crate::chip::ChipView;
use crate::config::BodyPolarity;
use crate::point::ImagePoint;
use crate::segment::background::{Background, SkySpans};

/// The width profile: `width[i]` at `t = start + (i + 0.5) * bin` px along the axis; beside it
/// the same of the opposite polarity's pixels left out of it (`opposite[i]`, positive), where an
/// exhaust plume shows.
pub struct WidthProfile {
    width: [f32; PROFILE_BINS],
    opposite: [f32; PROFILE_BINS],
    bins: usize,
    start: f32,
    bin: f32,
}

/// Pixels whose contrast is this many noise deviations of the wrong polarity are left out of
/// the profile (an exhaust plume of opposite polarity over the tail) and summed apart.
const OPPOSITE_CUTOFF_SIGMA: f32 = 4.0;

impl WidthProfile {
    /// Builds the profile over `-reach..reach` px along `axis`, from pixels within `band` px of
    /// it, for a body of contrast `contrast` and polarity `polarity`.
    #[allow(clippy::too_many_arguments)]
    pub fn build(
        chip: &ChipView,
        background: &Background,
        axis: &Axis,
        polarity: BodyPolarity,
        contrast: f32,
        reach: f32,
        band: f32,
    ) -> WidthProfile {
        let bin = (2.0 * reach / PROFILE_BINS as f32).max(1.0);
        let bins = ((2.0 * reach / bin) as usize).clamp(1, PROFILE_BINS);
        let start = -0.5 * bins as f32 * bin;
        let mut width = [0.0f32; PROFILE_BINS];
        let mut opposite = [0.0f32; PROFILE_BINS];
        let sign = polarity.sign();
        let cutoff = -OPPOSITE_CUTOFF_SIGMA * background.sigma();
        let extent = reach + band + 1.0;
        let ImagePoint { x: cx, y: cy } = axis.centre;
        let x_lo = (cx - extent).max(0.0) as usize;
        let x_hi = ((cx + extent).max(0.0) as usize + 1).min(chip.width());
        let y_lo = (cy - extent).max(0.0) as usize;
        let y_hi = ((cy + extent).max(0.0) as usize + 1).min(chip.height());
        let scale = 1.0 / (contrast.max(1e-6) * bin);
        let along = (start - bin, start + (bins as f32 + 1.0) * bin);
        let mut spans = SkySpans::new();
        // The bins' positions of the pixels within `band` px of the axis.
        let position_at = |x: usize, y: usize| {
            let (along, across) = axis.local(x as f32, y as f32);
            let position = (along - start) / bin - 0.5;
            let inside =
                !(libm::fabsf(across) > band || position < -1.0 || position >= bins as f32);
            (position, inside)
        };
        for y in y_lo..y_hi {
            let (x0, x1) = passing_span(
                row_span(axis.centre, axis.dir, y, along, band, (x_lo, x_hi)),
                |x| position_at(x, y).1,
            );
            spans.for_each_in_span(&background.row(y), chip, x0, x1, |x, v, sky| {
                let (position, _) = position_at(x, y);
                let value = sign * (f32::from(v) - sky);
                let (profile, value) = if value < cutoff {
                    (&mut opposite, -value)
                } else {
                    (&mut width, value)
                };
                // Shared linearly by the bins either side: bin `lower` (-1 before the first:
                // none) and the next (`bins` past the last: none). The floor by truncation,
                // exact for these values and cheaper on the M4F than `libm::floorf`.
                let lower = if position < 0.0 {
                    -1.0
                } else {
                    position as usize as f32
                };
                let frac = position - lower;
                let next = (lower + 1.0) as usize;
                if next >= 1
                    && let Some(slot) = profile.get_mut(next - 1)
                {
                    *slot += value * (1.0 - frac) * scale;
                }
                if next < bins
                    && let Some(slot) = profile.get_mut(next)
                {
                    *slot += value * frac * scale;
                }
            });
        }
        WidthProfile {
            width,
            opposite,
            bins,
            start,
            bin,
        }
    }

    /// Width at bin `i`, px (0 outside).
    pub fn at(&self, i: usize) -> f32 {
        if i < self.bins {
            self.width.get(i).copied().unwrap_or(0.0)
        } else {
            0.0
        }
    }

    /// Position of bin `i`'s centre along the axis, px.
    pub fn t_of(&self, i: usize) -> f32 {
        self.start + (i as f32 + 0.5) * self.bin
    }

    /// The bin containing position `t`, clamped to the profile.
    pub fn bin_of(&self, t: f32) -> usize {
        (((t - self.start) / self.bin).max(0.0) as usize).min(self.bins.saturating_sub(1))
    }

    /// Number of bins.
    pub fn len(&self) -> usize {
        self.bins
    }

    /// True when the profile has no bins.
    pub fn is_empty(&self) -> bool {
        self.bins == 0
    }

    /// Walks from bin `from` one bin at a time in direction `step` (+1 or -1) and returns the
    /// last bin at or above `floor` before `max_gap` consecutive bins below it (a gap in a broken
    /// silhouette is crossed; the sky beyond the end is not).
    pub fn body_end(&self, from: usize, step: isize, floor: f32, max_gap: usize) -> usize {
        let mut last = from;
        let mut below = 0usize;
        let mut i = from as isize + step;
        while i >= 0 && (i as usize) < self.bins && below < max_gap.max(1) {
            if self.at(i as usize) >= floor {
                last = i as usize;
                below = 0;
            } else {
                below += 1;
            }
            i += step;
        }
        last
    }

    /// Width at bin `i` less the opposite polarity's there, px (0 outside): the whole contrast
    /// across the axis, where a plume of the opposite polarity counts negative.
    pub fn signed_at(&self, i: usize) -> f32 {
        self.at(i) - self.opposite_at(i)
    }

    /// Where, walking inwards from bin `outer` in direction `inward`, the width first reaches
    /// `level`: a position along the axis, px, linearly interpolated between the two bins.
    pub fn crossing_inward(&self, outer: usize, inward: isize, level: f32) -> Option<f32> {
        self.crossing_inward_of(|i| self.at(i), outer, inward, level)
    }

    /// [`WidthProfile::crossing_inward`] from the bin beyond `bin` going `outward` (+1 or -1):
    /// where a body whose last bin is `bin` reaches `level` there.
    pub fn crossing_from_beyond(&self, bin: usize, outward: isize, level: f32) -> Option<f32> {
        let beyond = usize::try_from(bin as isize + outward).ok()?;
        self.crossing_inward(beyond, -outward, level)
    }

    /// [`WidthProfile::crossing_inward`] on the signed profile ([`WidthProfile::signed_at`]).
    pub fn signed_crossing_inward(&self, outer: usize, inward: isize, level: f32) -> Option<f32> {
        self.crossing_inward_of(|i| self.signed_at(i), outer, inward, level)
    }

    /// Mean of the signed profile ([`WidthProfile::signed_at`]) between `t0` and `t1`, px.
    pub fn signed_mean_between(&self, t0: f32, t1: f32) -> f32 {
        let (sum, bins) = self.sum_between(t0, t1, |i| self.signed_at(i));
        sum / bins
    }

    /// The sum of `value` over the bins between positions `t0` and `t1` (either order), and
    /// how many bins that is.
    fn sum_between(&self, t0: f32, t1: f32, value: impl Fn(usize) -> f32) -> (f32, f32) {
        let (a, b) = (self.bin_of(t0.min(t1)), self.bin_of(t0.max(t1)));
        ((a..=b).map(value).sum(), (b - a + 1) as f32)
    }

    fn crossing_inward_of(
        &self,
        value: impl Fn(usize) -> f32,
        outer: usize,
        inward: isize,
        level: f32,
    ) -> Option<f32> {
        let mut prev = outer as isize - inward;
        let mut i = outer as isize;
        while i >= 0 && (i as usize) < self.bins {
            let b = value(i as usize);
            if b >= level {
                let a = if prev >= 0 && (prev as usize) < self.bins {
                    value(prev as usize)
                } else {
                    0.0
                };
                let frac = ((level - a) / (b - a).max(1e-9)).clamp(0.0, 1.0);
                let (ta, tb) = (self.t_of(prev.max(0) as usize), self.t_of(i as usize));
                let ta = if prev >= 0 {
                    ta
                } else {
                    tb - inward as f32 * self.bin
                };
                return Some(ta + (tb - ta) * frac);
            }
            prev = i;
            i += inward;
        }
        None
    }

    /// The opposite polarity's area between positions `t0` and `t1` (either order), in px² at
    /// the body's contrast.
    pub fn opposite_area_between(&self, t0: f32, t1: f32) -> f32 {
        let (sum, _) = self.sum_between(t0, t1, |i| self.opposite_at(i));
        sum * self.bin
    }

    /// Walking outwards from `from` px in direction `outward` (+1 or -1) for at most `reach`
    /// px, where the sum of the width (at most `cap` px) less `level` px, from `from` on, is
    /// greatest: the body goes on where what follows pays for the gaps it crosses (a faint
    /// stretch; a filament or terrain crossing it counts no more than `cap`), and stops where
    /// the sky follows, or where the opposite polarity's width reaches `cap` (a plume: nothing
    /// of the body lies beyond it). `from` where nothing beyond pays.
    pub fn paying_end(&self, from: f32, outward: isize, reach: f32, level: f32, cap: f32) -> f32 {
        let (mut sum, mut best, mut end) = (0.0f32, 0.0f32, from);
        for i in self
            .bins_outward(from, outward, reach, 1)
            .take_while(|i| self.opposite_at(*i) < cap)
        {
            sum += self.at(i).min(cap) - level;
            if sum > best {
                (best, end) = (sum, self.t_of(i));
            }
        }
        end
    }

    /// The opposite polarity's width at bin `i`, px at the body's contrast (0 outside).
    pub fn opposite_at(&self, i: usize) -> f32 {
        if i < self.bins {
            self.opposite.get(i).copied().unwrap_or(0.0)
        } else {
            0.0
        }
    }

    /// The first position, walking outwards from `from` px in direction `outward` (+1 or -1)
    /// for at most `reach` px, where the opposite polarity's width reaches `level` px: where a
    /// plume begins.
    pub fn opposite_onset(&self, from: f32, outward: isize, reach: f32, level: f32) -> Option<f32> {
        self.bins_outward(from, outward, reach, 0)
            .find(|i| self.opposite_at(*i) >= level)
            .map(|i| self.t_of(i))
    }

    /// The bins from the one at `from` px outwards in direction `outward` (+1 or -1), the
    /// first `skip` left out, for at most `reach` px and no farther than the profile's end.
    fn bins_outward(
        &self,
        from: f32,
        outward: isize,
        reach: f32,
        skip: isize,
    ) -> impl Iterator<Item = usize> + '_ {
        let steps = (reach / self.bin).max(0.0) as isize;
        let start = self.bin_of(from) as isize;
        (skip..=steps)
            .map(move |k| start + outward * k)
            .map_while(|i| usize::try_from(i).ok().filter(|i| *i < self.bins))
    }

    /// Mean width over positions between `t0` and `t1` (either order), px.
    pub fn mean_between(&self, t0: f32, t1: f32) -> f32 {
        let (sum, bins) = self.sum_between(t0, t1, |i| self.at(i));
        sum / bins
    }

    /// The zero of a least-squares line through the width where it lies between `lo` and `hi`,
    /// taking the contiguous bins from the end `outer` inwards (direction `inward`): the
    /// extrapolated tip of a tapering end, px along the axis.
    pub fn ramp_zero(&self, outer: usize, inward: isize, lo: f32, hi: f32) -> Option<f32> {
        let (mut n, mut st, mut sw, mut stt, mut stw) = (0.0f32, 0.0, 0.0, 0.0, 0.0);
        let mut i = outer as isize;
        let mut inside = false;
        while i >= 0 && (i as usize) < self.bins {
            let w = self.at(i as usize);
            if w > hi {
                break;
            }
            if w >= lo {
                inside = true;
                let t = self.t_of(i as usize);
                n += 1.0;
                st += t;
                sw += w;
                stt += t * t;
                stw += t * w;
            } else if inside {
                break;
            }
            i += inward;
        }
        let det = n * stt - st * st;
        if n < 2.0 || libm::fabsf(det) < 1e-9 {
            return None;
        }
        let slope = (n * stw - st * sw) / det;
        let intercept = (sw - slope * st) / n;
        (libm::fabsf(slope) > 1e-6).then(|| -intercept / slope)
    }

    /// The tip of the nose whose half-width point is `nose50` (px along the axis): the zero of
    /// [`WidthProfile::ramp_zero`] from the end `outer` inwards (direction `inward`) where it
    /// lies ahead of `nose50` by at most `reach_px` (the model's nose and the blur), else
    /// `nose50`. A flat or noisy ramp, such as a filament running on along the nose line,
    /// extrapolates anywhere.
    pub fn nose_tip(
        &self,
        outer: usize,
        inward: isize,
        (lo, hi): (f32, f32),
        nose50: f32,
        reach_px: f32,
    ) -> f32 {
        self.ramp_zero(outer, inward, lo, hi)
            .filter(|&t| (0.0..=reach_px).contains(&((nose50 - t) * inward as f32)))
            .unwrap_or(nose50)
    }
}

/// A test chip of bars and blobs along one line, and its width profile.
#[cfg(test)]
pub(crate) mod testing {
    use super::*;
    use crate::extremes::Axis;

    /// A stretch of the test chip (200 x 64 px, sky 100) along y = 32, from `x.0` to `x.1`
    /// (exclusive), within `half_width` px of the line, at grey level `grey`.
    pub struct Band {
        pub x: (usize, usize),
        pub half_width: f32,
        pub grey: u8,
    }

    impl Band {
        /// A dark bar 9 px wide, 60 grey levels below the sky.
        pub fn dark(x0: usize, x1: usize) -> Band {
            Band {
                x: (x0, x1),
                half_width: 4.0,
                grey: 40,
            }
        }

        /// The same bar 10 grey levels below the sky (the sky behind it as dark as the body).
        pub fn faded(x0: usize, x1: usize) -> Band {
            Band {
                grey: 90,
                ..Band::dark(x0, x1)
            }
        }

        /// A bright plume 11 px wide, 100 grey levels above the sky.
        pub fn plume(x0: usize, x1: usize) -> Band {
            Band {
                x: (x0, x1),
                half_width: 5.0,
                grey: 200,
            }
        }
    }

    /// The width profile of a dark body (contrast 60) over `reach` px either side of x = 100
    /// along y = 32, from pixels within 8 px of the line, on the test chip with `bands` drawn
    /// (in turn).
    pub fn profile_of(bands: impl IntoIterator<Item = Band>, reach: f32) -> WidthProfile {
        const W: usize = 200;
        let mut data = [100u8; W * 64];
        for band in bands {
            for (y, row) in data.chunks_exact_mut(W).enumerate() {
                if libm::fabsf(y as f32 - 32.0) <= band.half_width {
                    row[band.x.0..band.x.1].fill(band.grey);
                }
            }
        }
        let chip = ChipView::gray8(&data, W, 64, W, 0, 0).unwrap();
        let mut background = Background::new();
        background.estimate(&chip);
        let axis = Axis {
            centre: ImagePoint::new(100.0, 32.0),
            dir: ImagePoint::new(1.0, 0.0),
        };
        WidthProfile::build(
            &chip,
            &background,
            &axis,
            BodyPolarity::Dark,
            60.0,
            reach,
            8.0,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::testing::{Band, profile_of};

    /// The body found from x = 40 to 100 (t = -60 to 0) goes on past a 10-px gap (a stretch
    /// where the sky is as dark as the body) to x = 150 (t = 50): 40 px of body pay for it; a
    /// 4-px stub beyond a 20-px gap does not, nor anything past a plume, nor past `reach`.
    #[test]
    fn the_end_goes_on_where_the_body_pays_for_the_gap() {
        let (level, cap) = (4.0, 8.0);
        let gapped = profile_of([Band::dark(40, 100), Band::dark(110, 150)], 99.0);
        let end = gapped.paying_end(0.0, 1, 120.0, level, cap);
        assert!((end - 49.5).abs() <= 1.0, "{end}");
        let reached = gapped.paying_end(0.0, 1, 30.0, level, cap);
        assert!((reached - 30.0).abs() <= 1.0, "up to the reach: {reached}");
        let stub = profile_of([Band::dark(40, 100), Band::dark(120, 124)], 99.0);
        assert_eq!(stub.paying_end(0.0, 1, 120.0, level, cap), 0.0);
        let plume = profile_of(
            [
                Band::dark(40, 100),
                Band::dark(110, 150),
                Band::plume(102, 108),
            ],
            99.0,
        );
        assert_eq!(plume.paying_end(0.0, 1, 120.0, level, cap), 0.0);
    }

    /// A 9-px body ends at x = 120 (t = 20). Its nose tapering over 8 px to 3 px wide puts the
    /// ramp's zero 6 px beyond its last bin, at t = 36, within the nose's reach. A filament 5
    /// then 3 px wide running on to the chip's edge puts it near t = 140 instead: beyond the
    /// reach, the half-width point stands.
    #[test]
    fn the_nose_tip_is_the_ramp_zero_only_within_the_nose_reach() {
        let band = |x0, x1, half_width| Band {
            x: (x0, x1),
            half_width,
            grey: 40,
        };
        let ramp = (0.2 * 9.0, 0.65 * 9.0);
        let (nose50, reach) = (20.0, 29.0);
        let tapered = profile_of(
            [
                band(40, 120, 4.0),
                band(120, 124, 3.0),
                band(124, 128, 2.0),
                band(128, 132, 1.0),
            ],
            99.0,
        );
        let outer = tapered.bin_of(60.0);
        let tip = tapered.nose_tip(outer, -1, ramp, nose50, reach);
        assert!((tip - 36.0).abs() <= 1.0, "{tip}");
        let filament = profile_of(
            [band(40, 120, 4.0), band(120, 160, 2.0), band(160, 200, 1.0)],
            99.0,
        );
        let outer = filament.bin_of(98.0);
        let zero = filament.ramp_zero(outer, -1, ramp.0, ramp.1).unwrap();
        assert!(zero > 20.0 + 2.0 * reach, "the filament's ramp: {zero}");
        assert_eq!(filament.nose_tip(outer, -1, ramp, nose50, reach), nose50);
    }
}
