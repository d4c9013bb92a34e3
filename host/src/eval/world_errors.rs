//! World-frame errors (`docs/geometry.md`, "World frame"): the results' nose azimuth and
//! elevation and body origin in E against the truth restated in E from the clip's mount columns
//! and station, normalized to 1 km as the camera-frame errors are.

use super::pose_errors::wrap_deg;
use super::stats::{Summary, summarize};
use crate::clip::{Clip, ResultRow};
use imade_core::pose::Pose;
use imade_core::world::WorldPose;
use serde::Serialize;
use std::collections::HashMap;

/// The world-frame errors of a results file, over the frames with a pose, truth and a mount
/// pointing.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WorldEvaluation {
    /// Frames judged.
    pub frames: usize,
    /// Nose azimuth error of the chosen candidate, deg/km.
    pub nose_az: Option<Summary>,
    /// Nose elevation error of the chosen candidate, deg/km.
    pub nose_el: Option<Summary>,
    /// Distance of the body origin in E from the truth, m/km.
    pub origin: Option<Summary>,
    /// Frames with an angle of attack in the results and in the truth.
    pub frames_with_aoa: usize,
    /// Error of the total angle of attack, deg (not normalized: it is an angle between two
    /// directions in E, whatever the range).
    pub aoa: Option<Summary>,
    /// Error of its component up, deg.
    pub aoa_up: Option<Summary>,
    /// Error of its component right, deg.
    pub aoa_right: Option<Summary>,
}

/// The world-frame errors of `rows` on `clip`; None where the clip has no mount columns or no
/// row states a world pose.
pub fn evaluate(clip: &Clip, rows: &[ResultRow]) -> Option<WorldEvaluation> {
    if !clip.has_mount {
        return None;
    }
    let station = clip.station();
    let by_frame: HashMap<u64, &ResultRow> = rows
        .iter()
        .filter_map(|r| r.frame.map(|f| (f, r)))
        .collect();
    let (mut az, mut el, mut origin) = (Vec::new(), Vec::new(), Vec::new());
    let (mut aoa, mut aoa_up, mut aoa_right) = (Vec::new(), Vec::new(), Vec::new());
    for frame in clip.frames.iter().filter_map(|f| f.as_ref().ok()) {
        let (Some(truth), Some(mount), Some(row)) =
            (frame.truth, frame.mount, by_frame.get(&frame.frame))
        else {
            continue;
        };
        let (Some(nose_az), Some(nose_el), Some(e), Some(n), Some(u)) =
            (row.nose_az_deg, row.nose_el_deg, row.e_m, row.n_m, row.u_m)
        else {
            continue;
        };
        if !(row.is_ok() && truth.tz_m > 0.0) {
            continue;
        }
        let true_pose = Pose {
            tx_m: truth.tx_m as f32,
            ty_m: truth.ty_m as f32,
            tz_m: truth.tz_m as f32,
            pitch_deg: truth.pitch_deg as f32,
            yaw_deg: truth.yaw_deg as f32,
        };
        let expected = WorldPose::of(&true_pose, &mount, &station);
        let km = truth.tz_m / 1000.0;
        az.push(wrap_deg(nose_az - expected.nose_az_deg).abs() / km);
        el.push((nose_el - expected.nose_el_deg).abs() / km);
        let [te, tn, tu] = expected.origin_enu_m;
        origin.push(((e - te).powi(2) + (n - tn).powi(2) + (u - tu).powi(2)).sqrt() / km);
        if let (Some(truth), Some(total), Some(up), Some(right)) = (
            frame.truth_aoa,
            row.aoa_deg,
            row.aoa_up_deg,
            row.aoa_right_deg,
        ) {
            aoa.push((total - truth.total_deg).abs());
            aoa_up.push((up - truth.up_deg).abs());
            aoa_right.push((right - truth.right_deg).abs());
        }
    }
    (!az.is_empty()).then(|| WorldEvaluation {
        frames: az.len(),
        nose_az: summarize(&az),
        nose_el: summarize(&el),
        origin: summarize(&origin),
        frames_with_aoa: aoa.len(),
        aoa: summarize(&aoa),
        aoa_up: summarize(&aoa_up),
        aoa_right: summarize(&aoa_right),
    })
}
