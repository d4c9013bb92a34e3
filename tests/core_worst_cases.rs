//! Worst-case chips: each gives a defined status with a consistent result. Uniform, saturated
//! and pure-noise chips have no target; fine checkerboards overflow the run table and say so,
//! painting nothing; a projectile on a clipped sky, a clipped bright body, the largest chip and
//! the aimed one of two projectiles are measured; a body cut by the chip's border is refused.
//! (Their time per frame is benchmarked in tests/benches/worst_cases.rs.)
//!
//! The `#[ignore]`d tests state what the core does not do yet (found here, reported in
//! docs/benchmarks.md): a larger second projectile gives an ok status with a wrong pose. `cargo test -- --ignored` runs them.

use imade_core::segment::CapacityKind;
use imade_core::{
    BodyPolarity, ChipError, ChipView, Config, DetectConfig, FrameInput, FrameResult, Pipeline,
    Status,
};
use imade_tests::render::{
    ChipStyle, Rng, TruePose, blur, centred_origin, chip_u8, coverage, project,
};
use imade_tests::{TELESCOPE, core_camera};

fn pipeline(config: Config) -> Box<Pipeline> {
    Box::new(Pipeline::new(
        config,
        core_camera(&TELESCOPE),
        imade_tests::reference_model(),
    ))
}

/// Processes one 8-bit `side` x `side` chip (or a 16-bit one) with a fresh pipeline.
fn process(pipeline: &mut Pipeline, chip: ChipView, range_m: Option<f32>) -> FrameResult {
    let result = pipeline.process(&FrameInput {
        chip,
        time_s: 0.0,
        range_m,
        mount: None,
    });
    assert_consistent(pipeline, &chip, &result);
    result
}

/// A result agrees with itself: a capacity status names the capacity, a failed detection paints
/// nothing, an ok pose is finite with its angles in range, and the mask is the chip's size.
fn assert_consistent(pipeline: &Pipeline, chip: &ChipView, r: &FrameResult) {
    assert_eq!(r.status == Status::Capacity, r.capacity.is_some(), "{r:?}");
    let mask = pipeline.mask();
    if matches!(r.status, Status::NoTarget | Status::Capacity) {
        assert_eq!(mask.count(), 0, "{:?}: nothing painted", r.status);
    }
    if r.status == Status::Ok {
        assert!(r.is_finite(), "{r:?}");
        assert!((-90.0..=90.0).contains(&r.pose.pitch_deg), "{r:?}");
        assert!((-180.0..=180.0).contains(&r.pose.yaw_deg), "{r:?}");
        assert_eq!((mask.width(), mask.height()), (chip.width(), chip.height()));
        assert!(mask.count() > 0);
    }
}

fn gray8(pixels: &[u8], side: usize) -> ChipView<'_> {
    ChipView::gray8(pixels, side, side, side, 0, 0).unwrap()
}

fn pattern(side: usize, mut f: impl FnMut(usize, usize) -> u8) -> Vec<u8> {
    (0..side * side).map(|i| f(i % side, i / side)).collect()
}

#[test]
fn uniform_saturated_and_tiny_chips_have_no_target() {
    let mut p = pipeline(Config::DEFAULT);
    for level in [0u8, 1, 128, 254, 255] {
        let pixels = vec![level; 256 * 256];
        let r = process(&mut p, gray8(&pixels, 256), None);
        assert_eq!(r.status, Status::NoTarget, "uniform {level}");
    }
    for level in [0u16, 65535] {
        let pixels = vec![level; 512 * 512];
        let chip = ChipView::gray16(&pixels, 512, 512, 512, 0, 0).unwrap();
        assert_eq!(process(&mut p, chip, None).status, Status::NoTarget);
    }
    // Chips too small to hold a component of the minimum area (6 px).
    for (w, h) in [(1, 1), (2, 2), (1, 512), (512, 1), (5, 1)] {
        let pixels = pattern(512, |x, y| ((x * 37 + y * 91) % 251) as u8);
        let chip = ChipView::gray8(&pixels, w, h, 512, 0, 0).unwrap();
        assert_eq!(
            process(&mut p, chip, None).status,
            Status::NoTarget,
            "{w} x {h}"
        );
    }
}

/// Pure noise, of any amplitude up to the full range, holds no component that stands out of
/// it: the noise estimate follows the amplitude.
#[test]
fn noise_has_no_target() {
    let mut p = pipeline(Config::DEFAULT);
    let mut rng = Rng(17);
    for sigma in [1.0, 3.0, 10.0, 40.0] {
        let pixels = pattern(256, |_, _| (128.0 + sigma * rng.gaussian()).round() as u8);
        let r = process(&mut p, gray8(&pixels, 256), None);
        assert_eq!(r.status, Status::NoTarget, "Gaussian noise sigma {sigma}");
    }
    let uniform = pattern(256, |_, _| rng.next_u64() as u8);
    assert_eq!(
        process(&mut p, gray8(&uniform, 256), None).status,
        Status::NoTarget
    );
}

fn checkerboard(cell: usize, (a, b): (u8, u8)) -> Vec<u8> {
    pattern(256, |x, y| [a, b][(x / cell + y / cell) % 2])
}

/// A pixel checkerboard is all noise to the noise estimate: no target. Finer ones of high or
/// low contrast cut every row into runs: more than the run table holds (4096), said and
/// nothing painted.
#[test]
fn fine_checkerboards_have_no_target_or_overflow_the_runs() {
    let mut p = pipeline(Config::DEFAULT);
    for contrast in [(250, 5), (140, 110)] {
        let r = process(&mut p, gray8(&checkerboard(1, contrast), 256), None);
        assert_eq!(r.status, Status::NoTarget);
        for cell in [2usize, 3, 4, 5, 6, 7, 9, 10, 12] {
            let r = process(&mut p, gray8(&checkerboard(cell, contrast), 256), None);
            assert_eq!(r.capacity, Some(CapacityKind::Runs), "cell {cell}: {r:?}");
        }
    }
}

/// Coarse checkerboards hold no projectile: their diagonally joined cells make one component as
/// large as the chip, which reaches the chip's edge and so is no measurable body.
#[test]
fn coarse_checkerboards_give_no_pose() {
    let mut p = pipeline(Config::DEFAULT);
    for cell in [8usize, 16, 24, 32, 64, 128] {
        let r = process(&mut p, gray8(&checkerboard(cell, (250, 5)), 256), None);
        assert_ne!(r.status, Status::Ok, "cell {cell}: {r:?}");
    }
}

/// 70 dark 3 x 3 blobs, each a candidate of the minimum area: more components than the
/// selection holds (64).
#[test]
fn too_many_components_is_a_capacity_status() {
    let pixels = pattern(256, |x, y| {
        let blob = (y / 24) * 10 + x / 24 < 70 && x % 24 < 3 && y % 24 < 3;
        if blob { 20 } else { 200 }
    });
    let mut p = pipeline(Config::DEFAULT);
    let r = process(&mut p, gray8(&pixels, 256), None);
    assert_eq!(r.status, Status::Capacity);
    assert_eq!(r.capacity, Some(CapacityKind::Components));
}

/// A chip larger than the largest supported one is refused before the pipeline; the largest
/// one is processed.
#[test]
fn the_largest_chip_is_measured_and_a_larger_one_refused() {
    let pixels = vec![100u8; 513 * 513];
    assert_eq!(
        ChipView::gray8(&pixels, 513, 512, 513, 0, 0).err(),
        Some(ChipError::TooLarge)
    );
    let pose = TruePose {
        t: [0.0, 0.0, 700.0],
        pitch_deg: 10.0,
        yaw_deg: -60.0,
        roll_deg: 20.0,
    };
    let (pixels, _) = render(&pose, 512, &style(170.0, 60.0), 3);
    let mut p = pipeline(Config::DEFAULT);
    let r = process(&mut p, chip_of(&pixels, 512, &pose), Some(700.0));
    assert_eq!(r.status, Status::Ok);
    assert_pose(&r, &pose, 2.0, 8.0);
}

/// A dark body on a sky brighter than full scale (clipped flat at 255, no noise left), and a
/// bright body clipped at 255 on a dark sky, are both measured.
#[test]
fn clipped_skies_and_bodies_are_measured() {
    let pose = TruePose {
        t: [3.0, -2.0, 1100.0],
        pitch_deg: 25.0,
        yaw_deg: 70.0,
        roll_deg: 40.0,
    };
    let (pixels, _) = render(&pose, 256, &style(300.0, 80.0), 5);
    assert!(
        pixels.iter().filter(|&&v| v == 255).count() > 60000,
        "the sky is clipped"
    );
    let mut p = pipeline(Config::DEFAULT);
    let r = process(&mut p, chip_of(&pixels, 256, &pose), Some(1100.0));
    assert_eq!(r.status, Status::Ok);
    assert_pose(&r, &pose, 2.0, 8.0);

    let (pixels, _) = render(&pose, 256, &style(40.0, 400.0), 6);
    assert!(
        pixels.iter().filter(|&&v| v == 255).count() > 300,
        "the body is clipped"
    );
    let bright = Config {
        detect: DetectConfig {
            polarity: Some(BodyPolarity::Bright),
            ..DetectConfig::DEFAULT
        },
        ..Config::DEFAULT
    };
    let mut p = pipeline(bright);
    let r = process(&mut p, chip_of(&pixels, 256, &pose), Some(1100.0));
    assert_eq!(r.status, Status::Ok);
    assert_pose(&r, &pose, 2.0, 8.0);
}

/// The aimed projectile with a second one `offset` px away at `range` m and `pitch` deg.
fn two_projectiles(aimed: &TruePose, offset: (f64, f64), range: f64, pitch: f64) -> Vec<u8> {
    let other = TruePose {
        t: [
            offset.0 * aimed.t[2] / TELESCOPE.fx,
            offset.1 * aimed.t[2] / TELESCOPE.fy,
            range,
        ],
        pitch_deg: pitch,
        yaw_deg: 110.0,
        roll_deg: 0.0,
    };
    let s = style(170.0, 60.0);
    let (mut pixels, _) = render(aimed, 256, &s, 8);
    let origin = origin_of(aimed, 256);
    let other = coverage(&TELESCOPE, &other, origin.0, origin.1, 256, 256, 8);
    let other = blur(&other, 256, 256, s.psf_sigma);
    for (v, c) in pixels.iter_mut().zip(&other) {
        *v = (f64::from(*v) + c * (s.body - s.sky))
            .round()
            .clamp(0.0, 255.0) as u8;
    }
    pixels
}

const AIMED: TruePose = TruePose {
    t: [0.0, 0.0, 1200.0],
    pitch_deg: 20.0,
    yaw_deg: -70.0,
    roll_deg: 10.0,
};

/// Two projectiles in one chip: of the aimed one and a smaller one off its axis, the aimed one
/// is measured.
#[test]
fn of_two_projectiles_the_aimed_one_is_measured() {
    let pixels = two_projectiles(&AIMED, (0.0, -90.0), 1500.0, 45.0);
    let mut p = pipeline(Config::DEFAULT);
    let r = process(&mut p, chip_of(&pixels, 256, &AIMED), Some(1200.0));
    assert_eq!(r.status, Status::Ok);
    assert_pose(&r, &AIMED, 2.0, 8.0);
}

/// A larger (nearer) second projectile 75 px off wins the selection over the aimed one, and a
/// smaller one on the aimed one's axis is merged with it as a fragment.
#[test]
#[ignore = "open: a larger second projectile is measured instead of the aimed one; one on its axis is merged"]
fn of_two_projectiles_the_aimed_one_is_measured_whatever_the_other() {
    for (offset, range, pitch) in [((75.0, 0.0), 1000.0, -30.0), ((-80.0, 0.0), 1500.0, 45.0)] {
        let pixels = two_projectiles(&AIMED, offset, range, pitch);
        let mut p = pipeline(Config::DEFAULT);
        let r = process(&mut p, chip_of(&pixels, 256, &AIMED), Some(1200.0));
        assert_eq!(r.status, Status::Ok);
        assert_pose(&r, &AIMED, 2.0, 8.0);
    }
}

/// A chip whose left border cuts `cut` px off the body (which is 136 px long, nearly
/// broadside, at 1 km).
fn cut_body(cut: i64) -> (Vec<u8>, (i64, i64), TruePose) {
    let pose = TruePose {
        t: [0.0, 0.0, 1000.0],
        pitch_deg: 5.0,
        yaw_deg: -80.0,
        roll_deg: 0.0,
    };
    let (u, v) = project(&TELESCOPE, &pose, [0.0; 3]);
    let origin = (u.round() as i64 - 68 + cut, v.round() as i64 - 128);
    let style = style(170.0, 60.0);
    let (pixels, _) = chip_u8(&TELESCOPE, &pose, origin, (256, 256), &style, &mut Rng(9));
    (pixels, origin, pose)
}

/// A body cut by the chip's left border has lost an end: it is refused (`unmeasurable`) however
/// little is cut, rather than measured as a shorter body (the yaw drifted to -55 deg for -80 at a
/// 20 px cut before). The same body 10 px inside the border is measured.
#[test]
fn a_body_cut_by_the_border_is_refused() {
    for cut in [2i64, 5, 20, 40, 60] {
        let (pixels, origin, _) = cut_body(cut);
        let chip = ChipView::gray8(&pixels, 256, 256, 256, origin.0 as i32, origin.1 as i32);
        let r = process(&mut pipeline(Config::DEFAULT), chip.unwrap(), Some(1000.0));
        assert_eq!(r.status, Status::Unmeasurable, "cut {cut} px");
    }
    let (pixels, origin, pose) = cut_body(-10);
    let chip = ChipView::gray8(&pixels, 256, 256, 256, origin.0 as i32, origin.1 as i32);
    let r = process(&mut pipeline(Config::DEFAULT), chip.unwrap(), Some(1000.0));
    assert_eq!(r.status, Status::Ok);
    assert_pose(&r, &pose, 2.0, 8.0);
}

fn style(sky: f64, body: f64) -> ChipStyle {
    ChipStyle {
        sky,
        body,
        gradient: (0.03, -0.02),
        psf_sigma: 0.8,
        noise: 2.0,
    }
}

/// Full-frame origin of a `side` x `side` chip centred on the body origin.
fn origin_of(pose: &TruePose, side: usize) -> (i64, i64) {
    centred_origin(&TELESCOPE, pose, side)
}

fn render(pose: &TruePose, side: usize, style: &ChipStyle, seed: u64) -> (Vec<u8>, Vec<bool>) {
    chip_u8(
        &TELESCOPE,
        pose,
        origin_of(pose, side),
        (side, side),
        style,
        &mut Rng(seed),
    )
}

fn chip_of<'a>(pixels: &'a [u8], side: usize, pose: &TruePose) -> ChipView<'a> {
    let (x0, y0) = origin_of(pose, side);
    ChipView::gray8(pixels, side, side, side, x0 as i32, y0 as i32).unwrap()
}

/// The pitch within `pitch_tol` deg and the better yaw candidate within `yaw_tol` deg.
fn assert_pose(r: &FrameResult, truth: &TruePose, pitch_tol: f32, yaw_tol: f32) {
    let pitch = (r.pose.pitch_deg - truth.pitch_deg as f32).abs();
    let yaw = |y: f32| imade_core::pose::wrap_deg(y - truth.yaw_deg as f32).abs();
    assert!(
        pitch < pitch_tol,
        "pitch {} for {}",
        r.pose.pitch_deg,
        truth.pitch_deg
    );
    assert!(
        yaw(r.pose.yaw_deg).min(yaw(r.yaw_alt_deg)) < yaw_tol,
        "yaw {} / {} for {}",
        r.pose.yaw_deg,
        r.yaw_alt_deg,
        truth.yaw_deg
    );
}
