//! Detection in clutter (issue 14, in progress): the bundled clutter clips rendered by the
//! simulator's clutter physics (`fixtures/small-clutter-*`, `docs/simulator.md`). These tests
//! hold what detection achieves today, so that it does not slip back; the issue's own targets
//! (95 % of frames, mask IoU 0.85, pitch 0.5 and chosen yaw 4 deg/km) are not met yet.

use imade_host::eval::paper::Parameter;
use imade_host::run::RangeArg;
use std::path::Path;

/// A dark body of 6.4 noise deviations with a bright plume, a hillside entering from the chip's
/// lower edge, cloud filaments and a second projectile: the candidate of the body's size, clear of
/// the edge and of the body's polarity, is the target (the terrain or the plume was before: no
/// frame had a pose).
#[test]
fn terrain_and_a_plume_do_not_take_the_bodys_place() {
    let clip = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/small-clutter-terrain");
    let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("clutter-terrain");
    let _ = std::fs::remove_dir_all(&out);
    let evaluation = imade_tests::run_and_evaluate(&clip, "bundled", RangeArg::Auto, true, &out);
    let poses = evaluation.pose.frames_with_pose;
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
    println!(
        "small-clutter-terrain: {poses}/20 poses, median pitch {pitch:.3} deg/km, blind IoU {iou:.3}"
    );
    assert!(poses >= 17, "{poses} of 20 frames with a pose");
    assert!(iou >= 0.4, "median IoU of the blind mask {iou}");
    assert!(pitch <= 3.0, "median pitch error {pitch} deg/km");
}
