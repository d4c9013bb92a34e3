//! The imade-pack/2 byte layout: a fixed header, then one fixed record per frame row of the
//! clip, each chip record followed by its samples. All numbers little-endian. (Version 2 added
//! the tracking mount's pointing and the station, for the world frame.)
//!
//! Header ([`HEADER_LEN`] bytes):
//!
//! | bytes | field |
//! | --- | --- |
//! | 0..8 | magic `IMADEPK2` |
//! | 8..24 | camera `fx`, `fy`, `cx`, `cy`, f32, px |
//! | 24 | range use: 0 auto, 1 ignore |
//! | 25 | silhouette table: 0 none, 1 the bundled table of the projectile |
//! | 26 | length of the projectile id, at most [`MAX_PROJECTILE_ID`] |
//! | 27 | flags: bit 0 the clip has the mount's columns (the results state the world frame); bit 1 the grey-level fit runs (`imade pack --grey-fit`) |
//! | 28..60 | projectile id, UTF-8, zero-padded |
//! | 60..64 | number of records, u32 |
//! | 64..88 | station east, north, up, f64, m (zero without the mount's columns) |
//! | 88..96 | zero |
//!
//! Record ([`RECORD_LEN`] bytes):
//!
//! | bytes | field |
//! | --- | --- |
//! | 0 | kind: 0 chip, 1 bad chip, 2 bad row |
//! | 1 | flags: bit 0 frame number present, bit 1 range present, bit 2 mount pointing present |
//! | 2 | bytes per sample: 1 or 2 for a chip, 0 otherwise |
//! | 3 | zero |
//! | 4..12 | frame number, u64 |
//! | 12..20 | capture time, f64, s |
//! | 20..24 | range, f32, m |
//! | 24..32 | chip origin `x0`, `y0`, i32, full-frame px |
//! | 32..36 | chip width, height, u16, px |
//! | 36..40 | zero |
//! | 40..56 | mount azimuth, elevation, f64, deg |
//!
//! A chip record is followed by width x height samples, row-major, without padding.

use imade_core::world::{Mount, Station};
use imade_core::{Camera, RangeUse};

#[cfg(target_endian = "big")]
compile_error!("imade-pack reads 16-bit samples in place and needs a little-endian target");

/// Bytes of the file header.
pub const HEADER_LEN: usize = 96;
/// Bytes of a record (without its samples).
pub const RECORD_LEN: usize = 56;
/// Longest projectile id, bytes.
pub const MAX_PROJECTILE_ID: usize = 32;

const MAGIC: [u8; 8] = *b"IMADEPK2";
const FLAG_FRAME: u8 = 1;
const FLAG_RANGE: u8 = 2;
const FLAG_MOUNT: u8 = 4;
/// Header flag: the clip has the mount's columns.
const FLAG_WORLD: u8 = 1;
/// Header flag: the grey-level fit runs.
const FLAG_GREY_FIT: u8 = 2;

/// Why bytes are not imade-pack/1.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PackError {
    /// The file does not start with the magic.
    BadMagic,
    /// Unknown range-use code.
    BadRangeUse(u8),
    /// Unknown table code.
    BadTable(u8),
    /// The projectile id is too long or not UTF-8.
    BadProjectile,
    /// Unknown record kind.
    BadKind(u8),
    /// A chip record with a sample size other than 1 or 2 bytes, or an empty chip.
    BadChip,
    /// A mount pointing that is not finite or whose elevation is beyond the vertical, or a
    /// station that is not finite.
    BadWorld,
}

impl core::fmt::Display for PackError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            PackError::BadMagic => write!(f, "not an imade-pack/2 file"),
            PackError::BadRangeUse(code) => write!(f, "unknown range-use code {code}"),
            PackError::BadTable(code) => write!(f, "unknown table code {code}"),
            PackError::BadProjectile => write!(f, "bad projectile id"),
            PackError::BadKind(kind) => write!(f, "unknown record kind {kind}"),
            PackError::BadChip => write!(f, "chip record with a bad sample size or no samples"),
            PackError::BadWorld => write!(f, "a mount pointing or station that is no place"),
        }
    }
}

impl core::error::Error for PackError {}

/// Which silhouette table the table match uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TableUse {
    /// None: the closed form only.
    None,
    /// The silhouette table carried by the projectile's model file in the firmware's flash.
    Bundled,
}

/// The file header: what the pipeline is built from.
#[derive(Debug, Clone, PartialEq)]
pub struct Header {
    /// The camera intrinsics, as the host's pipeline gets them.
    pub camera: Camera,
    /// How range measurements are used.
    pub range_use: RangeUse,
    /// Which silhouette table the pipeline uses.
    pub table: TableUse,
    /// The projectile's model id (a built-in model of the core).
    pub projectile: heapless::String<MAX_PROJECTILE_ID>,
    /// Number of records that follow.
    pub records: u32,
    /// Where the clip has the mount's columns: the station the results state the world frame
    /// from.
    pub world: Option<Station>,
    /// Whether the pipeline runs the grey-level fit (`imade run`'s default; off, the firmware's
    /// default, is `imade run --no-grey-fit`).
    pub grey_fit: bool,
}

impl Header {
    /// A header; fails when the projectile id is longer than [`MAX_PROJECTILE_ID`] bytes.
    pub fn new(
        camera: Camera,
        range_use: RangeUse,
        table: TableUse,
        projectile: &str,
        records: u32,
    ) -> Result<Self, PackError> {
        Ok(Header {
            camera,
            range_use,
            table,
            projectile: heapless::String::try_from(projectile)
                .map_err(|_| PackError::BadProjectile)?,
            records,
            world: None,
            grey_fit: false,
        })
    }

    /// The header of a clip run with the grey-level fit.
    pub fn with_grey_fit(self) -> Self {
        Header {
            grey_fit: true,
            ..self
        }
    }

    /// The header of a clip with the mount's columns, recorded at `station`.
    pub fn with_world(self, station: Station) -> Self {
        Header {
            world: Some(station),
            ..self
        }
    }

    /// The header's bytes.
    pub fn encode(&self) -> [u8; HEADER_LEN] {
        let mut b = [0u8; HEADER_LEN];
        b[0..8].copy_from_slice(&MAGIC);
        let c = &self.camera;
        for (i, v) in [c.fx, c.fy, c.cx, c.cy].into_iter().enumerate() {
            let at = 8 + 4 * i;
            b[at..at + 4].copy_from_slice(&v.to_le_bytes());
        }
        b[24] = match self.range_use {
            RangeUse::Auto => 0,
            RangeUse::Ignore => 1,
        };
        b[25] = match self.table {
            TableUse::None => 0,
            TableUse::Bundled => 1,
        };
        let id = self.projectile.as_bytes();
        // The id's capacity is MAX_PROJECTILE_ID, so its length fits a byte and its slot.
        b[26] = id.len() as u8;
        b[28..28 + id.len()].copy_from_slice(id);
        b[60..64].copy_from_slice(&self.records.to_le_bytes());
        if self.grey_fit {
            b[27] |= FLAG_GREY_FIT;
        }
        if let Some(station) = &self.world {
            b[27] |= FLAG_WORLD;
            for (i, v) in station.enu_m.iter().enumerate() {
                let at = 64 + 8 * i;
                b[at..at + 8].copy_from_slice(&v.to_le_bytes());
            }
        }
        b
    }

    /// Parses a header.
    pub fn decode(b: &[u8; HEADER_LEN]) -> Result<Self, PackError> {
        if b[0..8] != MAGIC {
            return Err(PackError::BadMagic);
        }
        let range_use = match b[24] {
            0 => RangeUse::Auto,
            1 => RangeUse::Ignore,
            code => return Err(PackError::BadRangeUse(code)),
        };
        let table = match b[25] {
            0 => TableUse::None,
            1 => TableUse::Bundled,
            code => return Err(PackError::BadTable(code)),
        };
        let id = b
            .get(28..28 + usize::from(b[26]))
            .filter(|id| id.len() <= MAX_PROJECTILE_ID)
            .and_then(|id| core::str::from_utf8(id).ok())
            .ok_or(PackError::BadProjectile)?;
        let projectile = heapless::String::try_from(id).map_err(|_| PackError::BadProjectile)?;
        Ok(Header {
            camera: Camera {
                fx: f32_at(b, 8),
                fy: f32_at(b, 12),
                cx: f32_at(b, 16),
                cy: f32_at(b, 20),
            },
            range_use,
            table,
            projectile,
            records: u32::from_le_bytes(array_at(b, 60)),
            world: if b[27] & FLAG_WORLD != 0 {
                let enu_m = [64, 72, 80].map(|at| f64::from_le_bytes(array_at(b, at)));
                if !enu_m.iter().all(|v| v.is_finite()) {
                    return Err(PackError::BadWorld);
                }
                Some(Station { enu_m })
            } else {
                None
            },
            grey_fit: b[27] & FLAG_GREY_FIT != 0,
        })
    }
}

/// Size of a chip sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SampleDepth {
    /// 8-bit samples.
    U8,
    /// 16-bit samples.
    U16,
}

impl SampleDepth {
    /// Bytes per sample.
    pub fn bytes(self) -> usize {
        match self {
            SampleDepth::U8 => 1,
            SampleDepth::U16 => 2,
        }
    }
}

/// A frame with its chip, as the host hands it to the pipeline.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ChipFrame {
    /// Frame number.
    pub frame: u64,
    /// Capture time, s.
    pub time_s: f64,
    /// Slant range from the range sensor, m, where the row has one.
    pub range_m: Option<f32>,
    /// Full-frame pixel of the chip's top-left pixel.
    pub x0: i32,
    /// Full-frame pixel of the chip's top-left pixel.
    pub y0: i32,
    /// Chip width, px.
    pub width: u16,
    /// Chip height, px.
    pub height: u16,
    /// Sample size.
    pub depth: SampleDepth,
    /// Where the mount pointed the camera, where the row says.
    pub mount: Option<Mount>,
}

impl ChipFrame {
    /// Number of samples.
    pub fn samples(&self) -> usize {
        usize::from(self.width) * usize::from(self.height)
    }
}

/// One record: one frame row of the clip.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Record {
    /// A frame whose chip follows.
    Chip(ChipFrame),
    /// A frame whose chip the host could not use (missing, corrupt, wrongly sized).
    BadChip {
        /// Frame number.
        frame: u64,
    },
    /// A `frames.csv` row the host could not parse.
    BadRow {
        /// Frame number, where it could be read.
        frame: Option<u64>,
    },
}

impl Record {
    /// Bytes of samples that follow the record.
    pub fn payload_len(&self) -> usize {
        match self {
            Record::Chip(c) => c.samples() * c.depth.bytes(),
            Record::BadChip { .. } | Record::BadRow { .. } => 0,
        }
    }

    /// The record's bytes.
    pub fn encode(&self) -> [u8; RECORD_LEN] {
        let mut b = [0u8; RECORD_LEN];
        let frame = match *self {
            Record::Chip(c) => {
                b[0] = 0;
                b[2] = c.depth.bytes() as u8;
                b[12..20].copy_from_slice(&c.time_s.to_le_bytes());
                if let Some(r) = c.range_m {
                    b[1] |= FLAG_RANGE;
                    b[20..24].copy_from_slice(&r.to_le_bytes());
                }
                b[24..28].copy_from_slice(&c.x0.to_le_bytes());
                b[28..32].copy_from_slice(&c.y0.to_le_bytes());
                b[32..34].copy_from_slice(&c.width.to_le_bytes());
                b[34..36].copy_from_slice(&c.height.to_le_bytes());
                if let Some(m) = &c.mount {
                    b[1] |= FLAG_MOUNT;
                    b[40..48].copy_from_slice(&m.az_deg().to_le_bytes());
                    b[48..56].copy_from_slice(&m.el_deg().to_le_bytes());
                }
                Some(c.frame)
            }
            Record::BadChip { frame } => {
                b[0] = 1;
                Some(frame)
            }
            Record::BadRow { frame } => {
                b[0] = 2;
                frame
            }
        };
        if let Some(frame) = frame {
            b[1] |= FLAG_FRAME;
            b[4..12].copy_from_slice(&frame.to_le_bytes());
        }
        b
    }

    /// Parses a record.
    pub fn decode(b: &[u8; RECORD_LEN]) -> Result<Self, PackError> {
        let frame = (b[1] & FLAG_FRAME != 0).then(|| u64::from_le_bytes(array_at(b, 4)));
        match b[0] {
            0 => {
                let depth = match b[2] {
                    1 => SampleDepth::U8,
                    2 => SampleDepth::U16,
                    _ => return Err(PackError::BadChip),
                };
                let chip = ChipFrame {
                    frame: frame.ok_or(PackError::BadChip)?,
                    time_s: f64::from_le_bytes(array_at(b, 12)),
                    range_m: (b[1] & FLAG_RANGE != 0).then(|| f32_at(b, 20)),
                    x0: i32::from_le_bytes(array_at(b, 24)),
                    y0: i32::from_le_bytes(array_at(b, 28)),
                    width: u16::from_le_bytes(array_at(b, 32)),
                    height: u16::from_le_bytes(array_at(b, 34)),
                    depth,
                    mount: if b[1] & FLAG_MOUNT != 0 {
                        let (az, el) = (f64_at(b, 40), f64_at(b, 48));
                        Some(Mount::new_checked(az, el).map_err(|_| PackError::BadWorld)?)
                    } else {
                        None
                    },
                };
                if chip.samples() == 0 {
                    return Err(PackError::BadChip);
                }
                Ok(Record::Chip(chip))
            }
            1 => Ok(Record::BadChip {
                frame: frame.ok_or(PackError::BadChip)?,
            }),
            2 => Ok(Record::BadRow { frame }),
            kind => Err(PackError::BadKind(kind)),
        }
    }
}

/// The little-endian bytes of 16-bit samples, as a chip record's payload holds them.
pub fn le_bytes(samples: &[u16]) -> impl Iterator<Item = u8> + '_ {
    samples.iter().flat_map(|s| s.to_le_bytes())
}

/// `N` bytes at `at` (in bounds for every caller: offsets are within the fixed layouts).
fn array_at<const N: usize>(b: &[u8], at: usize) -> [u8; N] {
    let mut out = [0u8; N];
    if let Some(s) = b.get(at..at + N) {
        out.copy_from_slice(s);
    }
    out
}

fn f32_at(b: &[u8], at: usize) -> f32 {
    f32::from_le_bytes(array_at(b, at))
}

fn f64_at(b: &[u8], at: usize) -> f64 {
    f64::from_le_bytes(array_at(b, at))
}
