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
/// The bundled meshes of the other shapes (`fixtures/meshes/`) are what `imade model mesh
/// --shape ID` writes, byte for byte: the meshes their clips were rendered from.
#[test]
fn bundled_meshes_are_the_shapes_meshes() {
    let meshes = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/meshes");
    for id in crate::sim::shapes::IDS {
        let bundled = std::fs::read_to_string(meshes.join(format!("{id}.obj"))).unwrap();
        let mesh = crate::sim::shapes::mesh(id).unwrap();
        assert!(mesh.to_obj() == bundled, "{id}: the bundled mesh differs");
    }
}

#[test]
fn small_fixtures_are_reproduced_byte_for_byte() {
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures");
    for name in [
        "small-known-range",
        "small-unknown-range",
        "small-rocket-2200x120",
        "small-shell-600x100",
        "small-sixfin-1000x70",
        "small-clutter-plume",
        "small-clutter-terrain",
        "small-towards-camera",
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

// ---- Clutter (issue 14): what the new physics puts in the chips, measured in them. ----

/// A clutter preset cut to `frames` frames, every 8th camera frame from 1 s (the body stays whole
/// in the chip), with `seed`.
fn clutter(preset: &str, seed: u64, frames: u32) -> Scenario {
    let mut s = presets::preset(preset).unwrap();
    s.seed = seed;
    s.clip.frames = frames;
    s.clip.keep_every = 8;
    s.sensor.supersampling = 4;
    s
}

/// The chip's samples as numbers.
fn samples(frame: &simulation::RenderedFrame) -> Vec<f64> {
    match &frame.chip.pixels {
        crate::clip::ChipPixels::U8(p) => p.iter().map(|&v| f64::from(v)).collect(),
        crate::clip::ChipPixels::U16(p) => p.iter().map(|&v| f64::from(v)).collect(),
    }
}

/// The mask grown by `r` px (a square neighbourhood).
fn dilate(mask: &[bool], w: usize, h: usize, r: usize) -> Vec<bool> {
    let mut out = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            if mask[y * w + x] {
                for yy in y.saturating_sub(r)..(y + r + 1).min(h) {
                    for xx in x.saturating_sub(r)..(x + r + 1).min(w) {
                        out[yy * w + xx] = true;
                    }
                }
            }
        }
    }
    out
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

/// The mask of a rendered frame as booleans.
fn mask_of(frame: &simulation::RenderedFrame) -> Vec<bool> {
    frame.mask.as_raw().iter().map(|&m| m > 0).collect()
}

/// The body's contrast measured in a chip, in units of the noise measured beside it: the mean of
/// a ring 4-10 px off the mask minus the mean of the mask's interior (mask pixels 1 px from its
/// edge), over the noise from differences of horizontally adjacent ring pixels (which cancel the
/// sky's smooth structure). Positive: darker than the sky.
fn measured_contrast(frame: &simulation::RenderedFrame) -> (f64, f64) {
    let (w, h) = (frame.chip.width as usize, frame.chip.height as usize);
    let v = samples(frame);
    let mask = mask_of(frame);
    let not_mask: Vec<bool> = mask.iter().map(|m| !m).collect();
    let interior: Vec<bool> = dilate(&not_mask, w, h, 1).iter().map(|m| !m).collect();
    let (near, far) = (dilate(&mask, w, h, 3), dilate(&mask, w, h, 10));
    let ring: Vec<bool> = near.iter().zip(&far).map(|(n, f)| !n && *f).collect();
    let pick = |sel: &[bool]| -> Vec<f64> {
        v.iter()
            .zip(sel)
            .filter(|(_, s)| **s)
            .map(|(x, _)| *x)
            .collect()
    };
    let (body, sky) = (pick(&interior), pick(&ring));
    let diffs: Vec<f64> = (0..w * h)
        .filter(|&i| i % w + 1 < w && ring[i] && ring[i + 1])
        .map(|i| v[i + 1] - v[i])
        .collect();
    let noise = libm::sqrt(diffs.iter().map(|d| d * d).sum::<f64>() / diffs.len() as f64 / 2.0);
    assert!(body.len() > 50 && sky.len() > 500);
    ((mean(&sky) - mean(&body)) / noise, noise)
}

#[test]
fn clutter_body_contrast_is_the_requested_number_of_noise_sigmas() {
    // The faint-plume ranges with the plume and filaments taken out, so the ring is sky.
    for (seed, bright) in [(1, false), (2, false), (3, true), (4, false)] {
        let mut s = clutter("clutter-faint-plume", seed, 4);
        s.plume.enabled = false;
        s.randomize.filament_count = None;
        s.filaments.count = 0;
        if bright {
            s.randomize.bright_body_probability = Some(1.0);
        }
        let sim = Simulation::new(s).unwrap();
        let requested = sim.resolved().projectile.contrast_sigma.unwrap();
        assert!((3.0..5.0).contains(&requested));
        let psf = sim.resolved().sensor.psf_sigma_px;
        assert!((0.5..1.5).contains(&psf));
        let measured: Vec<f64> = (0..sim.plans().len())
            .map(|i| measured_contrast(&sim.render_frame(i).unwrap()).0)
            .collect();
        let m = mean(&measured) * if bright { -1.0 } else { 1.0 };
        eprintln!("seed {seed}: requested {requested:.2}, psf {psf:.2}, measured {measured:?}");
        // The PSF takes up to about a fifth off the interior of a 7 px body; the per-frame
        // jitter is 10 %.
        assert!(
            m > 0.7 * requested && m < 1.15 * requested,
            "seed {seed}: measured {m:.2} sigma, requested {requested:.2} (psf {psf:.2})"
        );
    }
}

#[test]
fn filaments_are_as_dark_as_the_body_and_never_in_the_mask() {
    let mut s = clutter("clutter-faint-plume", 21, 3);
    s.plume.enabled = false;
    s.randomize.filament_count = None;
    s.randomize.psf_sigma_px = Some([0.5, 0.8]);
    s.filaments.count = 4;
    s.filaments.width_px = [1.5, 2.5];
    let with = Simulation::new(s.clone()).unwrap();
    s.filaments.count = 0;
    let without = Simulation::new(s).unwrap();
    for i in 0..with.plans().len() {
        let (a, b) = (
            with.render_frame(i).unwrap(),
            without.render_frame(i).unwrap(),
        );
        assert_eq!(a.mask, b.mask, "the filaments change the mask");
        let (body, noise) = measured_contrast(&b);
        let clutter = with.frame_clutter(i).unwrap();
        let (w, h) = (a.chip.width as usize, a.chip.height as usize);
        let away = dilate(&mask_of(&a), w, h, 6);
        let (va, vb) = (samples(&a), samples(&b));
        // The filaments' cores, away from the body: same noise stream, so the difference of the
        // two chips is the filaments' darkness (plus a little shot-noise difference).
        let core: Vec<f64> = (0..w * h)
            .filter(|&p| !away[p] && clutter.filament_depth((p % w) as f64, (p / w) as f64) > 3.0)
            .map(|p| (vb[p] - va[p]) / noise)
            .collect();
        assert!(core.len() > 100, "frame {i}: {} core pixels", core.len());
        let dark = mean(&core);
        eprintln!("frame {i}: filament cores {dark:.2} sigma, body {body:.2} sigma");
        assert!(
            dark > 0.6 * body && dark < 1.6 * body,
            "frame {i}: filament cores {dark:.2} sigma, body {body:.2} sigma"
        );
    }
}

#[test]
fn terrain_enters_at_the_lower_edge_and_a_second_object_crosses() {
    let scenario = clutter("clutter-terrain", 31, 12);
    let sim = Simulation::new(scenario.clone()).unwrap();
    let mut alone = scenario;
    alone.randomize.second_object_probability = Some(0.0);
    let alone = Simulation::new(alone).unwrap();
    let s = sim.resolved();
    assert!(s.near_terrain.enabled);
    let noise = sim.frame_clutter(0).unwrap().noise;
    let mut crossed = 0;
    for i in 0..sim.plans().len() {
        let frame = sim.render_frame(i).unwrap();
        let (w, h) = (frame.chip.width as usize, frame.chip.height as usize);
        let v = samples(&frame);
        let rows = |r: std::ops::Range<usize>| mean(&v[r.start * w..r.end * w]);
        let (bottom, top) = (rows(h - 4..h), rows(0..h / 4));
        // Sky noise in counts: the model's sigma at the top rows' level.
        let radiance_per_count = 1.0 / 255.0 * s.sensor.full_well_e / noise.electrons_per_radiance;
        let sigma_counts = noise.sigma(top * radiance_per_count) / radiance_per_count;
        assert!(
            top - bottom > 10.0 * sigma_counts,
            "frame {i}: bottom rows {bottom:.1}, top {top:.1} (sigma {sigma_counts:.2})"
        );
        // The terrain stays low: the chip's second quarter is still far brighter than its foot.
        assert!(
            rows(h / 4..h / 2) - bottom > 10.0 * sigma_counts,
            "frame {i}"
        );
        // The second object, where it covers the chip away from the body, darkens it by its
        // contrast (the same frame without it has the same noise stream).
        let clutter = sim.frame_clutter(i).unwrap();
        let away = dilate(&mask_of(&frame), w, h, 8);
        let without = samples(&alone.render_frame(i).unwrap());
        let covered: Vec<f64> = (0..w * h)
            .filter(|&p| !away[p] && clutter.mover_coverage((p % w) as f64, (p / w) as f64) > 0.99)
            .map(|p| (without[p] - v[p]) / sigma_counts)
            .collect();
        if covered.len() > 10 {
            crossed += 1;
            let dark = mean(&covered);
            let requested = s.second_object.contrast_sigma;
            assert!(
                dark > 0.5 * requested && dark < 1.3 * requested,
                "frame {i}: the object is {dark:.2} sigma darker, requested {requested}"
            );
        }
    }
    assert!(crossed >= 2, "the second object shows in {crossed} frames");
}

#[test]
fn the_plume_is_outside_the_mask_and_both_plume_polarities_render() {
    for dark in [false, true] {
        let mut s = clutter("clutter-faint-plume", 41, 2);
        s.randomize.dark_plume_probability = Some(if dark { 1.0 } else { 0.0 });
        s.randomize.plume_brightness = Some([0.5, 0.5]);
        s.randomize.filament_count = None;
        s.filaments.count = 0;
        let with = Simulation::new(s.clone()).unwrap();
        s.plume.enabled = false;
        let without = Simulation::new(s).unwrap();
        for i in 0..2 {
            let (a, b) = (
                with.render_radiance(i).unwrap(),
                without.render_radiance(i).unwrap(),
            );
            assert_eq!(a.mask, b.mask, "the plume changes the mask");
            let noise = with.frame_clutter(i).unwrap().noise;
            let plume: Vec<f64> = a
                .radiance
                .iter()
                .zip(&b.radiance)
                .zip(&a.mask)
                .filter(|(_, m)| !**m)
                .map(|((x, y), _)| (x - y) / noise.sigma(*y))
                .collect();
            let strong = plume.iter().filter(|d| d.abs() > 10.0).count();
            let wrong_way = plume
                .iter()
                .filter(|d| (**d > 1.0 && dark) || (**d < -1.0 && !dark))
                .count();
            assert!(strong > 20, "dark {dark}, frame {i}: {strong} plume pixels");
            assert_eq!(wrong_way, 0, "dark {dark}, frame {i}");
        }
    }
}

#[test]
fn clutter_clips_are_deterministic_and_the_seed_redraws_the_physics() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    let s = clutter("clutter-random", 51, 3);
    Simulation::new(s.clone())
        .unwrap()
        .write_clip(&a, 1)
        .unwrap();
    Simulation::new(s.clone())
        .unwrap()
        .write_clip(&b, 2)
        .unwrap();
    assert!(files(&a) == files(&b), "same seed, different bytes");
    let draws: Vec<Scenario> = (0..12)
        .map(|seed| {
            Simulation::new(clutter("clutter-random", seed, 1))
                .unwrap()
                .resolved()
                .clone()
        })
        .collect();
    let distinct = |f: &dyn Fn(&Scenario) -> String| {
        let mut v: Vec<String> = draws.iter().map(f).collect();
        v.sort();
        v.dedup();
        v.len()
    };
    assert!(distinct(&|s| format!("{:.6}", s.sensor.psf_sigma_px)) == 12);
    assert!(distinct(&|s| format!("{:?}", s.projectile.polarity)) == 2);
    assert!(distinct(&|s| format!("{:?}", s.plume.polarity)) == 2);
    assert!(distinct(&|s| format!("{}", s.near_terrain.enabled)) == 2);
    assert!(distinct(&|s| format!("{}", s.filaments.count)) >= 4);
}
