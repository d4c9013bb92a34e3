//! The body looked for at its own scale: a straight bar of its diameter, darker (or brighter)
//! than the sky on both sides, about as long as the model says it can look.
//!
//! In clutter a faint body does not stand out pixel by pixel, and what does (a plume, a cloud
//! band, terrain, filaments as dark as the body) wins a selection by significance. Integrated
//! over its own width and length the body is the strongest straight bar of its width:
//!
//! 1. The chip is averaged over blocks about half a diameter wide ([`BarConfig::block_diameters`]),
//!    which raises a faint body's signal-to-noise by the block's side.
//! 2. For each of `K` directions (a step of about a diameter over the integration length), every
//!    block's sum along a digital line of the integration length is compared with the sums along
//!    the two parallel lines [`BarConfig::flank_diameters`] to either side (both on the grid).
//!    The response is the smaller of the two contrasts in noise sigmas: an edge darker on one
//!    side only (a cloud band's, the terrain's) gives nothing, and a filament narrower than the
//!    body a fraction of its response. Sliding sums make this a few operations per block and
//!    direction. Responses are ranked against the scatter of the blocks along the smoother
//!    flank line too: terrain's or a cloud's texture makes strong responses, the sky beside a
//!    body is even.
//! 3. The strongest responses, apart, are the candidate bars ([`BarSearch::search`]). Each is
//!    refined in angle and offset and measured ([`BarSearch::measure`]): walked along its axis
//!    both ways until its contrast stays below a fraction of its middle's (or far above it:
//!    terrain) for longer than a filament is wide, which gives its ends and length, so that a
//!    band or filament longer than the body, or one that runs into the chip's edge, is refused;
//!    and the glow of a plume of the other polarity just beyond an end is measured.
//! 4. Where the chip has a plume, the bars that end at it are measured too
//!    ([`BarSearch::measure_from`]): of the lines that start at the plume's edge (along its
//!    axis only, where it is elongated: a plume trails the body), the
//!    [`PLUME_DIRECTIONS`] of highest contrast among their neighbours, for the selection to
//!    judge (a dark cloud band's edge beside the plume can outdo a faint body's line by contrast
//!    alone, not by its width). A faint body's own response can be lost among a cloud's, but
//!    its plume is the brightest thing in the chip and marks where its tail is: the bar reaches
//!    on to the plume's edge where its tail faded under the glow, and where it runs on beyond
//!    the body's length (into a cloud past the nose) it is the body over the integration
//!    length.

use super::select::{ExpectedBody, Shape};
use crate::chip::ChipView;
use crate::point::ImagePoint;

/// Largest number of directions tried.
pub const MAX_DIRECTIONS: usize = 64;

/// Largest number of candidate bars kept.
pub const MAX_BARS: usize = 8;

/// Directions from a plume measured as bars ([`BarSearch::measure_from`]).
pub const PLUME_DIRECTIONS: usize = 3;

/// Largest number of peaks (strongest responses, apart) measured as bars.
const MAX_PEAKS: usize = 24;

/// The bar search's tunables.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BarConfig {
    /// Block side, in body diameters (1 to 64 px; larger where the chip has more blocks than
    /// the search's grid holds).
    pub block_diameters: f32,
    /// Integration length, as a fraction of the body's broadside length ...
    pub length_fraction: f32,
    /// ... and at least this many diameters.
    pub min_length_diameters: f32,
    /// The flank lines lie this many diameters from the bar's axis.
    pub flank_diameters: f32,
    /// Smallest response of a candidate, in noise sigmas of the contrast of its line sums.
    pub threshold_sigma: f32,
    /// A bar's end is where its contrast falls below this fraction of its middle's, or rises
    /// above `end_ceiling` times it (terrain, far darker than a faint body, beyond its tail) ...
    pub end_fraction: f32,
    /// ... (the ceiling) ...
    pub end_ceiling: f32,
    /// ... for longer than this many diameters (shorter dips are crossed).
    pub max_gap_diameters: f32,
    /// A component target of the body's polarity whose mean contrast is at least this many
    /// noise sigmas stands without a search (a body of high contrast is not in doubt), unless as
    /// a bar it runs into the chip's edge (a piece of terrain).
    pub strong_sigma: f32,
    /// A measured bar whose ends lie within this fraction of the body's broadside length (or a
    /// span) of the chip's edge is refused: the body's extremes may be cut.
    pub overhang_lengths: f32,
    /// A measured bar shorter than this many diameters is refused.
    pub min_bar_diameters: f32,
    /// A bar with a plume at an end ([`Bar::plume_sigma`] at least this) is judged whatever
    /// its cross-section's width (a cloud beside a faint body widens the fit; a filament has
    /// no plume), and the chip's plume is a component at least this significant.
    pub plume_min_sigma: f32,
    /// A bar gains this times ln(1 + [`Bar::plume_sigma`] / `plume_min_sigma`) in the
    /// selection's score: the brighter the plume at its end, the surer it is the body's.
    pub plume_weight: f32,
    /// A bar's cross-section width disagreeing with the body's costs it at most this in the
    /// selection's score (in clutter the fitted width is a weak witness).
    pub max_width_penalty: f32,
    /// A component target shorter than this fraction of the bar it lies on is a fragment of
    /// the body: the bar is the target.
    pub fragment_fraction: f32,
    /// A bar whose centre line lies on the component target's mask over at least this fraction
    /// of its middle half is a piece of the component (a fin or an end of a body that detection
    /// found whole): the component stands.
    pub piece_fraction: f32,
    /// Where the body's size is from a measured range, a strong component of its polarity
    /// shorter than this fraction of its broadside length may be a plume of its polarity: the
    /// best bar that ends at it along its axis is the body.
    pub plume_length_fraction: f32,
    /// ... unless that plume's mean contrast is more than this many times the bar's.
    pub plume_max_contrast_ratio: f32,
}

impl BarConfig {
    /// The defaults.
    pub const DEFAULT: BarConfig = BarConfig {
        block_diameters: 0.5,
        length_fraction: 0.7,
        min_length_diameters: 3.0,
        flank_diameters: 1.25,
        threshold_sigma: 6.0,
        end_fraction: 0.4,
        end_ceiling: 2.5,
        max_gap_diameters: 1.5,
        strong_sigma: 8.0,
        overhang_lengths: 0.3,
        min_bar_diameters: 2.5,
        plume_min_sigma: 8.0,
        plume_weight: 1.0,
        max_width_penalty: 2.0,
        fragment_fraction: 0.5,
        piece_fraction: 0.8,
        plume_length_fraction: 0.5,
        plume_max_contrast_ratio: 10.0,
    };
}

impl Default for BarConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// A bar in the chip: the body, or something shaped like it.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Bar {
    /// Its middle, chip px.
    pub centre: ImagePoint,
    /// Unit vector along it (either way).
    pub dir: ImagePoint,
    /// Half its length, px (the integration length's half until measured).
    pub half_length_px: f32,
    /// Its contrast against the mean of its two flanks, grey levels (the body's polarity
    /// positive; a search's peak: against the flank with less).
    pub contrast: f32,
    /// Its significance: its mean contrast over its length in units of the contrast's own
    /// scatter along it (at least the noise's), times the square root of the samples (a
    /// search's peak: its response in noise sigmas, less where the flanks are textured).
    pub significance: f32,
    /// The strongest contrast of the other polarity just beyond either end, in noise sigmas of
    /// one block's contrast: a plume at the tail.
    pub plume_sigma: f32,
}

/// Why a candidate bar is not the body.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BarRefusal {
    /// No contrast of the body's polarity along it.
    NoContrast,
    /// It runs on beyond the longest the body can look (a cloud band, a filament).
    TooLong,
    /// It runs into the chip's edge.
    AtEdge,
    /// It is shorter than [`BarConfig::min_bar_diameters`] (a compact spot, or a body seen
    /// nearly end-on, which the components find).
    TooShort,
    /// No chip is prepared ([`BarSearch::prepare`] was not called, or refused the size).
    NotPrepared,
}

/// The search's block grid and its buffers, `CELLS` blocks at most.
pub struct BarSearch<const CELLS: usize> {
    /// Block means, the body's polarity positive (sign times grey level).
    blocks: [f32; CELLS],
    /// Sums along the current direction's lines, per block (NaN: the line leaves the grid) ...
    lines: [f32; CELLS],
    /// ... and the variance of the blocks along them, grey levels squared.
    scatter: [f32; CELLS],
    cols: usize,
    rows: usize,
    /// Block side, px.
    side: usize,
    /// Noise standard deviation of one block mean, grey levels.
    block_sigma: f32,
    /// What the prepared chip is searched for (None: not prepared).
    scale: Option<Scale>,
}

impl<const CELLS: usize> Default for BarSearch<CELLS> {
    fn default() -> Self {
        Self::new()
    }
}

/// What [`BarSearch::search`] integrates over, from the expected body and the config.
#[derive(Debug, Clone, Copy)]
struct Scale {
    diameter_px: f32,
    overhang_px: f32,
    length_px: f32,
    flank_px: f32,
    longest_px: f32,
    /// A stretch below a bar's end level shorter than this is crossed, px.
    gap_px: f32,
}

impl<const CELLS: usize> BarSearch<CELLS> {
    /// An empty search.
    pub const fn new() -> Self {
        BarSearch {
            blocks: [0.0; CELLS],
            lines: [0.0; CELLS],
            scatter: [0.0; CELLS],
            cols: 0,
            rows: 0,
            side: 1,
            block_sigma: 1.0,
            scale: None,
        }
    }

    /// Averages `chip` (noise `sigma` grey levels a pixel) over blocks for a body of
    /// `expected`'s size and polarity `sign` (+1 brighter than the sky, -1 darker), which can
    /// be no longer than `longest_px`; false where that size gives no search. [`BarSearch::search`]
    /// and [`BarSearch::measure`] work on the blocks.
    pub fn prepare(
        &mut self,
        chip: &ChipView,
        sigma: f32,
        sign: f32,
        expected: &ExpectedBody,
        longest_px: f32,
        config: &BarConfig,
    ) -> bool {
        self.scale = None;
        let (width, height) = (chip.width(), chip.height());
        let diagonal = libm::hypotf(width as f32, height as f32);
        let mut scale = scale_of(expected, longest_px, config);
        let sizes = [scale.diameter_px, scale.length_px, scale.longest_px];
        // A body of no size, or one that cannot be seen whole in the chip, is not searched for.
        let seen = scale.diameter_px <= diagonal && scale.length_px <= diagonal;
        if !sizes.iter().all(|v| v.is_finite() && *v > 0.0) || !sigma.is_finite() || !seen {
            return false;
        }
        if CELLS < 9 {
            return false;
        }
        // Nothing runs on further than across the chip (the walks' step counts stay small).
        scale.longest_px = scale.longest_px.min(2.0 * diagonal);
        scale.overhang_px = scale.overhang_px.min(diagonal);
        // At least the side that fits the chip in the grid, then up to it exactly.
        let fit = libm::sqrtf((width * height) as f32 / CELLS as f32) as usize;
        let mut side = ((config.block_diameters * scale.diameter_px) as usize).clamp(1, 64);
        side = side.max(fit);
        while (width / side) * (height / side) > CELLS {
            side += 1;
        }
        let (cols, rows) = (width / side, height / side);
        if cols < 3 || rows < 3 {
            return false;
        }
        self.cols = cols;
        self.rows = rows;
        self.side = side;
        self.block_sigma = sigma.max(0.3) / side as f32;
        let norm = sign / (side * side) as f32;
        self.blocks.iter_mut().for_each(|b| *b = 0.0);
        for y in 0..rows * side {
            let row = y / side;
            chip.for_each_in_span(y, 0, cols * side, |x, v| {
                if let Some(b) = self.blocks.get_mut(row * cols + x / side) {
                    *b += norm * f32::from(v);
                }
            });
        }
        self.scale = Some(scale);
        true
    }

    /// The strongest bars in the prepared chip ([`BarSearch::prepare`]), each measured
    /// ([`BarSearch::measure`]); those refused are left out. Where the chip has a `plume` (a
    /// compact glow of the other polarity), the bar that ends at it ([`BarSearch::measure_from`])
    /// is among them, whatever its strength. Strongest first.
    pub fn search(
        &mut self,
        config: &BarConfig,
        plume: Option<&Shape>,
        bars: &mut heapless::Vec<Bar, MAX_BARS>,
    ) {
        bars.clear();
        let Some(scale) = self.scale else {
            return;
        };
        let mut peaks: heapless::Vec<Bar, MAX_PEAKS> = heapless::Vec::new();
        let directions = scale.directions();
        for k in 0..directions {
            let angle = core::f32::consts::PI * k as f32 / directions as f32;
            let dir = ImagePoint::new(libm::cosf(angle), libm::sinf(angle));
            self.direction_peaks(dir, &scale, config, &mut peaks);
        }
        peaks.sort_unstable_by(|a, b| b.significance.total_cmp(&a.significance));
        for peak in &peaks {
            let (centre, dir) = self.refine(peak.centre, peak.dir, &scale);
            if let Ok(bar) = self.walk(centre, dir, &scale, config) {
                // Two peaks on one bar measure the same: keep one.
                let same = bars.iter().any(|b| same_bar(b, &bar, scale.diameter_px));
                if !same {
                    let _ = bars.push(bar);
                }
            }
        }
        bars.sort_unstable_by(|a, b| b.significance.total_cmp(&a.significance));
        // The plume's bars measured from the plume, the few strongest directions: each replaces
        // the same bar measured from its middle where it is longer or has the stronger plume
        // (the plume's end is the one a faint tail's walk misses), else the weakest.
        let from_plume = plume.and_then(|p| self.measure_from(p, config).ok());
        for bar in from_plume.into_iter().flatten().flatten() {
            match bars
                .iter_mut()
                .find(|b| same_bar(b, &bar, scale.diameter_px))
            {
                Some(same)
                    if same.half_length_px < bar.half_length_px
                        || same.plume_sigma < bar.plume_sigma =>
                {
                    *same = bar
                }
                Some(_) => {}
                None => {
                    if bars.is_full() {
                        bars.pop();
                    }
                    let _ = bars.push(bar);
                }
            }
            bars.sort_unstable_by(|a, b| b.significance.total_cmp(&a.significance));
        }
    }

    /// The bars that end at `plume` in the prepared chip ([`BarSearch::prepare`]): of the
    /// directions all round the plume, the lines of the integration length that start at the
    /// plume's edge and whose mean contrast is highest among their neighbours', the
    /// [`PLUME_DIRECTIONS`] strongest (strongest first), each refined and measured as the
    /// search's. Err where no chip is prepared or no line has a contrast.
    pub fn measure_from(
        &self,
        plume: &Shape,
        config: &BarConfig,
    ) -> Result<heapless::Vec<Result<Bar, BarRefusal>, PLUME_DIRECTIONS>, BarRefusal> {
        let scale = self.scale.as_ref().ok_or(BarRefusal::NotPrepared)?;
        let directions = 2 * scale.directions();
        let line = |k: usize| {
            let angle = 2.0 * core::f32::consts::PI * k as f32 / directions as f32;
            let dir = ImagePoint::new(libm::cosf(angle), libm::sinf(angle));
            let centre = plume.centre + dir * (plume.reach_along(dir) + 0.5 * scale.length_px);
            (centre, dir)
        };
        // Each line's mean contrast, once (NaN where it leaves the grid, or where it leaves an
        // elongated plume across its axis).
        let mut contrast = [f32::NAN; 2 * MAX_DIRECTIONS];
        for (k, c) in contrast.iter_mut().take(directions).enumerate() {
            let (centre, dir) = line(k);
            if trails_along(plume, dir) {
                *c = self.line_contrast(centre, dir, scale).unwrap_or(f32::NAN);
            }
        }
        let contrast_of = |k: usize| contrast.get(k % directions).copied().unwrap_or(f32::NAN);
        // The strongest local maxima of the contrast round the plume, strongest first.
        let mut peaks: heapless::Vec<(f32, usize), PLUME_DIRECTIONS> = heapless::Vec::new();
        for k in 0..directions {
            let c = contrast_of(k);
            let neighbours = [contrast_of(k + directions - 1), contrast_of(k + 1)];
            if c.is_nan() || neighbours.iter().any(|n| *n > c) {
                continue;
            }
            let at = peaks
                .iter()
                .position(|(p, _)| c > *p)
                .unwrap_or(peaks.len());
            if at < PLUME_DIRECTIONS {
                if peaks.is_full() {
                    peaks.pop();
                }
                let _ = peaks.insert(at, (c, k));
            }
        }
        if peaks.is_empty() {
            return Err(BarRefusal::NoContrast);
        }
        Ok(peaks
            .iter()
            .map(|&(_, k)| {
                let (centre, dir) = line(k);
                self.measure_line_from(plume, centre, dir, scale, config)
            })
            .collect())
    }

    /// The bar along the line from `plume` through `centre` along `dir`, refined and measured
    /// as the search's, reaching on to the plume.
    fn measure_line_from(
        &self,
        plume: &Shape,
        centre: ImagePoint,
        dir: ImagePoint,
        scale: &Scale,
        config: &BarConfig,
    ) -> Result<Bar, BarRefusal> {
        let (centre, dir) = self.refine(centre, dir, scale);
        // The plume marks the tail, so a line that runs on beyond the body's length from it
        // (into a cloud or a filament past the nose) is the body over the integration length.
        let bar = match self.walk(centre, dir, scale, config) {
            Err(BarRefusal::TooLong) => {
                let half = 0.5 * scale.length_px;
                self.measured(centre, dir, (-half, half), scale)
            }
            measured => measured,
        }?;
        Ok(self.reaching(bar, plume, scale))
    }

    /// Measures the bar nearest the line through `centre` along `dir` in the prepared chip
    /// ([`BarSearch::prepare`]): its line refined as the search's, its ends, contrast and
    /// significance.
    pub fn measure(
        &self,
        centre: ImagePoint,
        dir: ImagePoint,
        config: &BarConfig,
    ) -> Result<Bar, BarRefusal> {
        let scale = self.scale.as_ref().ok_or(BarRefusal::NotPrepared)?;
        let (centre, dir) = self.refine(centre, dir, scale);
        self.walk(centre, dir, scale, config)
    }

    /// The block at column `c`, row `r`, or None outside the grid.
    fn block(&self, c: isize, r: isize) -> Option<f32> {
        grid_at(&self.blocks, self.cols, self.rows, c, r)
    }

    /// The blocks across the bar at `p` (chip px): on it and `flank_px` to either side along
    /// `normal` (None off the grid).
    fn section_at(&self, p: ImagePoint, normal: ImagePoint, flank_px: f32) -> Option<Section> {
        let cell = |q: ImagePoint| self.block_at(q);
        Some(Section {
            centre: cell(p)?,
            plus: cell(p + normal * flank_px)?,
            minus: cell(p - normal * flank_px)?,
        })
    }

    /// The blocks' value at chip point `q`, bilinear between block centres (None where a block
    /// it needs is off the grid).
    fn block_at(&self, q: ImagePoint) -> Option<f32> {
        if !q.is_finite() {
            return None;
        }
        let s = self.side as f32;
        let (u, v) = (q.x / s - 0.5, q.y / s - 0.5);
        let (c, r) = (libm::floorf(u), libm::floorf(v));
        let (wu, wv) = (u - c, v - r);
        let (c, r) = (c as isize, r as isize);
        let top = self.block(c, r)? * (1.0 - wu) + self.block(c + 1, r)? * wu;
        let bottom = self.block(c, r + 1)? * (1.0 - wu) + self.block(c + 1, r + 1)? * wu;
        Some(top * (1.0 - wv) + bottom * wv)
    }

    /// The mean contrast along the line through `centre` along `dir` over `length_px`, sampled a
    /// block apart (None where it leaves the grid).
    fn line_contrast(&self, centre: ImagePoint, dir: ImagePoint, scale: &Scale) -> Option<f32> {
        let (sum, on_grid, samples) = self.contrast_sum(centre, dir, scale);
        (on_grid == samples).then(|| sum / samples as f32)
    }

    /// The contrasts along the line through `centre` along `dir` over the integration length,
    /// sampled a block apart: their sum over the samples on the grid, how many those are, and
    /// how many samples there are.
    fn contrast_sum(
        &self,
        centre: ImagePoint,
        dir: ImagePoint,
        scale: &Scale,
    ) -> (f32, usize, usize) {
        let step = self.side as f32;
        let half_steps = ((0.5 * scale.length_px / step) as i32).max(1);
        let normal = dir.perpendicular();
        let (mut sum, mut on_grid) = (0.0f32, 0usize);
        for i in -half_steps..=half_steps {
            if let Some(c) =
                self.contrast_at(centre + dir * (i as f32 * step), normal, scale.flank_px)
            {
                sum += c;
                on_grid += 1;
            }
        }
        (sum, on_grid, (2 * half_steps + 1) as usize)
    }

    /// The line near the one through `centre` along `dir` (turned by up to a direction step of
    /// the search, moved by up to a block across) with the highest mean contrast: the search's
    /// directions and blocks are coarse.
    fn refine(
        &self,
        centre: ImagePoint,
        dir: ImagePoint,
        scale: &Scale,
    ) -> (ImagePoint, ImagePoint) {
        let step_rad = core::f32::consts::PI / scale.directions() as f32;
        let mut best = (centre, dir, f32::NEG_INFINITY);
        let angle = libm::atan2f(dir.y, dir.x);
        for turn in -4i8..=4 {
            let a = angle + f32::from(turn) * 0.25 * step_rad;
            let dir = ImagePoint::new(libm::cosf(a), libm::sinf(a));
            for shift in -2i8..=2 {
                let moved =
                    centre + dir.perpendicular() * (f32::from(shift) * 0.5 * self.side as f32);
                if let Some(c) = self.line_contrast(moved, dir, scale)
                    && c > best.2
                {
                    best = (moved, dir, c);
                }
            }
        }
        (best.0, best.1)
    }

    /// The bar's contrast at `p` ([`Section::contrast`]).
    fn contrast_at(&self, p: ImagePoint, normal: ImagePoint, flank_px: f32) -> Option<f32> {
        self.section_at(p, normal, flank_px).map(|s| s.contrast())
    }

    /// Sums along direction `dir`'s digital lines, then each block's response; the strongest,
    /// apart, join `peaks`.
    fn direction_peaks(
        &mut self,
        dir: ImagePoint,
        scale: &Scale,
        config: &BarConfig,
        peaks: &mut heapless::Vec<Bar, MAX_PEAKS>,
    ) {
        // Walk the grid's major coordinate `u` (x where the direction is nearer the x axis);
        // the minor one `v` steps by `slope` per block.
        let x_major = libm::fabsf(dir.x) >= libm::fabsf(dir.y);
        let (major, minor) = if x_major {
            (dir.x, dir.y)
        } else {
            (dir.y, dir.x)
        };
        let slope = minor / major;
        let (n_u, n_v) = if x_major {
            (self.cols, self.rows)
        } else {
            (self.rows, self.cols)
        };
        let side = self.side as f32;
        let half = ((scale.length_px * libm::fabsf(major) / (2.0 * side)) as usize).max(1);
        let window = 2 * half + 1;
        let flank = (libm::roundf(scale.flank_px / (side * libm::fabsf(major))) as usize).max(1);
        let index = |u: usize, v: usize| {
            if x_major {
                v * self.cols + u
            } else {
                u * self.cols + v
            }
        };
        let (blocks, lines, scatter) = (&self.blocks, &mut self.lines, &mut self.scatter);
        let (cols, rows) = (self.cols, self.rows);
        lines.iter_mut().for_each(|l| *l = f32::NAN);
        scatter.iter_mut().for_each(|v| *v = f32::NAN);
        let reach = libm::ceilf(libm::fabsf(slope) * n_u as f32) as isize + 1;
        for v0 in -reach..n_v as isize + reach {
            let v_at = |u: usize| v0 + libm::roundf(u as f32 * slope) as isize;
            let value = |u: usize| {
                let v = v_at(u);
                if x_major {
                    grid_at(blocks, cols, rows, u as isize, v)
                } else {
                    grid_at(blocks, cols, rows, v, u as isize)
                }
            };
            let (mut sum, mut squares, mut count) = (0.0f32, 0.0f32, 0usize);
            for lead in 0..n_u + half {
                if lead < n_u
                    && let Some(b) = value(lead)
                {
                    sum += b;
                    squares += b * b;
                    count += 1;
                }
                if let Some(trail) = lead.checked_sub(window)
                    && let Some(b) = value(trail)
                {
                    sum -= b;
                    squares -= b * b;
                    count -= 1;
                }
                let Some(u) = lead.checked_sub(half) else {
                    continue;
                };
                let Ok(v) = usize::try_from(v_at(u)) else {
                    continue;
                };
                if u < n_u && v < n_v && count == window {
                    let i = index(u, v);
                    if let (Some(l), Some(s)) = (lines.get_mut(i), scatter.get_mut(i)) {
                        let mean = sum / window as f32;
                        (*l, *s) = (sum, (squares / window as f32 - mean * mean).max(0.0));
                    }
                }
            }
        }
        let noise = self.block_sigma * libm::sqrtf(2.0 * window as f32);
        let threshold = config.threshold_sigma * noise;
        let block_variance = self.block_sigma * self.block_sigma;
        for v in flank..n_v.saturating_sub(flank) {
            for u in 0..n_u {
                let line = |v: usize| self.lines.get(index(u, v)).copied().unwrap_or(f32::NAN);
                let (minus, plus) = (line(v - flank), line(v + flank));
                // Both flanks must be on the grid (NaN: a line that leaves it).
                if minus.is_nan() || plus.is_nan() {
                    continue;
                }
                let response = line(v) - minus.max(plus);
                if response.is_nan() || response < threshold {
                    continue;
                }
                let (x, y) = if x_major { (u, v) } else { (v, u) };
                let centre = ImagePoint::new((x as f32 + 0.5) * side, (y as f32 + 0.5) * side);
                // Ranked against the scatter of the blocks along the smoother flank line as well
                // as the noise: terrain's or a cloud's texture makes strong responses, the sky
                // beside a body is even (the body's own line is not, where it is shorter).
                let scatter = |v: usize| self.scatter.get(index(u, v)).copied().unwrap_or(0.0);
                let texture = scatter(v - flank).min(scatter(v + flank));
                let peak = Bar {
                    centre,
                    dir,
                    half_length_px: 0.5 * scale.length_px,
                    contrast: response / window as f32,
                    significance: response / noise
                        * libm::sqrtf(block_variance / (block_variance + texture)),
                    plume_sigma: 0.0,
                };
                keep_peak(peaks, peak, scale);
            }
        }
    }

    /// Walks the bar through `centre` along `dir` both ways to its ends.
    fn walk(
        &self,
        centre: ImagePoint,
        dir: ImagePoint,
        scale: &Scale,
        config: &BarConfig,
    ) -> Result<Bar, BarRefusal> {
        let normal = dir.perpendicular();
        let step = self.side as f32;
        let at = |t: f32| ImagePoint::new(centre.x + t * dir.x, centre.y + t * dir.y);
        // The middle's contrast: the mean over the integration length.
        let (sum, count, _) = self.contrast_sum(centre, dir, scale);
        if count == 0 || sum.is_nan() || sum <= 0.0 {
            return Err(BarRefusal::NoContrast);
        }
        let middle = sum / count as f32;
        let (level, ceiling) = (config.end_fraction * middle, config.end_ceiling * middle);
        let max_steps = scale.max_steps(step);
        // A stretch below the level shorter than this is crossed (a filament, a cloud's edge).
        let gap = scale.gap_steps(step);
        // Each way: half a step beyond the last step at the level before `gap` below it.
        let end = |way: f32| -> Result<f32, BarRefusal> {
            let mut last = 0;
            for i in 1..=max_steps {
                let c = self
                    .contrast_at(at(way * i as f32 * step), normal, scale.flank_px)
                    .ok_or(BarRefusal::AtEdge)?;
                if c >= level && c <= ceiling {
                    last = i;
                } else if i - last >= gap {
                    return Ok(way * (last as f32 + 0.5) * step);
                }
            }
            Err(BarRefusal::TooLong)
        };
        let (ahead, behind) = (end(1.0)?, end(-1.0)?);
        let half_length_px = 0.5 * (ahead - behind);
        if half_length_px > 0.5 * scale.longest_px {
            return Err(BarRefusal::TooLong);
        }
        if half_length_px < config.min_bar_diameters * 0.5 * scale.diameter_px {
            return Err(BarRefusal::TooShort);
        }
        self.measured(centre, dir, (behind, ahead), scale)
    }

    /// The bar along the line through `centre` along `dir` between its ends `behind` and
    /// `ahead` (px along it): its contrast, significance and plume; refused where the chip
    /// does not hold the body's extremes beyond them.
    fn measured(
        &self,
        centre: ImagePoint,
        dir: ImagePoint,
        (behind, ahead): (f32, f32),
        scale: &Scale,
    ) -> Result<Bar, BarRefusal> {
        let normal = dir.perpendicular();
        let step = self.side as f32;
        let at = |t: f32| ImagePoint::new(centre.x + t * dir.x, centre.y + t * dir.y);
        let half_length_px = 0.5 * (ahead - behind);
        // The body's extremes may lie well beyond where its bar fades (fins widen it, a nose
        // tapers): `overhang_px` beyond each end must be in the chip.
        let clear = scale.overhang_px + step;
        let inside = |t: f32| self.contrast_at(at(t), normal, scale.flank_px).is_some();
        if !inside(ahead + clear) || !inside(behind - clear) {
            return Err(BarRefusal::AtEdge);
        }
        // Its contrast over the measured length, and how significant it is against the
        // contrast's own scatter along it (terrain's texture scatters more than the noise).
        let mid = 0.5 * (ahead + behind);
        let steps = ((half_length_px / step) as usize).min((MAX_WALK_SAMPLES - 1) / 2);
        let mut samples = [0.0f32; MAX_WALK_SAMPLES];
        let mut count = 0usize;
        for i in -(steps as i32)..=steps as i32 {
            let c = self.contrast_at(at(mid + i as f32 * step), normal, scale.flank_px);
            if let (Some(c), Some(slot)) = (c, samples.get_mut(count)) {
                *slot = c;
                count += 1;
            }
        }
        let samples = samples.get_mut(..count).unwrap_or_default();
        let contrast = samples.iter().sum::<f32>() / count.max(1) as f32;
        let scatter = robust_sd(samples, contrast).max(self.contrast_noise());
        let mid_point = at(mid);
        let glow = |way: f32| self.glow_beyond(mid_point, dir, way * half_length_px, way, scale);
        Ok(Bar {
            centre: mid_point,
            dir,
            half_length_px,
            contrast,
            significance: contrast / scatter * libm::sqrtf(count as f32),
            plume_sigma: glow(1.0).max(glow(-1.0)),
        })
    }

    /// The strongest glow of the other polarity beyond `end_t` px along the line through
    /// `centre` along `dir`, going `way` (+1 or -1) for a gap's length
    /// ([`BarConfig::max_gap_diameters`]), in noise sigmas of one block's contrast.
    fn glow_beyond(
        &self,
        centre: ImagePoint,
        dir: ImagePoint,
        end_t: f32,
        way: f32,
        scale: &Scale,
    ) -> f32 {
        let step = self.side as f32;
        let normal = dir.perpendicular();
        let glow = (1..=scale.gap_steps(step))
            .filter_map(|i| {
                let t = end_t + way * i as f32 * step;
                self.section_at(centre + dir * t, normal, scale.flank_px)
            })
            .fold(0.0f32, |m, s| m.max(s.glow()));
        glow / self.contrast_noise()
    }

    /// The noise standard deviation of one block's contrast against its two flanks
    /// ([`Section::contrast`]), grey levels.
    fn contrast_noise(&self) -> f32 {
        self.block_sigma * libm::sqrtf(1.5)
    }

    /// `bar` reaching on to the `plume`'s edge where a stretch of its tail faded under the
    /// plume's glow parts them (no farther than the body can look, and only where its line
    /// passes within a diameter of the plume's extent across it), with the plume's glow measured
    /// beyond it or at the plume's centroid, whichever is the stronger: the plume marks the
    /// tail.
    fn reaching(&self, bar: Bar, plume: &Shape, scale: &Scale) -> Bar {
        let to_plume = plume.centre - bar.centre;
        let normal = bar.dir.perpendicular();
        let (along, across) = (to_plume.dot(bar.dir), to_plume.dot(normal));
        let way = if along >= 0.0 { 1.0 } else { -1.0 };
        let gap = libm::fabsf(along) - plume.reach_along(bar.dir) - bar.half_length_px;
        let on_line = libm::fabsf(across) <= scale.diameter_px + plume.reach_along(normal);
        if !(on_line
            && trails_along(plume, bar.dir)
            && gap > 0.0
            && 2.0 * bar.half_length_px + gap <= scale.longest_px)
        {
            return bar;
        }
        let half_length_px = bar.half_length_px + 0.5 * gap;
        let centre = bar.centre + bar.dir * (way * 0.5 * gap);
        // The glow beyond the reached end, or at the plume's centroid (the line may pass it
        // aside: a plume blown off the axis, a line refined a degree or two off it).
        let at_plume = self
            .section_at(plume.centre, normal, scale.flank_px)
            .map_or(0.0, |s| s.glow() / self.contrast_noise());
        let glow = self
            .glow_beyond(centre, bar.dir, way * half_length_px, way, scale)
            .max(at_plume);
        Bar {
            centre,
            half_length_px,
            plume_sigma: bar.plume_sigma.max(glow),
            ..bar
        }
    }
}

/// The blocks across a bar at one place along it (the body's polarity positive).
#[derive(Debug, Clone, Copy)]
struct Section {
    centre: f32,
    plus: f32,
    minus: f32,
}

impl Section {
    /// The bar's contrast: its block less the mean of the two flanks' (a cloud band beside the
    /// body takes half of it, not all).
    fn contrast(&self) -> f32 {
        self.centre - 0.5 * (self.plus + self.minus)
    }

    /// How far the block lies beyond both flanks on the other polarity's side (a plume's glow;
    /// the sky beside terrain lies beyond one flank only), or 0.
    fn glow(&self) -> f32 {
        (self.plus.min(self.minus) - self.centre).max(0.0)
    }
}

/// Largest number of contrast samples along a measured bar.
const MAX_WALK_SAMPLES: usize = 256;

/// A robust standard deviation of `values` about `mean`: 1.4826 times the median absolute
/// deviation (reorders `values`).
fn robust_sd(values: &mut [f32], mean: f32) -> f32 {
    values.iter_mut().for_each(|v| *v = libm::fabsf(*v - mean));
    let mid = values.len() / 2;
    if values.is_empty() {
        return 0.0;
    }
    let (_, median, _) = values.select_nth_unstable_by(mid, f32::total_cmp);
    1.4826 * *median
}

/// The value at column `c`, row `r` of a grid `cols` x `rows` stored by rows, or None outside.
fn grid_at(grid: &[f32], cols: usize, rows: usize, c: isize, r: isize) -> Option<f32> {
    let (c, r) = (usize::try_from(c).ok()?, usize::try_from(r).ok()?);
    (c < cols && r < rows)
        .then(|| grid.get(r * cols + c).copied())
        .flatten()
}

impl Scale {
    /// The most steps of `step` px a walk takes from a bar's middle each way.
    fn max_steps(&self, step: f32) -> i32 {
        (0.5 * self.longest_px / step) as i32 + 2
    }

    /// A gap's length ([`BarConfig::max_gap_diameters`]) in steps of `step` px.
    fn gap_steps(&self, step: f32) -> i32 {
        (libm::ceilf(self.gap_px / step) as i32).clamp(2, self.max_steps(step).max(2))
    }

    /// The directions searched: a step of about a diameter over the integration length.
    fn directions(&self) -> usize {
        ((core::f32::consts::PI * self.length_px / self.diameter_px) as usize)
            .clamp(4, MAX_DIRECTIONS)
    }
}

/// The search's lengths for `expected`.
fn scale_of(expected: &ExpectedBody, longest_px: f32, config: &BarConfig) -> Scale {
    let diameter_px = expected.diameter_px;
    Scale {
        diameter_px,
        overhang_px: expected
            .span_px
            .max(config.overhang_lengths * expected.length_px),
        length_px: (config.length_fraction * expected.length_px)
            .max(config.min_length_diameters * diameter_px),
        flank_px: config.flank_diameters * diameter_px,
        longest_px,
        gap_px: config.max_gap_diameters * diameter_px,
    }
}

/// The smallest |cosine| between two peaks' directions taken as one bar's (about 20 degrees:
/// its neighbouring directions respond too).
const PEAK_PARALLEL_COS: f32 = 0.94;

/// The smallest |cosine| between a bar and the axis of a plume of the body's polarity at its
/// end for the two to be a body and its plume (about 20 degrees: a short plume's axis is coarse).
pub const PLUME_ALIGNED_COS: f32 = 0.94;

/// A plume at least this elongated (its shape's major over minor standard deviation) trails
/// the body along its own axis.
pub const PLUME_MIN_ELONGATION: f32 = 1.5;

/// Whether a body along `dir` can end at `plume`: a plume that is round, or elongated along
/// `dir` (within [`PLUME_ALIGNED_COS`]; a cloud band ending at it across its axis is not the
/// body).
fn trails_along(plume: &Shape, dir: ImagePoint) -> bool {
    plume.elongation() < PLUME_MIN_ELONGATION
        || libm::fabsf(plume.axis.dot(dir)) >= PLUME_ALIGNED_COS
}

/// The smallest |cosine| between two lines taken as parallel (about 10 degrees).
pub const PARALLEL_COS: f32 = 0.985;

/// Whether two measured bars are one: parallel ([`PARALLEL_COS`]), their middles within a
/// diameter across and a half-length along.
fn same_bar(a: &Bar, b: &Bar, diameter_px: f32) -> bool {
    let (dx, dy) = (b.centre.x - a.centre.x, b.centre.y - a.centre.y);
    let d = ImagePoint::new(dx, dy);
    libm::fabsf(a.dir.dot(b.dir)) >= PARALLEL_COS
        && libm::fabsf(d.dot(a.dir.perpendicular())) <= diameter_px
        && libm::fabsf(d.dot(a.dir)) <= a.half_length_px.max(b.half_length_px)
}

/// Adds `peak` to `peaks` unless a stronger one lies on the same bar (within half the
/// integration length, about parallel); a weaker one there is replaced; when full, the weakest
/// goes.
fn keep_peak(peaks: &mut heapless::Vec<Bar, MAX_PEAKS>, peak: Bar, scale: &Scale) {
    let near = |b: &Bar| {
        let (dx, dy) = (peak.centre.x - b.centre.x, peak.centre.y - b.centre.y);
        let close = libm::sqrtf(dx * dx + dy * dy) <= 0.5 * scale.length_px;
        close && libm::fabsf(b.dir.dot(peak.dir)) >= PEAK_PARALLEL_COS
    };
    if let Some(i) = peaks.iter().position(near) {
        if let Some(b) = peaks.get_mut(i)
            && peak.significance > b.significance
        {
            *b = peak;
        }
        return;
    }
    if peaks.push(peak).is_err() {
        let weakest = peaks
            .iter()
            .enumerate()
            .min_by(|a, b| a.1.significance.total_cmp(&b.1.significance))
            .map(|(i, b)| (i, b.significance));
        if let Some((i, s)) = weakest
            && peak.significance > s
            && let Some(b) = peaks.get_mut(i)
        {
            *b = peak;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::segment::select::UNIFORM_BAR_HALF_SDS;
    use crate::testing::noise_sequence;

    const SIDE: usize = 256;

    /// The fraction of the pixel at (`x`, `y`) within `half_width` px of the segment from `a` to
    /// `b` (4 x 4 samples).
    fn coverage(x: usize, y: usize, a: ImagePoint, b: ImagePoint, half_width: f32) -> f32 {
        let d = b - a;
        let length = d.norm();
        let dir = d * (1.0 / length);
        let mut inside = 0;
        for k in 0..16 {
            let p = ImagePoint::new(
                x as f32 + (k % 4) as f32 * 0.25 - 0.375,
                y as f32 + (k / 4) as f32 * 0.25 - 0.375,
            );
            let q = p - a;
            let (along, across) = (q.dot(dir), q.dot(dir.perpendicular()));
            if (0.0..=length).contains(&along) && libm::fabsf(across) <= half_width {
                inside += 1;
            }
        }
        inside as f32 / 16.0
    }

    /// A sky of 120 grey levels with noise 3, a faint dark body 7 px wide and 110 px long at 35
    /// deg through the centre (12 grey levels, 4 sigma), a bright plume beyond its tail, a dark
    /// cloud band across the chip and a dark filament 2 px wide across the body.
    fn cluttered_chip() -> ([u8; SIDE * SIDE], ImagePoint, ImagePoint) {
        chip_with(12.0, 12.0, 1.0)
    }

    /// [`cluttered_chip`] with the body and the filament `body` and `filament` grey levels dark,
    /// the filament `filament_half_width` px to either side of its line.
    fn chip_with(
        body: f32,
        filament: f32,
        filament_half_width: f32,
    ) -> ([u8; SIDE * SIDE], ImagePoint, ImagePoint) {
        let dir = ImagePoint::new(libm::cosf(0.61), libm::sinf(0.61));
        let centre = ImagePoint::new(128.0, 128.0);
        let (nose, tail) = (centre + dir * 55.0, centre - dir * 55.0);
        let plume = tail - dir * 8.0;
        let (f0, f1) = (ImagePoint::new(60.0, 200.0), ImagePoint::new(170.0, 40.0));
        let mut noise = noise_sequence(SIDE * SIDE, 11);
        let mut data = [0u8; SIDE * SIDE];
        for (i, v) in data.iter_mut().enumerate() {
            let (x, y) = (i % SIDE, i / SIDE);
            let band = if (40..60).contains(&y) { -15.0 } else { 0.0 };
            let (px, py) = (x as f32 - plume.x, y as f32 - plume.y);
            let glow = 60.0 * libm::expf(-(px * px + py * py) / 32.0);
            let value = 120.0 + band + glow
                - body * coverage(x, y, tail, nose, 3.5)
                - filament * coverage(x, y, f0, f1, filament_half_width)
                + 3.0 * noise.next().unwrap_or(0.0);
            *v = value.clamp(0.0, 255.0) as u8;
        }
        (data, centre, dir)
    }

    /// The bar along the strongest line from `plume` ([`BarSearch::measure_from`]).
    fn strongest_from(search: &BarSearch<4096>, plume: &Shape, config: &BarConfig) -> Bar {
        let bars = search.measure_from(plume, config).expect("lines");
        bars.first().copied().expect("a line").expect("a bar")
    }

    fn expected() -> ExpectedBody {
        ExpectedBody {
            diameter_px: 7.0,
            span_px: 7.0,
            length_px: 120.0,
        }
    }

    /// The faint body is the strongest bar: found through the filament, with its plume, and
    /// along its axis; the band across the chip runs into the edge and is no bar.
    #[test]
    fn finds_a_faint_body_among_clutter() {
        let (data, centre, dir) = cluttered_chip();
        let chip = ChipView::gray8(&data, SIDE, SIDE, SIDE, 0, 0).unwrap();
        let config = BarConfig::DEFAULT;
        let mut search: BarSearch<4096> = BarSearch::new();
        assert!(search.prepare(&chip, 3.0, -1.0, &expected(), 160.0, &config));
        let mut bars = heapless::Vec::new();
        search.search(&config, None, &mut bars);
        let body = bars.first().expect("a bar");
        let along = (body.centre - centre).dot(dir);
        let across = (body.centre - centre).dot(dir.perpendicular());
        assert!(
            libm::fabsf(body.dir.dot(dir)) > libm::cosf(6f32.to_radians()),
            "{body:?}"
        );
        assert!(
            libm::fabsf(across) < 3.0 && libm::fabsf(along) < 20.0,
            "{body:?}"
        );
        assert!((35.0..=62.0).contains(&body.half_length_px), "{body:?}");
        assert!(body.plume_sigma >= config.plume_min_sigma, "{body:?}");
        assert!(
            body.significance >= 3.0 * config.threshold_sigma,
            "{body:?}"
        );
        let band = search.measure(
            ImagePoint::new(128.0, 50.0),
            ImagePoint::new(1.0, 0.0),
            &config,
        );
        assert!(
            matches!(band, Err(BarRefusal::AtEdge | BarRefusal::TooLong)),
            "{band:?}"
        );
    }

    /// Where a wide filament outshines a fainter body (8 grey levels, under 3 sigma), the bar
    /// measured from the plume is the body's, and the search given the plume has it.
    #[test]
    fn the_bar_ending_at_the_plume_is_the_body() {
        let (data, centre, dir) = chip_with(8.0, 16.0, 3.5);
        let chip = ChipView::gray8(&data, SIDE, SIDE, SIDE, 0, 0).unwrap();
        let config = BarConfig::DEFAULT;
        let mut search: BarSearch<4096> = BarSearch::new();
        assert!(search.prepare(&chip, 3.0, -1.0, &expected(), 160.0, &config));
        // The glow's Gaussian has a sigma of 4 px about a point 63 px behind the centre.
        let plume = Shape {
            centre: centre - dir * 63.0,
            axis: ImagePoint::new(1.0, 0.0),
            major_sd: 4.0,
            minor_sd: 4.0,
        };
        let is_body = |bar: &Bar| {
            let (along, across) = (
                (bar.centre - centre).dot(dir),
                (bar.centre - centre).dot(dir.perpendicular()),
            );
            libm::fabsf(bar.dir.dot(dir)) > libm::cosf(6f32.to_radians())
                && libm::fabsf(across) < 3.0
                && libm::fabsf(along) < 20.0
                && (35.0..=62.0).contains(&bar.half_length_px)
                && bar.plume_sigma >= config.plume_min_sigma
        };
        let from_plume = strongest_from(&search, &plume, &config);
        assert!(is_body(&from_plume), "{from_plume:?}");
        let mut bars = heapless::Vec::new();
        search.search(&config, Some(&plume), &mut bars);
        assert!(bars.iter().any(is_body), "{bars:?}");
    }

    /// A filament twice as dark as the faint body (16 grey levels, 7 px wide) runs 100 px
    /// down from its plume: the line of highest contrast from the plume is the
    /// filament's, the body's comes next, and the search given the plume has the body's bar.
    #[test]
    fn the_bars_from_the_plume_hold_the_body_beside_a_darker_filament() {
        let (mut data, centre, dir) = chip_with(8.0, 0.0, 1.0);
        let plume_at = centre - dir * 63.0;
        let spur_end = plume_at + ImagePoint::new(0.0, 1.0) * 100.0;
        for (i, v) in data.iter_mut().enumerate() {
            let (x, y) = (i % SIDE, i / SIDE);
            let dark = 16.0 * coverage(x, y, plume_at, spur_end, 3.5);
            *v = (f32::from(*v) - dark).clamp(0.0, 255.0) as u8;
        }
        let chip = ChipView::gray8(&data, SIDE, SIDE, SIDE, 0, 0).unwrap();
        let config = BarConfig::DEFAULT;
        let mut search: BarSearch<4096> = BarSearch::new();
        assert!(search.prepare(&chip, 3.0, -1.0, &expected(), 160.0, &config));
        let plume = Shape {
            centre: plume_at,
            axis: ImagePoint::new(1.0, 0.0),
            major_sd: 4.0,
            minor_sd: 4.0,
        };
        let is_body = |bar: &Bar| {
            let across = (bar.centre - centre).dot(dir.perpendicular());
            libm::fabsf(bar.dir.dot(dir)) > libm::cosf(6f32.to_radians())
                && libm::fabsf(across) < 3.0
        };
        let strongest = strongest_from(&search, &plume, &config);
        assert!(
            libm::fabsf(strongest.dir.y) > libm::cosf(6f32.to_radians()),
            "the filament's: {strongest:?}"
        );
        let ranked = search.measure_from(&plume, &config).expect("lines");
        assert!(ranked.iter().flatten().any(is_body), "{ranked:?}");
        let mut bars = heapless::Vec::new();
        search.search(&config, Some(&plume), &mut bars);
        assert!(bars.iter().any(is_body), "{bars:?}");
        // A plume elongated along the body's axis trails the body: the filament, 55 degrees
        // across that axis, does not end at it (no line from it is measured), and the
        // strongest line from it is the body's.
        let trailing = Shape {
            axis: dir,
            major_sd: 8.0,
            minor_sd: 3.0,
            ..plume
        };
        let strongest = strongest_from(&search, &trailing, &config);
        assert!(is_body(&strongest), "{strongest:?}");
        let ranked = search.measure_from(&trailing, &config).expect("lines");
        assert!(
            ranked
                .iter()
                .flatten()
                .all(|b| libm::fabsf(b.dir.y) < libm::cosf(20f32.to_radians())),
            "{ranked:?}"
        );
    }

    /// A faint body (8 grey levels, 110 px along `DIR` through `CENTRE`) whose last 20 px fade
    /// into the wide glow of a plume 12 px beyond its tail and `aside_px` off its line, and,
    /// where `runs_on`, a filament as dark running on from its nose along its line for 70 px.
    fn fading_body(runs_on: bool, aside_px: f32) -> [u8; SIDE * SIDE] {
        let (centre, dir) = fading_line();
        let (nose, tail) = (centre + dir * 55.0, centre - dir * 55.0);
        let faded = tail + dir * 20.0;
        let beyond = nose + dir * if runs_on { 70.0 } else { 0.0 };
        let plume = tail - dir * 12.0 + dir.perpendicular() * aside_px;
        let mut noise = noise_sequence(SIDE * SIDE, 7);
        let mut data = [0u8; SIDE * SIDE];
        for (i, v) in data.iter_mut().enumerate() {
            let (x, y) = (i % SIDE, i / SIDE);
            let (px, py) = (x as f32 - plume.x, y as f32 - plume.y);
            let glow = 60.0 * libm::expf(-(px * px + py * py) / 72.0);
            let value = 120.0 + glow - 8.0 * coverage(x, y, faded, beyond, 3.5)
                + 3.0 * noise.next().unwrap_or(0.0);
            *v = value.clamp(0.0, 255.0) as u8;
        }
        data
    }

    /// The fading body's middle and direction.
    fn fading_line() -> (ImagePoint, ImagePoint) {
        (
            ImagePoint::new(110.0, 120.0),
            ImagePoint::new(libm::cosf(0.3), libm::sinf(0.3)),
        )
    }

    /// Walked from its middle, the fading body ends short of its plume (or, running on into
    /// the filament, is too long); measured from the plume, it reaches on to the plume's edge,
    /// its plume measured there.
    #[test]
    fn the_plume_holds_a_body_that_fades_at_its_tail() {
        let (centre, dir) = fading_line();
        let plume = centre - dir * 67.0;
        let glow = Shape {
            centre: plume,
            axis: ImagePoint::new(1.0, 0.0),
            major_sd: 4.0,
            minor_sd: 4.0,
        };
        // The plume's edge: 1.732 sigmas of its shape from its centre, px along the body.
        let edge = (plume - centre).dot(dir) + UNIFORM_BAR_HALF_SDS * 4.0;
        let tail_end = |bar: &Bar| (bar.centre - centre).dot(dir) - bar.half_length_px;
        let config = BarConfig::DEFAULT;
        for runs_on in [false, true] {
            let data = fading_body(runs_on, 0.0);
            let chip = ChipView::gray8(&data, SIDE, SIDE, SIDE, 0, 0).unwrap();
            let mut search: BarSearch<4096> = BarSearch::new();
            assert!(search.prepare(&chip, 3.0, -1.0, &expected(), 160.0, &config));
            match search.measure(centre, dir, &config) {
                Ok(walked) if !runs_on => {
                    assert!(tail_end(&walked) > edge + 10.0, "{walked:?}");
                    assert!(walked.plume_sigma < config.plume_min_sigma, "{walked:?}");
                }
                walked => assert_eq!(walked, Err(BarRefusal::TooLong), "runs on {runs_on}"),
            }
            let bar = strongest_from(&search, &glow, &config);
            assert!(
                libm::fabsf(bar.dir.dot(dir)) > libm::cosf(6f32.to_radians()),
                "{bar:?}"
            );
            assert!(libm::fabsf(tail_end(&bar) - edge) < 4.0, "{edge} {bar:?}");
            assert!(bar.plume_sigma >= config.plume_min_sigma, "{bar:?}");
        }
    }

    /// A plume whose glow lies a diameter and more off the body's line (blown aside, or the
    /// body's line refined a little off it) still marks the tail: measured from the plume, the
    /// body reaches on to it, the plume's glow measured at its centroid.
    #[test]
    fn a_plume_beside_the_line_still_marks_the_tail() {
        let (centre, dir) = fading_line();
        let aside = 9.0;
        let glow = Shape {
            centre: centre - dir * 67.0 + dir.perpendicular() * aside,
            axis: ImagePoint::new(1.0, 0.0),
            major_sd: 4.0,
            minor_sd: 4.0,
        };
        let config = BarConfig::DEFAULT;
        let data = fading_body(false, aside);
        let chip = ChipView::gray8(&data, SIDE, SIDE, SIDE, 0, 0).unwrap();
        let mut search: BarSearch<4096> = BarSearch::new();
        assert!(search.prepare(&chip, 3.0, -1.0, &expected(), 160.0, &config));
        let bar = strongest_from(&search, &glow, &config);
        assert!(
            libm::fabsf(bar.dir.dot(dir)) > libm::cosf(6f32.to_radians()),
            "{bar:?}"
        );
        assert!(bar.plume_sigma >= config.plume_min_sigma, "{bar:?}");
        // Walked from its middle the same body has no plume; the search given the plume keeps
        // the bar that has one.
        let walked = search.measure(centre, dir, &config).expect("bar");
        assert!(walked.plume_sigma < config.plume_min_sigma, "{walked:?}");
        let mut bars = heapless::Vec::new();
        search.search(&config, Some(&glow), &mut bars);
        assert!(
            bars.iter()
                .any(|b| libm::fabsf(b.dir.dot(dir)) > 0.99
                    && b.plume_sigma >= config.plume_min_sigma),
            "{bars:?}"
        );
    }

    /// A body that could not be seen whole in the chip (a range 1e-30 m away) is not searched
    /// for, and nothing runs long; a bar through a short spot is too short.
    #[test]
    fn huge_bodies_and_short_spots_are_refused() {
        let (data, _, _) = cluttered_chip();
        let chip = ChipView::gray8(&data, SIDE, SIDE, SIDE, 0, 0).unwrap();
        let config = BarConfig::DEFAULT;
        let mut search: BarSearch<4096> = BarSearch::new();
        let huge = ExpectedBody {
            diameter_px: 1e30,
            span_px: 2e30,
            length_px: 1e31,
        };
        assert!(!search.prepare(&chip, 3.0, -1.0, &huge, 1e32, &config));
        let mut spot = [120u8; SIDE * SIDE];
        for y in 124..132 {
            for x in 124..132 {
                spot[y * SIDE + x] = 60;
            }
        }
        let chip = ChipView::gray8(&spot, SIDE, SIDE, SIDE, 0, 0).unwrap();
        assert!(search.prepare(&chip, 3.0, -1.0, &expected(), 160.0, &config));
        let short = search.measure(
            ImagePoint::new(128.0, 128.0),
            ImagePoint::new(1.0, 0.0),
            &config,
        );
        assert_eq!(short, Err(BarRefusal::TooShort));
    }

    /// A grid too small for any chip, or a body of no size, gives no search.
    #[test]
    fn no_search_without_a_grid_or_a_size() {
        let (data, _, _) = cluttered_chip();
        let chip = ChipView::gray8(&data, SIDE, SIDE, SIDE, 0, 0).unwrap();
        let config = BarConfig::DEFAULT;
        let mut tiny: BarSearch<4> = BarSearch::new();
        assert!(!tiny.prepare(&chip, 3.0, -1.0, &expected(), 160.0, &config));
        let mut bars = heapless::Vec::new();
        tiny.search(&config, None, &mut bars);
        assert!(bars.is_empty());
        let mut search: BarSearch<4096> = BarSearch::new();
        let none = ExpectedBody {
            diameter_px: f32::NAN,
            ..expected()
        };
        assert!(!search.prepare(&chip, 3.0, -1.0, &none, 160.0, &config));
        assert!(
            search
                .measure(
                    ImagePoint::new(1.0, 1.0),
                    ImagePoint::new(1.0, 0.0),
                    &config
                )
                .is_err()
        );
    }
}
