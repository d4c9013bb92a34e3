//! The shape-guided loop (the source paper's Fig. 1): rounds of segmentation guided by the prior
//! and table match again, the segmentation's transform carried to the match's input, and the
//! stop rule that judges each re-match.
//!
//! The table match measures the chip's grey-level width profile along the silhouette's axis,
//! with the measured nose tip and tail base as its extreme-point term. The segmentation is the
//! prior moved by one transform (chip px to chip px), so it moves the matched nose tip and tail
//! base: those moved ends give the new axis and the new extreme points, and, through
//! [`closed_form::from_ends`], the new starting tilt. The grey levels stay the chip's own.

use super::pose::{self, MatchInput, MatchedPose};
use super::{GuidedLoopConfig, GuidedMethod, MatchConfig, TableMatch};
use crate::camera::Camera;
use crate::chip::ChipView;
use crate::closed_form::{self, ClosedForm};
use crate::extremes::{Axis, Silhouette};
use crate::model::ProjectileModel;
use crate::pose::RAD;
use crate::shape_guided::{Affine2, GuidedSegmentation, ShapeGuidedError};
use core::cmp::Ordering;
use nalgebra::Vector2;

impl<const MASK_WORDS: usize> TableMatch<MASK_WORDS> {
    /// The loop from the first match `first` (whose prior is drawn; `range_m` the known range,
    /// if any): each round's re-match is kept only when the stop rule accepts it. Returns the
    /// match kept.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn guided_loop_from(
        &mut self,
        input: &MatchInput,
        range_m: Option<f32>,
        camera: &Camera,
        model: &ProjectileModel,
        config: &MatchConfig,
        first: MatchedPose,
    ) -> MatchedPose {
        let limits = &config.guided;
        let (Some(method), Some(table)) = (limits.method, self.table) else {
            return first;
        };
        // Without a range the re-matches keep the first match's scale: the segmentation moves
        // the axis and the ends, and a section read across the moved axis scattered the image
        // range by up to 11 % either way (table1-test without its range, TETRIS: 17 frames).
        let scale = range_m.map_or(
            pose::MatchScale::Held(first.placement.px_per_unit),
            pose::MatchScale::Range,
        );
        let mut outcome = LoopOutcome::start(method, &first);
        let (mut current, mut measured) = (first, *input.silhouette);
        outcome.stop = loop {
            if outcome.rounds >= limits.max_rounds {
                break LoopStop::Rounds;
            }
            outcome.rounds += 1;
            let segmentation = match self.segment_around_prior(method, config, input.chip) {
                Ok(s) => s,
                Err(e) => break LoopStop::Failed(e),
            };
            outcome.last = Some(segmentation);
            if segmentation.shift_px < limits.identity_px {
                break LoopStop::Converged;
            }
            let Some(moved) = moved_input(
                &measured,
                &current,
                &segmentation.transform,
                input.origin,
                camera,
                model,
            ) else {
                break LoopStop::Degenerate;
            };
            let moved_frame = MatchInput {
                silhouette: &moved.silhouette,
                ..*input
            };
            let Ok(next) = pose::match_pose(
                &moved_frame,
                &table,
                model,
                camera,
                &moved.closed,
                scale,
                config,
            ) else {
                break LoopStop::NoMatch;
            };
            if let Err(stop) = judge(&current, &next, limits) {
                break stop;
            }
            outcome.accepted += 1;
            (current, measured) = (next, moved.silhouette);
            self.draw_prior(input.chip, &current);
        };
        outcome.rms_px = current.matched.rms_px;
        self.outcome = Some(outcome);
        current
    }

    /// The segmentation at the frame's final pose: where the loop ran and the prior has been
    /// drawn again at a pose refined after it (the grey-level fit's), the loop's method segments
    /// the chip once more around that prior. The pose is not changed: the mask is the method's
    /// answer to the best prior the frame has. Where the method fails, the prior is the mask.
    pub fn segment_at_final_pose(&mut self, chip: &ChipView, config: &MatchConfig) {
        let Some(method) = config.guided.method.filter(|_| self.outcome.is_some()) else {
            return;
        };
        let segmentation = self.segment_around_prior(method, config, chip);
        if let (Ok(s), Some(outcome)) = (segmentation, self.outcome.as_mut()) {
            outcome.last = Some(s);
        }
    }

    /// `method`'s segmentation of `chip` around the prior, into the guided mask; where it
    /// fails, the prior is the mask.
    fn segment_around_prior(
        &mut self,
        method: GuidedMethod,
        config: &MatchConfig,
        chip: &ChipView,
    ) -> Result<GuidedSegmentation, ShapeGuidedError> {
        let segmentation = self.guided.segment(
            method,
            &config.guided.segmentation,
            chip,
            &self.prior,
            &mut self.guided_mask,
        );
        if segmentation.is_err() {
            self.guided_mask.clone_from(&self.prior);
        }
        segmentation
    }
}

/// Why the loop stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LoopStop {
    /// The segmentation moved the prior less than [`GuidedLoopConfig::identity_px`].
    Converged,
    /// The segmentation failed (the prior is kept as the segmentation).
    Failed(ShapeGuidedError),
    /// The moved ends coincide: no axis.
    Degenerate,
    /// The table match found nothing on the moved axis.
    NoMatch,
    /// The re-match's tilt or ends moved more than the stop rule allows.
    Disagrees,
    /// The re-match fits the width profile worse than the current match.
    WorseResidual,
    /// [`GuidedLoopConfig::max_rounds`] rounds were made.
    Rounds,
}

/// What the loop did in a frame.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LoopOutcome {
    /// The method.
    pub method: GuidedMethod,
    /// Segmentations made.
    pub rounds: u8,
    /// Re-matches accepted (the pose is the last accepted one, or the first match).
    pub accepted: u8,
    /// Why it stopped.
    pub stop: LoopStop,
    /// The last segmentation, where one succeeded.
    pub last: Option<GuidedSegmentation>,
    /// RMS width residual of the first match, px.
    pub first_rms_px: f32,
    /// RMS width residual of the match kept, px.
    pub rms_px: f32,
}

impl LoopOutcome {
    /// A loop with `method` that has not run yet, from the first match.
    pub fn start(method: GuidedMethod, first: &MatchedPose) -> LoopOutcome {
        LoopOutcome {
            method,
            rounds: 0,
            accepted: 0,
            stop: LoopStop::Rounds,
            last: None,
            first_rms_px: first.matched.rms_px,
            rms_px: first.matched.rms_px,
        }
    }
}

/// The table match's new input after a segmentation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Moved {
    /// The silhouette on the moved axis, with ends such that the table match's end correction
    /// gives back the moved nose tip and tail base.
    pub silhouette: Silhouette,
    /// The closed form from the moved ends at the match's range: the starting tilt.
    pub closed: ClosedForm,
}

/// Carries `transform` (chip px to chip px) to the table match's input: the nose tip and tail
/// base of `matched` (on a chip whose top-left is full-frame `origin`) are moved by it, and
/// `silhouette` (the one `matched` was measured on) is put on the moved axis. None when the
/// moved ends coincide or are not finite.
pub fn moved_input(
    silhouette: &Silhouette,
    matched: &MatchedPose,
    transform: &Affine2,
    origin: (i32, i32),
    camera: &Camera,
    model: &ProjectileModel,
) -> Option<Moved> {
    let o = Vector2::new(origin.0 as f32, origin.1 as f32);
    let [nose, tail] = matched
        .ends
        .map(|end| transform.apply(Vector2::from(end) - o));
    let length = (nose - tail).norm();
    if !(length.is_finite() && length > f32::EPSILON) {
        return None;
    }
    let dir = (nose - tail) / length;
    let centre = transform.apply(silhouette.axis.centre.into());
    let across: Vector2<f32> = silhouette.axis.dir.perpendicular().into();
    let widening = (transform.matrix() * across).norm();
    let closed = closed_form::from_ends(
        (nose + o).into(),
        (tail + o).into(),
        camera,
        model.length_m,
        matched.range_m,
    );
    // The table match adds these to the silhouette's ends (the ogive's ramp and the base disc).
    let aspect = closed.aspect_deg * RAD;
    let px_per_m = matched.section.diameter_px * widening / model.diameter_m;
    let at_zero = Silhouette {
        nose_t: 0.0,
        tail_t: 0.0,
        ..*silhouette
    };
    let (nose_offset, tail_offset) = closed_form::corrected_ends(
        &at_zero,
        model,
        libm::sinf(aspect),
        libm::cosf(aspect),
        px_per_m,
    );
    let moved = Silhouette {
        axis: Axis {
            centre: centre.into(),
            dir: dir.into(),
        },
        nose_t: (nose - centre).dot(&dir) - nose_offset,
        tail_t: (tail - centre).dot(&dir) - tail_offset,
        diameter_px: silhouette.diameter_px * widening,
        ..*silhouette
    };
    let finite = [
        moved.axis.centre.x,
        moved.axis.centre.y,
        moved.nose_t,
        moved.tail_t,
        moved.diameter_px,
    ]
    .iter()
    .all(|v| v.is_finite());
    finite.then_some(Moved {
        silhouette: moved,
        closed,
    })
}

/// The stop rule: `next` replaces `current` only when its tilt and projected ends stay within
/// `config`'s limits of `current`'s and its RMS width residual is not larger.
pub fn judge(
    current: &MatchedPose,
    next: &MatchedPose,
    config: &GuidedLoopConfig,
) -> Result<(), LoopStop> {
    let tilt_change = libm::fabsf(next.matched.tilt_deg - current.matched.tilt_deg);
    let end_shift = current
        .ends
        .iter()
        .zip(&next.ends)
        .map(|(a, b)| libm::hypotf(b.x - a.x, b.y - a.y))
        .fold(0.0f32, f32::max);
    let agrees = tilt_change <= config.max_tilt_change_deg && end_shift <= config.max_end_shift_px;
    if !agrees {
        return Err(LoopStop::Disagrees);
    }
    // NaN fits no better.
    let fits_no_worse = matches!(
        next.matched.rms_px.partial_cmp(&current.matched.rms_px),
        Some(Ordering::Less | Ordering::Equal)
    );
    if !fits_no_worse {
        return Err(LoopStop::WorseResidual);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::extremes::SilhouetteConfig;
    use crate::lut::render::{Placement, View};
    use crate::model::testing::reference;
    use crate::point::ImagePoint;
    use crate::table_match::search::Match;
    use crate::table_match::section::LambertSection;

    const CAMERA: Camera = Camera {
        fx: 100_000.0,
        fy: 100_000.0,
        cx: 1023.5,
        cy: 1023.5,
    };
    const ORIGIN: (i32, i32) = (896, 896);

    /// A silhouette along +x through (128, 128) on the chip at [`ORIGIN`].
    fn silhouette() -> Silhouette {
        Silhouette {
            axis: Axis {
                centre: ImagePoint::new(128.0, 128.0),
                dir: ImagePoint::new(1.0, 0.0),
            },
            nose_t: 60.0,
            nose_ramp_offset_m: {
                let (low, high) = SilhouetteConfig::DEFAULT.nose_ramp;
                reference().nose_ramp_zero_offset_m(low, high)
            },
            tail_t: -64.0,
            diameter_px: 8.0,
            contrast: 50.0,
            sigma_px: 0.8,
            nose_evidence: 1.0,
            plume_at_tail: false,
        }
    }

    /// A match with its nose tip at chip (190, 128) and tail base at (62, 128), residual `rms_px`
    /// and tilt `tilt_deg`.
    fn matched(tilt_deg: f32, rms_px: f32, shift_px: f32) -> MatchedPose {
        let ends = [(190.0 + shift_px, 128.0), (62.0, 128.0)]
            .map(|(x, y)| ImagePoint::new(x, y) + ImagePoint::of_pixel(ORIGIN));
        MatchedPose {
            solution: closed_form::from_ends(ends[0], ends[1], &CAMERA, 1.378, 1000.0),
            range_m: 1000.0,
            matched: Match {
                tilt_deg,
                roll_deg: 0.0,
                roll_confidence: 0.0,
                px_per_d: 8.0,
                origin_t: 0.0,
                rms_px,
            },
            section: LambertSection {
                diameter_px: 8.0,
                mean_contrast: 50.0,
                sigma_px: 0.8,
                offset_px: 0.0,
            },
            view: View {
                tilt_deg,
                roll_deg: 0.0,
            },
            placement: Placement {
                origin: ImagePoint::new(126.0, 128.0),
                dir: ImagePoint::new(1.0, 0.0),
                px_per_unit: 8.0,
            },
            ends,
        }
    }

    #[test]
    fn a_translation_moves_the_axis_and_the_corrected_ends_are_the_moved_ends() {
        let shift = Vector2::new(3.0, -2.0);
        let transform = Affine2::about(Vector2::zeros(), nalgebra::Matrix2::identity(), shift);
        let sil = silhouette();
        let first = matched(20.0, 1.0, 0.0);
        let moved = moved_input(&sil, &first, &transform, ORIGIN, &CAMERA, &reference())
            .expect("a finite move");
        let m = moved.silhouette;
        assert!((m.axis.dir.x - 1.0).abs() < 1e-6 && m.axis.dir.y.abs() < 1e-6);
        assert!((m.axis.centre.x - 131.0).abs() < 1e-4 && (m.axis.centre.y - 126.0).abs() < 1e-4);
        assert_eq!(m.diameter_px, sil.diameter_px);
        // What the table match will take as the measured ends: the matched ends, moved.
        let aspect = moved.closed.aspect_deg * RAD;
        let px_per_m = first.section.diameter_px / reference().diameter_m;
        let (nose, tail) = closed_form::corrected_ends(
            &m,
            &reference(),
            libm::sinf(aspect),
            libm::cosf(aspect),
            px_per_m,
        );
        assert!((m.axis.point(nose).x - 193.0).abs() < 1e-3, "nose {nose}");
        assert!((m.axis.point(tail).x - 65.0).abs() < 1e-3, "tail {tail}");
        // The closed form of the moved ends: the same length, so the same aspect.
        assert!((moved.closed.aspect_deg - first.solution.aspect_deg).abs() < 0.05);
    }

    #[test]
    fn a_collapsing_transform_gives_no_input() {
        let transform = Affine2 {
            linear: [[0.0, 0.0], [0.0, 0.0]],
            offset: [10.0, 10.0],
        };
        let moved = moved_input(
            &silhouette(),
            &matched(20.0, 1.0, 0.0),
            &transform,
            ORIGIN,
            &CAMERA,
            &reference(),
        );
        assert_eq!(moved, None);
    }

    #[test]
    fn the_stop_rule_keeps_only_agreeing_matches_that_fit_no_worse() {
        let limits = GuidedLoopConfig::DEFAULT;
        let current = matched(20.0, 1.0, 0.0);
        assert_eq!(judge(&current, &matched(24.0, 0.9, 2.0), &limits), Ok(()));
        assert_eq!(judge(&current, &matched(20.0, 1.0, 0.0), &limits), Ok(()));
        let tilted = matched(26.0, 0.5, 0.0);
        assert_eq!(judge(&current, &tilted, &limits), Err(LoopStop::Disagrees));
        let moved = matched(20.0, 0.5, 3.5);
        assert_eq!(judge(&current, &moved, &limits), Err(LoopStop::Disagrees));
        let worse = matched(20.0, 1.01, 0.0);
        assert_eq!(
            judge(&current, &worse, &limits),
            Err(LoopStop::WorseResidual)
        );
        let nan = matched(20.0, f32::NAN, 0.0);
        assert_eq!(judge(&current, &nan, &limits), Err(LoopStop::WorseResidual));
    }
}
