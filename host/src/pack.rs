//! `imade pack`: a clip packed for the firmware (imade-pack/2, `firmware-sim/pack`), read exactly
//! as `imade run` reads it: the same camera, range use, model and table, and per frame row the
//! same time, range, mount pointing, chip origin and chip samples, or the same `bad_chip` /
//! `bad_row` status; and the station where the clip has the mount's columns.

use crate::clip::{ChipImage, ChipPixels, Clip, FrameChipError, FrameRow, write_atomically};
use crate::run::RangeArg;
use anyhow::Context;
use imade_pack::{ChipFrame, Header, Record, SampleDepth, TableUse, format::le_bytes};
use std::path::{Path, PathBuf};

/// Arguments of `imade pack`.
#[derive(Debug, clap::Args)]
pub struct PackArgs {
    /// Clip folder (imade-clip/1).
    pub clip: PathBuf,
    /// The packed file to write.
    #[arg(long)]
    pub out: PathBuf,
    /// How range measurements are used (as for `imade run`).
    #[arg(long, value_enum, default_value = "auto")]
    pub range: RangeArg,
    /// Model and silhouette table (as for `imade run`): `bundled`, `none` or a model file; the
    /// firmware reads the model and its table from flash, so a model file must be the one the
    /// firmware was built with (`firmware-sim/run --lut FILE` builds it so).
    #[arg(long, default_value = "bundled")]
    pub lut: String,
    /// Run the grey-level fit (`imade run`'s default; the firmware's default is without it, as
    /// `imade run --no-grey-fit`, which its budgets allow).
    #[arg(long)]
    pub grey_fit: bool,
}

/// Runs `imade pack`.
pub fn run(args: &PackArgs) -> anyhow::Result<()> {
    let records = pack_clip(&args.clip, &args.out, args.range, &args.lut, args.grey_fit)?;
    eprintln!(
        "{}: {records} frame rows -> {}",
        args.clip.display(),
        args.out.display()
    );
    Ok(())
}

/// Packs the clip in `dir` into `out` (written atomically), with the range use and table choice
/// of `imade run --range range --lut lut`, with the grey-level fit or not; returns the number of
/// records.
pub fn pack_clip(
    dir: &Path,
    out: &Path,
    range: RangeArg,
    lut: &str,
    grey_fit: bool,
) -> anyhow::Result<usize> {
    let (bytes, records) = pack_bytes(dir, range, lut, grey_fit)?;
    if let Some(parent) = out.parent() {
        std::fs::create_dir_all(parent)
            .with_context(|| format!("creating {}", parent.display()))?;
    }
    write_atomically(out, &bytes)?;
    Ok(records)
}

/// The packed bytes of the clip in `dir`, and the number of records.
pub fn pack_bytes(
    dir: &Path,
    range: RangeArg,
    lut: &str,
    grey_fit: bool,
) -> anyhow::Result<(Vec<u8>, usize)> {
    let clip = Clip::open(dir)?;
    let model = clip.model(lut)?;
    let camera = clip.meta.camera.camera();
    let records = u32::try_from(clip.frames.len()).context("too many frames")?;
    let table = match crate::model::table_for(lut, &model) {
        Some(_) => TableUse::Bundled,
        None => TableUse::None,
    };
    let range_use = range.config().range_use;
    let mut header = Header::new(camera, range_use, table, &clip.meta.projectile, records)
        .with_context(|| format!("projectile id {:?}", clip.meta.projectile))?;
    if clip.has_mount {
        header = header.with_world(clip.station());
    }
    if grey_fit {
        header = header.with_grey_fit();
    }
    let mut bytes = header.encode().to_vec();
    for entry in &clip.frames {
        let record = match entry {
            Ok(row) => match chip_frame(&clip, row) {
                Ok((frame, chip)) => {
                    bytes.extend_from_slice(&Record::Chip(frame).encode());
                    match &chip.pixels {
                        ChipPixels::U8(p) => bytes.extend_from_slice(p),
                        ChipPixels::U16(p) => bytes.extend(le_bytes(p)),
                    }
                    continue;
                }
                Err(error) => {
                    eprintln!("imade: {}: frame {}: {error:#}", dir.display(), row.frame);
                    Record::BadChip { frame: row.frame }
                }
            },
            Err(error) => {
                eprintln!("imade: {}: {error}", dir.display());
                Record::BadRow { frame: error.frame }
            }
        };
        bytes.extend_from_slice(&record.encode());
    }
    Ok((bytes, clip.frames.len()))
}

/// A frame's record header and chip, checked as `imade run` checks it.
fn chip_frame(clip: &Clip, row: &FrameRow) -> Result<(ChipFrame, ChipImage), FrameChipError> {
    let chip = clip.load_frame_chip(row)?;
    // The core viewed it, so both sides are at most its largest chip side.
    let side = |v: u32| {
        u16::try_from(v).map_err(|_| FrameChipError::Refused {
            path: clip.path_of(&row.chip),
            error: imade_core::ChipError::TooLarge,
        })
    };
    let frame = ChipFrame {
        frame: row.frame,
        time_s: row.time_s,
        range_m: row.range_m.map(|r| r as f32),
        x0: chip.origin.0,
        y0: chip.origin.1,
        width: side(chip.image.width)?,
        height: side(chip.image.height)?,
        depth: match chip.image.pixels {
            ChipPixels::U8(_) => SampleDepth::U8,
            ChipPixels::U16(_) => SampleDepth::U16,
        },
        mount: row.mount,
    };
    Ok((frame, chip.image))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The header packed from a bundled clip reads back as the clip and the options say: its
    /// range use, table, projectile, records, station, and the grey-level fit, which sets the
    /// replayed pipeline's configuration.
    #[test]
    fn the_header_carries_the_clips_options() {
        let clip = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/small-unknown-range");
        for grey_fit in [false, true] {
            let (bytes, records) =
                pack_bytes(&clip, RangeArg::Ignore, "bundled", grey_fit).unwrap();
            let header = imade_pack::read_header(&mut bytes.as_slice()).unwrap();
            assert_eq!(records, 20);
            assert_eq!(header.records, 20);
            assert_eq!(header.range_use, imade_core::RangeUse::Ignore);
            assert_eq!(header.table, TableUse::Bundled);
            assert_eq!(header.projectile.as_str(), "ref-1378x80");
            assert!(header.world.is_some(), "the clip has the mount's columns");
            assert_eq!(header.grey_fit, grey_fit);
            assert_eq!(header.config().grey_fit.enabled, grey_fit);
        }
    }
}
