//! Summary statistics of error and IoU samples.

use serde::Serialize;

/// Median, mean and 90th percentile of a sample.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Summary {
    /// Sample size.
    pub n: usize,
    /// Median.
    pub median: f64,
    /// Mean.
    pub mean: f64,
    /// 90th percentile.
    pub p90: f64,
}

/// Box-plot statistics of a sample (whiskers at the extremes).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BoxStats {
    /// Sample size.
    pub n: usize,
    /// Smallest value.
    pub min: f64,
    /// 25th percentile.
    pub q1: f64,
    /// Median.
    pub median: f64,
    /// 75th percentile.
    pub q3: f64,
    /// Largest value.
    pub max: f64,
    /// Mean.
    pub mean: f64,
}

/// The `q`-quantile (0..=1) of sorted values, linearly interpolated between order statistics
/// (the "type 7" definition of R and numpy); None for an empty sample.
pub fn quantile(sorted: &[f64], q: f64) -> Option<f64> {
    let last = sorted.len().checked_sub(1)?;
    let position = q.clamp(0.0, 1.0) * last as f64;
    let below = position.floor() as usize;
    let above = (below + 1).min(last);
    let (a, b) = (*sorted.get(below)?, *sorted.get(above)?);
    Some(a + (b - a) * (position - below as f64))
}

fn sorted(values: &[f64]) -> Vec<f64> {
    let mut v: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    v
}

fn mean(sorted: &[f64]) -> f64 {
    sorted.iter().sum::<f64>() / sorted.len() as f64
}

/// Median, mean and 90th percentile of the finite values; None when there are none.
pub fn summarize(values: &[f64]) -> Option<Summary> {
    let v = sorted(values);
    Some(Summary {
        n: v.len(),
        median: quantile(&v, 0.5)?,
        mean: mean(&v),
        p90: quantile(&v, 0.9)?,
    })
}

/// Box-plot statistics of the finite values; None when there are none.
pub fn box_stats(values: &[f64]) -> Option<BoxStats> {
    let v = sorted(values);
    Some(BoxStats {
        n: v.len(),
        min: *v.first()?,
        q1: quantile(&v, 0.25)?,
        median: quantile(&v, 0.5)?,
        q3: quantile(&v, 0.75)?,
        max: *v.last()?,
        mean: mean(&v),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_match_the_type_7_definition() {
        // numpy.percentile([1, 2, 3, 4, 10], [25, 50, 90]) = [2.0, 3.0, 7.6]
        let s = summarize(&[10.0, 1.0, 3.0, 2.0, 4.0]).unwrap();
        assert_eq!(s.median, 3.0);
        assert!((s.p90 - 7.6).abs() < 1e-12);
        assert_eq!(s.mean, 4.0);
        let b = box_stats(&[10.0, 1.0, 3.0, 2.0, 4.0, f64::NAN]).unwrap();
        assert_eq!((b.n, b.min, b.q1, b.q3, b.max), (5, 1.0, 2.0, 4.0, 10.0));
        assert!(summarize(&[f64::NAN]).is_none());
    }
}
