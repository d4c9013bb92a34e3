//! 8-connected component labeling of a classified chip region, run by run, in fixed memory.
//!
//! Each row of the region is cut into runs of equal nonzero class (the class is the contrast
//! polarity: +1 brighter, -1 darker than the background). A run joins the label of every run of
//! the same class in the row above that touches it (8-connectivity), merging labels through a
//! union-find table; statistics accumulate per provisional label and fold into the roots at the
//! end. Capacities are const generics; running out is an error, never a truncation.

use super::background::{Background, RowLevels};
use crate::capacity::{BACKGROUND_TILE, MAX_CHIP_SIDE, MAX_TILES_PER_SIDE};
use crate::chip::ChipView;
use crate::point::ImagePoint;

/// The largest box of [`Labeler::label_box`], px.
pub const MAX_BOX_PX: usize = 5;

/// The residuals [`Labeler::label_box`] holds for its box's rows: [`MAX_BOX_PX`] rows of a
/// chip half the largest side wide (5 KiB of stack).
const HELD_FLOATS: usize = MAX_BOX_PX * MAX_CHIP_SIDE / 2;

/// The background-subtracted values of row `y` from column `x_start`, into `out` (its length).
fn residuals_of_row(
    chip: &ChipView,
    background: &Background,
    y: usize,
    x_start: usize,
    out: &mut [f32],
) {
    background.fill_row(y, x_start, out);
    chip.zip_span(y, x_start, out.iter_mut(), |value, r| {
        *r = f32::from(value) - *r;
    });
}

/// The background-subtracted values of row `y` from column `x_start` into `out`, which holds
/// the background there on entry, each value also classed by `classify` into `classes` in the
/// same pass.
fn classified_row(
    chip: &ChipView,
    (y, x_start): (usize, usize),
    out: &mut [f32],
    classes: &mut [i8],
    classify: &impl Fn(f32) -> i8,
) {
    let slots = out.iter_mut().zip(classes.iter_mut());
    chip.zip_span(y, x_start, slots, |value, (r, class)| {
        *r = f32::from(value) - *r;
        *class = classify(*r);
    });
}

/// Classifies each column of `column_sums` (sums over `n_rows` rows) by its mean over the
/// `2 half + 1` columns around it (clipped at the row's ends), into `classes`: a running sum,
/// each column added as it enters the box and taken off as it leaves, in that order. The
/// columns whose box is whole have their own loop (no ends to test, the same divisor): the
/// faint pass runs it on every pixel of the chip.
fn box_across(
    column_sums: &[f32],
    half: usize,
    n_rows: f32,
    classes: &mut [i8],
    classify: &impl Fn(f32) -> i8,
) {
    let width = column_sums.len().min(classes.len());
    let mut sum: f32 = column_sums.iter().take(half.min(width)).sum();
    // Column `x` with its box clipped by the row's ends.
    let at_end = |x: usize, sum: &mut f32, classes: &mut [i8]| {
        if x + half < width
            && let Some(&entering) = column_sums.get(x + half)
        {
            *sum += entering;
        }
        let lo = x.saturating_sub(half);
        let hi = (x + half + 1).min(width);
        if let Some(c) = classes.get_mut(x) {
            *c = classify(*sum / (n_rows * (hi - lo) as f32));
        }
        if x >= half
            && let Some(&leaving) = column_sums.get(x - half)
        {
            *sum -= leaving;
        }
    };
    // The columns whose box is whole: `whole.start` at least `half`, `whole.end + half` at most
    // `width`.
    let whole = half.min(width)..width.saturating_sub(half).max(half.min(width));
    for x in 0..whole.start {
        at_end(x, &mut sum, classes);
    }
    let divisor = n_rows * (2 * half + 1) as f32;
    let entering = column_sums.get(whole.start + half..).unwrap_or_default();
    let leaving = (whole.start.checked_sub(half))
        .and_then(|first| column_sums.get(first..))
        .unwrap_or_default();
    let inside = classes.get_mut(whole.clone()).unwrap_or_default();
    for ((class, &entering), &leaving) in inside.iter_mut().zip(entering).zip(leaving) {
        sum += entering;
        *class = classify(sum / divisor);
        sum -= leaving;
    }
    for x in whole.end..width {
        at_end(x, &mut sum, classes);
    }
}

/// Column spans of a chip row, left to right, one per run of neighbouring tiles at most.
type Spans = heapless::Vec<core::ops::Range<usize>, MAX_TILES_PER_SIDE>;

/// The spans of `columns` in tile row `ty` over the tiles whose pixels `classify` may give a
/// nonzero class, by the bounds of their background-subtracted values
/// ([`Background::residual_bounds`]; `scratch` holds a background row): where there are no
/// bounds, all of `columns`.
fn classed_spans(
    chip: &ChipView,
    background: &Background,
    ty: usize,
    columns: core::ops::Range<usize>,
    scratch: &mut [f32],
    classify: &impl Fn(f32) -> i8,
) -> Spans {
    let mut spans = Spans::new();
    let mut bounds = [(f32::NEG_INFINITY, f32::INFINITY); MAX_TILES_PER_SIDE];
    if !background.residual_bounds(chip, ty, scratch, &mut bounds) {
        // One span: the vector holds at least one.
        let _ = spans.push(columns);
        return spans;
    }
    for (tx, &(low, high)) in bounds.iter().enumerate() {
        let quiet =
            low.is_finite() && high.is_finite() && classify(low) == 0 && classify(high) == 0;
        let tile = tx * BACKGROUND_TILE..(tx + 1) * BACKGROUND_TILE;
        let (from, to) = (tile.start.max(columns.start), tile.end.min(columns.end));
        if quiet || from >= to {
            continue;
        }
        match spans.last_mut() {
            Some(last) if last.end == from => last.end = to,
            // As many spans as tiles at most.
            _ => {
                let _ = spans.push(from..to);
            }
        }
    }
    spans
}

/// Columns of a row bounded at a time by [`busy_spans`]: over so few the sky varies little and
/// the noise's extremes stay near its deviation, so the bounds are tight; aligned to multiples
/// of it, a group never straddles two tiles.
const SCREEN_PX: usize = 32;

// A group lies in one tile.
const _: () = assert!(BACKGROUND_TILE % SCREEN_PX == 0);

/// Calls `label` with each span of `columns` of row `y` that holds a pixel `classify` may give
/// a nonzero class: the columns are bounded [`SCREEN_PX`] at a time, by the extremes of their
/// samples against those of the row's background `levels` ([`RowLevels::try_for_each_group`]);
/// neighbouring busy groups make one span. A span left out holds only class 0, so the
/// runs are those of labeling all of `columns`.
fn busy_spans<E>(
    chip: &ChipView,
    levels: &RowLevels,
    y: usize,
    columns: core::ops::Range<usize>,
    classify: &impl Fn(f32) -> i8,
    mut label: impl FnMut(core::ops::Range<usize>) -> Result<(), E>,
) -> Result<(), E> {
    let mut busy: Option<core::ops::Range<usize>> = None;
    levels.try_for_each_group(columns, SCREEN_PX, |group, low, high| {
        let quiet = chip
            .span_range(y, group.start, group.end)
            .is_some_and(|(lowest, highest)| {
                classify(f32::from(lowest) - high) == 0 && classify(f32::from(highest) - low) == 0
            });
        match (&mut busy, quiet) {
            (Some(span), false) => span.end = group.end,
            (None, false) => busy = Some(group),
            (_, true) => {
                if let Some(span) = busy.take() {
                    return label(span);
                }
            }
        }
        Ok(())
    })?;
    busy.map_or(Ok(()), label)
}

/// A horizontal run of pixels of one class.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Run {
    /// Row, px.
    pub y: u16,
    /// First column, px.
    pub x0: u16,
    /// Last column (inclusive), px.
    pub x1: u16,
    /// Provisional label (resolve with [`Labeler::root`]).
    pub label: u16,
}

/// A rectangle of chip pixels, `x0..x1` x `y0..y1`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Rect {
    /// First column, px.
    pub x0: u16,
    /// First row, px.
    pub y0: u16,
    /// One past the last column, px.
    pub x1: u16,
    /// One past the last row, px.
    pub y1: u16,
}

impl Rect {
    /// This rectangle grown by `margin` px on every side and clipped to a `width` x `height` chip.
    pub fn grown(&self, margin: u16, width: usize, height: usize) -> Rect {
        Rect {
            x0: self.x0.saturating_sub(margin),
            y0: self.y0.saturating_sub(margin),
            x1: self.x1.saturating_add(margin).min(width as u16),
            y1: self.y1.saturating_add(margin).min(height as u16),
        }
    }

    /// True when `point` (chip px) lies in the rectangle.
    pub fn contains(&self, point: ImagePoint) -> bool {
        (f32::from(self.x0)..f32::from(self.x1)).contains(&point.x)
            && (f32::from(self.y0)..f32::from(self.y1)).contains(&point.y)
    }

    /// True when the rectangle reaches an edge of a `width` x `height` chip.
    pub fn touches_edge(&self, width: usize, height: usize) -> bool {
        self.x0 == 0
            || self.y0 == 0
            || usize::from(self.x1) >= width
            || usize::from(self.y1) >= height
    }
}

/// Pixel statistics of a label.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Moments {
    /// Pixel count.
    pub n: u32,
    sx: u64,
    sy: u64,
    sxx: u64,
    syy: u64,
    sxy: u64,
    /// Sum of background-subtracted values, grey levels.
    pub sum_residual: f32,
    /// Sum of raw values, grey levels.
    pub sum_value: u64,
    /// Bounding box.
    pub bbox: Rect,
    /// Class of the pixels (+1 brighter, -1 darker than the background).
    pub class: i8,
}

impl Moments {
    pub(crate) fn empty(class: i8) -> Self {
        Moments {
            n: 0,
            sx: 0,
            sy: 0,
            sxx: 0,
            syy: 0,
            sxy: 0,
            sum_residual: 0.0,
            sum_value: 0,
            bbox: Rect {
                x0: u16::MAX,
                y0: u16::MAX,
                x1: 0,
                y1: 0,
            },
            class,
        }
    }

    /// Adds the run `x0..=x1` of row `y` (exact integer sums).
    pub(crate) fn add_run(&mut self, y: u16, x0: u16, x1: u16, sum_residual: f32, sum_value: u64) {
        let n = u64::from(x1 - x0) + 1;
        let (a, b, yy) = (u64::from(x0), u64::from(x1), u64::from(y));
        let sum_x = (a + b) * n / 2;
        // Sum of x^2 for x in a..=b = S(b) - S(a - 1), S(k) = k (k + 1) (2k + 1) / 6.
        let s = |k: u64| k * (k + 1) * (2 * k + 1) / 6;
        let sum_xx = s(b) - if a == 0 { 0 } else { s(a - 1) };
        self.n += n as u32;
        self.sx += sum_x;
        self.sy += yy * n;
        self.sxx += sum_xx;
        self.syy += yy * yy * n;
        self.sxy += yy * sum_x;
        self.sum_residual += sum_residual;
        self.sum_value += sum_value;
        self.bbox.x0 = self.bbox.x0.min(x0);
        self.bbox.x1 = self.bbox.x1.max(x1 + 1);
        self.bbox.y0 = self.bbox.y0.min(y);
        self.bbox.y1 = self.bbox.y1.max(y + 1);
    }

    /// Adds another label's statistics.
    pub fn merge(&mut self, other: &Moments) {
        self.n += other.n;
        self.sx += other.sx;
        self.sy += other.sy;
        self.sxx += other.sxx;
        self.syy += other.syy;
        self.sxy += other.sxy;
        self.sum_residual += other.sum_residual;
        self.sum_value += other.sum_value;
        self.bbox.x0 = self.bbox.x0.min(other.bbox.x0);
        self.bbox.y0 = self.bbox.y0.min(other.bbox.y0);
        self.bbox.x1 = self.bbox.x1.max(other.bbox.x1);
        self.bbox.y1 = self.bbox.y1.max(other.bbox.y1);
    }

    /// Centroid, px.
    pub fn centroid(&self) -> ImagePoint {
        let n = self.n.max(1) as f32;
        ImagePoint::new(self.sx as f32 / n, self.sy as f32 / n)
    }

    /// Central second moments (xx, yy, xy), px^2, each pixel a unit square (variance 1/12 added).
    pub fn covariance(&self) -> (f32, f32, f32) {
        let n = self.n.max(1) as f32;
        let ImagePoint { x: cx, y: cy } = self.centroid();
        let xx = self.sxx as f32 / n - cx * cx + 1.0 / 12.0;
        let yy = self.syy as f32 / n - cy * cy + 1.0 / 12.0;
        let xy = self.sxy as f32 / n - cx * cy;
        (xx.max(1.0 / 12.0), yy.max(1.0 / 12.0), xy)
    }

    /// Mean background-subtracted value, grey levels.
    pub fn mean_residual(&self) -> f32 {
        self.sum_residual / self.n.max(1) as f32
    }

    /// Mean raw value, grey levels.
    pub fn mean_value(&self) -> f32 {
        self.sum_value as f32 / self.n.max(1) as f32
    }
}

/// A capacity of the labeler ran out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LabelError {
    /// More runs than the run table holds.
    Runs,
    /// More provisional labels than the label table holds.
    Labels,
}

/// The labeler and its tables: `MAX_RUNS` runs and `MAX_LABELS` provisional labels.
pub struct Labeler<const MAX_RUNS: usize, const MAX_LABELS: usize> {
    runs: heapless::Vec<Run, MAX_RUNS>,
    parent: heapless::Vec<u16, MAX_LABELS>,
    moments: heapless::Vec<Moments, MAX_LABELS>,
}

impl<const MAX_RUNS: usize, const MAX_LABELS: usize> Default for Labeler<MAX_RUNS, MAX_LABELS> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const MAX_RUNS: usize, const MAX_LABELS: usize> Labeler<MAX_RUNS, MAX_LABELS> {
    /// An empty labeler.
    pub const fn new() -> Self {
        Labeler {
            runs: heapless::Vec::new(),
            parent: heapless::Vec::new(),
            moments: heapless::Vec::new(),
        }
    }

    /// Labels `region` of the chip. Each pixel's background-subtracted value goes through
    /// `classify`, which returns its class (0 for background); the values it gives 0 must form
    /// an interval (a band about zero, or a half-line). On success every label is resolved and
    /// its statistics folded into its root.
    ///
    /// A tile of the background model ([`Background::residual_bounds`]) whose every pixel is
    /// bound to class 0 is not read: on a clear sky that is most of the chip. In the other
    /// tiles, a row's pixels are bounded `SCREEN_PX` (32) at a time against the sky
    /// ([`RowLevels`]) and only those that may leave it are classed. The runs are the same as if
    /// every pixel had been.
    pub fn label(
        &mut self,
        chip: &ChipView,
        background: &Background,
        region: Rect,
        classify: impl Fn(f32) -> i8,
    ) -> Result<(), LabelError> {
        self.label_box(chip, background, region, 1, classify)
    }

    /// Labels `region` as [`Labeler::label`] does, but classifies each pixel by the mean
    /// background-subtracted value over the `box_px` x `box_px` box around it (odd, at most
    /// [`MAX_BOX_PX`]; clipped to the region): a body as wide as the box keeps its contrast while
    /// the noise falls by the box's side, so a faint body comes out whole. The runs' statistics
    /// are those of the pixels' own values. Each row is read once per row of the box (no row
    /// store: the firmware's stack has no room for one). With a box of 1 px, this is
    /// [`Labeler::label`].
    pub fn label_box(
        &mut self,
        chip: &ChipView,
        background: &Background,
        region: Rect,
        box_px: usize,
        classify: impl Fn(f32) -> i8,
    ) -> Result<(), LabelError> {
        self.runs.clear();
        self.parent.clear();
        self.moments.clear();
        let half = (box_px.clamp(1, MAX_BOX_PX) - 1) / 2;
        if half == 0 {
            self.label_pixels(chip, background, region, classify)
        } else {
            self.label_boxes(chip, background, region, half, classify)
        }
    }

    /// [`Labeler::label_box`] on the box mean, `half` px (at least 1) on either side of each
    /// pixel, the tables cleared. Not inlined, as [`Labeler::label_pixels`] is not: their row
    /// buffers never share the firmware's stack.
    #[inline(never)]
    fn label_boxes(
        &mut self,
        chip: &ChipView,
        background: &Background,
        region: Rect,
        half: usize,
        classify: impl Fn(f32) -> i8,
    ) -> Result<(), LabelError> {
        let x_start = usize::from(region.x0);
        let x_end = usize::from(region.x1).min(chip.width());
        let width = x_end.saturating_sub(x_start).min(MAX_CHIP_SIDE);
        let (y_start, y_end) = (
            usize::from(region.y0),
            usize::from(region.y1).min(chip.height()),
        );
        // The residuals of the rows the box spans, each row computed once, in slot `r % side`
        // of `held`, where they fit (a chip up to `HELD_FLOATS / MAX_BOX_PX` px wide); else
        // every row again for each box it is in, in slot 0.
        let side = 2 * half + 1;
        let ring = side * width <= HELD_FLOATS;
        let mut held = [0.0f32; HELD_FLOATS];
        let mut box_row = [0.0f32; MAX_CHIP_SIDE];
        let mut class_row = [0i8; MAX_CHIP_SIDE];
        let (Some(boxed), Some(classes)) = (box_row.get_mut(..width), class_row.get_mut(..width))
        else {
            return Ok(());
        };
        let slot_of = |r: usize| if ring { (r % side) * width } else { 0 };
        let mut computed = y_start; // with the ring: the rows before this are in it
        let mut prev = 0..0;
        for y in y_start..y_end {
            // The column sums over the box's rows (in order, from zero), then a running sum
            // across the columns.
            let rows = y.saturating_sub(half).max(y_start)..(y + half + 1).min(y_end);
            let n_rows = rows.len().max(1) as f32;
            for r in rows.clone() {
                let Some(residuals) = held.get_mut(slot_of(r)..slot_of(r) + width) else {
                    return Ok(());
                };
                if !ring || r >= computed {
                    residuals_of_row(chip, background, r, x_start, residuals);
                }
                // The first row is the sum from zero (a residual is never -0: `v - sky`).
                let sums = boxed.iter_mut().zip(residuals.iter());
                if r == rows.start {
                    sums.for_each(|(b, v)| *b = *v);
                } else {
                    sums.for_each(|(b, v)| *b += v);
                }
            }
            computed = rows.end;
            box_across(boxed, half, n_rows, classes, &classify);
            if !ring && let Some(residuals) = held.get_mut(..width) {
                residuals_of_row(chip, background, y, x_start, residuals);
            }
            let Some(residuals) = held.get(slot_of(y)..slot_of(y) + width) else {
                return Ok(());
            };
            prev = self.push_row(chip, y, x_start, classes, residuals, prev)?;
        }
        self.resolve();
        Ok(())
    }

    /// [`Labeler::label_box`] pixel by pixel (a box of 1 px), the tables cleared: each row read
    /// only over the tiles whose pixels are not all bound to class 0 ([`classed_spans`]). Not
    /// inlined: its row buffers and the box's never share the firmware's stack.
    #[inline(never)]
    fn label_pixels(
        &mut self,
        chip: &ChipView,
        background: &Background,
        region: Rect,
        classify: impl Fn(f32) -> i8,
    ) -> Result<(), LabelError> {
        let columns = usize::from(region.x0)..usize::from(region.x1).min(chip.width());
        let rows = usize::from(region.y0)..usize::from(region.y1).min(chip.height());
        let mut residual_row = [0.0f32; MAX_CHIP_SIDE];
        let mut class_row = [0i8; MAX_CHIP_SIDE];
        let mut spans = Spans::new();
        let mut tile_row = None;
        let mut prev = 0..0;
        // The rows' background from the tiles, bounded to pass over the quiet columns.
        let from_tiles = background.from_tiles(chip);
        let mut levels = RowLevels::new();
        for y in rows {
            let ty = y / BACKGROUND_TILE;
            if tile_row != Some(ty) {
                tile_row = Some(ty);
                let scratch = &mut residual_row;
                spans = classed_spans(chip, background, ty, columns.clone(), scratch, &classify);
            }
            let row_start = self.runs.len();
            if from_tiles && !spans.is_empty() {
                levels.set(background, y);
            }
            let mut label_span = |span: core::ops::Range<usize>| {
                let slots = span.start - columns.start..span.end - columns.start;
                let (Some(residuals), Some(classes)) = (
                    residual_row.get_mut(slots.clone()),
                    class_row.get_mut(slots),
                ) else {
                    return Ok(());
                };
                if from_tiles {
                    levels.fill(span.start, residuals);
                } else {
                    background.fill_row(y, span.start, residuals);
                }
                classified_row(chip, (y, span.start), residuals, classes, &classify);
                self.push_row(chip, y, span.start, classes, residuals, prev.clone())
                    .map(|_| ())
            };
            for span in &spans {
                if from_tiles {
                    busy_spans(chip, &levels, y, span.clone(), &classify, &mut label_span)?;
                } else {
                    label_span(span.clone())?;
                }
            }
            prev = row_start..self.runs.len();
        }
        self.resolve();
        Ok(())
    }

    /// Cuts row `y` (from column `x_start`, `classes` and `residuals` per pixel) into runs of
    /// equal nonzero class and labels them against the previous row's runs `prev`; returns
    /// this row's runs.
    fn push_row(
        &mut self,
        chip: &ChipView,
        y: usize,
        x_start: usize,
        classes: &[i8],
        residuals: &[f32],
        prev: core::ops::Range<usize>,
    ) -> Result<core::ops::Range<usize>, LabelError> {
        let width = classes.len().min(residuals.len());
        let row_start = self.runs.len();
        let mut i = 0usize;
        while i < width {
            // The sky, four pixels at a time.
            if classes.get(i..i + 4) == Some(&[0i8; 4][..]) {
                i += 4;
                continue;
            }
            let class = classes.get(i).copied().unwrap_or(0);
            if class == 0 {
                i += 1;
                continue;
            }
            let first = i;
            while i < width && classes.get(i).copied() == Some(class) {
                i += 1;
            }
            let sum_r: f32 = residuals.get(first..i).map_or(0.0, |r| r.iter().sum());
            let mut sum_v = 0u64;
            chip.for_each_in_span(y, x_start + first, x_start + i, |_, v| {
                sum_v += u64::from(v)
            });
            let (x0, x1) = ((x_start + first) as u16, (x_start + i - 1) as u16);
            self.push_run(y as u16, x0, x1, class, sum_r, sum_v, prev.clone())?;
        }
        Ok(row_start..self.runs.len())
    }

    #[allow(clippy::too_many_arguments)]
    fn push_run(
        &mut self,
        y: u16,
        x0: u16,
        x1: u16,
        class: i8,
        sum_r: f32,
        sum_v: u64,
        prev: core::ops::Range<usize>,
    ) -> Result<(), LabelError> {
        let mut label: Option<u16> = None;
        for i in prev {
            let Some(&above) = self.runs.get(i) else {
                break;
            };
            if above.x0 > x1.saturating_add(1) {
                break;
            }
            if above.x1.saturating_add(1) < x0 || self.class_of(above.label) != class {
                continue;
            }
            let root = self.find(above.label);
            label = Some(match label {
                None => root,
                Some(l) => self.union(l, root),
            });
        }
        let label = match label {
            Some(l) => l,
            None => {
                let l = self.parent.len() as u16;
                self.parent.push(l).map_err(|_| LabelError::Labels)?;
                self.moments
                    .push(Moments::empty(class))
                    .map_err(|_| LabelError::Labels)?;
                l
            }
        };
        if let Some(m) = self.moments.get_mut(usize::from(label)) {
            m.add_run(y, x0, x1, sum_r, sum_v);
        }
        self.runs
            .push(Run { y, x0, x1, label })
            .map_err(|_| LabelError::Runs)
    }

    fn class_of(&self, label: u16) -> i8 {
        self.moments.get(usize::from(label)).map_or(0, |m| m.class)
    }

    /// The root of a label.
    pub fn root(&self, label: u16) -> u16 {
        let mut l = label;
        while let Some(&p) = self.parent.get(usize::from(l)) {
            if p == l {
                break;
            }
            l = p;
        }
        l
    }

    fn find(&mut self, label: u16) -> u16 {
        let root = self.root(label);
        // Path compression.
        let mut l = label;
        while l != root {
            let Some(p) = self.parent.get_mut(usize::from(l)) else {
                break;
            };
            let next = *p;
            *p = root;
            l = next;
        }
        root
    }

    /// Joins two roots; the smaller label becomes the root.
    fn union(&mut self, a: u16, b: u16) -> u16 {
        let (keep, drop) = if a <= b { (a, b) } else { (b, a) };
        if let Some(p) = self.parent.get_mut(usize::from(drop)) {
            *p = keep;
        }
        keep
    }

    /// Points every label at its root and folds statistics into roots (roots are always smaller
    /// than the labels joined to them, so one pass in order suffices).
    fn resolve(&mut self) {
        for l in 0..self.parent.len() {
            let root = self.find(l as u16);
            if usize::from(root) == l {
                continue;
            }
            let Some(&m) = self.moments.get(l) else {
                continue;
            };
            if let Some(r) = self.moments.get_mut(usize::from(root)) {
                r.merge(&m);
            }
        }
    }

    /// Root labels and their statistics, in label order.
    pub fn components(&self) -> impl Iterator<Item = (u16, &Moments)> {
        self.moments
            .iter()
            .enumerate()
            .filter(|(l, _)| self.parent.get(*l).is_some_and(|p| usize::from(*p) == *l))
            .map(|(l, m)| (l as u16, m))
    }

    /// Every run, with its provisional label.
    pub fn runs(&self) -> &[Run] {
        &self.runs
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    type Small = Labeler<64, 16>;

    fn label_u8<const R: usize, const L: usize>(
        labeler: &mut Labeler<R, L>,
        data: &[u8],
        w: usize,
        h: usize,
    ) -> Result<(), LabelError> {
        let chip = ChipView::gray8(data, w, h, w, 0, 0).unwrap();
        let bg = Background::new(); // all-zero background: the residual is the value
        let region = Rect {
            x0: 0,
            y0: 0,
            x1: w as u16,
            y1: h as u16,
        };
        labeler.label(&chip, &bg, region, |r| if r > 100.0 { 1 } else { 0 })
    }

    /// A bar 5 px wide whose contrast is 2 noise deviations, on a sky of +-1 sigma noise (a
    /// fixed pseudo-random pattern): classified pixel by pixel at 1 sigma it falls apart into
    /// many pieces; on its 3 x 3 box mean (noise 1/3 sigma) at 3 box sigmas it is one component
    /// holding the bar's area, and the sky gives nothing of note.
    #[test]
    fn a_faint_bar_comes_out_whole_on_its_box_mean() {
        let (w, h) = (96usize, 48usize);
        let sigma = 8.0f32;
        let mut data = [0u8; 96 * 48];
        // Uniform on +-sqrt 3 sigma (standard deviation sigma).
        let mut noise = crate::testing::uniform_noise(w * h, 12345);
        for y in 0..h {
            for x in 0..w {
                let noise = noise.next().unwrap_or(0.0) * sigma;
                let bar = (22..27).contains(&y) && (10..86).contains(&x);
                let value = 100.0 + noise + if bar { 2.0 * sigma } else { 0.0 };
                data[y * w + x] = value as u8;
            }
        }
        let chip = ChipView::gray8(&data, w, h, w, 0, 0).unwrap();
        let mut bg = Background::new();
        bg.estimate(&chip);
        let region = Rect {
            x0: 0,
            y0: 0,
            x1: w as u16,
            y1: h as u16,
        };
        let mut l = Labeler::<4096, 1024>::new();
        l.label(&chip, &bg, region, |r| i8::from(r > sigma))
            .unwrap();
        let pieces = l.components().filter(|(_, m)| m.n >= 6).count();
        assert!(
            pieces > 5,
            "pixel by pixel the bar breaks up: {pieces} pieces"
        );
        l.label_box(&chip, &bg, region, 3, |r| i8::from(r > sigma))
            .unwrap();
        let mut big: heapless::Vec<u32, 64> = l
            .components()
            .filter(|(_, m)| m.n >= 6)
            .map(|(_, m)| m.n)
            .collect();
        big.sort_unstable();
        assert_eq!(big.len(), 1, "one component on the box mean: {big:?}");
        // The bar has 5 x 76 = 380 px; the box mean reaches a pixel or so beyond its edges.
        assert!((300..=620).contains(&big[0]), "{big:?}");
    }

    /// The tiles left unread are exactly those whose pixels all class 0: on a sky with a
    /// gradient, noise, bodies of both polarities (one across a tile corner) and single pixels
    /// just past the threshold, the runs cover
    /// the same pixels with the same classes as classing every pixel against the background
    /// row, in the whole chip and in a region cut across tiles; and most tiles were not read.
    #[test]
    fn unread_tiles_lose_no_classed_pixel() {
        const W: usize = 160;
        const H: usize = 128;
        let sigma = 3.0f32;
        let mut data = [0u8; W * H];
        let noise = crate::testing::uniform_noise(W * H, 24_681_357);
        for (i, (v, noise)) in data.iter_mut().zip(noise).enumerate() {
            let (x, y) = (i % W, i / W);
            let (xf, yf) = (x as f32, y as f32);
            let dark = (60..66).contains(&y) && (20..90).contains(&x);
            let bright = (xf - 96.0).powi(2) + (yf - 32.0).powi(2) < 36.0;
            let body = if dark {
                -40.0
            } else if bright {
                30.0
            } else {
                0.0
            };
            let sky = 90.0 + 0.15 * xf + 0.1 * yf;
            *v = (sky + noise * sigma + body) as u8;
        }
        // Single pixels less than a grey level past the threshold, alone in their tiles, where
        // the sky is lowest (for the bright ones) or highest (the dark one) in the tile: there
        // the bounds are as tight as they get.
        let specks = [(128, 0, 1.0f32), (32, 96, 1.0), (159, 127, -1.0)];
        let mut bg = Background::new();
        for _ in 0..2 {
            let chip = ChipView::gray8(&data, W, H, W, 0, 0).unwrap();
            bg.estimate(&chip);
            let threshold = 4.5 * bg.sigma();
            let mut sky = [0.0f32; W];
            for (x, y, sign) in specks {
                bg.fill_row(y, 0, &mut sky);
                data[y * W + x] = (sky[x] + sign * (threshold + 0.5)).round() as u8;
            }
        }
        let chip = ChipView::gray8(&data, W, H, W, 0, 0).unwrap();
        bg.estimate(&chip);
        let threshold = 4.5 * bg.sigma();
        let classify = |r: f32| {
            if r > threshold {
                1
            } else if r < -threshold {
                -1
            } else {
                0
            }
        };
        for region in [
            Rect {
                x0: 0,
                y0: 0,
                x1: W as u16,
                y1: H as u16,
            },
            Rect {
                x0: 13,
                y0: 7,
                x1: 121,
                y1: 101,
            },
        ] {
            let mut l = Labeler::<4096, 1024>::new();
            l.label(&chip, &bg, region, classify).unwrap();
            let mut labeled = [0i8; W * H];
            for run in l.runs() {
                let class = l.class_of(l.root(run.label));
                for x in run.x0..=run.x1 {
                    labeled[usize::from(run.y) * W + usize::from(x)] = class;
                }
            }
            let mut sky = [0.0f32; W];
            let mut classed = 0;
            for y in usize::from(region.y0)..usize::from(region.y1) {
                bg.fill_row(y, 0, &mut sky);
                for x in usize::from(region.x0)..usize::from(region.x1) {
                    let expected = classify(f32::from(data[y * W + x]) - sky[x]);
                    assert_eq!(labeled[y * W + x], expected, "pixel ({x}, {y})");
                    classed += usize::from(expected != 0);
                }
            }
            assert!(classed > 400, "the bodies are classed: {classed} px");
            for (x, y, sign) in specks {
                if region.contains(ImagePoint::new(x as f32, y as f32)) {
                    assert_eq!(labeled[y * W + x], sign as i8, "speck ({x}, {y})");
                }
            }
        }
        // Within the read tiles, the screen: on a row of the dark bar (columns 20 to 89) only
        // the groups the bar lies in are labeled, on a row of sky alone none.
        let mut levels = RowLevels::new();
        let bar = (
            20 / SCREEN_PX * SCREEN_PX,
            90usize.div_ceil(SCREEN_PX) * SCREEN_PX,
        );
        for (y, expected) in [(62, &[bar][..]), (20, &[][..])] {
            levels.set(&bg, y);
            let mut spans = heapless::Vec::<(usize, usize), 8>::new();
            let mut push = |s: core::ops::Range<usize>| spans.push((s.start, s.end));
            busy_spans(&chip, &levels, y, 0..W, &classify, &mut push).unwrap();
            assert_eq!(&spans[..], expected, "row {y}");
        }
        let mut scratch = [0.0f32; W];
        let spans: [Spans; H / BACKGROUND_TILE] =
            core::array::from_fn(|ty| classed_spans(&chip, &bg, ty, 0..W, &mut scratch, &classify));
        // The tiles of the bodies and the single pixels, and no others (none of the region's).
        let expected: [&[(usize, usize)]; 4] = [
            &[(64, 160)],
            &[(0, 128)],
            &[(0, 96)],
            &[(32, 64), (128, 160)],
        ];
        for (spans, expected) in spans.iter().zip(expected) {
            let read = spans.iter().map(|span| (span.start, span.end));
            assert!(read.eq(expected.iter().copied()), "{spans:?}");
        }
    }

    /// The running box mean across a row classes each column as its clipped box's mean does,
    /// computed afresh: integer column sums keep both exact, so the classes must agree, at the
    /// row's ends, inside, and where the box is wider than the row.
    #[test]
    fn a_rows_running_box_mean_is_each_boxs_own() {
        let sums: [f32; 40] = core::array::from_fn(|i| ((i * 37 + 11) % 23) as f32 - 11.0);
        let classify = |m: f32| {
            if m > 0.9 {
                1
            } else if m < -0.9 {
                -1
            } else {
                0
            }
        };
        for width in [0, 1, 2, 3, 4, 5, 7, 12, 40] {
            for half in [1, 2, 3] {
                let n_rows = 3.0;
                let mut classes = [7i8; 40];
                box_across(
                    &sums[..width],
                    half,
                    n_rows,
                    &mut classes[..width],
                    &classify,
                );
                for (x, &class) in classes[..width].iter().enumerate() {
                    let (lo, hi) = (x.saturating_sub(half), (x + half + 1).min(width));
                    let mean = sums[lo..hi].iter().sum::<f32>() / (n_rows * (hi - lo) as f32);
                    assert_eq!(class, classify(mean), "width {width} half {half} x {x}");
                }
                assert!(
                    classes[width..].iter().all(|&c| c == 7),
                    "nothing past the row"
                );
            }
        }
    }

    #[test]
    fn box_rows_held_or_computed_again_label_alike() {
        // 5 rows of 200 px fit the held residuals, of 320 px do not: the bar far from either
        // region's right edge must come out the same, bit for bit.
        const W: usize = 320;
        let h = 48usize;
        let sigma = 8.0f32;
        let mut data = [0u8; W * 48];
        let noise = crate::testing::uniform_noise(W * 48, 987_654_321);
        for (i, (v, noise)) in data.iter_mut().zip(noise).enumerate() {
            let (x, y) = (i % W, i / W);
            let bar = (22..27).contains(&y) && (10..86).contains(&x);
            let value = 100.0 + noise * sigma + if bar { 2.0 * sigma } else { 0.0 };
            *v = value as u8;
        }
        let chip = ChipView::gray8(&data, W, h, W, 0, 0).unwrap();
        let mut bg = Background::new();
        bg.estimate(&chip);
        let bar = |x1: u16| {
            let region = Rect {
                x0: 0,
                y0: 0,
                x1,
                y1: h as u16,
            };
            let mut l = Labeler::<4096, 1024>::new();
            l.label_box(&chip, &bg, region, 5, |r| i8::from(r > sigma))
                .unwrap();
            l.components().map(|(_, m)| *m).max_by_key(|m| m.n).unwrap()
        };
        const { assert!(5 * 200 <= HELD_FLOATS && 5 * W > HELD_FLOATS) };
        let (held, again) = (bar(200), bar(W as u16));
        assert!(held.n >= 300, "{held:?}");
        assert_eq!(held, again);
    }

    #[test]
    fn eight_connectivity_joins_diagonals_and_u_shapes() {
        #[rustfmt::skip]
        let img: [u8; 6 * 5] = [
            255, 0, 0, 0, 0, 255,
            0, 255, 0, 0, 255, 0,
            0, 0, 255, 255, 0, 0,
            0, 0, 0, 0, 0, 0,
            255, 255, 0, 0, 0, 255,
        ];
        let mut l = Small::new();
        label_u8(&mut l, &img, 6, 5).unwrap();
        let comps: heapless::Vec<_, 8> = l.components().map(|(_, m)| m.n).collect();
        assert_eq!(
            comps.as_slice(),
            &[6, 2, 1],
            "V shape joined diagonally; two separate blobs"
        );
    }

    #[test]
    fn moments_match_a_hand_computed_rectangle() {
        let mut img = [0u8; 10 * 8];
        for y in 2..5 {
            for x in 3..8 {
                img[y * 10 + x] = 200;
            }
        }
        let mut l = Small::new();
        label_u8(&mut l, &img, 10, 8).unwrap();
        let (_, m) = l.components().next().unwrap();
        assert_eq!(m.n, 15);
        assert_eq!(
            m.bbox,
            Rect {
                x0: 3,
                y0: 2,
                x1: 8,
                y1: 5
            }
        );
        let ImagePoint { x: cx, y: cy } = m.centroid();
        assert!((cx - 5.0).abs() < 1e-6 && (cy - 3.0).abs() < 1e-6);
        let (xx, yy, xy) = m.covariance();
        // Continuous 5 x 3 box: width^2 / 12.
        assert!(
            (xx - 25.0 / 12.0).abs() < 1e-4 && (yy - 9.0 / 12.0).abs() < 1e-4 && xy.abs() < 1e-5
        );
        assert!((m.mean_residual() - 200.0).abs() < 1e-3);
    }

    #[test]
    fn capacities_are_exact_limits_and_errors() {
        // One run per row in 16 rows of isolated single pixels on alternate columns:
        // a chip with exactly N isolated pixels needs N runs and N labels.
        let make = |n: usize| {
            let mut img = [0u8; 32 * 32];
            for i in 0..n {
                img[(2 * (i / 16)) * 32 + 2 * (i % 16)] = 255;
            }
            img
        };
        let mut at_limit = Labeler::<16, 16>::new();
        assert_eq!(label_u8(&mut at_limit, &make(16), 32, 32), Ok(()));
        assert_eq!(at_limit.components().count(), 16);
        let mut over_labels = Labeler::<64, 16>::new();
        assert_eq!(
            label_u8(&mut over_labels, &make(17), 32, 32),
            Err(LabelError::Labels)
        );
        let mut over_runs = Labeler::<16, 64>::new();
        assert_eq!(
            label_u8(&mut over_runs, &make(17), 32, 32),
            Err(LabelError::Runs)
        );
    }
}
