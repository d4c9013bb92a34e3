//! 1-km-normalized pose errors (`docs/geometry.md`): |estimate - truth| / (Tz_true / 1 km),
//! angle differences wrapped to (-180, 180].

use super::paper::{Parameter, RangeCase, pose_accuracy};
use super::stats::{Summary, summarize};
use crate::clip::{GroundTruth, ResultRow};
use serde::Serialize;
use std::collections::HashMap;

/// The normalized errors of one frame with a pose and ground truth.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FrameErrors {
    /// Frame number.
    pub frame: u64,
    /// True depth, m.
    pub tz_true_m: f64,
    /// Tx error, m/km.
    pub tx: f64,
    /// Ty error, m/km.
    pub ty: f64,
    /// Tz error, m/km.
    pub tz: f64,
    /// Pitch error of the chosen candidate, deg/km.
    pub pitch: f64,
    /// Yaw error of the chosen candidate, deg/km.
    pub yaw: f64,
    /// Yaw error of the better candidate, deg/km.
    pub yaw_best: f64,
    /// True when the chosen candidate is the better one.
    pub yaw_choice_correct: bool,
    /// True when the row says the choice is settled (`yaw_resolved`).
    pub yaw_resolved: bool,
    /// True when a range measurement fixed Tz in this frame.
    pub range_used: bool,
    /// Where the row gives `tz_sd_m`: whether the Tz error is within two of those sigmas.
    pub tz_within_two_sd: Option<bool>,
    /// Where the row gives `pitch_sd_deg`: whether the pitch error is within two sigmas, not
    /// counting the choice (of the candidate nearer the truth).
    pub pitch_within_two_sd: Option<bool>,
    /// Where the row gives `yaw_sd_deg`: the same for yaw.
    pub yaw_within_two_sd: Option<bool>,
    /// Roll error modulo the fins' spacing, deg/km, where the row gives a roll and its chosen
    /// yaw candidate is the better one (the roll is the chosen candidate's: the mirror's turns
    /// the fins the other way).
    pub roll: Option<f64>,
    /// Where `roll` is judged and the row gives `roll_sd_deg`: whether it is within two sigmas.
    pub roll_within_two_sd: Option<bool>,
}

impl FrameErrors {
    /// The error of one parameter.
    pub fn get(&self, parameter: Parameter) -> f64 {
        match parameter {
            Parameter::Tx => self.tx,
            Parameter::Ty => self.ty,
            Parameter::Tz => self.tz,
            Parameter::Pitch => self.pitch,
            Parameter::Yaw => self.yaw,
            Parameter::YawBest => self.yaw_best,
        }
    }
}

/// The statistics of one parameter's errors beside the paper's figure.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ParameterErrors {
    /// The parameter.
    pub parameter: Parameter,
    /// Unit of the errors.
    pub unit: &'static str,
    /// Median, mean, p90 (None without any frame).
    pub stats: Option<Summary>,
    /// The paper's figure for this range case, where it gave one.
    pub paper: Option<f64>,
}

/// Pose accuracy of one results file against the clip's truth.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PoseEvaluation {
    /// Known range when most frames with a pose used a range measurement.
    pub case: RangeCase,
    /// Frames of the clip with ground truth.
    pub frames_with_truth: usize,
    /// Of those, frames with a pose.
    pub frames_with_pose: usize,
    /// Per parameter, in [`Parameter::ALL`] order.
    pub parameters: Vec<ParameterErrors>,
    /// Fraction of frames with a pose whose chosen yaw candidate is the better one.
    pub yaw_choice_correct: Option<f64>,
    /// Fraction of frames with a pose whose choice the row says is settled (`yaw_resolved`).
    pub yaw_resolved: Option<f64>,
    /// Of those, the fraction whose chosen candidate is the better one: how far `yaw_resolved`
    /// can be trusted; None where no frame is resolved.
    pub resolved_choice_correct: Option<f64>,
    /// Fraction of frames with `tz_sd_m` whose Tz error is within two of its sigmas (honest
    /// sigmas give about 95 %); None where no row has one.
    pub tz_within_two_sd: Option<f64>,
    /// The same for pitch and `pitch_sd_deg`, not counting the choice (of the candidate nearer
    /// the truth).
    pub pitch_within_two_sd: Option<f64>,
    /// The same for yaw and `yaw_sd_deg`.
    pub yaw_within_two_sd: Option<f64>,
    /// Roll errors, deg/km, of the frames with a roll and the better yaw candidate chosen.
    pub roll: Option<Summary>,
    /// Frames with a pose that give a roll.
    pub frames_with_roll: usize,
    /// The same as `pitch_within_two_sd` for roll and `roll_sd_deg`.
    pub roll_within_two_sd: Option<f64>,
    /// Per-frame errors.
    pub frames: Vec<FrameErrors>,
}

impl PoseEvaluation {
    /// The statistics of `parameter`'s errors, where any frame had one.
    pub fn stats(&self, parameter: Parameter) -> Option<Summary> {
        self.parameters
            .iter()
            .find(|e| e.parameter == parameter)
            .and_then(|e| e.stats)
    }
}

/// Wraps an angle difference to (-180, 180] deg.
pub fn wrap_deg(d: f64) -> f64 {
    let w = d.rem_euclid(360.0);
    if w > 180.0 { w - 360.0 } else { w }
}

/// The errors of one frame; None unless the row has a pose. Rolls differ modulo
/// `roll_period_deg`, the fins' spacing.
pub fn frame_errors(
    frame: u64,
    truth: &GroundTruth,
    row: &ResultRow,
    roll_period_deg: f64,
) -> Option<FrameErrors> {
    if !row.is_ok() || truth.tz_m.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let km = truth.tz_m / 1000.0;
    let err = |estimate: f64, truth: f64| (estimate - truth).abs() / km;
    let angle = |estimate: f64, truth: f64| wrap_deg(estimate - truth).abs() / km;
    let yaw = angle(row.yaw_deg?, truth.yaw_deg);
    let pitch = angle(row.pitch_deg?, truth.pitch_deg);
    let yaw_alt = row
        .yaw_alt_deg
        .map_or(f64::INFINITY, |a| angle(a, truth.yaw_deg));
    // The sigmas do not count the choice between the mirror candidates (docs/formats.md): they
    // are judged on the candidate nearer the truth. Errors here are per km; a sigma is not.
    // Where the mirror is nearer but its pitch is not given, pitch is not judged.
    let (pitch_judged, yaw_judged) = if yaw_alt < yaw {
        (
            row.pitch_alt_deg.map(|p| angle(p, truth.pitch_deg)),
            yaw_alt,
        )
    } else {
        (Some(pitch), yaw)
    };
    let within = |error_per_km: f64, sd: Option<f64>| sd.map(|sd| error_per_km * km <= 2.0 * sd);
    let half = 0.5 * roll_period_deg;
    let roll = row
        .roll_deg
        .filter(|_| yaw <= yaw_alt)
        .map(|r| ((r - truth.roll_deg + half).rem_euclid(roll_period_deg) - half).abs() / km);
    Some(FrameErrors {
        frame,
        tz_true_m: truth.tz_m,
        tx: err(row.tx_m?, truth.tx_m),
        ty: err(row.ty_m?, truth.ty_m),
        tz: err(row.tz_m?, truth.tz_m),
        pitch,
        yaw,
        yaw_best: yaw.min(yaw_alt),
        yaw_choice_correct: yaw <= yaw_alt,
        yaw_resolved: row.yaw_resolved,
        range_used: row.range_used,
        tz_within_two_sd: row
            .tz_sd_m
            .zip(row.tz_m)
            .map(|(sd, tz)| (tz - truth.tz_m).abs() <= 2.0 * sd),
        pitch_within_two_sd: pitch_judged.and_then(|p| within(p, row.pitch_sd_deg)),
        yaw_within_two_sd: within(yaw_judged, row.yaw_sd_deg),
        roll,
        roll_within_two_sd: roll.and_then(|r| within(r, row.roll_sd_deg)),
    })
}

/// Evaluates results against the truth of `(frame, truth)` pairs, rolls modulo
/// `roll_period_deg`.
pub fn evaluate(
    truth: &[(u64, GroundTruth)],
    results: &[ResultRow],
    roll_period_deg: f64,
) -> PoseEvaluation {
    let by_frame: HashMap<u64, &ResultRow> = results
        .iter()
        .filter_map(|r| r.frame.map(|f| (f, r)))
        .collect();
    let frames: Vec<FrameErrors> = truth
        .iter()
        .filter_map(|(frame, t)| frame_errors(*frame, t, by_frame.get(frame)?, roll_period_deg))
        .collect();
    let ranged = frames.iter().filter(|f| f.range_used).count();
    let case = if 2 * ranged > frames.len() {
        RangeCase::Known
    } else {
        RangeCase::Unknown
    };
    let parameters = Parameter::ALL
        .iter()
        .map(|&parameter| ParameterErrors {
            parameter,
            unit: parameter.unit(),
            stats: summarize(&frames.iter().map(|f| f.get(parameter)).collect::<Vec<_>>()),
            paper: pose_accuracy(case, parameter),
        })
        .collect();
    let correct = frames.iter().filter(|f| f.yaw_choice_correct).count();
    let share = |part: usize, whole: usize| (whole > 0).then(|| part as f64 / whole as f64);
    let resolved: Vec<&FrameErrors> = frames.iter().filter(|f| f.yaw_resolved).collect();
    let resolved_correct = resolved.iter().filter(|f| f.yaw_choice_correct).count();
    let share_within = |within: fn(&FrameErrors) -> Option<bool>| {
        let judged: Vec<bool> = frames.iter().filter_map(within).collect();
        let inside = judged.iter().filter(|w| **w).count();
        share(inside, judged.len())
    };
    PoseEvaluation {
        case,
        frames_with_truth: truth.len(),
        frames_with_pose: frames.len(),
        parameters,
        yaw_choice_correct: share(correct, frames.len()),
        yaw_resolved: share(resolved.len(), frames.len()),
        resolved_choice_correct: share(resolved_correct, resolved.len()),
        tz_within_two_sd: share_within(|f| f.tz_within_two_sd),
        pitch_within_two_sd: share_within(|f| f.pitch_within_two_sd),
        yaw_within_two_sd: share_within(|f| f.yaw_within_two_sd),
        roll: summarize(&frames.iter().filter_map(|f| f.roll).collect::<Vec<_>>()),
        frames_with_roll: results
            .iter()
            .filter(|r| r.is_ok() && r.roll_deg.is_some())
            .count(),
        roll_within_two_sd: share_within(|f| f.roll_within_two_sd),
        frames,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn truth() -> GroundTruth {
        GroundTruth {
            tx_m: 1.0,
            ty_m: -2.0,
            tz_m: 2000.0,
            pitch_deg: 10.0,
            yaw_deg: 179.0,
            roll_deg: 0.0,
        }
    }

    fn row(yaw: f64, yaw_alt: f64) -> ResultRow {
        ResultRow {
            frame: Some(7),
            status: "ok".into(),
            tx_m: Some(1.3),
            ty_m: Some(-2.0),
            tz_m: Some(1900.0),
            pitch_deg: Some(4.0),
            yaw_deg: Some(yaw),
            yaw_alt_deg: Some(yaw_alt),
            yaw_resolved: false,
            range_used: false,
            roll_deg: None,
            tz_sd_m: Some(60.0),
            pitch_sd_deg: Some(2.9),
            yaw_sd_deg: None,
            pitch_alt_deg: None,
            image_range_m: None,
            roll_sd_deg: None,
            nose_az_deg: None,
            nose_el_deg: None,
            e_m: None,
            n_m: None,
            u_m: None,
            aoa_deg: None,
            aoa_up_deg: None,
            aoa_right_deg: None,
        }
    }

    #[test]
    fn errors_are_normalized_to_one_km_and_wrapped() {
        // At 2 km every absolute error is halved; yaw -179 is 2 deg from 179 across the wrap.
        let e = frame_errors(7, &truth(), &row(-179.0, 0.0), 90.0).unwrap();
        assert!((e.tx - 0.15).abs() < 1e-9);
        assert!((e.tz - 50.0).abs() < 1e-9);
        assert!((e.pitch - 3.0).abs() < 1e-9);
        assert!((e.yaw - 1.0).abs() < 1e-9);
        assert!(e.yaw_choice_correct);
        // 100 m off with a sigma of 60 m: within two sigmas. Pitch 6 deg off (3 per km) with a
        // sigma of 2.9 deg: outside, a sigma being compared with the error itself, not per km.
        assert_eq!(e.tz_within_two_sd, Some(true));
        assert_eq!(e.pitch_within_two_sd, Some(false));
        assert_eq!(e.yaw_within_two_sd, None);
    }

    #[test]
    fn the_better_candidate_and_the_choice_are_scored() {
        let e = frame_errors(7, &truth(), &row(1.0, 171.0), 90.0).unwrap();
        assert!((e.yaw - 89.0).abs() < 1e-9);
        assert!((e.yaw_best - 4.0).abs() < 1e-9);
        assert!(!e.yaw_choice_correct);
        let failed = ResultRow {
            status: "no_target".into(),
            ..row(0.0, 0.0)
        };
        assert!(frame_errors(7, &truth(), &failed, 90.0).is_none());
        let eval = evaluate(&[(7, truth()), (8, truth())], &[row(1.0, 171.0)], 90.0);
        assert_eq!((eval.frames_with_truth, eval.frames_with_pose), (2, 1));
        assert_eq!(eval.case, RangeCase::Unknown);
        assert_eq!(eval.yaw_choice_correct, Some(0.0));
        assert_eq!(
            (eval.yaw_resolved, eval.resolved_choice_correct),
            (Some(0.0), None)
        );
    }

    /// Of three frames with a pose, two resolved: one on the right side, one on the wrong;
    /// the third, unresolved and wrong, does not count against `yaw_resolved`'s trust.
    #[test]
    fn a_resolved_choice_is_scored_apart() {
        let resolved = |yaw: f64, yaw_alt: f64| ResultRow {
            yaw_resolved: true,
            ..row(yaw, yaw_alt)
        };
        let rows = [
            ResultRow {
                frame: Some(1),
                ..resolved(1.0, 171.0)
            },
            ResultRow {
                frame: Some(2),
                ..resolved(171.0, 1.0)
            },
            ResultRow {
                frame: Some(3),
                ..row(1.0, 171.0)
            },
        ];
        let truth: Vec<(u64, GroundTruth)> = (1..=3).map(|f| (f, truth())).collect();
        let eval = evaluate(&truth, &rows, 90.0);
        assert_eq!(eval.yaw_choice_correct, Some(1.0 / 3.0));
        assert_eq!(eval.yaw_resolved, Some(2.0 / 3.0));
        assert_eq!(eval.resolved_choice_correct, Some(0.5));
    }

    /// A roll is scored modulo the fins' spacing, per km, and only where the chosen candidate is
    /// the better one: 88 deg against a true 0 with four fins is 2 deg off (1 per km at 2 km),
    /// and with a sigma of 1.5 deg within two of them.
    #[test]
    fn a_roll_is_scored_modulo_the_fins_spacing() {
        let rolled = ResultRow {
            roll_deg: Some(88.0),
            roll_sd_deg: Some(1.5),
            ..row(-179.0, 0.0)
        };
        let e = frame_errors(7, &truth(), &rolled, 90.0).unwrap();
        assert!((e.roll.unwrap() - 1.0).abs() < 1e-9, "{e:?}");
        assert_eq!(e.roll_within_two_sd, Some(true));
        // Six fins: 88 is 28 deg from a true 0 modulo 60.
        let six = frame_errors(7, &truth(), &rolled, 60.0).unwrap();
        assert!((six.roll.unwrap() - 14.0).abs() < 1e-9, "{six:?}");
        // The mirror candidate chosen: the roll is not scored.
        let mirrored = ResultRow {
            roll_deg: Some(88.0),
            ..row(1.0, 171.0)
        };
        assert_eq!(
            frame_errors(7, &truth(), &mirrored, 90.0).unwrap().roll,
            None
        );
    }
}
