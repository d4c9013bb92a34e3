//! The standard normal distribution, tabulated: its CDF `Phi` and density `phi` by cubic Hermite
//! interpolation between knots every [`STEP`] over `-U_MAX..U_MAX`, in pure f32.
//!
//! The blurred-box fits evaluate `Phi` and `phi` a few million times a frame; `libm`'s `erff`
//! and `expf` were most of their time (more on the Cortex-M4F). The knots are computed at
//! compile time (f64 series, rounded to f32), so the host and the firmware use the same bits,
//! and the interpolation is a fixed sequence of f32 operations (no fused multiply-add), so they
//! give the same results. Interpolating `Phi` with its derivative `phi` and `phi` with its
//! derivative `-u phi` at the knots is exact to about 5e-8 (absolute) everywhere.

/// Knot spacing, in standard deviations.
pub const STEP: f32 = 1.0 / 16.0;
/// The table's half range, in standard deviations: beyond it `Phi` is 0 or 1 and `phi` is 0
/// (both below 1e-15).
pub const U_MAX: f32 = 8.0;
/// Knots: `u_i = -U_MAX + i STEP`.
const KNOTS: usize = 257;

/// `(Phi(u_i), phi(u_i))` at every knot.
static TABLE: [(f32, f32); KNOTS] = table();

/// The standard normal CDF and density at `u`: `(Phi(u), phi(u))`. NaN gives NaN.
#[inline]
pub fn cdf_pdf(u: f32) -> (f32, f32) {
    let x = (u + U_MAX) * (1.0 / STEP);
    if x.is_nan() {
        return (x, x);
    }
    if x <= 0.0 {
        return (0.0, 0.0);
    }
    if x >= (KNOTS - 1) as f32 {
        return (1.0, 0.0);
    }
    let i = x as usize;
    let (Some(&(p0, d0)), Some(&(p1, d1))) = (TABLE.get(i), TABLE.get(i + 1)) else {
        return (1.0, 0.0);
    };
    // The knots are exact in f32; `u - u0` keeps u's precision (`x` rounds it near 0).
    let u0 = i as f32 * STEP - U_MAX;
    let u1 = u0 + STEP;
    let t = ((u - u0) * (1.0 / STEP)).clamp(0.0, 1.0);
    let s = 1.0 - t;
    // Hermite basis on [0, 1]; derivatives are scaled by the knot spacing.
    let h00 = (1.0 + 2.0 * t) * s * s;
    let h01 = t * t * (3.0 - 2.0 * t);
    let h10 = t * s * s * STEP;
    let h11 = -(t * t * s) * STEP;
    let cdf = p0 + h01 * (p1 - p0) + (h10 * d0 + h11 * d1);
    let pdf = h00 * d0 + h01 * d1 - (h10 * u0 * d0 + h11 * u1 * d1);
    (cdf, pdf)
}

/// Standard normal cumulative distribution.
#[inline]
pub fn cdf(u: f32) -> f32 {
    cdf_pdf(u).0
}

/// Standard normal density.
#[inline]
pub fn pdf(u: f32) -> f32 {
    cdf_pdf(u).1
}

/// The knots, computed in f64 at compile time.
const fn table() -> [(f32, f32); KNOTS] {
    let mut out = [(0.0f32, 0.0f32); KNOTS];
    let mut i = 0;
    while i < KNOTS {
        let u = -(U_MAX as f64) + i as f64 * STEP as f64;
        let density = 0.398_942_280_401_432_7 * exp_neg(0.5 * u * u);
        let half = 0.5 * erf_abs(abs(u) * core::f64::consts::FRAC_1_SQRT_2);
        let cdf = if u < 0.0 { 0.5 - half } else { 0.5 + half };
        out[i] = (cdf as f32, density as f32);
        i += 1;
    }
    out
}

const fn abs(x: f64) -> f64 {
    if x < 0.0 { -x } else { x }
}

/// `exp(-a)` for `a >= 0`, relative error about 1e-15: `exp(-a) = 2^-k exp(-r)`, `r` in
/// `[0, ln 2)`, by its Taylor series.
const fn exp_neg(a: f64) -> f64 {
    let mut k = 0;
    let mut r = a;
    while r >= core::f64::consts::LN_2 {
        r -= core::f64::consts::LN_2;
        k += 1;
    }
    let (mut term, mut sum, mut n) = (1.0f64, 1.0f64, 1.0f64);
    while n < 30.0 {
        term *= -r / n;
        sum += term;
        n += 1.0;
    }
    while k > 0 {
        sum *= 0.5;
        k -= 1;
    }
    sum
}

/// `erf(x)` for `x >= 0`: `2/sqrt(pi) exp(-x²) sum_n 2^n x^(2n+1) / (1 3 ... (2n+1))`, a series
/// of positive terms (no cancellation).
const fn erf_abs(x: f64) -> f64 {
    let (mut term, mut sum, mut n) = (x, x, 0.0f64);
    while term > 1e-17 * sum {
        n += 1.0;
        term *= 2.0 * x * x / (2.0 * n + 1.0);
        sum += term;
    }
    core::f64::consts::FRAC_2_SQRT_PI * exp_neg(x * x) * sum
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against `libm`'s `erf` and `exp` in f64 (independent of the table's series), between and
    /// at knots, in the tails and beyond the table.
    #[test]
    fn matches_the_f64_distribution() {
        let mut worst = (0.0f64, 0.0f64);
        let mut k = 0;
        let mut at = 0.0;
        while k <= 14_000 {
            let x = -9.0 + k as f32 * 0.001_3;
            let (c, p) = cdf_pdf(x);
            let u = f64::from(x);
            let truth_c = 0.5 * (1.0 + libm::erf(u * core::f64::consts::FRAC_1_SQRT_2));
            let truth_p = 0.398_942_280_401_432_7 * libm::exp(-0.5 * u * u);
            if (f64::from(c) - truth_c).abs() > worst.0 {
                at = x;
            }
            worst.0 = worst.0.max((f64::from(c) - truth_c).abs());
            worst.1 = worst.1.max((f64::from(p) - truth_p).abs());
            k += 1;
        }
        assert!(
            worst.0 < 1e-7 && worst.1 < 1e-7,
            "worst errors {worst:?} at {at}"
        );
        assert_eq!(cdf_pdf(-100.0), (0.0, 0.0));
        assert_eq!(cdf_pdf(100.0), (1.0, 0.0));
        assert!(cdf(f32::NAN).is_nan() && pdf(f32::NAN).is_nan());
        assert_eq!(cdf_pdf(f32::INFINITY), (1.0, 0.0));
        assert_eq!(cdf_pdf(f32::NEG_INFINITY), (0.0, 0.0));
    }

    /// Monotone CDF across knots (a fit's cost must not see steps), to one rounding
    /// step near 1 (f32::EPSILON).
    #[test]
    fn cdf_is_monotone() {
        let mut last = 0.0f32;
        let mut u = -8.5f32;
        while u < 8.5 {
            let c = cdf(u);
            assert!(c >= last - f32::EPSILON, "at {u}: {c} < {last}");
            last = c;
            u += 0.000_7;
        }
    }
}
