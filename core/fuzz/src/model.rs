//! Model files (`imade-model/1`) assembled from fuzzer-chosen fields, with a valid layout and
//! checksum, so that the parser's checks of the values, the accessors and the stages that read
//! the model are reached (random bytes stop at the magic or the CRC).

use crate::table::with_checksum;
use arbitrary::Arbitrary;
use imade_core::model::format::{FIELD, HEADER_LEN, MAGIC, MODEL_ID_LEN, VERSION};

/// A model's fields.
#[derive(Arbitrary, Debug)]
pub struct ModelSpec {
    /// Model id bytes (any, NUL-padded to the field).
    pub id: Vec<u8>,
    /// The profile: shaped from small numbers, or any floats.
    pub profile: ProfileSpec,
    /// Fin count (any u16; the parser allows up to 16).
    pub fin_count: u16,
    /// Root leading and trailing edge, tip leading and trailing edge (m aft of the tip), tip
    /// radius, thickness (m) and roll of the first fin (deg).
    pub fins: FinSpec,
}

/// The radius profile.
#[derive(Arbitrary, Debug)]
pub enum ProfileSpec {
    /// Length and diameter from small numbers (mm), stations evenly spaced from the tip to the
    /// base with radii `radii[k] / 255` of the largest.
    Shaped {
        /// Length, mm.
        length_mm: u16,
        /// Largest diameter, mm.
        diameter_mm: u16,
        /// Radii, 1/255 of the largest (2 to 64 used).
        radii: Vec<u8>,
    },
    /// Any floats, NaN and infinities included.
    Raw {
        /// Overall length, m.
        length: f32,
        /// Body diameter, m.
        diameter: f32,
        /// (s, radius) stations.
        stations: Vec<(f32, f32)>,
    },
}

/// The fins' planform.
#[derive(Arbitrary, Debug)]
pub enum FinSpec {
    /// Fractions (1/255) of the length for the chords and of the radius for the span.
    Shaped {
        /// Root chord, tip chord, tip offset from the base, tip span: 1/255 of their range.
        fractions: [u8; 4],
        /// Thickness, 0.1 mm.
        thickness: u8,
        /// First fin's roll, deg.
        roll: i8,
    },
    /// Any floats.
    Raw([f32; 7]),
}

/// The model file of `spec`, with no silhouette table, checksummed.
pub fn build(spec: &ModelSpec) -> Vec<u8> {
    let (length, diameter, stations) = profile(&spec.profile);
    let fins = fins(&spec.fins, length, 0.5 * diameter);
    let mut bytes = vec![0u8; HEADER_LEN];
    bytes[..8].copy_from_slice(&MAGIC);
    bytes[8..10].copy_from_slice(&VERSION.to_le_bytes());
    bytes[10..12].copy_from_slice(&(HEADER_LEN as u16).to_le_bytes());
    let id = &spec.id[..spec.id.len().min(MODEL_ID_LEN)];
    bytes[FIELD.id..FIELD.id + id.len()].copy_from_slice(id);
    let mut put = |at: usize, v: f32| bytes[at..at + 4].copy_from_slice(&v.to_le_bytes());
    put(FIELD.length, length);
    put(FIELD.diameter, diameter);
    for (at, v) in [
        FIELD.fin_root_le,
        FIELD.fin_root_te,
        FIELD.fin_tip_le,
        FIELD.fin_tip_te,
        FIELD.fin_tip_radius,
        FIELD.fin_thickness,
        FIELD.fin_first_roll,
    ]
    .into_iter()
    .zip(fins)
    {
        put(at, v);
    }
    let count = stations.len().min(usize::from(u16::MAX)) as u16;
    bytes[FIELD.stations..FIELD.stations + 2].copy_from_slice(&count.to_le_bytes());
    bytes[FIELD.fin_count..FIELD.fin_count + 2].copy_from_slice(&spec.fin_count.to_le_bytes());
    for (s, r) in stations {
        bytes.extend(s.to_le_bytes());
        bytes.extend(r.to_le_bytes());
    }
    with_checksum(bytes)
}

/// Length, diameter and stations of the profile.
fn profile(spec: &ProfileSpec) -> (f32, f32, Vec<(f32, f32)>) {
    match spec {
        ProfileSpec::Shaped {
            length_mm,
            diameter_mm,
            radii,
        } => {
            let length = f32::from(*length_mm) / 1000.0;
            let diameter = f32::from(*diameter_mm) / 1000.0;
            let radii = &radii[..radii.len().min(64)];
            let last = radii.len().saturating_sub(1).max(1) as f32;
            let stations = radii
                .iter()
                .enumerate()
                .map(|(k, &r)| {
                    (
                        length * k as f32 / last,
                        0.5 * diameter * f32::from(r) / 255.0,
                    )
                })
                .collect();
            (length, diameter, stations)
        }
        ProfileSpec::Raw {
            length,
            diameter,
            stations,
        } => (
            *length,
            *diameter,
            stations.iter().take(70).copied().collect(),
        ),
    }
}

/// The seven fin fields.
fn fins(spec: &FinSpec, length: f32, radius: f32) -> [f32; 7] {
    match *spec {
        FinSpec::Shaped {
            fractions,
            thickness,
            roll,
        } => {
            let f = |k: usize| f32::from(fractions[k]) / 255.0;
            let root = f(0) * length;
            let tip = f(1) * root;
            let tip_te = length - f(2) * (root - tip);
            [
                length - root,
                length,
                tip_te - tip,
                tip_te,
                radius * (1.0 + 2.0 * f(3)),
                f32::from(thickness) * 1e-4,
                f32::from(roll),
            ]
        }
        FinSpec::Raw(values) => values,
    }
}
