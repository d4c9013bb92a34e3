//! The slant range's motion model: a Kalman filter of range, range rate and range acceleration
//! driven by white jerk, fed each frame's image range with its noise.
//!
//! A projectile's slant range changes smoothly: along a straight line past the camera its rate
//! turns from closing to opening through the closest approach, where the range acceleration is
//! `v^2 / R` (about 90 m/s² for 300 m/s at 1 km) and changes over a second or so. A constant-
//! acceleration state follows that without the lag of a blend with the previous value (the
//! source paper's Eq. 5), and its covariance says how well the range is known: the one-sigma
//! `tz_sd_m` of the results.
//!
//! The arithmetic is in `f64` (software floating point on the Cortex-M4F, a few thousand
//! instructions a frame): its rounding is IEEE's on every target, so host and firmware agree
//! bit for bit.

use nalgebra::{SMatrix, SVector};

/// State: slant range (m), its rate (m/s) and its acceleration (m/s²).
type State = SVector<f64, 3>;
/// The state's covariance.
type Covariance = SMatrix<f64, 3, 3>;

/// The range filter's tunables.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RangeFilterConfig {
    /// Spectral density of the white jerk that drives the range acceleration, m²/s⁵: how fast
    /// the acceleration may change (a pass of the closest approach changes it by `v^2 / R` over
    /// about `R / v` s).
    pub jerk_psd: f32,
    /// One sigma of the range rate before the first frame, m/s ...
    pub initial_rate_sd_m_s: f32,
    /// ... and of the range acceleration, m/s².
    pub initial_acceleration_sd_m_s2: f32,
    /// One sigma of an image range as a fraction of it, until the window has measured the
    /// noise (three frames) ...
    pub initial_noise_fraction: f32,
    /// ... and at least this fraction after (a window of lucky frames is not believed).
    pub min_noise_fraction: f32,
    /// The image range's systematic error, one sigma as a fraction of the range, per squared
    /// ratio of blur to apparent diameter: the range is read at the diameter's scale, and a
    /// width fitted against blur is off by a fraction that grows as `(blur / diameter)^2` and
    /// varies slowly, so the frames do not average it out. It adds to the reported sigma, not to
    /// the filter's weights.
    pub systematic_blur: f32,
    /// ... at least this fraction of the range.
    pub min_systematic_fraction: f32,
    /// A measurement further than this many sigmas from the prediction counts with the weight
    /// that puts it at this distance (Huber): one wrong frame cannot drag the track.
    pub huber_sigmas: f32,
}

impl RangeFilterConfig {
    /// The defaults.
    pub const DEFAULT: RangeFilterConfig = RangeFilterConfig {
        jerk_psd: 2000.0,
        initial_rate_sd_m_s: 400.0,
        initial_acceleration_sd_m_s2: 100.0,
        initial_noise_fraction: 0.03,
        min_noise_fraction: 0.002,
        systematic_blur: 0.4,
        min_systematic_fraction: 0.002,
        huber_sigmas: 3.0,
    };
}

impl Default for RangeFilterConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The filter's estimate of the slant range at a frame.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RangeEstimate {
    /// Slant range, m.
    pub range_m: f32,
    /// Its one-sigma uncertainty, m: the filter's, and the systematic error's
    /// ([`RangeFilterConfig::systematic_blur`]).
    pub sd_m: f32,
}

/// The image scale a range was read at.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ImageScale {
    /// The body's apparent diameter, px.
    pub diameter_px: f32,
    /// The blur's standard deviation, px.
    pub blur_px: f32,
}

impl ImageScale {
    /// A range read without blur (a sensor's): only the least systematic error
    /// ([`RangeFilterConfig::min_systematic_fraction`]).
    pub const SHARP: ImageScale = ImageScale {
        diameter_px: 1.0,
        blur_px: 0.0,
    };

    /// The image range's systematic error at this scale, one sigma as a fraction of the range
    /// ([`RangeFilterConfig::systematic_blur`]).
    fn systematic_fraction(&self, config: &RangeFilterConfig) -> f32 {
        let ratio = self.blur_px / self.diameter_px;
        let fraction = config.systematic_blur * ratio * ratio;
        if fraction.is_finite() {
            fraction.max(config.min_systematic_fraction)
        } else {
            config.min_systematic_fraction
        }
    }
}

/// A state estimate at one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Track {
    /// Time of that frame, s.
    t: f32,
    /// State estimate.
    x: State,
    /// Its covariance.
    p: Covariance,
}

/// One frame of the filter, as kept to smooth a recorded clip ([`smooth`]): the prediction it
/// started from and the estimate after its measurement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FilterStep {
    /// The estimate after the frame's measurement (smoothed in place by [`smooth`]).
    estimate: Track,
    /// The prediction from the previous frame's estimate, and that estimate's time (s) and
    /// state, which tell [`smooth`] whose prediction it is; None for the first frame of a track.
    prediction: Option<(f32, State, Track)>,
    /// The image range's systematic error at the frame's scale, a fraction of the range.
    systematic_fraction: f32,
}

impl FilterStep {
    /// The frame's time, s.
    pub fn time_s(&self) -> f32 {
        self.estimate.t
    }

    /// The frame's range and its one sigma (the filter's, or the smoother's after [`smooth`],
    /// with the systematic error).
    pub fn range(&self) -> RangeEstimate {
        let x = &self.estimate;
        let systematic = f64::from(self.systematic_fraction) * x.x.x;
        RangeEstimate {
            range_m: x.x.x as f32,
            sd_m: libm::sqrt(x.p.m11.max(0.0) + systematic * systematic) as f32,
        }
    }

    /// The range rate at the frame and its one sigma, m/s.
    pub fn rate(&self) -> (f32, f32) {
        let x = &self.estimate;
        (x.x.y as f32, libm::sqrt(x.p.m22.max(0.0)) as f32)
    }
}

/// The range filter: empty until the first measurement.
#[derive(Debug, Clone, Default)]
pub struct RangeFilter {
    last: Option<FilterStep>,
}

impl RangeFilter {
    /// An empty filter.
    pub const fn new() -> Self {
        RangeFilter { last: None }
    }

    /// The last frame the filter took: its prediction and estimate.
    pub fn last_step(&self) -> Option<FilterStep> {
        self.last
    }

    /// Takes the slant range `measured_m` at time `t` (s, after the last frame's), read at
    /// `scale` (a sensor's at [`ImageScale::SHARP`]), whose noise the window puts at
    /// `noise_sd_m` (one sigma, m; None while unknown),
    /// and returns the filtered range. A measurement that is not finite and positive leaves the
    /// filter as it was and gives None.
    pub fn update(
        &mut self,
        t: f32,
        measured_m: f32,
        noise_sd_m: Option<f32>,
        scale: &ImageScale,
        config: &RangeFilterConfig,
    ) -> Option<RangeEstimate> {
        if !(measured_m.is_finite() && measured_m > 0.0) {
            return None;
        }
        let z = f64::from(measured_m);
        let fraction = match noise_sd_m {
            Some(sd) if sd.is_finite() => f64::from(sd) / z,
            _ => f64::from(config.initial_noise_fraction),
        };
        let noise = z * fraction.max(f64::from(config.min_noise_fraction));
        let prediction = match self.last {
            Some(last) if t > last.estimate.t => {
                let (x, p) = predict(&last.estimate, t, config);
                Some((last.estimate.t, last.estimate.x, Track { t, x, p }))
            }
            _ => None,
        };
        let (x, p) = match prediction {
            Some((_, _, predicted)) => (predicted.x, predicted.p),
            None => initial(z, noise, config),
        };
        let (x, p) = correct(x, p, z, noise * noise, f64::from(config.huber_sigmas));
        let step = FilterStep {
            estimate: Track { t, x, p },
            prediction,
            systematic_fraction: scale.systematic_fraction(config),
        };
        let estimate = step.range();
        if !(estimate.range_m.is_finite() && estimate.range_m > 0.0 && estimate.sd_m.is_finite()) {
            // An absurd input (found by fuzzing) overflowed the state: start afresh next time.
            self.last = None;
            return None;
        }
        self.last = Some(step);
        Some(estimate)
    }
}

/// Smooths the filter steps of a recorded clip in place (Rauch-Tung-Striebel): each frame's
/// estimate then uses the frames after it too. `steps` are in time order; where a step's
/// prediction did not come from the step before it (a new track, or a frame left out), the
/// smoothing restarts there.
pub fn smooth(steps: &mut [FilterStep]) {
    for k in (1..steps.len()).rev() {
        let (Some(next), Some(step)) = (steps.get(k).copied(), steps.get_mut(k - 1)) else {
            continue;
        };
        let Some((from_t, from_x, predicted)) = next.prediction else {
            continue;
        };
        let current = &mut step.estimate;
        // Times restart with every track: the state, not yet smoothed here, tells them apart.
        if from_t != current.t || from_x != current.x {
            continue;
        }
        let Some(predicted_inverse) = predicted.p.try_inverse() else {
            continue;
        };
        let f = transition(f64::from(next.estimate.t - current.t));
        let gain = current.p * f.transpose() * predicted_inverse;
        let x = current.x + gain * (next.estimate.x - predicted.x);
        let p = current.p + gain * (next.estimate.p - predicted.p) * gain.transpose();
        if x.iter().chain(p.iter()).all(|v| v.is_finite()) {
            current.x = x;
            current.p = p;
        }
    }
}

/// The state transition over `dt` s (constant acceleration).
fn transition(dt: f64) -> Covariance {
    Covariance::new(1.0, dt, 0.5 * dt * dt, 0.0, 1.0, dt, 0.0, 0.0, 1.0)
}

/// The track carried to time `t`: state and covariance, with the white jerk's process noise.
fn predict(track: &Track, t: f32, config: &RangeFilterConfig) -> (State, Covariance) {
    let dt = f64::from(t - track.t);
    let f = transition(dt);
    let q = f64::from(config.jerk_psd);
    let (dt2, dt3) = (dt * dt, dt * dt * dt);
    let process = Covariance::new(
        dt3 * dt2 / 20.0,
        dt2 * dt2 / 8.0,
        dt3 / 6.0,
        dt2 * dt2 / 8.0,
        dt3 / 3.0,
        dt2 / 2.0,
        dt3 / 6.0,
        dt2 / 2.0,
        dt,
    ) * q;
    (f * track.x, f * track.p * f.transpose() + process)
}

/// The first frame's state: the measured range, rate and acceleration unknown.
fn initial(z: f64, noise: f64, config: &RangeFilterConfig) -> (State, Covariance) {
    let rate = f64::from(config.initial_rate_sd_m_s);
    let acceleration = f64::from(config.initial_acceleration_sd_m_s2);
    (
        State::new(z, 0.0, 0.0),
        Covariance::from_diagonal(&State::new(
            noise * noise,
            rate * rate,
            acceleration * acceleration,
        )),
    )
}

/// The measurement `z` with variance `r` folded into the predicted state (`x`, `p`); an
/// innovation beyond `huber` sigmas has its variance raised to put it at `huber` sigmas.
fn correct(x: State, p: Covariance, z: f64, r: f64, huber: f64) -> (State, Covariance) {
    let innovation = z - x.x;
    let spread = p.m11 + r;
    let distance = libm::fabs(innovation) / libm::sqrt(spread.max(f64::MIN_POSITIVE));
    let r = if distance > huber && huber > 0.0 {
        r + spread * ((distance / huber) - 1.0)
    } else {
        r
    };
    // The innovation's variance with the (raised) measurement variance.
    let s = p.m11 + r;
    if !(s.is_finite() && s > 0.0) {
        return (x, p);
    }
    let gain = p.column(0) / s;
    let x = x + gain * innovation;
    // Joseph's form keeps the covariance symmetric and positive.
    let h = SMatrix::<f64, 1, 3>::new(1.0, 0.0, 0.0);
    let i_kh = Covariance::identity() - gain * h;
    let p = i_kh * p * i_kh.transpose() + gain * gain.transpose() * r;
    (x, p)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::noise_sequence;

    /// A body 8 px wide under a 0.9-px blur.
    const SCALE: ImageScale = ImageScale {
        diameter_px: 8.0,
        blur_px: 0.9,
    };

    /// A crossing flight past the closest approach, R = sqrt(R0^2 + v^2 (t - t0)^2), measured
    /// with 1 % noise: the filter's error is well under the measurement's, and within two of its
    /// own sigmas in most frames.
    #[test]
    fn follows_a_closest_approach_with_honest_sigmas() {
        let config = RangeFilterConfig::DEFAULT;
        let (r0, v, t0, dt) = (1000.0f32, 300.0f32, 2.0f32, 1.0 / 15.0);
        let mut filter = RangeFilter::new();
        let (mut within, mut total, mut sq_err, mut sq_meas) = (0, 0, 0.0f32, 0.0f32);
        for (k, n) in noise_sequence(60, 7).enumerate() {
            let t = k as f32 * dt;
            let truth = libm::sqrtf(r0 * r0 + v * v * (t - t0) * (t - t0));
            let noise = 0.01 * truth;
            let measured = truth + noise * n;
            let estimate = filter
                .update(t, measured, Some(noise), &SCALE, &config)
                .unwrap();
            if k >= 10 {
                let err = estimate.range_m - truth;
                sq_err += err * err;
                sq_meas += (measured - truth) * (measured - truth);
                total += 1;
                if libm::fabsf(err) <= 2.0 * estimate.sd_m {
                    within += 1;
                }
            }
        }
        let (rms, rms_meas) = (
            libm::sqrtf(sq_err / total as f32),
            libm::sqrtf(sq_meas / total as f32),
        );
        assert!(
            rms < 0.6 * rms_meas,
            "filtered {rms} m, measured {rms_meas} m"
        );
        let share = within as f32 / total as f32;
        assert!(share >= 0.8, "{within} of {total} within two sigmas");
    }

    /// The smoother, given the filter's steps of the closest-approach pass, is closer to the
    /// truth than the filter (rms), still within two of its sigmas in most frames, and gives a
    /// range rate whose sign is the truth's wherever that rate is beyond three of its sigmas.
    #[test]
    fn smoothing_a_recorded_pass_beats_the_filter() {
        let config = RangeFilterConfig::DEFAULT;
        let (r0, v, t0, dt) = (1000.0f32, 300.0f32, 2.0f32, 1.0 / 15.0);
        let truth = |t: f32| libm::sqrtf(r0 * r0 + v * v * (t - t0) * (t - t0));
        let mut filter = RangeFilter::new();
        let mut steps = [None; 60];
        let mut filtered_sq = 0.0f32;
        for ((k, n), slot) in noise_sequence(60, 11).enumerate().zip(steps.iter_mut()) {
            let t = k as f32 * dt;
            let noise = 0.01 * truth(t);
            let estimate = filter
                .update(t, truth(t) + noise * n, Some(noise), &SCALE, &config)
                .unwrap();
            filtered_sq += (estimate.range_m - truth(t)).powi(2);
            *slot = filter.last_step();
        }
        let mut steps = steps.map(Option::unwrap);
        smooth(&mut steps);
        let (mut smoothed_sq, mut within, mut signed) = (0.0f32, 0, 0);
        for (k, step) in steps.iter().enumerate() {
            let t = k as f32 * dt;
            let estimate = step.range();
            let err = estimate.range_m - truth(t);
            smoothed_sq += err * err;
            if err.abs() <= 2.0 * estimate.sd_m {
                within += 1;
            }
            let (rate, rate_sd) = step.rate();
            let true_rate = v * v * (t - t0) / truth(t);
            if rate.abs() > 3.0 * rate_sd {
                assert_eq!(
                    rate > 0.0,
                    true_rate > 0.0,
                    "frame {k}: {rate} +- {rate_sd}"
                );
                signed += 1;
            }
        }
        assert!(
            smoothed_sq < 0.6 * filtered_sq,
            "smoothed {smoothed_sq}, filtered {filtered_sq}"
        );
        assert!(within >= 48, "{within} of 60 within two sigmas");
        // Away from the closest approach (rate 0 at frame 30) the rate's sign is resolved.
        assert!(
            signed >= 40,
            "{signed} of 60 frames with a significant rate"
        );
    }

    /// Steps of two tracks (the second after a reset) are smoothed apart: the first track's
    /// last step is the filter's, untouched by the second track.
    #[test]
    fn smoothing_restarts_where_a_track_does() {
        let config = RangeFilterConfig::DEFAULT;
        let mut steps = [None; 20];
        for (track, start) in [(0usize, 1000.0f32), (1, 3000.0)] {
            let mut filter = RangeFilter::new();
            for k in 0..10 {
                let t = k as f32 / 30.0;
                filter.update(t, start + 50.0 * t, Some(2.0), &SCALE, &config);
                steps[track * 10 + k] = filter.last_step();
            }
        }
        let mut steps = steps.map(Option::unwrap);
        let end_of_first = steps[9];
        smooth(&mut steps);
        assert_eq!(steps[9], end_of_first);
        assert!((steps[0].range().range_m - 1000.0).abs() < 1.0);
        assert!((steps[10].range().range_m - 3000.0).abs() < 1.0);
        // Times restart with a track: a step predicted from a new track's first frame (at
        // t = 0, not kept) does not join an old track's step at t = 0.
        let mut old = RangeFilter::new();
        old.update(0.0, 1000.0, Some(2.0), &SCALE, &config);
        let mut new = RangeFilter::new();
        new.update(0.0, 3000.0, Some(2.0), &SCALE, &config);
        new.update(1.0 / 30.0, 3005.0, Some(2.0), &SCALE, &config);
        let kept = old.last_step().unwrap();
        let mut pair = [kept, new.last_step().unwrap()];
        smooth(&mut pair);
        assert_eq!(pair[0], kept);
    }

    /// A constant rate is followed without lag: the error after 40 noiseless frames is tiny.
    #[test]
    fn a_steady_rate_has_no_lag() {
        let config = RangeFilterConfig::DEFAULT;
        let mut filter = RangeFilter::new();
        let mut last = None;
        for k in 0..40 {
            let t = k as f32 / 30.0;
            let truth = 1200.0 + 120.0 * t;
            last = filter
                .update(t, truth, Some(1.0), &SCALE, &config)
                .map(|e| e.range_m - truth);
        }
        let lag = last.unwrap();
        assert!(lag.abs() < 0.05, "lag {lag} m");
        // A measurement given no weight leaves the prediction: the rate was learned.
        let predicted = filter
            .update(40.0 / 30.0, 5000.0, Some(1e7), &SCALE, &config)
            .unwrap();
        assert!((predicted.range_m - 1360.0).abs() < 0.1, "{predicted:?}");
    }

    /// One frame 30 % off moves the estimate by a few sigmas at most, not by the 30 %.
    #[test]
    fn an_outlier_cannot_drag_the_range() {
        let config = RangeFilterConfig::DEFAULT;
        let mut filter = RangeFilter::new();
        let mut before = 0.0;
        for k in 0..20 {
            let t = k as f32 / 30.0;
            before = filter
                .update(t, 1500.0, Some(5.0), &SCALE, &config)
                .unwrap()
                .range_m;
        }
        let after = filter
            .update(20.0 / 30.0, 1950.0, Some(5.0), &SCALE, &config)
            .unwrap();
        assert!(
            (after.range_m - before).abs() < 30.0,
            "{before} -> {after:?}"
        );
    }

    /// Bad measurements are refused and leave the track; absurd ones cannot make it non-finite.
    #[test]
    fn bad_measurements_are_refused() {
        let config = RangeFilterConfig::DEFAULT;
        let mut filter = RangeFilter::new();
        assert!(filter.update(0.0, 1000.0, None, &SCALE, &config).is_some());
        for bad in [f32::NAN, f32::INFINITY, -5.0, 0.0] {
            assert!(filter.update(0.1, bad, None, &SCALE, &config).is_none());
        }
        // The track survived: a measurement given no weight leaves its range.
        let kept = filter
            .update(0.1, 5000.0, Some(1e7), &SCALE, &config)
            .unwrap();
        assert!((kept.range_m - 1000.0).abs() < 1e-3, "{kept:?}");
        let huge = filter.update(
            0.2,
            f32::MAX,
            Some(f32::MAX),
            &ImageScale {
                diameter_px: f32::NAN,
                blur_px: 0.0,
            },
            &config,
        );
        assert!(huge.is_none_or(|e| e.range_m.is_finite() && e.sd_m.is_finite()));
    }
}
