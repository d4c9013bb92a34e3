//! Nelder-Mead simplex minimization (Lagarias et al. 1998 coefficients: reflection 1,
//! expansion 2, contraction 1/2, shrink 1/2), derivative-free, in fixed memory: `N` parameters,
//! `V = N + 1` vertices (checked at compile time).

/// When the search stops.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NelderMeadConfig {
    /// Most objective evaluations.
    pub max_evaluations: u32,
    /// Stop when the spread of the objective over the simplex is at most this...
    pub f_tolerance: f32,
    /// ... and every vertex is within this of the best one in every parameter.
    pub x_tolerance: f32,
}

/// The best point found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Minimum<const N: usize> {
    /// Its parameters.
    pub x: [f32; N],
    /// The objective there.
    pub f: f32,
    /// Objective evaluations spent.
    pub evaluations: u32,
}

/// Minimizes `f` from `start`, the initial simplex spanning `steps` along each parameter. A
/// non-finite objective value counts as +infinity (use it for points outside the feasible
/// region).
pub fn minimize<const N: usize, const V: usize>(
    mut f: impl FnMut(&[f32; N]) -> f32,
    start: [f32; N],
    steps: [f32; N],
    config: &NelderMeadConfig,
) -> Minimum<N> {
    const { assert!(N >= 1 && V == N + 1, "a simplex has N + 1 vertices") };
    let mut evaluations = 0u32;
    let mut eval = |x: &[f32; N], count: &mut u32| {
        *count += 1;
        let v = f(x);
        if v.is_finite() { v } else { f32::INFINITY }
    };
    let mut points = [start; V];
    let mut values = [0.0f32; V];
    for (i, p) in points.iter_mut().enumerate().skip(1) {
        if let (Some(c), Some(s)) = (p.get_mut(i - 1), steps.get(i - 1)) {
            *c += s;
        }
    }
    for (p, v) in points.iter().zip(values.iter_mut()) {
        *v = eval(p, &mut evaluations);
    }
    loop {
        sort(&mut points, &mut values);
        let (best, worst, second) = (values[0], values[V - 1], values[V - 2]);
        if evaluations >= config.max_evaluations || converged(&points, &values, config) {
            break;
        }
        let mut centroid = [0.0f32; N];
        for p in points.iter().take(N) {
            for (c, x) in centroid.iter_mut().zip(p) {
                *c += x / N as f32;
            }
        }
        let toward = |t: f32, from: &[f32; N]| -> [f32; N] {
            core::array::from_fn(|k| centroid[k] + t * (from[k] - centroid[k]))
        };
        let worst_point = points[V - 1];
        let reflected = toward(-1.0, &worst_point);
        let fr = eval(&reflected, &mut evaluations);
        let accepted = if fr < best {
            let expanded = toward(-2.0, &worst_point);
            let fe = eval(&expanded, &mut evaluations);
            Some(if fe < fr {
                (expanded, fe)
            } else {
                (reflected, fr)
            })
        } else if fr < second {
            Some((reflected, fr))
        } else {
            // Outside contraction when the reflection improved on the worst, else inside.
            let (t, bound) = if fr < worst { (-0.5, fr) } else { (0.5, worst) };
            let contracted = toward(t, &worst_point);
            let fc = eval(&contracted, &mut evaluations);
            (fc <= bound).then_some((contracted, fc))
        };
        match accepted {
            Some((p, v)) => {
                points[V - 1] = p;
                values[V - 1] = v;
            }
            None => {
                let anchor = points[0];
                for (p, v) in points.iter_mut().zip(values.iter_mut()).skip(1) {
                    for (x, a) in p.iter_mut().zip(anchor) {
                        *x = a + 0.5 * (*x - a);
                    }
                    *v = eval(p, &mut evaluations);
                }
            }
        }
    }
    Minimum {
        x: points[0],
        f: values[0],
        evaluations,
    }
}

/// Insertion sort of the vertices by objective value, best first (V is small).
fn sort<const N: usize, const V: usize>(points: &mut [[f32; N]; V], values: &mut [f32; V]) {
    for i in 1..V {
        let mut j = i;
        while j > 0 && values[j] < values[j - 1] {
            values.swap(j, j - 1);
            points.swap(j, j - 1);
            j -= 1;
        }
    }
}

fn converged<const N: usize, const V: usize>(
    points: &[[f32; N]; V],
    values: &[f32; V],
    config: &NelderMeadConfig,
) -> bool {
    let spread = values[V - 1] - values[0];
    let size = points.iter().skip(1).fold(0.0f32, |m, p| {
        p.iter()
            .zip(&points[0])
            .fold(m, |m, (a, b)| m.max((a - b).abs()))
    });
    spread <= config.f_tolerance && size <= config.x_tolerance
}

#[cfg(test)]
mod tests {
    use super::*;

    const CONFIG: NelderMeadConfig = NelderMeadConfig {
        max_evaluations: 4000,
        f_tolerance: 1e-10,
        x_tolerance: 1e-5,
    };

    #[test]
    fn finds_the_rosenbrock_valley_minimum() {
        let rosen = |x: &[f32; 2]| {
            let (a, b) = (1.0 - x[0], x[1] - x[0] * x[0]);
            a * a + 100.0 * b * b
        };
        let m = minimize::<2, 3>(rosen, [-1.2, 1.0], [0.5, 0.5], &CONFIG);
        assert!(
            (m.x[0] - 1.0).abs() < 1e-2 && (m.x[1] - 1.0).abs() < 2e-2,
            "{m:?}"
        );
        assert!(m.evaluations < CONFIG.max_evaluations);
    }

    #[test]
    fn finds_a_shifted_quadratic_in_seven_dimensions() {
        let target = [0.3, -0.2, 0.05, 0.1, -0.1, 2.0, -3.0];
        let weights = [4.0, 1.0, 9.0, 2.0, 2.0, 0.1, 0.3];
        let q = |x: &[f32; 7]| {
            (0..7)
                .map(|k| weights[k] * (x[k] - target[k]) * (x[k] - target[k]))
                .sum::<f32>()
        };
        let m = minimize::<7, 8>(q, [0.0; 7], [0.1; 7], &CONFIG);
        for (k, (got, want)) in m.x.iter().zip(target).enumerate() {
            assert!((got - want).abs() < 1e-2, "{k}: {m:?}");
        }
    }

    #[test]
    fn treats_non_finite_values_as_infeasible_and_respects_the_budget() {
        // Feasible only for x >= 1: the minimum is on the boundary.
        let f = |x: &[f32; 1]| if x[0] < 1.0 { f32::NAN } else { x[0] };
        let budget = NelderMeadConfig {
            max_evaluations: 60,
            ..CONFIG
        };
        let m = minimize::<1, 2>(f, [3.0], [1.0], &budget);
        assert!(m.x[0] >= 1.0 && m.x[0] < 1.1, "{m:?}");
        assert!(m.evaluations <= 62, "{}", m.evaluations);
    }
}
