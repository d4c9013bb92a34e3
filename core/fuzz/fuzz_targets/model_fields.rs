//! Model files assembled field by field ([`imade_core_fuzz::model`]): the parser on each, every
//! accessor of the ones it accepts, and a frame of a synthesized chip through a pipeline built
//! with that model (no table: a table belongs to one model). Every result is checked by the
//! oracle.
#![no_main]

use arbitrary::Arbitrary;
use imade_core::mask::ChipMask;
use imade_core::{Camera, Config, FrameInput, Pipeline, ProjectileModel};
use imade_core_fuzz::model::{ModelSpec, build};
use imade_core_fuzz::{oracle, synth};
use libfuzzer_sys::fuzz_target;

#[derive(Arbitrary, Debug)]
struct Input {
    model: ModelSpec,
    chip: synth::ChipSpec,
    origin: (i16, i16),
    range_m: Option<u16>,
}

/// Reads every accessor of `model`.
fn read_all(model: &ProjectileModel) {
    let _ = (
        model.id(),
        model.radius_m(),
        model.base_radius_m(),
        model.max_radius_m(),
    );
    let _ = (model.fins(), model.distinct_roll_deg(), model.cylinder_s());
    for i in 0..=model.stations() {
        let _ = model.station(i);
    }
    for k in -1..=65 {
        let _ = model.radius_at(model.length_m * k as f32 / 64.0);
    }
    let _ = model.nose_ramp_zero_offset_m(0.2, 0.65);
}

fuzz_target!(|input: Input| {
    let bytes = build(&input.model);
    if ProjectileModel::parse(&bytes).is_err() {
        return;
    }
    // The pipeline holds a `'static` model (in flash on the firmware): an accepted file's bytes
    // (at most 644) are leaked, about 64 MB per 100,000 accepted inputs.
    let bytes: &'static [u8] = Vec::leak(bytes);
    let Ok(model) = ProjectileModel::parse(bytes) else {
        return;
    };
    read_all(&model);
    let camera = Camera {
        fx: 100000.0,
        fy: 100000.0,
        cx: 1023.5,
        cy: 1023.5,
    };
    let mut pipeline: Box<Pipeline> = Box::new(Pipeline::new(Config::DEFAULT, camera, model));
    let mut scratch = Box::new(ChipMask::new());
    let chip = synth::synthesize(&input.chip, &mut scratch);
    let origin = (i32::from(input.origin.0), i32::from(input.origin.1));
    let Ok(view) = chip.view(origin) else {
        return;
    };
    let result = pipeline.process(&FrameInput {
        chip: view,
        time_s: 0.0,
        range_m: input.range_m.map(f32::from),
        mount: None,
    });
    oracle::check(&pipeline, &view, &result);
});
