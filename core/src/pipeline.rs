//! The pipeline: one method from a chip to a [`FrameResult`], called alike by the host, the
//! tests, the benchmarks, the fuzzers and the firmware. It owns the stages, each with its own
//! buffers, and passes each stage's result to the next; nothing is allocated per frame.
//!
//! | stage | module | hands on |
//! | --- | --- | --- |
//! | detection | [`crate::segment`] | [`Target`] and its mask |
//! | silhouette | [`crate::extremes`] | [`Silhouette`] (then the detection cuts the final mask) |
//! | closed form | [`crate::closed_form`] | [`Hypothesis`] |
//! | table match | [`crate::table_match`] | [`Measurement`] (and the shape prior) |
//! | grey-level fit | [`crate::grey_fit`] | [`Measurement::fitted`] |
//! | temporal estimate | [`crate::temporal`] | [`Estimate`]: range and yaw choice |
//! | flight filter (in the temporal estimate: no range sensor, the mount's pointing) | [`crate::flight_filter`] | the range gravity scales, the yaw side; a sure range for the next frame's image stages to hold the scale at |
//! | world frame (with the mount's pointing) | [`crate::world`] | [`Motion`]: the velocity, which may settle the yaw choice; [`FrameResult::world`] |

use crate::camera::Camera;
use crate::capacity::{DEFAULT_MAX_LABELS, DEFAULT_MAX_RUNS, OUTLINE_COLUMNS};
use crate::chip::ChipView;
use crate::closed_form::{ClosedForm, Hypothesis};
use crate::config::{Config, RangeUse};
use crate::extremes::{self, Silhouette};
use crate::flight_filter::{FlightStep, Sight};
use crate::frame::{FrameError, FrameInput, FrameResult, Status};
use crate::grey_fit::{self, FitInput, FitStart};
use crate::lut::table::Table;
use crate::mask::BitMask;
use crate::model::ProjectileModel;
use crate::point::ImagePoint;
use crate::pose::Pose;
use crate::range_filter::{FilterStep, ImageScale};
use crate::segment::{
    Expectation, ExpectedBody, Proportions, SegmentError, Segmenter, Target, TrackGate, TrackUse,
};
#[cfg(feature = "shape-guided")]
use crate::table_match::guided_loop::LoopOutcome;
use crate::table_match::{MatchedPose, Measurement, TableMatch};
use crate::temporal::{Estimate, Observation, Prediction, Temporal, YawChoice};
use crate::track::Track;
use crate::uncertainty::{self, AngleVariance, EndSd};
use crate::world::{self, Flight, Motion, Mount, Side, Station, WorldStage};

/// An aspect at least this, deg, reads broadside: the apparent length at the model's whole
/// length or beyond (the closed form holds the aspect at 90 deg there).
const BROADSIDE_DEG: f32 = 90.0 - 1e-3;
/// Halvings of the search for the range at which a broadside body's length is the model's whole
/// ([`Pipeline::aspect_interval`]): to 2^-16 of half the range.
const WHOLE_LENGTH_HALVINGS: u32 = 16;

/// A frame's input, checked: the range to use and the camera valid.
struct CheckedInput<'a> {
    chip: &'a ChipView<'a>,
    time_s: f64,
    sensor_range_m: Option<f32>,
    mount: Option<Mount>,
}

/// What a frame's ok result was solved from: kept so that a recorded clip's frames can be solved
/// again at a smoothed range ([`Pipeline::resolve`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Solved {
    /// The frame's measurement (closed form and table match).
    pub measurement: Measurement,
    /// The temporal estimate it was solved at.
    pub estimate: Estimate,
    /// How detection used the track.
    pub track: TrackUse,
    /// One sigma of the silhouette's ends ([`uncertainty::end_sd`]).
    pub end_sd: EndSd,
    /// How the frame was seen moving in the world frame, where it came with the mount's
    /// pointing.
    pub motion: Option<Motion>,
}

/// The pipeline with its stages: `MAX_RUNS` and `MAX_LABELS` size the detection's labeler,
/// `MASK_WORDS` its chip masks (32-bit words each, [`crate::capacity::mask_words`] of the
/// largest chip side: 512 px by default; a larger chip is then a `Capacity` status), and
/// `BAR_CELLS` the grid of its bar search ([`crate::segment::bar`]; 0: no bar search). See
/// [`crate::capacity`].
pub struct Pipeline<
    const MAX_RUNS: usize = DEFAULT_MAX_RUNS,
    const MAX_LABELS: usize = DEFAULT_MAX_LABELS,
    const MASK_WORDS: usize = { crate::capacity::MASK_WORDS },
    const BAR_CELLS: usize = { crate::capacity::BAR_GRID_CELLS },
> {
    config: Config,
    camera: Camera,
    model: ProjectileModel<'static>,
    detect: Segmenter<MAX_RUNS, MAX_LABELS, MASK_WORDS, BAR_CELLS>,
    table_match: TableMatch<MASK_WORDS>,
    temporal: Temporal,
    track: Track,
    world: WorldStage,
    station: Station,
    solved: Option<Solved>,
    range_step: Option<FilterStep>,
    /// The last frame's time in the temporal stage, s (its flight step is kept there).
    frame_t: Option<f32>,
}

impl<
    const MAX_RUNS: usize,
    const MAX_LABELS: usize,
    const MASK_WORDS: usize,
    const BAR_CELLS: usize,
> Pipeline<MAX_RUNS, MAX_LABELS, MASK_WORDS, BAR_CELLS>
{
    /// A pipeline for one camera and projectile.
    pub const fn new(config: Config, camera: Camera, model: ProjectileModel<'static>) -> Self {
        Pipeline {
            config,
            camera,
            model,
            detect: Segmenter::new(),
            table_match: TableMatch::new(),
            temporal: Temporal::new(),
            track: Track::new(),
            world: WorldStage::new(),
            station: Station { enu_m: [0.0; 3] },
            solved: None,
            range_step: None,
            frame_t: None,
        }
    }

    /// The pipeline matching its poses against `table` (one built for this pipeline's model, as
    /// [`ProjectileModel::matches_table`] checks: the table its model file carries), and drawing
    /// the shape prior.
    pub const fn with_table(mut self, table: Table<'static>) -> Self {
        self.set_table(table);
        self
    }

    /// Matches against `table` from now on, in place: a pipeline too large to be moved on a
    /// small stack (the firmware's) is given its table this way.
    pub const fn set_table(&mut self, table: Table<'static>) {
        self.table_match.set_table(table);
    }

    /// The shape-guided loop's TETRIS method ([`crate::GuidedMethod::Tetris`]) runs with
    /// `weights` from now on.
    #[cfg(feature = "shape-guided")]
    pub const fn set_tetris(&mut self, weights: crate::shape_guided::TetrisWeights<'static>) {
        self.table_match.set_tetris(weights);
    }

    /// Where the camera stands in the world frame (the origin until set): the frames that come
    /// with the mount's pointing are stated from there.
    pub const fn set_station(&mut self, station: Station) {
        self.station = station;
    }

    /// The configuration.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The target mask of the last frame (chip-sized; empty when no target was found).
    pub fn mask(&self) -> &BitMask<MASK_WORDS> {
        self.detect.mask()
    }

    /// The shape prior of the last frame: the model's silhouette rendered at the estimated pose
    /// (the grey-level fit's where it ran, else the table match's after the shape-guided loop,
    /// where that ran), chip-sized (empty when no pose was estimated
    /// or no lookup table is loaded).
    pub fn prior(&self) -> &BitMask<MASK_WORDS> {
        self.table_match.prior()
    }

    /// The shape-guided segmentation of the last frame, chip-sized: around the prior at the
    /// grey-level fit's pose where the fit ran, else the loop's last round (the prior it started
    /// from where the method failed); empty where the loop did not run.
    #[cfg(feature = "shape-guided")]
    pub fn guided_mask(&self) -> &BitMask<MASK_WORDS> {
        self.table_match.guided_mask()
    }

    /// What the shape-guided loop did in the last frame (None where it did not run).
    #[cfg(feature = "shape-guided")]
    pub fn guided_loop(&self) -> Option<&LoopOutcome> {
        self.table_match.guided_loop()
    }

    /// The last frame's table match, with its measurements (None where it did not run or match).
    pub fn matched(&self) -> Option<&MatchedPose> {
        self.table_match.matched()
    }

    /// What the last frame's ok result was solved from (None where it gave no pose).
    pub fn last_solved(&self) -> Option<&Solved> {
        self.solved.as_ref()
    }

    /// The flight filter's step at the last frame, where it took that frame: the steps of a
    /// recorded clip, in order, are what [`crate::flight_filter::smooth`] smooths.
    pub fn last_flight_step(&self) -> Option<FlightStep> {
        self.temporal.flight_step(self.frame_t?)
    }

    /// The range filter's step at the last frame, where the filter took a range there (the
    /// sensor's or the image's), with a pose or without: the steps of a recorded clip, in order,
    /// are what [`crate::range_filter::smooth`] smooths.
    pub fn last_range_step(&self) -> Option<FilterStep> {
        self.range_step
    }

    /// The ok result of a frame `solved` earlier, solved again at another temporal `estimate`
    /// (a smoothed range and yaw choice); an `Unmeasurable` one where that pose breaks the
    /// result's contract.
    pub fn resolve(&self, solved: &Solved, estimate: &Estimate) -> FrameResult {
        let result = self.result(&solved.measurement, estimate, solved.end_sd, solved.track);
        let (result, _) = self.placed(solved, *estimate, result);
        match result.check() {
            Ok(()) => result,
            Err(_) => FrameResult::from_error(FrameError::Unmeasurable),
        }
    }

    /// Forgets the temporal state (a new clip).
    pub fn reset(&mut self) {
        self.temporal.reset();
        self.track.reset();
        self.world.reset();
        self.detect.clear_mask();
        self.table_match.clear();
    }

    /// Processes one frame: detection, silhouette, closed form, table match, grey-level fit,
    /// temporal estimate.
    pub fn process(&mut self, input: &FrameInput) -> FrameResult {
        self.table_match.clear();
        self.solved = None;
        self.range_step = None;
        self.frame_t = None;
        let input = match self.check(input) {
            Ok(input) => input,
            Err(e) => return FrameResult::from_error(e),
        };
        let prediction = self.temporal.predict(input.time_s, &self.config.temporal);
        let gate = self.track.gate(input.time_s, &self.config.track);
        let measured = self.measure(&input, &prediction, gate);
        let end_sd = measured.as_ref().ok().map(|(_, m)| self.end_sd(m));
        let observation = measured.as_ref().ok().map(|(_, m)| Observation {
            image_range_m: m.image_range_m(),
            nose_dir: m
                .fitted
                .map_or(m.hypothesis.silhouette.axis.dir, |f| f.nose_dir()),
            scale: ImageScale {
                diameter_px: m.hypothesis.silhouette.diameter_px,
                blur_px: m.hypothesis.silhouette.sigma_px,
            },
            // The flight filter's: it runs where the range is the image's.
            sight: input
                .mount
                .filter(|_| input.sensor_range_m.is_none())
                .zip(end_sd)
                .and_then(|(mount, end_sd)| self.sight(m, &mount, &end_sd)),
            range_held: m.hypothesis.from_flight,
        });
        let estimate = self.temporal.update(
            &prediction,
            input.sensor_range_m,
            observation,
            &self.config.temporal,
        );
        self.range_step = self.temporal.range_step(prediction.t);
        self.frame_t = Some(prediction.t);
        let (target, measurement, estimate, end_sd) = match (measured, estimate, end_sd) {
            (Ok((target, m)), Some(estimate), Some(end_sd)) => (target, m, estimate, end_sd),
            (Err(e), _, _) => return FrameResult::from_error(e),
            (Ok(_), _, _) => return FrameResult::from_error(FrameError::Unmeasurable),
        };
        let result = self.result(&measurement, &estimate, end_sd, target.track);
        // Finite but extreme intrinsics or ranges can overflow the geometry, or underflow the
        // depth to the camera's plane (found by fuzzing): such a pose is no pose.
        if result.check().is_err() {
            self.table_match.clear();
            return FrameResult::from_error(FrameError::Unmeasurable);
        }
        self.track.update(input.time_s, &target);
        let motion = input.mount.and_then(|mount| {
            let config = &self.config.world;
            let motion = self
                .world
                .motion(input.time_s, &result, mount, &self.station, config)?;
            // Without a sensor the positions scatter along the lines of sight: the flight
            // filter's velocity, where it took the frame.
            let flown = self
                .last_flight_step()
                .map(|step| step.estimate().velocity_enu_m_s);
            Some(Motion {
                velocity_enu_m_s: motion.velocity_enu_m_s.or(flown),
                ..motion
            })
        });
        let mut solved = Solved {
            measurement,
            estimate,
            track: target.track,
            end_sd,
            motion,
        };
        let (result, estimate) = self.placed(&solved, estimate, result);
        solved.estimate = estimate;
        self.solved = Some(solved);
        result
    }

    /// The ok `result` of the frame `solved` at `estimate`, placed in the world frame where the
    /// frame came with the mount's pointing: where the velocity tells the nose from its mirror
    /// image ([`Motion::side`]), that candidate, resolved, and the estimate with that choice;
    /// where the velocity lies too near the image plane to tell, the choice unresolved.
    ///
    /// Where the velocity is sure, an angle of attack beyond [`world::WorldConfig::max_aoa_deg`]
    /// and the frame's reach raises the pitch and yaw sigmas to the excess
    /// ([`world::attitude_sd_floor_deg`]). Then, whatever settled the side, it is left
    /// unresolved where the candidates lie within the measurement's reach of each other
    /// ([`world::side_within_reach`]), unless a sensor's velocity lies clear of the image plane
    /// ([`world::WorldConfig::side_clear_velocity_deg`]).
    fn placed(
        &self,
        solved: &Solved,
        estimate: Estimate,
        result: FrameResult,
    ) -> (FrameResult, Estimate) {
        let sure = self.velocity_sure(&result, &estimate);
        let (mut result, estimate) = self.placed_by_motion(solved, estimate, result, sure);
        let config = &self.config.world;
        // An attitude far from a sure velocity is a failed measurement: its sigmas cover it.
        if let Some(aoa) = result.world.and_then(|world| world.aoa).filter(|_| sure) {
            let floor = world::attitude_sd_floor_deg(&aoa, &result, config);
            result.pitch_sd_deg = result.pitch_sd_deg.max(floor);
            result.yaw_sd_deg = result.yaw_sd_deg.max(floor);
        }
        let velocity_clear = result.range_used
            && solved
                .motion
                .and_then(|motion| motion.velocity_off_image_plane_deg(&result))
                .is_some_and(|off| off > config.side_clear_velocity_deg);
        result.yaw_resolved &=
            velocity_clear || !world::side_within_reach(&result, config.side_min_sigmas);
        (result, estimate)
    }

    /// Whether the velocity of the frame of `result` at `estimate` is sure: placed by a sensor's
    /// ranges, or, without a sensor, as sure as the image's range
    /// ([`world::WorldConfig::side_max_range_sd_fraction`]).
    fn velocity_sure(&self, result: &FrameResult, estimate: &Estimate) -> bool {
        let max_sd = self.config.world.side_max_range_sd_fraction * estimate.range_m;
        result.range_used || estimate.range_sd_m.is_some_and(|sd| sd <= max_sd)
    }

    /// [`Pipeline::placed`] up to the measurement's reach: the side as the estimate and the
    /// motion settle it, resolved only where the velocity is `sure`
    /// ([`Pipeline::velocity_sure`]).
    fn placed_by_motion(
        &self,
        solved: &Solved,
        estimate: Estimate,
        result: FrameResult,
        sure: bool,
    ) -> (FrameResult, Estimate) {
        let Some(motion) = solved.motion.filter(|_| result.status == Status::Ok) else {
            return (result, estimate);
        };
        let margin = self.config.world.side_margin_deg;
        let choice = |away: bool, resolved: bool| YawChoice { away, resolved };
        let away = estimate.choice.away;
        // Where the velocity is not sure, it still picks the candidate, unresolved.
        let choice = match motion.side(&result, margin) {
            None => None,
            Some(Side::Chosen) => Some(choice(away, sure)),
            Some(Side::Mirrored) => Some(choice(!away, sure)),
            Some(Side::Either) => Some(choice(away, false)),
        };
        let (mut result, estimate) = match choice {
            // The other candidate: solved again.
            Some(choice) if choice.away != away => {
                let estimate = Estimate { choice, ..estimate };
                let result =
                    self.result(&solved.measurement, &estimate, solved.end_sd, solved.track);
                (result, estimate)
            }
            Some(choice) => (
                FrameResult {
                    yaw_resolved: choice.resolved,
                    ..result
                },
                Estimate { choice, ..estimate },
            ),
            None => (result, estimate),
        };
        result.world = Some(motion.state(&result, &self.station));
        (result, estimate)
    }

    /// The image work of one frame, stage by stage, up to the grey-level fit: the target and the
    /// measurement. `prediction` is what the recent frames expect of this one, `gate` where the
    /// track expects the body.
    fn measure(
        &mut self,
        input: &CheckedInput,
        prediction: &Prediction,
        gate: Option<TrackGate>,
    ) -> Result<(Target, Measurement), FrameError> {
        let (chip, config) = (input.chip, &self.config);
        let aim = ImagePoint::new(0.5 * chip.width() as f32, 0.5 * chip.height() as f32);
        let nose_dir = prediction.nose_dir;
        let expected = input
            .sensor_range_m
            .or(prediction.range_m)
            .and_then(|range_m| self.expected_body(range_m));
        let target = self
            .detect
            .detect(
                chip,
                &config.detect,
                aim,
                &Expectation {
                    size: expected,
                    gate,
                    proportions: Some(Proportions {
                        span_diameters: self.model.max_radius_m() / self.model.radius_m(),
                        length_diameters: self.model.length_m / self.model.diameter_m,
                    }),
                    size_measured: input.sensor_range_m.is_some(),
                },
            )
            .inspect_err(|e| {
                if let SegmentError::Capacity(_) = e {
                    self.detect.clear_mask();
                }
            })?;
        let flight = self.flight(input);
        let prior = extremes::Prior {
            nose_dir,
            diameter_px: expected.map(|e| e.diameter_px),
            flight_dir: flight.and_then(|f| f.in_chip(config.world.min_flight_across)),
        };
        let silhouette = self.silhouette(chip, &target, &prior)?;
        let target = self
            .detect
            .cut_mask(chip, &config.detect, &target, &silhouette)?;
        let origin = (chip.x0(), chip.y0());
        // Without a sensor, the flight's range where it is sure: the image stages hold the
        // scale there, as at a sensor's reading.
        let held_range_m = prediction
            .held_range
            .filter(|_| input.sensor_range_m.is_none())
            .map(|held| held.range_m as f32);
        let hypothesis = Hypothesis::solve(
            &silhouette,
            origin,
            &self.camera,
            &self.model,
            input.sensor_range_m.or(held_range_m),
        )
        .map(|hypothesis| Hypothesis {
            from_flight: held_range_m.is_some(),
            ..hypothesis
        })
        .ok_or(FrameError::Unmeasurable)?;
        let mut measurement = self.table_match.measure(
            chip,
            self.detect.background(),
            target.polarity,
            &hypothesis,
            &self.camera,
            &self.model,
            &config.table_match,
        );
        if let (Some(matched), true) = (&measurement.matched, config.grey_fit.enabled) {
            let input = FitInput {
                chip,
                background: self.detect.background(),
                origin,
                range_m: hypothesis.fixed_range_m,
                range_sensed: hypothesis.sensor_range_m().is_some(),
                nose_towards: prediction.nose_away.map(|away| !away),
                plume_at_tail: hypothesis.silhouette.plume_at_tail,
                cluttered_sky: measurement.cluttered_sky,
                flight_tilt_deg: flight.and_then(|f| f.tilt_deg()),
            };
            measurement.fitted = grey_fit::fit::<OUTLINE_COLUMNS>(
                &input,
                &FitStart::of_match(matched, &self.model, target.polarity),
                &self.model,
                &self.camera,
                &config.grey_fit,
            )
            .ok();
            // The shape prior at the frame's final pose: the fit's.
            let guided = config.table_match.guided.method.is_some();
            if let (Some(fitted), true) = (
                &measurement.fitted,
                config.table_match.shape_prior || guided,
            ) {
                let placement = fitted.placement_in_chip(origin, self.model.diameter_m);
                self.table_match
                    .redraw_prior(chip, &fitted.view, &placement);
                #[cfg(feature = "shape-guided")]
                self.table_match
                    .segment_at_final_pose(chip, &config.table_match);
            }
        }
        Ok((target, measurement))
    }

    /// How the body flies as the camera sees it at the chip of `input`'s middle, where the frame
    /// comes with the mount's pointing and the recent frames' positions give a velocity at its
    /// time ([`WorldStage::velocity_ahead`]).
    fn flight(&self, input: &CheckedInput) -> Option<Flight> {
        let mount = input.mount?;
        let velocity = self
            .world
            .velocity_ahead(input.time_s, &self.config.world)?;
        let chip = input.chip;
        let middle = ImagePoint::new(
            chip.x0() as f32 + 0.5 * chip.width() as f32,
            chip.y0() as f32 + 0.5 * chip.height() as f32,
        );
        Some(Flight::new(&velocity, &mount, &self.camera, middle))
    }

    /// One sigma of the silhouette's ends in `measurement`: the grey-level fit's where it ran,
    /// else the silhouette's ([`uncertainty::end_sd`]).
    fn end_sd(&self, measurement: &Measurement) -> EndSd {
        measurement
            .fitted
            .and_then(|f| {
                let diameter_px = measurement.hypothesis.silhouette.diameter_px;
                uncertainty::fitted_end_sd(&f, diameter_px, &self.config.uncertainty)
            })
            .unwrap_or_else(|| {
                uncertainty::end_sd(
                    &measurement.hypothesis.silhouette,
                    self.detect.background().sigma(),
                    measurement.matched.as_ref().map(|m| m.matched.rms_px),
                    &self.config.uncertainty,
                )
            })
    }

    /// The line of sight to the body origin of `measured` in the world frame, the camera
    /// pointed as `mount`: the origin's direction, which the range does not change (it is
    /// solved at the image range), with its sigma: the pointing's
    /// ([`crate::flight_filter::FlightFilterConfig::sight_sd_px`]) and the origin's place in the
    /// chip from the ends' sigmas `end_sd` (their mean over the two directions), together.
    fn sight(&self, measured: &Measurement, mount: &Mount, end_sd: &EndSd) -> Option<Sight> {
        let range_m = measured.image_range_m()?;
        let [x, y, z] = measured
            .at_range(&self.camera, &self.model, range_m)
            .translation;
        let dir = mount.rotation_camera_to_world()
            * nalgebra::Vector3::new(f64::from(x), f64::from(y), f64::from(z));
        let dir = dir.try_normalize(0.0)?;
        let focal = f64::from(self.camera.fx.min(self.camera.fy));
        let pointing_px = self.config.temporal.flight.sight_sd_px;
        let (along, across) = (end_sd.along_px, end_sd.across_px);
        let place_px = libm::sqrtf(0.5 * (along * along + across * across));
        let sd_px = libm::sqrtf(pointing_px * pointing_px + place_px * place_px);
        let sd_rad = f64::from(sd_px) / focal;
        Some(Sight {
            station_enu_m: self.station.enu_m,
            dir_enu: [dir.x, dir.y, dir.z],
            sd_rad,
        })
    }

    /// The body's size in the chip at `range_m` m (None for a range that gives no finite size).
    fn expected_body(&self, range_m: f32) -> Option<ExpectedBody> {
        let px_per_m = self.camera.fx.min(self.camera.fy) / range_m;
        let expected = ExpectedBody {
            diameter_px: self.model.diameter_m * px_per_m,
            span_px: 2.0 * self.model.max_radius_m() * px_per_m,
            length_px: self.model.length_m * px_per_m,
        };
        let sizes = [expected.diameter_px, expected.span_px, expected.length_px];
        sizes
            .iter()
            .all(|v| v.is_finite() && *v > 0.0)
            .then_some(expected)
    }

    /// The silhouette stage on `target`, with what is known of it beforehand.
    fn silhouette(
        &self,
        chip: &ChipView,
        target: &Target,
        prior: &extremes::Prior,
    ) -> Result<Silhouette, FrameError> {
        extremes::measure(
            chip,
            self.detect.background(),
            target,
            &self.model,
            prior,
            &self.config.silhouette,
        )
        .map_err(|_| FrameError::Unmeasurable)
    }

    /// The frame's input checked: the range sensor's reading (where it is used) finite and
    /// positive, the camera valid and the time finite.
    fn check<'a>(&self, input: &'a FrameInput<'a>) -> Result<CheckedInput<'a>, FrameError> {
        let sensor_range_m = match (input.range_m, self.config.range_use) {
            (Some(r), RangeUse::Auto) if !(r.is_finite() && r > 0.0) => {
                return Err(FrameError::BadInput);
            }
            (Some(r), RangeUse::Auto) => Some(r),
            _ => None,
        };
        if !self.camera.is_valid() || !input.time_s.is_finite() {
            return Err(FrameError::BadInput);
        }
        Ok(CheckedInput {
            chip: &input.chip,
            time_s: input.time_s,
            sensor_range_m,
            mount: input.mount,
        })
    }

    /// `measured` solved at the two ranges that carry a fractional sigma `fraction` of its
    /// apparent length over the model's at `range_m` (or of that range) into the aspect, nearer
    /// and farther: `range_m (1 - fraction)` (at least half of it) and `range_m (1 + fraction)`.
    /// Where the length reads the model's whole length or more even at the nearer one (the
    /// aspect held at 90 deg at both: a body seen broadside, whose length tells its tilt only to
    /// second order), the nearer is taken a fraction below the range at which the length would
    /// be just the model's whole, so that the sigma holds what a length that much shorter
    /// allows (where even half the range reads whole, that half).
    fn aspect_interval(
        &self,
        measured: &Measurement,
        range_m: f32,
        fraction: f32,
    ) -> (ClosedForm, ClosedForm) {
        let solve = |r: f32| measured.at_range(&self.camera, &self.model, r);
        let aspect_at = |r: f32| solve(r).aspect_deg;
        let near_m = range_m * (1.0 - fraction).max(0.5);
        let near = solve(near_m);
        let far = solve(range_m * (1.0 + fraction));
        if near.aspect_deg < BROADSIDE_DEG {
            return (near, far);
        }
        // The range at which the length is just whole, between half the range (where it reads
        // less, unless the body reads twice the model's length) and the nearer one, by halving.
        let short_solution = solve(0.5 * range_m);
        if short_solution.aspect_deg >= BROADSIDE_DEG {
            return (short_solution, far);
        }
        let (mut short, mut whole) = (0.5 * range_m, near_m);
        for _ in 0..WHOLE_LENGTH_HALVINGS {
            let middle = 0.5 * (short + whole);
            if aspect_at(middle) < BROADSIDE_DEG {
                short = middle;
            } else {
                whole = middle;
            }
        }
        (solve(whole * (1.0 - fraction).max(0.5)), far)
    }

    /// One sigma of the slant range of `measured` at the temporal `estimate`, m: the filters',
    /// and without a range sensor among clutter also the image range's systematic error there
    /// ([`crate::uncertainty::UncertaintyConfig::cluttered_range_fraction`]), which the
    /// filters do not know.
    fn range_sd_m(&self, measured: &Measurement, estimate: &Estimate) -> Option<f32> {
        let sd = estimate.range_sd_m?;
        if !measured.image_range_among_clutter() {
            return Some(sd);
        }
        let systematic = self.config.uncertainty.cluttered_range_fraction * estimate.range_m;
        Some(libm::hypotf(sd, systematic))
    }

    /// The ok result of `measured` at the temporal `estimate`, its ends placed to `end_sd`: the
    /// angles' sigmas carry that and the range's sigma through the solution
    /// ([`crate::uncertainty`]); they are the chosen candidate's, not counting the choice.
    fn result(
        &self,
        measured: &Measurement,
        estimate: &Estimate,
        end_sd: EndSd,
        track: TrackUse,
    ) -> FrameResult {
        let pick = |solution: ClosedForm| {
            let [away, towards] = solution.candidates;
            if estimate.choice.away {
                (solution, away, towards)
            } else {
                (solution, towards, away)
            }
        };
        let (solution, chosen, alternative) =
            pick(measured.at_range(&self.camera, &self.model, estimate.range_m));
        let sil = &measured.hypothesis.silhouette;
        // The apparent length's fractional sigma moves the aspect as the range's does.
        let length_px = libm::fabsf(sil.nose_t - sil.tail_t);
        // Two ends; an average of independent lengths is known the better.
        let lengths = f32::from(measured.lengths_averaged());
        let length_fraction =
            core::f32::consts::SQRT_2 * end_sd.along_px / length_px / libm::sqrtf(lengths);
        let range_sd_m = self.range_sd_m(measured, estimate);
        let range_fraction = range_sd_m.map_or(0.0, |sd| sd / estimate.range_m);
        // Without a range sensor, among clutter, a silhouette whose own scale disagrees with
        // the range taken has its length or its diameter misread by about that fraction (a
        // filament along the body, a plume over its base): its aspect is that much less sure.
        // (On a clear sky the disagreement is the image range's own noise, which the length's
        // and the range's sigmas already count.)
        let disagreement = match measured.image_range_m() {
            Some(image_range_m) if measured.image_range_among_clutter() => {
                libm::fabsf(image_range_m - estimate.range_m) / estimate.range_m
            }
            _ => 0.0,
        };
        let fraction = libm::sqrtf(
            length_fraction * length_fraction
                + range_fraction * range_fraction
                + disagreement * disagreement,
        );
        let mut variance = AngleVariance::default();
        let (near, far) = self.aspect_interval(measured, estimate.range_m, fraction);
        variance.add_half_gap(&pick(far).1, &pick(near).1);
        let [tx_m, ty_m, tz_m] = solution.translation;
        let in_plane_rad = core::f32::consts::SQRT_2 * end_sd.across_px / length_px;
        variance.add_in_plane(
            &chosen,
            nalgebra::Vector3::new(tx_m, ty_m, tz_m),
            in_plane_rad,
        );
        let (pitch_sd_deg, yaw_sd_deg) = variance.sd_deg();
        let roll = measured.fitted.as_ref().and_then(|fitted| {
            let sd = uncertainty::fitted_roll_sd(fitted, &self.config.uncertainty)?;
            let sight = nalgebra::Vector3::new(tx_m, ty_m, tz_m);
            let roll = crate::pose::roll_of_silhouette(
                chosen.pitch_deg,
                chosen.yaw_deg,
                &sight,
                fitted.view.roll_deg,
            );
            // Modulo the fins' spacing, in [0, spacing).
            let spacing = self.model.fin_spacing_deg()?;
            let within = roll % spacing;
            let within = if within < 0.0 {
                within + spacing
            } else {
                within
            };
            (within.is_finite() && within < spacing).then_some((within, sd))
        });
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
            yaw_resolved: estimate.choice.resolved,
            range_used: measured.hypothesis.sensor_range_m().is_some(),
            roll_deg: roll.map(|r| r.0),
            roll_sd_deg: roll.map(|r| r.1),
            // The depth is the slant range times the line of sight's cosine: so is its sigma.
            tz_sd_m: range_sd_m.map(|sd| sd * tz_m / estimate.range_m),
            pitch_sd_deg,
            yaw_sd_deg,
            image_range_m: measured.image_range_m().unwrap_or(0.0),
            silhouette: Some(measured.hypothesis.silhouette),
            matched: measured.matched.map(|m| m.matched),
            track: Some(track),
            world: None,
        }
    }
}
