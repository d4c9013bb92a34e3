//! What the firmware reports per frame: a defmt log line, and rows in three host files (paths as
//! given in the firmware's arguments):
//!
//! - the imade-results/1 CSV, through the core's row formatter (the same bytes as `imade run`),
//! - the outcomes, one line per frame in Rust's `Debug` form: every float of the result at full
//!   precision (shortest round-trip), so equal lines mean bit-equal results,
//! - the measurements CSV: `frame,status,instructions,stack_peak_bytes` for every frame the
//!   pipeline ran on (the stack peak is the deepest since reset).

use crate::host_io::{self, IoError, OutputFile};
use crate::stack;
use core::fmt::Write;
use imade_core::results;
use imade_pack::Outcome;

/// Longest line written, bytes (an outcome's `Debug` form is the longest).
const MAX_LINE: usize = 2048;

/// Why a frame could not be reported.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum OutputError {
    /// A semihosting call failed.
    Io(IoError),
    /// A line did not fit its buffer.
    LineTooLong,
}

impl From<IoError> for OutputError {
    fn from(e: IoError) -> Self {
        OutputError::Io(e)
    }
}

/// The three output files.
pub struct Outputs {
    results: OutputFile,
    outcomes: OutputFile,
    measurements: OutputFile,
}

impl Outputs {
    /// Creates the files and writes the CSV headers; the results' with the world frame's
    /// columns where `world` (the clip has the mount's columns).
    pub fn create(
        results: &str,
        outcomes: &str,
        measurements: &str,
        world: bool,
    ) -> Result<Self, OutputError> {
        let mut outputs = Outputs {
            results: host_io::create(results)?,
            outcomes: host_io::create(outcomes)?,
            measurements: host_io::create(measurements)?,
        };
        let mut header = heapless::String::<MAX_LINE>::new();
        let columns = if world { results::WORLD_HEADER } else { "" };
        write!(header, "{}{columns}", results::HEADER).map_err(|_| OutputError::LineTooLong)?;
        outputs.results.write_line(&header)?;
        outputs
            .measurements
            .write_line("frame,status,instructions,stack_peak_bytes")?;
        Ok(outputs)
    }

    /// Reports one frame: `instructions` is what the pipeline took, where it ran and was counted;
    /// `world`: the clip has the mount's columns.
    pub fn frame(
        &mut self,
        outcome: &Outcome,
        instructions: Option<u64>,
        world: bool,
    ) -> Result<(), OutputError> {
        let mut line = heapless::String::<MAX_LINE>::new();
        outcome
            .write_row(&mut line, world)
            .map_err(|_| OutputError::LineTooLong)?;
        self.results.write_line(&line)?;
        line.clear();
        write!(line, "{outcome:?}").map_err(|_| OutputError::LineTooLong)?;
        self.outcomes.write_line(&line)?;
        match outcome {
            Outcome::Processed { frame, result } => {
                let stack_peak = stack::peak_bytes();
                defmt::info!(
                    "frame {=u64}: {=str} {} pitch_alt {=f32} yaw_alt {=f32} resolved {=bool} range_used {=bool}; {} instructions, stack peak {=usize} B",
                    frame,
                    result.status.as_str(),
                    result.pose,
                    result.pitch_alt_deg,
                    result.yaw_alt_deg,
                    result.yaw_resolved,
                    result.range_used,
                    instructions,
                    stack_peak
                );
                line.clear();
                write!(line, "{frame},{},", result.status.as_str())
                    .and_then(|()| match instructions {
                        Some(n) => write!(line, "{n}"),
                        None => Ok(()),
                    })
                    .and_then(|()| write!(line, ",{stack_peak}"))
                    .map_err(|_| OutputError::LineTooLong)?;
                self.measurements.write_line(&line)?;
            }
            Outcome::Unusable { frame, status } => {
                defmt::warn!("frame {}: {=str}", frame, status);
            }
        }
        Ok(())
    }
}
