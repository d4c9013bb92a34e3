//! Deterministic procedural noise: lattice value noise and its fractal sums (fBm), for clouds and
//! terrain. Lattice values come from an integer hash of the cell and a key, never from a table
//! built at run time, so the field is the same on every machine and for every thread.

use super::random::mix64;

/// Fractal (multi-octave) value noise in two dimensions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fbm {
    /// Lattice key (from the scenario seed and the field's purpose).
    pub key: u64,
    /// Number of octaves.
    pub octaves: u32,
    /// Frequency ratio between successive octaves.
    pub lacunarity: f64,
    /// Amplitude ratio between successive octaves.
    pub gain: f64,
}

impl Fbm {
    /// The sum of the octaves at (x, y), in lattice units of the first octave, normalized to
    /// [0, 1] (values cluster around 0.5).
    pub fn at(&self, x: f64, y: f64) -> f64 {
        let (mut sum, mut norm, mut amp, mut freq) = (0.0, 0.0, 1.0, 1.0);
        for octave in 0..self.octaves {
            // Each octave gets its own lattice and an offset so octaves do not align at 0.
            let key = mix64(self.key ^ u64::from(octave));
            let shift = 0.37 * f64::from(octave);
            sum += amp * value2(key, x * freq + shift, y * freq - shift);
            norm += amp;
            amp *= self.gain;
            freq *= self.lacunarity;
        }
        sum / norm
    }

    /// One-dimensional fBm (a cut through the 2D field along y = 0).
    pub fn at1(&self, x: f64) -> f64 {
        self.at(x, 0.0)
    }
}

/// The largest integer not above `x` (|x| < 2^62), exactly, without a library call.
fn floor(x: f64) -> i64 {
    let t = x as i64;
    if t as f64 > x { t - 1 } else { t }
}

/// Quintic fade 6t^5 - 15t^4 + 10t^3: C2-smooth interpolation weight.
fn fade(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// The lattice value of cell (ix, iy) under `key`, in [0, 1).
fn lattice(key: u64, ix: i64, iy: i64) -> f64 {
    // Odd multipliers spread the cell over all 64 bits; one mixing round finishes the hash.
    let cell = (ix as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15)
        ^ (iy as u64)
            .wrapping_mul(0xc2b2_ae3d_27d4_eb4f)
            .rotate_left(31);
    let h = mix64(key ^ cell);
    (h >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// Value noise at (x, y): smooth interpolation of the lattice values, in [0, 1).
fn value2(key: u64, x: f64, y: f64) -> f64 {
    let (ix, iy) = (floor(x), floor(y));
    let (tx, ty) = (fade(x - ix as f64), fade(y - iy as f64));
    let a = lattice(key, ix, iy);
    let b = lattice(key, ix + 1, iy);
    let c = lattice(key, ix, iy + 1);
    let d = lattice(key, ix + 1, iy + 1);
    let top = a + (b - a) * tx;
    let bottom = c + (d - c) * tx;
    top + (bottom - top) * ty
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fbm_is_bounded_continuous_and_keyed() {
        let f = Fbm {
            key: 42,
            octaves: 6,
            lacunarity: 2.0,
            gain: 0.5,
        };
        let mut mean = 0.0;
        for i in 0..1000 {
            let x = f64::from(i) * 0.173 - 50.0;
            let v = f.at(x, 0.5 * x);
            assert!((0.0..1.0).contains(&v));
            assert!(
                (f.at(x + 1e-7, 0.5 * x) - v).abs() < 1e-4,
                "continuity at {x}"
            );
            mean += v / 1000.0;
        }
        assert!((mean - 0.5).abs() < 0.1, "mean {mean}");
        for x in [-2.5, -2.0, -0.0, 0.3, 7.0, 1e12 + 0.5] {
            assert_eq!(floor(x) as f64, libm::floor(x));
        }
        let g = Fbm { key: 43, ..f };
        assert_ne!(f.at(3.3, 4.4), g.at(3.3, 4.4));
    }
}
