//! The detection stage: background model, threshold, connected components, target selection, and
//! the target's mask.
//!
//! [`Segmenter::detect`] thresholds the background-subtracted chip at
//! [`DetectConfig::threshold_sigma`] noise deviations on both sides (targets darker or brighter
//! than the sky), labels 8-connected components, and selects the projectile ([`select`]). Once
//! the silhouette stage has measured the body's full contrast, [`Segmenter::cut_mask`] recuts the
//! mask at a fraction of it (half, by default: the pixels at least half covered).

pub mod background;
pub mod bar;
pub mod corridor;
pub mod gate;
pub mod label;
pub mod select;
pub mod terrain;

use crate::capacity::{BAR_GRID_CELLS, DEFAULT_MAX_LABELS, DEFAULT_MAX_RUNS, MAX_COMPONENTS};
use crate::chip::ChipView;
use crate::config::BodyPolarity;
use crate::extremes::cross_profile::{self, Stretch};
use crate::extremes::{Axis, Silhouette};
use crate::mask::BitMask;
use crate::point::ImagePoint;
use background::{Background, Region};
use bar::{Bar, BarConfig, BarRefusal, BarSearch, MAX_BARS};
use corridor::CorridorConfig;
pub use gate::{TrackGate, TrackUse};
use label::{LabelError, Labeler, Moments, Rect};
pub use select::UNIFORM_BAR_HALF_SDS;
use select::{Candidate, Selection, Shape, Spread};
pub use select::{ExpectedBody, Proportions, SizeTolerance};
use terrain::TerrainConfig;

/// The detection stage's tunables.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DetectConfig {
    /// Detection threshold on the background-subtracted chip, in noise standard deviations.
    pub threshold_sigma: f32,
    /// Times the detection threshold is doubled and the chip labeled again when a table of the
    /// labeler runs out (clutter); a `capacity` status only after the last.
    pub retries: u8,
    /// Smallest component kept for target selection, px.
    pub min_area_px: u32,
    /// The body's contrast polarity; None: either (the more elongated candidate wins).
    pub polarity: Option<BodyPolarity>,
    /// Fraction of the body's full contrast at which the final mask is cut: 0.5 keeps pixels at
    /// least half covered, as the ground-truth masks (`docs/formats.md`).
    pub mask_level: f32,
    /// Lowest mask cut, in noise standard deviations (guards low-contrast targets against noise).
    pub mask_min_sigma: f32,
    /// The final cut looks this many blur standard deviations beyond the detected box ...
    pub mask_margin_sigmas: f32,
    /// ... plus this many px.
    pub mask_margin_px: f32,
    /// A body whose contrast is below this many noise sigmas is cut on its 3 px box mean (the
    /// noise a third; the half-contrast crossings of its edges stay).
    pub faint_mask_sigma: f32,
    /// A detected body whose mask is at least this wide, px, can cover more than half of a
    /// background tile and drag the sky model to its own level: the sky under it is estimated
    /// again without it ([`Background::exclude`]) ...
    pub sky_exclusion_min_width_px: f32,
    /// ... over its mask's extent times this factor ...
    pub sky_exclusion_scale: f32,
    /// ... plus this many px (the blur).
    pub sky_exclusion_px: f32,
    /// When that moves the sky by more than this many noise standard deviations and ...
    pub redetect_sigma: f32,
    /// ... this fraction of the body's mean contrast in its mask (a wide body had dragged the
    /// first estimate to its own level), the corrected sky is kept and the chip detected again
    /// on it; otherwise the first estimate stands (a cloud's texture moves it less).
    pub redetect_contrast: f32,
    /// Where the body's size is expected ([`ExpectedBody`]), how far a candidate's may stray
    /// from it: a candidate outside it (a cloud filament, terrain, a plume) is not the body.
    pub body_size: SizeTolerance,
    /// Where no candidate has the body's size, the chip is labeled again on its mean over a box
    /// this many body diameters wide (odd, 3 to [`label::MAX_BOX_PX`] px) ...
    pub faint_box_diameters: f32,
    /// ... at this many standard deviations of the box mean's noise (the noise over the box's
    /// side): a faint body comes out whole.
    pub faint_threshold_sigma: f32,
    /// Among candidates of the body's size, the score's weight of the width's agreement with the
    /// body's ([`ExpectedBody::width_agreement`]): a terrain piece or cloud is wider.
    pub width_weight: f32,
    /// ... and the bonus of a candidate of the body's `polarity` (a plume of the other one can
    /// be of the body's size and more significant than a faint body).
    pub polarity_weight: f32,
    /// The bonus of a candidate where the track expects the body ([`TrackGate`]).
    pub track_weight: f32,
    /// Where the body's size is expected, the bar search at its scale ([`bar`]); None: off.
    pub bar: Option<BarConfig>,
    /// Where no range is known, the body diameters the bar search tries, px.
    pub unknown_range_diameters_px: [f32; UNKNOWN_SCALES],
    /// The sky measured along the detected body where the tiles do not follow it
    /// ([`corridor`]); None: the tiles' everywhere.
    pub corridor: Option<CorridorConfig>,
    /// Terrain looked for along the chip's lower edge ([`terrain`]): the sky taken from above
    /// it; None: not looked for.
    pub terrain: Option<TerrainConfig>,
}

impl DetectConfig {
    /// The defaults.
    pub const DEFAULT: DetectConfig = DetectConfig {
        threshold_sigma: 4.5,
        retries: 2,
        min_area_px: 6,
        polarity: Some(BodyPolarity::Dark),
        mask_level: 0.5,
        mask_min_sigma: 2.0,
        mask_margin_sigmas: 2.0,
        mask_margin_px: 3.0,
        faint_mask_sigma: 8.0,
        sky_exclusion_min_width_px: 12.0,
        sky_exclusion_scale: 1.25,
        sky_exclusion_px: 3.0,
        redetect_sigma: 3.0,
        redetect_contrast: 0.5,
        body_size: SizeTolerance {
            min_width: 0.5,
            max_width: 1.6,
            max_length: 1.3,
            margin_px: 4.0,
        },
        faint_box_diameters: 0.6,
        faint_threshold_sigma: 4.0,
        width_weight: 4.0,
        polarity_weight: 2.0,
        track_weight: 1.0,
        bar: Some(BarConfig::DEFAULT),
        unknown_range_diameters_px: [4.0, 7.0, 12.0],
        corridor: Some(CorridorConfig::DEFAULT),
        terrain: Some(TerrainConfig::DEFAULT),
    };
}

impl Default for DetectConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// What detection knows of the body before it looks at the chip.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Expectation {
    /// Its size in the chip, where the range is known (the sensor's or the track's).
    pub size: Option<ExpectedBody>,
    /// Where the track of recent frames expects it.
    pub gate: Option<TrackGate>,
    /// Its shape in diameters (the model's), for the sizes tried where no range is known.
    pub proportions: Option<Proportions>,
    /// Whether `size` comes from a measured range (the sensor's), not one predicted from the
    /// recent frames' image ranges: only a measured size calls a strong component too short to
    /// be the body ([`BarConfig::plume_length_fraction`]; a predicted one, read short, took a
    /// body seen end on at 2 km for a plume).
    pub size_measured: bool,
}

impl Expectation {
    /// Nothing known: detection as the source paper's (the most significant candidate).
    pub const NONE: Expectation = Expectation {
        size: None,
        gate: None,
        proportions: None,
        size_measured: false,
    };
}

/// The side of the box a faint body of the `expected` size is looked for with, px: odd, 3 to
/// [`label::MAX_BOX_PX`], or less than 3 for a body too thin for a box.
fn faint_box_px(expected: &ExpectedBody, config: &DetectConfig) -> usize {
    let side = config.faint_box_diameters * expected.diameter_px;
    if side.is_nan() || side < 3.0 {
        return 1;
    }
    // Clamped before the conversion: a huge side (an absurd range or config) would overflow.
    let side = side.min(label::MAX_BOX_PX as f32);
    ((side - 1.0) / 2.0) as usize * 2 + 1
}

/// The region a detected body of mask shape `shape` and its blur cover, for the sky model to
/// leave out: the mask's extent ([`UNIFORM_BAR_HALF_SDS`]) scaled and grown by the config's sky
/// exclusion.
fn sky_exclusion(shape: &Shape, config: &DetectConfig) -> Region {
    let extent =
        |sd: f32| config.sky_exclusion_scale * UNIFORM_BAR_HALF_SDS * sd + config.sky_exclusion_px;
    Region {
        axis: Axis {
            centre: shape.centre,
            dir: shape.axis,
        },
        half_length: extent(shape.major_sd),
        half_width: extent(shape.minor_sd),
    }
}

/// Why no target came out of segmentation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SegmentError {
    /// No component of at least the minimum area.
    NoTarget,
    /// A capacity ran out.
    Capacity(CapacityKind),
    /// The target (its final mask, or a candidate of the body's expected size) reaches the
    /// chip's edge: the body has lost an end (or more), and its extremes and scale would be those
    /// of a shorter body.
    AtEdge,
}

/// Which capacity ran out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CapacityKind {
    /// The labeler's run table.
    Runs,
    /// The labeler's label table.
    Labels,
    /// More than [`MAX_COMPONENTS`] components of the minimum area.
    Components,
    /// The chip is larger than the mask.
    Mask,
}

impl From<LabelError> for SegmentError {
    fn from(e: LabelError) -> Self {
        SegmentError::Capacity(match e {
            LabelError::Runs => CapacityKind::Runs,
            LabelError::Labels => CapacityKind::Labels,
        })
    }
}

/// The segmented target.
#[derive(Debug, Clone, Copy)]
pub struct Target {
    /// The body's contrast polarity against the sky.
    pub polarity: BodyPolarity,
    /// Combined statistics of its parts.
    pub moments: Moments,
    /// Shape from the moments.
    pub shape: Shape,
    /// Number of components it was merged from.
    pub parts: u8,
    /// Components of at least the minimum area in the chip.
    pub components: u16,
    /// How the track was used to pick it.
    pub track: TrackUse,
    /// What found it.
    pub found_by: FoundBy,
}

/// What found a target.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FoundBy {
    /// The connected components of the thresholded chip (its mask is theirs).
    Components,
    /// The bar search at the body's scale ([`bar`]; its mask is the bar's rectangle).
    Bar,
}

/// The detection stage and its fixed buffers: the sky model, the labeler (`MAX_RUNS` runs,
/// `MAX_LABELS` provisional labels), the target's chip mask (`MASK_WORDS` 32-bit words) and the
/// bar search's grid (`BAR_CELLS` blocks, three 4-byte values each; fewer than 9: no bar
/// search).
pub struct Segmenter<
    const MAX_RUNS: usize = DEFAULT_MAX_RUNS,
    const MAX_LABELS: usize = DEFAULT_MAX_LABELS,
    const MASK_WORDS: usize = { crate::capacity::MASK_WORDS },
    const BAR_CELLS: usize = BAR_GRID_CELLS,
> {
    background: Background,
    labeler: Labeler<MAX_RUNS, MAX_LABELS>,
    mask: BitMask<MASK_WORDS>,
    bars: BarSearch<BAR_CELLS>,
}

impl<
    const MAX_RUNS: usize,
    const MAX_LABELS: usize,
    const MASK_WORDS: usize,
    const BAR_CELLS: usize,
> Default for Segmenter<MAX_RUNS, MAX_LABELS, MASK_WORDS, BAR_CELLS>
{
    fn default() -> Self {
        Self::new()
    }
}

impl<
    const MAX_RUNS: usize,
    const MAX_LABELS: usize,
    const MASK_WORDS: usize,
    const BAR_CELLS: usize,
> Segmenter<MAX_RUNS, MAX_LABELS, MASK_WORDS, BAR_CELLS>
{
    /// An empty segmenter.
    pub const fn new() -> Self {
        Segmenter {
            background: Background::new(),
            labeler: Labeler::new(),
            mask: BitMask::new(),
            bars: BarSearch::new(),
        }
    }

    /// The background model of the last chip.
    pub fn background(&self) -> &Background {
        &self.background
    }

    /// The target mask of the last chip (chip-sized; empty when no target was found).
    pub fn mask(&self) -> &BitMask<MASK_WORDS> {
        &self.mask
    }

    /// Empties the target mask.
    pub fn clear_mask(&mut self) {
        self.mask.clear();
    }

    /// Detects the target in `chip`, aiming near `aim` (chip px), and paints its mask. Where
    /// the body's size is expected ([`Expectation::size`]), only a candidate of that size is the
    /// target, and a body too faint to stand out pixel by pixel is looked for at its own scale.
    /// Where the track has a gate ([`Expectation::gate`]), a candidate inside it is preferred.
    pub fn detect(
        &mut self,
        chip: &ChipView,
        config: &DetectConfig,
        aim: ImagePoint,
        expect: &Expectation,
    ) -> Result<Target, SegmentError> {
        let target = self.detect_target(chip, config, aim, expect)?;
        if let Some(corridor_config) = &config.corridor {
            let shape = &target.shape;
            let width = 2.0 * UNIFORM_BAR_HALF_SDS * shape.minor_sd;
            // Without a range, the measured width and the model's proportions.
            let span_diameters = expect.proportions.map_or(1.0, |p| p.span_diameters);
            let (diameter, span) = expect.size.map_or((width, width * span_diameters), |e| {
                (e.diameter_px, e.span_px)
            });
            let half_length = UNIFORM_BAR_HALF_SDS * shape.major_sd;
            let corridor = corridor_config.shape(shape.line(), half_length, diameter, span);
            let contrast = libm::fabsf(target.moments.mean_residual());
            self.background.follow_corridor(
                chip,
                &corridor,
                corridor_config.max_disagreement * contrast,
            );
        }
        Ok(target)
    }

    /// [`Segmenter::detect`] up to the target, on the tiles' sky.
    fn detect_target(
        &mut self,
        chip: &ChipView,
        config: &DetectConfig,
        aim: ImagePoint,
        expect: &Expectation,
    ) -> Result<Target, SegmentError> {
        self.mask
            .reset(chip.width(), chip.height())
            .map_err(|_| SegmentError::Capacity(CapacityKind::Mask))?;
        self.background.estimate(chip);
        if let Some(terrain) = &config.terrain {
            self.background.estimate_terrain(chip, terrain);
        }
        let first = self.detect_on_sky(chip, config, aim, expect, None);
        let first = self.judge_by_bar(chip, config, aim, expect, first)?;
        // A bar is the body's width by construction: the sky is not estimated again under it.
        if first.found_by == FoundBy::Bar
            || UNIFORM_BAR_HALF_SDS * 2.0 * first.shape.minor_sd < config.sky_exclusion_min_width_px
        {
            return Ok(first);
        }
        let region = sky_exclusion(&first.shape, config);
        let contrast = libm::fabsf(first.moments.sum_residual) / first.moments.n.max(1) as f32;
        let min_change = (config.redetect_sigma * self.background.sigma())
            .max(config.redetect_contrast * contrast);
        if !self.background.exclude(chip, &region, min_change) {
            return Ok(first);
        }
        // Again on the corrected sky: the same body, now whole (the first detection stands if
        // nothing there has the body's size any more).
        let around = Some(first.shape.centre);
        match self.detect_on_sky(chip, config, aim, expect, around) {
            Err(SegmentError::NoTarget | SegmentError::AtEdge) => Ok(first),
            other => other,
        }
    }

    /// [`Segmenter::detect`] on the current sky model; with `around`, only a candidate whose box
    /// holds that point (chip px) can be the target. The mask is repainted only when a target
    /// is found.
    fn detect_on_sky(
        &mut self,
        chip: &ChipView,
        config: &DetectConfig,
        aim: ImagePoint,
        expect: &Expectation,
        around: Option<ImagePoint>,
    ) -> Result<Target, SegmentError> {
        let (expected, gate) = (expect.size.as_ref(), expect.gate.as_ref());
        let sigma = self.background.sigma();
        let diag = libm::hypotf(chip.width() as f32, chip.height() as f32);
        // Of the body's size, clear of the chip's edge (terrain and large clutter enter from
        // there, and a body cut by the edge has lost an end), and where it was.
        let (width, height) = (chip.width(), chip.height());
        let sized = |m: &Moments| {
            expected.is_none_or(|e| e.fits(m, &config.body_size))
                && around.is_none_or(|p| m.bbox.contains(p))
        };
        let at_edge = |m: &Moments| m.bbox.touches_edge(width, height);
        let fits = |m: &Moments| sized(m) && !at_edge(m);
        // Of the candidates that fit, the one whose width agrees best with the body's, of the
        // body's polarity where it is known.
        let judged = |m: &Moments| {
            fits(m).then(|| {
                let width = expected.map_or(0.0, |e| {
                    e.width_agreement(m, config.body_size.margin_px, config.width_weight)
                });
                let polarity = match config.polarity {
                    Some(p) if p.sign() == f32::from(m.class) => config.polarity_weight,
                    _ => 0.0,
                };
                width + polarity
            })
        };
        let select = |candidates: &heapless::Vec<Candidate, MAX_COMPONENTS>,
                      judge: &dyn Fn(&Moments) -> Option<f32>| {
            select::select(candidates, sigma, aim, diag, config.polarity, judge)
        };
        // Without an expected size, the best candidate clear of the chip's edge as the source
        // paper picks it; with one, the best of those of the body's size. Where the track has a
        // gate, a candidate inside it gains `track_weight`: the target is re-examined when that
        // changes the pick.
        let judge = |m: &Moments| match expected {
            Some(_) => judged(m),
            None => (!at_edge(m)).then_some(0.0),
        };
        let choose = |candidates: &heapless::Vec<Candidate, MAX_COMPONENTS>| {
            let best = select(candidates, &judge)?;
            let Some(gate) = gate else {
                return Some((best, TrackUse::Fresh));
            };
            let tracked = |m: &Moments| {
                judge(m).map(|score| {
                    score
                        + if gate.admits(m) {
                            config.track_weight
                        } else {
                            0.0
                        }
                })
            };
            let chosen = select(candidates, &tracked)?;
            let track = match (gate.admits(&chosen.moments), chosen.parts == best.parts) {
                (false, _) => TrackUse::Fresh,
                (true, true) => TrackUse::Gated,
                (true, false) => TrackUse::Reexamined,
            };
            Some((chosen, track))
        };
        let mut candidates = heapless::Vec::new();
        let threshold = config.threshold_sigma * sigma;
        self.labeled_candidates(chip, config, threshold, 1, &mut candidates)?;
        // A candidate of the body's size cut by the chip's edge: if nothing else is taken, the
        // body is there but has lost an end.
        let cut_by_edge = candidates
            .iter()
            .any(|c| sized(&c.moments) && at_edge(&c.moments));
        let of_body_polarity = |t: &Target| config.polarity.is_none_or(|p| p == t.polarity);
        let first = choose(&candidates).map(|(selection, track)| {
            self.mask.clear();
            paint(&self.labeler, &selection.parts, &mut self.mask);
            target_of(&selection, candidates.len(), track)
        });
        let box_px = expected.map_or(1, |e| faint_box_px(e, config));
        let missing = if cut_by_edge {
            SegmentError::AtEdge
        } else {
            SegmentError::NoTarget
        };
        match first {
            Some(target) if of_body_polarity(&target) || box_px < 3 => return Ok(target),
            None if box_px < 3 => return Err(missing),
            _ => {}
        }
        // Nothing of the body's size and polarity: the body may be too faint to stand out pixel
        // by pixel (where a plume does); it is looked for at its own scale. A candidate of the
        // body's polarity found there wins; else the first pass's stands.
        let threshold = config.faint_threshold_sigma * sigma / box_px as f32;
        self.labeled_candidates(chip, config, threshold, box_px, &mut candidates)?;
        let faint = choose(&candidates).filter(|(s, _)| {
            config
                .polarity
                .is_none_or(|p| p.sign() == f32::from(s.moments.class))
        });
        match (faint, first) {
            (Some((selection, track)), _) => {
                self.mask.clear();
                paint(&self.labeler, &selection.parts, &mut self.mask);
                Ok(target_of(&selection, candidates.len(), track))
            }
            (None, Some(first)) => Ok(first),
            (None, None) => Err(missing),
        }
    }

    /// The component `target` (or its absence) judged against the strongest bars of the body's
    /// width in the chip ([`bar`]), where the body's size is expected and the config has a bar
    /// search and a polarity. A component of the body's polarity and high contrast stands
    /// without a search, unless as a bar it runs into the chip's edge. Else each bar (among them
    /// the one ending at the chip's plume, [`Segmenter::plume`]) is judged by the model (its
    /// fitted cross-section must have the body's diameter, or a plume mark its tail) and scored
    /// ([`Segmenter::bar_score`]); where the best lies on the component, or scores no better
    /// than the component measured as a bar, the component stands, unless it is a fragment of
    /// that bar ([`BarConfig::fragment_fraction`]); it stands too where the bar is only a piece
    /// of it ([`BarConfig::piece_fraction`]); else the bar becomes the target, its mask the
    /// bar's rectangle. A strong component short for the body, where the size is measured
    /// ([`Segmenter::is_plume_like`]), gives way to the best bar that ends at it along its axis
    /// (a faint body and its plume of the body's polarity), else it is judged as any other.
    fn judge_by_bar(
        &mut self,
        chip: &ChipView,
        config: &DetectConfig,
        aim: ImagePoint,
        expect: &Expectation,
        target: Result<Target, SegmentError>,
    ) -> Result<Target, SegmentError> {
        let (Some(bar_config), Some(polarity)) = (config.bar, config.polarity) else {
            return target;
        };
        // The body's size: the expected one, or, where no range is known, a few tried (not
        // where a structure as large as the chip reached its edge: with no size to judge by,
        // a bar in its texture would pass for the body; terrain along one edge is no such).
        let mut sizes: heapless::Vec<ExpectedBody, UNKNOWN_SCALES> = heapless::Vec::new();
        match (expect.size, expect.proportions) {
            (Some(size), _) => sizes.extend([size]),
            (None, _) if self.spans_the_chip(chip) => return target,
            (None, Some(proportions)) => sizes.extend(
                config
                    .unknown_range_diameters_px
                    .iter()
                    .map(|d| proportions.at(*d)),
            ),
            (None, None) => return target,
        }
        let diag = libm::hypotf(chip.width() as f32, chip.height() as f32);
        let mut best: Option<(f32, Bar, ExpectedBody)> = None;
        let mut own_best: Option<(f32, Bar, ExpectedBody)> = None;
        for size in &sizes {
            let judging = Judging {
                config,
                bar_config: &bar_config,
                polarity,
                aim,
                diag,
                gate: expect.gate.as_ref(),
                expected: size,
                size_measured: expect.size.is_some() && expect.size_measured,
            };
            match self.judge_at_size(chip, &judging, &target) {
                SizeVerdict::ComponentStands => return target,
                SizeVerdict::BodyBeforePlume(bar) => {
                    return Ok(self.bar_target(chip, &bar, size, polarity, expect, &target));
                }
                SizeVerdict::Judged { best: b, own } => {
                    for (kept, found) in [(&mut best, b), (&mut own_best, own)] {
                        if let Some((score, bar)) = found
                            && kept.as_ref().is_none_or(|(s, _, _)| score > *s)
                        {
                            *kept = Some((score, bar, *size));
                        }
                    }
                }
            }
        }
        let Some((best_score, bar, size)) = best else {
            return target;
        };
        // The component stands where it lies on the winning bar (its mask is the finer one),
        // or where its own bar scores at least as well; unless it is only a fragment of that
        // bar (a filament's crossing or the cloud behind broke the faint body's pixels), which
        // is then the target.
        let on_bar = target.as_ref().is_ok_and(|t| {
            let region = Region {
                axis: Axis {
                    centre: bar.centre,
                    dir: bar.dir,
                },
                half_length: bar.half_length_px,
                half_width: size.diameter_px,
            };
            libm::fabsf(t.shape.axis.dot(bar.dir)) >= bar::PARALLEL_COS
                && region.contains(t.shape.centre.x, t.shape.centre.y)
        });
        let own = own_best
            .filter(|(score, _, _)| *score >= best_score)
            .map(|(_, bar, size)| (bar, size));
        let (bar, size) = match (on_bar.then_some((bar, size)).or(own), &target) {
            (Some((under, _)), Ok(t))
                if 2.0 * UNIFORM_BAR_HALF_SDS * t.shape.major_sd
                    >= bar_config.fragment_fraction * 2.0 * under.half_length_px =>
            {
                return target;
            }
            (Some(under), _) => under,
            (None, _) => (bar, size),
        };
        // A bar that is a piece of a strong component (a fin or an end of a body found whole,
        // whose own bar was refused near the chip's edge) leaves the component standing.
        let piece = target.as_ref().is_ok_and(|t| {
            t.polarity == polarity
                && self.is_strong(t, &bar_config)
                && self.mask_along(&bar) >= bar_config.piece_fraction
        });
        if piece {
            return target;
        }
        Ok(self.bar_target(chip, &bar, &size, polarity, expect, &target))
    }

    /// `bar` as the target, its mask the bar's rectangle `size`'s diameter wide, gated where the
    /// track's gate (`expect`) admits it; it counts the components of the component `target`.
    fn bar_target(
        &mut self,
        chip: &ChipView,
        bar: &Bar,
        size: &ExpectedBody,
        polarity: BodyPolarity,
        expect: &Expectation,
        target: &Result<Target, SegmentError>,
    ) -> Target {
        let components = target.as_ref().map_or(0, |t| t.components);
        let gated = expect
            .gate
            .is_some_and(|g| g.admits_line(bar.centre, bar.dir, polarity));
        let track = if gated {
            TrackUse::Gated
        } else {
            TrackUse::Fresh
        };
        self.paint_bar(chip, bar, size.diameter_px, polarity, (components, track))
    }

    /// Whether the component `target` stands out by at least [`BarConfig::strong_sigma`] noise
    /// sigmas on average.
    fn is_strong(&self, target: &Target, bar_config: &BarConfig) -> bool {
        libm::fabsf(target.moments.mean_residual())
            >= bar_config.strong_sigma * self.background.sigma()
    }

    /// Whether `target` is a strong component of the body's `polarity` shorter than
    /// [`BarConfig::plume_length_fraction`] of the body seen broadside (`expected`): a plume of
    /// the body's polarity at its tail, or the body seen end on.
    fn is_plume_like(
        &self,
        target: &Target,
        polarity: BodyPolarity,
        expected: &ExpectedBody,
        bar_config: &BarConfig,
    ) -> bool {
        target.polarity == polarity
            && self.is_strong(target, bar_config)
            && 2.0 * UNIFORM_BAR_HALF_SDS * target.shape.major_sd
                < bar_config.plume_length_fraction * expected.length_px
    }

    /// The fraction of the middle half of `bar`'s centre line (its ends lie up to half a block
    /// beyond the body's), sampled a pixel apart, that lies on the target mask.
    fn mask_along(&self, bar: &Bar) -> f32 {
        let longest = (self.mask.width() + self.mask.height()) as f32;
        let steps = libm::floorf(0.5 * bar.half_length_px.clamp(0.0, longest)) as i32;
        let on = (-steps..=steps)
            .filter(|i| {
                let p = bar.centre + bar.dir * *i as f32;
                p.x >= 0.0 && p.y >= 0.0 && self.mask.get(p.x as usize, p.y as usize)
            })
            .count();
        on as f32 / (2 * steps + 1) as f32
    }

    /// The bar search for a body of `judging.expected`'s size: the component `target` stands
    /// where it is of the body's polarity and high contrast and, as a bar, clear of the chip's
    /// edge (a piece of terrain is not); else the best bar's score and the component's own.
    fn judge_at_size(
        &mut self,
        chip: &ChipView,
        judging: &Judging,
        target: &Result<Target, SegmentError>,
    ) -> SizeVerdict {
        let (config, bar_config, expected) = (judging.config, judging.bar_config, judging.expected);
        let sigma = self.background.sigma();
        let longest = config.body_size.max_length * expected.length_px + config.body_size.margin_px;
        let sign = judging.polarity.sign();
        if !self
            .bars
            .prepare(chip, sigma, sign, expected, longest, bar_config)
        {
            return SizeVerdict::Judged {
                best: None,
                own: None,
            };
        }
        // The component measured as a bar (None: not of the body's polarity).
        let own = target.as_ref().ok().and_then(|t| {
            (t.polarity == judging.polarity)
                .then(|| self.bars.measure(t.shape.centre, t.shape.axis, bar_config))
        });
        let strong = target.as_ref().is_ok_and(|t| self.is_strong(t, bar_config));
        let blob = target.as_ref().ok().filter(|t| {
            judging.size_measured && self.is_plume_like(t, judging.polarity, expected, bar_config)
        });
        let stands = strong && own.is_some_and(|o| o != Err(BarRefusal::AtEdge));
        if stands && blob.is_none() {
            return SizeVerdict::ComponentStands;
        }
        let mut bars: heapless::Vec<Bar, MAX_BARS> = heapless::Vec::new();
        let plume = match blob {
            Some(t) => Some(t.shape),
            None => self.plume(judging.polarity, sigma, longest, bar_config),
        };
        self.bars.search(bar_config, plume.as_ref(), &mut bars);
        let score = |bar: &Bar| self.bar_score(chip, bar, judging);
        // A plume of the body's polarity: the best bar that ends at it, on its axis (the plume
        // trails the body), with its middle beyond it and not too faint beside it (a line of
        // noise along a strong body seen end on), is the body.
        if let Some(blob) = blob {
            let shape = &blob.shape;
            let contrast = libm::fabsf(blob.moments.mean_residual());
            let ends_at_blob = |bar: &Bar| {
                let reach = shape.reach_along(bar.dir);
                let line = Axis {
                    centre: bar.centre,
                    dir: bar.dir,
                };
                let (along, across) = line.local(shape.centre.x, shape.centre.y);
                let on_axis = UNIFORM_BAR_HALF_SDS * shape.minor_sd + expected.diameter_px;
                bar.contrast * bar_config.plume_max_contrast_ratio >= contrast
                    && libm::fabsf(shape.axis.dot(bar.dir)) >= bar::PLUME_ALIGNED_COS
                    && libm::fabsf(across) <= on_axis
                    && libm::fabsf(along) > reach
                    && libm::fabsf(libm::fabsf(along) - bar.half_length_px)
                        <= reach + expected.diameter_px
            };
            let body = bars
                .iter()
                .filter(|b| ends_at_blob(b))
                .filter_map(|b| score(b).map(|s| (s, *b)))
                .max_by(|a, b| a.0.total_cmp(&b.0));
            match body {
                Some((_, bar)) => return SizeVerdict::BodyBeforePlume(bar),
                None if stands => return SizeVerdict::ComponentStands,
                None => {}
            }
        }
        SizeVerdict::Judged {
            best: bars
                .iter()
                .filter_map(|b| score(b).map(|s| (s, *b)))
                .max_by(|a, b| a.0.total_cmp(&b.0)),
            own: own
                .and_then(Result::ok)
                .and_then(|b| score(&b).map(|s| (s, b))),
        }
    }

    /// Whether a component of the last labeling reaches the chip's edge and spans more than
    /// half the chip both across and down.
    fn spans_the_chip(&self, chip: &ChipView) -> bool {
        let (width, height) = (chip.width(), chip.height());
        self.labeler.components().any(|(_, m)| {
            let r = &m.bbox;
            r.touches_edge(width, height)
                && 2 * usize::from(r.x1.saturating_sub(r.x0)) > width
                && 2 * usize::from(r.y1.saturating_sub(r.y0)) > height
        })
    }

    /// The chip's plume, where the last labeling has one: its most significant component of
    /// the other polarity than the body's `polarity` (at least [`BarConfig::plume_min_sigma`]
    /// noise `sigma`s summed over its pixels), no longer than the body can look (`longest_px`).
    fn plume(
        &self,
        polarity: BodyPolarity,
        sigma: f32,
        longest_px: f32,
        bar_config: &BarConfig,
    ) -> Option<Shape> {
        let other = if polarity.sign() > 0.0 { -1 } else { 1 };
        let significance =
            |m: &Moments| libm::fabsf(m.sum_residual) / (sigma.max(1e-3) * libm::sqrtf(m.n as f32));
        self.labeler
            .components()
            .filter(|(_, m)| m.class == other)
            .map(|(_, m)| m)
            .filter(|m| 2.0 * UNIFORM_BAR_HALF_SDS * Spread::of(m).major_sd <= longest_px)
            .max_by(|a, b| libm::fabsf(a.sum_residual).total_cmp(&libm::fabsf(b.sum_residual)))
            .filter(|m| significance(m) >= bar_config.plume_min_sigma)
            .map(Shape::of)
    }

    /// The selection score of `bar` as the body ([`select`]'s terms: its significance, its
    /// nearness to the aim point; the agreement of its fitted diameter with the body's, at
    /// most [`BarConfig::max_width_penalty`]; the track's bonus; a plume's at an end), or None
    /// where it is not significant, or its cross-section does not fit a body of the expected
    /// width and no plume marks it.
    fn bar_score(&self, chip: &ChipView, bar: &Bar, judging: &Judging) -> Option<f32> {
        let Judging {
            config,
            bar_config,
            polarity,
            aim,
            diag,
            gate,
            expected,
            ..
        } = *judging;
        let shape = Shape {
            centre: bar.centre,
            axis: bar.dir,
            major_sd: bar.half_length_px / UNIFORM_BAR_HALF_SDS,
            minor_sd: 0.5 * expected.diameter_px / UNIFORM_BAR_HALF_SDS,
        };
        let reach = 0.6 * bar.half_length_px;
        let section = cross_profile::fit(
            chip,
            &self.background,
            &shape,
            polarity,
            Stretch {
                t0: -reach,
                t1: reach,
            },
            2.0 * expected.diameter_px + 2.0,
            None,
        )?;
        let width = section.diameter_px;
        let tolerance = &config.body_size;
        let fits = width >= tolerance.min_width * expected.diameter_px
            && width <= tolerance.max_width * expected.span_px + tolerance.margin_px;
        let plume = bar.plume_sigma / bar_config.plume_min_sigma;
        if !(fits || plume >= 1.0)
            || bar.significance.is_nan()
            || bar.significance < bar_config.threshold_sigma
        {
            return None;
        }
        let ratio = libm::logf(width / expected.diameter_px.max(1e-3));
        let gated = gate.is_some_and(|g| g.admits_line(bar.centre, bar.dir, polarity));
        Some(
            select::significance_and_nearness(bar.significance, bar.centre, aim, diag)
                - (config.width_weight * ratio * ratio).min(bar_config.max_width_penalty)
                + if gated { config.track_weight } else { 0.0 }
                + bar_config.plume_weight * libm::logf(1.0 + plume.max(0.0)),
        )
    }

    /// Paints `bar` as a rectangle `diameter_px` wide into the mask and returns it as the
    /// target (with the chip's count of `components` and the `track`'s use).
    fn paint_bar(
        &mut self,
        chip: &ChipView,
        bar: &Bar,
        diameter_px: f32,
        polarity: BodyPolarity,
        (components, track): (u16, TrackUse),
    ) -> Target {
        self.mask.clear();
        let class = if polarity.sign() > 0.0 { 1 } else { -1 };
        let mut moments = Moments::empty(class);
        let (half_length, half_width) = (bar.half_length_px, 0.5 * diameter_px);
        let rectangle = Region {
            axis: Axis {
                centre: bar.centre,
                dir: bar.dir,
            },
            half_length,
            half_width,
        };
        let reach = libm::fabsf(bar.dir.x) * half_length + libm::fabsf(bar.dir.y) * half_width;
        let (x_lo, x_hi) = clamped_span(bar.centre.x, reach, chip.width());
        let reach = libm::fabsf(bar.dir.y) * half_length + libm::fabsf(bar.dir.x) * half_width;
        let (y_lo, y_hi) = clamped_span(bar.centre.y, reach, chip.height());
        for y in y_lo..y_hi {
            let inside = |x: usize| rectangle.contains(x as f32, y as f32);
            let Some(x0) = (x_lo..x_hi).find(|&x| inside(x)) else {
                continue;
            };
            let x1 = (x0..x_hi).take_while(|&x| inside(x)).last().unwrap_or(x0);
            self.mask.set_run(y, x0, x1);
            self.add_mask_run(chip, &mut moments, y, x0, x1);
        }
        Target {
            polarity,
            moments,
            shape: Shape::of(&moments),
            parts: 1,
            components,
            track,
            found_by: FoundBy::Bar,
        }
    }

    /// The components of at least the minimum area of the chip labeled at `threshold` grey
    /// levels from the sky, either side, on its `box_px` box mean ([`Labeler::label_box`]).
    /// Clutter (a cloudy sky the sky model does not follow) can fill a table at the threshold; a
    /// target stands out at a higher one, so it is doubled and the chip labeled again, a few
    /// times at most.
    fn labeled_candidates(
        &mut self,
        chip: &ChipView,
        config: &DetectConfig,
        threshold: f32,
        box_px: usize,
        candidates: &mut heapless::Vec<Candidate, MAX_COMPONENTS>,
    ) -> Result<(), SegmentError> {
        let mut threshold = threshold;
        let mut retries = config.retries;
        loop {
            match self.candidates(chip, threshold, box_px, config.min_area_px, candidates) {
                Err(SegmentError::Capacity(_)) if retries > 0 => {
                    retries -= 1;
                    threshold *= 2.0;
                }
                other => return other,
            }
        }
    }

    /// Labels the whole chip at `threshold` grey levels from the sky, either side, on its
    /// `box_px` box mean, and lists the components of at least `min_area` px in `candidates`.
    fn candidates(
        &mut self,
        chip: &ChipView,
        threshold: f32,
        box_px: usize,
        min_area: u32,
        candidates: &mut heapless::Vec<Candidate, MAX_COMPONENTS>,
    ) -> Result<(), SegmentError> {
        candidates.clear();
        let whole = Rect {
            x0: 0,
            y0: 0,
            x1: chip.width() as u16,
            y1: chip.height() as u16,
        };
        self.labeler
            .label_box(chip, &self.background, whole, box_px, |r| {
                if r > threshold {
                    1
                } else if r < -threshold {
                    -1
                } else {
                    0
                }
            })?;
        for (label, moments) in self.labeler.components() {
            if moments.n >= min_area {
                candidates
                    .push(Candidate {
                        label,
                        moments: *moments,
                    })
                    .map_err(|_| SegmentError::Capacity(CapacityKind::Components))?;
            }
        }
        Ok(())
    }

    /// The final mask of `target`, cut at the fraction [`DetectConfig::mask_level`] of the
    /// contrast the silhouette stage measured (`silhouette`): the target recut, or an error when
    /// a table ran out or the recut mask reaches the chip's edge ([`SegmentError::AtEdge`]).
    pub fn cut_mask(
        &mut self,
        chip: &ChipView,
        config: &DetectConfig,
        target: &Target,
        silhouette: &Silhouette,
    ) -> Result<Target, SegmentError> {
        let level = (config.mask_level * silhouette.contrast)
            .max(config.mask_min_sigma * self.background.sigma());
        let margin =
            (config.mask_margin_sigmas * silhouette.sigma_px + config.mask_margin_px) as u16;
        // A faint body is cut on its box mean: the edges' half-contrast crossings stay where
        // they are, the noise falls by the box's side.
        let faint = silhouette.contrast < config.faint_mask_sigma * self.background.sigma();
        let box_px = if faint { FAINT_MASK_BOX_PX } else { 1 };
        let recut = match self.recut(chip, target, level, margin, box_px) {
            Err(SegmentError::NoTarget) => *target,
            other => other?,
        };
        // A faint body's recut reaches into the clutter that crosses it (filaments, cloud): a
        // bar's is kept within the bar and the silhouette's ends.
        let recut = match target.found_by {
            FoundBy::Bar => self.clip_to_bar(chip, target, &recut, silhouette, f32::from(margin)),
            FoundBy::Components => recut,
        };
        if recut.moments.bbox.touches_edge(chip.width(), chip.height()) {
            return Err(SegmentError::AtEdge);
        }
        Ok(recut)
    }

    /// The `recut` mask of the bar target `bar` cleared outside the bar's line, `margin_px`
    /// beyond half its width (its painted rectangle's) across it and beyond the farther of its
    /// ends and the silhouette's along it, and its statistics counted again (the recut where
    /// nothing is left).
    fn clip_to_bar(
        &mut self,
        chip: &ChipView,
        bar: &Target,
        recut: &Target,
        silhouette: &Silhouette,
        margin_px: f32,
    ) -> Target {
        let line = bar.shape.line();
        let ends = [silhouette.nose_t, silhouette.tail_t].map(|t| {
            let p = silhouette.axis.point(t);
            libm::fabsf(line.local(p.x, p.y).0)
        });
        let kept_region = Region {
            axis: line,
            half_length: ends
                .iter()
                .fold(UNIFORM_BAR_HALF_SDS * bar.shape.major_sd, |m, e| m.max(*e))
                + margin_px,
            half_width: UNIFORM_BAR_HALF_SDS * bar.shape.minor_sd + margin_px,
        };
        let mut moments = Moments::empty(recut.moments.class);
        let b = recut.moments.bbox;
        for y in usize::from(b.y0)..usize::from(b.y1) {
            let mut run: Option<usize> = None;
            for x in usize::from(b.x0)..=usize::from(b.x1) {
                let inside = x < usize::from(b.x1) && kept_region.contains(x as f32, y as f32);
                let kept = inside && self.mask.get(x, y);
                if !inside {
                    self.mask.set(x, y, false);
                }
                match (kept, run) {
                    (true, None) => run = Some(x),
                    (false, Some(x0)) => {
                        self.add_mask_run(chip, &mut moments, y, x0, x - 1);
                        run = None;
                    }
                    _ => {}
                }
            }
        }
        if moments.n == 0 {
            return *recut;
        }
        Target {
            moments,
            shape: Shape::of(&moments),
            ..*recut
        }
    }

    /// Adds the run `x0..=x1` of row `y` to `moments`, with its residuals against the sky.
    fn add_mask_run(&self, chip: &ChipView, moments: &mut Moments, y: usize, x0: usize, x1: usize) {
        let (mut residual, mut value) = (0.0f32, 0u64);
        let sky = self.background.row(y);
        chip.for_each_in_span(y, x0, x1 + 1, |x, v| {
            residual += f32::from(v) - sky.at(x);
            value += u64::from(v);
        });
        moments.add_run(y as u16, x0 as u16, x1 as u16, residual, value);
    }

    /// Recuts the target's mask where its contrast (of the target's polarity) reaches `level`
    /// grey levels within `margin` px of its box, keeping the components that overlap the
    /// current mask, and repaints the mask.
    fn recut(
        &mut self,
        chip: &ChipView,
        target: &Target,
        level: f32,
        margin: u16,
        box_px: usize,
    ) -> Result<Target, SegmentError> {
        let mask = &mut self.mask;
        let region = target
            .moments
            .bbox
            .grown(margin, chip.width(), chip.height());
        let sign = target.polarity.sign();
        self.labeler
            .label_box(chip, &self.background, region, box_px, |r| {
                if r * sign >= level { 1 } else { 0 }
            })?;
        let mut keep: heapless::Vec<u16, MAX_COMPONENTS> = heapless::Vec::new();
        for run in self.labeler.runs() {
            let root = self.labeler.root(run.label);
            let overlaps =
                mask.any_in_run(usize::from(run.y), usize::from(run.x0), usize::from(run.x1));
            if overlaps && !keep.contains(&root) {
                keep.push(root)
                    .map_err(|_| SegmentError::Capacity(CapacityKind::Components))?;
            }
        }
        let mut parts = keep.iter();
        let Some(first) = parts.next() else {
            // Nothing reaches the level (very low contrast): keep the detection as it is.
            return Ok(*target);
        };
        let moments_of = |l: &u16| {
            self.labeler
                .components()
                .find(|(label, _)| label == l)
                .map(|(_, m)| *m)
        };
        let Some(mut moments) = moments_of(first) else {
            return Ok(*target);
        };
        for l in parts {
            if let Some(m) = moments_of(l) {
                moments.merge(&m);
            }
        }
        mask.clear();
        paint(&self.labeler, &keep, mask);
        Ok(Target {
            polarity: target.polarity,
            moments,
            shape: Shape::of(&moments),
            parts: keep.len() as u8,
            components: target.components,
            track: target.track,
            found_by: target.found_by,
        })
    }
}

/// The pixels within `reach` px of `centre` along one side of a chip `len` px long: a start and
/// an end (exclusive).
pub(crate) fn clamped_span(centre: f32, reach: f32, len: usize) -> (usize, usize) {
    let lo = libm::floorf(centre - reach).max(0.0) as usize;
    let hi = (libm::ceilf(centre + reach) + 1.0).clamp(0.0, len as f32) as usize;
    (lo.min(hi), hi)
}

/// What the bar search at one size says of the component target ([`Segmenter::judge_at_size`]).
enum SizeVerdict {
    /// It is the body: of its polarity, high contrast, clear of the edge.
    ComponentStands,
    /// It is a plume of the body's polarity ([`Segmenter::is_plume_like`]), and the bar (the
    /// best that ends at it) the body.
    BodyBeforePlume(Bar),
    /// The best bar's score and the bar, and the component's own score and bar.
    Judged {
        best: Option<(f32, Bar)>,
        own: Option<(f32, Bar)>,
    },
}

/// The box side a faint body's mask is cut on, px.
const FAINT_MASK_BOX_PX: usize = 3;

/// Sizes of the body the bar search tries where no range is known.
const UNKNOWN_SCALES: usize = 3;

/// What a frame's bars are judged with ([`Segmenter::bar_score`]).
#[derive(Clone, Copy)]
struct Judging<'a> {
    config: &'a DetectConfig,
    bar_config: &'a BarConfig,
    /// The body's polarity.
    polarity: BodyPolarity,
    /// Where the tracker aims, chip px.
    aim: ImagePoint,
    /// The chip's diagonal, px.
    diag: f32,
    /// Where the track expects the body.
    gate: Option<&'a TrackGate>,
    /// The body's expected size ...
    expected: &'a ExpectedBody,
    /// ... given by a measured range ([`Expectation::size_measured`]).
    size_measured: bool,
}

/// Paints the runs of the components `roots` of `labeler` into `mask`.
fn paint<const MAX_RUNS: usize, const MAX_LABELS: usize, const W: usize>(
    labeler: &Labeler<MAX_RUNS, MAX_LABELS>,
    roots: &[u16],
    mask: &mut BitMask<W>,
) {
    for run in labeler.runs() {
        if roots.contains(&labeler.root(run.label)) {
            mask.set_run(usize::from(run.y), usize::from(run.x0), usize::from(run.x1));
        }
    }
}

fn target_of(selection: &Selection, components: usize, track: TrackUse) -> Target {
    Target {
        polarity: if selection.moments.class > 0 {
            BodyPolarity::Bright
        } else {
            BodyPolarity::Dark
        },
        moments: selection.moments,
        shape: Shape::of(&selection.moments),
        parts: selection.parts.len() as u8,
        components: components as u16,
        track,
        found_by: FoundBy::Components,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The side of the bar tests' chips, px.
    const SIDE: usize = 256;

    /// A `SIDE` x `SIDE` chip's grey levels: the sky at `sky`, darker by `dark(x, y)`, plus
    /// `noise_sd` times the noise sequence of `seed`.
    fn chip_data(
        sky: f32,
        noise_sd: f32,
        seed: u32,
        dark: impl Fn(usize, usize) -> f32,
    ) -> [u8; SIDE * SIDE] {
        let mut noise = crate::testing::noise_sequence(SIDE * SIDE, seed);
        let mut data = [0u8; SIDE * SIDE];
        for (i, v) in data.iter_mut().enumerate() {
            let (x, y) = (i % SIDE, i / SIDE);
            *v =
                (sky - dark(x, y) + noise_sd * noise.next().unwrap_or(0.0)).clamp(0.0, 255.0) as u8;
        }
        data
    }

    /// The target a fresh segmenter detects in the `SIDE` x `SIDE` chip `data`, aiming at its
    /// middle, for a body of the `expected` size (from a measured range where `size_measured`).
    fn detect_sized(data: &[u8], expected: ExpectedBody, size_measured: bool) -> Target {
        let chip = ChipView::gray8(data, SIDE, SIDE, SIDE, 0, 0).unwrap();
        let mut segmenter: Segmenter = Segmenter::new();
        segmenter
            .detect(
                &chip,
                &DetectConfig::DEFAULT,
                ImagePoint::new(128.0, 128.0),
                &Expectation {
                    size: Some(expected),
                    size_measured,
                    ..Expectation::NONE
                },
            )
            .unwrap()
    }

    /// Terrain (a dark band 12 px high across the bottom of the chip) and a dark bar 6 px wide and
    /// 80 px long: the terrain is the most significant component, the bar the one of the body's
    /// size. The terrain enters from the chip's edge, where no whole body can be: with an
    /// expected size or without, the bar is taken.
    #[test]
    fn the_candidate_of_the_bodys_size_wins_over_terrain() {
        let (w, h) = (160usize, 128usize);
        let mut data = [150u8; 160 * 128];
        for y in 0..h {
            for x in 0..w {
                let terrain = y >= 116;
                let bar = (40..46).contains(&y) && (40..120).contains(&x);
                if terrain || bar {
                    data[y * w + x] = 60;
                }
            }
        }
        // A little texture so the noise estimate is not at its floor.
        for (i, v) in data.iter_mut().enumerate() {
            *v = v.wrapping_add((i * 7 % 5) as u8);
        }
        let chip = ChipView::gray8(&data, w, h, w, 0, 0).unwrap();
        let aim = ImagePoint::new(80.0, 64.0);
        let config = DetectConfig::DEFAULT;
        let mut segmenter: Segmenter = Segmenter::new();
        let blind = segmenter
            .detect(&chip, &config, aim, &Expectation::NONE)
            .unwrap();
        assert!(
            (blind.shape.centre.y - 42.5).abs() < 1.0 && (blind.shape.centre.x - 79.5).abs() < 1.0,
            "{:?}",
            blind.shape
        );
        let expected = ExpectedBody {
            diameter_px: 6.0,
            span_px: 12.0,
            length_px: 90.0,
        };
        let target = segmenter
            .detect(
                &chip,
                &config,
                aim,
                &Expectation {
                    size: Some(expected),
                    ..Expectation::NONE
                },
            )
            .unwrap();
        assert!(
            (target.shape.centre.y - 42.5).abs() < 1.0
                && (target.shape.centre.x - 79.5).abs() < 1.0,
            "{:?}",
            target.shape
        );
    }

    /// A bright cloud band across the whole chip (rows 10-29, 40 grey levels up) outweighs a
    /// compact plume (14 x 6 px, 90 up) beside a dark bar: the plume is still the chip's plume,
    /// the band being longer than the body can look.
    #[test]
    fn the_plume_is_found_beside_a_brighter_cloud_band() {
        let (w, h) = (160usize, 128usize);
        let mut data = [100u8; 160 * 128];
        for (i, v) in data.iter_mut().enumerate() {
            let (x, y) = (i % w, i / w);
            *v = if (10..30).contains(&y) {
                140
            } else if (70..76).contains(&y) && (40..100).contains(&x) {
                40
            } else if (70..76).contains(&y) && (100..114).contains(&x) {
                190
            } else {
                100
            };
            *v = v.wrapping_add((i * 7 % 5) as u8);
        }
        let chip = ChipView::gray8(&data, w, h, w, 0, 0).unwrap();
        let config = DetectConfig::DEFAULT;
        let mut segmenter: Segmenter = Segmenter::new();
        segmenter
            .detect(
                &chip,
                &config,
                ImagePoint::new(80.0, 64.0),
                &Expectation::NONE,
            )
            .unwrap();
        let band_sum = |m: &Moments| libm::fabsf(m.sum_residual);
        let brightest = segmenter
            .labeler
            .components()
            .map(|(_, m)| m)
            .filter(|m| m.class > 0)
            .max_by(|a, b| band_sum(a).total_cmp(&band_sum(b)))
            .map(Shape::of)
            .expect("bright components");
        assert!(
            (10.0..30.0).contains(&brightest.centre.y)
                && 2.0 * UNIFORM_BAR_HALF_SDS * brightest.major_sd > 100.0,
            "the band is the most significant bright component: {brightest:?}"
        );
        let sigma = segmenter.background.sigma();
        let bar_config = config.bar.expect("the bar search's settings");
        let plume = segmenter
            .plume(BodyPolarity::Dark, sigma, 100.0, &bar_config)
            .expect("the plume");
        assert!(
            (plume.centre.x - 106.5).abs() < 1.5 && (plume.centre.y - 72.5).abs() < 1.5,
            "{plume:?}"
        );
    }

    /// A faint body (9 grey levels, 3 noise sigmas, 7 px wide and 110 px long) whose last 20 px
    /// are darker (20 grey levels: a filament crossing it): the dark stretch is the component
    /// that stands out, but only a fragment of the bar it lies on, and the bar, the whole body,
    /// is the target.
    #[test]
    fn a_fragment_gives_way_to_the_bar_it_lies_on() {
        let data = chip_data(120.0, 3.0, 5, |x, y| {
            let on_body = (125..132).contains(&y) && (73..183).contains(&x);
            match (on_body, x >= 163) {
                (false, _) => 0.0,
                (true, false) => 9.0,
                (true, true) => 20.0,
            }
        });
        let expected = ExpectedBody {
            diameter_px: 7.0,
            span_px: 14.0,
            length_px: 115.0,
        };
        let target = detect_sized(&data, expected, false);
        let length = 2.0 * UNIFORM_BAR_HALF_SDS * target.shape.major_sd;
        assert_eq!(target.found_by, FoundBy::Bar, "{target:?}");
        assert!(
            (target.shape.centre.x - 128.0).abs() < 8.0
                && (target.shape.centre.y - 128.0).abs() < 3.0
                && (90.0..=125.0).contains(&length),
            "{target:?}"
        );
    }

    /// A faint body (9 grey levels on noise 3, 7 px wide, 110 px long) whose plume is of its
    /// own polarity and much stronger (40 grey levels, 24 x 11 px at its tail): the plume is the
    /// component that stands out, short for the body. With the size from a measured range the
    /// bar ending at the plume along its axis, the body, is the target; with a size predicted
    /// from the image the plume stands.
    #[test]
    fn a_faint_body_ending_at_a_plume_of_its_polarity_is_the_target() {
        let data = chip_data(120.0, 3.0, 11, |x, y| {
            let on_body = (125..132).contains(&y) && (60..170).contains(&x);
            let on_plume = (123..134).contains(&y) && (170..194).contains(&x);
            if on_plume {
                40.0
            } else if on_body {
                9.0
            } else {
                0.0
            }
        });
        let expected = ExpectedBody {
            diameter_px: 7.0,
            span_px: 14.0,
            length_px: 115.0,
        };
        let detect = |size_measured| detect_sized(&data, expected, size_measured);
        let target = detect(true);
        let length = 2.0 * UNIFORM_BAR_HALF_SDS * target.shape.major_sd;
        assert_eq!(target.found_by, FoundBy::Bar, "{target:?}");
        assert!(
            (target.shape.centre.x - 115.0).abs() < 10.0
                && (target.shape.centre.y - 128.0).abs() < 3.0
                && (90.0..=130.0).contains(&length),
            "{target:?}"
        );
        let predicted = detect(false);
        assert_eq!(predicted.found_by, FoundBy::Components, "{predicted:?}");
        assert!(
            (predicted.shape.centre.x - 181.5).abs() < 4.0,
            "{predicted:?}"
        );
    }

    /// A strong body (60 grey levels on noise 2), 8 px wide and 138 px long with fins 20 px
    /// across its last 14 px, its nose 28 px from the chip's edge: nearer than a faded bar's
    /// ends could hide the body's extremes, so the component's own bar is refused, and the bar
    /// search finds a piece of it. The component, the whole body, stays the target.
    #[test]
    fn a_strong_body_near_the_edge_is_not_given_up_for_a_piece_of_it() {
        let data = chip_data(150.0, 2.0, 7, |x, y| {
            let on_body = (124..132).contains(&y) && (90..228).contains(&x);
            let on_fins = (118..138).contains(&y) && (90..104).contains(&x);
            if on_body || on_fins { 60.0 } else { 0.0 }
        });
        let expected = ExpectedBody {
            diameter_px: 8.0,
            span_px: 20.0,
            length_px: 138.0,
        };
        let target = detect_sized(&data, expected, false);
        let length = 2.0 * UNIFORM_BAR_HALF_SDS * target.shape.major_sd;
        assert_eq!(target.found_by, FoundBy::Components, "{target:?}");
        assert!(
            (target.shape.centre.x - 155.0).abs() < 8.0
                && (target.shape.centre.y - 128.0).abs() < 1.0
                && (125.0..=150.0).contains(&length),
            "{target:?}"
        );
    }

    /// A faint body (12 grey levels on noise 3: 4 sigmas), 7 px wide and 60 px long: cut on its
    /// 3 px box mean, its mask is the body's rectangle to an IoU of at least 0.95, and nearer it
    /// than cut pixel by pixel.
    #[test]
    fn a_faint_body_is_cut_on_its_box_mean() {
        const SIDE: usize = 128;
        let (x_range, y_range) = (34..94usize, 61..68usize);
        let mut noise = crate::testing::noise_sequence(SIDE * SIDE, 9);
        let mut data = [0u8; SIDE * SIDE];
        for (i, v) in data.iter_mut().enumerate() {
            let (x, y) = (i % SIDE, i / SIDE);
            let dark = if x_range.contains(&x) && y_range.contains(&y) {
                12.0
            } else {
                0.0
            };
            *v = (120.0 - dark + 3.0 * noise.next().unwrap_or(0.0)).clamp(0.0, 255.0) as u8;
        }
        let chip = ChipView::gray8(&data, SIDE, SIDE, SIDE, 0, 0).unwrap();
        let expect = Expectation {
            size: Some(ExpectedBody {
                diameter_px: 7.0,
                span_px: 14.0,
                length_px: 62.0,
            }),
            ..Expectation::NONE
        };
        let silhouette = Silhouette {
            axis: Axis {
                centre: ImagePoint::new(63.5, 64.0),
                dir: ImagePoint::new(1.0, 0.0),
            },
            nose_t: 30.0,
            nose_ramp_offset_m: 0.0,
            tail_t: -30.0,
            diameter_px: 7.0,
            contrast: 12.0,
            sigma_px: 0.5,
            nose_evidence: 0.0,
            plume_at_tail: false,
        };
        let iou_with = |faint_mask_sigma: f32| {
            let config = DetectConfig {
                faint_mask_sigma,
                ..DetectConfig::DEFAULT
            };
            let mut segmenter: Segmenter = Segmenter::new();
            let aim = ImagePoint::new(64.0, 64.0);
            let target = segmenter.detect(&chip, &config, aim, &expect).unwrap();
            segmenter
                .cut_mask(&chip, &config, &target, &silhouette)
                .unwrap();
            let mask = segmenter.mask();
            let (mut both, mut either) = (0usize, 0usize);
            for y in 0..SIDE {
                for x in 0..SIDE {
                    let truth = x_range.contains(&x) && y_range.contains(&y);
                    both += usize::from(truth && mask.get(x, y));
                    either += usize::from(truth || mask.get(x, y));
                }
            }
            both as f32 / either.max(1) as f32
        };
        let (boxed, plain) = (iou_with(8.0), iou_with(0.0));
        assert!(
            boxed >= 0.95 && boxed > plain,
            "box {boxed}, pixel by pixel {plain}"
        );
    }

    /// The box side for a faint body: odd, from 3 px, at most the labeler's largest; none for a
    /// body too thin.
    #[test]
    fn the_faint_box_follows_the_body_diameter() {
        let config = DetectConfig::DEFAULT;
        let side = |d: f32| {
            let e = ExpectedBody {
                diameter_px: d,
                span_px: 2.0 * d,
                length_px: 17.0 * d,
            };
            faint_box_px(&e, &config)
        };
        assert_eq!(side(3.0), 1);
        assert_eq!(side(5.0), 3);
        assert_eq!(side(7.5), 3);
        assert_eq!(side(9.0), 5);
        assert_eq!(side(40.0), label::MAX_BOX_PX);
        assert_eq!(side(f32::MAX), label::MAX_BOX_PX);
        assert_eq!(side(f32::INFINITY), label::MAX_BOX_PX);
        assert_eq!(side(f32::NAN), 1);
    }
}
