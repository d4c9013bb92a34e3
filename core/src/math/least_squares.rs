//! Levenberg-Marquardt (damped Gauss-Newton) over `N` parameters, in fixed memory, pure f32.
//!
//! A fit implements [`Problem`]: at a point of its parameter space it accumulates, over its own
//! data, the weighted squared residual and the normal equations `JᵀWJ` and `JᵀWr` (a
//! [`Normal`], usually with [`Normal::add`] per point and [`Normal::complete`] at the end),
//! where `r` is the measured minus the modelled value and `J` the model's gradient. [`minimize`] owns the rest: the damping,
//! the step, its acceptance, the convergence test and the iteration limit, as set by a
//! [`Config`].
//!
//! Each iteration solves `(JᵀWJ + λ diag(max(JᵀWJ_kk, floor))) δ = JᵀWr` by Cholesky, lets the
//! problem [`constrain`](Problem::constrain) the trial `p + δ`, and evaluates it. A trial whose
//! cost is finite and not larger is accepted and `λ` shrinks; the fit has converged when the
//! cost fell by at most a relative tolerance. Otherwise `λ` grows, and the search gives up when
//! `λ` passes its limit; a damped matrix Cholesky cannot factor also grows `λ`, without a trial
//! and without that limit (the iteration limit still holds). Where the config sets a step
//! tolerance, a trial, accepted or not, that moves the parameters by at most that fraction of
//! their size has converged too. The operations are a fixed
//! sequence of f32 additions, multiplications, divisions and square roots (no fused multiply-add,
//! in nalgebra's Cholesky either), so the host and the Cortex-M4F give the same bits.

use nalgebra::{SMatrix, SVector};

/// A relative cost change is measured against at least this cost (in the problem's cost units),
/// so an exact fit (cost 0) stops.
const COST_FLOOR: f32 = 1e-12;

/// The cost and normal equations of a least-squares problem at one point of its parameter space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Normal<const N: usize> {
    /// Weighted sum of squared residuals.
    pub cost: f32,
    /// `JᵀWJ`, symmetric: [`minimize`] reads its lower triangle (with the diagonal).
    pub jtj: SMatrix<f32, N, N>,
    /// `JᵀWr`, `r` the measured minus the modelled value.
    pub jtr: SVector<f32, N>,
}

impl<const N: usize> Normal<N> {
    /// Nothing accumulated yet.
    pub fn zeros() -> Normal<N> {
        Normal {
            cost: 0.0,
            jtj: SMatrix::zeros(),
            jtr: SVector::zeros(),
        }
    }

    /// Adds one point: residual `r` (measured minus modelled), model gradient `g` with respect
    /// to the parameters, weight `w`. The cost grows by `w r²`, `JᵀWJ` by `w g gᵀ` (its upper
    /// triangle only: [`complete`](Normal::complete) it once every point is added) and `JᵀWr`
    /// by `w r g`.
    #[inline]
    pub fn add(&mut self, g: &SVector<f32, N>, w: f32, r: f32) {
        self.cost += w * r * r;
        super::accumulate(&mut self.jtj, &mut self.jtr, g, w, r);
    }

    /// `JᵀWJ`'s lower triangle copied from its upper, where [`add`](Normal::add) accumulates.
    /// (Completed here, at the end of the fit's evaluation, rather than in the solver: the
    /// compiler then makes a faster per-point loop for the Cortex-M4F, 13 % fewer instructions
    /// in the box fit's evaluation.)
    #[inline]
    pub fn complete(mut self) -> Normal<N> {
        self.jtj.fill_lower_triangle_with_upper_triangle();
        self
    }
}

/// A least-squares fit, as [`minimize`] sees it.
pub trait Problem<const N: usize> {
    /// The cost and normal equations at `p`, accumulated over the fit's data; `None` where the
    /// model cannot be evaluated. A non-finite cost counts as `None`.
    fn evaluate(&self, p: &SVector<f32, N>) -> Option<Normal<N>>;

    /// Moves a trial point into the region where the model is meaningful (clamping a width to
    /// be positive, say, or limiting the step from `from`), before it is evaluated. The
    /// default leaves it as it is.
    fn constrain(&self, from: &SVector<f32, N>, trial: &mut SVector<f32, N>) {
        let _ = (from, trial);
    }
}

/// When and how [`minimize`] damps and stops.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// Most iterations (each solves the damped normal equations once and evaluates at most one
    /// trial).
    pub max_iterations: u32,
    /// The damping `λ` at the start: the fraction of each diagonal element of `JᵀWJ` added to
    /// it (dimensionless).
    pub initial_damping: f32,
    /// Factor on `λ` after a rejected trial or a damped matrix Cholesky cannot factor.
    pub damping_up: f32,
    /// Factor on `λ` after an accepted trial.
    pub damping_down: f32,
    /// `λ` shrinks no further than this.
    pub min_damping: f32,
    /// The search gives up when a rejected trial raises `λ` beyond this.
    pub max_damping: f32,
    /// The damping scales each diagonal element of `JᵀWJ` by at least this (in that element's
    /// units): a parameter the cost does not depend on (a fixed one, its gradient zeroed) is
    /// still damped, so the damped matrix stays positive definite and its step is zero.
    pub diagonal_floor: f32,
    /// Converged when an accepted trial lowers the cost by at most this fraction of it.
    pub relative_tolerance: f32,
    /// Converged, too, when a trial moves the parameters by at most this fraction of their
    /// size (`|trial - p| <= step_tolerance |p|`, Euclidean, as MINPACK's `xtol`), whether it
    /// is accepted or rejected: a larger damping only shortens the step, so the point is found
    /// to that precision. Near the minimum a cost in f32 changes by rounding only, and the cost
    /// test alone then waits for the damping to pass its limit, a rejected trial at a time.
    /// 0 (the default): the cost's test alone.
    pub step_tolerance: f32,
}

impl Config {
    /// The damping schedule every fit of the core uses (each sets its own iteration limit and
    /// tolerance): start at 1e-2, x10 after a rejected trial, x0.3 after an accepted one, within
    /// 1e-7..1e6, diagonal floor 1e-9.
    pub const DEFAULT: Config = Config {
        max_iterations: 30,
        initial_damping: 1e-2,
        damping_up: 10.0,
        damping_down: 0.3,
        min_damping: 1e-7,
        max_damping: 1e6,
        diagonal_floor: 1e-9,
        relative_tolerance: 1e-7,
        step_tolerance: 0.0,
    };
}

/// Why [`minimize`] stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Stop {
    /// An accepted trial lowered the cost by at most [`Config::relative_tolerance`], or a
    /// trial moved the parameters by at most [`Config::step_tolerance`] of their size.
    Converged,
    /// The damping passed [`Config::max_damping`]: no step nearby lowers the cost.
    DampingLimit,
    /// [`Config::max_iterations`] were spent.
    IterationLimit,
}

/// Where [`minimize`] stopped.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Solution<const N: usize> {
    /// The parameters: the start or an accepted trial.
    pub params: SVector<f32, N>,
    /// The cost there (finite).
    pub cost: f32,
    /// `JᵀWJ` there (complete), for the parameters' covariance.
    pub jtj: SMatrix<f32, N, N>,
    /// Iterations spent.
    pub iterations: u32,
    /// Why it stopped.
    pub stop: Stop,
}

/// Minimizes `problem`'s cost by Levenberg-Marquardt from `start`. `None` when the start cannot
/// be evaluated or its cost is not finite; a trial that cannot be evaluated is rejected.
pub fn minimize<const N: usize>(
    problem: &impl Problem<N>,
    start: SVector<f32, N>,
    config: &Config,
) -> Option<Solution<N>> {
    let evaluate = |p: &SVector<f32, N>| problem.evaluate(p).filter(|n| n.cost.is_finite());
    let mut p = start;
    // The cost and normal equations at `p`, carried over from an accepted trial.
    let mut at_p = evaluate(&p)?;
    let mut damping = config.initial_damping;
    let mut iterations = 0;
    let mut stop = Stop::IterationLimit;
    while iterations < config.max_iterations {
        iterations += 1;
        let mut damped = at_p.jtj;
        for k in 0..N {
            if let Some(d) = damped.get_mut((k, k)) {
                *d += damping * d.max(config.diagonal_floor);
            }
        }
        let Some(step) = damped.cholesky().map(|c| c.solve(&at_p.jtr)) else {
            damping *= config.damping_up;
            continue;
        };
        let mut trial = p + step;
        problem.constrain(&p, &mut trial);
        let tolerance = config.step_tolerance;
        let short_step = (trial - p).norm_squared() <= tolerance * tolerance * p.norm_squared();
        match evaluate(&trial) {
            Some(at_trial) if at_trial.cost <= at_p.cost => {
                let converged = short_step
                    || (at_p.cost - at_trial.cost)
                        <= config.relative_tolerance * at_p.cost.max(COST_FLOOR);
                p = trial;
                at_p = at_trial;
                damping = (damping * config.damping_down).max(config.min_damping);
                if converged {
                    stop = Stop::Converged;
                    break;
                }
            }
            _ if short_step => {
                stop = Stop::Converged;
                break;
            }
            _ => {
                damping *= config.damping_up;
                if damping > config.max_damping {
                    stop = Stop::DampingLimit;
                    break;
                }
            }
        }
    }
    Some(Solution {
        params: p,
        cost: at_p.cost,
        jtj: at_p.jtj,
        iterations,
        stop,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Settings for the tests: the fits' damping schedule, a tight tolerance, room to converge.
    const CONFIG: Config = Config {
        max_iterations: 200,
        ..Config::DEFAULT
    };

    /// A model `y(x; p)` of two parameters: its value and gradient.
    type Model = fn(f32, &SVector<f32, 2>) -> (f32, SVector<f32, 2>);

    /// Points `(x, y)` fitted by a model, all weights 1.
    struct Curve {
        points: [(f32, f32); 8],
        model: Model,
    }

    impl Problem<2> for Curve {
        fn evaluate(&self, p: &SVector<f32, 2>) -> Option<Normal<2>> {
            let mut normal = Normal::zeros();
            for &(x, y) in &self.points {
                let (value, g) = (self.model)(x, p);
                normal.add(&g, 1.0, y - value);
            }
            Some(normal.complete())
        }
    }

    /// Exact points of `model` at `truth`, x from -1 to 2.5.
    fn curve(truth: [f32; 2], model: Model) -> Curve {
        let truth = SVector::from(truth);
        let points = core::array::from_fn(|i| {
            let x = i as f32 * 0.5 - 1.0;
            (x, model(x, &truth).0)
        });
        Curve { points, model }
    }

    fn line(x: f32, p: &SVector<f32, 2>) -> (f32, SVector<f32, 2>) {
        (p[0] + p[1] * x, SVector::from([1.0, x]))
    }

    fn exponential(x: f32, p: &SVector<f32, 2>) -> (f32, SVector<f32, 2>) {
        let e = libm::expf(p[1] * x);
        (p[0] * e, SVector::from([e, p[0] * x * e]))
    }

    #[test]
    fn a_line_through_exact_points_is_recovered() {
        let problem = curve([1.5, -0.75], line);
        let s = minimize(&problem, SVector::from([0.0, 0.0]), &CONFIG).unwrap();
        assert!((s.params[0] - 1.5).abs() < 1e-5, "{s:?}");
        assert!((s.params[1] + 0.75).abs() < 1e-5, "{s:?}");
        assert!(s.cost < 1e-9, "{s:?}");
        assert_eq!(s.stop, Stop::Converged);
        // Linear: the damped Gauss-Newton steps get there in a few iterations.
        assert!(s.iterations <= 10, "{s:?}");
    }

    #[test]
    fn an_exponential_through_exact_points_is_recovered() {
        let problem = curve([2.0, -0.8], exponential);
        let s = minimize(&problem, SVector::from([1.0, 0.0]), &CONFIG).unwrap();
        assert!((s.params[0] - 2.0).abs() < 1e-4, "{s:?}");
        assert!((s.params[1] + 0.8).abs() < 1e-4, "{s:?}");
        assert_eq!(s.stop, Stop::Converged);
    }

    /// On points off the curve (a residual cost at the minimum), the cost's test alone goes on
    /// while each step still lowers the cost by more than its tolerance of it (12 iterations);
    /// a step tolerance ends the fit once a step no longer moves the parameters by more than
    /// that fraction of them (5), at the same point to 1e-4.
    #[test]
    fn a_step_that_no_longer_moves_the_parameters_ends_the_fit() {
        let mut problem = curve([2.0, -0.8], exponential);
        for (i, point) in problem.points.iter_mut().enumerate() {
            point.1 += if i % 2 == 0 { 0.01 } else { -0.01 };
        }
        let start = SVector::from([1.0, 0.0]);
        let by_cost = minimize(&problem, start, &CONFIG).unwrap();
        let stepped = Config {
            step_tolerance: 1e-5,
            ..CONFIG
        };
        let by_step = minimize(&problem, start, &stepped).unwrap();
        assert_eq!(by_step.stop, Stop::Converged, "{by_step:?}");
        assert!(
            by_step.iterations < by_cost.iterations,
            "{by_step:?} {by_cost:?}"
        );
        for k in 0..2 {
            assert!(
                (by_step.params[k] - by_cost.params[k]).abs() < 1e-4,
                "{by_step:?} {by_cost:?}"
            );
        }
    }

    /// Rosenbrock's valley as least squares: `r = (10 (y - x²), 1 - x)`, minimum 0 at (1, 1),
    /// from the classic start (-1.2, 1).
    struct Rosenbrock;

    impl Problem<2> for Rosenbrock {
        fn evaluate(&self, p: &SVector<f32, 2>) -> Option<Normal<2>> {
            let (x, y) = (p[0], p[1]);
            let mut normal = Normal::zeros();
            // Residuals as measured (0) minus modelled, gradients of the modelled values.
            normal.add(
                &SVector::from([-20.0 * x, 10.0]),
                1.0,
                -(10.0 * (y - x * x)),
            );
            normal.add(&SVector::from([-1.0, 0.0]), 1.0, -(1.0 - x));
            Some(normal.complete())
        }
    }

    #[test]
    fn rosenbrock_converges() {
        let s = minimize(&Rosenbrock, SVector::from([-1.2, 1.0]), &CONFIG).unwrap();
        assert!((s.params[0] - 1.0).abs() < 1e-3, "{s:?}");
        assert!((s.params[1] - 1.0).abs() < 1e-3, "{s:?}");
        assert!(s.cost < 1e-6, "{s:?}");
        assert_ne!(s.stop, Stop::IterationLimit, "{s:?}");
    }

    /// A line fit whose evaluation fails (`None`) or is NaN for slopes above `limit`.
    struct Fragile {
        line: Curve,
        limit: f32,
        nan: bool,
    }

    impl Problem<2> for Fragile {
        fn evaluate(&self, p: &SVector<f32, 2>) -> Option<Normal<2>> {
            let mut normal = self.line.evaluate(p)?;
            if p[1] > self.limit {
                if !self.nan {
                    return None;
                }
                normal.cost = f32::NAN;
            }
            Some(normal)
        }
    }

    fn fragile(limit: f32, nan: bool) -> Fragile {
        Fragile {
            line: curve([0.0, 1.0], line),
            limit,
            nan,
        }
    }

    #[test]
    fn a_start_that_cannot_be_evaluated_is_a_failure() {
        let start = SVector::from([0.0, 2.0]);
        assert_eq!(minimize(&fragile(1.5, false), start, &CONFIG), None);
        assert_eq!(minimize(&fragile(1.5, true), start, &CONFIG), None);
        let infinite = SVector::from([f32::INFINITY, 0.0]);
        assert_eq!(minimize(&fragile(1.5, false), infinite, &CONFIG), None);
        let nan = SVector::from([f32::NAN, 0.0]);
        assert_eq!(minimize(&fragile(1.5, false), nan, &CONFIG), None);
    }

    #[test]
    fn trials_that_cannot_be_evaluated_are_rejected() {
        // The optimum (slope 1) lies beyond the evaluable region (slope <= 0.5): every accepted
        // point stays inside it, and the search ends with a finite cost.
        for nan in [false, true] {
            let s = minimize(&fragile(0.5, nan), SVector::from([0.0, 0.0]), &CONFIG).unwrap();
            assert!(s.params[1] <= 0.5, "{s:?}");
            assert!(s.params[1] > 0.4, "{s:?}");
            assert!(s.cost.is_finite(), "{s:?}");
        }
    }

    /// The line fit with the slope held at or below `max_slope` and the intercept fixed (its
    /// gradient zeroed).
    struct Constrained {
        line: Curve,
        max_slope: f32,
    }

    impl Problem<2> for Constrained {
        fn evaluate(&self, p: &SVector<f32, 2>) -> Option<Normal<2>> {
            let mut normal = Normal::zeros();
            for &(x, y) in &self.line.points {
                let (value, mut g) = line(x, p);
                g[0] = 0.0;
                normal.add(&g, 1.0, y - value);
            }
            Some(normal.complete())
        }

        fn constrain(&self, _: &SVector<f32, 2>, trial: &mut SVector<f32, 2>) {
            trial[1] = trial[1].min(self.max_slope);
        }
    }

    #[test]
    fn a_constraint_holds_and_a_fixed_parameter_stays_put() {
        let problem = Constrained {
            line: curve([0.25, 2.0], line),
            max_slope: 1.0,
        };
        let s = minimize(&problem, SVector::from([0.25, 0.0]), &CONFIG).unwrap();
        assert_eq!(s.params[0], 0.25, "{s:?}");
        assert_eq!(s.params[1], 1.0, "{s:?}");
        // Free, the slope is found and the intercept is still not moved.
        let free = Constrained {
            max_slope: f32::INFINITY,
            ..problem
        };
        let s = minimize(&free, SVector::from([0.25, 0.0]), &CONFIG).unwrap();
        assert_eq!(s.params[0], 0.25, "{s:?}");
        assert!((s.params[1] - 2.0).abs() < 1e-5, "{s:?}");
    }

    /// The line fit with the slope's step limited to 0.25 per iteration.
    struct StepLimited(Curve);

    impl Problem<2> for StepLimited {
        fn evaluate(&self, p: &SVector<f32, 2>) -> Option<Normal<2>> {
            self.0.evaluate(p)
        }

        fn constrain(&self, from: &SVector<f32, 2>, trial: &mut SVector<f32, 2>) {
            trial[1] = from[1] + (trial[1] - from[1]).clamp(-0.25, 0.25);
        }
    }

    #[test]
    fn a_step_limit_from_the_current_point_holds() {
        let problem = StepLimited(curve([0.0, 2.0], line));
        let three = Config {
            max_iterations: 3,
            ..CONFIG
        };
        let s = minimize(&problem, SVector::from([0.0, 0.0]), &three).unwrap();
        assert_eq!(s.params[1], 0.75, "{s:?}");
        let s = minimize(&problem, SVector::from([0.0, 0.0]), &CONFIG).unwrap();
        assert!((s.params[1] - 2.0).abs() < 1e-5, "{s:?}");
    }

    /// Damping held at a floor with no room to grow: Gauss-Newton that stops at the first step
    /// that does not lower the cost, keeping the point before it.
    #[test]
    fn gauss_newton_stops_at_the_first_rejected_step() {
        let gauss_newton = Config {
            initial_damping: 1e-7,
            damping_down: 1.0,
            min_damping: 1e-7,
            max_damping: 1e-7,
            ..CONFIG
        };
        // The full step lands on slope 1, beyond the evaluable slopes (<= 0.5).
        let start = SVector::from([0.0, 0.0]);
        let s = minimize(&fragile(0.5, false), start, &gauss_newton).unwrap();
        assert_eq!(
            (s.params, s.iterations, s.stop),
            (start, 1, Stop::DampingLimit)
        );
        // Where the steps succeed it is Gauss-Newton: one step solves a line.
        let s = minimize(&curve([1.5, -0.75], line), start, &gauss_newton).unwrap();
        assert!((s.params[0] - 1.5).abs() < 1e-5, "{s:?}");
        assert!((s.params[1] + 0.75).abs() < 1e-5, "{s:?}");
        assert!(s.iterations <= 3, "{s:?}");
    }

    #[test]
    fn the_iteration_limit_holds() {
        let problem = curve([2.0, -0.8], exponential);
        let start = SVector::from([1.0, 0.0]);
        let none = Config {
            max_iterations: 0,
            ..CONFIG
        };
        let s = minimize(&problem, start, &none).unwrap();
        assert_eq!(
            (s.params, s.iterations, s.stop),
            (start, 0, Stop::IterationLimit)
        );
        assert_eq!(Some(s.cost), problem.evaluate(&start).map(|n| n.cost));
        let two = Config {
            max_iterations: 2,
            ..CONFIG
        };
        let s = minimize(&problem, start, &two).unwrap();
        assert_eq!((s.iterations, s.stop), (2, Stop::IterationLimit));
        assert!(s.cost < problem.evaluate(&start).unwrap().cost, "{s:?}");
    }

    /// Where no step lowers the cost (the start is the minimum, up to rounding) the damping
    /// grows to its limit, or an accepted equal cost stops the search, and the start is kept.
    #[test]
    fn at_the_minimum_the_search_stops_there() {
        let problem = curve([1.5, -0.75], line);
        let start = SVector::from([1.5, -0.75]);
        let s = minimize(&problem, start, &CONFIG).unwrap();
        assert_eq!(s.cost, 0.0, "{s:?}");
        assert_eq!(s.params, start, "{s:?}");
        assert!(s.stop != Stop::IterationLimit, "{s:?}");
    }

    /// A matrix Cholesky cannot factor (NaN normal equations with a finite cost) raises the
    /// damping without a step, until the iterations run out: no panic, the start kept.
    #[test]
    fn normal_equations_that_cannot_be_factored_are_survived() {
        struct Broken;
        impl Problem<2> for Broken {
            fn evaluate(&self, _: &SVector<f32, 2>) -> Option<Normal<2>> {
                Some(Normal {
                    cost: 1.0,
                    jtj: SMatrix::from_element(f32::NAN),
                    jtr: SVector::from_element(f32::NAN),
                })
            }
        }
        let start = SVector::from([1.0, 2.0]);
        let s = minimize(&Broken, start, &CONFIG).unwrap();
        assert_eq!((s.params, s.cost), (start, 1.0));
        assert_eq!((s.iterations, s.stop), (200, Stop::IterationLimit));
    }
}
