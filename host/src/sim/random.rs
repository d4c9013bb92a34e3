//! Seeded, portable randomness: one PCG stream per purpose and index, derived from the scenario
//! seed, so a frame's noise does not depend on how many frames came before it or on threads.

use rand_pcg::Pcg64;
use rand_pcg::rand_core::Rng;

/// What a random stream is for. Each purpose gets an independent stream per index.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Purpose {
    /// Clip-wide draws: pointing and tracker error shapes, attitude phases.
    Clip = 1,
    /// The exhaust plume of one frame.
    Plume = 2,
    /// The sensor noise of one frame.
    Sensor = 3,
    /// The range sensor's noise of one frame.
    Range = 4,
    /// The tracker's white jitter of one frame.
    Tracker = 5,
    /// Lattice keys of the procedural noise fields (clouds, terrain).
    Field = 6,
    /// The clip-wide draws of a scenario's `[randomize]` ranges.
    Randomize = 7,
    /// The clip-wide layout of the clutter (filaments, second object).
    Clutter = 8,
    /// The per-frame jitter of the randomized physics (PSF, body contrast).
    FrameJitter = 9,
    /// The TETRIS trainer's draws (`imade train tetris`): clips, frames, perturbed poses.
    Training = 10,
}

/// The SplitMix64 finalizer: a bijective 64-bit mixing function.
pub fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A seeded generator with the few distributions the simulator needs, all computed here with
/// `libm` so that the same seed gives the same numbers on every machine.
pub struct Random {
    pcg: Pcg64,
    /// The second normal of the last Box-Muller pair, not yet used.
    spare: Option<f64>,
}

impl Random {
    /// The stream for `purpose` and `index` (a frame number, or 0 for clip-wide streams).
    pub fn new(seed: u64, purpose: Purpose, index: u64) -> Random {
        let a = mix64(seed ^ mix64(purpose as u64));
        let b = mix64(a ^ mix64(index.wrapping_add(0x5151)));
        let state = (u128::from(a) << 64) | u128::from(b);
        let stream = (u128::from(mix64(b)) << 64) | u128::from(mix64(a ^ b));
        Random {
            pcg: Pcg64::new(state, stream),
            spare: None,
        }
    }

    /// Uniform in [0, 1), 53 random bits.
    pub fn uniform(&mut self) -> f64 {
        (self.pcg.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// An index uniform in `0..n` (0 for `n` 0), from one [`Random::uniform`].
    pub fn index(&mut self, n: usize) -> usize {
        ((self.uniform() * n as f64) as usize).min(n.saturating_sub(1))
    }

    /// Uniform in [lo, hi).
    pub fn between(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }

    /// Standard normal (Box-Muller; each pair of uniforms gives two normals).
    pub fn gaussian(&mut self) -> f64 {
        if let Some(z) = self.spare.take() {
            return z;
        }
        let u1 = 1.0 - self.uniform(); // (0, 1]
        let u2 = self.uniform();
        let radius = libm::sqrt(-2.0 * libm::log(u1));
        let (s, c) = libm::sincos(2.0 * std::f64::consts::PI * u2);
        self.spare = Some(radius * s);
        radius * c
    }

    /// A Poisson count with the given mean (exact by multiplication below 30, the normal
    /// approximation above, where it is accurate to well under a count).
    pub fn poisson(&mut self, mean: f64) -> f64 {
        if mean <= 0.0 {
            return 0.0;
        }
        if mean < 30.0 {
            let limit = libm::exp(-mean);
            let mut product = self.uniform();
            let mut count = 0.0;
            while product > limit {
                product *= self.uniform();
                count += 1.0;
            }
            count
        } else {
            libm::round(mean + libm::sqrt(mean) * self.gaussian()).max(0.0)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let draw = |p, i| Random::new(7, p, i).uniform();
        assert_eq!(draw(Purpose::Sensor, 3), draw(Purpose::Sensor, 3));
        assert_ne!(draw(Purpose::Sensor, 3), draw(Purpose::Sensor, 4));
        assert_ne!(draw(Purpose::Sensor, 3), draw(Purpose::Plume, 3));
    }

    #[test]
    fn poisson_and_gaussian_have_their_moments() {
        let mut r = Random::new(1, Purpose::Sensor, 0);
        for mean in [0.5, 4.0, 200.0] {
            let n = 20000;
            let xs: Vec<f64> = (0..n).map(|_| r.poisson(mean)).collect();
            let m = xs.iter().sum::<f64>() / n as f64;
            let v = xs.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / n as f64;
            assert!((m - mean).abs() < 0.05 * mean + 0.03, "mean {m} for {mean}");
            assert!(
                (v - mean).abs() < 0.1 * mean + 0.05,
                "variance {v} for {mean}"
            );
        }
        let g: Vec<f64> = (0..20000).map(|_| r.gaussian()).collect();
        let m = g.iter().sum::<f64>() / g.len() as f64;
        let v = g.iter().map(|x| x * x).sum::<f64>() / g.len() as f64;
        assert!(m.abs() < 0.03 && (v - 1.0).abs() < 0.05, "{m} {v}");
    }
}
