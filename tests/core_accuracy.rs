//! The core against the independent ray-casting renderer: chips rendered from known poses are
//! estimated back, and the errors, normalized to 1 km as in `docs/geometry.md`, are bounded. Run
//! with `--nocapture` to see the error table of the pose grid.

use imade_core::lut::table::Table;
use imade_core::{ChipView, pose::wrap_deg};
use imade_core::{Config, FrameInput, Pipeline, Status};
use imade_tests::render::{ChipStyle, Rng, TruePose, chip_u8, project};
use imade_tests::{TELESCOPE, bundled_table, core_camera};
use proptest::prelude::*;

const STYLE: ChipStyle = ChipStyle {
    sky: 170.0,
    body: 60.0,
    gradient: (0.05, -0.03),
    psf_sigma: 0.8,
    noise: 2.0,
};

const CHIP: usize = 256;

/// A pose at slant range `range` whose body origin images at full-frame pixel `at`.
fn pose_at(range: f64, at: (f64, f64), pitch: f64, yaw: f64, roll: f64) -> TruePose {
    let ray = [
        (at.0 - TELESCOPE.cx) / TELESCOPE.fx,
        (at.1 - TELESCOPE.cy) / TELESCOPE.fy,
        1.0,
    ];
    let norm = (ray[0] * ray[0] + ray[1] * ray[1] + 1.0).sqrt();
    TruePose {
        t: ray.map(|c| range * c / norm),
        pitch_deg: pitch,
        yaw_deg: yaw,
        roll_deg: roll,
    }
}

/// Errors of one frame, normalized to 1 km.
#[derive(Debug, Clone, Copy)]
struct Errors {
    tx: f64,
    ty: f64,
    tz: f64,
    pitch: f64,
    yaw_best: f64,
}

fn angle_error(a: f64, b: f64) -> f64 {
    wrap_deg((a - b) as f32).abs() as f64
}

/// Renders the pose into a chip whose origin is offset from the target by `jitter` px, runs a
/// fresh pipeline on it (with the table match where `table` is given) and returns the normalized
/// errors.
fn estimate(
    truth: &TruePose,
    jitter: (i64, i64),
    range_known: bool,
    seed: u64,
    table: Option<Table<'static>>,
) -> Option<Errors> {
    let (u, v) = project(&TELESCOPE, truth, [0.0; 3]);
    let origin = (
        u.round() as i64 - CHIP as i64 / 2 + jitter.0,
        v.round() as i64 - CHIP as i64 / 2 + jitter.1,
    );
    let (pixels, _) = chip_u8(
        &TELESCOPE,
        truth,
        origin,
        (CHIP, CHIP),
        &STYLE,
        &mut Rng(seed),
    );
    let chip = ChipView::gray8(&pixels, CHIP, CHIP, CHIP, origin.0 as i32, origin.1 as i32).ok()?;
    let pipeline: Pipeline = Pipeline::new(
        Config::DEFAULT,
        core_camera(&TELESCOPE),
        imade_tests::reference_model(),
    );
    let mut pipeline = match table {
        Some(t) => pipeline.with_table(t),
        None => pipeline,
    };
    let range = truth.t.iter().map(|c| c * c).sum::<f64>().sqrt();
    let result = pipeline.process(&FrameInput {
        chip,
        time_s: 0.0,
        range_m: range_known.then_some(range as f32),
        mount: None,
    });
    if result.status != Status::Ok {
        return None;
    }
    let per_km = truth.t[2] / 1000.0;
    let p = result.pose;
    Some(Errors {
        tx: (p.tx_m as f64 - truth.t[0]).abs() / per_km,
        ty: (p.ty_m as f64 - truth.t[1]).abs() / per_km,
        tz: (p.tz_m as f64 - truth.t[2]).abs() / per_km,
        pitch: angle_error(p.pitch_deg as f64, truth.pitch_deg) / per_km,
        yaw_best: angle_error(p.yaw_deg as f64, truth.yaw_deg)
            .min(angle_error(result.yaw_alt_deg as f64, truth.yaw_deg))
            / per_km,
    })
}

fn median_and_max(mut v: Vec<f64>) -> (f64, f64) {
    v.sort_by(f64::total_cmp);
    (v[v.len() / 2], v[v.len() - 1])
}

/// The renderer itself reproduces the spec's test vector (so the truth it gives is the spec's).
#[test]
fn renderer_matches_the_spec_test_vector() {
    let pose = TruePose {
        t: [3.0, -2.0, 1500.0],
        pitch_deg: 30.0,
        yaw_deg: -60.0,
        roll_deg: 20.0,
    };
    for (b, (u, v)) in [
        ([0.689, 0.0, 0.0], (1189.017, 867.231)),
        ([-0.689, 0.0, 0.0], (1257.997, 913.111)),
        ([0.0, 0.0, 0.0], (1223.500, 890.167)),
        ([-0.689, 0.0, 0.1], (1254.144, 918.537)),
    ] {
        let (pu, pv) = project(&TELESCOPE, &pose, b);
        assert!(
            (pu - u).abs() < 1e-3 && (pv - v).abs() < 1e-3,
            "{b:?}: ({pu}, {pv})"
        );
    }
}

/// The pose grid of the foundation issue: 1 to 2 km, fx = 100000 px, pitch and yaw over their
/// ranges, the target off the chip centre and the chip off the optical centre.
/// Errors over the pose grid with unknown and with known range, and the frames without a pose.
fn grid(table: Option<Table<'static>>) -> (Vec<Errors>, Vec<Errors>, usize) {
    let mut unknown = Vec::new();
    let mut known = Vec::new();
    let mut failures = 0;
    let mut seed = 1u64;
    for range in [1000.0, 1500.0, 2000.0] {
        for pitch in [-40.0, -15.0, 5.0, 25.0, 50.0] {
            for yaw in [-150.0, -120.0, -80.0, -45.0, 30.0, 65.0, 100.0, 135.0] {
                seed += 1;
                let at = (
                    1023.5 + 600.0 * ((seed % 7) as f64 / 3.0 - 1.0),
                    1023.5 - 500.0 * ((seed % 5) as f64 / 2.0 - 1.0),
                );
                let truth = pose_at(range, at, pitch, yaw, 17.0 * seed as f64);
                let jitter = ((seed % 41) as i64 - 20, (seed % 29) as i64 - 14);
                match (
                    estimate(&truth, jitter, false, seed, table),
                    estimate(&truth, jitter, true, seed, table),
                ) {
                    (Some(u), Some(k)) => {
                        unknown.push(u);
                        known.push(k);
                    }
                    _ => failures += 1,
                }
            }
        }
    }
    (unknown, known, failures)
}

type Rows = [(&'static str, (f64, f64)); 5];

/// Prints the median and worst of each error and returns them.
fn report(name: &str, e: &[Errors]) -> Rows {
    let col = |f: fn(&Errors) -> f64| median_and_max(e.iter().map(f).collect());
    let rows = [
        ("Tx m/km", col(|e| e.tx)),
        ("Ty m/km", col(|e| e.ty)),
        ("Tz m/km", col(|e| e.tz)),
        ("pitch deg/km", col(|e| e.pitch)),
        ("yaw (best of two) deg/km", col(|e| e.yaw_best)),
    ];
    println!("{name} ({} frames): median / worst", e.len());
    for (label, (median, worst)) in rows {
        println!("  {label:28} {median:8.3} {worst:9.3}");
    }
    rows
}

/// The pose grid of the foundation issue: 1 to 2 km, fx = 100000 px, pitch and yaw over their
/// ranges, the target off the chip centre and the chip off the optical centre.
#[test]
fn closed_form_over_a_pose_grid() {
    let (unknown, known, failures) = grid(None);
    let u = report("unknown range (Tz from the diameter)", &unknown);
    let k = report("known range", &known);
    println!("failed frames: {failures}");
    assert_eq!(failures, 0, "every grid frame gives a pose");
    // Bounds well inside the source paper's (Tz 50 m/km, pitch 6 deg/km with unknown range;
    // in-plane 0.15 m/km, pitch 3 deg/km, yaw 20 deg/km with known range).
    let (tz, pitch_u, yaw_u) = (u[2].1, u[3].1, u[4].1);
    assert!(tz.0 < 15.0 && tz.1 < 60.0, "Tz from the diameter: {tz:?}");
    assert!(
        pitch_u.0 < 0.5 && pitch_u.1 < 3.0,
        "pitch, unknown range: {pitch_u:?}"
    );
    assert!(yaw_u.0 < 5.0, "yaw, unknown range: {yaw_u:?}");
    let (tx, ty, pitch_k, yaw_k) = (k[0].1, k[1].1, k[3].1, k[4].1);
    assert!(tx.0 < 0.05 && ty.0 < 0.05, "in-plane: {tx:?} {ty:?}");
    assert!(
        pitch_k.0 < 0.5 && pitch_k.1 < 3.0,
        "pitch, known range: {pitch_k:?}"
    );
    assert!(yaw_k.0 < 3.0, "yaw, known range: {yaw_k:?}");
}

/// The same grid through the table match: every frame matched, and the bounds of the table
/// issue (its targets on Tz, pitch and yaw, per km) met on the renderer's uniform-body chips.
#[test]
fn table_match_over_a_pose_grid() {
    let (unknown, known, failures) = grid(Some(bundled_table()));
    let u = report("table match, unknown range", &unknown);
    let k = report("table match, known range", &known);
    println!("failed frames: {failures}");
    assert_eq!(failures, 0, "every grid frame gives a pose");
    let (tz, pitch_u, yaw_u) = (u[2].1, u[3].1, u[4].1);
    // The worst frame (about 180 m/km) is a broken shading fit on a 4-px-wide body at 2 km.
    assert!(tz.0 < 5.0 && tz.1 < 250.0, "Tz: {tz:?}");
    assert!(pitch_u.0 < 0.5, "pitch, unknown range: {pitch_u:?}");
    assert!(yaw_u.0 < 6.0, "yaw, unknown range: {yaw_u:?}");
    let (tx, ty, pitch_k, yaw_k) = (k[0].1, k[1].1, k[3].1, k[4].1);
    assert!(tx.0 < 0.01 && ty.0 < 0.01, "in-plane: {tx:?} {ty:?}");
    assert!(pitch_k.0 < 0.5, "pitch, known range: {pitch_k:?}");
    assert!(yaw_k.0 < 4.0, "yaw, known range: {yaw_k:?}");
}

proptest! {
    #![proptest_config(imade_tests::proptest_config(24))]

    /// Random poses at 1-2 km away from the degenerate nose-on and tail-on views.
    #[test]
    fn random_poses_are_estimated_back(
        range in 1000.0f64..2000.0,
        pitch in -60.0f64..60.0,
        yaw_side in prop::bool::ANY,
        yaw_mag in 25.0f64..155.0,
        roll in 0.0f64..360.0,
        u in 500.0f64..1550.0,
        v in 500.0f64..1550.0,
        jx in -30i64..30,
        jy in -30i64..30,
        seed in 0u64..1000,
    ) {
        let yaw = if yaw_side { yaw_mag } else { -yaw_mag };
        let truth = pose_at(range, (u, v), pitch, yaw, roll);
        let e = estimate(&truth, (jx, jy), true, seed, None);
        prop_assert!(e.is_some(), "no pose");
        let e = e.unwrap();
        prop_assert!(e.pitch < 3.0, "pitch error {} deg/km", e.pitch);
        prop_assert!(e.yaw_best < 15.0, "yaw error {} deg/km", e.yaw_best);
        prop_assert!(e.tx < 0.1 && e.ty < 0.1, "in-plane {} {} m/km", e.tx, e.ty);
    }
}

/// A case proptest found: broadside, 7 degrees pitch, the nose 29 px from the chip's edge. The
/// body is detected whole, but its own bar reaches too near the edge; a piece of it (the fins)
/// used to win the bar search, and pitch was 6 to 7 deg/km off on three noise seeds of five.
#[test]
fn a_broadside_body_near_the_chip_edge_is_taken_whole() {
    let truth = pose_at(1002.45, (1281.02, 729.58), -7.412, 90.018, 0.0);
    for seed in [219, 3, 4] {
        let e = estimate(&truth, (-30, 21), true, seed, None).expect("a pose");
        assert!(
            e.pitch < 0.5 && e.yaw_best < 3.0 && e.ty < 0.01,
            "seed {seed}: {e:?}"
        );
    }
}
