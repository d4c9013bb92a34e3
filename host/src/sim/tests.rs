//! Tests of the simulator as a whole: determinism, the mask's coverage rule against an analytic
//! silhouette, mesh files against the built-in model, and the bundled fixtures.

use super::camera::{CameraPose, Intrinsics};
use super::math::{Mat3, Vec3};
use super::model::{ProjectileModel, REF_1378X80};
use super::pose::{Attitude, BodyPose};
use super::render::{FrameScene, RenderedChip, render};
use super::scenario::{ProjectileConfig, SceneConfig};
use super::sky::Environment;
use super::*;
use std::path::{Path, PathBuf};

const K: Intrinsics = Intrinsics {
    fx: 100000.0,
    fy: 100000.0,
    cx: 1023.5,
    cy: 1023.5,
    width: 2048,
    height: 2048,
};

/// Renders one 256 x 256 chip centred on the principal point, with no plume.
fn render_pose(model: &ProjectileModel, translation: Vec3, attitude: Attitude) -> RenderedChip {
    let environment = Environment::new(&SceneConfig::default(), 1).unwrap();
    let camera = CameraPose {
        position: Vec3::new(0.0, 0.0, 2.0),
        r_cw: CameraPose::on_mount(Vec3::default(), 0.3, 0.2).r_cw,
    };
    let body = BodyPose {
        translation,
        rotation: attitude.rotation_cb(),
    };
    let scene = FrameScene {
        intrinsics: &K,
        camera: &camera,
        chip_origin: (896, 896),
        chip_size: (256, 256),
        model,
        body: &body,
        albedo: 0.1,
        time_s: 3.0,
        environment: &environment,
        puffs: &[],
        psf_sigma_px: 0.9,
        supersampling: 8,
        clutter: None,
    };
    render(&scene).unwrap()
}

/// Silhouette area of ref-1378x80 seen broadside with two fins in the image plane, m^2, from the
/// spec's formulas (Simpson's rule over the ogive).
fn broadside_area() -> f64 {
    let m = REF_1378X80;
    let n = 20000;
    let h = m.nose_length / f64::from(n);
    let ogive: f64 = (0..=n)
        .map(|i| {
            let w = if i == 0 || i == n {
                1.0
            } else if i % 2 == 1 {
                4.0
            } else {
                2.0
            };
            w * m.radius_at(f64::from(i) * h)
        })
        .sum::<f64>()
        * h
        / 3.0;
    let cylinder = 2.0 * m.radius * (m.length - m.nose_length);
    let fin = (m.fin_tip_radius - m.radius) * 0.5 * (m.fin_root_chord + m.fin_tip_chord);
    2.0 * ogive + cylinder + 2.0 * fin
}

#[test]
fn broadside_mask_area_matches_the_analytic_silhouette() {
    let model = ProjectileModel::from_config(&ProjectileConfig::default()).unwrap();
    // Broadside, tilted in the image plane so that pixel rows do not line up with the edges.
    let broadside = Attitude {
        pitch_deg: 17.0,
        yaw_deg: 90.0,
        roll_deg: 0.0,
    };
    for (tz, offset) in [(1000.0, 0.0), (1500.0, 0.37)] {
        let chip = render_pose(&model, Vec3::new(offset, -offset, tz), broadside);
        let scale = K.fx / tz;
        let expected = broadside_area() * scale * scale;
        let counted = chip.mask.iter().filter(|&&m| m).count() as f64;
        assert!(
            (counted / expected - 1.0).abs() < 0.015,
            "Tz {tz}: mask {counted} px, silhouette {expected:.1} px^2"
        );
    }
}

#[test]
fn mask_is_the_body_alone_and_the_body_is_darker_than_the_sky() {
    let model = ProjectileModel::from_config(&ProjectileConfig::default()).unwrap();
    let attitude = Attitude {
        pitch_deg: 20.0,
        yaw_deg: -70.0,
        roll_deg: 10.0,
    };
    let chip = render_pose(&model, Vec3::new(0.0, 0.0, 1200.0), attitude);
    let (mut body, mut nb, mut sky, mut ns) = (0.0, 0.0, 0.0, 0.0);
    for (l, m) in chip.radiance.iter().zip(&chip.mask) {
        if *m {
            body += l;
            nb += 1.0;
        } else {
            sky += l;
            ns += 1.0;
        }
    }
    assert!(nb > 200.0);
    assert!(
        body / nb < 0.6 * sky / ns,
        "body {} sky {}",
        body / nb,
        sky / ns
    );
}

#[test]
fn an_obj_export_of_the_built_in_mesh_renders_the_same_mask() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ref.obj");
    std::fs::write(&path, REF_1378X80.tessellate().to_obj()).unwrap();
    let from_file = ProjectileModel::from_config(&ProjectileConfig {
        mesh: Some(path),
        ..ProjectileConfig::default()
    })
    .unwrap();
    assert_eq!(from_file.id, "ref");
    let built_in = ProjectileModel::from_config(&ProjectileConfig::default()).unwrap();
    let attitude = Attitude {
        pitch_deg: -35.0,
        yaw_deg: 130.0,
        roll_deg: 33.0,
    };
    let t = Vec3::new(0.2, 0.1, 1300.0);
    let a = render_pose(&built_in, t, attitude);
    let b = render_pose(&from_file, t, attitude);
    assert_eq!(a.mask, b.mask);
}

/// A scenario small enough to render in a moment.
fn tiny_scenario(seed: u64) -> Scenario {
    let mut s = presets::preset("table1-test").unwrap();
    s.seed = seed;
    s.clip.frames = 3;
    s.clip.keep_every = 30;
    s.camera.chip_width = 96;
    s.camera.chip_height = 96;
    s.camera.tracker_jitter_px = 10.0;
    s.sensor.supersampling = 4;
    s
}

/// Every file under `dir`, relative path and bytes, in path order.
fn files(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let mut pending = vec![dir.to_path_buf()];
    while let Some(d) = pending.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                pending.push(path);
            } else {
                let bytes = std::fs::read(&path).unwrap();
                out.push((path.strip_prefix(dir).unwrap().to_path_buf(), bytes));
            }
        }
    }
    out.sort();
    out
}

#[test]
fn same_scenario_and_seed_give_identical_bytes_whatever_the_threads() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b, c) = (
        dir.path().join("a"),
        dir.path().join("b"),
        dir.path().join("c"),
    );
    Simulation::new(tiny_scenario(11))
        .unwrap()
        .write_clip(&a, 1)
        .unwrap();
    Simulation::new(tiny_scenario(11))
        .unwrap()
        .write_clip(&b, 3)
        .unwrap();
    Simulation::new(tiny_scenario(12))
        .unwrap()
        .write_clip(&c, 2)
        .unwrap();
    let (fa, fb, fc) = (files(&a), files(&b), files(&c));
    assert_eq!(
        fa.len(),
        3 + 2 * 3,
        "clip.json, frames.csv, scenario.toml, chips, masks"
    );
    assert!(fa == fb, "same seed, different bytes");
    let chip = |f: &[(PathBuf, Vec<u8>)]| f.iter().find(|(p, _)| p.starts_with("chips")).cloned();
    assert_ne!(chip(&fa), chip(&fc), "another seed should give other chips");
}

#[test]
fn written_clip_reads_back_with_its_truth() {
    let dir = tempfile::tempdir().unwrap();
    let sim = Simulation::new(tiny_scenario(5)).unwrap();
    sim.write_clip(dir.path(), 2).unwrap();
    let clip = crate::clip::Clip::open(dir.path()).unwrap();
    assert_eq!(clip.meta.projectile, "ref-1378x80");
    assert_eq!(clip.frames.len(), 3);
    for (row, plan) in clip.frames.iter().zip(sim.plans()) {
        let row = row.as_ref().unwrap();
        let truth = row.truth.unwrap();
        assert_eq!(row.frame, plan.frame);
        assert_eq!(truth.yaw_deg, plan.attitude.yaw_deg);
        assert_eq!(row.range_m, Some(plan.body.translation.norm()));
        let chip = crate::clip::load_chip(&clip.resolve(&row.chip).unwrap()).unwrap();
        assert_eq!((chip.width, chip.height), (96, 96));
        let (_, _, mask) =
            crate::clip::load_mask(&clip.resolve(row.gt_mask.as_ref().unwrap()).unwrap()).unwrap();
        assert!(mask.iter().filter(|&&m| m).count() > 100);
        // The truth pose projects the body origin inside the chip.
        let t = Vec3::new(truth.tx_m, truth.ty_m, truth.tz_m);
        let (u, v) = K.project(t).unwrap();
        assert!((row.chip_x0 as f64..row.chip_x0 as f64 + 96.0).contains(&u));
        assert!((row.chip_y0 as f64..row.chip_y0 as f64 + 96.0).contains(&v));
        let r = Attitude {
            pitch_deg: truth.pitch_deg,
            yaw_deg: truth.yaw_deg,
            roll_deg: truth.roll_deg,
        }
        .rotation_cb();
        assert!(r.max_abs_diff(&plan.body.rotation) < 1e-9);
        assert!((r * r.transpose()).max_abs_diff(&Mat3::IDENTITY) < 1e-12);
    }
}

/// The bundled fixtures made from scenario files are reproduced byte for byte: the check that the
/// simulator is deterministic across machines (fixtures/README.md says how they were made).
#[test]
fn small_fixtures_are_reproduced_byte_for_byte() {
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures");
    for name in [
        "small-known-range",
        "small-unknown-range",
        "small-rocket-2200x120",
        "small-shell-600x100",
        "small-sixfin-1000x70",
    ] {
        let scenario_file = fixtures.join("scenarios").join(format!("{name}.toml"));
        let dir = tempfile::tempdir().unwrap();
        let scenario = Scenario::from_file(&scenario_file).unwrap();
        Simulation::new(scenario)
            .unwrap()
            .write_clip(dir.path(), 2)
            .unwrap();
        let fresh = files(dir.path());
        let bundled = files(&fixtures.join(name));
        assert_eq!(fresh.len(), bundled.len(), "{name}: file count");
        for ((p, a), (q, b)) in fresh.iter().zip(&bundled) {
            assert_eq!(p, q);
            assert!(
                a == b,
                "{name}: {} differs from the bundled fixture",
                p.display()
            );
        }
    }
}
