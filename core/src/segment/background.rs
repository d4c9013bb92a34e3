//! The sky background model and the noise estimate.
//!
//! The chip is cut into [`BACKGROUND_TILE`]-pixel tiles; each tile's median is its background
//! level (robust to a target covering less than half of it), and the background at any pixel is
//! the bilinear interpolation between tile centres, which follows sky gradients and clouds larger
//! than a tile. The noise is the robust standard deviation of horizontal neighbour differences,
//! which background gradients do not inflate.

use crate::capacity::{BACKGROUND_TILE, MAX_CHIP_SIDE, MAX_TILES_PER_SIDE, NOISE_SAMPLES};
use crate::chip::ChipView;
use crate::extremes::{Axis, row_span};
use crate::math::bilinear_blend;
use crate::segment::corridor::{Corridor, CorridorShape};
use crate::segment::terrain::{Horizon, TerrainConfig};

/// Smallest noise standard deviation reported, grey levels (the quantization floor).
const MIN_SIGMA: f32 = 0.3;

/// A region of the chip left out of the background: within `half_length` px of `axis.centre`
/// along the axis and `half_width` px across it (a detected body and its blur).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Region {
    /// The region's centre line.
    pub axis: Axis,
    /// Half its extent along the axis, px.
    pub half_length: f32,
    /// Half its extent across the axis, px.
    pub half_width: f32,
}

impl Region {
    /// Whether the chip point (`x`, `y`) lies in the region.
    pub fn contains(&self, x: f32, y: f32) -> bool {
        let (along, across) = self.axis.local(x, y);
        libm::fabsf(along) <= self.half_length && libm::fabsf(across) <= self.half_width
    }
}

/// Background levels per tile and the chip's noise level.
#[derive(Clone)]
pub struct Background {
    width: usize,
    height: usize,
    tiles_x: usize,
    tiles_y: usize,
    levels: [f32; MAX_TILES_PER_SIDE * MAX_TILES_PER_SIDE],
    /// Each tile's lowest and highest pixel value, grey levels, as its histogram in
    /// [`Background::estimate`] read them (for a 16-bit chip, to the edges of the coarse bins);
    /// `(0, u16::MAX)` where no chip was estimated.
    ranges: [(u16, u16); MAX_TILES_PER_SIDE * MAX_TILES_PER_SIDE],
    columns: AxisTable,
    rows: AxisTable,
    sigma: f32,
    /// The sky measured along the body, where the tiles do not follow it ([`corridor`]).
    ///
    /// [`corridor`]: crate::segment::corridor
    corridor: Option<Corridor>,
    /// Whether [`Background::estimate_terrain`] found terrain in the chip.
    terrain: bool,
}

/// The interpolation along one axis at every pixel of the chip, tabulated once per chip so that
/// the per-pixel background costs two lookups: `t0[p]`, `t1[p]` and `w[p]` are
/// [`axis_weights`] at pixel `p`.
#[derive(Clone)]
struct AxisTable {
    t0: [u8; MAX_CHIP_SIDE],
    t1: [u8; MAX_CHIP_SIDE],
    w: [f32; MAX_CHIP_SIDE],
    len: usize,
    /// Each tile's centre along the axis, px ([`tile_centre`]).
    centres: [f32; MAX_TILES_PER_SIDE],
    /// The tiles and the axis's size the table holds (None before the first chip): a mount's
    /// chips are all of one size, so the table is worked out once.
    filled_for: Option<(usize, usize)>,
}

// Tile indices are stored as u8.
const _: () = assert!(MAX_TILES_PER_SIDE <= 256);

impl AxisTable {
    const fn new() -> Self {
        AxisTable {
            t0: [0; MAX_CHIP_SIDE],
            t1: [0; MAX_CHIP_SIDE],
            w: [0.0; MAX_CHIP_SIDE],
            len: 0,
            centres: [0.0; MAX_TILES_PER_SIDE],
            filled_for: None,
        }
    }

    /// Tabulates [`axis_weights`] for the pixels of an axis of `size` px and `tiles` tiles
    /// (nothing to do where it holds them already).
    fn fill(&mut self, tiles: usize, size: usize) {
        if self.filled_for == Some((tiles, size)) {
            return;
        }
        self.filled_for = Some((tiles, size));
        for (t, centre) in self.centres.iter_mut().enumerate().take(tiles) {
            *centre = tile_centre(t, size);
        }
        self.len = size.min(MAX_CHIP_SIDE);
        for p in 0..self.len {
            let (t0, t1, w) = axis_weights(p as f32, tiles, size);
            if let (Some(a), Some(b), Some(c)) =
                (self.t0.get_mut(p), self.t1.get_mut(p), self.w.get_mut(p))
            {
                (*a, *b, *c) = (t0 as u8, t1 as u8, w);
            }
        }
    }

    /// The weights at pixel `p`, when the table has it.
    #[inline]
    fn get(&self, p: usize) -> Option<(usize, usize, f32)> {
        if p >= self.len {
            return None;
        }
        Some((
            usize::from(*self.t0.get(p)?),
            usize::from(*self.t1.get(p)?),
            *self.w.get(p)?,
        ))
    }

    /// The weights at position `p`, px: from the table at a pixel, else computed.
    #[inline]
    fn weights(&self, p: f32, tiles: usize, size: usize) -> (usize, usize, f32) {
        let pixel = p as usize;
        if pixel as f32 == p {
            self.at_pixel(pixel, tiles, size)
        } else {
            axis_weights(p, tiles, size)
        }
    }

    /// The weights at pixel `p`: from the table where it has it, else computed.
    #[inline]
    fn at_pixel(&self, p: usize, tiles: usize, size: usize) -> (usize, usize, f32) {
        self.get(p)
            .unwrap_or_else(|| axis_weights(p as f32, tiles, size))
    }
}

impl Default for Background {
    fn default() -> Self {
        Self::new()
    }
}

impl Background {
    /// An empty model.
    pub const fn new() -> Self {
        Background {
            width: 0,
            height: 0,
            tiles_x: 0,
            tiles_y: 0,
            levels: [0.0; MAX_TILES_PER_SIDE * MAX_TILES_PER_SIDE],
            ranges: [(0, u16::MAX); MAX_TILES_PER_SIDE * MAX_TILES_PER_SIDE],
            columns: AxisTable::new(),
            rows: AxisTable::new(),
            sigma: MIN_SIGMA,
            corridor: None,
            terrain: false,
        }
    }

    /// Estimates the background and noise of a chip.
    pub fn estimate(&mut self, chip: &ChipView) {
        self.width = chip.width();
        self.height = chip.height();
        self.tiles_x = self.width.div_ceil(BACKGROUND_TILE).min(MAX_TILES_PER_SIDE);
        self.tiles_y = self
            .height
            .div_ceil(BACKGROUND_TILE)
            .min(MAX_TILES_PER_SIDE);
        self.columns.fill(self.tiles_x, self.width);
        self.rows.fill(self.tiles_y, self.height);
        let mut histogram = Histogram::new();
        for ty in 0..self.tiles_y {
            for tx in 0..self.tiles_x {
                let tile = tile_median(chip, self.tile_rect(tx, ty), EVERY_PIXEL, &mut histogram);
                let index = ty * self.tiles_x + tx;
                if let (Some(level), Some(range)) =
                    (self.levels.get_mut(index), self.ranges.get_mut(index))
                {
                    (*level, *range) = (tile.level, tile.range);
                }
            }
        }
        self.sigma = self.noise_sigma_of(chip);
        self.corridor = None;
        self.terrain = false;
    }

    /// Looks for terrain entering the chip from its lower edge ([`Horizon::find`], against the
    /// sky of the top row's tiles) and, where there is some, estimates again every tile it
    /// reaches from its pixels more than [`TerrainConfig::margin_px`] above the horizon; a tile
    /// with less than a quarter of its pixels left takes the level of the tile above it (the
    /// sky carried down over the terrain, which then stands out whole). Returns whether the
    /// chip has terrain.
    pub fn estimate_terrain(&mut self, chip: &ChipView, config: &TerrainConfig) -> bool {
        let (tiles_x, tiles_y) = (self.tiles_x, self.tiles_y);
        if tiles_y < 2 || tiles_x == 0 {
            return false;
        }
        // The top row's median (a copy: the median reorders), and the bottom row in place.
        let mut top_row = [0.0f32; MAX_TILES_PER_SIDE];
        let (Some(top), Some(levels_top)) =
            (top_row.get_mut(..tiles_x), self.levels.get(..tiles_x))
        else {
            return false;
        };
        top.copy_from_slice(levels_top);
        let (_, sky, _) = top.select_nth_unstable_by(tiles_x / 2, f32::total_cmp);
        let bottom_start = (tiles_y - 1) * tiles_x;
        let bottom = self
            .levels
            .get(bottom_start..bottom_start + tiles_x)
            .unwrap_or_default();
        // Only here: the tiles keep what it tells.
        let mut horizon = Horizon::new();
        if !horizon.find(chip, *sky, self.sigma, (bottom, BACKGROUND_TILE), config) {
            return false;
        }
        self.terrain = true;
        let margin = usize::from(config.margin_px);
        let sky_pixel = |x: usize, y: usize| !horizon.covers(x, y, margin);
        let mut histogram = Histogram::new();
        for ty in 0..tiles_y {
            for tx in 0..tiles_x {
                let rect = self.tile_rect(tx, ty);
                let reached = (rect.0..rect.2).any(|x| horizon.covers(x, rect.3 - 1, margin));
                if !reached {
                    continue;
                }
                let TileMedian {
                    level,
                    pixels: kept,
                    ..
                } = tile_median(chip, rect, Some(sky_pixel), &mut histogram);
                let area = (rect.2 - rect.0) * (rect.3 - rect.1);
                let level = match ty.checked_sub(1) {
                    _ if 4 * kept >= area => level,
                    Some(above) => self.level(tx, above),
                    None => continue,
                };
                if let Some(slot) = self.levels.get_mut(ty * tiles_x + tx) {
                    *slot = level;
                }
            }
        }
        true
    }

    /// Measures the sky along a body in the corridor `shape` ([`Corridor`]) and uses it there
    /// from now on (until the next [`Background::estimate`]) where it disagrees with the tiles
    /// by more than `max_disagreement` grey levels (rms); returns whether it does.
    pub fn follow_corridor(
        &mut self,
        chip: &ChipView,
        shape: &CorridorShape,
        max_disagreement: f32,
    ) -> bool {
        self.corridor = None;
        // The plain flank means first: where even they agree with the tiles, nothing to do.
        let screened = Corridor::screen(chip, shape, |x, y| self.tiles_at(x, y));
        if screened.is_none_or(|d| d <= max_disagreement) {
            return false;
        }
        let Some(corridor) = Corridor::measure(chip, shape) else {
            return false;
        };
        let disagreement = corridor.disagreement(|x, y| self.tiles_at(x, y));
        let follow = disagreement > max_disagreement;
        if follow {
            self.corridor = Some(corridor);
        }
        follow
    }

    /// Whether the sky along the body is the corridor's ([`Background::follow_corridor`]): the
    /// sky beside it is cluttered beyond what the tiles follow.
    pub fn follows_corridor(&self) -> bool {
        self.corridor.is_some()
    }

    /// Whether terrain enters the chip from its lower edge ([`Background::estimate_terrain`],
    /// since the last [`Background::estimate`]).
    pub fn has_terrain(&self) -> bool {
        self.terrain
    }

    /// Re-estimates the tiles that `region` overlaps from their pixels outside it, and keeps
    /// the result when it moves a tile's level by more than `min_change` grey levels (returns
    /// whether it did): a body covering more than half a tile drags the tile's median to the
    /// body's level (a body 16 px wide or more does), a thin one does not and leaves the sky as
    /// it was. A tile with less than a quarter of its pixels left takes the mean of its
    /// neighbours that kept enough.
    pub fn exclude(&mut self, chip: &ChipView, region: &Region, min_change: f32) -> bool {
        let reach = region.half_length + region.half_width;
        let tiles_of = |centre: f32, tiles: usize| {
            let first = ((centre - reach).max(0.0) as usize) / BACKGROUND_TILE;
            let last = ((centre + reach).max(0.0) as usize) / BACKGROUND_TILE;
            (first.min(tiles), (last + 1).min(tiles))
        };
        let (tx0, tx1) = tiles_of(region.axis.centre.x, self.tiles_x);
        let (ty0, ty1) = tiles_of(region.axis.centre.y, self.tiles_y);
        let outside = |x: usize, y: usize| !region.contains(x as f32, y as f32);
        let mut levels = self.levels;
        let mut too_few = [false; MAX_TILES_PER_SIDE * MAX_TILES_PER_SIDE];
        let mut histogram = Histogram::new();
        for ty in ty0..ty1 {
            for tx in tx0..tx1 {
                let rect = self.tile_rect(tx, ty);
                // Only a tile the region covers about half of or more can have been dragged.
                if region_cover(rect, outside) < MIN_DRAGGED_COVER {
                    continue;
                }
                let TileMedian {
                    level,
                    pixels: kept,
                    ..
                } = tile_median(chip, rect, Some(outside), &mut histogram);
                let index = ty * self.tiles_x + tx;
                let area = (rect.2 - rect.0) * (rect.3 - rect.1);
                if 4 * kept < area {
                    if let Some(flag) = too_few.get_mut(index) {
                        *flag = true;
                    }
                } else if let Some(slot) = levels.get_mut(index) {
                    *slot = level;
                }
            }
        }
        let usable = |tx: usize, ty: usize| {
            tx < self.tiles_x
                && ty < self.tiles_y
                && !too_few.get(ty * self.tiles_x + tx).copied().unwrap_or(true)
        };
        for ty in ty0..ty1 {
            for tx in tx0..tx1 {
                if usable(tx, ty) {
                    continue;
                }
                let neighbours = [
                    (tx.wrapping_sub(1), ty),
                    (tx + 1, ty),
                    (tx, ty.wrapping_sub(1)),
                    (tx, ty + 1),
                ];
                let (mut sum, mut n) = (0.0f32, 0u32);
                for (nx, ny) in neighbours {
                    if usable(nx, ny) {
                        sum += levels.get(ny * self.tiles_x + nx).copied().unwrap_or(0.0);
                        n += 1;
                    }
                }
                if n > 0
                    && let Some(slot) = levels.get_mut(ty * self.tiles_x + tx)
                {
                    *slot = sum / n as f32;
                }
            }
        }
        let moved = levels
            .iter()
            .zip(&self.levels)
            .any(|(new, old)| libm::fabsf(new - old) > min_change);
        if moved {
            self.levels = levels;
        }
        moved
    }

    /// Bounds on the background-subtracted value ([`Background::fill_row`]) of every pixel of
    /// the tiles in tile row `ty`, grey levels: `(lowest, highest)` per tile into `bounds`, one
    /// per tile column. `scratch` holds one background row (the chip's width; shorter, nothing
    /// is bounded). Returns false, with nothing written, where there are no bounds: the sky
    /// follows a corridor, the chip is not the one estimated, or `ty` is outside it.
    ///
    /// The background is bilinear between neighbouring tile centres, so over a tile its extremes
    /// lie on the rows and columns of the tile's edges and next to its centre: it is read there.
    /// The pixels' extremes are the tile's histogram's.
    pub fn residual_bounds(
        &self,
        chip: &ChipView,
        ty: usize,
        scratch: &mut [f32],
        bounds: &mut [(f32, f32); MAX_TILES_PER_SIDE],
    ) -> bool {
        let Some(row) = scratch.get_mut(..self.width) else {
            return false;
        };
        if !self.from_tiles(chip) || ty >= self.tiles_y {
            return false;
        }
        let (_, y0, _, y1) = self.tile_rect(0, ty);
        let mut sky = [(f32::INFINITY, f32::NEG_INFINITY); MAX_TILES_PER_SIDE];
        for y in extreme_lines(y0, y1, tile_centre(ty, self.height)) {
            self.fill_row_from_tiles(y, 0, row);
            for (tx, (low, high)) in sky.iter_mut().enumerate().take(self.tiles_x) {
                let (x0, _, x1, _) = self.tile_rect(tx, ty);
                for x in extreme_lines(x0, x1, tile_centre(tx, self.width)) {
                    let value = row.get(x).copied().unwrap_or(f32::NAN);
                    (*low, *high) = (low.min(value), high.max(value));
                }
            }
        }
        let ranges = self.ranges.iter().skip(ty * self.tiles_x);
        let tiles = bounds.iter_mut().zip(sky).zip(ranges).take(self.tiles_x);
        for ((bound, (low, high)), &(lowest, highest)) in tiles {
            let (lowest, highest) = (f32::from(lowest), f32::from(highest));
            // The rounding of the interpolation and of the subtraction, with room to spare.
            let margin = 1e-3 + 1e-5 * highest.max(libm::fabsf(low)).max(libm::fabsf(high));
            *bound = (lowest - high - margin, highest - low + margin);
        }
        true
    }

    /// Tile (`tx`, `ty`)'s pixels: columns `.0..2`, rows `.1..3`.
    fn tile_rect(&self, tx: usize, ty: usize) -> (usize, usize, usize, usize) {
        let (x0, y0) = (tx * BACKGROUND_TILE, ty * BACKGROUND_TILE);
        (
            x0,
            y0,
            (x0 + BACKGROUND_TILE).min(self.width),
            (y0 + BACKGROUND_TILE).min(self.height),
        )
    }

    /// Noise standard deviation, grey levels.
    pub fn sigma(&self) -> f32 {
        self.sigma
    }

    fn level(&self, tx: usize, ty: usize) -> f32 {
        self.levels
            .get(ty * self.tiles_x + tx)
            .copied()
            .unwrap_or(0.0)
    }

    /// Background at chip pixel (x, y), grey levels: the corridor's where it has one there, else
    /// bilinear between tile centres.
    pub fn at(&self, x: f32, y: f32) -> f32 {
        self.corridor_at(x, y)
            .unwrap_or_else(|| self.tiles_at(x, y))
    }

    /// The corridor's sky at chip point (x, y), where it has one there.
    #[inline]
    fn corridor_at(&self, x: f32, y: f32) -> Option<f32> {
        self.corridor.as_ref().and_then(|c| c.at(x, y))
    }

    /// The tiles' background at chip pixel (x, y), grey levels (bilinear between tile centres).
    fn tiles_at(&self, x: f32, y: f32) -> f32 {
        let column = self.columns.weights(x, self.tiles_x, self.width);
        self.bilinear(column, self.rows.weights(y, self.tiles_y, self.height))
    }

    /// The tiles' levels blended between the tiles and weights of a column and a row
    /// ([`axis_weights`]).
    #[inline]
    fn bilinear(&self, column: (usize, usize, f32), row: (usize, usize, f32)) -> f32 {
        let ((x0, x1, wx), (y0, y1, wy)) = (column, row);
        bilinear_blend(self.corners((x0, x1), (y0, y1)), wx, wy)
    }

    /// The levels of tiles `x0`, `x1` in rows `y0` and `y1`: top left, top right, bottom left,
    /// bottom right.
    #[inline]
    fn corners(&self, (x0, x1): (usize, usize), (y0, y1): (usize, usize)) -> [f32; 4] {
        [
            self.level(x0, y0),
            self.level(x1, y0),
            self.level(x0, y1),
            self.level(x1, y1),
        ]
    }

    /// The background along chip row `y`, read pixel by pixel ([`SkyRow::at`]) as
    /// [`Background::at`] reads it, bit for bit, with the row's interpolation weights found once.
    pub fn row(&self, y: usize) -> SkyRow<'_> {
        SkyRow {
            background: self,
            y,
            weights: self.rows.weights(y as f32, self.tiles_y, self.height),
        }
    }

    /// Writes the background of row `y`, columns `x_start..x_start + out.len()`, into `out`.
    pub fn fill_row(&self, y: usize, x_start: usize, out: &mut [f32]) {
        self.fill_row_from_tiles(y, x_start, out);
        self.overlay_corridor(y, x_start, out);
    }

    /// Writes the corridor's sky over row `y`'s background in `out` (columns `x_start..`) where
    /// it has one.
    fn overlay_corridor(&self, y: usize, x_start: usize, out: &mut [f32]) {
        let Some(corridor) = &self.corridor else {
            return;
        };
        let shape = corridor.shape();
        let half = shape.half_length;
        let end = x_start + out.len();
        let (a, b) = row_span(
            shape.axis.centre,
            shape.axis.dir,
            y,
            (-half, half),
            shape.outer,
            (x_start, end),
        );
        corridor.overlay_row(y, a..b, x_start, out);
    }

    /// Whether the background of `chip`'s rows is the tiles' alone, to be read a row at a time
    /// through [`RowLevels`]: not where the sky follows a corridor, or `chip` is not the one
    /// estimated.
    pub fn from_tiles(&self, chip: &ChipView) -> bool {
        self.corridor.is_none() && chip.width() == self.width && chip.height() == self.height
    }

    /// [`Background::fill_row`] from the tiles alone.
    fn fill_row_from_tiles(&self, y: usize, x_start: usize, out: &mut [f32]) {
        let mut row = RowLevels::new();
        row.set(self, y);
        row.fill(x_start, out);
    }

    fn noise_sigma_of(&self, chip: &ChipView) -> f32 {
        let (w, h) = (chip.width(), chip.height());
        if w < 2 {
            return MIN_SIGMA;
        }
        // A regular grid of about NOISE_SAMPLES horizontal neighbour differences.
        let cells = ((w - 1) * h).max(1);
        let step = libm::sqrtf((cells / NOISE_SAMPLES) as f32).max(1.0) as usize;
        // Scratch for this call only: kept in the model, it weighed on the pipeline all along.
        let mut samples = [0.0f32; NOISE_SAMPLES];
        let mut n = 0usize;
        'rows: for y in (0..h).step_by(step.max(1)) {
            for x in (0..w - 1).step_by(step.max(1)) {
                let Some(slot) = samples.get_mut(n) else {
                    break 'rows;
                };
                *slot = (f32::from(chip.get(x + 1, y)) - f32::from(chip.get(x, y))).abs();
                n += 1;
            }
        }
        let Some(samples) = samples.get_mut(..n) else {
            return MIN_SIGMA;
        };
        if samples.is_empty() {
            return MIN_SIGMA;
        }
        let mid = samples.len() / 2;
        let (_, median, _) = samples.select_nth_unstable_by(mid, f32::total_cmp);
        // Median |N(0, s)| = 0.6745 s; the difference of two pixels has s = sqrt(2) sigma.
        let rough = (*median / 0.6745).max(1.0);
        // Refine with the RMS of the differences within 3.5 rough sigmas (less quantization bias
        // than the median of integer data); 0.9955 is the variance kept by a 3.5-sigma cut.
        let clip = 3.5 * rough;
        let (sum, count) = samples
            .iter()
            .filter(|d| **d <= clip)
            .fold((0.0f32, 0u32), |(s, c), d| (s + d * d, c + 1));
        if count == 0 {
            return MIN_SIGMA;
        }
        let diff_sigma = libm::sqrtf(sum / (count as f32 * 0.9955));
        (diff_sigma / core::f32::consts::SQRT_2).max(MIN_SIGMA)
    }
}

/// The background along one chip row ([`Background::row`]).
pub struct SkyRow<'a> {
    background: &'a Background,
    y: usize,
    /// The row's tiles and the second one's weight ([`axis_weights`]).
    weights: (usize, usize, f32),
}

impl SkyRow<'_> {
    /// Background at column `x` of the row, grey levels: [`Background::at`] at (`x`, `y`).
    #[inline]
    pub fn at(&self, x: usize) -> f32 {
        let background = self.background;
        background
            .corridor_at(x as f32, self.y as f32)
            .unwrap_or_else(|| {
                let column = background
                    .columns
                    .at_pixel(x, background.tiles_x, background.width);
                background.bilinear(column, self.weights)
            })
    }

    /// The background at columns `x_start..x_start + out.len()` of the row into `out`:
    /// [`SkyRow::at`] at each, bit for bit, each pair of tiles' levels read once and the
    /// corridor laid over its own span, not tested at every pixel (read so by the width profile
    /// and the cross-sections' binning, the firmware's frame on small-known-range went from
    /// 9.73 M to 9.32 M instructions).
    pub fn fill(&self, x_start: usize, out: &mut [f32]) {
        let background = self.background;
        let (y0, y1, wy) = self.weights;
        let mut tiles = None;
        let mut corners = [0.0; 4];
        for (x, slot) in (x_start..).zip(out.iter_mut()) {
            let (x0, x1, wx) = background
                .columns
                .at_pixel(x, background.tiles_x, background.width);
            if tiles != Some((x0, x1)) {
                tiles = Some((x0, x1));
                corners = background.corners((x0, x1), (y0, y1));
            }
            *slot = bilinear_blend(corners, wx, wy);
        }
        background.overlay_corridor(self.y, x_start, out);
    }
}

/// One chip row's background from the tiles, as pieces linear between the tile centres, set
/// for a row ([`RowLevels::set`]) and then written over spans of its columns
/// ([`RowLevels::fill`]) or bounded a few columns at a time ([`RowLevels::try_for_each_group`]):
/// the labeler passes over columns whose pixels cannot leave the sky.
pub struct RowLevels {
    /// Each tile column's piece: the row's level at its centre, grey levels, the slope on to
    /// the next centre, grey levels per px (0 from the last), and the centre, px.
    pieces: [Piece; MAX_TILES_PER_SIDE],
    tiles: usize,
    /// Room for the interpolations' rounding, grey levels.
    margin: f32,
}

impl Default for RowLevels {
    fn default() -> Self {
        Self::new()
    }
}

impl RowLevels {
    /// No row: a flat zero background.
    pub const fn new() -> Self {
        RowLevels {
            pieces: [(0.0, 0.0, 0.0); MAX_TILES_PER_SIDE],
            tiles: 0,
            margin: 0.0,
        }
    }

    /// Takes row `y` of `background` (the tiles' levels, with no corridor).
    pub fn set(&mut self, background: &Background, y: usize) {
        let tiles = background.tiles_x;
        let (y0, y1, wy) = background
            .rows
            .weights(y as f32, background.tiles_y, background.height);
        // The row's level at every tile centre, then the slopes between neighbouring centres.
        let level = |t: usize| background.level(t, y0) * (1.0 - wy) + background.level(t, y1) * wy;
        let centres = &background.columns.centres;
        let mut highest = 0.0f32;
        let mut left = level(0);
        for (t, (piece, &c0)) in self.pieces.iter_mut().zip(centres).enumerate().take(tiles) {
            let (right, slope) = match centres.get(t + 1) {
                Some(&c1) if t + 1 < tiles => {
                    let right = level(t + 1);
                    (
                        right,
                        if c1 > c0 {
                            (right - left) / (c1 - c0)
                        } else {
                            0.0
                        },
                    )
                }
                _ => (left, 0.0),
            };
            *piece = (left, slope, c0);
            highest = highest.max(libm::fabsf(left));
            left = right;
        }
        self.tiles = tiles;
        // As [`Background::residual_bounds`]: with room to spare (every value between two
        // levels is at most the largest in magnitude).
        self.margin = 1e-3 + 1e-5 * highest;
    }

    /// The row's level at tile column `t`'s centre, grey levels.
    fn level(&self, t: usize) -> f32 {
        self.pieces.get(t).map_or(0.0, |piece| piece.0)
    }

    /// Writes the row's background at columns `x_start..x_start + out.len()` into `out`: linear
    /// between neighbouring centres, flat beyond the outer ones, filled piece by piece (a pixel
    /// costs a multiply-add): piece `t` holds the pixels after centre `t` up to centre `t + 1`.
    pub fn fill(&self, x_start: usize, out: &mut [f32]) {
        let last = self.tiles.saturating_sub(1);
        let after = |t: usize| self.pieces.get(t).map_or(0, |piece| piece.2 as usize + 1);
        let end = x_start + out.len();
        let mut fill =
            |from: usize, to: usize, value: Piece| fill_piece(out, x_start, from, to, value);
        let flat = |t: usize| (self.level(t), 0.0, 0.0);
        if last == 0 {
            fill(x_start, end, flat(0));
            return;
        }
        fill(x_start, after(0), flat(0));
        for (t, &piece) in self.pieces.iter().enumerate().take(last) {
            fill(after(t), after(t + 1), piece);
        }
        fill(after(last), end, flat(last));
    }

    /// Cuts `columns` into groups of `group` px, aligned to multiples of it and each within one
    /// tile, and calls `f(group's columns, lowest, highest)` with the lowest and highest
    /// background over each, grey levels, widened by room for the rounding: every value
    /// [`Background::fill_row`] writes there lies between them. The background is linear
    /// between neighbouring tile centres and flat beyond the outer ones, so over a group its
    /// extremes lie at the first and last column and at the centre where the group holds it.
    /// Stops at the first error. Columns beyond the tiles are one group, unbounded.
    pub fn try_for_each_group<E>(
        &self,
        columns: core::ops::Range<usize>,
        group: usize,
        mut f: impl FnMut(core::ops::Range<usize>, f32, f32) -> Result<(), E>,
    ) -> Result<(), E> {
        let group = group.clamp(1, BACKGROUND_TILE);
        let mut from = columns.start;
        while from < columns.end {
            let t = from / BACKGROUND_TILE;
            let Some(&(level, slope, centre)) = self.pieces.get(t).filter(|_| t < self.tiles)
            else {
                return f(from..columns.end, f32::NEG_INFINITY, f32::INFINITY);
            };
            // The piece from the centre before (flat before the first centre) and this one's.
            let before = t
                .checked_sub(1)
                .and_then(|p| self.pieces.get(p).copied())
                .unwrap_or((level, 0.0, centre));
            let this = (level, slope, centre);
            let on = |(level, slope, centre): Piece, x: f32| level + slope * (x - centre);
            let tile_end = ((t + 1) * BACKGROUND_TILE).min(columns.end);
            while from < tile_end {
                let to = ((from / group + 1) * group).min(tile_end);
                let (x0, x1) = (from as f32, (to - 1) as f32);
                let (first, last) = if x1 < centre {
                    (on(before, x0), on(before, x1))
                } else if x0 >= centre {
                    (on(this, x0), on(this, x1))
                } else {
                    (on(before, x0), on(this, x1))
                };
                let (mut low, mut high) = (first.min(last), first.max(last));
                if x0 < centre && centre <= x1 {
                    (low, high) = (low.min(level), high.max(level));
                }
                f(from..to, low - self.margin, high + self.margin)?;
                from = to;
            }
        }
        Ok(())
    }
}

/// Columns of a row's background filled at a time ([`SkySpans`]).
const SKY_CHUNK: usize = 64;

/// Rows' backgrounds read beside the chip's samples, `SKY_CHUNK` (64) columns at a time
/// ([`SkyRow::fill`]): its buffer is made once for the many rows of a stage (zeroed for each
/// row, it took 0.2 M instructions a frame on the Cortex-M4F).
pub struct SkySpans {
    sky: [f32; SKY_CHUNK],
}

impl Default for SkySpans {
    fn default() -> Self {
        Self::new()
    }
}

impl SkySpans {
    /// An empty buffer.
    pub const fn new() -> Self {
        SkySpans {
            sky: [0.0; SKY_CHUNK],
        }
    }

    /// Calls `f(x, value, sky)` for the samples of `row` in columns `x_start..x_end` of `chip`
    /// (clipped to it), `sky` the background there: [`SkyRow::at`], bit for bit.
    pub fn for_each_in_span(
        &mut self,
        row: &SkyRow,
        chip: &ChipView,
        x_start: usize,
        x_end: usize,
        mut f: impl FnMut(usize, u16, f32),
    ) {
        let x_end = x_end.min(chip.width());
        let mut from = x_start;
        while from < x_end {
            let to = (from + SKY_CHUNK).min(x_end);
            let chunk = self.sky.get_mut(..to - from).unwrap_or_default();
            row.fill(from, chunk);
            chip.for_each_in_span(row.y, from, to, |x, v| {
                if let Some(&level) = chunk.get(x - from) {
                    f(x, v, level);
                }
            });
            from = to;
        }
    }
}

/// A linear piece of a row's background: `level + slope (x - origin)` at column `x`.
type Piece = (f32, f32, f32);

/// Writes `piece` at the columns `from..to` of a row whose columns `x_start..` are `out`.
fn fill_piece(out: &mut [f32], x_start: usize, from: usize, to: usize, piece: Piece) {
    let (level, slope, origin) = piece;
    let (a, b) = (from.max(x_start), to.min(x_start + out.len()));
    if let Some(slots) = out.get_mut(a.saturating_sub(x_start)..b.saturating_sub(x_start)) {
        let mut x = a as f32;
        for slot in slots {
            *slot = level + slope * (x - origin);
            x += 1.0;
        }
    }
}

/// The lines (columns or rows) `from..to` of a tile whose centre is at `centre`, px, where a
/// function linear on either side of the centre has its extremes over the tile: its first and
/// last line and the two around the centre (some may repeat).
fn extreme_lines(from: usize, to: usize, centre: f32) -> [usize; 4] {
    let last = to.saturating_sub(1).max(from);
    let before = (centre as usize).clamp(from, last);
    [from, before, (before + 1).min(last), last]
}

/// Centre of tile `t` along an axis of `size` pixels, px.
fn tile_centre(t: usize, size: usize) -> f32 {
    let start = t * BACKGROUND_TILE;
    let len = BACKGROUND_TILE.min(size.saturating_sub(start)).max(1);
    start as f32 + (len as f32 - 1.0) * 0.5
}

/// The two tiles whose centres bracket `p` along an axis of `tiles` tiles, and the weight of the
/// second; clamped to the edge tiles outside the outermost centres.
fn axis_weights(p: f32, tiles: usize, size: usize) -> (usize, usize, f32) {
    if tiles <= 1 {
        return (0, 0, 0.0);
    }
    let last = tiles - 1;
    if p <= tile_centre(0, size) {
        return (0, 0, 0.0);
    }
    if p >= tile_centre(last, size) {
        return (last, last, 0.0);
    }
    let t0 = ((p / BACKGROUND_TILE as f32) as usize).min(last);
    let t0 = if p < tile_centre(t0, size) {
        t0.saturating_sub(1)
    } else {
        t0
    };
    let t1 = (t0 + 1).min(last);
    let c0 = tile_centre(t0, size);
    let c1 = tile_centre(t1, size);
    let w = if c1 > c0 { (p - c0) / (c1 - c0) } else { 0.0 };
    (t0, t1, w.clamp(0.0, 1.0))
}

/// Below this fraction of a tile inside an excluded region (sampled, [`region_cover`]), the
/// body in the region covers less than half the tile and cannot have dragged its median.
const MIN_DRAGGED_COVER: f32 = 0.4;

/// The fraction of the tile `rect` (columns `.0..2`, rows `.1..3`) not `outside` a region, on a
/// grid of 8 x 8 sample points.
fn region_cover(rect: (usize, usize, usize, usize), outside: impl Fn(usize, usize) -> bool) -> f32 {
    const GRID: usize = 8;
    let (x0, y0, x1, y1) = rect;
    let at = |lo: usize, hi: usize, k: usize| lo + (2 * k + 1) * (hi - lo) / (2 * GRID);
    let inside = (0..GRID * GRID)
        .filter(|k| !outside(at(x0, x1, k % GRID), at(y0, y1, k / GRID)))
        .count();
    inside as f32 / (GRID * GRID) as f32
}

/// What [`tile_median`] read of a tile's pixels.
struct TileMedian {
    /// The median, interpolated within its histogram bin, grey levels.
    level: f32,
    /// How many pixels it took.
    pixels: usize,
    /// The lowest and highest of them, grey levels (for a 16-bit chip, the edges of their
    /// coarse bins).
    range: (u16, u16),
}

/// A tile's histogram of its pixels' grey levels (for a 16-bit chip, their high bytes): zero
/// between tiles. [`tile_median`] clears only the bins its pixels filled, so the tiles of a chip
/// share one histogram instead of each clearing its 1 KiB (the 64 tiles of a 256 x 256 chip
/// cleared 64 KiB a frame).
struct Histogram([u32; 256]);

impl Histogram {
    fn new() -> Histogram {
        Histogram([0; 256])
    }
}

/// Every pixel of a tile, for [`tile_median`].
const EVERY_PIXEL: Option<fn(usize, usize) -> bool> = None;

/// Adds each of `bytes` to `histogram`, four at a time from a word: every tile of every chip is
/// counted so, and on the Cortex-M4F this took 0.3 % fewer instructions a frame than a loop over
/// the bytes (which already took 0.4 % fewer than one over the samples with their columns).
fn count_bytes(bytes: &[u8], histogram: &mut [u32; 256]) {
    let mut words = bytes.chunks_exact(4);
    for word in &mut words {
        let word = <[u8; 4]>::try_from(word).map_or(0, u32::from_le_bytes);
        for shift in [0, 8, 16, 24] {
            histogram[((word >> shift) & 0xFF) as usize] += 1;
        }
    }
    for &v in words.remainder() {
        histogram[usize::from(v)] += 1;
    }
}

/// The median of the pixels `(x, y)` of the tile `rect` (columns `.0..2`, rows `.1..3`) for
/// which `keep(x, y)` (every pixel where `keep` is None), counted in `histogram` (zero before
/// and after).
fn tile_median(
    chip: &ChipView,
    rect: (usize, usize, usize, usize),
    keep: Option<impl Fn(usize, usize) -> bool>,
    histogram: &mut Histogram,
) -> TileMedian {
    let (x0, y0, x1, y1) = rect;
    let shift = if chip.is_16bit() { 8 } else { 0 };
    let coarse = &mut histogram.0;
    let kept = |x: usize, y: usize| keep.as_ref().is_none_or(|keep| keep(x, y));
    for y in y0..y1 {
        match (chip.gray8_span(y, x0, x1), &keep) {
            (Some(bytes), None) => count_bytes(bytes, coarse),
            _ => chip.for_each_in_span(y, x0, x1, |x, v| {
                if kept(x, y) {
                    coarse[usize::from((v >> shift) as u8)] += 1;
                }
            }),
        }
    }
    let (Some(lowest), Some(highest)) = (
        coarse.iter().position(|&c| c > 0),
        coarse.iter().rposition(|&c| c > 0),
    ) else {
        return TileMedian {
            level: 0.0,
            pixels: 0,
            range: (0, u16::MAX),
        };
    };
    let total: u32 = coarse
        .get(lowest..=highest)
        .unwrap_or_default()
        .iter()
        .sum();
    let range = (
        (lowest as u16) << shift,
        ((highest as u16) << shift) | ((1u16 << shift) - 1),
    );
    let half = total as f32 * 0.5;
    let (bin, below) = median_bin(coarse, lowest, half);
    let level = if shift == 0 {
        interpolated(bin, below, coarse, half, 1.0)
    } else {
        // 16-bit: a second pass over the low byte of the values in the median's coarse bin.
        let mut fine = [0u32; 256];
        for y in y0..y1 {
            chip.for_each_in_span(y, x0, x1, |x, v| {
                if usize::from(v >> 8) == bin && kept(x, y) {
                    fine[usize::from(v as u8)] += 1;
                }
            });
        }
        let (fine_bin, fine_below) = median_bin(&fine, 0, half - below as f32);
        (bin as f32) * 256.0 + interpolated(fine_bin, fine_below, &fine, half - below as f32, 1.0)
    };
    if let Some(filled) = coarse.get_mut(lowest..=highest) {
        filled.fill(0);
    }
    TileMedian {
        level,
        pixels: total as usize,
        range,
    }
}

/// The bin where the cumulative count reaches `half`, and the count below it; the bins below
/// `first` are empty.
fn median_bin(hist: &[u32; 256], first: usize, half: f32) -> (usize, u32) {
    let mut below = 0u32;
    for (i, &c) in hist.iter().enumerate().skip(first) {
        if (below + c) as f32 >= half {
            return (i, below);
        }
        below += c;
    }
    (255, below)
}

/// The median inside bin `bin` of width `width`, assuming its values spread evenly.
fn interpolated(bin: usize, below: u32, hist: &[u32; 256], half: f32, width: f32) -> f32 {
    let count = hist.get(bin).copied().unwrap_or(0).max(1) as f32;
    bin as f32 * width - 0.5 * width + width * ((half - below as f32) / count).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 4 x 4 tile worked out by hand: levels 10 (4 px), 20 (6), 30 (2), 40 (3) and 250 (1).
    /// Half of 16 is reached in the bin of 20 with 4 below: 20 - 0.5 + (8 - 4) / 6. Without the
    /// 10s and the 250 (11 px), half of 11 is reached there with none below: 19.5 + 5.5 / 6.
    #[test]
    fn a_tiles_median_is_interpolated_in_its_bin() {
        let data: [u8; 16] = [
            10, 20, 10, 250, 20, 10, 20, 30, 40, 20, 10, 40, 30, 20, 40, 20,
        ];
        let chip = ChipView::gray8(&data, 4, 4, 4, 0, 0).unwrap();
        let mut histogram = Histogram::new();
        let all = tile_median(&chip, (0, 0, 4, 4), EVERY_PIXEL, &mut histogram);
        assert_eq!((all.pixels, all.range), (16, (10, 250)));
        assert!(
            (all.level - (19.5 + 4.0 / 6.0)).abs() < 1e-5,
            "{}",
            all.level
        );
        // Every pixel counted four at a time from words, and one by one (a row of 3: the
        // words' remainder), gives the same.
        for rect in [(0, 0, 4, 4), (1, 0, 4, 4), (0, 1, 3, 3)] {
            let by_words = tile_median(&chip, rect, EVERY_PIXEL, &mut histogram);
            let one_by_one = tile_median(&chip, rect, Some(|_, _| true), &mut histogram);
            assert_eq!(
                (by_words.level, by_words.pixels, by_words.range),
                (one_by_one.level, one_by_one.pixels, one_by_one.range),
                "{rect:?}"
            );
        }
        let kept = tile_median(
            &chip,
            (0, 0, 4, 4),
            Some(|x: usize, y: usize| !matches!(data[y * 4 + x], 10 | 250)),
            &mut histogram,
        );
        assert_eq!((kept.pixels, kept.range), (11, (20, 40)));
        assert!(
            (kept.level - (19.5 + 5.5 / 6.0)).abs() < 1e-5,
            "{}",
            kept.level
        );
        let none = tile_median(&chip, (0, 0, 4, 4), Some(|_, _| false), &mut histogram);
        assert_eq!((none.pixels, none.range), (0, (0, u16::MAX)));
        // Each tile leaves the shared histogram empty for the next.
        assert!(histogram.0.iter().all(|&c| c == 0));
    }

    #[test]
    fn follows_a_gradient_and_ignores_a_small_target() {
        let (w, h) = (128usize, 96usize);
        let mut data = [0u8; 128 * 96];
        for y in 0..h {
            for x in 0..w {
                let sky = 100.0 + 0.5 * x as f32 + 0.25 * y as f32;
                let dark = (60..70).contains(&x) && (40..44).contains(&y);
                data[y * w + x] = if dark { 20 } else { sky as u8 };
            }
        }
        let chip = ChipView::gray8(&data, w, h, w, 0, 0).unwrap();
        let mut bg = Background::new();
        bg.estimate(&chip);
        for (x, y) in [(20.0, 20.0), (64.0, 42.0), (100.0, 70.0)] {
            let truth = 100.0 + 0.5 * x + 0.25 * y;
            assert!(
                (bg.at(x, y) - truth).abs() < 1.5,
                "at ({x},{y}): {}",
                bg.at(x, y)
            );
        }
        let mut row = [0.0f32; 128];
        bg.fill_row(42, 0, &mut row);
        for x in [0usize, 17, 64, 127] {
            assert!(
                (row[x] - bg.at(x as f32, 42.0)).abs() < 1e-3,
                "row and point agree at {x}"
            );
        }
        assert!(
            bg.sigma() < 1.0,
            "a noiseless gradient has little noise: {}",
            bg.sigma()
        );
    }

    /// A bar 24 px wide drags the tiles it covers to its own level; left out, the sky is found
    /// again under it (the tiles it covers wholly take their neighbours' level). A thin bar moves
    /// nothing, and the first estimate stands.
    #[test]
    fn a_wide_body_left_out_gives_the_sky_back() {
        let (w, h) = (128usize, 128usize);
        let mut data = [0u8; 128 * 128];
        for wide in [true, false] {
            let half_width = if wide { 12.0 } else { 2.0 };
            for y in 0..h {
                for x in 0..w {
                    let across = (y as f32 - 48.0).abs();
                    let inside = across <= half_width && (16..112).contains(&x);
                    data[y * w + x] = if inside { 30 } else { 150 };
                }
            }
            let chip = ChipView::gray8(&data, w, h, w, 0, 0).unwrap();
            let mut bg = Background::new();
            bg.estimate(&chip);
            let region = Region {
                axis: Axis {
                    centre: crate::point::ImagePoint::new(64.0, 48.0),
                    dir: crate::point::ImagePoint::new(1.0, 0.0),
                },
                half_length: 50.0,
                half_width: half_width + 3.0,
            };
            let before = bg.at(64.0, 48.0);
            let moved = bg.exclude(&chip, &region, 3.0);
            assert_eq!(moved, wide, "wide {wide}");
            if wide {
                assert!(before < 100.0, "the wide bar drags the sky: {before}");
            }
            for (x, y) in [(64.0, 48.0), (20.0, 40.0), (100.0, 56.0)] {
                assert!(
                    (bg.at(x, y) - 150.0).abs() < 1.0,
                    "wide {wide}: sky at ({x},{y}) is {}",
                    bg.at(x, y)
                );
            }
        }
    }

    /// Terrain 90 grey levels darker than the sky below a ridge at rows 100-110 of a 128 px chip
    /// (noise 2): the tiles alone give the terrain its own level and put the sky just above the
    /// ridge between the two; with the terrain found, the sky is the sky's everywhere (carried
    /// down over the terrain), so that the terrain stands out whole from the lower edge.
    #[test]
    fn terrain_from_the_lower_edge_leaves_the_sky_its_own_level() {
        let (w, h) = (128usize, 128usize);
        let ridge = |x: usize| 100 + (x % 20).min(20 - x % 20) / 2;
        let mut data = [0u8; 128 * 128];
        for (i, v) in data.iter_mut().enumerate() {
            let (x, y) = (i % w, i / w);
            let noise = ((i * 7919) % 5) as u8;
            *v = if y >= ridge(x) {
                58 + noise
            } else {
                148 + noise
            };
        }
        let chip = ChipView::gray8(&data, w, h, w, 0, 0).unwrap();
        let mut bg = Background::new();
        bg.estimate(&chip);
        let (on_terrain, above_ridge) = ((40.0, 120.0), (40.0, 96.0));
        assert!(bg.at(on_terrain.0, on_terrain.1) < 100.0);
        assert!(bg.at(above_ridge.0, above_ridge.1) < 140.0);
        assert!(!bg.has_terrain());
        assert!(bg.estimate_terrain(&chip, &TerrainConfig::DEFAULT));
        assert!(bg.has_terrain());
        for (x, y) in [on_terrain, above_ridge, (100.0, 20.0)] {
            let sky = bg.at(x, y);
            assert!((sky - 150.0).abs() < 2.0, "sky at ({x},{y}) is {sky}");
        }
        // Found again by a fresh estimate only when asked.
        bg.estimate(&chip);
        assert!(bg.at(on_terrain.0, on_terrain.1) < 100.0);
        assert!(!bg.has_terrain());
    }

    /// The per-pixel tables are a cache, kept from chip to chip while the size stays: the
    /// background they give is bit for bit the direct interpolation between tile centres, at
    /// pixels and between them; a row walked segment by segment gives the same to rounding.
    #[test]
    fn tabulated_interpolation_is_the_direct_one() {
        let mut data = [0u8; 300 * 300];
        for (i, v) in data.iter_mut().enumerate() {
            *v = ((i * 7919) % 251) as u8 / 4 + (i / 300 / 9) as u8;
        }
        // One model for chips of changing sizes, some again after others: its tables follow.
        let mut bg = Background::new();
        for (w, h) in [
            (1, 1),
            (5, 300),
            (32, 33),
            (100, 65),
            (256, 256),
            (256, 256),
            (300, 97),
            (32, 33),
            (256, 256),
        ] {
            let chip = ChipView::gray8(&data, w, h, 300, 0, 0).unwrap();
            bg.estimate(&chip);
            let column = |t: usize, y0: usize, y1: usize, wy: f32| {
                bg.level(t, y0) * (1.0 - wy) + bg.level(t, y1) * wy
            };
            let mut row = [0.0f32; 300];
            let mut filled = [0.0f32; 300];
            for y in 0..h {
                let (y0, y1, wy) = axis_weights(y as f32, bg.tiles_y, bg.height);
                bg.fill_row(y, 0, &mut row[..w]);
                // A span from column 3: the row's fill, chunk by chunk, gives the pixels' own.
                bg.row(y).fill(0, &mut filled[..w]);
                let mut visited = 0;
                SkySpans::new().for_each_in_span(&bg.row(y), &chip, 3, w, |x, v, sky| {
                    assert_eq!(x, 3 + visited);
                    assert_eq!(v, u16::from(data[y * 300 + x]));
                    assert_eq!(sky.to_bits(), bg.row(y).at(x).to_bits(), "({x},{y})");
                    visited += 1;
                });
                assert_eq!(visited, w.saturating_sub(3));
                for (x, value) in row[..w].iter().enumerate() {
                    let (x0, x1, wx) = axis_weights(x as f32, bg.tiles_x, bg.width);
                    let (left, right) = (column(x0, y0, y1, wy), column(x1, y0, y1, wy));
                    let direct_row = left + (right - left) * wx;
                    assert!((value - direct_row).abs() <= 1e-4, "row at ({x},{y})");
                    for dx in [0.0f32, 0.25, 0.5] {
                        let xf = x as f32 + dx;
                        let (x0, x1, wx) = axis_weights(xf, bg.tiles_x, bg.width);
                        let top = bg.level(x0, y0) * (1.0 - wx) + bg.level(x1, y0) * wx;
                        let bottom = bg.level(x0, y1) * (1.0 - wx) + bg.level(x1, y1) * wx;
                        let direct = top * (1.0 - wy) + bottom * wy;
                        assert_eq!(bg.at(xf, y as f32).to_bits(), direct.to_bits());
                        if dx == 0.0 {
                            assert_eq!(bg.row(y).at(x).to_bits(), direct.to_bits());
                            assert_eq!(filled[x].to_bits(), direct.to_bits());
                        }
                    }
                }
            }
        }
    }

    /// A row's groups, bounded by [`RowLevels::try_for_each_group`], cover its columns in order
    /// and hold every value [`Background::fill_row`] writes in them, with no more room than the
    /// rounding's: on noisy tiles, chips with partial tiles, groups that do and do not divide a
    /// tile.
    #[test]
    fn a_rows_group_bounds_hold_its_filled_background() {
        let mut data = [0u8; 300 * 300];
        for (i, v) in data.iter_mut().enumerate() {
            *v = ((i * 7919) % 251) as u8 / 2 + (i / 300 / 5) as u8;
        }
        let mut levels = RowLevels::new();
        for (w, h) in [(1, 1), (5, 300), (32, 33), (100, 65), (256, 256), (300, 97)] {
            let chip = ChipView::gray8(&data, w, h, 300, 0, 0).unwrap();
            let mut bg = Background::new();
            bg.estimate(&chip);
            assert!(bg.from_tiles(&chip));
            let mut row = [0.0f32; 300];
            for y in 0..h {
                bg.fill_row(y, 0, &mut row[..w]);
                levels.set(&bg, y);
                for group in [5, 8, 16] {
                    let mut next = 0;
                    let result: Result<(), ()> =
                        levels.try_for_each_group(0..w, group, |columns, low, high| {
                            assert_eq!(columns.start, next, "in order");
                            assert!(columns.end > columns.start && columns.len() <= group);
                            let tile = columns.start / BACKGROUND_TILE;
                            assert_eq!((columns.end - 1) / BACKGROUND_TILE, tile, "one tile");
                            next = columns.end;
                            let filled = &row[columns];
                            let lowest = filled.iter().copied().fold(f32::INFINITY, f32::min);
                            let highest = filled.iter().copied().fold(f32::NEG_INFINITY, f32::max);
                            assert!(low <= lowest && highest <= high, "({y}) {low} {high}");
                            // Where the group holds a centre between two pixels, its level,
                            // less than a pixel's step beyond theirs, is in the bounds.
                            let step = filled
                                .windows(2)
                                .map(|pair| (pair[1] - pair[0]).abs())
                                .fold(0.0, f32::max);
                            let room = 5e-3 + step;
                            assert!(lowest - low < room && high - highest < room, "({y})");
                            Ok(())
                        });
                    assert_eq!((result, next), (Ok(()), w));
                }
            }
        }
    }

    #[test]
    fn estimates_gaussian_noise() {
        // A deterministic pseudo-random Gaussian field (sum of 12 uniforms) with sigma 4.
        let (w, h) = (256usize, 256usize);
        let mut data = [0u16; 256 * 256];
        let mut state = 12345u32;
        for v in data.iter_mut() {
            let mut acc = 0.0f32;
            for _ in 0..12 {
                state = state.wrapping_mul(1664525).wrapping_add(1013904223);
                acc += (state >> 8) as f32 / (1u32 << 24) as f32;
            }
            *v = (1000.0 + 4.0 * (acc - 6.0)).round() as u16;
        }
        let chip = ChipView::gray16(&data, w, h, w, 0, 0).unwrap();
        let mut bg = Background::new();
        bg.estimate(&chip);
        assert!((bg.sigma() - 4.0).abs() < 0.3, "sigma {}", bg.sigma());
        assert!((bg.at(128.0, 128.0) - 1000.0).abs() < 0.5);
    }
}
