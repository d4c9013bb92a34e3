//! Reading imade-results/1 CSVs (the rows are written by `imade_core::results`).

use anyhow::{Context, bail};
use serde::Deserialize;
use std::path::Path;

/// One row of an imade-results/1 file. Pose fields are present only where `status` is `ok`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct ResultRow {
    /// The input frame number (empty for a `frames.csv` row whose number could not be read).
    pub frame: Option<u64>,
    /// `ok` or the reason there is no pose.
    pub status: String,
    /// Estimated body origin in the camera frame, m.
    pub tx_m: Option<f64>,
    /// See `tx_m`.
    pub ty_m: Option<f64>,
    /// Estimated depth, m.
    pub tz_m: Option<f64>,
    /// Pitch of the chosen candidate, deg.
    pub pitch_deg: Option<f64>,
    /// Yaw of the chosen candidate, deg.
    pub yaw_deg: Option<f64>,
    /// Yaw of the mirrored candidate, deg.
    pub yaw_alt_deg: Option<f64>,
    /// True where the choice between the candidates is resolved.
    pub yaw_resolved: bool,
    /// True where a range measurement fixed Tz.
    pub range_used: bool,
    /// Roll modulo the fins' spacing (90 deg for four fins), where estimated.
    pub roll_deg: Option<f64>,
    /// One sigma of `tz_m`, m, where estimated.
    #[serde(default)]
    pub tz_sd_m: Option<f64>,
    /// One sigma of `pitch_deg`, deg, where estimated.
    #[serde(default)]
    pub pitch_sd_deg: Option<f64>,
    /// One sigma of `yaw_deg`, deg, where estimated.
    #[serde(default)]
    pub yaw_sd_deg: Option<f64>,
    /// Pitch of the mirrored candidate, deg (an imade column).
    #[serde(default)]
    pub pitch_alt_deg: Option<f64>,
    /// Slant range measured from the image, m (an imade column).
    #[serde(default)]
    pub image_range_m: Option<f64>,
    /// One sigma of `roll_deg`, deg, where it is given (an imade column).
    #[serde(default)]
    pub roll_sd_deg: Option<f64>,
    /// Nose azimuth in the world frame, deg clockwise from north, where the clip gives the
    /// mount's pointing.
    #[serde(default)]
    pub nose_az_deg: Option<f64>,
    /// Nose elevation in the world frame, deg.
    #[serde(default)]
    pub nose_el_deg: Option<f64>,
    /// Body origin in the world frame: east, m.
    #[serde(default)]
    pub e_m: Option<f64>,
    /// ... north, m.
    #[serde(default)]
    pub n_m: Option<f64>,
    /// ... up, m.
    #[serde(default)]
    pub u_m: Option<f64>,
    /// Total angle of attack in the world frame, deg, where the velocity is known.
    #[serde(default)]
    pub aoa_deg: Option<f64>,
    /// Its component up (the nose above the velocity), deg (an imade column).
    #[serde(default)]
    pub aoa_up_deg: Option<f64>,
    /// Its component right (the nose right of the velocity), deg (an imade column).
    #[serde(default)]
    pub aoa_right_deg: Option<f64>,
}

impl ResultRow {
    /// True where the frame has a pose.
    pub fn is_ok(&self) -> bool {
        self.status == "ok"
    }
}

/// Reads an imade-results/1 file; a malformed row fails the whole file, naming its line.
pub fn read_results(path: &Path) -> anyhow::Result<Vec<ResultRow>> {
    let mut reader = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_path(path)
        .with_context(|| format!("opening {}", path.display()))?;
    let mut rows = Vec::new();
    for record in reader.deserialize::<ResultRow>() {
        let row = record.with_context(|| format!("reading {}", path.display()))?;
        if row.is_ok()
            && [row.tx_m, row.ty_m, row.tz_m, row.pitch_deg, row.yaw_deg]
                .iter()
                .any(Option::is_none)
        {
            bail!(
                "{}: frame {:?} is ok but lacks a pose column",
                path.display(),
                row.frame
            );
        }
        rows.push(row);
    }
    Ok(rows)
}
