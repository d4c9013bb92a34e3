//! The refinement loop's two pieces (the pipeline runs the rounds): the shape-guided transform
//! carried to the table match's input, and the stop rule that judges a re-match.
//!
//! The table match measures the chip's grey-level width profile along the silhouette's axis,
//! with the measured nose tip and tail base as its extreme-point term. The segmentation is the
//! prior moved by one transform (chip px to chip px), so it moves the matched nose tip and tail
//! base: those moved ends give the new axis and the new extreme points, and, through
//! [`closed_form::from_ends`], the new starting tilt. The grey levels stay the chip's own.

use super::affine::Affine2;
use super::{Method, Refinement, ShapeGuidedError};
use crate::camera::Camera;
use crate::closed_form::{self, ClosedForm};
use crate::config::{RefineConfig, RefineMethod};
use crate::extremes::{Axis, Silhouette};
use crate::lut::Refined;
use crate::model::ProjectileModel;
use crate::pose::RAD;
use core::cmp::Ordering;
use nalgebra::Vector2;

impl RefineMethod {
    /// The shape-guided method, or None for no refinement.
    pub fn method(self) -> Option<Method> {
        match self {
            RefineMethod::None => None,
            RefineMethod::SisCut => Some(Method::SisCut),
            RefineMethod::GvfAsm => Some(Method::GvfAsm),
        }
    }
}

/// Why the loop stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LoopStop {
    /// The segmentation moved the prior less than [`RefineConfig::identity_px`].
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
    /// [`RefineConfig::max_rounds`] rounds were made.
    Rounds,
}

/// What the loop did in a frame.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LoopOutcome {
    /// The method.
    pub method: Method,
    /// Segmentations made.
    pub rounds: u8,
    /// Re-matches accepted (the pose is the last accepted one, or the first match).
    pub accepted: u8,
    /// Why it stopped.
    pub stop: LoopStop,
    /// The last segmentation, where one succeeded.
    pub last: Option<Refinement>,
    /// RMS width residual of the first match, px.
    pub first_rms_px: f32,
    /// RMS width residual of the match kept, px.
    pub rms_px: f32,
}

impl LoopOutcome {
    /// A loop with `method` that has not run yet, from the first match.
    pub fn start(method: Method, first: &Refined) -> LoopOutcome {
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
    matched: &Refined,
    transform: &Affine2,
    origin: (i32, i32),
    camera: &Camera,
    model: &ProjectileModel,
) -> Option<Moved> {
    let o = Vector2::new(origin.0 as f32, origin.1 as f32);
    let [nose, tail] = matched
        .ends
        .map(|(x, y)| transform.apply(Vector2::new(x, y) - o));
    let length = (nose - tail).norm();
    if !(length.is_finite() && length > f32::EPSILON) {
        return None;
    }
    let dir = (nose - tail) / length;
    let (cx, cy) = silhouette.axis.centre;
    let centre = transform.apply(Vector2::new(cx, cy));
    let across = Vector2::new(-silhouette.axis.dir.1, silhouette.axis.dir.0);
    let widening = (transform.matrix() * across).norm();
    let closed =
        closed_form::from_ends(nose + o, tail + o, camera, model.length_m, matched.range_m);
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
            centre: (centre.x, centre.y),
            dir: (dir.x, dir.y),
        },
        nose_t: (nose - centre).dot(&dir) - nose_offset,
        tail_t: (tail - centre).dot(&dir) - tail_offset,
        diameter_px: silhouette.diameter_px * widening,
        ..*silhouette
    };
    let finite = [
        moved.axis.centre.0,
        moved.axis.centre.1,
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
pub fn judge(current: &Refined, next: &Refined, config: &RefineConfig) -> Result<(), LoopStop> {
    let tilt_change = libm::fabsf(next.matched.tilt_deg - current.matched.tilt_deg);
    let end_shift = current
        .ends
        .iter()
        .zip(&next.ends)
        .map(|(a, b)| libm::hypotf(b.0 - a.0, b.1 - a.1))
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
