//! Temporal state in fixed memory: range smoothing (the motion model's filter, or the source
//! paper's Eq. 5), the range trend over a window, and the yaw choice it resolves.
//!
//! By default the image range goes through the motion model's Kalman filter
//! ([`crate::range_filter`]), whose measurement noise is the window's own scatter (of each
//! sample about its neighbours' chord). Eq. 5 stays for comparison with the source paper: it
//! blends the current estimate with the previous one: `Tz(t) = r Tz_meas + (1 - r) Tz(t-1)`.
//! A projectile's range changes by metres per frame, so blending with the previous value as it
//! was would lag the truth by `(1 - r) / r` frames of motion; here the previous smoothed value is
//! first carried to the current time along the window's robust trend. The trend is the
//! Theil-Sen slope of the measured slant range against time; it resolves the yaw choice when it
//! differs from zero by `trend_sigma` standard errors: a growing range means the nose points away
//! (nose-first flight), a shrinking one that it points towards the camera. While no stretch of the
//! window is significant, the filter's range rate chooses (a range sensor's readings go through
//! the filter too). A recorded clip's filter steps can be smoothed afterwards
//! ([`crate::range_filter::smooth`]).

use crate::capacity::MAX_WINDOW;
use crate::flight_filter::{
    FlightEstimate, FlightFilter, FlightFilterConfig, FlightStep, RangeReading, Sight,
};
use crate::point::ImagePoint;
use crate::range_filter::{FilterStep, ImageScale, RangeFilter, RangeFilterConfig};

/// How the image range is smoothed across frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RangeSmoothing {
    /// The motion model's Kalman filter ([`crate::range_filter`]): range, rate and acceleration,
    /// each frame weighted by the window's measured noise; gives the range's uncertainty.
    MotionModel,
    /// The source paper's Eq. 5 (`tz_smoothing_r`), carried along the window's trend; no
    /// uncertainty.
    Eq5,
}

/// The temporal stage's tunables.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TemporalConfig {
    /// How the image range is smoothed.
    pub range_smoothing: RangeSmoothing,
    /// The motion model's tunables: its filter smooths the image range
    /// ([`RangeSmoothing::MotionModel`]) and takes a range sensor's readings in either mode.
    pub range_filter: RangeFilterConfig,
    /// The flight's motion model ([`crate::flight_filter`]): where a frame without a range
    /// sensor comes with its line of sight in the world frame, its range is the flight
    /// filter's (gravity's bend of the path across the lines of sight scales it), and the
    /// filter's range rate chooses the yaw side.
    pub flight: FlightFilterConfig,
    /// Weight `r` of the source paper's Eq. 5 Tz smoothing, in (0, 1], for frames
    /// `tz_smoothing_interval_s` apart; 1 disables smoothing.
    pub tz_smoothing_r: f32,
    /// The frame interval `r` is for, s (the source paper's 30 Hz camera). Frames further apart
    /// blend as that many steps would: `1 - (1 - r)^(dt / interval)`, so a clip that keeps every
    /// n-th frame is not smoothed n times harder.
    pub tz_smoothing_interval_s: f32,
    /// Frames in the window for the Tz trend (at most [`MAX_WINDOW`]).
    pub window_frames: usize,
    /// Fewest frames in the window before its range trend can resolve the yaw choice.
    pub min_trend_frames: usize,
    /// Significance of the Tz trend, in standard errors, needed to resolve the yaw choice.
    pub trend_sigma: f32,
    /// A gap between frames longer than this, s, resets the temporal state.
    pub max_gap_s: f32,
    /// The range is predicted (and detection judges candidates by the body's size at it) only
    /// where the window's ranges scatter about their neighbours' chords by at most this
    /// fraction of the range: a few image ranges read off in clutter would carry the size
    /// expected away from the body's, which then is no candidate.
    pub max_predicted_scatter: f32,
}

/// Eq. 5's weight for frames `dt` s apart: `r` per `tz_smoothing_interval_s`, compounded (the
/// weight itself for a non-positive or non-finite interval).
fn step_weight(config: &TemporalConfig, dt: f32) -> f32 {
    let r = config.tz_smoothing_r.clamp(0.0, 1.0);
    let steps = dt / config.tz_smoothing_interval_s;
    if !(steps.is_finite() && steps > 1.0) {
        return r;
    }
    (1.0 - libm::powf(1.0 - r, steps)).clamp(0.0, 1.0)
}

impl TemporalConfig {
    /// The defaults.
    pub const DEFAULT: TemporalConfig = TemporalConfig {
        range_smoothing: RangeSmoothing::MotionModel,
        range_filter: RangeFilterConfig::DEFAULT,
        flight: FlightFilterConfig::DEFAULT,
        tz_smoothing_r: 0.1,
        tz_smoothing_interval_s: 1.0 / 30.0,
        window_frames: 15,
        min_trend_frames: 4,
        trend_sigma: 3.0,
        max_gap_s: 1.0,
        max_predicted_scatter: 0.08,
    };
}

impl Default for TemporalConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// What the temporal state tells a frame before its image work.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prediction {
    /// The frame's time from the first frame kept, s.
    pub t: f32,
    /// The nose's image direction of the last frame with a pose, if any.
    pub nose_dir: Option<ImagePoint>,
    /// The slant range expected at this frame, m: the flight filter's where it is sure
    /// ([`FlightFilterConfig::size_fraction`]), else the recent ones' (the last range in the
    /// window carried along the trend); None before any.
    pub range_m: Option<f32>,
    /// The flight filter's range for this frame and its sigma, where it is sure enough to hold
    /// the image's scale at ([`FlightFilterConfig::hold_fraction`]).
    pub held_range: Option<RangeReading>,
    /// Whether the nose points away from the camera, as the last resolved yaw choice had it
    /// (None before any).
    pub nose_away: Option<bool>,
}

/// One frame's observation for the temporal state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Observation {
    /// The slant range from the image, m (None where the range sensor's is used).
    pub image_range_m: Option<f32>,
    /// The nose's image direction.
    pub nose_dir: ImagePoint,
    /// The scale the image range was read at.
    pub scale: ImageScale,
    /// The line of sight to the body origin in the world frame, where the frame came with the
    /// mount's pointing.
    pub sight: Option<Sight>,
    /// Whether the image stages held the scale at the flight's range
    /// ([`Prediction::held_range`]): the frame then gives the flight its sight alone.
    pub range_held: bool,
}

/// The temporal stage's estimate for a frame with a pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// Slant range: the sensor's, else the smoothed image range, m.
    pub range_m: f32,
    /// One sigma of `range_m` where the motion model gave it, m (None for the sensor's range,
    /// whose noise the clip does not state, and for Eq. 5).
    pub range_sd_m: Option<f32>,
    /// The yaw choice.
    pub choice: YawChoice,
}

/// Pairs of a full window, for the Theil-Sen slope.
const MAX_PAIRS: usize = MAX_WINDOW * (MAX_WINDOW - 1) / 2;

#[derive(Debug, Clone, Copy)]
struct Sample {
    t: f32,
    range: f32,
}

/// The range trend over the window.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Trend {
    /// Slope of the slant range, m/s.
    pub slope: f32,
    /// Its standard error, m/s.
    pub stderr: f32,
    /// Samples in the window.
    pub frames: u8,
}

/// The yaw choice between the two mirror candidates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct YawChoice {
    /// True: the nose points away from the camera (candidate 0); false: towards it.
    pub away: bool,
    /// True when the evidence decided it: the window's range trend, or the filter's range rate,
    /// beyond `trend_sigma` of their standard errors.
    pub resolved: bool,
}

impl YawChoice {
    /// The choice a range rate of `rate_m_s` ± `sd_m_s` (one sigma) makes: the side of its sign
    /// (a growing range: the nose points away in nose-first flight), the likelier one, resolved
    /// where the rate differs from zero by more than `sigmas` sigmas; `fallback`, unresolved,
    /// where the rate has no sign or its sigma is not positive. An unresolved side follows the
    /// rate's sign even within a sigma of zero: keeping the last side instead (tried) was right
    /// less often (small-towards-camera without the range: 65 % against 80 %).
    pub fn of_rate(rate_m_s: f32, sd_m_s: f32, sigmas: f32, fallback: bool) -> YawChoice {
        if !(rate_m_s.is_finite() && rate_m_s != 0.0 && sd_m_s > 0.0) {
            return YawChoice {
                away: fallback,
                resolved: false,
            };
        }
        YawChoice {
            away: rate_m_s > 0.0,
            resolved: libm::fabsf(rate_m_s) > sigmas * sd_m_s,
        }
    }
}

/// The temporal state.
#[derive(Debug, Clone)]
pub struct Temporal {
    window: heapless::Deque<Sample, MAX_WINDOW>,
    origin_s: Option<f64>,
    last_t: f32,
    smoothed: Option<Sample>,
    filter: RangeFilter,
    flight: FlightFilter,
    last_away: Option<bool>,
    nose_dir: Option<ImagePoint>,
}

impl Default for Temporal {
    fn default() -> Self {
        Self::new()
    }
}

impl Temporal {
    /// An empty state.
    pub const fn new() -> Self {
        Temporal {
            window: heapless::Deque::new(),
            origin_s: None,
            last_t: 0.0,
            smoothed: None,
            filter: RangeFilter::new(),
            flight: FlightFilter::new(),
            last_away: None,
            nose_dir: None,
        }
    }

    /// The range filter's step at the frame of time `t` (s, [`Prediction::t`]), where it took
    /// that frame's range.
    pub fn range_step(&self, t: f32) -> Option<FilterStep> {
        self.filter.last_step().filter(|step| step.time_s() == t)
    }

    /// The flight filter's step at the frame of time `t` (s, [`Prediction::t`]), where it took
    /// that frame.
    pub fn flight_step(&self, t: f32) -> Option<FlightStep> {
        self.flight
            .last_step()
            .filter(|step| step.time_s() == f64::from(t))
    }

    /// Forgets everything.
    pub fn reset(&mut self) {
        *self = Self::new();
    }

    /// What the state tells the frame captured at `time_s` (s, any origin) before its image
    /// work. A frame not after the last one, or after a gap longer than `config.max_gap_s`,
    /// resets the state first. The range is predicted only within `config.max_gap_s` of the
    /// window's last range (frames without one, no pose and no sensor, leave the trend's
    /// extrapolation to grow without a check, and a wrong prediction would keep the body, no
    /// longer of its size, from being found again), and only from three ranges or more that
    /// scatter by at most `config.max_predicted_scatter`; where the flight filter predicts the
    /// range surely enough ([`FlightFilterConfig::size_fraction`]), its range instead.
    pub fn predict(&mut self, time_s: f64, config: &TemporalConfig) -> Prediction {
        let t = self.frame_time(time_s, config);
        let slope = self.trend().map_or(0.0, |tr| tr.slope);
        let range_m = self
            .window
            .back()
            .filter(|last| t - last.t <= config.max_gap_s)
            .filter(|last| {
                self.noise()
                    .is_some_and(|n| n <= config.max_predicted_scatter * last.range)
            })
            .map(|last| last.range + slope * (t - last.t))
            .filter(|r| r.is_finite() && *r > 0.0);
        let flown = self
            .flight
            .predicted_range(f64::from(t), &config.flight)
            .filter(|_| config.flight.enabled);
        let sure = |fraction: f32| move |r: &RangeReading| r.sd_m < f64::from(fraction) * r.range_m;
        let range_m = flown
            .filter(sure(config.flight.size_fraction))
            .map(|r| r.range_m as f32)
            .or(range_m);
        let held_range = flown.filter(sure(config.flight.hold_fraction));
        Prediction {
            t,
            nose_dir: self.nose_dir,
            range_m,
            held_range,
            nose_away: self.last_away,
        }
    }

    /// Takes the frame's range sensor reading `sensor_range_m` (evidence of the range trend
    /// whatever became of the image) and, where the image gave a pose, its `observation`: the
    /// image range is smoothed and joins the window, the nose direction is kept, and the yaw is
    /// chosen. The estimate is None without an observation, or without any range.
    pub fn update(
        &mut self,
        prediction: &Prediction,
        sensor_range_m: Option<f32>,
        observation: Option<Observation>,
        config: &TemporalConfig,
    ) -> Option<Estimate> {
        let t = prediction.t;
        if let Some(r) = sensor_range_m {
            self.push_range(t, r, config);
            // The sensor's range goes through the motion model too: its rate decides the yaw
            // side of a smoothed recorded clip (`crate::range_filter::smooth`).
            let _ =
                self.filter
                    .update(t, r, self.noise(), &ImageScale::SHARP, &config.range_filter);
        }
        let observation = observation?;
        let mut flight_rate = None;
        let (range_m, range_sd_m) = match (sensor_range_m, observation.image_range_m) {
            (Some(r), _) => (r, None),
            (None, Some(r)) => match config.range_smoothing {
                RangeSmoothing::Eq5 => {
                    let smoothed = self.smooth_range(t, r, config);
                    self.push_range(t, r, config);
                    (smoothed, None)
                }
                RangeSmoothing::MotionModel if observation.range_held => {
                    // The image's scale was the flight's: the frame adds its sight alone, and
                    // the window the flight's range. A sight the flight leaves out keeps the
                    // range it was held at.
                    let flown = observation.sight.and_then(|sight| {
                        self.flight
                            .update_sight(f64::from(t), &sight, &config.flight)
                    });
                    flight_rate = flown.map(|f| f.rate_m_s);
                    let range = flown.map(|f| f.range).or(prediction.held_range)?;
                    let range_m = range.range_m as f32;
                    self.push_range(t, range_m, config);
                    (range_m, Some(range.sd_m as f32))
                }
                RangeSmoothing::MotionModel => {
                    self.push_range(t, r, config);
                    let noise = self.noise();
                    let filtered = self.filter.update(
                        t,
                        r,
                        noise,
                        &observation.scale,
                        &config.range_filter,
                    )?;
                    let sd = noise.unwrap_or(config.range_filter.initial_noise_fraction * r);
                    let reading = RangeReading {
                        range_m: f64::from(r),
                        sd_m: f64::from(sd),
                    };
                    let flown = observation
                        .sight
                        .filter(|_| config.flight.enabled)
                        .and_then(|sight| {
                            self.flight
                                .update(f64::from(t), &sight, reading, &config.flight)
                        });
                    // A flight not yet established speaks for the frame only where it agrees
                    // with the range filter: one started from two image ranges far apart can
                    // run off at its next frame.
                    let gate = f64::from(config.flight.young_gate_sigmas);
                    let agrees = |flown: &FlightEstimate| {
                        let (a, b) = (flown.range, filtered);
                        let sd = libm::sqrt(a.sd_m * a.sd_m + f64::from(b.sd_m * b.sd_m));
                        libm::fabs(a.range_m - f64::from(b.range_m)) <= gate * sd
                    };
                    let established = self.flight.established(&config.flight);
                    match flown.filter(|flown| established || agrees(flown)) {
                        Some(flown) => {
                            flight_rate = Some(flown.rate_m_s);
                            (flown.range.range_m as f32, Some(flown.range.sd_m as f32))
                        }
                        None => (filtered.range_m, Some(filtered.sd_m)),
                    }
                }
            },
            (None, None) => return None,
        };
        self.nose_dir = Some(observation.nose_dir);
        let flight_rate = flight_rate.map(|(rate, sd)| (rate as f32, sd as f32));
        let choice = self.choose_yaw(t, flight_rate, config);
        Some(Estimate {
            range_m,
            range_sd_m,
            choice,
        })
    }

    /// Time of a frame relative to the first frame kept, s. A frame not after the last one, or
    /// after a gap longer than `config.max_gap_s`, resets the state first.
    fn frame_time(&mut self, time_s: f64, config: &TemporalConfig) -> f32 {
        if let Some(origin) = self.origin_s {
            let t = (time_s - origin) as f32;
            let gap = t - self.last_t;
            if t.is_finite() && gap > 0.0 && gap <= config.max_gap_s {
                self.last_t = t;
                return t;
            }
            self.reset();
        }
        self.origin_s = Some(time_s);
        self.last_t = 0.0;
        0.0
    }

    /// Smooths a slant range measured from the image at time `t` (Eq. 5 with trend), m.
    fn smooth_range(&mut self, t: f32, measured: f32, config: &TemporalConfig) -> f32 {
        let value = match self.smoothed {
            Some(prev) => {
                let slope = self.trend().map_or(0.0, |tr| tr.slope);
                let predicted = prev.range + slope * (t - prev.t);
                let r = step_weight(config, t - prev.t);
                r * measured + (1.0 - r) * predicted
            }
            None => measured,
        };
        self.smoothed = Some(Sample { t, range: value });
        value
    }

    /// Adds a measured slant range at time `t` to the window.
    fn push_range(&mut self, t: f32, range: f32, config: &TemporalConfig) {
        let capacity = config.window_frames.clamp(2, MAX_WINDOW);
        while self.window.len() >= capacity {
            self.window.pop_front();
        }
        // Room is guaranteed by the loop above.
        let _ = self.window.push_back(Sample { t, range });
    }

    /// The Theil-Sen trend of the window, with a robust standard error; none with fewer than 3
    /// samples.
    pub fn trend(&self) -> Option<Trend> {
        self.recent_trend(self.window.len())
    }

    /// The Theil-Sen trend of the last `frames` samples of the window (all of them where there
    /// are fewer), with a robust standard error; none with fewer than 3 samples.
    pub fn recent_trend(&self, frames: usize) -> Option<Trend> {
        let n = frames.min(self.window.len());
        if n < 3 {
            return None;
        }
        let recent = || self.window.iter().skip(self.window.len() - n);
        let mut slopes = [0.0f32; MAX_PAIRS];
        let mut count = 0usize;
        for (i, a) in recent().enumerate() {
            for b in recent().skip(i + 1) {
                let dt = b.t - a.t;
                if dt > 0.0
                    && let Some(slot) = slopes.get_mut(count)
                {
                    *slot = (b.range - a.range) / dt;
                    count += 1;
                }
            }
        }
        let slope = median(slopes.get_mut(..count)?)?;
        let mut residuals = [0.0f32; MAX_WINDOW];
        let mut intercepts = [0.0f32; MAX_WINDOW];
        for ((s, r), i) in recent()
            .zip(residuals.iter_mut())
            .zip(intercepts.iter_mut())
        {
            *i = s.range - slope * s.t;
            *r = *i;
        }
        let intercept = median(intercepts.get_mut(..n)?)?;
        for r in residuals.iter_mut().take(n) {
            *r = libm::fabsf(*r - intercept);
        }
        // A few samples can lie on a line by chance: the scatter about the line is not trusted
        // below the noise of the whole window.
        let spread = (1.4826 * median(residuals.get_mut(..n)?)?).max(self.noise().unwrap_or(0.0));
        let mean_t = recent().map(|s| s.t).sum::<f32>() / n as f32;
        let sxx: f32 = recent().map(|s| (s.t - mean_t) * (s.t - mean_t)).sum();
        Some(Trend {
            slope,
            stderr: spread / libm::sqrtf(sxx.max(1e-12)),
            frames: n as u8,
        })
    }

    /// The noise of the measured range over the whole window, m: the robust spread of each
    /// inner sample about the chord of its two neighbours, scaled to one sample's noise. Chords
    /// follow a trend and, between neighbours, most of a curve, so this is the measurement's
    /// own scatter; none with fewer than 3 samples.
    fn noise(&self) -> Option<f32> {
        let mut deviations = [0.0f32; MAX_WINDOW];
        let mut count = 0usize;
        let samples = || self.window.iter();
        for ((a, b), c) in samples().zip(samples().skip(1)).zip(samples().skip(2)) {
            // Frame times increase strictly (`frame_time`), so the span is positive.
            let span = c.t - a.t;
            let (wa, wc) = ((c.t - b.t) / span, (b.t - a.t) / span);
            let chord = wa * a.range + wc * c.range;
            if let Some(slot) = deviations.get_mut(count) {
                *slot = libm::fabsf(b.range - chord) / libm::sqrtf(1.0 + wa * wa + wc * wc);
                count += 1;
            }
        }
        Some(1.4826 * median(deviations.get_mut(..count)?)?)
    }

    /// Chooses between the mirror candidates from the range trend of the shortest recent stretch
    /// of the window (at least `config.min_trend_frames` frames) whose slope is significant: the
    /// least delayed evidence, so that a range that turns (a projectile passing its closest
    /// point) changes the choice within a few frames instead of half a window. While no stretch
    /// is significant, the motion model's range rate at the frame of time `t` chooses (the
    /// likelier side, resolved where the rate is significant: [`YawChoice::of_rate`]); without
    /// it, the last resolved choice stands (or "away", for a projectile flying off from the
    /// launcher). Where the flight filter took the frame, its `flight_rate` (m/s and its sigma)
    /// chooses instead of the trend: the lines of sight and gravity tell it, not the image
    /// ranges.
    fn choose_yaw(
        &mut self,
        t: f32,
        flight_rate: Option<(f32, f32)>,
        config: &TemporalConfig,
    ) -> YawChoice {
        let shortest = config.min_trend_frames.max(3);
        let decided = flight_rate
            .is_none()
            .then(|| {
                (shortest..=self.window.len())
                    .filter_map(|frames| self.recent_trend(frames))
                    .find(|tr| libm::fabsf(tr.slope) > config.trend_sigma * tr.stderr)
            })
            .flatten();
        let choice = match decided {
            Some(tr) => YawChoice {
                away: tr.slope > 0.0,
                resolved: true,
            },
            None => {
                let fallback = self.last_away.unwrap_or(true);
                // Without a filter's step the rate has no sign: the fallback stands.
                let (rate, rate_sd) = flight_rate
                    .or_else(|| self.range_step(t).map(|step| step.rate()))
                    .unwrap_or((0.0, 0.0));
                YawChoice::of_rate(rate, rate_sd, config.trend_sigma, fallback)
            }
        };
        if choice.resolved {
            self.last_away = Some(choice.away);
        }
        choice
    }
}

/// Median of a slice (reordered in place); none when empty.
fn median(values: &mut [f32]) -> Option<f32> {
    if values.is_empty() {
        return None;
    }
    let mid = values.len() / 2;
    let (_, m, _) = values.select_nth_unstable_by(mid, f32::total_cmp);
    Some(*m)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ballistic flight's frame at `t` s seen from `station`: its true range and its line of
    /// sight, turned `off` rad across (a detection that took something else).
    fn flight_frame(station: [f64; 3], t: f64, off: f64) -> (f64, Sight) {
        let p = [80.0 * t, 100.0 * t, 500.0 + 60.0 * t - 4.903_325 * t * t];
        let d = [p[0] - station[0], p[1] - station[1], p[2] - station[2]];
        let range = libm::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        let dir = [
            d[0] / range + off * d[1] / range,
            d[1] / range - off * d[0] / range,
            d[2] / range,
        ];
        let norm = libm::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
        let sight = Sight {
            station_enu_m: station,
            dir_enu: [dir[0] / norm, dir[1] / norm, dir[2] / norm],
            sd_rad: 1e-5,
        };
        (range, sight)
    }

    /// Once the flight is sure of its range the next frame's scale is held there; such a frame
    /// keeps its pose even where the flight leaves its sight out (a detection that took
    /// something else): its range is the one it was held at.
    #[test]
    fn a_held_frame_the_flight_leaves_out_keeps_its_range() {
        // Held where sure to 1 % (image ranges 2 % apart reach the default's 0.5 % only late).
        let config = TemporalConfig {
            flight: FlightFilterConfig {
                hold_fraction: 0.01,
                ..FlightFilterConfig::DEFAULT
            },
            ..TemporalConfig::DEFAULT
        };
        let station = [-900.0, -600.0, 2.0];
        let mut temporal = Temporal::new();
        let observation = |range: f64, sight: Sight, held: bool| Observation {
            image_range_m: Some(range as f32),
            nose_dir: ImagePoint::new(1.0, 0.0),
            scale: ImageScale::SHARP,
            sight: Some(sight),
            range_held: held,
        };
        let mut held = None;
        for k in 0..40 {
            let time_s = 0.5 * f64::from(k);
            let prediction = temporal.predict(time_s, &config);
            if let Some(range) = prediction.held_range {
                held = Some((time_s, prediction, range));
                break;
            }
            let (range, sight) = flight_frame(station, time_s, 0.0);
            temporal.update(
                &prediction,
                None,
                Some(observation(range, sight, false)),
                &config,
            );
        }
        let (time_s, prediction, range) = held.expect("the flight never became sure");
        let (truth, off) = flight_frame(station, time_s, 1e-3);
        assert!(libm::fabs(range.range_m - truth) < 2.5 * range.sd_m);
        let estimate = temporal
            .update(
                &prediction,
                None,
                Some(observation(truth, off, true)),
                &config,
            )
            .expect("the held frame lost its pose");
        assert_eq!(estimate.range_m, range.range_m as f32);
    }

    /// Among clutter the image ranges mostly read short (a filament or the plume widens the
    /// silhouette): here every other frame's is 25 % short. The window's ranges then scatter
    /// too much to predict from, while the flight's lines of sight and gravity fix the range:
    /// once the flight is sure of it ([`FlightFilterConfig::size_fraction`]), the range
    /// expected for the next frame (the body's size the detection looks for) is the flight's,
    /// within 3 % of the truth. Without the flight, none is expected.
    #[test]
    fn the_size_expected_among_short_image_ranges_is_the_flights() {
        let station = [-900.0, -600.0, 2.0];
        let predicted = |config: &TemporalConfig| {
            let mut temporal = Temporal::new();
            for k in 0..30 {
                let time_s = 0.5 * f64::from(k);
                let prediction = temporal.predict(time_s, config);
                let (range, sight) = flight_frame(station, time_s, 0.0);
                let short = if k % 2 == 1 { 0.75 } else { 1.0 };
                let observation = Observation {
                    image_range_m: Some((range * short) as f32),
                    nose_dir: ImagePoint::new(1.0, 0.0),
                    scale: ImageScale::SHARP,
                    sight: Some(sight),
                    range_held: false,
                };
                temporal.update(&prediction, None, Some(observation), config);
            }
            temporal.predict(15.0, config).range_m
        };
        let (truth, _) = flight_frame(station, 15.0, 0.0);
        let flown = predicted(&TemporalConfig::DEFAULT).expect("no range expected");
        assert!(
            libm::fabs(f64::from(flown) / truth - 1.0) < 0.03,
            "{flown} m against {truth}"
        );
        let without_flight = TemporalConfig {
            flight: FlightFilterConfig {
                enabled: false,
                ..FlightFilterConfig::DEFAULT
            },
            ..TemporalConfig::DEFAULT
        };
        assert_eq!(predicted(&without_flight), None);
    }

    /// Eq. 5's weight compounds over the frames a clip skipped: r for frames one interval apart
    /// (or closer), 1 - 0.9^2 = 0.19 for two, 1 - 0.9^8 for eight; r = 1 stays 1.
    #[test]
    fn the_smoothing_weight_compounds_over_skipped_frames() {
        let config = TemporalConfig::DEFAULT;
        let step = config.tz_smoothing_interval_s;
        assert_eq!(step_weight(&config, step * 0.5), 0.1);
        assert!((step_weight(&config, step) - 0.1).abs() < 1e-5);
        assert!((step_weight(&config, 2.0 * step) - 0.19).abs() < 1e-5);
        let eight = 1.0 - 0.9f32.powi(8);
        assert!((step_weight(&config, 8.0 * step) - eight).abs() < 1e-5);
        assert_eq!(step_weight(&config, f32::NAN), 0.1);
        let none = TemporalConfig {
            tz_smoothing_r: 1.0,
            ..config
        };
        assert_eq!(step_weight(&none, 8.0 * step), 1.0);
    }

    #[test]
    fn resolves_a_growing_range_as_away_and_a_shrinking_one_as_towards() {
        let config = TemporalConfig::DEFAULT;
        for (rate, away) in [(90.0f32, true), (-90.0, false)] {
            let mut state = Temporal::new();
            let mut choice = state.choose_yaw(0.0, None, &config);
            assert!(!choice.resolved);
            for k in 0..12 {
                let t = state.frame_time(100.0 + k as f64 / 30.0, &config);
                // +-2 m of alternating noise on a linear trend.
                let noise = if k % 2 == 0 { 2.0 } else { -2.0 };
                state.push_range(t, 1500.0 + rate * t + noise, &config);
                choice = state.choose_yaw(t, None, &config);
            }
            assert!(choice.resolved, "rate {rate}");
            assert_eq!(choice.away, away);
            let trend = state.trend().unwrap();
            assert!((trend.slope - rate).abs() < 15.0, "slope {}", trend.slope);
        }
    }

    #[test]
    fn a_range_that_turns_changes_the_choice_within_three_frames() {
        // A pass of the closest point: r = 1000 + c (t - t0)^2, sampled every 0.27 s (a clip
        // kept every 8th frame) with 1 cm of noise. A chord of 5 samples has the sign of the
        // range rate 2 frames back; the samples' deviation from their neighbours' chords, c dt^2,
        // is taken as noise, so the slope is significant (3 standard errors) from 2.6 frames
        // after the turn.
        let config = TemporalConfig::DEFAULT;
        let (c, t0, dt) = (40.0f32, 2.5f32, 0.27f32);
        let mut state = Temporal::new();
        for k in 0..20 {
            let t = state.frame_time(f64::from(k as f32 * dt), &config);
            let noise = if k % 2 == 0 { 0.01 } else { -0.01 };
            state.push_range(t, 1000.0 + c * (t - t0) * (t - t0) + noise, &config);
            let choice = state.choose_yaw(t, None, &config);
            if k >= 4 && t <= t0 - 3.0 * dt {
                assert!(choice.resolved && !choice.away, "frame {k}: {choice:?}");
            }
            if t >= t0 + 3.0 * dt {
                assert!(choice.resolved && choice.away, "frame {k}: {choice:?}");
            }
        }
    }

    /// A rate beyond three sigmas resolves the side of its sign; within them it still picks
    /// that side, unresolved; a rate without a sign or a sigma that is not positive keeps the
    /// fallback.
    #[test]
    fn a_range_rate_chooses_the_side_of_its_sign() {
        let choice = |rate: f32, sd: f32| YawChoice::of_rate(rate, sd, 3.0, true);
        assert_eq!(
            choice(-40.0, 10.0),
            YawChoice {
                away: false,
                resolved: true
            }
        );
        assert_eq!(
            choice(25.0, 10.0),
            YawChoice {
                away: true,
                resolved: false
            }
        );
        assert_eq!(
            choice(-25.0, 10.0),
            YawChoice {
                away: false,
                resolved: false
            }
        );
        for (rate, sd) in [
            (0.0, 10.0),
            (-40.0, 0.0),
            (f32::NAN, 1.0),
            (-40.0, f32::NAN),
        ] {
            assert_eq!(
                choice(rate, sd),
                YawChoice {
                    away: true,
                    resolved: false
                },
                "{rate} {sd}"
            );
        }
    }

    #[test]
    fn a_flat_noisy_range_stays_unresolved() {
        let config = TemporalConfig::DEFAULT;
        let mut state = Temporal::new();
        let mut t = 0.0;
        for k in 0..15 {
            t = state.frame_time(k as f64 / 30.0, &config);
            let noise = [3.0, -1.0, 4.0, -4.0, 0.5][k % 5];
            state.push_range(t, 1500.0 + noise, &config);
        }
        assert!(!state.choose_yaw(t, None, &config).resolved);
    }

    #[test]
    fn smoothing_follows_a_trend_without_lag() {
        let config = TemporalConfig::DEFAULT;
        let mut state = Temporal::new();
        let mut last = 0.0;
        for k in 0..40 {
            let t = state.frame_time(k as f64 / 30.0, &config);
            let truth = 1200.0 + 120.0 * t;
            state.push_range(t, truth, &config);
            last = state.smooth_range(t, truth, &config) - truth;
        }
        assert!(last.abs() < 0.5, "lag {last} m");
    }

    /// The range is predicted from three steady ranges carried along their trend (120 m/s),
    /// not from two, nor from ranges scattering by 15 % (an image range read off in clutter),
    /// nor more than `max_gap_s` after the last range.
    #[test]
    fn the_range_is_predicted_only_from_steady_recent_ranges() {
        let config = TemporalConfig::DEFAULT;
        // The ranges at 0.1 s steps, then predictions at `at_s` (frames without a range).
        let predicted = |ranges: &[f32], at_s: &[f64]| {
            let mut state = Temporal::new();
            for (k, r) in ranges.iter().enumerate() {
                let t = state.frame_time(k as f64 * 0.1, &config);
                state.push_range(t, *r, &config);
            }
            let mut last = None;
            for t in at_s {
                last = state.predict(*t, &config).range_m;
            }
            last
        };
        let steady = [1200.0, 1212.0, 1224.0, 1236.0];
        let next = predicted(&steady, &[0.4]).expect("a prediction");
        assert!((next - 1248.0).abs() < 0.5, "{next}");
        assert_eq!(predicted(&steady[..2], &[0.2]), None);
        assert_eq!(predicted(&[1200.0, 1400.0, 1150.0, 1450.0], &[0.4]), None);
        // 0.9 s after the last range still, 1.4 s no longer (no gap between frames over 1 s).
        assert!(predicted(&steady, &[1.2]).is_some());
        assert_eq!(predicted(&steady, &[1.0, 1.7]), None);
    }

    #[test]
    fn a_time_gap_or_reversal_resets() {
        let config = TemporalConfig::DEFAULT;
        let mut state = Temporal::new();
        assert_eq!(state.frame_time(10.0, &config), 0.0);
        assert!((state.frame_time(10.1, &config) - 0.1).abs() < 1e-6);
        assert_eq!(state.frame_time(10.05, &config), 0.0, "time went back");
        assert_eq!(
            state.frame_time(20.0, &config),
            0.0,
            "gap longer than max_gap_s"
        );
    }
}
