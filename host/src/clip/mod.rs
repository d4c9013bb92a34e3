//! The `imade-clip/1` recorded-clip format (`docs/formats.md`): the one place it is parsed and
//! written.
//!
//! A clip is a folder with `clip.json` (camera and clip metadata), `frames.csv` (one row per frame)
//! and the chips as 8-bit or 16-bit grayscale PNGs. Reading is per frame and lossless about errors:
//! a malformed row or a corrupt chip is an error for that frame only. A path named in the clip is
//! opened only through [`Clip::resolve`], which refuses one that leads outside the clip folder.

mod chip_image;
mod frame_chip;
mod frames;
mod mask_png;
mod meta;
mod paths;
mod results;
mod writer;

pub use chip_image::{ChipImage, ChipPixels, load_chip, load_mask};
pub use frame_chip::{FrameChip, FrameChipError};
pub use frames::{
    FrameRow, FrameRowError, Frames, GroundTruth, MOUNT_COLUMNS, TrueAngleOfAttack, read_frames,
};
pub use mask_png::{mask_image, save_mask};
pub use meta::{CameraMeta, ChipSize, ClipMeta, FORMAT_ID, StationMeta, read_meta};
pub use paths::{ClipPathError, resolve_clip_path};
pub use results::{ResultRow, read_results};
pub use writer::{ClipWriter, write_atomically};

use anyhow::Context;
use imade_core::ProjectileModel;
use imade_core::world::Station;
use std::path::{Path, PathBuf};

/// An opened clip: its folder, metadata and frame rows (each row parsed or its error).
#[derive(Debug)]
pub struct Clip {
    /// The clip folder.
    pub dir: PathBuf,
    /// Parsed `clip.json`.
    pub meta: ClipMeta,
    /// One entry per data line of `frames.csv`, in file order.
    pub frames: Vec<Result<FrameRow, FrameRowError>>,
    /// True where `frames.csv` has the tracking mount's columns: the results then state each
    /// ok frame in the world frame too.
    pub has_mount: bool,
}

impl Clip {
    /// Opens a clip folder: reads `clip.json` and `frames.csv`. Fails only when the clip as a whole
    /// cannot be read (missing or invalid metadata, unreadable `frames.csv`, missing columns);
    /// a bad row is kept as that row's error.
    pub fn open(dir: &Path) -> anyhow::Result<Clip> {
        let meta = read_meta(&dir.join("clip.json"))?;
        let frames = read_frames(&dir.join("frames.csv"))?;
        Ok(Clip {
            dir: dir.to_path_buf(),
            meta,
            frames: frames.rows,
            has_mount: frames.has_mount,
        })
    }

    /// The model of the clip's projectile for the table choice `lut` (`--lut`): a model file's
    /// path, whose id must be the clip's, or `bundled` / `none` for the bundled model of that
    /// id. An unknown id or a mismatch is an error naming `clip.json`.
    pub fn model(&self, lut: &str) -> anyhow::Result<ProjectileModel<'static>> {
        let file = (!matches!(lut, "bundled" | "none")).then(|| Path::new(lut));
        crate::model::for_clip(&self.meta.projectile, file)
            .with_context(|| format!("{}", self.dir.join("clip.json").display()))
    }

    /// The file named by `relative` (a path read from the clip), resolved inside the clip folder;
    /// an absolute path or one leading outside the folder is refused (see [`resolve_clip_path`]).
    /// Open a clip's files through this.
    pub fn resolve(&self, relative: &str) -> Result<PathBuf, ClipPathError> {
        resolve_clip_path(&self.dir, relative)
    }

    /// Where the camera stands in the world frame: `clip.json`'s station, else the origin.
    pub fn station(&self) -> Station {
        self.meta
            .station
            .as_ref()
            .map_or(Station::default(), |s| Station { enu_m: s.enu_m })
    }

    /// The clip folder joined with `relative`, unchecked: for messages. Files are opened through
    /// [`Clip::resolve`].
    pub fn path_of(&self, relative: &str) -> PathBuf {
        self.dir.join(relative)
    }
}
