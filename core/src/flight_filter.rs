//! The flight's motion model: an iterated extended Kalman filter of the body origin's position,
//! velocity and along-track acceleration in the world frame E, fed each frame's line of sight
//! (the mount's pointing and the body's place in the chip) and image range.
//!
//! Without a range sensor the image gives the range only to a few per cent a frame (the scale of
//! a body 4-8 px wide), but it gives the line of sight to a few microradians. A projectile in
//! flight is pulled by gravity, which is known: `g` down, plus drag and thrust along its
//! velocity, which are not. Gravity's share across the velocity bends the path by
//! `g cos(flight path angle) t² / 2` (hundreds of metres over ten seconds), and how far that
//! bend appears across the line of sight depends on the range: the lines of sight of a few
//! seconds, with the image ranges only to start from, fix the range to a few metres per km where
//! the image ranges alone scatter by 30 (`docs/benchmarks.md`). The same state gives the
//! velocity, whose rate along the line of sight tells the nose from its mirror image.
//!
//! The state is `[p (m, E), v (m/s, E), a (m/s², along v)]`, driven by `g + a v/|v|`, with white
//! noise on the acceleration (what the model leaves out: lift, wind) and on the rate of `a` (a
//! drag that changes with the speed). The first two frames start it (their positions at the
//! image ranges, the velocity their difference); each later frame is carried to its time (RK4)
//! and corrected by its two sight angles and its image range, relinearized
//! [`FlightFilterConfig::iterations`] times (the sight's angles are a thousand times sharper
//! than the range: one linearization at a range a few per cent off would leave their pull
//! biased). An image range further than [`FlightFilterConfig::huber_sigmas`] from the
//! prediction counts with the weight that puts it there (Huber).
//!
//! The arithmetic is `f64`: positions of kilometres are resolved to millimetres, and IEEE
//! rounding makes host and firmware agree bit for bit. A recorded clip's steps can be smoothed
//! afterwards ([`smooth`], Rauch-Tung-Striebel).

use nalgebra::{SMatrix, SVector, Vector3};

/// State: position (m, E), velocity (m/s, E), acceleration along the velocity (m/s²).
type State = SVector<f64, 7>;
/// The state's covariance (and a transition's Jacobian).
type Covariance = SMatrix<f64, 7, 7>;
/// A row of a measurement's Jacobian.
type Row = SMatrix<f64, 1, 7>;

/// Index of the velocity in the state.
const V: usize = 3;
/// Index of the along-track acceleration in the state.
const A: usize = 6;

/// The flight filter's tunables.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FlightFilterConfig {
    /// Whether the filter gives the range of frames without a range sensor (where they come
    /// with the mount's pointing).
    pub enabled: bool,
    /// Gravity, m/s² (down, -U in E).
    pub gravity_m_s2: f32,
    /// Spectral density of the white acceleration the model leaves out (lift, wind), m²/s³.
    pub acceleration_psd: f32,
    /// Spectral density of the white jerk that changes the along-track acceleration, m²/s⁵.
    pub along_jerk_psd: f32,
    /// One sigma of the line of sight, px of the chip (the body origin's place).
    pub sight_sd_px: f32,
    /// An image range is weighted as if its one sigma were at least this fraction of it.
    pub min_range_fraction: f32,
    /// One sigma of the velocity at the second frame beyond what the two positions give, m/s
    /// (each axis).
    pub initial_velocity_sd_m_s: f32,
    /// One sigma of the along-track acceleration at the second frame, m/s².
    pub initial_along_sd_m_s2: f32,
    /// An image range further than this many sigmas from the prediction counts with the
    /// weight that puts it at this distance (Huber).
    pub huber_sigmas: f32,
    /// The longest integration step, s.
    pub max_step_s: f32,
    /// Linearizations of each frame's correction.
    pub iterations: u32,
}

impl FlightFilterConfig {
    /// The defaults.
    pub const DEFAULT: FlightFilterConfig = FlightFilterConfig {
        enabled: true,
        gravity_m_s2: 9.80665,
        acceleration_psd: 0.001,
        along_jerk_psd: 0.1,
        sight_sd_px: 1.0,
        min_range_fraction: 0.02,
        initial_velocity_sd_m_s: 2.0,
        initial_along_sd_m_s2: 20.0,
        huber_sigmas: 3.0,
        max_step_s: 0.05,
        iterations: 3,
    };
}

impl Default for FlightFilterConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// A frame's line of sight to the body origin, in E.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sight {
    /// Where the camera stands, m in E.
    pub station_enu_m: [f64; 3],
    /// Unit vector from the camera to the body origin, E.
    pub dir_enu: [f64; 3],
    /// One sigma of each of its two angles, rad.
    pub sd_rad: f64,
}

/// A slant range with its one sigma, m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RangeReading {
    /// The range, m.
    pub range_m: f64,
    /// Its one sigma, m.
    pub sd_m: f64,
}

/// The filter's estimate at a frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlightEstimate {
    /// Slant range from the station to the body origin, m, and its one sigma.
    pub range: RangeReading,
    /// Its rate, m/s (positive: opening), and the rate's one sigma.
    pub rate_m_s: (f64, f64),
    /// The body origin's velocity, m/s in E.
    pub velocity_enu_m_s: [f64; 3],
}

/// The first frame of a flight, kept until the second starts the filter.
#[derive(Debug, Clone, Copy, PartialEq)]
struct First {
    t: f64,
    sight: Sight,
    range: RangeReading,
}

/// The prediction a step started from: the previous step's time and state (which tell
/// [`smooth`] whose prediction it is), the predicted state and covariance, and the transition's
/// Jacobian.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Predicted {
    from_t: f64,
    from_x: State,
    x: State,
    p: Covariance,
    transition: Covariance,
}

/// One frame of the filter, as kept to smooth a recorded clip ([`smooth`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlightStep {
    t: f64,
    x: State,
    p: Covariance,
    station: Vector3<f64>,
    predicted: Option<Predicted>,
}

impl FlightStep {
    /// The frame's time, s.
    pub fn time_s(&self) -> f64 {
        self.t
    }

    /// The estimate at the frame (the filter's, or the smoother's after [`smooth`]).
    pub fn estimate(&self) -> FlightEstimate {
        let offset = self.x.fixed_rows::<3>(0) - self.station;
        let range = offset.norm();
        let sight = offset / range;
        let velocity = self.x.fixed_rows::<3>(V).into_owned();
        let rate = sight.dot(&velocity);
        // d(rate)/dp = (v - sight rate) / range, d(rate)/dv = sight.
        let mut rate_row = Row::zeros();
        let across = (velocity - sight * rate) / range;
        rate_row
            .fixed_columns_mut::<3>(0)
            .copy_from(&across.transpose());
        rate_row
            .fixed_columns_mut::<3>(V)
            .copy_from(&sight.transpose());
        let mut range_row = Row::zeros();
        range_row
            .fixed_columns_mut::<3>(0)
            .copy_from(&sight.transpose());
        let variance = |row: &Row| (row * self.p * row.transpose()).x.max(0.0);
        FlightEstimate {
            range: RangeReading {
                range_m: range,
                sd_m: libm::sqrt(variance(&range_row)),
            },
            rate_m_s: (rate, libm::sqrt(variance(&rate_row))),
            velocity_enu_m_s: [velocity.x, velocity.y, velocity.z],
        }
    }
}

/// The flight filter: empty until the first frame.
#[derive(Debug, Clone, Default)]
pub struct FlightFilter {
    first: Option<First>,
    last: Option<FlightStep>,
}

impl FlightFilter {
    /// An empty filter.
    pub const fn new() -> Self {
        FlightFilter {
            first: None,
            last: None,
        }
    }

    /// The last frame the filter took.
    pub fn last_step(&self) -> Option<FlightStep> {
        self.last
    }

    /// Takes the frame at time `t` (s, after the last frame's): its line of sight and image
    /// range. Returns the estimate there; None for the first frame of a flight (one frame
    /// tells no velocity) and for a frame that is no measurement (not finite, not after the
    /// last, a range not positive, a sight not a unit vector), which leaves the filter as it
    /// was.
    pub fn update(
        &mut self,
        t: f64,
        sight: &Sight,
        range: RangeReading,
        config: &FlightFilterConfig,
    ) -> Option<FlightEstimate> {
        if !is_measurement(t, sight, &range) {
            return None;
        }
        let fraction = f64::from(config.min_range_fraction);
        let range = RangeReading {
            sd_m: range.sd_m.max(fraction * range.range_m),
            ..range
        };
        let step = match (self.last, self.first) {
            (Some(last), _) if t > last.t => {
                let predicted = predict(&last, t, config)?;
                let (x, p) = correct(&predicted, sight, &range, config);
                FlightStep {
                    t,
                    x,
                    p,
                    station: Vector3::from(sight.station_enu_m),
                    predicted: Some(predicted),
                }
            }
            (None, Some(first)) if t > first.t => start(&first, t, sight, &range, config),
            (Some(_), _) | (None, Some(_)) => return None,
            (None, None) => {
                self.first = Some(First {
                    t,
                    sight: *sight,
                    range,
                });
                return None;
            }
        };
        let estimate = step.estimate();
        let finite = step.x.iter().chain(step.p.iter()).all(|v| v.is_finite())
            && estimate.range.sd_m.is_finite()
            && estimate.range.range_m > 0.0;
        if !finite {
            // An absurd input overflowed the state: start afresh.
            *self = Self::new();
            return None;
        }
        self.last = Some(step);
        Some(estimate)
    }
}

/// Whether a frame's inputs make a measurement.
fn is_measurement(t: f64, sight: &Sight, range: &RangeReading) -> bool {
    let dir = Vector3::from(sight.dir_enu);
    t.is_finite()
        && sight.station_enu_m.iter().all(|v| v.is_finite())
        && libm::fabs(dir.norm() - 1.0) < 1e-6
        && sight.sd_rad.is_finite()
        && sight.sd_rad > 0.0
        && range.range_m.is_finite()
        && range.range_m > 0.0
        && range.sd_m.is_finite()
        && range.sd_m > 0.0
}

/// The filter started at the second frame: its position at the image range, the velocity the
/// difference from the first's, each with the covariance the two readings give.
fn start(
    first: &First,
    t: f64,
    sight: &Sight,
    range: &RangeReading,
    config: &FlightFilterConfig,
) -> FlightStep {
    let (p0, c0) = placed(&first.sight, &first.range);
    let (p1, c1) = placed(sight, range);
    let dt = t - first.t;
    let velocity = (p1 - p0) / dt;
    let mut x = State::zeros();
    x.fixed_rows_mut::<3>(0).copy_from(&p1);
    x.fixed_rows_mut::<3>(V).copy_from(&velocity);
    let extra = f64::from(config.initial_velocity_sd_m_s);
    let along = f64::from(config.initial_along_sd_m_s2);
    let mut p = Covariance::zeros();
    p.fixed_view_mut::<3, 3>(0, 0).copy_from(&c1);
    p.fixed_view_mut::<3, 3>(0, V).copy_from(&(c1 / dt));
    p.fixed_view_mut::<3, 3>(V, 0).copy_from(&(c1 / dt));
    p.fixed_view_mut::<3, 3>(V, V)
        .copy_from(&((c0 + c1) / (dt * dt) + nalgebra::Matrix3::identity() * (extra * extra)));
    p[(A, A)] = along * along;
    FlightStep {
        t,
        x,
        p,
        station: Vector3::from(sight.station_enu_m),
        predicted: None,
    }
}

/// The position a sight and range place the body origin at, and its covariance: the range's
/// along the sight, the sight's across it.
fn placed(sight: &Sight, range: &RangeReading) -> (Vector3<f64>, nalgebra::Matrix3<f64>) {
    let dir = Vector3::from(sight.dir_enu);
    let along = dir * dir.transpose();
    let across = nalgebra::Matrix3::identity() - along;
    let lateral = sight.sd_rad * range.range_m;
    (
        Vector3::from(sight.station_enu_m) + dir * range.range_m,
        along * (range.sd_m * range.sd_m) + across * (lateral * lateral),
    )
}

/// The state's rate of change: `[v, g + a v/|v|, 0]`.
fn derivative(x: &State, gravity: f64) -> State {
    let velocity = x.fixed_rows::<3>(V);
    let speed = velocity.norm();
    let mut dx = State::zeros();
    dx.fixed_rows_mut::<3>(0).copy_from(&velocity);
    if speed > 0.0 {
        dx.fixed_rows_mut::<3>(V)
            .copy_from(&(velocity * (x[A] / speed)));
    }
    dx[V + 2] -= gravity;
    dx
}

/// The Jacobian of [`derivative`].
fn jacobian(x: &State) -> Covariance {
    let mut j = Covariance::zeros();
    j.fixed_view_mut::<3, 3>(0, V)
        .copy_from(&nalgebra::Matrix3::identity());
    let velocity = x.fixed_rows::<3>(V).into_owned();
    let speed = velocity.norm();
    if speed > 0.0 {
        let dir = velocity / speed;
        let turn = (nalgebra::Matrix3::identity() - dir * dir.transpose()) * (x[A] / speed);
        j.fixed_view_mut::<3, 3>(V, V).copy_from(&turn);
        j.fixed_view_mut::<3, 1>(V, A).copy_from(&dir);
    }
    j
}

/// The state carried `dt` s on (RK4 in steps of at most `max_step_s`).
fn propagate(x: &State, dt: f64, gravity: f64, max_step_s: f64) -> State {
    let steps = libm::ceil(dt / max_step_s).clamp(1.0, 10_000.0);
    let h = dt / steps;
    let mut x = *x;
    for _ in 0..steps as u32 {
        let k1 = derivative(&x, gravity);
        let k2 = derivative(&(x + k1 * (0.5 * h)), gravity);
        let k3 = derivative(&(x + k2 * (0.5 * h)), gravity);
        let k4 = derivative(&(x + k3 * h), gravity);
        x += (k1 + (k2 + k3) * 2.0 + k4) * (h / 6.0);
    }
    x
}

/// The last step carried to time `t`: state, covariance with the process noise, and the
/// transition's Jacobian (second order, at the interval's middle). None where the state does
/// not stay finite.
fn predict(last: &FlightStep, t: f64, config: &FlightFilterConfig) -> Option<Predicted> {
    let dt = t - last.t;
    let gravity = f64::from(config.gravity_m_s2);
    let max_step = f64::from(config.max_step_s).max(1e-3);
    let middle = propagate(&last.x, 0.5 * dt, gravity, max_step);
    let j = jacobian(&middle) * dt;
    let transition = Covariance::identity() + j + j * j * 0.5;
    let x = propagate(&last.x, dt, gravity, max_step);
    let p = transition * last.p * transition.transpose() + process_noise(&middle, dt, config);
    x.iter().all(|v| v.is_finite()).then_some(Predicted {
        from_t: last.t,
        from_x: last.x,
        x,
        p,
        transition,
    })
}

/// The process noise over `dt` s: white acceleration on each axis, and white jerk of the
/// along-track acceleration along the velocity at `x`.
fn process_noise(x: &State, dt: f64, config: &FlightFilterConfig) -> Covariance {
    let (dt2, dt3) = (dt * dt, dt * dt * dt);
    let (dt4, dt5) = (dt2 * dt2, dt2 * dt3);
    let mut q = Covariance::zeros();
    let white = f64::from(config.acceleration_psd);
    let identity = nalgebra::Matrix3::<f64>::identity();
    q.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&(identity * (white * dt3 / 3.0)));
    q.fixed_view_mut::<3, 3>(0, V)
        .copy_from(&(identity * (white * dt2 / 2.0)));
    q.fixed_view_mut::<3, 3>(V, 0)
        .copy_from(&(identity * (white * dt2 / 2.0)));
    q.fixed_view_mut::<3, 3>(V, V)
        .copy_from(&(identity * (white * dt)));
    let jerk = f64::from(config.along_jerk_psd);
    let velocity = x.fixed_rows::<3>(V).into_owned();
    let speed = velocity.norm();
    let dir = if speed > 0.0 {
        velocity / speed
    } else {
        Vector3::zeros()
    };
    // The integrated random walk along `dir`: p ~ t^5/20, v ~ t^3/3, a ~ t.
    let along = dir * dir.transpose();
    let mut add = |r: usize, c: usize, block: nalgebra::Matrix3<f64>| {
        let mut view = q.fixed_view_mut::<3, 3>(r, c);
        view += block;
    };
    add(0, 0, along * (jerk * dt5 / 20.0));
    add(0, V, along * (jerk * dt4 / 8.0));
    add(V, 0, along * (jerk * dt4 / 8.0));
    add(V, V, along * (jerk * dt3 / 3.0));
    for i in 0..3 {
        let (pa, va) = (jerk * dt3 / 6.0 * dir[i], jerk * dt2 / 2.0 * dir[i]);
        q[(i, A)] += pa;
        q[(A, i)] += pa;
        q[(V + i, A)] += va;
        q[(A, V + i)] += va;
    }
    q[(A, A)] += jerk * dt;
    q
}

/// The measurements of one frame: the sight's two angles (across it, horizontal and up) and the
/// range.
const MEASUREMENTS: usize = 3;

/// The predicted state corrected by the frame's sight and image range, relinearized
/// `config.iterations` times (an iterated EKF: each pass linearizes at the last pass's state).
fn correct(
    predicted: &Predicted,
    sight: &Sight,
    range: &RangeReading,
    config: &FlightFilterConfig,
) -> (State, Covariance) {
    let station = Vector3::from(sight.station_enu_m);
    let dir = Vector3::from(sight.dir_enu);
    // Two unit vectors across the sight: horizontal, and the third of the triad.
    let horizontal = dir.cross(&Vector3::z());
    let horizontal = if horizontal.norm() > 1e-9 {
        horizontal.normalize()
    } else {
        Vector3::x()
    };
    let up = dir.cross(&horizontal);
    let angle_variance = sight.sd_rad * sight.sd_rad;
    // The image range's variance, raised where it lies beyond `huber_sigmas` of the prediction.
    let (x0, p0) = (predicted.x, predicted.p);
    let range_variance = {
        let offset = x0.fixed_rows::<3>(0) - station;
        let predicted_range = offset.norm();
        let sight0 = offset / predicted_range;
        let spread =
            (sight0.transpose() * p0.fixed_view::<3, 3>(0, 0) * sight0).x + range.sd_m * range.sd_m;
        let distance = libm::fabs(range.range_m - predicted_range) / libm::sqrt(spread);
        let huber = f64::from(config.huber_sigmas);
        let r = range.sd_m * range.sd_m;
        if distance > huber && huber > 0.0 {
            r + spread * (distance / huber - 1.0)
        } else {
            r
        }
    };
    let noise = SMatrix::<f64, MEASUREMENTS, MEASUREMENTS>::from_diagonal(&SVector::from([
        angle_variance,
        angle_variance,
        range_variance,
    ]));
    let mut x = x0;
    let mut h = SMatrix::<f64, MEASUREMENTS, 7>::zeros();
    let mut gain = SMatrix::<f64, 7, MEASUREMENTS>::zeros();
    for _ in 0..config.iterations.max(1) {
        let offset = x.fixed_rows::<3>(0) - station;
        let distance = offset.norm();
        let seen = offset / distance;
        // The predicted angles (the sight's components across the measured one) and range.
        let values =
            SVector::<f64, MEASUREMENTS>::from([horizontal.dot(&seen), up.dot(&seen), distance]);
        let measured = SVector::<f64, MEASUREMENTS>::from([0.0, 0.0, range.range_m]);
        // d(e . seen)/dp = (e - seen (e . seen)) / distance; d(distance)/dp = seen.
        for (row, e) in [horizontal, up].iter().enumerate() {
            let d = (e - seen * e.dot(&seen)) / distance;
            h.fixed_view_mut::<1, 3>(row, 0).copy_from(&d.transpose());
        }
        h.fixed_view_mut::<1, 3>(2, 0).copy_from(&seen.transpose());
        let innovation_cov = h * p0 * h.transpose() + noise;
        let Some(inverse) = innovation_cov.try_inverse() else {
            return (x0, p0);
        };
        gain = p0 * h.transpose() * inverse;
        x = x0 + gain * (measured - values - h * (x0 - x));
    }
    // Joseph's form keeps the covariance symmetric and positive.
    let i_kh = Covariance::identity() - gain * h;
    let p = i_kh * p0 * i_kh.transpose() + gain * noise * gain.transpose();
    (x, p)
}

/// Smooths the steps of a recorded clip in place (Rauch-Tung-Striebel): each frame's estimate
/// then uses the frames after it too. `steps` are in time order; where a step's prediction did
/// not come from the step before it (a new flight, a frame left out), the smoothing restarts
/// there.
pub fn smooth(steps: &mut [FlightStep]) {
    for k in (1..steps.len()).rev() {
        let (Some(next), Some(step)) = (steps.get(k).copied(), steps.get_mut(k - 1)) else {
            continue;
        };
        let Some(predicted) = next.predicted else {
            continue;
        };
        if predicted.from_t != step.t || predicted.from_x != step.x {
            continue;
        }
        let Some(predicted_inverse) = predicted.p.try_inverse() else {
            continue;
        };
        let gain = step.p * predicted.transition.transpose() * predicted_inverse;
        let x = step.x + gain * (next.x - predicted.x);
        let p = step.p + gain * (next.p - predicted.p) * gain.transpose();
        if x.iter().chain(p.iter()).all(|v| v.is_finite()) {
            step.x = x;
            step.p = p;
        }
    }
}
