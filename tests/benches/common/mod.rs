//! Fixture chips for the benchmarks: a bundled clip (by default `fixtures/table1-test`, or the
//! folder named by `IMADE_BENCH_CLIP`), read through imade-host's clip reader, the one place the
//! clip format is parsed.

pub mod cpu;

use cpu::ThreadCpuTime;
use criterion::Bencher;
use imade_core::lut::table::Table;
use imade_core::{Camera, ChipView, Config, FrameInput, Pipeline, ProjectileModel};
use imade_host::clip::{ChipImage, Clip, ClipMeta, load_chip};
use std::hint::black_box;
use std::path::PathBuf;

/// One decoded frame of the clip.
pub struct Frame {
    /// The chip's pixels.
    pub image: ChipImage,
    /// Full-frame pixel of the chip's top-left pixel.
    pub origin: (i32, i32),
    /// Capture time, s.
    pub time_s: f64,
    /// Range-sensor slant range, m, where the clip has one.
    pub range_m: Option<f32>,
}

impl Frame {
    /// The chip as a core view.
    pub fn view(&self) -> ChipView<'_> {
        self.image
            .view(self.origin.0, self.origin.1)
            .expect("fixture chips fit the core")
    }

    /// The frame as the pipeline's input.
    pub fn input(&self) -> FrameInput<'_> {
        FrameInput {
            chip: self.view(),
            time_s: self.time_s,
            range_m: self.range_m,
            mount: None,
        }
    }
}

/// A clip decoded into memory.
pub struct Fixture {
    /// The clip's metadata.
    pub meta: ClipMeta,
    /// Camera intrinsics.
    pub camera: Camera,
    /// The projectile.
    pub model: ProjectileModel<'static>,
    /// The projectile's bundled silhouette table, where there is one.
    pub table: Option<Table<'static>>,
    /// Every frame, in clip order.
    pub frames: Vec<Frame>,
}

/// The clip folder the benchmarks run on.
pub fn clip_dir() -> PathBuf {
    std::env::var_os("IMADE_BENCH_CLIP").map_or_else(
        || PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fixtures/table1-test"),
        PathBuf::from,
    )
}

/// Loads the benchmark clip; a missing or broken fixture stops the benchmark with its error.
pub fn load() -> Fixture {
    let dir = clip_dir();
    let clip = Clip::open(&dir).unwrap_or_else(|e| panic!("{}: {e:#}", dir.display()));
    let camera = clip.meta.camera.camera();
    let model = clip.model("bundled").unwrap_or_else(|e| panic!("{e:#}"));
    let table = model.table();
    let frames = clip
        .frames
        .iter()
        .map(|row| {
            let row = row.as_ref().expect("fixture rows are well formed");
            let path = clip.path_of(&row.chip);
            Frame {
                image: load_chip(&path).unwrap_or_else(|e| panic!("{e:#}")),
                origin: (row.chip_x0 as i32, row.chip_y0 as i32),
                time_s: row.time_s,
                range_m: row.range_m.map(|r| r as f32),
            }
        })
        .collect();
    Fixture {
        meta: clip.meta.clone(),
        camera,
        model,
        table,
        frames,
    }
}

/// Times `Pipeline::process` on the fixture's frames in turn, with `config` and, where given,
/// `table`.
pub fn bench_frames(
    b: &mut Bencher<ThreadCpuTime>,
    fixture: &Fixture,
    config: Config,
    table: Option<Table<'static>>,
) {
    let pipeline = Pipeline::new(config, fixture.camera, fixture.model);
    let mut pipeline: Box<Pipeline> = Box::new(match table {
        Some(t) => pipeline.with_table(t),
        None => pipeline,
    });
    pipeline.set_tetris(imade_tests::bundled_tetris());
    let mut frames = fixture.frames.iter().cycle();
    b.iter(|| {
        let frame = frames.next().expect("a clip with frames");
        black_box(pipeline.process(&black_box(frame.input())))
    });
}
