//! Detection in clutter (issue 14): the bundled clutter clips rendered by the simulator's
//! clutter physics (`fixtures/small-clutter-*`, `docs/simulator.md`). With the range known,
//! both hold the pose targets (95 % of frames, pitch 0.5 and chosen yaw 4 deg/km); the
//! other tests hold what detection achieves today, so that it does not slip back.

use imade_host::eval::paper::Parameter;
use imade_host::eval::pose_errors::FrameErrors;
use imade_host::eval::stats::summarize;
use imade_host::run::{PolarityArg, RangeArg};
use imade_host::sim::scenario::Weather;
use imade_host::sim::{Scenario, Simulation};
use std::path::Path;

/// Renders `scenario` into the clip folder `clip` (two threads).
fn simulate(scenario: Scenario, clip: &Path) {
    Simulation::new(scenario)
        .and_then(|s| s.write_clip(clip, 2))
        .unwrap_or_else(|e| panic!("{}: {e:#}", clip.display()));
}

/// The evaluation of the bundled clip `name` run with `range`: frames with a pose, median
/// pitch and chosen yaw errors (deg/km), median IoU of the blind mask.
fn run_clutter_clip(name: &str, range: RangeArg) -> (usize, f64, f64, f64) {
    let clip = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../fixtures")
        .join(name);
    let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("{name}-{range:?}"));
    let _ = std::fs::remove_dir_all(&out);
    let evaluation = imade_tests::run_and_evaluate(&clip, "bundled", range, true, &out);
    let median = |p| evaluation.pose.stats(p).map_or(f64::NAN, |s| s.median);
    let (pitch, yaw) = (median(Parameter::Pitch), median(Parameter::Yaw));
    let iou = evaluation
        .segmentation
        .iter()
        .find(|s| s.folder == imade_host::stages::MASKS_FOLDER)
        .and_then(|s| s.stats)
        .map_or(f64::NAN, |s| s.median);
    let poses = evaluation.pose.frames_with_pose;
    println!(
        "{name}, range {range:?}: {poses}/20 poses, median pitch {pitch:.3}, chosen yaw {yaw:.2} deg/km, blind IoU {iou:.3}"
    );
    (poses, pitch, yaw, iou)
}

/// A dark body of 6.4 noise deviations with a bright plume, a hillside entering from the chip's
/// lower edge, cloud filaments and a second projectile: the candidate of the body's size, clear of
/// the edge and of the body's polarity, or the bar of the body's width where terrain took its
/// place, is the target (the terrain or the plume was before: no frame had a pose). Since the
/// sky is taken from above the terrain (`segment/terrain.rs`), the terrain stands out whole from
/// the lower edge and its ridge is no candidate: 18 -> 20 frames with a pose, blind IoU 0.74 ->
/// 0.79, pitch 0.28 -> 0.29 deg/km (0.36 at 9b6f9d8; 0.31 since the grey-level fit takes the body
/// as opaque over a sky it fits in bins along it, where the sky beside it is cluttered; 0.27,
/// chosen yaw 3.7 -> 2.3, since its tilt is drawn to the velocity's there).
#[test]
fn terrain_and_a_plume_do_not_take_the_bodys_place() {
    let (poses, pitch, yaw, iou) = run_clutter_clip("small-clutter-terrain", RangeArg::Auto);
    assert!(poses >= 19, "{poses} of 20 frames with a pose");
    assert!(iou >= 0.75, "median IoU of the blind mask {iou}");
    assert!(pitch <= 0.3, "median pitch error {pitch} deg/km");
    assert!(yaw <= 3.0, "median chosen yaw error {yaw} deg/km");
}

/// The same clip without the range: the terrain reaching the chip's edge is no candidate, and
/// the bar search runs beside it at the sizes tried. Before, the terrain was the target in every
/// frame and no frame had a pose (its mask reached the edge); at d3adc9f 18 of 20 did, the
/// body's mask at a median IoU of 0.74, pitch 1.65 deg/km, Tz 52 m/km. Since the terrain stands
/// out whole (d1e5118) the first frame's target is a cloud band, and its image range, a quarter
/// short, had carried the motion model's range, and the body's size detection expects from it,
/// away for the frames after (11 frames with a pose; 16 once a prediction no longer carried on
/// through frames without a pose, IoU 0.53, pitch 9.1). Now the range is predicted only from
/// ranges that scatter by at most 8 % (`temporal.max_predicted_scatter`), and else the sizes are
/// tried: 20 frames have a pose, IoU 0.79, but pitch 5.6 deg/km and Tz 241 m/km (the range read
/// from the image in clutter is issue 15's).
#[test]
fn terrain_is_no_candidate_without_a_range_either() {
    let (poses, _, _, iou) = run_clutter_clip("small-clutter-terrain", RangeArg::Ignore);
    assert!(poses >= 19, "{poses} of 20 frames with a pose");
    assert!(iou >= 0.7, "median IoU of the blind mask {iou}");
}

/// A faint dark body (3-5 noise deviations a pixel) with a bright plume over its tail far
/// brighter than the body is dark, crossed by dark cloud filaments as dark as itself, under
/// banded cloud: the bar of the body's width and length, with the plume at an end, is the
/// target, the sky along it is the corridor's, and its cross-sections keep the diameter the
/// range gives. Before, the plume or a cloud patch was taken in every frame (median IoU 0, pitch
/// 21 deg/km).
///
/// Its attitude is judged over more frames (the next test): with a third of these 20 frames lost
/// to clutter, their median is a toss between the good frames and the bad (4.7 deg/km before
/// the plume's glow, the faded tail and the body past a filament were read, 11.3 after, 3.6
/// since the bar ending at the plume is a candidate and a bar's direction holds in clutter, 3.3
/// with the model reading the nose, 2.5 since the nose's ramp no longer extrapolates past the
/// model's nose, 1.4 since the width profile of a faint body in a cluttered sky sums only the
/// body's own width, 1.2 at 9b6f9d8, 0.70 since the grey-level fit takes the body as opaque over
/// a sky it fits in bins along it, 0.48 since it also starts at the velocity's tilt, 0.46 since
/// its tilt is drawn to the velocity's; the same scene over 120 frames went from 4.7 to 1.2 to
/// 0.33 to 0.26 to 0.22). The chosen yaw, near broadside here (a pixel of length is several
/// degrees of tilt), went from 13 at 9b6f9d8 to 6.4 to 3.1 deg/km with the velocity's tilt. The
/// blind mask's median IoU went from 0.41 to 0.49.
#[test]
fn a_faint_body_is_found_beside_its_plume_and_filaments() {
    let (poses, pitch, yaw, iou) = run_clutter_clip("small-clutter-plume", RangeArg::Auto);
    assert!(poses >= 19, "{poses} of 20 frames with a pose");
    assert!(iou >= 0.45, "median IoU of the blind mask {iou}");
    assert!(pitch <= 0.5, "median pitch error {pitch} deg/km");
    assert!(yaw <= 4.0, "median chosen yaw error {yaw} deg/km");
}

/// The scene of `fixtures/small-clutter-plume` drawn at three other seeds (its physics drawn
/// again: contrast 3-5 noise sigmas, blur 0.5-1.5 px, the plume's brightness and size, the
/// filaments), 40 frames each, with the range; `clear`: without cloud or filaments. The
/// errors of the frames with a pose, pooled, and how many frames have truth.
fn faint_body_frames(clear: bool) -> (Vec<FrameErrors>, usize) {
    let scene = if clear { "clear" } else { "clutter" };
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("faint-body-{scene}"));
    let _ = std::fs::remove_dir_all(&dir);
    let file =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/small-clutter-plume/scenario.toml");
    let (mut frames, mut with_truth) = (Vec::new(), 0);
    for seed in [11, 12, 13] {
        let mut scenario = Scenario::from_file(&file).expect("the scenario");
        scenario.seed = seed;
        scenario.clip.frames = 40;
        if clear {
            scenario.scene.weather = Weather::Clear;
            scenario.scene.cloud_cover = 0.0;
            scenario.filaments.count = 0;
            scenario.randomize.filament_count = Some([0, 0]);
        }
        let clip = dir.join(format!("seed-{seed}"));
        simulate(scenario, &clip);
        let out = dir.join(format!("run-{seed}"));
        let evaluation =
            imade_tests::run_and_evaluate(&clip, "bundled", RangeArg::Auto, false, &out);
        with_truth += evaluation.pose.frames_with_truth;
        frames.extend(evaluation.pose.frames);
    }
    (frames, with_truth)
}

/// The median of one error over `frames`.
fn median(frames: &[FrameErrors], error: fn(&FrameErrors) -> f64) -> f64 {
    let values: Vec<f64> = frames.iter().map(error).collect();
    summarize(&values).map_or(f64::NAN, |s| s.median)
}

/// A faint body under a plume over 120 frames: the plume marks the tail and its glow on the
/// tail is fitted, a tail faded against a dark sky is bridged to the plume, and the body is
/// followed past a filament crossing it and where a cloud behind it lowers its contrast; the bar
/// that ends at the plume is a candidate, a fragment gives way to the bar it lies on, and in
/// clutter the bar's direction holds the axis. Before, pitch 4.7 and chosen yaw 34 deg/km under
/// clutter (at 41d34c1 1.2 and 13; at 9b818f5 0.52 and 5.6; at 9b8cacd, the model reading the
/// nose of a body faded before its plume or run on along a filament, 0.46 and 4.5; now, the
/// nose's ramp held to the model's nose and a faint body's width profile summed over its own
/// width where the sky beside it is cluttered, 0.33 and 3.8; since the grey-level fit takes the
/// body as opaque over a sky it fits in bins along it, where the sky beside it is cluttered,
/// 0.26 and 2.8; since it also starts at the velocity's tilt, 0.22 and 2.2; since its tilt is
/// drawn to the velocity's, 0.20 and 1.3), 0.27 and 4.5 on a clear sky (then 0.10 and 1.5; at
/// 9b8cacd 0.10 and 1.1; at 9b6f9d8 0.11 and 0.94; now 0.10 and 0.97).
#[test]
fn a_faint_body_under_a_plume_keeps_its_attitude_over_three_seeds() {
    for (clear, max_pitch, max_yaw) in [(false, 0.25, 1.6), (true, 0.15, 1.5)] {
        let (frames, with_truth) = faint_body_frames(clear);
        let (pitch, yaw) = (median(&frames, |f| f.pitch), median(&frames, |f| f.yaw));
        println!(
            "clear {clear}: {} of {with_truth} frames with a pose, median pitch {pitch:.3}, chosen yaw {yaw:.2} deg/km",
            frames.len()
        );
        assert!(
            frames.len() * 100 >= 95 * with_truth,
            "{} of {with_truth}",
            frames.len()
        );
        assert!(
            pitch <= max_pitch,
            "clear {clear}: median pitch {pitch} deg/km"
        );
        assert!(
            yaw <= max_yaw,
            "clear {clear}: median chosen yaw {yaw} deg/km"
        );
    }
}

/// The scene of `fixtures/small-clutter-terrain` (terrain, a plume, filaments, a second
/// object) with the body brighter than the sky instead (a sunlit body), 20 frames with the
/// range, written to `clip`.
fn write_bright_body_clip(clip: &Path) {
    let file = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../fixtures/small-clutter-terrain/scenario.toml");
    let mut scenario = Scenario::from_file(&file).expect("the scenario");
    scenario.seed = 21;
    scenario.randomize.bright_body_probability = Some(1.0);
    simulate(scenario, clip);
}

/// `clip` run with the body's polarity `polarity` into `dir`: frames with a pose, median pitch
/// error.
fn run_with_polarity(clip: &Path, dir: &Path, polarity: PolarityArg) -> (usize, f64) {
    let out = dir.join(format!("run-{polarity:?}"));
    let args = imade_host::run::RunArgs {
        polarity,
        ..imade_tests::run_args(clip, RangeArg::Auto, &out)
    };
    let evaluation = imade_tests::evaluate_run(args);
    let pitch = evaluation
        .pose
        .stats(Parameter::Pitch)
        .map_or(f64::NAN, |s| s.median);
    let poses = evaluation.pose.frames_with_pose;
    println!("bright body, --polarity {polarity:?}: {poses}/20 poses, median pitch {pitch:.3}");
    (poses, pitch)
}

/// A bright body is found with `--polarity bright`; taken for a dark one (the default), the
/// second object or the cloud's shade is taken instead. Its pitch (2.8 deg/km, against 0.29 for
/// the dark body of the same scene) is not yet the dark body's: its bright plume, of the body's
/// own polarity, joins the body's mask and is read as its tail in about a third of the frames
/// (issue 14, the plume of either polarity).
#[test]
fn a_bright_body_is_found_when_its_polarity_is_given() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("bright-body");
    let _ = std::fs::remove_dir_all(&dir);
    let clip = dir.join("clip");
    write_bright_body_clip(&clip);
    let (poses, pitch) = run_with_polarity(&clip, &dir, PolarityArg::Bright);
    assert!(poses >= 18, "{poses} of 20 frames with a pose");
    assert!(pitch <= 4.0, "median pitch error {pitch} deg/km");
    let (poses, pitch) = run_with_polarity(&clip, &dir, PolarityArg::Dark);
    assert!(poses < 18 || pitch > 5.0, "{poses} poses, pitch {pitch}");
}

/// `imade simulate --preset clutter-random --seed 53` (30 frames): a dark body under a plume of
/// dark smoke, its own polarity, which joins its mask and tapers like a nose, so that the
/// image's ends were read the wrong way round in most frames (median pitch 35.6 deg/km, the
/// pitch's sign wrong). The clip carries the mount's pointing and the range: the velocity of
/// the frames before says which way the body flies across the chip, and a projectile flies
/// nose first (`world::Flight::in_chip`); the median pitch was then 8.4 deg/km (the smoke still
/// lengthens the tail in many frames), 2.2 once the grey-level fit took the body as opaque over
/// a sky fitted in bins along it (d0e84d2), and 3.5 since the fit also starts at the velocity's
/// tilt (its tail held where the smoke begins, which the smoke moves).
#[test]
fn the_flight_tells_the_nose_beside_a_plume_of_the_bodys_polarity() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("smoke-plume");
    let clip = dir.join("clip");
    let _ = std::fs::remove_dir_all(&dir);
    let mut scenario = imade_host::sim::presets::clutter_random(53);
    scenario.clip.frames = 30;
    simulate(scenario, &clip);
    let evaluation =
        imade_tests::run_and_evaluate(&clip, "bundled", RangeArg::Auto, false, &dir.join("run"));
    let pitch = evaluation
        .pose
        .stats(Parameter::Pitch)
        .map_or(f64::NAN, |s| s.median);
    println!(
        "smoke plume: {} poses, median pitch {pitch:.3} deg/km",
        evaluation.pose.frames_with_pose
    );
    assert!(evaluation.pose.frames_with_pose >= 28);
    assert!(pitch <= 12.0, "median pitch error {pitch} deg/km");
}

/// `imade simulate --preset clutter-terrain --seed S` (20 frames, S = 11, 12, 13), run without
/// the range: the image's ranges among the clutter are off by 5-25 %, and so is the velocity
/// that stands on them. Before the velocity was held to a sure range
/// (`WorldConfig::side_max_range_sd_fraction`) and the side to the measurement's reach
/// (`side_min_sigmas`), 5, 6 and 6 of the 10, 12 and 12 frames whose yaw side was reported
/// resolved were on the wrong side; now at most one a clip may be, and where some frames are
/// resolved most of them are right. The choice itself, resolved or not, is scored as before.
#[test]
fn without_a_range_among_clutter_a_resolved_side_is_the_right_one() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("clutter-side");
    let _ = std::fs::remove_dir_all(&dir);
    for seed in [11, 12, 13] {
        let mut scenario = imade_host::sim::presets::clutter_terrain(seed);
        scenario.clip.frames = 20;
        let clip = dir.join(format!("seed-{seed}"));
        simulate(scenario, &clip);
        let out = dir.join(format!("run-{seed}"));
        let pose =
            imade_tests::run_and_evaluate(&clip, "bundled", RangeArg::Ignore, false, &out).pose;
        let resolved = pose.frames.iter().filter(|f| f.yaw_resolved);
        let wrong = resolved.clone().filter(|f| !f.yaw_choice_correct).count();
        let count = resolved.count();
        println!("seed {seed}: {count} frames resolved, {wrong} on the wrong side");
        assert!(
            wrong <= 1,
            "seed {seed}: {wrong} of {count} resolved frames wrong"
        );
        assert!(
            count == 0 || 2 * wrong < count,
            "seed {seed}: {wrong} of {count}"
        );
    }
}

/// With the range among clutter, a fifth to a third of the frames had their attitude off by 10
/// to 50 of its sigmas: a filament or the plume taken into the silhouette. Such a frame's nose
/// lies far from the velocity the sensor's positions give (a projectile flies within a few
/// degrees of it), and its angle sigmas now cover the excess (`WorldConfig::max_aoa_deg`). The
/// two bundled clutter clips and two simulated ones (one whose detection takes a crossing
/// filament, one with a faint body beside its plume), before -> after, pitch / yaw within two
/// sigmas: small-clutter-plume 75 / 70 -> 85 / 80 %, small-clutter-terrain 85 / 80 -> 95 / 90 %,
/// clutter-random seed 12 6 / 17 -> 89 / 94 %, clutter-faint-plume seed 15 60 / 60 -> 95 / 95 %.
#[test]
fn with_a_range_among_clutter_the_angle_sigmas_cover_the_failed_frames() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("clutter-sigmas");
    let _ = std::fs::remove_dir_all(&dir);
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures");
    let mut clips = vec![
        fixtures.join("small-clutter-plume"),
        fixtures.join("small-clutter-terrain"),
    ];
    for (name, mut scenario) in [
        ("random-12", imade_host::sim::presets::clutter_random(12)),
        (
            "faint-plume-15",
            imade_host::sim::presets::clutter_faint_plume(15),
        ),
    ] {
        scenario.clip.frames = 20;
        let clip = dir.join(name);
        simulate(scenario, &clip);
        clips.push(clip);
    }
    for (k, clip) in clips.iter().enumerate() {
        let out = dir.join(format!("run-{k}"));
        let pose = imade_tests::run_and_evaluate(clip, "bundled", RangeArg::Auto, false, &out).pose;
        let (pitch, yaw) = (
            pose.pitch_within_two_sd.unwrap_or(0.0),
            pose.yaw_within_two_sd.unwrap_or(0.0),
        );
        println!(
            "{}: pitch {:.0} %, yaw {:.0} % within two sigmas",
            clip.display(),
            100.0 * pitch,
            100.0 * yaw
        );
        assert!(
            pitch >= 0.8 && yaw >= 0.8,
            "{}: pitch {pitch}, yaw {yaw} within two sigmas",
            clip.display()
        );
    }
}

/// Without a range, among clutter, a frame's sigmas count what the filters do not know: the image
/// range's systematic error there (`UncertaintyConfig::cluttered_range_fraction`, 20 % of the
/// range) and, for the angles, the silhouette's own scale's disagreement with the range taken
/// (a filament along the body misreads its length or its diameter by about that fraction).
/// The bundled clutter clips without their range, Tz / pitch / yaw within two sigmas, before ->
/// after: small-clutter-plume 80 / 75 / 55 -> 95 / 90 / 80 %, small-clutter-terrain 80 / 75 / 65
/// -> 100 / 80 / 80 %; their poses are unchanged.
#[test]
fn without_a_range_among_clutter_the_sigmas_count_the_image_ranges_error() {
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures");
    for clip in ["small-clutter-plume", "small-clutter-terrain"] {
        let out =
            Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("sigmas-without-range-{clip}"));
        let _ = std::fs::remove_dir_all(&out);
        let pose = imade_tests::run_and_evaluate(
            &fixtures.join(clip),
            "bundled",
            RangeArg::Ignore,
            false,
            &out,
        )
        .pose;
        let within = [
            ("Tz", pose.tz_within_two_sd),
            ("pitch", pose.pitch_within_two_sd),
            ("yaw", pose.yaw_within_two_sd),
        ];
        println!("{clip}: {within:?} within two sigmas");
        for (name, share) in within {
            let share = share.expect("sigmas in every ok row");
            assert!(share >= 0.8, "{clip}: {name} within two sigmas in {share}");
        }
    }
}

/// Without its range, small-clutter-plume's flight filter starts afresh from two image ranges
/// 606 and 1064 m (the body flew at 1068 and 1063: among clutter they scatter by 25 %), and at
/// the next frame, 78, the young flight ran off to 201 +- 17 m where the body flew at 1060 and
/// the range filter read 1054 +- 135: that frame's Tz was 81 % short. A flight that has corrected
/// fewer than five frames now speaks for a frame only where it agrees with the range filter
/// (`FlightFilterConfig::young_gate_sigmas`): frame 78 within 1 %, and the clip's median Tz
/// error 63 -> 44 m/km.
#[test]
fn without_a_range_a_young_flight_that_runs_off_is_not_the_frames_range() {
    let clip = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/small-clutter-plume");
    let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("young-flight");
    let _ = std::fs::remove_dir_all(&out);
    let pose = imade_tests::run_and_evaluate(&clip, "bundled", RangeArg::Ignore, false, &out).pose;
    let frame = pose
        .frames
        .iter()
        .find(|f| f.frame == 78)
        .expect("frame 78 has a pose");
    assert!(frame.tz.abs() < 10.0, "frame 78: Tz {} m/km off", frame.tz);
    let tz = median(&pose.frames, |f| f.tz.abs());
    assert!(tz < 50.0, "median Tz error {tz} m/km");
}
