//! Shape-guided segmentation (SIS-Cut, GVF-ASM and 2D TETRIS, the source paper's Algorithms 2
//! and 1 and Section 4.3.3, TETRIS with the bundled weights) against independent truth: chips and truth masks from the ray-casting renderer, or the
//! Table 1 test clip's chips and masks; priors rendered by the same renderer at a deliberately
//! wrong pose. The IoU against the truth of the prior and of each method's mask is compared, as
//! the paper's Fig. 19 does. Run with `--nocapture` for the tables.

use imade_core::lut::render;
use imade_core::shape_guided::{ShapeGuided, ShapeGuidedConfig};
use imade_core::table_match::guided_loop::{LoopOutcome, LoopStop};
use imade_core::{
    Camera, ChipMask, ChipView, Config, FrameInput, GuidedLoopConfig, GuidedMethod, Pipeline,
    RangeUse, Status,
};
use imade_host::clip::{Clip, load_chip, load_mask};
use imade_tests::pose_errors;
use imade_tests::render::{
    ChipStyle, Intrinsics, Rng, TruePose, chip_u8, coverage, project, rotation,
};
use std::path::PathBuf;
use std::time::{Duration, Instant};

const CAM: Intrinsics = Intrinsics {
    fx: 100000.0,
    fy: 100000.0,
    cx: 1023.5,
    cy: 1023.5,
};

const CHIP: usize = 256;

/// Sub-pixel samples per side when rendering a prior (a binary mask needs fewer than a chip).
const PRIOR_SS: usize = 4;

/// A chip-sized mask from one bool per pixel, row-major.
fn to_mask(bits: &[bool], w: usize, h: usize) -> ChipMask {
    let mut m = ChipMask::new();
    m.reset(w, h).expect("chip-sized");
    for (k, _) in bits.iter().enumerate().filter(|(_, b)| **b) {
        m.set(k % w, k / w, true);
    }
    m
}

/// Intersection over union of a mask and the truth.
fn iou(mask: &ChipMask, truth: &[bool], w: usize) -> f64 {
    let (mut both, mut either) = (0usize, 0usize);
    for (k, &t) in truth.iter().enumerate() {
        let m = mask.get(k % w, k / w);
        both += usize::from(m && t);
        either += usize::from(m || t);
    }
    if either == 0 {
        1.0
    } else {
        both as f64 / either as f64
    }
}

/// The silhouette at `pose` as a half-coverage mask of the chip at `origin`.
fn prior_mask(
    cam: &Intrinsics,
    pose: &TruePose,
    origin: (i64, i64),
    w: usize,
    h: usize,
) -> ChipMask {
    let cov = coverage(cam, pose, origin.0, origin.1, w, h, PRIOR_SS);
    let bits: Vec<bool> = cov.iter().map(|&c| c >= 0.5).collect();
    to_mask(&bits, w, h)
}

/// Row-major 3 x 3 product.
fn mul(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

/// `pose` with its attitude turned by `angle_deg` about the line of sight to the body origin
/// (an in-plane rotation of the silhouette), its origin moved by (`du`, `dv`) px in the image
/// and its distance scaled by `range_factor` (the silhouette scales by about its inverse).
fn perturbed(pose: &TruePose, du: f64, dv: f64, range_factor: f64, angle_deg: f64) -> TruePose {
    let t = pose.t;
    let norm = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
    let m = [t[0] / norm, t[1] / norm, t[2] / norm];
    // Rodrigues rotation about m.
    let (s, c) = angle_deg.to_radians().sin_cos();
    let k = [[0.0, -m[2], m[1]], [m[2], 0.0, -m[0]], [-m[1], m[0], 0.0]];
    let kk = mul(&k, &k);
    let turn: [[f64; 3]; 3] = std::array::from_fn(|i| {
        std::array::from_fn(|j| f64::from(u8::from(i == j)) + s * k[i][j] + (1.0 - c) * kk[i][j])
    });
    let r = mul(
        &turn,
        &rotation(pose.pitch_deg, pose.yaw_deg, pose.roll_deg),
    );
    // Nose = first column of R (C = (right, down, forward)): (cp sy, -sp, cp cy).
    let nose = [r[0][0], r[1][0], r[2][0]];
    let pitch = (-nose[1]).asin().to_degrees();
    let yaw = nose[0].atan2(nose[2]).to_degrees();
    // Roll: R = R(pitch, yaw, 0) Rx(roll), so Rx(roll) = R(pitch, yaw, 0)^T R.
    let r0 = rotation(pitch, yaw, 0.0);
    let r0t: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| r0[j][i]));
    let rx = mul(&r0t, &r);
    let roll = rx[2][1].atan2(rx[1][1]).to_degrees();
    let per_px = t[2] / CAM.fx;
    TruePose {
        t: [
            (t[0] + du * per_px) * range_factor,
            (t[1] + dv * per_px) * range_factor,
            t[2] * range_factor,
        ],
        pitch_deg: pitch,
        yaw_deg: yaw,
        roll_deg: roll,
    }
}

/// The methods compared.
const METHODS: usize = GuidedMethod::ALL.len();

/// The methods' workspace, TETRIS with the bundled weights.
fn shape_guided() -> Box<ShapeGuided> {
    let mut sg = Box::new(ShapeGuided::new());
    sg.set_tetris(imade_tests::bundled_tetris());
    sg
}

/// IoU of the prior and of each method's mask, and each method's time.
#[derive(Debug, Clone, Copy)]
struct Outcome {
    prior: f64,
    methods: [f64; METHODS],
    times: [Duration; METHODS],
}

/// Refines `prior` on `chip` with both methods and scores everything against `truth`.
fn evaluate(sg: &mut ShapeGuided, chip: &ChipView, prior: &ChipMask, truth: &[bool]) -> Outcome {
    let config = ShapeGuidedConfig::DEFAULT;
    let w = chip.width();
    let mut out = ChipMask::new();
    let mut methods = [0.0; METHODS];
    let mut times = [Duration::ZERO; METHODS];
    for (k, method) in GuidedMethod::ALL.into_iter().enumerate() {
        let start = Instant::now();
        let refined = sg.segment(method, &config, chip, prior, &mut out);
        times[k] = start.elapsed();
        // A refusal keeps the prior, as the pipeline would.
        methods[k] = match refined {
            Ok(_) => iou(&out, truth, w),
            Err(_) => iou(prior, truth, w),
        };
    }
    Outcome {
        prior: iou(prior, truth, w),
        methods,
        times,
    }
}

/// Quartiles (25 %, median, 75 %).
fn quartiles(mut v: Vec<f64>) -> [f64; 3] {
    v.sort_by(f64::total_cmp);
    let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    [at(0.25), at(0.5), at(0.75)]
}

/// Prints the IoU quartiles of the prior and both methods, with the share of cases each method
/// improved; returns (prior median, [method medians], [improved shares]).
fn report(title: &str, outcomes: &[Outcome]) -> (f64, [f64; METHODS], [f64; METHODS]) {
    println!(
        "{title} ({} cases): IoU against truth, 25% / median / 75%",
        outcomes.len()
    );
    let prior = quartiles(outcomes.iter().map(|o| o.prior).collect());
    println!(
        "  {:10} {:.3} / {:.3} / {:.3}",
        "prior", prior[0], prior[1], prior[2]
    );
    let mut medians = [0.0; METHODS];
    let mut improved = [0.0; METHODS];
    for (k, method) in GuidedMethod::ALL.into_iter().enumerate() {
        let q = quartiles(outcomes.iter().map(|o| o.methods[k]).collect());
        let better = outcomes.iter().filter(|o| o.methods[k] > o.prior).count();
        let ms = outcomes
            .iter()
            .map(|o| o.times[k].as_secs_f64())
            .sum::<f64>()
            * 1e3
            / outcomes.len() as f64;
        println!(
            "  {:10} {:.3} / {:.3} / {:.3}   better than the prior in {better} of {}, {ms:.1} ms a frame",
            method.as_str(),
            q[0],
            q[1],
            q[2],
            outcomes.len()
        );
        medians[k] = q[1];
        improved[k] = better as f64 / outcomes.len() as f64;
    }
    (prior[1], medians, improved)
}

/// A pose at slant range `range` whose body origin images at full-frame pixel `at`.
fn pose_at(range: f64, at: (f64, f64), pitch: f64, yaw: f64, roll: f64) -> TruePose {
    let ray = [(at.0 - CAM.cx) / CAM.fx, (at.1 - CAM.cy) / CAM.fy, 1.0];
    let norm = (ray[0] * ray[0] + ray[1] * ray[1] + 1.0).sqrt();
    TruePose {
        t: ray.map(|c| range * c / norm),
        pitch_deg: pitch,
        yaw_deg: yaw,
        roll_deg: roll,
    }
}

/// Rendered chips over a pose grid, each with a prior shifted by about 3 px, scaled by 6 % and
/// turned by 4 deg in the image (a wrong pose whose silhouette is still an affine image of the
/// truth's); returns the outcomes.
fn synthetic_cases(style: &ChipStyle) -> Vec<Outcome> {
    let mut sg = shape_guided();
    let mut outcomes = Vec::new();
    let mut seed = 7u64;
    for range in [1000.0, 1500.0] {
        for pitch in [-20.0, 10.0, 35.0] {
            for yaw in [-120.0, -70.0, 50.0, 100.0] {
                seed += 1;
                let sign = if seed % 2 == 0 { 1.0 } else { -1.0 };
                let truth = pose_at(range, (1100.0, 950.0), pitch, yaw, 13.0 * seed as f64);
                let (u, v) = project(&CAM, &truth, [0.0; 3]);
                let origin = (
                    u.round() as i64 - CHIP as i64 / 2,
                    v.round() as i64 - CHIP as i64 / 2,
                );
                let (pixels, truth_mask) =
                    chip_u8(&CAM, &truth, origin, (CHIP, CHIP), style, &mut Rng(seed));
                let wrong = perturbed(&truth, 2.5 * sign, -1.5, 1.0 + 0.06 * sign, 4.0 * sign);
                let prior = prior_mask(&CAM, &wrong, origin, CHIP, CHIP);
                let chip =
                    ChipView::gray8(&pixels, CHIP, CHIP, CHIP, origin.0 as i32, origin.1 as i32)
                        .expect("chip");
                outcomes.push(evaluate(&mut sg, &chip, &prior, &truth_mask));
            }
        }
    }
    outcomes
}

/// Dark body, PSF 0.8 px, noise 1 grey level, a faint sky gradient.
const CLEAN: ChipStyle = ChipStyle {
    sky: 170.0,
    body: 60.0,
    gradient: (0.05, -0.03),
    psf_sigma: 0.8,
    noise: 1.0,
};

/// A seventh of [`CLEAN`]'s contrast, a steeper gradient, a wider PSF and noise 7 grey levels:
/// contrast to noise about 2.1.
const NOISY: ChipStyle = ChipStyle {
    sky: 150.0,
    body: 135.0,
    gradient: (0.15, -0.1),
    psf_sigma: 1.2,
    noise: 7.0,
};

#[test]
fn every_method_improves_a_wrong_prior_on_clean_chips() {
    let outcomes = synthetic_cases(&CLEAN);
    let (prior, medians, improved) = report("clean rendered chips", &outcomes);
    for (k, method) in GuidedMethod::ALL.into_iter().enumerate() {
        assert!(
            medians[k] > prior + 0.15,
            "{}: median IoU {:.3} vs prior {prior:.3}",
            method.as_str(),
            medians[k]
        );
        assert!(
            improved[k] >= 0.9,
            "{}: improved {:.2}",
            method.as_str(),
            improved[k]
        );
    }
}

#[test]
fn noisy_low_contrast_chips_are_reported() {
    let outcomes = synthetic_cases(&NOISY);
    let (prior, medians, _) = report("noisy low-contrast rendered chips", &outcomes);
    // SIS-Cut compares grey-level distributions over whole regions and barely notices the
    // noise; GVF-ASM follows the noisy edge map and keeps only part of its gain.
    let [sis_cut, gvf_asm, tetris] = medians;
    assert!(tetris > prior, "tetris: {tetris:.3} vs prior {prior:.3}");
    assert!(
        sis_cut > prior + 0.15,
        "sis-cut: {sis_cut:.3} vs prior {prior:.3}"
    );
    assert!(gvf_asm > prior, "gvf-asm: {gvf_asm:.3} vs prior {prior:.3}");
}

/// The bundled Table 1 test clip.
fn table1() -> Clip {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fixtures/table1-test");
    Clip::open(&dir).expect("fixture clip")
}

#[test]
fn fixture_clip_blind_prior_and_refined_masks() {
    let clip = table1();
    let cam_meta = clip.meta.camera;
    let cam = Intrinsics {
        fx: cam_meta.fx,
        fy: cam_meta.fy,
        cx: cam_meta.cx,
        cy: cam_meta.cy,
    };
    let camera = Camera {
        fx: cam.fx as f32,
        fy: cam.fy as f32,
        cx: cam.cx as f32,
        cy: cam.cy as f32,
    };
    let mut pipeline: Pipeline =
        Pipeline::new(Config::DEFAULT, camera, imade_tests::reference_model());
    let mut sg = shape_guided();
    let mut rng = Rng(1378);
    let mut outcomes = Vec::new();
    let mut blind = Vec::new();
    let mut exact = Vec::new();
    let mut near = Vec::new();
    let mut roll_rng = Rng(90);
    for (index, row) in clip
        .frames
        .iter()
        .map(|r| r.as_ref().expect("valid row"))
        .enumerate()
    {
        let image = load_chip(&clip.path_of(&row.chip)).expect("chip");
        let (w, h) = (image.width as usize, image.height as usize);
        let (mw, mh, truth) =
            load_mask(&clip.path_of(row.gt_mask.as_deref().expect("mask"))).expect("mask");
        assert_eq!((mw as usize, mh as usize), (w, h));
        let chip = image
            .view(row.chip_x0 as i32, row.chip_y0 as i32)
            .expect("view");
        let result = pipeline.process(&FrameInput {
            chip,
            time_s: row.time_s,
            range_m: row.range_m.map(|r| r as f32),
            mount: row.mount,
        });
        if result.status == Status::Ok {
            blind.push(iou(pipeline.mask(), &truth, w));
        }
        let gt = row.truth.expect("ground truth");
        let truth_pose = TruePose {
            t: [gt.tx_m, gt.ty_m, gt.tz_m],
            pitch_deg: gt.pitch_deg,
            yaw_deg: gt.yaw_deg,
            roll_deg: gt.roll_deg,
        };
        let origin = (row.chip_x0, row.chip_y0);
        if index % 10 == 0 {
            // The independent renderer at the true pose against the simulator's mask.
            exact.push(iou(&prior_mask(&cam, &truth_pose, origin, w, h), &truth, w));
        }
        if index % 5 == 0 {
            // A prior that is right but for the roll: what refinement does to a good prior.
            let rolled = TruePose {
                roll_deg: 360.0 * roll_rng.uniform(),
                ..truth_pose
            };
            let prior = prior_mask(&cam, &rolled, origin, w, h);
            near.push(evaluate(&mut sg, &chip, &prior, &truth));
        }
        // The prior: the true pose perturbed as a table match might miss it (in-plane ~1.5 px,
        // range ~4 %, pitch ~2 deg, yaw ~5 deg), the roll unknown (any).
        let per_px = gt.tz_m / cam.fx;
        let range_factor = 1.0 + 0.04 * rng.gaussian();
        let wrong = TruePose {
            t: [
                (truth_pose.t[0] + 1.5 * per_px * rng.gaussian()) * range_factor,
                (truth_pose.t[1] + 1.5 * per_px * rng.gaussian()) * range_factor,
                truth_pose.t[2] * range_factor,
            ],
            pitch_deg: truth_pose.pitch_deg + 2.0 * rng.gaussian(),
            yaw_deg: truth_pose.yaw_deg + 5.0 * rng.gaussian(),
            roll_deg: 360.0 * rng.uniform(),
        };
        let prior = prior_mask(&cam, &wrong, origin, w, h);
        outcomes.push(evaluate(&mut sg, &chip, &prior, &truth));
    }
    let print = |label: &str, v: &[f64]| {
        let q = quartiles(v.to_vec());
        println!(
            "{label}, {} frames: {:.3} / {:.3} / {:.3}",
            v.len(),
            q[0],
            q[1],
            q[2]
        );
        q[1]
    };
    let exact = print(
        "prior at the exact pose (renderer vs simulator masks)",
        &exact,
    );
    let blind = print("blind mask (the pipeline's segmentation)", &blind);
    let (good, good_medians, _) =
        report("table1-test, prior at the true pose, roll unknown", &near);
    let (prior, medians, _) = report("table1-test, prior from a perturbed true pose", &outcomes);
    assert_eq!(outcomes.len(), 175);
    assert!(
        exact > 0.9,
        "the renderer's silhouettes match the clip's masks: {exact:.3}"
    );
    // GVF-ASM leaves a good prior where it is; SIS-Cut grows it over the blurred edge (its
    // criterion's bias, reported in docs/shape-guided.md, not asserted).
    assert!(
        good_medians[1] > good - 0.02,
        "gvf-asm on a good prior: {:.3} vs {good:.3}",
        good_medians[1]
    );
    let [sis_cut, gvf_asm, tetris] = medians;
    assert!(
        tetris > prior + 0.1,
        "tetris: {tetris:.3} vs prior {prior:.3}"
    );
    assert!(
        sis_cut > prior + 0.1,
        "sis-cut: {sis_cut:.3} vs prior {prior:.3}"
    );
    assert!(
        gvf_asm > prior + 0.05,
        "gvf-asm: {gvf_asm:.3} vs prior {prior:.3}"
    );
    // Neither reaches the blind mask from a prior this wrong (see docs/shape-guided.md).
    println!(
        "medians: blind {blind:.3}, prior {prior:.3}, sis-cut {sis_cut:.3}, gvf-asm {gvf_asm:.3}"
    );
}

/// A config with every tunable drawn from `values` (including zero, negative, huge and NaN).
fn odd_config(values: &[f32]) -> ShapeGuidedConfig {
    let mut c = ShapeGuidedConfig::DEFAULT;
    let at = |k: usize| values[k % values.len()];
    c.sis_cut.ring_px = at(0);
    c.sis_cut.bins = at(1).abs().min(1e6) as usize;
    c.sis_cut.uniform_mix = at(2);
    c.sis_cut.probe_px = at(3);
    c.sis_cut.max_shift_px = at(4);
    c.sis_cut.max_log_scale = at(5);
    c.sis_cut.search.max_evaluations = at(6).abs().min(300.0) as u32;
    c.gvf_asm.capture_px = at(7);
    c.gvf_asm.mu = at(8);
    c.gvf_asm.gvf_iterations = at(9).abs().min(50.0) as u32;
    c.gvf_asm.asm_iterations = at(10).abs().min(50.0) as u32;
    c.gvf_asm.gain_px = at(11);
    c.gvf_asm.step_px = at(12);
    c
}

proptest::proptest! {
    #![proptest_config(imade_tests::proptest_config(64))]

    /// Any chip, any prior and any tunables: a result or an error, never a panic; a result's
    /// mask has the chip's size and the pixels it reports.
    #[test]
    fn any_input_gives_a_result_or_an_error(
        w in 1usize..48,
        h in 1usize..48,
        wide in proptest::bool::ANY,
        seed in 0u64..1000,
        density in 0.0f64..1.0,
        default_config in proptest::bool::ANY,
        values in proptest::collection::vec(
            proptest::prop_oneof![
                -1e30f32..1e30,
                -5.0f32..50.0,
                proptest::strategy::Just(f32::NAN),
                proptest::strategy::Just(f32::INFINITY),
                proptest::strategy::Just(0.0f32),
            ],
            13,
        ),
    ) {
        let mut rng = Rng(seed);
        let narrow: Vec<u8> = (0..w * h).map(|_| (rng.uniform() * 256.0) as u8).collect();
        let deep: Vec<u16> = narrow.iter().map(|&v| u16::from(v) * 257).collect();
        let chip = if wide {
            ChipView::gray16(&deep, w, h, w, 0, 0)
        } else {
            ChipView::gray8(&narrow, w, h, w, 0, 0)
        }
        .expect("chip");
        // A random blob: a rectangle with random holes.
        let (x0, y0) = ((rng.uniform() * w as f64) as usize, (rng.uniform() * h as f64) as usize);
        let (x1, y1) = ((rng.uniform() * w as f64) as usize, (rng.uniform() * h as f64) as usize);
        let bits: Vec<bool> = (0..w * h)
            .map(|k| {
                let (x, y) = (k % w, k / w);
                (x0.min(x1)..=x0.max(x1)).contains(&x)
                    && (y0.min(y1)..=y0.max(y1)).contains(&y)
                    && rng.uniform() < density
            })
            .collect();
        let prior = to_mask(&bits, w, h);
        let config = if default_config { ShapeGuidedConfig::DEFAULT } else { odd_config(&values) };
        let mut sg = shape_guided();
        let mut out = ChipMask::new();
        for method in GuidedMethod::ALL {
            if let Ok(r) = sg.segment(method, &config, &chip, &prior, &mut out) {
                proptest::prop_assert_eq!((out.width(), out.height()), (w, h));
                proptest::prop_assert_eq!(r.area_px, out.count());
            }
        }
    }
}

/// One frame of the refinement loop on the Table 1 test clip.
struct LoopFrame {
    /// Frame number.
    frame: u64,
    /// Pose errors per 1 km: Tx, Ty, Tz (m/km), pitch, chosen yaw, best yaw (deg/km).
    errors: [f64; 6],
    /// What the loop did (None without refinement).
    outcome: Option<LoopOutcome>,
    /// IoU against the truth of the blind mask, the prior at the final pose (the grey-level
    /// fit's), the refined mask and the silhouette of the match the loop kept (None where the
    /// stage has no mask).
    ious: [Option<f64>; 4],
    /// The kept match's scale, px a body diameter.
    px_per_d: Option<f32>,
}

/// The pipeline with the bundled table and `method` over `clip`, with the grey-level fit where
/// `grey_fit`.
fn run_loop(
    clip: &Clip,
    method: Option<GuidedMethod>,
    range_use: RangeUse,
    grey_fit: bool,
) -> Vec<LoopFrame> {
    let camera = clip.meta.camera.camera();
    let mut config = Config {
        range_use,
        ..Config::DEFAULT
    }
    .with_guided_method(method);
    config.grey_fit.enabled = grey_fit;
    let table = imade_tests::bundled_table();
    let mut pipeline: Box<Pipeline> =
        Box::new(Pipeline::new(config, camera, imade_tests::reference_model()).with_table(table));
    pipeline.set_tetris(imade_tests::bundled_tetris());
    let mut frames = Vec::new();
    for row in clip.frames.iter().map(|r| r.as_ref().expect("valid row")) {
        let image = load_chip(&clip.path_of(&row.chip)).expect("chip");
        let w = image.width as usize;
        let (_, _, truth) =
            load_mask(&clip.path_of(row.gt_mask.as_deref().expect("mask"))).expect("mask");
        let chip = image
            .view(row.chip_x0 as i32, row.chip_y0 as i32)
            .expect("view");
        let result = pipeline.process(&FrameInput {
            chip,
            time_s: row.time_s,
            range_m: row.range_m.map(|r| r as f32),
            mount: row.mount,
        });
        if result.status != Status::Ok {
            continue;
        }
        let score = |m: &ChipMask| (m.count() > 0).then(|| iou(m, &truth, w));
        // The kept match's silhouette, drawn here: the pipeline's prior is drawn again at the
        // grey-level fit's pose.
        let mut kept = ChipMask::new();
        if let Some(matched) = pipeline.matched() {
            kept.reset(chip.width(), chip.height()).expect("chip-sized");
            let entry = table.entry_nearest(&matched.view);
            render::draw_entry(&mut kept, &entry, &matched.placement).expect("infallible");
        }
        frames.push(LoopFrame {
            frame: row.frame,
            errors: pose_errors(&result, &row.truth.expect("ground truth")),
            outcome: pipeline.guided_loop().copied(),
            ious: [
                score(pipeline.mask()),
                score(pipeline.prior()),
                score(pipeline.guided_mask()),
                score(&kept),
            ],
            px_per_d: pipeline.matched().map(|m| m.placement.px_per_unit),
        });
    }
    frames
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

/// The refinement loop with each method, with and without the clip's range, against the truth:
/// the stop rule never keeps a re-match that fits the width profile worse than the first match,
/// the pose stays within the table match's targets (tests/table_match.rs), every frame with a
/// pose has a refined mask, and where a re-match was accepted the silhouette of the match kept is
/// compared with the first match's (the run without refinement). Without the range, the kept
/// match's scale is the first match's in every frame (the re-matches hold it).
#[test]
fn refinement_loop_on_the_table1_test_clip() {
    let clip = table1();
    for range_use in [RangeUse::Auto, RangeUse::Ignore] {
        // Without the grey-level fit, which runs after the loop and would measure its own pose
        // (and costs about 130 ms a frame: 8 runs of 175 frames).
        let none = run_loop(&clip, None, range_use, false);
        for method in [None].into_iter().chain(GuidedMethod::ALL.map(Some)) {
            let frames = if method.is_none() {
                &none
            } else {
                &run_loop(&clip, method, range_use, false)
            };
            assert!(frames.len() >= 150, "{} frames with a pose", frames.len());
            let errors = |k: usize| median(frames.iter().map(|f| f.errors[k]).collect());
            let ious = |k: usize| median(frames.iter().filter_map(|f| f.ious[k]).collect());
            let outcomes: Vec<LoopOutcome> = frames.iter().filter_map(|f| f.outcome).collect();
            let mut stops = std::collections::BTreeMap::new();
            for o in &outcomes {
                *stops.entry(format!("{:?}", o.stop)).or_insert(0) += 1;
            }
            // The kept match's silhouette against the first one, where a re-match was accepted.
            let paired: Vec<(f64, f64)> = frames
                .iter()
                .filter(|f| f.outcome.is_some_and(|o| o.accepted > 0))
                .filter_map(|f| Some((f, none.iter().find(|n| n.frame == f.frame)?)))
                .filter_map(|(f, n)| Some((n.ious[3]?, f.ious[3]?)))
                .collect();
            let better = paired.iter().filter(|(a, b)| b > a).count();
            let worse = paired.iter().filter(|(a, b)| b < a).count();
            println!(
                "{range_use:?} {}: {} frames, Tx {:.4} Ty {:.4} Tz {:.2} m/km, pitch {:.3} yaw {:.2} \
                 best {:.2} deg/km; IoU blind {:.3} prior {:.3} refined {:.3}; re-match accepted \
                 in {} (kept match's IoU {:.3} -> {:.3}, better in {better}, worse in {worse}), stops {stops:?}",
                method.map_or("none", |m| m.as_str()),
                frames.len(),
                errors(0),
                errors(1),
                errors(2),
                errors(3),
                errors(4),
                errors(5),
                ious(0),
                ious(1),
                ious(2),
                paired.len(),
                median(paired.iter().map(|p| p.0).collect()),
                median(paired.iter().map(|p| p.1).collect()),
            );
            if method.is_none() {
                assert!(outcomes.is_empty() && frames.iter().all(|f| f.ious[2].is_none()));
                continue;
            }
            assert_eq!(outcomes.len(), frames.len(), "the loop runs in every frame");
            for (f, o) in frames.iter().zip(&outcomes) {
                assert!(o.rms_px <= o.first_rms_px, "kept a worse fit: {o:?}");
                assert!(o.rounds >= 1 && o.rounds <= GuidedLoopConfig::DEFAULT.max_rounds);
                assert!(o.accepted < o.rounds || o.stop == LoopStop::Rounds, "{o:?}");
                assert!(f.ious[2].is_some(), "no refined mask: {o:?}");
            }
            let (first, kept) = (
                median(paired.iter().map(|p| p.0).collect()),
                median(paired.iter().map(|p| p.1).collect()),
            );
            // Since the prior is drawn by the truth masks' rule (pixel centres), the accepted
            // re-matches move the kept silhouette's IoU either way about as often (SIS-Cut with
            // the range: median 0.882 -> 0.911, better in 25 and worse in 34 of 59; GVF-ASM
            // 0.843 -> 0.831): they must not spoil it.
            assert!(
                kept >= first - 0.02,
                "accepted re-matches lower the kept match's median IoU {first} -> {kept} (better \
                 in {better}, worse in {worse} of {})",
                paired.len()
            );
            if range_use == RangeUse::Ignore {
                // Without a range the re-matches keep the first match's scale: every frame's
                // kept match has the scale of the run without refinement (to the table search's
                // rounding), and so its range.
                for (f, n) in frames
                    .iter()
                    .filter_map(|f| Some((f, none.iter().find(|n| n.frame == f.frame)?)))
                {
                    let (Some(kept), Some(first)) = (f.px_per_d, n.px_per_d) else {
                        panic!("frame {}: no match", f.frame);
                    };
                    assert!(
                        (kept / first - 1.0).abs() < 1e-5,
                        "frame {}: the scale moved, {first} -> {kept} px a diameter",
                        f.frame
                    );
                }
                assert!(errors(2) <= 10.0, "Tz {}", errors(2));
                assert!(errors(3) <= 0.5, "pitch {}", errors(3));
                assert!(errors(5) <= 6.0, "yaw best {}", errors(5));
            } else {
                assert!(errors(0) <= 0.01 && errors(1) <= 0.01, "in-plane");
                assert!(errors(3) <= 0.5, "pitch {}", errors(3));
                assert!(errors(4) <= 4.0, "yaw chosen {}", errors(4));
            }
        }
    }
}

/// With the grey-level fit, each method segments the chip once more around the prior drawn at
/// the fit's pose: on `fixtures/small-known-range` (20 frames, range known) every frame with a
/// pose has a refined mask, and its median IoU against the truth masks beats both the blind
/// mask's and the refined mask the loop alone gives (without the fit, from the first match's
/// prior). Measured: blind 0.955; refined without the fit / with it: SIS-Cut 0.887 / 0.943,
/// GVF-ASM 0.971 / 0.984, TETRIS 0.967 / 0.984. SIS-Cut's stays below the blind mask's.
#[test]
fn each_method_segments_again_at_the_grey_level_fits_pose() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fixtures/small-known-range");
    let clip = Clip::open(&dir).expect("fixture clip");
    for method in GuidedMethod::ALL {
        let [loop_only, fitted] =
            [false, true].map(|grey_fit| run_loop(&clip, Some(method), RangeUse::Auto, grey_fit));
        assert_eq!(fitted.len(), clip.frames.len(), "a pose in every frame");
        assert!(fitted.iter().all(|f| f.ious[2].is_some()), "a refined mask");
        let median_of = |frames: &[LoopFrame], k: usize| {
            median(frames.iter().filter_map(|f| f.ious[k]).collect())
        };
        let (blind, before, after) = (
            median_of(&fitted, 0),
            median_of(&loop_only, 2),
            median_of(&fitted, 2),
        );
        println!(
            "{}: IoU blind {blind:.3}, refined without the fit {before:.3}, with it {after:.3}",
            method.as_str()
        );
        assert!(after > before + 0.01, "{}", method.as_str());
        if method != GuidedMethod::SisCut {
            assert!(after >= 0.95 && after > blind, "{}", method.as_str());
        }
    }
}
