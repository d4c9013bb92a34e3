//! `frames.csv`: one row per frame, required columns in any order, optional ground truth.

use anyhow::{Context, bail};
use imade_core::world::{Mount, MountError};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Ground truth of one frame (simulated clips only), in the conventions of `docs/geometry.md`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GroundTruth {
    /// Body-origin position in the camera frame, m.
    pub tx_m: f64,
    /// See `tx_m`.
    pub ty_m: f64,
    /// Depth of the body origin, m.
    pub tz_m: f64,
    /// Nose elevation above the camera X-Z plane, deg.
    pub pitch_deg: f64,
    /// Nose azimuth from +Z towards +X, deg.
    pub yaw_deg: f64,
    /// Roll about the body axis, deg.
    pub roll_deg: f64,
}

/// One parsed row of `frames.csv`.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameRow {
    /// 1-based line number in `frames.csv` (the header is line 1).
    pub line: u64,
    /// Frame number, strictly increasing through the clip.
    pub frame: u64,
    /// Capture time, s (arbitrary origin).
    pub time_s: f64,
    /// Chip PNG path relative to the clip folder.
    pub chip: String,
    /// Full-frame pixel of the chip's top-left pixel.
    pub chip_x0: i64,
    /// See `chip_x0`.
    pub chip_y0: i64,
    /// Slant range from a range sensor, m, where there is one.
    pub range_m: Option<f64>,
    /// Where the tracking mount pointed the camera, where the clip says
    /// (`mount_az_deg`, `mount_el_deg`).
    pub mount: Option<Mount>,
    /// Ground-truth pose, where the clip has all six gt_ columns filled.
    pub truth: Option<GroundTruth>,
    /// Ground-truth mask PNG path relative to the clip folder.
    pub gt_mask: Option<String>,
    /// Ground-truth angle of attack (simulated clips with the mount's pointing), where all three
    /// `gt_aoa_` columns are filled.
    pub truth_aoa: Option<TrueAngleOfAttack>,
}

/// The true angle of attack of a frame (imade's own ground-truth columns `gt_aoa_deg`,
/// `gt_aoa_up_deg`, `gt_aoa_right_deg`): the nose against the velocity in the world frame, deg,
/// as `imade_core::world::AngleOfAttack` splits it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TrueAngleOfAttack {
    /// Total angle, deg.
    pub total_deg: f64,
    /// The nose above the velocity, deg.
    pub up_deg: f64,
    /// The nose right of the velocity, deg.
    pub right_deg: f64,
}

/// A row of `frames.csv` that could not be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("frames.csv line {line}{}: {message}", frame.map(|f| format!(" (frame {f})")).unwrap_or_default())]
pub struct FrameRowError {
    /// 1-based line number in `frames.csv`.
    pub line: u64,
    /// The frame number, where it could be read.
    pub frame: Option<u64>,
    /// What is wrong.
    pub message: String,
}

/// The CSV record as written on disk; every field optional so that a missing value is reported
/// per row rather than failing the clip.
#[derive(Debug, Deserialize, Serialize, Default)]
pub(super) struct RawRow {
    pub frame: Option<String>,
    pub time_s: Option<String>,
    pub chip: Option<String>,
    pub chip_x0: Option<String>,
    pub chip_y0: Option<String>,
    pub range_m: Option<String>,
    pub mount_az_deg: Option<String>,
    pub mount_el_deg: Option<String>,
    pub gt_tx_m: Option<String>,
    pub gt_ty_m: Option<String>,
    pub gt_tz_m: Option<String>,
    pub gt_pitch_deg: Option<String>,
    pub gt_yaw_deg: Option<String>,
    pub gt_roll_deg: Option<String>,
    pub gt_mask: Option<String>,
    pub gt_aoa_deg: Option<String>,
    pub gt_aoa_up_deg: Option<String>,
    pub gt_aoa_right_deg: Option<String>,
}

const REQUIRED: [&str; 6] = ["frame", "time_s", "chip", "chip_x0", "chip_y0", "range_m"];

/// The optional tracking-mount columns: both or neither.
pub const MOUNT_COLUMNS: [&str; 2] = ["mount_az_deg", "mount_el_deg"];

/// A parsed `frames.csv`: one entry per data row (each row parsed or its error), and whether
/// the file has the tracking mount's columns.
#[derive(Debug)]
pub struct Frames {
    /// One entry per data line, in file order.
    pub rows: Vec<Result<FrameRow, FrameRowError>>,
    /// True where the header has both [`MOUNT_COLUMNS`].
    pub has_mount: bool,
}

/// Reads `frames.csv`. Fails when the file cannot be read, lacks a required column or has only
/// one of the [`MOUNT_COLUMNS`]; otherwise returns one entry per data row, and enforces
/// strictly increasing frame numbers (a row whose number does not increase is that row's
/// error).
pub fn read_frames(path: &Path) -> anyhow::Result<Frames> {
    let mut reader = csv::ReaderBuilder::new()
        .flexible(true)
        .trim(csv::Trim::All)
        .from_path(path)
        .with_context(|| format!("opening {}", path.display()))?;
    let headers = reader
        .headers()
        .with_context(|| format!("reading the header of {}", path.display()))?
        .clone();
    for column in REQUIRED {
        if !headers.iter().any(|h| h == column) {
            bail!("{}: missing required column {column:?}", path.display());
        }
    }
    let has_mount = match MOUNT_COLUMNS.map(|c| headers.iter().any(|h| h == c)) {
        [true, true] => true,
        [false, false] => false,
        _ => bail!(
            "{}: the tracking mount's columns come together: {} and {}",
            path.display(),
            MOUNT_COLUMNS[0],
            MOUNT_COLUMNS[1]
        ),
    };
    let mut rows = Vec::new();
    let mut last_frame: Option<u64> = None;
    for (index, record) in reader.records().enumerate() {
        let line = record
            .as_ref()
            .ok()
            .and_then(|r| r.position().map(|p| p.line()))
            .unwrap_or(index as u64 + 2);
        let parsed = record
            .map_err(|e| FrameRowError {
                line,
                frame: None,
                message: e.to_string(),
            })
            .and_then(|r| {
                r.deserialize::<RawRow>(Some(&headers))
                    .map_err(|e| FrameRowError {
                        line,
                        frame: None,
                        message: e.to_string(),
                    })
            })
            .and_then(|raw| parse_row(line, raw));
        let checked = parsed.and_then(|row| match last_frame {
            Some(prev) if row.frame <= prev => Err(FrameRowError {
                line,
                frame: Some(row.frame),
                message: format!(
                    "frame number {} does not increase (previous {prev})",
                    row.frame
                ),
            }),
            _ => Ok(row),
        });
        if let Ok(row) = &checked {
            last_frame = Some(row.frame);
        }
        rows.push(checked);
    }
    Ok(Frames { rows, has_mount })
}

fn parse_row(line: u64, raw: RawRow) -> Result<FrameRow, FrameRowError> {
    let frame_number = raw.frame.as_deref().and_then(|s| s.parse::<u64>().ok());
    let err = |message: String| FrameRowError {
        line,
        frame: frame_number,
        message,
    };
    let frame = frame_number.ok_or_else(|| err(format!("bad frame number {:?}", raw.frame)))?;
    let time_s = required_f64("time_s", &raw.time_s).map_err(err)?;
    let chip = raw
        .chip
        .filter(|s| !s.is_empty())
        .ok_or_else(|| err("empty chip path".into()))?;
    let chip_x0 = required_i64("chip_x0", &raw.chip_x0).map_err(err)?;
    let chip_y0 = required_i64("chip_y0", &raw.chip_y0).map_err(err)?;
    let range_m = optional_f64("range_m", &raw.range_m).map_err(err)?;
    if let Some(r) = range_m
        && r <= 0.0
    {
        return Err(err(format!("range_m must be positive, got {r}")));
    }
    let mount = match (
        optional_f64("mount_az_deg", &raw.mount_az_deg).map_err(err)?,
        optional_f64("mount_el_deg", &raw.mount_el_deg).map_err(err)?,
    ) {
        (Some(az), Some(el)) => Some(Mount::new_checked(az, el).map_err(|e| {
            err(match e {
                MountError::NotFinite => "mount_az_deg, mount_el_deg: not finite".into(),
                MountError::ElevationOutOfRange => {
                    format!("mount_el_deg must be within [-90, 90], got {el}")
                }
            })
        })?),
        (None, None) => None,
        _ => {
            return Err(err(
                "mount_az_deg and mount_el_deg: one is given without the other".into(),
            ));
        }
    };
    let gt = [
        &raw.gt_tx_m,
        &raw.gt_ty_m,
        &raw.gt_tz_m,
        &raw.gt_pitch_deg,
        &raw.gt_yaw_deg,
        &raw.gt_roll_deg,
    ]
    .map(|v| optional_f64("gt_", v));
    let truth = match gt {
        [
            Ok(Some(tx_m)),
            Ok(Some(ty_m)),
            Ok(Some(tz_m)),
            Ok(Some(pitch_deg)),
            Ok(Some(yaw_deg)),
            Ok(Some(roll_deg)),
        ] => Some(GroundTruth {
            tx_m,
            ty_m,
            tz_m,
            pitch_deg,
            yaw_deg,
            roll_deg,
        }),
        _ => None,
    };
    let truth_aoa = match [&raw.gt_aoa_deg, &raw.gt_aoa_up_deg, &raw.gt_aoa_right_deg]
        .map(|v| optional_f64("gt_aoa_", v))
    {
        [Ok(Some(total_deg)), Ok(Some(up_deg)), Ok(Some(right_deg))] => Some(TrueAngleOfAttack {
            total_deg,
            up_deg,
            right_deg,
        }),
        _ => None,
    };
    Ok(FrameRow {
        line,
        frame,
        time_s,
        chip,
        chip_x0,
        chip_y0,
        range_m,
        mount,
        truth,
        gt_mask: raw.gt_mask.filter(|s| !s.is_empty()),
        truth_aoa,
    })
}

fn optional_f64(name: &str, value: &Option<String>) -> Result<Option<f64>, String> {
    match value.as_deref() {
        None | Some("") => Ok(None),
        Some(s) => match s.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(Some(v)),
            _ => Err(format!("{name}: not a finite number: {s:?}")),
        },
    }
}

fn required_f64(name: &str, value: &Option<String>) -> Result<f64, String> {
    optional_f64(name, value)?.ok_or_else(|| format!("{name}: missing"))
}

fn required_i64(name: &str, value: &Option<String>) -> Result<i64, String> {
    let s = value.as_deref().unwrap_or("");
    s.parse::<i64>()
        .map_err(|_| format!("{name}: not an integer: {s:?}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Writes `text` as a `frames.csv` and reads it.
    fn read(text: &str) -> anyhow::Result<Frames> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("frames.csv");
        std::fs::write(&path, text).unwrap();
        read_frames(&path)
    }

    const HEAD: &str = "frame,time_s,chip,chip_x0,chip_y0,range_m";

    #[test]
    fn the_mount_columns_are_read_and_checked_per_row() {
        let frames = read(&format!(
            "{HEAD},mount_az_deg,mount_el_deg\n\
             1,0.0,chips/000001.png,0,0,,30.5,20.25\n\
             2,0.1,chips/000002.png,0,0,,,\n\
             3,0.2,chips/000003.png,0,0,,30,95\n\
             4,0.3,chips/000004.png,0,0,,30,\n"
        ))
        .unwrap();
        assert!(frames.has_mount);
        let mount = frames.rows[0].as_ref().unwrap().mount.unwrap();
        assert_eq!((mount.az_deg(), mount.el_deg()), (30.5, 20.25));
        assert_eq!(frames.rows[1].as_ref().unwrap().mount, None);
        let above = frames.rows[2].as_ref().unwrap_err();
        assert!(
            above.message.contains("mount_el_deg must be within"),
            "{above}"
        );
        let half = frames.rows[3].as_ref().unwrap_err();
        assert!(
            half.message.contains("one is given without the other"),
            "{half}"
        );
    }

    #[test]
    fn one_mount_column_alone_is_refused_and_none_is_no_mount() {
        let error = read(&format!(
            "{HEAD},mount_az_deg\n1,0,chips/000001.png,0,0,,30\n"
        ))
        .unwrap_err();
        assert!(format!("{error}").contains("come together"), "{error}");
        let frames = read(&format!("{HEAD}\n1,0,chips/000001.png,0,0,\n")).unwrap();
        assert!(!frames.has_mount);
        assert_eq!(frames.rows[0].as_ref().unwrap().mount, None);
    }
}
