//! The lookup-table parser, `Table::parse` and `Table::parse_for`, on raw bytes, on tables
//! assembled from fuzzer-chosen header fields and entries, and on the bundled table with bytes
//! changed, the last two with their checksum made right so that the checks behind it are
//! reached. A table that parses has every accessor read over its whole grid, and one that parses
//! for the reference projectile refines a fixed synthesized frame (the matcher on hostile
//! entries) and draws the grid's corner entries where the match placed the silhouette.
#![no_main]

use arbitrary::Arbitrary;
use imade_core::closed_form::{self, ClosedForm};
use imade_core::extremes::{self, Silhouette};
use imade_core::lut::render;
use imade_core::lut::table::{CRC, HEADER_LEN, MAGIC, MODEL_ID_LEN, Table, VERSION, entry_len};
use imade_core::lut::{self, Frame};
use imade_core::mask::ChipMask;
use imade_core::segment::Segmenter;
use imade_core::segment::background::Background;
use imade_core::{Camera, Config, REF_1378X80};
use imade_core_fuzz::synth::{self, ChipSpec, Raw, Shape};
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

#[derive(Arbitrary, Debug)]
struct Header {
    version: Option<u16>,
    header_len: Option<u16>,
    other_model: bool,
    diameter_m: Option<f32>,
    length_m: Option<f32>,
    /// Grid, modulo 40 tilts, 24 rolls and 260 stations.
    tilts: u8,
    rolls: u8,
    stations: u16,
    v_quantum: f32,
    /// Bytes added to (positive) or cut from (negative) the implied length.
    length_error: i8,
}

/// Assembles a table from `header` and `entries` and writes its checksum.
fn build(header: &Header, entries: &[u8]) -> Vec<u8> {
    let (tilts, rolls) = (
        usize::from(header.tilts % 40),
        usize::from(header.rolls % 24),
    );
    let stations = usize::from(header.stations % 260);
    let mut bytes = vec![0u8; HEADER_LEN];
    bytes[..8].copy_from_slice(&MAGIC);
    let put16 =
        |b: &mut Vec<u8>, at: usize, v: u16| b[at..at + 2].copy_from_slice(&v.to_le_bytes());
    let put32 =
        |b: &mut Vec<u8>, at: usize, v: f32| b[at..at + 4].copy_from_slice(&v.to_le_bytes());
    put16(&mut bytes, 8, header.version.unwrap_or(VERSION));
    put16(
        &mut bytes,
        10,
        header.header_len.unwrap_or(HEADER_LEN as u16),
    );
    let id = if header.other_model {
        "other"
    } else {
        REF_1378X80.id
    };
    let id = &id.as_bytes()[..id.len().min(MODEL_ID_LEN)];
    bytes[12..12 + id.len()].copy_from_slice(id);
    put32(
        &mut bytes,
        44,
        header.diameter_m.unwrap_or(REF_1378X80.diameter_m),
    );
    put32(
        &mut bytes,
        48,
        header.length_m.unwrap_or(REF_1378X80.length_m),
    );
    put16(&mut bytes, 52, tilts as u16);
    put16(&mut bytes, 54, rolls as u16);
    put16(&mut bytes, 56, stations as u16);
    put32(&mut bytes, 60, header.v_quantum);
    let body =
        (tilts * rolls * entry_len(stations)).saturating_add_signed(header.length_error.into());
    bytes.extend(entries.iter().copied().cycle().take(body));
    bytes.resize(HEADER_LEN + body, 0);
    with_checksum(bytes)
}

/// Appends the CRC of `bytes`.
fn with_checksum(mut bytes: Vec<u8>) -> Vec<u8> {
    let crc = CRC.checksum(&bytes);
    bytes.extend(crc.to_le_bytes());
    bytes
}

/// A synthesized frame of the reference projectile at 1 km, measured up to the closed form.
struct Prepared {
    chip: synth::Chip,
    background: Background,
    silhouette: Silhouette,
    class: i8,
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
        let mut mask = Box::new(ChipMask::new());
        let target = segmenter
            .detect(&view, &Config::DEFAULT, (128.0, 128.0), &mut mask)
            .expect("the projectile is found");
        let background = segmenter.background().clone();
        let silhouette = extremes::measure(&view, &background, &target, &REF_1378X80, None)
            .expect("the projectile is measured");
        let range =
            closed_form::range_from_diameter(&silhouette, &CAMERA, &REF_1378X80).expect("a range");
        let closed = closed_form::solve(&silhouette, ORIGIN, &CAMERA, &REF_1378X80, range);
        Prepared {
            chip,
            background,
            silhouette,
            class: target.class,
            closed,
        }
    })
}

/// Reads every accessor of a parsed table over its grid (and past it: indices are clamped).
fn read_all(table: &Table) {
    for i in 0..=table.tilts() {
        let _ = table.tilt_deg(i);
        for j in 0..=table.rolls() {
            let _ = table.roll_deg(j);
            let entry = table.entry(i, j);
            let (lo, hi) = entry.u_range();
            for s in 0..=entry.stations() {
                let _ = entry.edges(s);
            }
            for u in [
                lo,
                hi,
                0.5 * (lo + hi),
                lo - 1.0,
                hi + 1.0,
                f32::NAN,
                f32::INFINITY,
            ] {
                let _ = entry.edges_at(u);
            }
        }
    }
    let _ = table.model_id();
}

/// Refines the prepared frame against `table` and draws entries at the matched placement.
fn refine(table: &Table, range_m: Option<u16>) {
    let p = prepared();
    let view = p.chip.view(ORIGIN).expect("a valid chip");
    let frame = Frame {
        chip: &view,
        background: &p.background,
        silhouette: &p.silhouette,
        class: p.class,
        origin: ORIGIN,
    };
    let range = range_m.map(f32::from);
    let Ok(refined) = lut::refine(&frame, table, &REF_1378X80, &CAMERA, &p.closed, range) else {
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
    let _ = refined.at_range(&CAMERA, &REF_1378X80, refined.range_m);
}

fn check(bytes: &[u8], range_m: Option<u16>) {
    if let Ok(table) = Table::parse(bytes) {
        read_all(&table);
    }
    if let Ok(table) = Table::parse_for(bytes, &REF_1378X80) {
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
