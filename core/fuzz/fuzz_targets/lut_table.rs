//! The lookup-table parser and the table match behind it: `Table::parse` (and the reference model's check of the table)
//! on raw bytes, on tables assembled from fuzzer-chosen header fields and entries, and on the
//! bundled table with bytes changed, the last two with their checksum made right so that the checks behind it are
//! reached. A table that parses has every accessor read over its whole grid, and one that parses
//! for the reference projectile refines a fixed synthesized frame (the matcher on hostile
//! entries) and draws the grid's corner entries where the match placed the silhouette. A patched
//! bundled table costs milliseconds an input (checksums and a match over 321 KB); `lut_parse`
//! fuzzes the parser alone, thousands of times faster.
#![no_main]

use arbitrary::Arbitrary;
use imade_core::closed_form::{self, ClosedForm};
use imade_core::extremes::{self, Silhouette};
use imade_core::lut::render;
use imade_core::lut::table::Table;
use imade_core::mask::ChipMask;
use imade_core::segment::background::Background;
use imade_core::segment::{Expectation, Segmenter};
use imade_core::table_match::{MatchConfig, MatchInput, pose};
use imade_core::{BodyPolarity, Camera, Config, ImagePoint};
use imade_core_fuzz::reference;
use imade_core_fuzz::synth::{self, ChipSpec, Raw, Shape};
use imade_core_fuzz::table::{Header, build, read_all, with_checksum};
use libfuzzer_sys::fuzz_target;
use std::sync::OnceLock;

static TABLE_BYTES: &[u8] = include_bytes!("../../../fixtures/lut/ref-1378x80.lut");

const CAMERA: Camera = Camera {
    fx: 100000.0,
    fy: 100000.0,
    cx: 1023.5,
    cy: 1023.5,
};
/// Full-frame pixel of the synthesized chip's top-left.
const ORIGIN: (i32, i32) = (896, 896);

#[derive(Arbitrary, Debug)]
enum Input {
    /// Bytes parsed as they are.
    Raw(Vec<u8>),
    /// A table assembled from fields, its entries repeating `entries`, its checksum right.
    Built {
        header: Header,
        entries: Vec<u8>,
        range_m: Option<u16>,
    },
    /// The bundled table with `(offset, byte)` changes, its checksum right.
    Patched {
        patches: Vec<(u32, u8)>,
        range_m: Option<u16>,
    },
}

/// A synthesized frame of the reference projectile at 1 km, measured up to the closed form.
struct Prepared {
    chip: synth::Chip,
    background: Background,
    silhouette: Silhouette,
    polarity: BodyPolarity,
    closed: ClosedForm,
}

fn prepared() -> &'static Prepared {
    static PREPARED: OnceLock<Prepared> = OnceLock::new();
    PREPARED.get_or_init(|| {
        let spec = ChipSpec {
            size: (256, 256),
            large: 0,
            pad: 0,
            cut: 0,
            wide: false,
            sky: 180 * 257,
            gradient: (3, -2),
            noise: 0,
            seed: 7,
            blur: true,
            shapes: vec![Shape::Projectile {
                centre: (128, 120),
                px_per_m: 100,
                angle: 7000,
                tilt: 25,
                roll: 30,
                level: -110 * 128,
            }],
            raw: Raw {
                at: 0,
                bytes: Vec::new(),
            },
        };
        let chip = synth::synthesize(&spec, &mut ChipMask::new());
        let view = chip.view(ORIGIN).expect("a valid chip");
        let mut segmenter: Box<Segmenter> = Box::default();
        let target = segmenter
            .detect(
                &view,
                &Config::DEFAULT.detect,
                ImagePoint::new(128.0, 128.0),
                &Expectation::NONE,
            )
            .expect("the projectile is found");
        let background = segmenter.background().clone();
        let config = Config::DEFAULT.silhouette;
        let silhouette = extremes::measure(
            &view,
            &background,
            &target,
            &reference(),
            &extremes::Prior::default(),
            &config,
        )
        .expect("the projectile is measured");
        let range =
            closed_form::range_from_diameter(&silhouette, &CAMERA, &reference()).expect("a range");
        let closed = closed_form::solve(&silhouette, ORIGIN, &CAMERA, &reference(), range);
        Prepared {
            chip,
            background,
            silhouette,
            polarity: target.polarity,
            closed,
        }
    })
}

/// Matches the prepared frame against `table` and draws entries at the matched placement.
fn refine(table: &Table, range_m: Option<u16>) {
    let p = prepared();
    let view = p.chip.view(ORIGIN).expect("a valid chip");
    let frame = MatchInput {
        chip: &view,
        background: &p.background,
        silhouette: &p.silhouette,
        polarity: p.polarity,
        origin: ORIGIN,
    };
    let scale = range_m.map_or(pose::MatchScale::Free, |r| {
        pose::MatchScale::Range(f32::from(r))
    });
    let config = MatchConfig::DEFAULT;
    let Ok(refined) = pose::match_pose(
        &frame,
        table,
        &reference(),
        &CAMERA,
        &p.closed,
        scale,
        &config,
    ) else {
        return;
    };
    assert!(
        refined.range_m.is_finite() && refined.range_m > 0.0,
        "{refined:?}"
    );
    let mut prior = Box::new(ChipMask::new());
    prior.reset(256, 256).expect("a chip-sized mask");
    for (i, j) in [(0, 0), (table.tilts(), table.rolls())] {
        let Ok(()) = render::draw_entry(&mut *prior, &table.entry(i, j), &refined.placement);
    }
    let _ = refined.at_range(&CAMERA, &reference(), refined.range_m);
}

fn check(bytes: &[u8], range_m: Option<u16>) {
    if let Ok(table) = Table::parse(bytes) {
        read_all(&table);
    }
    if let Ok(table) = Table::parse(bytes)
        && reference().matches_table(&table)
    {
        refine(&table, range_m);
    }
}

fuzz_target!(|input: Input| match input {
    Input::Raw(bytes) => check(&bytes, None),
    Input::Built {
        header,
        entries,
        range_m,
    } => check(&build(&header, &entries), range_m),
    Input::Patched { patches, range_m } => {
        let mut bytes = TABLE_BYTES[..TABLE_BYTES.len() - 4].to_vec();
        let len = bytes.len();
        for (at, b) in patches {
            bytes[at as usize % len] = b;
        }
        check(&with_checksum(bytes), range_m);
    }
});
