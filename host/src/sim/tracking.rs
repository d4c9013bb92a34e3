//! The tracker: it points the mount at the projectile with a smooth pointing error (so the target
//! wanders off the principal point by up to a few hundred px), and cuts each chip around the
//! target with jitter (so the target is off the chip centre by up to tens of px).

use super::camera::{CameraPose, Intrinsics, azimuth_elevation};
use super::math::Vec3;
use super::random::{Purpose, Random};
use super::scenario::CameraConfig;

/// A smooth, bounded wander: a sum of sinusoids whose amplitudes add up to the bound.
#[derive(Debug, Clone, PartialEq)]
struct Wander {
    /// (amplitude, angular frequency rad/s, phase rad) per term.
    terms: Vec<(f64, f64, f64)>,
}

impl Wander {
    /// A wander bounded by `max`, whose slowest term has about `longest_period` s, and whose
    /// other terms are faster by the given ratios.
    fn new(max: f64, longest_period: f64, ratios: &[f64], rng: &mut Random) -> Wander {
        let tau = 2.0 * std::f64::consts::PI;
        let weights: Vec<f64> = ratios.iter().map(|_| rng.between(0.5, 1.0)).collect();
        let total: f64 = weights.iter().sum();
        let terms = ratios
            .iter()
            .zip(&weights)
            .map(|(ratio, w)| {
                let period = longest_period * ratio * rng.between(0.8, 1.2);
                (max * w / total, tau / period, rng.between(0.0, tau))
            })
            .collect();
        Wander { terms }
    }

    fn at(&self, t: f64) -> f64 {
        self.terms
            .iter()
            .map(|(a, w, p)| a * libm::sin(w * t + p))
            .sum()
    }
}

/// Share of the chip jitter that is smooth (the rest is white, frame to frame).
const SMOOTH_JITTER: f64 = 0.7;

/// The tracker of one clip.
#[derive(Debug, Clone, PartialEq)]
pub struct Tracker {
    position: Vec3,
    intrinsics: Intrinsics,
    chip: (u32, u32),
    pointing: [Wander; 2],
    jitter: [Wander; 2],
    white_jitter: f64,
    seed: u64,
}

impl Tracker {
    /// The tracker of a scenario; its error shapes come from `rng`, its per-frame white jitter
    /// from the `Tracker` stream of `seed`.
    pub fn new(cfg: &CameraConfig, intrinsics: Intrinsics, seed: u64, rng: &mut Random) -> Tracker {
        let pointing_ratios = [1.0, 0.45, 0.2];
        let jitter_ratios = [1.0, 0.4];
        let smooth = SMOOTH_JITTER * cfg.tracker_jitter_px;
        let mut wander = |max, period, ratios: &[f64]| Wander::new(max, period, ratios, rng);
        Tracker {
            position: Vec3::from_array(cfg.position_m),
            intrinsics,
            chip: (cfg.chip_width, cfg.chip_height),
            pointing: [
                wander(
                    cfg.pointing_error_px,
                    cfg.pointing_period_s,
                    &pointing_ratios,
                ),
                wander(
                    cfg.pointing_error_px,
                    cfg.pointing_period_s,
                    &pointing_ratios,
                ),
            ],
            jitter: [
                wander(smooth, 1.5, &jitter_ratios),
                wander(smooth, 1.5, &jitter_ratios),
            ],
            white_jitter: (1.0 - SMOOTH_JITTER) * cfg.tracker_jitter_px,
            seed,
        }
    }

    /// Where the mount points at time `t` (s) when the body origin is at `target` (W): at the
    /// target, off by the pointing error.
    pub fn camera(&self, target: Vec3, t: f64) -> CameraPose {
        let (az, el) = azimuth_elevation(target - self.position);
        let (ex, ey) = (self.pointing[0].at(t), self.pointing[1].at(t));
        // Pointing left of the target puts it right of centre, pointing above puts it below.
        let az_cam = az - ex / (self.intrinsics.fx * libm::cos(el).max(0.05));
        let el_cam = el + ey / self.intrinsics.fy;
        CameraPose::on_mount(self.position, az_cam, el_cam)
    }

    /// The full-frame top-left pixel of the chip of camera frame `frame` at time `t`, cut around
    /// the target seen at (u, v) with the tracker's jitter, and kept inside the frame.
    pub fn chip_origin(&self, (u, v): (f64, f64), t: f64, frame: u64) -> (i64, i64) {
        let mut rng = Random::new(self.seed, Purpose::Tracker, frame);
        let jx = self.jitter[0].at(t) + self.white_jitter * rng.between(-1.0, 1.0);
        let jy = self.jitter[1].at(t) + self.white_jitter * rng.between(-1.0, 1.0);
        let place = |centre: f64, chip: u32, full: u32| -> i64 {
            let x0 = libm::round(centre - 0.5 * (f64::from(chip) - 1.0)) as i64;
            x0.clamp(0, i64::from(full - chip))
        };
        (
            place(u + jx, self.chip.0, self.intrinsics.width),
            place(v + jy, self.chip.1, self.intrinsics.height),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wander_stays_within_its_bound_and_moves() {
        let mut rng = Random::new(9, Purpose::Clip, 0);
        let w = Wander::new(250.0, 7.0, &[1.0, 0.45, 0.2], &mut rng);
        let values: Vec<f64> = (0..2000).map(|i| w.at(f64::from(i) * 0.01)).collect();
        assert!(values.iter().all(|v| v.abs() <= 250.0));
        let spread = values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(spread > 50.0, "{spread}");
    }

    #[test]
    fn the_mount_puts_the_target_near_the_principal_point() {
        let cfg = CameraConfig::default();
        let k = Intrinsics {
            fx: cfg.fx,
            fy: cfg.fy,
            cx: cfg.cx,
            cy: cfg.cy,
            width: cfg.width,
            height: cfg.height,
        };
        let tracker = Tracker::new(&cfg, k, 5, &mut Random::new(5, Purpose::Clip, 0));
        let target = Vec3::new(0.0, 900.0, 400.0);
        for i in 0..50 {
            let t = f64::from(i) * 0.2;
            let cam = tracker.camera(target, t);
            let (u, v) = k.project(cam.to_camera(target)).unwrap();
            let (ex, ey) = (tracker.pointing[0].at(t), tracker.pointing[1].at(t));
            assert!((u - cfg.cx - ex).abs() < 0.5 && (v - cfg.cy - ey).abs() < 0.5);
            let (x0, y0) = tracker.chip_origin((u, v), t, i as u64);
            let dx = x0 as f64 + 127.5 - u;
            let dy = y0 as f64 + 127.5 - v;
            assert!(
                dx.abs() <= cfg.tracker_jitter_px + 0.5 && dy.abs() <= cfg.tracker_jitter_px + 0.5
            );
        }
    }
}
