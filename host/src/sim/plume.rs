//! The exhaust plume: a flickering train of glowing Gaussian puffs behind the base, along -x_B
//! (attached at the tail: the first puff sits within a tenth of the plume's length of the base).
//! It adds light, or with a dark polarity absorbs it like smoke (never part of the mask).
//!
//! By default each puff is a whole 3-D Gaussian, so its glow reaches ahead of the base plane,
//! partly over the tail (a halo): the body hides a puff only where its surface is nearer than the
//! puff's front. With `glow_ahead_of_base = false` the gas glows only behind the base plane: along
//! each camera ray an isotropic Gaussian puff is a 1-D Gaussian in the distance `s` (centred at
//! the ray's closest approach to the puff, of the puff's sigma), so the light the ray collects
//! over the stretch behind the base plane and in front of the body's surface is the whole line
//! integral times a difference of two normal integrals (erf).

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
    /// The base plane, x_B m: where the gas glows only behind it, None for a whole Gaussian.
    pub base_x: Option<f64>,
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
                base_x: (!cfg.glow_ahead_of_base).then_some(model.tail_x),
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
        // Where the gas glows only behind the base plane: the axis and the plane's offset in C.
        let plane = puff.base_x.map(|base_x| {
            let axis = body.rotation.col(0);
            (axis, base_x + axis.dot(body.translation))
        });
        for y in ys {
            let wy = pixel_weight(y as f64 - v, sy);
            for (x, w) in xs.clone().zip(&wx) {
                let depths = samples
                    .window_pixel(x, y)
                    .map(|(px, py)| samples.pixel_samples(px, py).map(|(_, z)| z));
                let visible = match (plane, depths) {
                    (Some((axis, offset)), depths) => {
                        let ray = k.ray(x as f64, y as f64);
                        behind_base_fraction(c, puff.sigma, ray, axis, offset, depths)
                    }
                    (None, Some(depths)) => {
                        let hidden = depths.filter(|z| *z < front).count();
                        1.0 - hidden as f64 / samples.samples_per_pixel() as f64
                    }
                    (None, None) => 1.0,
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

/// The share of a puff's light (centre `c` in C, m; Gaussian `sigma`, m) that the camera ray
/// `ray` (z = 1) collects behind the base plane `axis . p <= offset` (C) and in front of the
/// body, averaged over the pixel's samples of camera depth `depths` (infinite where a sample
/// misses the body; None outside the rasterized window: no body).
fn behind_base_fraction(
    c: Vec3,
    sigma: f64,
    ray: Vec3,
    axis: Vec3,
    offset: f64,
    depths: Option<impl Iterator<Item = f64>>,
) -> f64 {
    let length = ray.norm();
    let d = ray * (1.0 / length);
    // The unit normal integral up to distance s along the ray.
    let centre = c.dot(d);
    let below = |s: f64| 0.5 * (1.0 + libm::erf((s - centre) / (std::f64::consts::SQRT_2 * sigma)));
    // The gas side of the plane along the ray: s (axis . d) <= offset.
    let slope = axis.dot(d);
    let (gas_from, gas_to) = if slope > 0.0 {
        (f64::NEG_INFINITY, offset / slope)
    } else if slope < 0.0 {
        (offset / slope, f64::INFINITY)
    } else if offset >= 0.0 {
        (f64::NEG_INFINITY, f64::INFINITY)
    } else {
        return 0.0;
    };
    let share = |body: f64| {
        let to = gas_to.min(body);
        if to > gas_from {
            below(to) - below(gas_from)
        } else {
            0.0
        }
    };
    match depths {
        Some(depths) => {
            let (sum, count) = depths.fold((0.0, 0usize), |(sum, count), z| {
                (sum + share(z * length), count + 1)
            });
            if count > 0 {
                sum / count as f64
            } else {
                share(f64::INFINITY)
            }
        }
        None => share(f64::INFINITY),
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

    /// The base-plane cut by hand, the camera looking along +Z at a puff 1 km away whose sigma
    /// is 0.1 m. Side-on (the axis along +X, the base plane at x = 0, gas at x <= 0): a ray ahead
    /// of the plane collects nothing, one behind it all the puff's light, one that meets the body
    /// 0.1 m in front of the puff's centre Phi(-1) of it. End-on (the axis along +Z, the base
    /// facing the camera at z = 1000 m, the puff 0.2 m in front of it): the ray that meets the
    /// base collects Phi(2) of it, the glow in front of the base.
    #[test]
    fn the_gas_glows_only_behind_the_base_plane() {
        let x = Vec3::new(1.0, 0.0, 0.0);
        let c = Vec3::new(-0.2, 0.0, 1000.0);
        let ray = |u: f64| Vec3::new(u / 1000.0, 0.0, 1.0);
        let none: Option<std::iter::Empty<f64>> = None;
        assert!(behind_base_fraction(c, 0.1, ray(0.05), x, 0.0, none.clone()) < 1e-12);
        let behind = behind_base_fraction(c, 0.1, ray(-0.3), x, 0.0, none.clone());
        assert!((behind - 1.0).abs() < 1e-9, "{behind}");
        let hidden = behind_base_fraction(c, 0.1, ray(-0.3), x, 0.0, Some([999.9].into_iter()));
        assert!((hidden - 0.158_655).abs() < 1e-3, "{hidden}");
        let z = Vec3::new(0.0, 0.0, 1.0);
        let front = Vec3::new(0.0, 0.0, 999.8);
        let end_on =
            behind_base_fraction(front, 0.1, ray(0.0), z, 1000.0, Some([1000.0].into_iter()));
        assert!((end_on - 0.977_25).abs() < 1e-3, "{end_on}");
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
