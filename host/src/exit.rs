//! Exit codes of the `imade` binary, and the errors that choose them.
//!
//! | code | meaning |
//! | --- | --- |
//! | 0 | success |
//! | 1 | failure: nothing useful was written (unwritable output, unreadable results, ...) |
//! | 2 | bad command line (from the argument parser) |
//! | 3 | some frames had unusable input; their rows say `bad_row` or `bad_chip`, the others were processed |
//! | 4 | some clips could not be read at all (clip.json, frames.csv or projectile); the others were processed |

/// A partial success: results were written, but some of the input was unusable.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PartialFailure {
    /// Some frames had unusable input.
    #[error("{frames} frame(s) had unusable input (see the messages above and summary.json)")]
    BadFrames {
        /// How many frames.
        frames: usize,
    },
    /// Some clips could not be read at all.
    #[error("{failed} of {total} clip(s) could not be read (see the messages above)")]
    BadClips {
        /// Clips that could not be read.
        failed: usize,
        /// Clips given.
        total: usize,
    },
}

impl PartialFailure {
    /// The process exit code of this outcome.
    pub fn exit_code(&self) -> u8 {
        match self {
            PartialFailure::BadFrames { .. } => 3,
            PartialFailure::BadClips { .. } => 4,
        }
    }
}

/// The exit code for the outcome of a subcommand: 0 on success, the code of a
/// [`PartialFailure`] anywhere in the error's chain, else 1.
pub fn exit_code(outcome: &anyhow::Result<()>) -> u8 {
    match outcome {
        Ok(()) => 0,
        Err(error) => error
            .chain()
            .find_map(|e| e.downcast_ref::<PartialFailure>())
            .map_or(1, PartialFailure::exit_code),
    }
}
