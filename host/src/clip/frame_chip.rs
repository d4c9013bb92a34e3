//! A frame row's chip, loaded with every check made before the core sees it.

use super::{ChipImage, Clip, ClipPathError, FrameRow, load_chip};
use std::path::PathBuf;

/// Why a frame's chip cannot be given to the pipeline (its results row says `bad_chip`).
#[derive(Debug, thiserror::Error)]
pub enum FrameChipError {
    /// The chip path is absolute or leads outside the clip folder, or names no file.
    #[error(transparent)]
    Path(#[from] ClipPathError),
    /// The PNG could not be read or is not grayscale.
    #[error(transparent)]
    Unreadable(#[from] anyhow::Error),
    /// The chip's size differs from `clip.json`'s.
    #[error("{path}: chip is {width}x{height}, clip.json says {expected_width}x{expected_height}")]
    WrongSize {
        /// The chip file.
        path: PathBuf,
        /// Chip width, px.
        width: u32,
        /// Chip height, px.
        height: u32,
        /// Width from `clip.json`, px.
        expected_width: u32,
        /// Height from `clip.json`, px.
        expected_height: u32,
    },
    /// The chip origin does not fit an i32.
    #[error("chip origin ({x0}, {y0}) out of range")]
    OriginOutOfRange {
        /// Full-frame x of the chip's left column.
        x0: i64,
        /// Full-frame y of the chip's top row.
        y0: i64,
    },
    /// The core refuses to view the chip.
    #[error("{path}: unusable chip: {error:?}")]
    Refused {
        /// The chip file.
        path: PathBuf,
        /// The core's reason.
        error: imade_core::ChipError,
    },
}

/// A frame's chip with its full-frame origin (x0, y0), px; the core accepts its view.
#[derive(Debug, Clone)]
pub struct FrameChip {
    /// The decoded chip.
    pub image: ChipImage,
    /// Full-frame coordinates of the chip's top-left pixel, px.
    pub origin: (i32, i32),
}

impl FrameChip {
    /// The core's view of the chip (checked when the chip was loaded).
    pub fn view(&self) -> Result<imade_core::ChipView<'_>, imade_core::ChipError> {
        self.image.view(self.origin.0, self.origin.1)
    }
}

impl Clip {
    /// Loads `row`'s chip and checks it as the pipeline needs it: inside the clip folder (checked
    /// before it is opened), readable, of `clip.json`'s size, its origin an i32 pair, and accepted
    /// by the core's `ChipView`.
    pub fn load_frame_chip(&self, row: &FrameRow) -> Result<FrameChip, FrameChipError> {
        let path = self.resolve(&row.chip)?;
        let image = load_chip(&path)?;
        let expected = self.meta.chip;
        if (image.width, image.height) != (expected.width, expected.height) {
            return Err(FrameChipError::WrongSize {
                path,
                width: image.width,
                height: image.height,
                expected_width: expected.width,
                expected_height: expected.height,
            });
        }
        let origin = match (i32::try_from(row.chip_x0), i32::try_from(row.chip_y0)) {
            (Ok(x0), Ok(y0)) => (x0, y0),
            _ => {
                return Err(FrameChipError::OriginOutOfRange {
                    x0: row.chip_x0,
                    y0: row.chip_y0,
                });
            }
        };
        let chip = FrameChip { image, origin };
        match chip.view() {
            Ok(_) => Ok(chip),
            Err(error) => Err(FrameChipError::Refused { path, error }),
        }
    }
}
