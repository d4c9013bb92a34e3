//! The JSON summary of `imade run` (`summary.json` in the output folder): per clip, the status
//! counts, every input problem with its file, line and frame, and the time taken.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::PathBuf;

/// Format identifier of `summary.json`.
pub const SUMMARY_FORMAT: &str = "imade-run-summary/1";

/// What `imade run` did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunSummary {
    /// Always [`SUMMARY_FORMAT`].
    pub format: String,
    /// One entry per clip, in the order given.
    pub clips: Vec<ClipSummary>,
}

/// What became of one clip.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct ClipSummary {
    /// The clip folder.
    pub clip: PathBuf,
    /// How range measurements were used (`auto`, `given` or `ignore`).
    pub range: String,
    /// The results file, where one was written.
    pub results: Option<PathBuf>,
    /// Why the clip could not be processed at all, where it could not.
    pub error: Option<String>,
    /// Result rows written (one per data row of `frames.csv`).
    pub frames: usize,
    /// Rows per status (`ok`, `no_target`, `bad_chip`, ...).
    pub statuses: BTreeMap<String, usize>,
    /// Every frame whose input was unusable.
    pub problems: Vec<Problem>,
    /// Wall time spent on the clip, s.
    pub seconds: f64,
}

/// One unusable frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Problem {
    /// Line of `frames.csv` (the header is line 1).
    pub line: u64,
    /// Frame number, where it could be read.
    pub frame: Option<u64>,
    /// What is wrong, naming the file.
    pub message: String,
}

impl ClipSummary {
    /// Counts one written row of `status`.
    pub fn count(&mut self, status: &str) {
        self.frames += 1;
        *self.statuses.entry(status.to_owned()).or_default() += 1;
    }

    /// Rows with a pose.
    pub fn ok(&self) -> usize {
        self.statuses.get("ok").copied().unwrap_or(0)
    }
}

impl RunSummary {
    /// Frames with unusable input, over all clips.
    pub fn bad_frames(&self) -> usize {
        self.clips.iter().map(|c| c.problems.len()).sum()
    }

    /// Clips that could not be processed at all.
    pub fn failed_clips(&self) -> usize {
        self.clips.iter().filter(|c| c.error.is_some()).count()
    }
}
