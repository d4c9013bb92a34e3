//! `clip.json`: camera intrinsics, chip size, projectile id and frame rate.

use anyhow::{Context, bail};
use imade_core::Camera;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The format identifier this version of imade reads and writes.
pub const FORMAT_ID: &str = "imade-clip/1";

/// Camera intrinsics and full-frame size, in pixels.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CameraMeta {
    /// Focal length along x, px.
    pub fx: f64,
    /// Focal length along y, px.
    pub fy: f64,
    /// Principal point x, full-frame px (pixel centres at integers).
    pub cx: f64,
    /// Principal point y, full-frame px.
    pub cy: f64,
    /// Full-frame width, px.
    pub width: u32,
    /// Full-frame height, px.
    pub height: u32,
}

impl CameraMeta {
    /// The intrinsics as the core takes them (f32, full-frame px).
    pub fn camera(&self) -> Camera {
        Camera {
            fx: self.fx as f32,
            fy: self.fy as f32,
            cx: self.cx as f32,
            cy: self.cy as f32,
        }
    }
}

/// Chip size, px.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct ChipSize {
    /// Chip width, px.
    pub width: u32,
    /// Chip height, px.
    pub height: u32,
}

/// The recording station (`clip.json`'s `station`): who recorded the clip and where the camera
/// stands in the range's East-North-Up frame (`docs/geometry.md`, "World frame").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StationMeta {
    /// The station's name (clips of one test from several stations tell them apart by it).
    pub id: String,
    /// East, north and up of the camera's optical centre, m.
    pub enu_m: [f64; 3],
}

/// The contents of `clip.json`. Unknown keys are ignored.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ClipMeta {
    /// Always [`FORMAT_ID`].
    pub format: String,
    /// Camera intrinsics.
    pub camera: CameraMeta,
    /// Size of every chip.
    pub chip: ChipSize,
    /// Id of the projectile model (for example `ref-1378x80`).
    pub projectile: String,
    /// The camera's frame rate, Hz (a clip may keep only every n-th frame).
    pub frame_rate_hz: f64,
    /// The recording station, where the clip names one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub station: Option<StationMeta>,
}

/// Reads and validates `clip.json`.
pub fn read_meta(path: &Path) -> anyhow::Result<ClipMeta> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let meta: ClipMeta =
        serde_json::from_str(&text).with_context(|| format!("parsing {}", path.display()))?;
    if meta.format != FORMAT_ID {
        bail!(
            "{}: format is {:?}, this imade reads {:?}",
            path.display(),
            meta.format,
            FORMAT_ID
        );
    }
    let c = &meta.camera;
    let finite_positive = |v: f64| v.is_finite() && v > 0.0;
    if !(finite_positive(c.fx) && finite_positive(c.fy) && c.cx.is_finite() && c.cy.is_finite()) {
        bail!(
            "{}: camera intrinsics must be finite with fx, fy > 0",
            path.display()
        );
    }
    if meta.chip.width == 0 || meta.chip.height == 0 {
        bail!("{}: chip size must be positive", path.display());
    }
    if let Some(station) = &meta.station
        && !station.enu_m.iter().all(|v| v.is_finite())
    {
        bail!("{}: station.enu_m must be finite", path.display());
    }
    Ok(meta)
}
