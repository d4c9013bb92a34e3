//! The pipeline: one method from a chip to a [`FrameResult`], called alike by the host, the
//! tests, the benchmarks, the fuzzers and the firmware. It owns every buffer and the temporal
//! state; nothing is allocated per frame.

use crate::camera::Camera;
use crate::capacity::{DEFAULT_MAX_LABELS, DEFAULT_MAX_RUNS};
use crate::chip::ChipView;
use crate::closed_form::{self, ClosedForm};
use crate::config::{Config, RangeUse, RefineMethod};
use crate::extremes::{self, Silhouette};
use crate::lut::matcher::Match;
use crate::lut::table::Table;
use crate::lut::{self, Refined, render};
use crate::mask::BitMask;
use crate::model::ProjectileModel;
use crate::pose::Pose;
use crate::segment::{CapacityKind, SegmentError, Segmenter};
#[cfg(feature = "shape-guided")]
use crate::shape_guided::{LoopOutcome, LoopStop, ShapeGuided, ShapeGuidedConfig, feedback};
use crate::temporal::Temporal;

/// One frame's input.
#[derive(Debug, Clone, Copy)]
pub struct FrameInput<'a> {
    /// The chip.
    pub chip: ChipView<'a>,
    /// Capture time, s (arbitrary origin; must increase from frame to frame).
    pub time_s: f64,
    /// Slant range to the body origin from a range sensor, m, where there is one.
    pub range_m: Option<f32>,
}

/// What became of a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Status {
    /// A pose was estimated.
    Ok,
    /// No target in the chip.
    NoTarget,
    /// A fixed capacity ran out (which one is in [`FrameResult::capacity`]).
    Capacity,
    /// The input is unusable (invalid camera, non-finite or non-positive range, ...).
    BadInput,
    /// A target was found but its silhouette could not be measured.
    Unmeasurable,
}

impl Status {
    /// The status as written in imade-results/1.
    pub fn as_str(&self) -> &'static str {
        match self {
            Status::Ok => "ok",
            Status::NoTarget => "no_target",
            Status::Capacity => "capacity",
            Status::BadInput => "bad_input",
            Status::Unmeasurable => "unmeasurable",
        }
    }
}

/// One frame's result.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FrameResult {
    /// What became of the frame; the other fields are meaningful only when it is `Ok`.
    pub status: Status,
    /// Which capacity ran out, when the status is `Capacity`.
    pub capacity: Option<CapacityKind>,
    /// The pose with the chosen yaw candidate.
    pub pose: Pose,
    /// Pitch of the mirrored candidate, deg.
    pub pitch_alt_deg: f32,
    /// Yaw of the mirrored candidate, deg.
    pub yaw_alt_deg: f32,
    /// True when the choice between the candidates was resolved by the range trend.
    pub yaw_resolved: bool,
    /// True when a range measurement fixed the distance.
    pub range_used: bool,
    /// Roll modulo 90 deg, where estimated.
    pub roll_deg: Option<f32>,
    /// Slant range measured from the image (before smoothing), m; 0 where not measured.
    pub image_range_m: f32,
    /// The silhouette's measurements.
    pub silhouette: Option<Silhouette>,
    /// The table match, where a table is loaded and it matched (the pose is then the refined
    /// one; otherwise it is the closed form's).
    pub matched: Option<Match>,
}

impl FrameResult {
    /// True when every number of the result is finite: pose, mirrored candidate, measurements
    /// and table match.
    pub fn is_finite(&self) -> bool {
        let p = &self.pose;
        let pose = [p.tx_m, p.ty_m, p.tz_m, p.pitch_deg, p.yaw_deg];
        let other = [self.pitch_alt_deg, self.yaw_alt_deg, self.image_range_m];
        let silhouette = self.silhouette.map_or([0.0; 10], |s| {
            [
                s.axis.centre.0,
                s.axis.centre.1,
                s.axis.dir.0,
                s.axis.dir.1,
                s.nose_t,
                s.tail_t,
                s.diameter_px,
                s.contrast,
                s.sigma_px,
                s.nose_evidence,
            ]
        });
        let matched = self.matched.map_or([0.0; 6], |m| {
            [
                m.tilt_deg,
                m.roll_deg,
                m.roll_confidence,
                m.px_per_d,
                m.origin_t,
                m.rms_px,
            ]
        });
        let roll = [self.roll_deg.unwrap_or(0.0)];
        [&pose[..], &other, &silhouette, &matched, &roll]
            .iter()
            .all(|values| values.iter().all(|v| v.is_finite()))
    }

    /// A result with only a status.
    pub const fn failed(status: Status) -> Self {
        FrameResult {
            status,
            capacity: None,
            pose: Pose {
                tx_m: 0.0,
                ty_m: 0.0,
                tz_m: 0.0,
                pitch_deg: 0.0,
                yaw_deg: 0.0,
            },
            pitch_alt_deg: 0.0,
            yaw_alt_deg: 0.0,
            yaw_resolved: false,
            range_used: false,
            roll_deg: None,
            image_range_m: 0.0,
            silhouette: None,
            matched: None,
        }
    }
}

/// The pipeline with its buffers: `MAX_RUNS` and `MAX_LABELS` size the labeler, `MASK_WORDS`
/// its chip masks (32-bit words each, [`crate::capacity::mask_words`] of the largest chip side:
/// 512 px by default; a larger chip is then a `Capacity` status). See [`crate::capacity`].
pub struct Pipeline<
    const MAX_RUNS: usize = DEFAULT_MAX_RUNS,
    const MAX_LABELS: usize = DEFAULT_MAX_LABELS,
    const MASK_WORDS: usize = { crate::capacity::MASK_WORDS },
> {
    config: Config,
    camera: Camera,
    model: ProjectileModel,
    segmenter: Segmenter<MAX_RUNS, MAX_LABELS>,
    mask: BitMask<MASK_WORDS>,
    prior: BitMask<MASK_WORDS>,
    temporal: Temporal,
    table: Option<Table<'static>>,
    refined: Option<Refined>,
    #[cfg(feature = "shape-guided")]
    shape_guided: ShapeGuided,
    #[cfg(feature = "shape-guided")]
    refined_mask: BitMask<MASK_WORDS>,
    #[cfg(feature = "shape-guided")]
    outcome: Option<LoopOutcome>,
}

impl<const MAX_RUNS: usize, const MAX_LABELS: usize, const MASK_WORDS: usize>
    Pipeline<MAX_RUNS, MAX_LABELS, MASK_WORDS>
{
    /// A pipeline for one camera and projectile.
    pub const fn new(config: Config, camera: Camera, model: ProjectileModel) -> Self {
        Pipeline {
            config,
            camera,
            model,
            segmenter: Segmenter::new(),
            mask: BitMask::new(),
            prior: BitMask::new(),
            temporal: Temporal::new(),
            table: None,
            refined: None,
            #[cfg(feature = "shape-guided")]
            shape_guided: ShapeGuided::new(),
            #[cfg(feature = "shape-guided")]
            refined_mask: BitMask::new(),
            #[cfg(feature = "shape-guided")]
            outcome: None,
        }
    }

    /// The pipeline refining its poses against `table` (validated by
    /// [`Table::parse_for`] for this pipeline's model), and drawing the shape prior.
    pub const fn with_table(mut self, table: Table<'static>) -> Self {
        self.table = Some(table);
        self
    }

    /// The configuration.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The target mask of the last frame (chip-sized; empty when no target was found).
    pub fn mask(&self) -> &BitMask<MASK_WORDS> {
        &self.mask
    }

    /// The shape prior of the last frame: the model's silhouette rendered at the estimated pose
    /// (after the refinement loop, where it ran), chip-sized (empty when no pose was estimated or
    /// no lookup table is loaded).
    pub fn prior(&self) -> &BitMask<MASK_WORDS> {
        &self.prior
    }

    /// The shape-guided segmentation of the last frame's last refinement round (the prior it
    /// started from where the method failed), chip-sized; empty where the loop did not run.
    #[cfg(feature = "shape-guided")]
    pub fn refined_mask(&self) -> &BitMask<MASK_WORDS> {
        &self.refined_mask
    }

    /// What the refinement loop did in the last frame (None where it did not run).
    #[cfg(feature = "shape-guided")]
    pub fn refinement(&self) -> Option<&LoopOutcome> {
        self.outcome.as_ref()
    }

    /// The last frame's table match, with its measurements (None where it did not run or match).
    pub fn refined(&self) -> Option<&Refined> {
        self.refined.as_ref()
    }

    /// Forgets the temporal state (a new clip).
    pub fn reset(&mut self) {
        self.temporal.reset();
        self.mask.clear();
        self.clear_pose_outputs();
    }

    /// Clears what only a frame with a pose gives: prior, table match, refinement.
    fn clear_pose_outputs(&mut self) {
        self.prior.clear();
        self.refined = None;
        #[cfg(feature = "shape-guided")]
        {
            self.refined_mask.clear();
            self.outcome = None;
        }
    }

    /// Processes one frame.
    pub fn process(&mut self, input: &FrameInput) -> FrameResult {
        self.clear_pose_outputs();
        let range = match (input.range_m, self.config.range_use) {
            (Some(r), RangeUse::Auto) => {
                if !(r.is_finite() && r > 0.0) {
                    return FrameResult::failed(Status::BadInput);
                }
                Some(r)
            }
            _ => None,
        };
        if !self.camera.is_valid() || !input.time_s.is_finite() {
            return FrameResult::failed(Status::BadInput);
        }
        let t = self.temporal.frame_time(input.time_s, &self.config);
        // A range sensor's reading is evidence of the range trend (and so of the yaw choice)
        // whatever becomes of the image.
        if let Some(r) = range {
            self.temporal.push_range(t, r, &self.config);
        }
        let chip = &input.chip;
        let aim = (0.5 * chip.width() as f32, 0.5 * chip.height() as f32);
        let target = match self
            .segmenter
            .detect(chip, &self.config, aim, &mut self.mask)
        {
            Ok(t) => t,
            Err(SegmentError::NoTarget) => return FrameResult::failed(Status::NoTarget),
            Err(SegmentError::Capacity(kind)) => {
                self.mask.clear();
                return FrameResult {
                    capacity: Some(kind),
                    ..FrameResult::failed(Status::Capacity)
                };
            }
        };
        let background = self.segmenter.background();
        let silhouette = match extremes::measure(
            chip,
            background,
            &target,
            &self.model,
            self.temporal.nose_dir(),
        ) {
            Ok(s) => s,
            Err(_) => return FrameResult::failed(Status::Unmeasurable),
        };
        let level = (self.config.mask_level * silhouette.contrast)
            .max(self.config.mask_min_sigma * background.sigma());
        let margin = (2.0 * silhouette.sigma_px + 3.0) as u16;
        let recut = match self
            .segmenter
            .refine(chip, &target, level, margin, &mut self.mask)
        {
            Ok(recut) => recut,
            Err(SegmentError::Capacity(kind)) => {
                return FrameResult {
                    capacity: Some(kind),
                    ..FrameResult::failed(Status::Capacity)
                };
            }
            Err(SegmentError::NoTarget) => target,
        };
        // A silhouette that reaches the chip's edge has lost an end (or more): its extremes and
        // scale would be those of a shorter body.
        if recut.moments.bbox.touches_edge(chip.width(), chip.height()) {
            return FrameResult::failed(Status::Unmeasurable);
        }
        let image_range = closed_form::range_from_diameter(&silhouette, &self.camera, &self.model);
        let refined = match (self.table, range.or(image_range)) {
            (Some(table), Some(start_range)) => {
                let closed = closed_form::solve(
                    &silhouette,
                    (chip.x0(), chip.y0()),
                    &self.camera,
                    &self.model,
                    start_range,
                );
                let frame = lut::Frame {
                    chip,
                    background: self.segmenter.background(),
                    silhouette: &silhouette,
                    class: target.class,
                    origin: (chip.x0(), chip.y0()),
                };
                lut::refine(&frame, &table, &self.model, &self.camera, &closed, range).ok()
            }
            _ => None,
        };
        let needs_prior =
            self.config.shape_prior || self.config.refine.method != RefineMethod::None;
        let refined = refined.map(|first| {
            if needs_prior {
                self.draw_prior(chip, &first);
            }
            self.refine_loop(chip, &silhouette, target.class, range, first)
        });
        // The range measured from the image: the matched scale's, else the diameter's.
        let image_range = refined
            .as_ref()
            .filter(|_| range.is_none())
            .map(|r| r.range_m)
            .or(image_range);
        let range_m = match (range, image_range) {
            (Some(r), _) => r,
            (None, Some(r)) => {
                let smoothed = self.temporal.smooth_range(t, r, &self.config);
                self.temporal.push_range(t, r, &self.config);
                smoothed
            }
            (None, None) => return FrameResult::failed(Status::Unmeasurable),
        };
        self.temporal.set_nose_dir(silhouette.axis.dir);
        let solution = match &refined {
            Some(r) => r.at_range(&self.camera, &self.model, range_m),
            None => closed_form::solve(
                &silhouette,
                (chip.x0(), chip.y0()),
                &self.camera,
                &self.model,
                range_m,
            ),
        };
        let choice = self.temporal.choose_yaw(&self.config);
        self.refined = refined;
        let result = FrameResult {
            matched: refined.map(|r| r.matched),
            ..self.result(&solution, &silhouette, choice, range.is_some(), image_range)
        };
        // Finite but extreme intrinsics or ranges can overflow the geometry, or underflow the
        // depth to the camera's plane (found by fuzzing).
        if result.is_finite() && result.pose.tz_m > 0.0 {
            result
        } else {
            self.clear_pose_outputs();
            FrameResult::failed(Status::Unmeasurable)
        }
    }

    /// The refinement loop (`Config.refine`) from the first table match `first`, whose prior is
    /// drawn: rounds of shape-guided segmentation and table match on the moved axis and ends, each
    /// re-match kept only when the stop rule accepts it. Returns the match kept.
    #[cfg(feature = "shape-guided")]
    fn refine_loop(
        &mut self,
        chip: &ChipView,
        silhouette: &Silhouette,
        class: i8,
        range: Option<f32>,
        first: Refined,
    ) -> Refined {
        let limits = self.config.refine;
        let (Some(method), Some(table)) = (limits.method.method(), self.table) else {
            return first;
        };
        let origin = (chip.x0(), chip.y0());
        let mut outcome = LoopOutcome::start(method, &first);
        let (mut current, mut measured) = (first, *silhouette);
        outcome.stop = loop {
            if outcome.rounds >= limits.max_rounds {
                break LoopStop::Rounds;
            }
            outcome.rounds += 1;
            let segmentation = self.shape_guided.refine(
                method,
                &ShapeGuidedConfig::DEFAULT,
                chip,
                &self.prior,
                &mut self.refined_mask,
            );
            let segmentation = match segmentation {
                Ok(s) => s,
                Err(e) => {
                    self.refined_mask.clone_from(&self.prior);
                    break LoopStop::Failed(e);
                }
            };
            outcome.last = Some(segmentation);
            if segmentation.shift_px < limits.identity_px {
                break LoopStop::Converged;
            }
            let Some(moved) = feedback::moved_input(
                &measured,
                &current,
                &segmentation.transform,
                origin,
                &self.camera,
                &self.model,
            ) else {
                break LoopStop::Degenerate;
            };
            let frame = lut::Frame {
                chip,
                background: self.segmenter.background(),
                silhouette: &moved.silhouette,
                class,
                origin,
            };
            let Ok(next) = lut::refine(
                &frame,
                &table,
                &self.model,
                &self.camera,
                &moved.closed,
                range,
            ) else {
                break LoopStop::NoMatch;
            };
            if let Err(stop) = feedback::judge(&current, &next, &limits) {
                break stop;
            }
            outcome.accepted += 1;
            (current, measured) = (next, moved.silhouette);
            self.draw_prior(chip, &current);
        };
        outcome.rms_px = current.matched.rms_px;
        self.outcome = Some(outcome);
        current
    }

    /// Without the `shape-guided` feature there is no refinement: the first match is kept.
    #[cfg(not(feature = "shape-guided"))]
    fn refine_loop(
        &mut self,
        _chip: &ChipView,
        _silhouette: &Silhouette,
        _class: i8,
        _range: Option<f32>,
        first: Refined,
    ) -> Refined {
        first
    }

    /// Draws the matched entry's silhouette into the prior mask.
    fn draw_prior(&mut self, chip: &ChipView, refined: &Refined) {
        self.prior.clear();
        let Some(table) = &self.table else { return };
        let tilt_step = 90.0 / (table.tilts() - 1) as f32;
        let roll_step = 90.0 / table.rolls() as f32;
        let entry = table.entry(
            libm::roundf(refined.view.tilt_deg / tilt_step) as usize,
            libm::roundf(refined.view.roll_deg / roll_step) as usize,
        );
        // A silhouette more than twice the chip's size is no prior for it, and embedded-graphics
        // fills a triangle in time quadratic in its size (a 2 m range drew for 3 s): not drawn.
        let (lo, hi) = entry.u_range();
        let side = chip.width().max(chip.height()) as f32;
        let fits = refined.placement.px_per_unit * (hi - lo).max(1.0) <= 2.0 * side;
        if !fits {
            return;
        }
        if self.prior.reset(chip.width(), chip.height()).is_ok() {
            // The mask is an infallible draw target.
            let _ = render::draw_entry(&mut self.prior, &entry, &refined.placement);
        }
    }

    fn result(
        &self,
        solution: &ClosedForm,
        silhouette: &Silhouette,
        choice: crate::temporal::YawChoice,
        range_used: bool,
        image_range: Option<f32>,
    ) -> FrameResult {
        let [away, towards] = solution.candidates;
        let (chosen, alternative) = if choice.away {
            (away, towards)
        } else {
            (towards, away)
        };
        let [tx_m, ty_m, tz_m] = solution.translation;
        FrameResult {
            status: Status::Ok,
            capacity: None,
            pose: Pose {
                tx_m,
                ty_m,
                tz_m,
                pitch_deg: chosen.pitch_deg,
                yaw_deg: chosen.yaw_deg,
            },
            pitch_alt_deg: alternative.pitch_deg,
            yaw_alt_deg: alternative.yaw_deg,
            yaw_resolved: choice.resolved,
            range_used,
            roll_deg: None,
            image_range_m: image_range.unwrap_or(0.0),
            silhouette: Some(*silhouette),
            matched: None,
        }
    }
}
