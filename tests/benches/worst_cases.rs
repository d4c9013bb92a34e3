//! Time per frame of the whole pipeline on worst-case chips: uniform, saturated, checkerboards
//! and noise that maximize components and runs, capacity overflows, the largest chip, the largest
//! target, a target cut by the chip border and two projectiles in one chip (the last two made
//! from a fixture chip). The pipeline is `imade run`'s default: with the bundled silhouette
//! table where there is one. Each case's status is printed once; the slowest case bounds the
//! frame time on the host.
//!
//! `cargo bench -p imade-tests --bench worst_cases`; with `IMADE_WORST_CLIP=DIR` the chips of
//! the fixture's size and depth are also written to DIR as an imade-clip/1 clip, one frame each,
//! for `firmware-sim/run` to count their instructions on the Cortex-M4F.

// Shared with the stage benchmarks; not every item is used here.
#[allow(dead_code)]
mod common;

use common::Fixture;
use common::cpu::ThreadCpuTime;
use criterion::{Criterion, criterion_group, criterion_main};
use imade_core::{ChipView, Config, FrameInput, Pipeline};
use imade_host::clip::{ChipImage, ChipPixels, ClipWriter, FrameRow};
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

/// A worst-case chip.
struct Case {
    name: &'static str,
    width: usize,
    height: usize,
    pixels: ChipPixels,
}

impl Case {
    fn u8(name: &'static str, side: usize, f: impl Fn(usize, usize) -> u8) -> Case {
        let pixels = (0..side * side).map(|i| f(i % side, i / side)).collect();
        Case {
            name,
            width: side,
            height: side,
            pixels: ChipPixels::U8(pixels),
        }
    }

    fn u16(name: &'static str, side: usize, f: impl Fn(usize, usize) -> u16) -> Case {
        let pixels = (0..side * side).map(|i| f(i % side, i / side)).collect();
        Case {
            name,
            width: side,
            height: side,
            pixels: ChipPixels::U16(pixels),
        }
    }

    fn view(&self) -> ChipView<'_> {
        let (w, h) = (self.width, self.height);
        match &self.pixels {
            ChipPixels::U8(p) => ChipView::gray8(p, w, h, w, 0, 0),
            ChipPixels::U16(p) => ChipView::gray16(p, w, h, w, 0, 0),
        }
        .expect("worst-case chips fit the core")
    }
}

/// A deterministic hash of a pixel position (SplitMix64 finalizer): reproducible noise.
fn hash(x: usize, y: usize) -> u64 {
    let mut z = ((y as u64) << 32 | x as u64).wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Approximately Gaussian noise with unit deviation (sum of four uniforms).
fn gaussian(x: usize, y: usize) -> f32 {
    let h = hash(x, y);
    let sum: f32 = (0..4)
        .map(|k| ((h >> (16 * k)) & 0xFFFF) as f32 / 65535.0)
        .sum();
    (sum - 2.0) * 3.0f32.sqrt()
}

fn cases(fixture: &Fixture) -> Vec<Case> {
    let frame = &fixture.frames[fixture.frames.len() / 2];
    let ChipPixels::U8(chip) = &frame.image.pixels else {
        panic!("the fixture chips are 8-bit");
    };
    let side = frame.image.width as usize;
    let at = |x: usize, y: usize| chip[(y % side) * side + x % side];
    let checker = |cell: usize| move |x: usize, y: usize| [250u8, 5][(x / cell + y / cell) % 2];
    vec![
        Case::u8("fixture", side, at),
        Case::u8("black", 256, |_, _| 0),
        Case::u8("white", 256, |_, _| 255),
        Case::u16("white16_512", 512, |_, _| u16::MAX),
        Case::u8("checker1", 256, checker(1)),
        Case::u8("checker2", 256, checker(2)),
        Case::u8("checker4", 256, checker(4)),
        // Isolated dark pixels every 5th column of every 3rd row: 4400 labels.
        Case::u8(
            "salt",
            256,
            |x, y| {
                if y % 3 == 0 && x % 5 == 0 { 0 } else { 200 }
            },
        ),
        // 63 dark 3 x 3 blobs: every one a candidate, just under the component capacity.
        Case::u8("blobs63", 256, |x, y| {
            let (cx, cy) = (x / 32, y / 32);
            let blob = cx * 8 + cy < 63 && x % 32 < 3 && y % 32 < 3;
            if blob { 20 } else { 200 }
        }),
        Case::u8("noise_uniform", 256, |x, y| hash(x, y) as u8),
        Case::u8("noise_gauss", 256, |x, y| {
            (120.0 + 3.0 * gaussian(x, y)) as u8
        }),
        Case::u16("noise_uniform16_512", 512, |x, y| hash(x, y) as u16),
        // The largest target: a dark bar 40 px wide along the diagonal of the largest chip.
        Case::u16("bar16_512", 512, |x, y| {
            let across = (x as f32 - y as f32).abs() / std::f32::consts::SQRT_2;
            let sky = 30000.0 + 40.0 * gaussian(x, y);
            (if across < 20.0 { sky - 20000.0 } else { sky }) as u16
        }),
        // A steep 16-bit sky gradient clipped to black over a third of the chip (found by
        // fuzzing: a false target whose shape prior spans thousands of pixels).
        Case::u16("gradient16", 256, |x, y| {
            (61245 - 16 * x as i64 - 160 * y as i64).clamp(0, 65535) as u16
        }),
        // The fixture's body cut by the left border: the chip moved 128 px left, wrapping.
        Case::u8("border", side, |x, y| at(x + 128, y)),
        // A second projectile: the darker of the chip and itself moved 60 px right, 40 px down.
        Case::u8("two", side, |x, y| {
            at(x, y).min(at(x + side - 60, y + side - 40))
        }),
    ]
}

/// Writes the cases of the fixture's chip size and depth as a clip in `dir`, one frame each.
fn write_clip(dir: &Path, fixture: &Fixture, cases: &[Case]) -> anyhow::Result<()> {
    let mut writer = ClipWriter::create(dir, &fixture.meta)?;
    let like = &fixture.frames[fixture.frames.len() / 2];
    let same_kind = |c: &&Case| {
        (c.width as u32, c.height as u32) == (like.image.width, like.image.height)
            && matches!(c.pixels, ChipPixels::U8(_))
    };
    for (k, case) in cases.iter().filter(same_kind).enumerate() {
        let row = FrameRow {
            line: k as u64 + 2,
            frame: k as u64,
            time_s: k as f64 / 30.0,
            chip: String::new(),
            chip_x0: i64::from(like.origin.0),
            chip_y0: i64::from(like.origin.1),
            range_m: None,
            mount: None,
            truth: None,
            gt_mask: None,
            truth_aoa: None,
        };
        let chip = ChipImage {
            width: case.width as u32,
            height: case.height as u32,
            pixels: case.pixels.clone(),
        };
        writer.write_frame(&row, &chip, None)?;
        eprintln!("worst clip frame {k}: {}", case.name);
    }
    writer.finish()?;
    Ok(())
}

fn worst_cases(c: &mut Criterion<ThreadCpuTime>) {
    let fixture = common::load();
    let cases = cases(&fixture);
    if let Some(dir) = std::env::var_os("IMADE_WORST_CLIP") {
        write_clip(Path::new(&dir), &fixture, &cases).unwrap_or_else(|e| panic!("{e:#}"));
    }
    let mut group = c.benchmark_group("worst");
    for case in &cases {
        let pipeline = Pipeline::new(Config::DEFAULT, fixture.camera, fixture.model);
        let mut pipeline: Box<Pipeline> = Box::new(match fixture.table {
            Some(table) => pipeline.with_table(table),
            None => pipeline,
        });
        let mut time_s = 0.0;
        let mut frame = || {
            time_s += 1.0 / 30.0;
            pipeline.process(&FrameInput {
                chip: case.view(),
                time_s,
                range_m: None,
                mount: None,
            })
        };
        let result = frame();
        eprintln!(
            "worst/{}: {}x{}, status {}{}",
            case.name,
            case.width,
            case.height,
            result.status.as_str(),
            result
                .capacity
                .map(|k| format!(" ({k:?})"))
                .unwrap_or_default()
        );
        group.bench_function(case.name, |b| b.iter(|| black_box(frame())));
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .with_measurement(ThreadCpuTime::default())
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    targets = worst_cases
}
criterion_main!(benches);
