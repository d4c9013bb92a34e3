//! Time per frame of each shape-guided segmentation method (the source paper's Table 2 reports
//! GVF-ASM at 0.12 fps and SIS-Cut at 0.18 fps in Matlab):
//!
//! - `shape_guided/<method>`: the method alone on a synthetic 256 x 256 chip of the reference
//!   projectile at 1 km (about 138 px long, as in the Table 1 clip), with a prior drawn at a wrong
//!   placement: 3 px off, 6 % too large and turned by 4 deg;
//! - `frame_refine/<method>`: the whole frame (`Pipeline::process` with the bundled table and
//!   `GuidedLoopConfig::method` = the method, `none` included), cycling through the bundled `table1-test`
//!   clip (`IMADE_BENCH_CLIP` names another).
//!
//! Times are the benchmark thread's CPU time, one core.
//!
//! `cargo bench -p imade-tests --bench shape_guided`

// Shared with the other benchmarks; not every item is used here.
#[allow(dead_code)]
mod common;

use common::cpu::ThreadCpuTime;
use criterion::{Criterion, criterion_group, criterion_main};
use imade_core::lut::render::{Placement, View, draw};
use imade_core::shape_guided::{ShapeGuided, ShapeGuidedConfig};
use imade_core::{ChipMask, ChipView, Config, GuidedMethod, ImagePoint};
use std::hint::black_box;
use std::time::Duration;

/// Chip side, px.
const SIDE: usize = 256;
/// Supersampling of the chip's coverage.
const SS: usize = 2;
/// Sky and body grey levels.
const SKY: f32 = 170.0;
const BODY: f32 = 60.0;

/// The model at 30 deg tilt, roll 20 deg, axis at -35 deg in the image, 100 px per metre
/// (1 km at fx = 100000 px), origin at `origin` chip px, scaled by `scale` and turned by
/// `turn_deg`, drawn into `target` at `ss` samples per px.
fn silhouette(target: &mut ChipMask, ss: usize, origin: (f32, f32), scale: f32, turn_deg: f32) {
    let angle = (-35.0f32 + turn_deg).to_radians();
    let placement = Placement {
        origin: ImagePoint::new(origin.0 * ss as f32, origin.1 * ss as f32),
        dir: ImagePoint::new(angle.cos(), angle.sin()),
        px_per_unit: 100.0 * scale * ss as f32,
    };
    let view = View {
        tilt_deg: 30.0,
        roll_deg: 20.0,
    };
    target
        .reset(SIDE * ss, SIDE * ss)
        .expect("fits the chip mask");
    draw(target, &imade_tests::reference_model(), &view, &placement).expect("infallible");
}

/// The chip (coverage-shaded, a 3-tap blur, deterministic noise of about 2 grey levels) and
/// the wrong prior.
fn scene() -> (Vec<u8>, ChipMask) {
    let mut fine = ChipMask::new();
    silhouette(&mut fine, SS, (128.0, 128.0), 1.0, 0.0);
    let coverage: Vec<f32> = (0..SIDE * SIDE)
        .map(|k| {
            let (x, y) = (k % SIDE, k / SIDE);
            let hits = (0..SS * SS)
                .filter(|s| fine.get(x * SS + s % SS, y * SS + s / SS))
                .count();
            hits as f32 / (SS * SS) as f32
        })
        .collect();
    let at = |x: usize, y: usize| coverage[y.min(SIDE - 1) * SIDE + x.min(SIDE - 1)];
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let pixels = (0..SIDE * SIDE)
        .map(|k| {
            let (x, y) = (k % SIDE, k / SIDE);
            let c = 0.5 * at(x, y)
                + 0.125
                    * (at(x + 1, y)
                        + at(x.saturating_sub(1), y)
                        + at(x, y + 1)
                        + at(x, y.saturating_sub(1)));
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let noise = ((state >> 40) as f32 / (1u64 << 24) as f32 - 0.5) * 7.0;
            (SKY + (BODY - SKY) * c + noise).round().clamp(0.0, 255.0) as u8
        })
        .collect();
    let mut prior = ChipMask::new();
    silhouette(&mut prior, 1, (130.5, 126.0), 1.06, 4.0);
    (pixels, prior)
}

fn bench(c: &mut Criterion<ThreadCpuTime>) {
    let (pixels, prior) = scene();
    let chip = ChipView::gray8(&pixels, SIDE, SIDE, SIDE, 896, 896).expect("chip");
    let config = ShapeGuidedConfig::DEFAULT;
    let mut sg = Box::new(ShapeGuided::new());
    sg.set_tetris(imade_tests::bundled_tetris());
    let mut out = ChipMask::new();
    let mut group = c.benchmark_group("shape_guided");
    group.sample_size(20);
    for method in GuidedMethod::ALL {
        group.bench_function(method.as_str(), |b| {
            b.iter(|| {
                let r = sg.segment(
                    method,
                    &config,
                    black_box(&chip),
                    black_box(&prior),
                    &mut out,
                );
                black_box(r).expect("refines")
            })
        });
    }
    group.finish();
}

fn frame_refine(c: &mut Criterion<ThreadCpuTime>) {
    let fixture = common::load();
    let table = fixture
        .table
        .expect("the clip's projectile has a bundled table");
    let mut group = c.benchmark_group("frame_refine");
    group.sample_size(20);
    for method in [None].into_iter().chain(GuidedMethod::ALL.map(Some)) {
        group.bench_function(method.map_or("none", |m| m.as_str()), |b| {
            // Without the grey-level fit (about 130 ms a frame here), whose cost would hide the
            // loop's: the paper's pipeline, detection to the refined match.
            let mut config = Config::DEFAULT.with_guided_method(method);
            config.grey_fit.enabled = false;
            common::bench_frames(b, &fixture, config, Some(table));
        });
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .with_measurement(ThreadCpuTime::default())
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(4));
    targets = bench, frame_refine
}
criterion_main!(benches);
