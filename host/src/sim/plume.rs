//! The exhaust plume: a flickering train of glowing Gaussian puffs behind the base, along -x_B
//! (attached at the tail: the first puff sits within a tenth of the plume's length of the base).
//! It adds light, or with a dark polarity absorbs it like smoke (never part of the mask), partly
//! over the tail: the body hides a puff only where its surface is nearer than the puff's front.

use super::camera::Intrinsics;
use super::math::Vec3;
use super::model::ProjectileModel;
use super::pose::BodyPose;
use super::random::Random;
use super::raster::SampleBuffer;
use super::scenario::{PlumeConfig, Polarity};

/// Number of puffs in the plume.
const PUFFS: usize = 10;

/// One glowing puff.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Puff {
    /// Centre in body frame B, m.
    pub centre: Vec3,
    /// Gaussian radius, m.
    pub sigma: f64,
    /// Peak radiance added at the puff's centre, relative units (optical depth when `dark`).
    pub peak: f64,
    /// Whether the puff is dark smoke that absorbs rather than glowing exhaust.
    pub dark: bool,
}

/// The puffs of one frame (empty without a plume); `rng` is that frame's plume stream.
pub fn puffs(cfg: &PlumeConfig, model: &ProjectileModel, rng: &mut Random) -> Vec<Puff> {
    if !cfg.enabled || cfg.brightness == 0.0 {
        return Vec::new();
    }
    let caliber = 2.0 * model.body_radius;
    let length = cfg.length_calibers * caliber;
    let nozzle = cfg.width_calibers * caliber;
    let flicker = libm::exp(cfg.flicker * rng.gaussian() - 0.5 * cfg.flicker * cfg.flicker);
    (0..PUFFS)
        .map(|k| {
            let along = length * (k as f64 + rng.between(0.2, 0.8)) / PUFFS as f64;
            let f = along / length;
            let sigma = nozzle * (1.0 + 1.5 * f) * rng.between(0.8, 1.2);
            let wobble = 0.3 * sigma;
            Puff {
                centre: Vec3::new(
                    model.tail_x - along,
                    wobble * rng.between(-1.0, 1.0),
                    wobble * rng.between(-1.0, 1.0),
                ),
                sigma,
                peak: cfg.brightness * flicker * libm::exp(-2.5 * f) * rng.between(0.7, 1.3),
                dark: cfg.polarity == Polarity::Dark,
            }
        })
        .collect()
}

/// Adds the plume's light to `image`, a row-major window of `width` pixels whose top-left pixel is
/// full-frame (x0, y0). `samples` holds the body's depth; `transmission` is the haze's.
pub fn add_plume(
    image: &mut [f64],
    (x0, y0, width): (i64, i64, usize),
    puffs: &[Puff],
    body: &BodyPose,
    k: &Intrinsics,
    samples: &SampleBuffer,
    transmission: f64,
) {
    let height = image.len() / width;
    for puff in puffs {
        let c = body.to_camera(puff.centre);
        let Some((u, v)) = k.project(c) else { continue };
        let (sx, sy) = (k.fx * puff.sigma / c.z, k.fy * puff.sigma / c.z);
        let front = c.z - puff.sigma;
        // Pixel-integrated Gaussian, separable: weights per column and per row.
        let reach_x = libm::ceil(4.0 * sx + 1.0) as i64;
        let reach_y = libm::ceil(4.0 * sy + 1.0) as i64;
        let (cu, cv) = (libm::round(u) as i64, libm::round(v) as i64);
        let xs = (cu - reach_x).max(x0)..=(cu + reach_x).min(x0 + width as i64 - 1);
        let ys = (cv - reach_y).max(y0)..=(cv + reach_y).min(y0 + height as i64 - 1);
        let wx: Vec<f64> = xs.clone().map(|x| pixel_weight(x as f64 - u, sx)).collect();
        let norm = puff.peak * transmission * 2.0 * std::f64::consts::PI * sx * sy;
        let depth_norm = puff.peak * 2.0 * std::f64::consts::PI * sx * sy;
        for y in ys {
            let wy = pixel_weight(y as f64 - v, sy);
            for (x, w) in xs.clone().zip(&wx) {
                let visible = match samples.window_pixel(x, y) {
                    Some((px, py)) => {
                        let hidden = samples
                            .pixel_samples(px, py)
                            .filter(|(_, z)| *z < front)
                            .count();
                        1.0 - hidden as f64 / samples.samples_per_pixel() as f64
                    }
                    None => 1.0,
                };
                let index = (y - y0) as usize * width + (x - x0) as usize;
                if puff.dark {
                    // Smoke: the optical depth at this pixel, and what the haze leaves of it.
                    let depth = depth_norm * w * wy * visible;
                    image[index] *= 1.0 - transmission * (1.0 - libm::exp(-depth));
                } else {
                    image[index] += norm * w * wy * visible;
                }
            }
        }
    }
}

/// Integral of the unit Gaussian density of `sigma` over the pixel [d - 0.5, d + 0.5].
fn pixel_weight(d: f64, sigma: f64) -> f64 {
    let s = std::f64::consts::SQRT_2 * sigma;
    0.5 * (libm::erf((d + 0.5) / s) - libm::erf((d - 0.5) / s))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::random::Purpose;
    use crate::sim::scenario::ProjectileConfig;

    #[test]
    fn puffs_trail_behind_the_base_and_flicker() {
        let model = ProjectileModel::from_config(&ProjectileConfig::default()).unwrap();
        let cfg = PlumeConfig::default();
        let a = puffs(&cfg, &model, &mut Random::new(1, Purpose::Plume, 10));
        let b = puffs(&cfg, &model, &mut Random::new(1, Purpose::Plume, 11));
        assert_eq!(a.len(), PUFFS);
        assert!(a.iter().all(|p| p.centre.x < model.tail_x && p.peak > 0.0));
        assert_ne!(a[0].peak, b[0].peak);
        let off = PlumeConfig {
            enabled: false,
            ..cfg
        };
        assert!(puffs(&off, &model, &mut Random::new(1, Purpose::Plume, 10)).is_empty());
    }

    #[test]
    fn pixel_weights_sum_to_one() {
        for sigma in [0.3, 1.0, 4.0] {
            let total: f64 = (-30..=30)
                .map(|d| pixel_weight(f64::from(d) + 0.2, sigma))
                .sum();
            assert!((total - 1.0).abs() < 1e-9, "{sigma}: {total}");
        }
    }
}
