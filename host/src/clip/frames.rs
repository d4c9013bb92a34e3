//! `frames.csv`: one row per frame, required columns in any order, optional ground truth.

use anyhow::{Context, bail};
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
    /// Ground-truth pose, where the clip has all six gt_ columns filled.
    pub truth: Option<GroundTruth>,
    /// Ground-truth mask PNG path relative to the clip folder.
    pub gt_mask: Option<String>,
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
    pub gt_tx_m: Option<String>,
    pub gt_ty_m: Option<String>,
    pub gt_tz_m: Option<String>,
    pub gt_pitch_deg: Option<String>,
    pub gt_yaw_deg: Option<String>,
    pub gt_roll_deg: Option<String>,
    pub gt_mask: Option<String>,
}

const REQUIRED: [&str; 6] = ["frame", "time_s", "chip", "chip_x0", "chip_y0", "range_m"];

/// Reads `frames.csv`. Fails when the file cannot be read or lacks a required column; otherwise
/// returns one entry per data row, and enforces strictly increasing frame numbers (a row whose
/// number does not increase is that row's error).
pub fn read_frames(path: &Path) -> anyhow::Result<Vec<Result<FrameRow, FrameRowError>>> {
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
    Ok(rows)
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
    Ok(FrameRow {
        line,
        frame,
        time_s,
        chip,
        chip_x0,
        chip_y0,
        range_m,
        truth,
        gt_mask: raw.gt_mask.filter(|s| !s.is_empty()),
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
