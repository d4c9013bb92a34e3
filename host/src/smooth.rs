//! `imade run --smooth`: a recorded clip's frames solved again at the range of a forward-backward
//! smoother.
//!
//! The live pipeline's range filter is causal: each frame's range uses that frame and the ones
//! before it. A recorded clip has the frames after it too. The filter's steps go backwards
//! through the Rauch-Tung-Striebel smoother of the core ([`range_filter::smooth`]), and every
//! frame whose range came from the image is solved again at its smoothed range, with the
//! smoothed sigma and the yaw side that the smoothed range rate decides. Where a sensor gave the
//! range, the range stands as given and only the yaw side is decided again, from the smoothed
//! rate of the sensor's ranges.

use imade_core::pipeline::Solved;
use imade_core::range_filter;
use imade_core::temporal::{Estimate, YawChoice};
use imade_core::{FrameResult, Pipeline};

/// One frame with a pose in a recorded clip: its place among the clip's rows and what it was
/// solved from.
#[derive(Debug, Clone, Copy)]
pub struct Recorded {
    /// Index of the frame's row in the clip's results.
    pub row: usize,
    /// What the pipeline solved the frame from.
    pub solved: Solved,
}

/// The smoothed results of the `recorded` frames (in time order) that the motion model took,
/// each with its row index.
pub fn smoothed_results(pipeline: &Pipeline, recorded: &[Recorded]) -> Vec<(usize, FrameResult)> {
    let filtered: Vec<&Recorded> = recorded
        .iter()
        .filter(|r| r.solved.range_step.is_some())
        .collect();
    let mut steps: Vec<_> = filtered
        .iter()
        .filter_map(|r| r.solved.range_step)
        .collect();
    range_filter::smooth(&mut steps);
    let sigmas = pipeline.config().temporal.trend_sigma;
    filtered
        .iter()
        .zip(&steps)
        .map(|(r, step)| {
            let (rate, rate_sd) = step.rate();
            let choice = YawChoice::of_rate(rate, rate_sd, sigmas, r.solved.estimate.choice.away);
            let estimate = if r.solved.measurement.hypothesis.sensor_range_m.is_some() {
                // The sensor's range stands as given; only the side is decided again.
                Estimate {
                    choice,
                    ..r.solved.estimate
                }
            } else {
                let range = step.range();
                Estimate {
                    range_m: range.range_m,
                    range_sd_m: Some(range.sd_m),
                    choice,
                }
            };
            (r.row, pipeline.resolve(&r.solved, &estimate))
        })
        .collect()
}
