//! `imade run --smooth`: a recorded clip's frames solved again at the range of a forward-backward
//! smoother.
//!
//! The live pipeline's range filter is causal: each frame's range uses that frame and the ones
//! before it. A recorded clip has the frames after it too. The filter's steps go backwards
//! through the Rauch-Tung-Striebel smoother of the core ([`range_filter::smooth`]), and every
//! frame whose range came from the image is solved again at its smoothed range, with the
//! smoothed sigma and the yaw side that the smoothed range rate decides. Where a sensor gave the
//! range, the range stands as given and only the yaw side is decided again, from the smoothed
//! rate of the sensor's ranges. Where the frames came with the mount's pointing, the flight
//! filter's steps ([`flight_filter`]) are smoothed alike, and a frame whose range came from the
//! image takes the smoothed flight's range, sigma and range rate instead: the lines of sight
//! after it fix its range better than anything before it could.

use imade_core::flight_filter::{self, FlightStep};
use imade_core::pipeline::Solved;
use imade_core::range_filter::{self, FilterStep};
use imade_core::temporal::{Estimate, YawChoice};
use imade_core::world::{self, FLIGHT_SAMPLES, Motion, Position, WorldConfig};
use imade_core::{FrameResult, Pipeline};

/// One processed frame of a recorded clip: its place among the clip's rows, the range filter's
/// step there (where it took a range) and what its pose was solved from (where it has one).
#[derive(Debug, Clone, Copy)]
pub struct Recorded {
    /// Index of the frame's row in the clip's results.
    pub row: usize,
    /// The range filter's step ([`Pipeline::last_range_step`]).
    pub step: Option<FilterStep>,
    /// The flight filter's step ([`Pipeline::last_flight_step`]).
    pub flight: Option<FlightStep>,
    /// What the pipeline solved the frame's pose from ([`Pipeline::last_solved`]).
    pub solved: Option<Solved>,
    /// The body origin in the world frame, where the frame has a pose and the mount's pointing.
    pub position: Option<Position>,
}

/// The smoothed results of the `recorded` frames (in time order) that have a pose and a filter
/// step (the range filter's or the flight filter's), each with its row index. Every step goes
/// through its smoother, also those of frames without a pose (a sensor's range where the image
/// gave none), so the backward pass runs through them.
pub fn smoothed_results(pipeline: &Pipeline, recorded: &[Recorded]) -> Vec<(usize, FrameResult)> {
    let stepped: Vec<&Recorded> = recorded
        .iter()
        .filter(|r| r.step.is_some() || r.flight.is_some())
        .collect();
    let (mut steps, step_index) = gathered(stepped.iter().map(|r| r.step));
    range_filter::smooth(&mut steps);
    let (mut flights, flight_index) = gathered(stepped.iter().map(|r| r.flight));
    flight_filter::smooth(&mut flights, &pipeline.config().temporal.flight);
    let sigmas = pipeline.config().temporal.trend_sigma;
    let positions: Vec<Position> = recorded.iter().filter_map(|r| r.position).collect();
    let world_config = &pipeline.config().world;
    stepped
        .iter()
        .zip(step_index.iter().zip(&flight_index))
        .filter_map(|(r, (step, flight))| {
            let step = step.and_then(|i| steps.get(i));
            let flight = flight
                .and_then(|i| flights.get(i))
                .map(FlightStep::estimate);
            // The flight's range and rate where it took the frame, else the range filter's.
            let (range, rate) = match (flight, step) {
                (Some(f), _) => (
                    (f.range.range_m as f32, f.range.sd_m as f32),
                    (f.rate_m_s.0 as f32, f.rate_m_s.1 as f32),
                ),
                (None, Some(step)) => {
                    let range = step.range();
                    ((range.range_m, range.sd_m), step.rate())
                }
                (None, None) => return None,
            };
            let velocity = flight.map(|f| f.velocity_enu_m_s);
            Some((r, r.solved.as_ref()?, range, rate, velocity))
        })
        .map(|(r, solved, (range_m, sd_m), (rate, rate_sd), flown)| {
            let choice = YawChoice::of_rate(rate, rate_sd, sigmas, solved.estimate.choice.away);
            let estimate = if solved.measurement.hypothesis.sensor_range_m().is_some() {
                // The sensor's range stands as given; only the side is decided again.
                Estimate {
                    choice,
                    ..solved.estimate
                }
            } else {
                Estimate {
                    range_m,
                    range_sd_m: Some(sd_m),
                    choice,
                }
            };
            // The velocity from the positions before and after the frame (a sensor's), else
            // the smoothed flight's.
            let motion = solved.motion.map(|m| Motion {
                velocity_enu_m_s: r
                    .position
                    .and_then(|p| centred_velocity(&positions, p.time_s, world_config))
                    .or(flown),
                ..m
            });
            let solved = Solved { motion, ..*solved };
            (r.row, pipeline.resolve(&solved, &estimate))
        })
        .collect()
}

/// The items that are there, in order, and each slot's index among them.
fn gathered<T>(slots: impl Iterator<Item = Option<T>>) -> (Vec<T>, Vec<Option<usize>>) {
    let mut items = Vec::new();
    let index = slots
        .map(|slot| {
            slot.map(|item| {
                items.push(item);
                items.len() - 1
            })
        })
        .collect();
    (items, index)
}

/// The velocity at `time_s` from the recorded `positions` around it, before and after: the
/// [`FLIGHT_SAMPLES`] nearest in time within half the live fit's span either side.
pub(crate) fn centred_velocity(
    positions: &[Position],
    time_s: f64,
    config: &WorldConfig,
) -> Option<[f64; 3]> {
    let mut near: Vec<&Position> = positions
        .iter()
        .filter(|p| (p.time_s - time_s).abs() <= 0.5 * config.max_span_s)
        .collect();
    near.sort_by(|a, b| {
        (a.time_s - time_s)
            .abs()
            .total_cmp(&(b.time_s - time_s).abs())
    });
    near.truncate(FLIGHT_SAMPLES);
    world::velocity_at(near, time_s)
}
