//! Replaying a packed clip: the pipeline built from the header and each record turned into the
//! same [`FrameInput`] and results row as `imade run` makes from the clip folder.

use crate::format::{ChipFrame, Header, Record, SampleDepth};
use core::fmt;
use imade_core::{ChipError, ChipView, Config, FrameInput, FrameResult, results};

impl Header {
    /// The pipeline configuration: the defaults with the header's range use, and the grey-level
    /// fit only where the header asks for it (`imade pack --grey-fit`): on the firmware it costs
    /// 0.7-1.7 G instructions a frame and 135 KB more stack, beyond its budgets, so by default
    /// the firmware runs as `imade run --no-grey-fit`.
    pub fn config(&self) -> Config {
        let mut config = Config {
            range_use: self.range_use,
            ..Config::DEFAULT
        };
        config.grey_fit.enabled = self.grey_fit;
        config
    }
}

impl ChipFrame {
    /// The pipeline's input, with the chip's samples as read by
    /// [`read_record`](crate::read_record) into `chip`.
    pub fn input<'a>(&self, chip: &'a [u16]) -> Result<FrameInput<'a>, ChipError> {
        let (w, h) = (usize::from(self.width), usize::from(self.height));
        let view = match self.depth {
            SampleDepth::U8 => {
                ChipView::gray8(bytemuck::cast_slice(chip), w, h, w, self.x0, self.y0)
            }
            SampleDepth::U16 => ChipView::gray16(chip, w, h, w, self.x0, self.y0),
        }?;
        Ok(FrameInput {
            chip: view,
            time_s: self.time_s,
            range_m: self.range_m,
            mount: self.mount,
        })
    }
}

/// What became of one record.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Outcome {
    /// The pipeline ran on the frame's chip.
    Processed {
        /// Frame number.
        frame: u64,
        /// The pipeline's result.
        result: FrameResult,
    },
    /// The frame had no usable input; its results row carries only a status.
    Unusable {
        /// Frame number, where known.
        frame: Option<u64>,
        /// `bad_chip` or `bad_row`, as `imade run` writes them.
        status: &'static str,
    },
}

/// Replays one record whose chip samples (if any) were read into `chip`: `process` runs the
/// pipeline on the frame's input. A chip the core refuses to view is `bad_chip`, as on the host.
pub fn replay(
    record: &Record,
    chip: &[u16],
    process: impl FnOnce(&FrameInput) -> FrameResult,
) -> Outcome {
    match *record {
        Record::Chip(c) => match c.input(chip) {
            Ok(input) => Outcome::Processed {
                frame: c.frame,
                result: process(&input),
            },
            Err(_) => Outcome::Unusable {
                frame: Some(c.frame),
                status: "bad_chip",
            },
        },
        Record::BadChip { frame } => Outcome::Unusable {
            frame: Some(frame),
            status: "bad_chip",
        },
        Record::BadRow { frame } => Outcome::Unusable {
            frame,
            status: "bad_row",
        },
    }
}

impl Outcome {
    /// Writes the outcome's imade-results/1 row, without a line end; with the world frame's
    /// columns where `world` (the clip has the mount's).
    pub fn write_row(&self, out: &mut impl fmt::Write, world: bool) -> fmt::Result {
        let state = match self {
            Outcome::Processed { frame, result } => {
                results::write_row(out, *frame, result)?;
                result.world
            }
            Outcome::Unusable { frame, status } => {
                results::write_status_row(out, *frame, status)?;
                None
            }
        };
        if world {
            results::write_world_columns(out, state.as_ref())?;
        }
        Ok(())
    }

    /// The outcome's results status.
    pub fn status(&self) -> &'static str {
        match self {
            Outcome::Processed { result, .. } => result.status.as_str(),
            Outcome::Unusable { status, .. } => status,
        }
    }
}
