//! The sky along a detected body, where it varies faster than the background's tiles follow.
//!
//! A cloud band a few pixels high, a filament or the terrain's edge crossing a faint body put
//! the tile model's sky off by several noise sigmas under it, and every measurement after
//! detection (the cross-section, the width profile, the table match) reads the body against that
//! sky. The corridor measures the sky beside the body instead: along the body's axis, in bins a
//! few pixels long, the trimmed mean of the pixels on each flank (between `inner` and `outer` px from
//! the axis, clear of the body and its blur). The sky at a point of the corridor is linear along
//! the axis between bin centres and across it between the two flanks.
//!
//! It is used only where it disagrees with the tiles by more than a fraction of the body's
//! contrast ([`Corridor::disagreement`]): a sky error that small does not matter, and the tiles'
//! estimate is smoother (a body of high contrast on a clean sky keeps it).

use super::clamped_span;
use crate::chip::ChipView;
use crate::extremes::{Axis, row_span};

/// Largest number of bins along the corridor.
pub const CORRIDOR_BINS: usize = 96;

/// Largest number of flank pixels one bin's median is taken over, per side.
const MAX_SAMPLES: usize = 256;

/// How the corridor is laid along a detected body.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CorridorConfig {
    /// The flanks start this many px beyond half the body's span (fins included) ...
    pub margin_px: f32,
    /// ... plus this fraction of the corridor's half-length (the detected axis's error in angle).
    pub axis_slope: f32,
    /// Each flank is this many body diameters wide.
    pub flank_diameters: f32,
    /// Bins along the axis are this many body diameters long.
    pub bin_diameters: f32,
    /// The corridor reaches this many times the detected half-length either side of the centre,
    /// plus a span (the ends beyond a short detection, and the sky beyond them).
    pub length_scale: f32,
    /// The corridor's sky is used where it disagrees with the tiles by more than this fraction
    /// of the body's contrast ([`Corridor::disagreement`]).
    pub max_disagreement: f32,
}

impl CorridorConfig {
    /// The defaults.
    pub const DEFAULT: CorridorConfig = CorridorConfig {
        margin_px: 2.0,
        axis_slope: 0.04,
        flank_diameters: 1.5,
        bin_diameters: 1.0,
        length_scale: 1.3,
        max_disagreement: 0.25,
    };

    /// The corridor along a body on `axis`, detected `half_length` px either side of its
    /// centre, of diameter `diameter_px` and span (fins included) `span_px`.
    pub fn shape(
        &self,
        axis: Axis,
        half_length: f32,
        diameter_px: f32,
        span_px: f32,
    ) -> CorridorShape {
        let half_length = self.length_scale * half_length + span_px;
        let inner = 0.5 * span_px + self.margin_px + self.axis_slope * half_length;
        CorridorShape {
            axis,
            half_length,
            inner,
            outer: inner + self.flank_diameters * diameter_px,
            bin_px: (self.bin_diameters * diameter_px).max(2.0),
        }
    }
}

impl Default for CorridorConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The corridor's geometry: where it lies and how it is binned.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CorridorShape {
    /// The body's axis.
    pub axis: Axis,
    /// Half the corridor's length along the axis, px.
    pub half_length: f32,
    /// The flanks start this far from the axis, px ...
    pub inner: f32,
    /// ... and end this far, px.
    pub outer: f32,
    /// Bin length along the axis, px.
    pub bin_px: f32,
}

/// The sky levels along a body, per bin and flank.
#[derive(Clone)]
pub struct Corridor {
    shape: CorridorShape,
    bins: usize,
    /// Per bin, the sky on the side of negative `across` ...
    minus: [f32; CORRIDOR_BINS],
    /// ... and on the positive side, grey levels.
    plus: [f32; CORRIDOR_BINS],
}

impl Corridor {
    /// Measures the corridor of `shape` in `chip`; None where it is degenerate or a flank of a
    /// bin has no pixel in the chip.
    pub fn measure(chip: &ChipView, shape: &CorridorShape) -> Option<Corridor> {
        let (shape, bins) = binned(shape)?;
        let mut corridor = Corridor {
            shape,
            bins,
            minus: [0.0; CORRIDOR_BINS],
            plus: [0.0; CORRIDOR_BINS],
        };
        for i in 0..bins {
            let t0 = -shape.half_length + i as f32 * shape.bin_px;
            let minus = flank_level(chip, &shape, (t0, t0 + shape.bin_px), -1.0)?;
            let plus = flank_level(chip, &shape, (t0, t0 + shape.bin_px), 1.0)?;
            if let (Some(m), Some(p)) = (corridor.minus.get_mut(i), corridor.plus.get_mut(i)) {
                (*m, *p) = (minus, plus);
            }
        }
        Some(corridor)
    }

    /// A quick look before [`Corridor::measure`]: how far the plain means of the flanks' pixels
    /// per bin lie from `tiles`, the root mean square over bins and flanks (grey levels; None
    /// where the shape is degenerate). One pass over every other row and column of the
    /// corridor, no sorting: on a clean sky it is small and the corridor need not be measured.
    pub fn screen(
        chip: &ChipView,
        shape: &CorridorShape,
        tiles: impl Fn(f32, f32) -> f32,
    ) -> Option<f32> {
        let (shape, bins) = binned(shape)?;
        let mut sums = [[0.0f32; 2]; CORRIDOR_BINS];
        let mut counts = [[0u32; 2]; CORRIDOR_BINS];
        let axis = &shape.axis;
        let reach = shape.half_length + shape.outer + 1.0;
        let (y_lo, y_hi) = clamped_span(axis.centre.y, reach, chip.height());
        let (x_lo, x_hi) = clamped_span(axis.centre.x, reach, chip.width());
        let half = shape.half_length;
        // Every other row and column: a quarter of the pixels is plenty for plain means.
        for y in (y_lo..y_hi).step_by(2) {
            let (a, b) = row_span(
                axis.centre,
                axis.dir,
                y,
                (-half, half),
                shape.outer,
                (x_lo, x_hi),
            );
            chip.for_each_in_span(y, a, b, |x, v| {
                if x % 2 == 1 {
                    return;
                }
                let (t, across) = axis.local(x as f32, y as f32);
                let side = usize::from(across > 0.0);
                let distance = libm::fabsf(across);
                if t < -half || t >= half || distance < shape.inner || distance > shape.outer {
                    return;
                }
                let bin = ((t + half) / shape.bin_px) as usize;
                if let (Some(s), Some(n)) = (
                    sums.get_mut(bin).and_then(|s| s.get_mut(side)),
                    counts.get_mut(bin).and_then(|n| n.get_mut(side)),
                ) {
                    *s += f32::from(v);
                    *n += 1;
                }
            });
        }
        let mean = |i: usize, side: usize| {
            let total = *sums.get(i)?.get(side)?;
            let count = *counts.get(i)?.get(side)?;
            (count > 0).then(|| total / count as f32)
        };
        Some(shape.rms_from_tiles(bins, mean, tiles))
    }

    /// Where the corridor lies.
    pub fn shape(&self) -> &CorridorShape {
        &self.shape
    }

    /// The sky at chip point (`x`, `y`), or None outside the corridor (beyond its ends, or more
    /// than `outer` px from the axis).
    pub fn at(&self, x: f32, y: f32) -> Option<f32> {
        let (along, across) = self.shape.axis.local(x, y);
        self.at_local(along, across, self.reading())
    }

    /// Writes the corridor's sky over `out`, which holds columns `x_start..` of row `y`, at the
    /// columns `columns` where it has one: [`Corridor::at`] at each, bit for bit, with what is
    /// the same for every point worked out once.
    pub fn overlay_row(
        &self,
        y: usize,
        columns: core::ops::Range<usize>,
        x_start: usize,
        out: &mut [f32],
    ) {
        let reading = self.reading();
        let slots = columns.start.saturating_sub(x_start)..columns.end.saturating_sub(x_start);
        let Some(slots) = out.get_mut(slots) else {
            return;
        };
        let y = y as f32;
        for (x, slot) in columns.zip(slots) {
            let (along, across) = self.shape.axis.local(x as f32, y);
            if let Some(level) = self.at_local(along, across, reading) {
                *slot = level;
            }
        }
    }

    /// The last bin, and the flanks' middle distance from the axis, px.
    fn reading(&self) -> (usize, f32) {
        let s = &self.shape;
        (self.bins.saturating_sub(1), 0.5 * (s.inner + s.outer))
    }

    /// [`Corridor::at`] at `along`, `across` px in the axis' frame, with `(last bin, mid)` from
    /// [`Corridor::reading`].
    #[inline]
    fn at_local(&self, along: f32, across: f32, (last, mid): (usize, f32)) -> Option<f32> {
        let s = &self.shape;
        if libm::fabsf(along) > s.half_length || libm::fabsf(across) > s.outer {
            return None;
        }
        let position = ((along + s.half_length) / s.bin_px - 0.5).clamp(0.0, last as f32);
        let i0 = position as usize;
        let i1 = (i0 + 1).min(last);
        let w = position - i0 as f32;
        let (Some(&m0), Some(&m1), Some(&p0), Some(&p1)) = (
            self.minus.get(i0),
            self.minus.get(i1),
            self.plus.get(i0),
            self.plus.get(i1),
        ) else {
            return None;
        };
        let (minus, plus) = (m0 + w * (m1 - m0), p0 + w * (p1 - p0));
        let u = ((across + mid) / (2.0 * mid)).clamp(0.0, 1.0);
        Some(minus + u * (plus - minus))
    }

    /// How far the corridor's flank levels lie from `tiles` (the tile model's sky at a chip
    /// point): the root mean square over bins and flanks, grey levels.
    pub fn disagreement(&self, tiles: impl Fn(f32, f32) -> f32) -> f32 {
        let level = |i: usize, side: usize| {
            let levels = if side == 0 { &self.minus } else { &self.plus };
            Some(levels.get(i).copied().unwrap_or(0.0))
        };
        self.shape.rms_from_tiles(self.bins, level, tiles)
    }
}

impl CorridorShape {
    /// The root mean square, over the first `bins` bins and both flanks (side 0 at negative
    /// `across`, 1 at positive), of `level(bin, side)` less `tiles` at the flank's middle, grey
    /// levels; a flank without a level is left out.
    fn rms_from_tiles(
        &self,
        bins: usize,
        level: impl Fn(usize, usize) -> Option<f32>,
        tiles: impl Fn(f32, f32) -> f32,
    ) -> f32 {
        let mid = 0.5 * (self.inner + self.outer);
        let normal = self.axis.dir.perpendicular();
        let (mut sum, mut n) = (0.0f32, 0u32);
        for i in 0..bins {
            let centre = self
                .axis
                .point(-self.half_length + (i as f32 + 0.5) * self.bin_px);
            for (side, sign) in [(0usize, -1.0f32), (1, 1.0)] {
                let Some(level) = level(i, side) else {
                    continue;
                };
                let p = centre + normal * (sign * mid);
                let d = level - tiles(p.x, p.y);
                sum += d * d;
                n += 1;
            }
        }
        libm::sqrtf(sum / n.max(1) as f32)
    }
}

/// `shape` with its bins fitted to its length (at most [`CORRIDOR_BINS`], at least one), and
/// their number; None where it is degenerate.
fn binned(shape: &CorridorShape) -> Option<(CorridorShape, usize)> {
    let sizes = [shape.half_length, shape.inner, shape.outer, shape.bin_px];
    if !sizes.iter().all(|v| v.is_finite() && *v > 0.0) || shape.outer <= shape.inner {
        return None;
    }
    let bin_px = shape
        .bin_px
        .max(2.0 * shape.half_length / CORRIDOR_BINS as f32);
    let bins = ((2.0 * shape.half_length / bin_px) as usize).clamp(1, CORRIDOR_BINS);
    let shape = CorridorShape {
        bin_px,
        half_length: 0.5 * bins as f32 * bin_px,
        ..*shape
    };
    Some((shape, bins))
}

/// The mean of the middle half (a trimmed mean, robust to a filament or a bright spot, and not
/// quantized as a median of integer samples is) of the chip's pixels of the flank on side `side` (-1 or +1 across the axis) of the
/// stretch `along` (px from the centre) of `shape` (at most [`MAX_SAMPLES`] of them); None where
/// there are none.
fn flank_level(
    chip: &ChipView,
    shape: &CorridorShape,
    along: (f32, f32),
    side: f32,
) -> Option<f32> {
    let mut values = [0.0f32; MAX_SAMPLES];
    let mut n = 0usize;
    let axis = &shape.axis;
    let (t0, t1) = along;
    let mid = 0.5 * (shape.inner + shape.outer);
    let centre = axis.point(0.5 * (t0 + t1)) + axis.dir.perpendicular() * (side * mid);
    let reach = 0.5 * (t1 - t0) + 0.5 * (shape.outer - shape.inner) + 1.0;
    let (y_lo, y_hi) = clamped_span(centre.y, reach, chip.height());
    let (x_lo, x_hi) = clamped_span(centre.x, reach, chip.width());
    // Every `stride`-th pixel of the flank, so that a wide flank is sampled all over.
    let area = (t1 - t0) * (shape.outer - shape.inner);
    let stride = (libm::ceilf(area / MAX_SAMPLES as f32) as usize).max(1);
    let mut seen = 0usize;
    for y in y_lo..y_hi {
        let (a, b) = row_span(axis.centre, axis.dir, y, along, shape.outer, (x_lo, x_hi));
        chip.for_each_in_span(y, a, b, |x, v| {
            let (t, across) = axis.local(x as f32, y as f32);
            let across = side * across;
            if t >= t0 && t < t1 && across >= shape.inner && across <= shape.outer {
                seen += 1;
                if seen % stride == 0
                    && let Some(slot) = values.get_mut(n)
                {
                    *slot = f32::from(v);
                    n += 1;
                }
            }
        });
    }
    let values = values.get_mut(..n)?;
    if values.is_empty() {
        return None;
    }
    // The lowest and the highest quarter partitioned off (no sort: linear time).
    let quarter = values.len() / 4;
    values.select_nth_unstable_by(quarter, f32::total_cmp);
    let upper = values.get_mut(quarter..)?;
    let keep = upper.len() - quarter;
    if quarter > 0 {
        upper.select_nth_unstable_by(keep, f32::total_cmp);
    }
    let middle = upper.get(..keep)?;
    let mean = middle.iter().sum::<f32>() / middle.len().max(1) as f32;
    Some(mean)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::point::ImagePoint;
    use crate::segment::background::Background;
    use crate::testing::noise_sequence;

    const SIDE: usize = 128;

    /// A sky of 100 grey levels (noise 2) with a cloud band 30 px high at 80 along the middle
    /// rows, and a body 5 px wide 10 grey levels darker than the band inside it.
    fn banded_chip() -> [u8; SIDE * SIDE] {
        let mut noise = noise_sequence(SIDE * SIDE, 5);
        let mut data = [0u8; SIDE * SIDE];
        for (i, v) in data.iter_mut().enumerate() {
            let (x, y) = (i % SIDE, i / SIDE);
            let band = if (49..79).contains(&y) { -20.0 } else { 0.0 };
            let body = if (62..67).contains(&y) && (24..104).contains(&x) {
                -10.0
            } else {
                0.0
            };
            *v = (100.0 + band + body + 2.0 * noise.next().unwrap_or(0.0)) as u8;
        }
        data
    }

    /// The tiles' sky under the body is the band's partly at best; the corridor's is the band's,
    /// and the background follows it there (and only there), since it disagrees with the tiles by
    /// more than a quarter of the body's contrast.
    #[test]
    fn follows_a_cloud_band_along_the_body() {
        let data = banded_chip();
        let chip = ChipView::gray8(&data, SIDE, SIDE, SIDE, 0, 0).unwrap();
        let shape = CorridorConfig::DEFAULT.shape(
            Axis {
                centre: ImagePoint::new(63.5, 64.0),
                dir: ImagePoint::new(1.0, 0.0),
            },
            40.0,
            5.0,
            5.0,
        );
        let corridor = Corridor::measure(&chip, &shape).unwrap();
        let sky = corridor.at(63.5, 64.0).unwrap();
        assert!((sky - 80.0).abs() < 1.0, "{sky}");
        assert!(corridor.at(63.5, 10.0).is_none());
        let mut background = Background::new();
        background.estimate(&chip);
        let tiles = background.at(63.5, 64.0);
        assert!(tiles - 80.0 > 3.0, "the tiles' sky {tiles}");
        assert!(!background.follows_corridor());
        assert!(background.follow_corridor(&chip, &shape, 0.25 * 10.0));
        assert!(background.follows_corridor());
        assert!((background.at(63.5, 64.0) - 80.0).abs() < 1.0);
        // The labeler's rows and the profiles' row reads see the same sky as single pixels do,
        // on the axis, across the flanks and beyond them.
        for y in [57, 60, 62, 64, 66, 69, 72] {
            let mut row = [0.0f32; SIDE];
            background.fill_row(y, 0, &mut row);
            let read = background.row(y);
            let mut filled = [0.0f32; SIDE];
            read.fill(0, &mut filled);
            for (x, (level, fill)) in row.iter().zip(filled).enumerate() {
                let single = background.at(x as f32, y as f32);
                assert!((level - single).abs() < 1e-3, "({x}, {y})");
                assert_eq!(read.at(x).to_bits(), single.to_bits(), "({x}, {y})");
                assert_eq!(fill.to_bits(), single.to_bits(), "({x}, {y})");
            }
        }
        assert_eq!(background.at(63.5, 10.0), tiles_far(&chip));
        // On a clean sky the tiles stay.
        let clean = [100u8; SIDE * SIDE];
        let clean = ChipView::gray8(&clean, SIDE, SIDE, SIDE, 0, 0).unwrap();
        background.estimate(&clean);
        assert!(!background.follow_corridor(&clean, &shape, 0.25 * 10.0));
        assert!(!background.follows_corridor());
    }

    /// The tiles' sky far from the body (where the corridor does not reach).
    fn tiles_far(chip: &ChipView) -> f32 {
        let mut background = Background::new();
        background.estimate(chip);
        background.at(63.5, 10.0)
    }
}
