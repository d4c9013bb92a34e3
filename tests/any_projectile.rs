//! Any projectile, end to end: a mesh becomes a model file (`imade model build --mesh`: profile
//! and fins derived from the mesh, silhouette table built from it), and `imade run --lut FILE`
//! estimates a clip with it. The mesh here is the reference projectile's tessellation, so its
//! run is compared with the run of the bundled model, which was made from the analytic shape.

use imade_host::eval::paper::Parameter;
use imade_host::run::RangeArg;
use imade_host::sim::model::REF_1378X80;
use std::path::{Path, PathBuf};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../fixtures")
        .join(name)
}

/// Errors per km of a run of `clip` with the model choice `lut`.
struct Errors {
    /// Medians: Tx, Tz (m/km), pitch, best yaw (deg/km).
    medians: [f64; 4],
    /// 90th percentile of the pitch error, deg/km.
    pitch_p90: f64,
    /// Frames with a pose.
    poses: usize,
}

/// The errors per km of a run of `clip` with the model choice `lut`.
fn errors(clip: &Path, lut: &str, range: RangeArg, out: &Path) -> Errors {
    let evaluation = imade_tests::run_and_evaluate(clip, lut, range, false, out);
    let stats = |p: Parameter| evaluation.pose.stats(p);
    let median = |p: Parameter| stats(p).map_or(f64::NAN, |s| s.median);
    Errors {
        medians: [
            median(Parameter::Tx),
            median(Parameter::Tz),
            median(Parameter::Pitch),
            median(Parameter::YawBest),
        ],
        pitch_p90: stats(Parameter::Pitch).map_or(f64::NAN, |s| s.p90),
        poses: evaluation.pose.frames_with_pose,
    }
}

#[test]
fn a_model_built_from_a_mesh_runs_a_clip_like_the_bundled_one() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("any-projectile");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let mesh = dir.join("ref-1378x80.obj");
    std::fs::write(&mesh, REF_1378X80.tessellate().to_obj()).unwrap();
    let model = imade_tests::model_from_mesh(&mesh, "ref-1378x80", 0.08, &dir);
    for (clip, range) in [
        ("small-known-range", RangeArg::Auto),
        ("small-unknown-range", RangeArg::Ignore),
    ] {
        let clip = fixture(clip);
        let bundled = errors(&clip, "bundled", range, &dir.join("bundled"));
        let meshed = errors(&clip, model.to_str().unwrap(), range, &dir.join("meshed"));
        let (bundled_poses, meshed_poses) = (bundled.poses, meshed.poses);
        let (bundled, meshed) = (bundled.medians, meshed.medians);
        println!(
            "{}: bundled model Tx {:.4} Tz {:.2} m/km pitch {:.3} yaw {:.2} deg/km ({bundled_poses} poses); \
             from the mesh Tx {:.4} Tz {:.2} m/km pitch {:.3} yaw {:.2} deg/km ({meshed_poses} poses)",
            clip.display(),
            bundled[0],
            bundled[1],
            bundled[2],
            bundled[3],
            meshed[0],
            meshed[1],
            meshed[2],
            meshed[3]
        );
        assert!(
            meshed_poses * 100 >= bundled_poses * 95,
            "poses {meshed_poses} of {bundled_poses}"
        );
        // Within 20 % of the bundled model's figure, or of a floor where both are tiny.
        let floors = [0.005, 0.5, 0.05, 0.5];
        for k in 0..4 {
            assert!(
                meshed[k] <= 1.2 * bundled[k] + floors[k],
                "error {k}: {} from the mesh, {} bundled",
                meshed[k],
                bundled[k]
            );
        }
    }
}

#[test]
fn a_model_file_for_another_projectile_is_refused() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("any-projectile-mismatch");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let model = dir.join("other.model");
    let bytes = imade_host::model::encode("other-1000x80", &imade_host::model::reference(), None)
        .expect("encodes");
    std::fs::write(&model, bytes).unwrap();
    let error = imade_host::model::for_clip("ref-1378x80", Some(&model)).unwrap_err();
    assert!(
        format!("{error:#}").contains("the model file is for \"other-1000x80\""),
        "{error:#}"
    );
    let unknown = imade_host::model::for_clip("nope-1x1", None).unwrap_err();
    assert!(
        format!("{unknown:#}").contains("unknown projectile \"nope-1x1\""),
        "{unknown:#}"
    );
}

/// The three other shapes of the simulator (`imade_host::sim::shapes`): each one's bundled mesh
/// (`fixtures/meshes/`) becomes a model file, and its bundled clip (`fixtures/small-<id>`, the
/// scene of `small-known-range` with the focal length scaled so that the body spans as many
/// pixels) runs with and without the range: every frame has a pose, the nose is never taken for
/// the tail (the 90th percentile of the pitch error stays small), and the medians per km are
/// within the source paper's accuracy (Tx 0.15 m, Tz 50 m, pitch 3 deg with the range and 6
/// without, yaw 20 deg). Printed as the per-shape table beside the reference.
#[test]
fn other_shapes_run_from_their_meshes() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("other-shapes");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let reference = fixture("small-known-range");
    println!(
        "| shape | range | Tx m/km | Tz m/km | pitch deg/km | pitch p90 | best yaw deg/km | poses |"
    );
    let row = |id: &str, name: &str, e: &Errors| {
        let m = e.medians;
        println!(
            "| {id} | {name} | {:.4} | {:.2} | {:.3} | {:.3} | {:.2} | {}/20 |",
            m[0], m[1], m[2], e.pitch_p90, m[3], e.poses
        );
    };
    for (range, name) in [(RangeArg::Auto, "known"), (RangeArg::Ignore, "unknown")] {
        let e = errors(
            &reference,
            "bundled",
            range,
            &dir.join(format!("ref-{name}")),
        );
        row("ref-1378x80", name, &e);
    }
    for id in imade_host::sim::shapes::IDS {
        let model = imade_tests::shape_model(&dir, id);
        let clip = fixture(&format!("small-{id}"));
        for (range, name) in [(RangeArg::Auto, "known"), (RangeArg::Ignore, "unknown")] {
            let e = errors(
                &clip,
                model.to_str().unwrap(),
                range,
                &dir.join(format!("{id}-{name}")),
            );
            row(id, name, &e);
            let m = e.medians;
            assert_eq!(e.poses, 20, "{id} {name}: frames with a pose");
            let pitch_bound = if range == RangeArg::Auto { 3.0 } else { 6.0 };
            assert!(
                m[0] <= 0.15 && m[1] <= 50.0,
                "{id} {name}: Tx {} Tz {}",
                m[0],
                m[1]
            );
            assert!(
                m[2] <= pitch_bound && e.pitch_p90 <= pitch_bound && m[3] <= 20.0,
                "{id} {name}: pitch {} (p90 {}) yaw {}",
                m[2],
                e.pitch_p90,
                m[3]
            );
        }
    }
}

/// The any-projectile accuracy claim, on clips long enough for medians to mean something: each
/// shape's scenario (`fixtures/scenarios/small-<id>.toml`, the scene of `small-known-range` with
/// the focal length scaled so that the body spans as many pixels) and the reference's, rendered
/// with 80 frames (every 2nd camera frame), run with and without the range: each shape's medians
/// per km are within 20 % of the reference's (or of a floor where both are tiny). The shell
/// without fins is gun-fired: it is compared on the scene without the exhaust plume, the
/// reference too, and also at the reference's own focal length (8-10 px across, where its scale
/// and its tail come from the outline alone). Under the rocket's plume (its bundled clip's
/// scene, a tracer's worst case) it is held within 2.5 times the reference's: that scene flies
/// within 8 deg of broadside in 37 of its 80 frames, where the plume's glow lies on the base
/// whose ellipse alone, with the length, shows a finless body's tilt (at 6 deg the shell's
/// length changes half as fast with the tilt as the reference's, 0.038 of itself per radian
/// against 0.076). Printed as the comparison table.
#[test]
fn other_shapes_match_the_reference_on_comparable_clips() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("comparable");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    // The scene of `name` with 80 frames, with or without its plume, at its own focal length or
    // at `fx` px.
    let render = |name: &str, scene: &str, plume: bool, fx: Option<f64>| {
        let file = fixture("scenarios").join(format!("small-{name}.toml"));
        let mut scenario = imade_host::sim::Scenario::from_file(&file).expect("the scenario");
        scenario.clip.frames = 80;
        scenario.clip.keep_every = 2;
        scenario.plume.enabled &= plume;
        if let Some(fx) = fx {
            (scenario.camera.fx, scenario.camera.fy) = (fx, fx);
        }
        let clip = dir.join(format!("{name}-{scene}"));
        imade_host::sim::Simulation::new(scenario)
            .and_then(|s| s.write_clip(&clip, 2))
            .unwrap_or_else(|e| panic!("{name}: {e:#}"));
        clip
    };
    let ranges = [(RangeArg::Auto, "known"), (RangeArg::Ignore, "unknown")];
    println!(
        "| shape | scene | range | Tx m/km | Tz m/km | pitch deg/km | best yaw deg/km | poses |"
    );
    let row = |id: &str, scene: &str, name: &str, e: &Errors| {
        let m = e.medians;
        println!(
            "| {id} | {scene} | {name} | {:.4} | {:.2} | {:.3} | {:.2} | {}/80 |",
            m[0], m[1], m[2], m[3], e.poses
        );
    };
    // The errors of `clip` run with the model choice `lut`, with and without the range.
    let run = |id: &str, scene: &str, clip: &Path, lut: &str| {
        ranges.map(|(range, name)| {
            let e = errors(clip, lut, range, &dir.join(format!("{id}-{scene}-{name}")));
            row(id, scene, name, &e);
            e
        })
    };
    let scene = |plume: bool| if plume { "plume" } else { "no plume" };
    let reference = [true, false].map(|plume| {
        run(
            "ref-1378x80",
            scene(plume),
            &render("known-range", scene(plume), plume, None),
            "bundled",
        )
    });
    // The reference's focal length.
    let reference_fx = 100_000.0;
    for id in imade_host::sim::shapes::IDS {
        let model = imade_tests::shape_model(&dir, id);
        let model = model.to_str().unwrap();
        let finned = imade_host::sim::shapes::description(id)
            .unwrap()
            .fins
            .is_some();
        // (scene, plume, focal length, the factor on the reference's error)
        let cases: &[(&str, bool, Option<f64>, f64)] = if finned {
            &[("plume", true, None, 1.2)]
        } else {
            &[
                ("no plume", false, None, 1.2),
                ("no plume, fx 100000", false, Some(reference_fx), 1.2),
                ("plume", true, None, 2.5),
            ]
        };
        for &(scene, plume, fx, factor) in cases {
            let errors = run(id, scene, &render(id, scene, plume, fx), model);
            let reference = &reference[usize::from(!plume)];
            for ((e, reference), (_, name)) in errors.iter().zip(reference).zip(ranges) {
                assert!(e.poses * 100 >= 95 * 80, "{id} {name}: {} poses", e.poses);
                let floors = [0.005, 0.5, 0.02, 0.2];
                for (k, floor) in floors.into_iter().enumerate() {
                    let (got, reference) = (e.medians[k], reference.medians[k]);
                    let bound = factor * reference + floor;
                    assert!(
                        got <= bound,
                        "{id} {scene} {name}: error {k} is {got}, the reference's {reference}, bound {bound}"
                    );
                }
            }
        }
    }
}
