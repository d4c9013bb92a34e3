//! From radiance to chip samples: the atmospheric and optical blur (a Gaussian PSF), the exposure,
//! Poisson shot noise, Gaussian read noise and quantization to 8 or 16 bits.

use super::clutter::NoiseModel;
use super::random::Random;
use super::scenario::SensorConfig;
use crate::clip::ChipPixels;

/// Half-width of the PSF kernel in sigmas.
const KERNEL_SIGMAS: f64 = 4.0;

/// Pixels the PSF reaches from its centre (the margin a window needs around the chip).
pub fn psf_reach(sigma: f64) -> usize {
    libm::ceil(KERNEL_SIGMAS * sigma) as usize
}

/// Blurs a row-major `width` x `height` image with a separable Gaussian of `sigma` px, keeping
/// only the interior `margin` pixels away from every edge (the margin must be at least
/// [`psf_reach`]). Returns the interior, row-major.
pub fn blur_interior(
    image: &[f64],
    width: usize,
    height: usize,
    sigma: f64,
    margin: usize,
) -> Vec<f64> {
    let (w, h) = (width - 2 * margin, height - 2 * margin);
    let reach = psf_reach(sigma).min(margin);
    let kernel: Vec<f64> = if sigma > 0.0 {
        let raw: Vec<f64> = (0..=2 * reach)
            .map(|i| {
                let d = i as f64 - reach as f64;
                libm::exp(-0.5 * d * d / (sigma * sigma))
            })
            .collect();
        let total: f64 = raw.iter().sum();
        raw.iter().map(|k| k / total).collect()
    } else {
        vec![1.0]
    };
    let r = (kernel.len() - 1) / 2;
    // Horizontal pass over the rows that the vertical pass needs.
    let mut rows = vec![0.0; w * height];
    for y in 0..height {
        for x in 0..w {
            let start = y * width + x + margin - r;
            rows[y * w + x] = kernel
                .iter()
                .zip(&image[start..start + kernel.len()])
                .map(|(k, v)| k * v)
                .sum();
        }
    }
    let mut out = vec![0.0; w * h];
    for y in 0..h {
        for x in 0..w {
            out[y * w + x] = kernel
                .iter()
                .enumerate()
                .map(|(i, k)| k * rows[(y + margin - r + i) * w + x])
                .sum();
        }
    }
    out
}

/// The camera's sensor for one clip.
#[derive(Debug, Clone, PartialEq)]
pub struct Sensor {
    /// Electrons per unit of radiance.
    electrons_per_radiance: f64,
    full_well: f64,
    read_noise: f64,
    bit_depth: u8,
}

impl Sensor {
    /// A sensor exposed so that radiance `reference` reads `cfg.sky_level` of full scale.
    pub fn new(cfg: &SensorConfig, reference: f64) -> Sensor {
        Sensor {
            electrons_per_radiance: cfg.sky_level * cfg.full_well_e / reference,
            full_well: cfg.full_well_e,
            read_noise: cfg.read_noise_e,
            bit_depth: cfg.bit_depth,
        }
    }

    /// The per-pixel noise of this sensor, in radiance units.
    pub fn noise_model(&self) -> NoiseModel {
        let max = if self.bit_depth == 16 { 65535.0 } else { 255.0 };
        NoiseModel {
            electrons_per_radiance: self.electrons_per_radiance,
            read_noise_e: self.read_noise,
            step_e: self.full_well / max,
        }
    }

    /// The noisy, quantized samples of a radiance image; `rng` is the frame's sensor stream.
    pub fn expose(&self, radiance: &[f64], rng: &mut Random) -> ChipPixels {
        let max = if self.bit_depth == 16 { 65535.0 } else { 255.0 };
        let mut digitize = |l: f64| {
            let mean = (l * self.electrons_per_radiance).max(0.0);
            let electrons = rng.poisson(mean) + self.read_noise * rng.gaussian();
            libm::round(electrons / self.full_well * max).clamp(0.0, max)
        };
        if self.bit_depth == 16 {
            ChipPixels::U16(radiance.iter().map(|&l| digitize(l) as u16).collect())
        } else {
            ChipPixels::U8(radiance.iter().map(|&l| digitize(l) as u8).collect())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::random::Purpose;

    #[test]
    fn blur_keeps_flux_and_spreads_a_point() {
        let (w, h, m) = (21, 21, 5);
        let mut img = vec![0.0; w * h];
        img[10 * w + 10] = 1.0;
        let out = blur_interior(&img, w, h, 1.0, m);
        assert_eq!(out.len(), 11 * 11);
        let total: f64 = out.iter().sum();
        assert!((total - 1.0).abs() < 1e-9);
        let centre = out[5 * 11 + 5];
        let neighbour = out[5 * 11 + 6];
        let expected_ratio = libm::exp(-0.5);
        assert!((neighbour / centre - expected_ratio).abs() < 1e-9);
        let sharp = blur_interior(&img, w, h, 0.0, m);
        assert_eq!(sharp[5 * 11 + 5], 1.0);
    }

    #[test]
    fn exposure_puts_the_reference_at_the_sky_level_with_shot_noise() {
        let cfg = SensorConfig::default();
        let sensor = Sensor::new(&cfg, 2.0);
        let mut rng = Random::new(1, Purpose::Sensor, 0);
        let ChipPixels::U8(px) = sensor.expose(&vec![2.0; 4096], &mut rng) else {
            panic!("8-bit expected");
        };
        let mean = px.iter().map(|&p| f64::from(p)).sum::<f64>() / px.len() as f64;
        let var = px
            .iter()
            .map(|&p| (f64::from(p) - mean).powi(2))
            .sum::<f64>()
            / px.len() as f64;
        assert!((mean - 0.7 * 255.0).abs() < 0.5, "{mean}");
        // Shot noise of 7000 e- plus 15 e- read noise, in 8-bit counts, plus quantization.
        let expected = (7000.0 + 225.0) / (10000.0f64 / 255.0).powi(2) + 1.0 / 12.0;
        assert!((var / expected - 1.0).abs() < 0.15, "{var} vs {expected}");
    }
}
