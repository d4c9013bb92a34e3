//! Detection in clutter (issue 14, in progress): the bundled clutter clips rendered by the
//! simulator's clutter physics (`fixtures/small-clutter-*`, `docs/simulator.md`). These tests
//! hold what detection achieves today, so that it does not slip back; the issue's own targets
//! (95 % of frames, mask IoU 0.85, pitch 0.5 and chosen yaw 4 deg/km) are not met yet.

use imade_host::eval::paper::Parameter;
use imade_host::run::RangeArg;
use std::path::Path;

/// The evaluation of the bundled clip `name` run with its range: frames with a pose, median
/// pitch error (deg/km), median IoU of the blind mask.
fn run_clutter_clip(name: &str) -> (usize, f64, f64) {
    let clip = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../fixtures")
        .join(name);
    let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&out);
    let evaluation = imade_tests::run_and_evaluate(&clip, "bundled", RangeArg::Auto, true, &out);
    let pitch = evaluation
        .pose
        .stats(Parameter::Pitch)
        .map_or(f64::NAN, |s| s.median);
    let iou = evaluation
        .segmentation
        .iter()
        .find(|s| s.folder == imade_host::stages::MASKS_FOLDER)
        .and_then(|s| s.stats)
        .map_or(f64::NAN, |s| s.median);
    let poses = evaluation.pose.frames_with_pose;
    println!("{name}: {poses}/20 poses, median pitch {pitch:.3} deg/km, blind IoU {iou:.3}");
    (poses, pitch, iou)
}

/// A dark body of 6.4 noise deviations with a bright plume, a hillside entering from the chip's
/// lower edge, cloud filaments and a second projectile: the candidate of the body's size, clear of
/// the edge and of the body's polarity, or the bar of the body's width where terrain took its
/// place, is the target (the terrain or the plume was before: no frame had a pose).
#[test]
fn terrain_and_a_plume_do_not_take_the_bodys_place() {
    let (poses, pitch, iou) = run_clutter_clip("small-clutter-terrain");
    assert!(poses >= 18, "{poses} of 20 frames with a pose");
    assert!(iou >= 0.6, "median IoU of the blind mask {iou}");
    assert!(pitch <= 2.0, "median pitch error {pitch} deg/km");
}

/// A faint dark body (3-5 noise deviations a pixel) with a bright plume over its tail far
/// brighter than the body is dark, crossed by dark cloud filaments as dark as itself, under
/// banded cloud: the bar of the body's width and length, with the plume at an end, is the
/// target, the sky along it is the corridor's, and its cross-sections keep the diameter the
/// range gives. Before, the plume or a cloud patch was taken in every frame (median IoU 0, pitch
/// 21 deg/km).
#[test]
fn a_faint_body_is_found_beside_its_plume_and_filaments() {
    let (poses, pitch, iou) = run_clutter_clip("small-clutter-plume");
    assert!(poses >= 18, "{poses} of 20 frames with a pose");
    assert!(iou >= 0.3, "median IoU of the blind mask {iou}");
    assert!(pitch <= 10.0, "median pitch error {pitch} deg/km");
}
