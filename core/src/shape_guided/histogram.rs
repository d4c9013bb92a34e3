//! Intensity histograms with linear (soft) binning, and the symmetric Kullback-Leibler
//! divergence of the source paper's Eq. 7 between two of them.

use crate::capacity::SHAPE_HIST_BINS;

/// A histogram of grey levels over `[lo, hi]` in `bins` equal bins (at most
/// [`SHAPE_HIST_BINS`]). Each sample is split between the two bins whose centres surround it,
/// so the counts vary continuously with the samples (a smooth objective for the simplex).
#[derive(Debug, Clone)]
pub struct Histogram {
    counts: [f32; SHAPE_HIST_BINS],
    bins: usize,
    lo: f32,
    bins_per_level: f32,
    total: f32,
}

impl Histogram {
    /// An empty histogram of `bins` bins (clamped to 2..=[`SHAPE_HIST_BINS`]) over `[lo, hi]`
    /// grey levels; a range narrower than one grey level is widened to one.
    pub fn new(bins: usize, lo: f32, hi: f32) -> Histogram {
        let bins = bins.clamp(2, SHAPE_HIST_BINS);
        let width = (hi - lo).max(1.0);
        Histogram {
            counts: [0.0; SHAPE_HIST_BINS],
            bins,
            lo,
            bins_per_level: bins as f32 / width,
            total: 0.0,
        }
    }

    /// Empties the histogram, keeping its bins.
    pub fn clear(&mut self) {
        self.counts.iter_mut().for_each(|c| *c = 0.0);
        self.total = 0.0;
    }

    /// Adds one sample (values outside the range go to the end bins).
    #[inline]
    pub fn add(&mut self, value: f32) {
        let last = (self.bins - 1) as f32;
        let t = ((value - self.lo) * self.bins_per_level - 0.5).clamp(0.0, last);
        let i = t as usize; // floor: t >= 0
        let w = t - i as f32;
        if let Some(c) = self.counts.get_mut(i) {
            *c += 1.0 - w;
        }
        if let Some(c) = self.counts.get_mut(i + 1) {
            *c += w;
        }
        self.total += 1.0;
    }

    /// Samples added.
    pub fn total(&self) -> f32 {
        self.total
    }

    /// Eq. 7: `(KL(p, q) + KL(q, p)) / 2 = sum (p - q) ln(p / q) / 2`, each probability mass
    /// function mixed with the uniform one by weight `mix` (clamped to [1e-4, 1]) so that empty
    /// bins stay finite and equal distributions give exactly 0 whatever their sample counts.
    /// Histograms of different bins, or an empty one, give 0.
    pub fn symmetric_kl(&self, other: &Histogram, mix: f32) -> f32 {
        if self.bins != other.bins || self.total <= 0.0 || other.total <= 0.0 {
            return 0.0;
        }
        let mix = mix.clamp(1e-4, 1.0);
        let uniform = mix / self.bins as f32;
        let (kp, kq) = ((1.0 - mix) / self.total, (1.0 - mix) / other.total);
        self.counts
            .iter()
            .zip(&other.counts)
            .take(self.bins)
            .map(|(a, b)| {
                let (p, q) = (a * kp + uniform, b * kq + uniform);
                (p - q) * libm::logf(p / q)
            })
            .sum::<f32>()
            * 0.5
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn filled(values: &[f32]) -> Histogram {
        let mut h = Histogram::new(16, 0.0, 160.0);
        values.iter().for_each(|&v| h.add(v));
        h
    }

    #[test]
    fn soft_binning_keeps_the_mass() {
        let h = filled(&[-5.0, 0.0, 17.0, 80.0, 155.0, 300.0]);
        assert_eq!(h.total(), 6.0);
        let mass: f32 = h.counts.iter().sum();
        assert!((mass - 6.0).abs() < 1e-5);
        // 20 grey levels lies halfway between the centres of bins 1 and 2.
        let g = filled(&[20.0]);
        assert!((g.counts[1] - 0.5).abs() < 1e-5 && (g.counts[2] - 0.5).abs() < 1e-5);
    }

    #[test]
    fn divergence_is_symmetric_zero_for_equal_and_grows_with_separation() {
        let dark = filled(&[10.0, 12.0, 15.0, 11.0]);
        let near = filled(&[30.0, 32.0, 35.0, 31.0]);
        let far = filled(&[140.0, 150.0, 145.0, 148.0]);
        assert!(dark.symmetric_kl(&dark, 0.02).abs() < 1e-6);
        let (a, b) = (dark.symmetric_kl(&far, 0.02), far.symmetric_kl(&dark, 0.02));
        assert!((a - b).abs() < 1e-5 && a > 0.0);
        // Disjoint supports saturate at the smoothing floor; a mixture is less separated.
        let mixed = filled(&[10.0, 12.0, 145.0, 148.0]);
        assert!(dark.symmetric_kl(&mixed, 0.02) < a);
        assert!(dark.symmetric_kl(&near, 0.02) > 0.0);
        assert_eq!(dark.symmetric_kl(&Histogram::new(16, 0.0, 1.0), 0.02), 0.0);
    }
}
