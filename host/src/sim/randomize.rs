//! The `[randomize]` section: physics drawn per clip from stated ranges, deterministically from
//! the seed, so that no clip is tuned to one look; and the per-frame jitter of the PSF and of the
//! body's contrast.

use super::random::{Purpose, Random};
use super::scenario::{Polarity, Scenario, SecondObjectKind};

/// The scenario with its `[randomize]` ranges drawn: every randomized key replaced by its draw.
/// Without a `[randomize]` section it is the scenario itself. Each slot takes one uniform from the
/// clip's randomize stream whether or not its key is given, so the draws of one key do not depend
/// on which others are given.
pub fn resolve(scenario: &Scenario) -> Scenario {
    let mut s = scenario.clone();
    let r = scenario.randomize.clone();
    if r == Default::default() {
        return s;
    }
    let mut rng = Random::new(scenario.seed, Purpose::Randomize, 0);
    // One uniform per slot, in this fixed order.
    let mut slot = || rng.uniform();
    let within = |[lo, hi]: [f64; 2], u: f64| lo + (hi - lo) * u;
    let u = slot();
    if let Some(range) = r.contrast_sigma {
        s.projectile.contrast_sigma = Some(within(range, u));
    }
    let u = slot();
    if let Some(p) = r.bright_body_probability {
        s.projectile.polarity = if u < p {
            Polarity::Bright
        } else {
            Polarity::Dark
        };
    }
    let u = slot();
    if let Some(range) = r.psf_sigma_px {
        s.sensor.psf_sigma_px = within(range, u);
    }
    let u = slot();
    if let Some(range) = r.read_noise_e {
        s.sensor.read_noise_e = within(range, u);
    }
    let u = slot();
    if let Some(range) = r.sky_level {
        s.sensor.sky_level = within(range, u);
    }
    let u = slot();
    if let Some(range) = r.plume_brightness {
        s.plume.brightness = within(range, u);
    }
    let u = slot();
    if let Some(range) = r.plume_length_calibers {
        s.plume.length_calibers = within(range, u);
    }
    let u = slot();
    if let Some(range) = r.plume_width_calibers {
        s.plume.width_calibers = within(range, u);
    }
    let u = slot();
    if let Some(p) = r.dark_plume_probability {
        s.plume.polarity = if u < p {
            Polarity::Dark
        } else {
            Polarity::Bright
        };
    }
    let u = slot();
    if let Some([lo, hi]) = r.filament_count {
        let n = f64::from(hi - lo + 1);
        s.filaments.count = lo + ((u * n) as u32).min(hi - lo);
    }
    let u = slot();
    if let Some(p) = r.near_terrain_probability {
        s.near_terrain.enabled = u < p;
    }
    let u = slot();
    if let Some(range) = r.near_terrain_cover {
        s.near_terrain.cover = within(range, u);
    }
    let u = slot();
    if let Some(range) = r.visibility_m {
        s.scene.visibility_m = within(range, u);
    }
    let (u, kind) = (slot(), slot());
    if let Some(p) = r.second_object_probability {
        s.second_object.kind = if u >= p {
            SecondObjectKind::None
        } else if scenario.second_object.kind != SecondObjectKind::None {
            scenario.second_object.kind
        } else if kind < 0.5 {
            SecondObjectKind::Bird
        } else {
            SecondObjectKind::Projectile
        };
    }
    s
}

/// One frame's jitter of the randomized physics.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameJitter {
    /// The PSF sigma of this frame, px.
    pub psf_sigma_px: f64,
    /// The body's contrast of this frame, noise sigmas (when the scenario sets one).
    pub contrast_sigma: Option<f64>,
}

/// The PSF and body contrast of camera frame `frame` of a resolved scenario (its own values
/// unless `[randomize]` asks for per-frame jitter).
pub fn frame_jitter(resolved: &Scenario, frame: u64) -> FrameJitter {
    let r = &resolved.randomize;
    let mut jitter = FrameJitter {
        psf_sigma_px: resolved.sensor.psf_sigma_px,
        contrast_sigma: resolved.projectile.contrast_sigma,
    };
    if r.frame_psf_jitter_px.is_none() && r.frame_contrast_jitter.is_none() {
        return jitter;
    }
    let mut rng = Random::new(resolved.seed, Purpose::FrameJitter, frame);
    let (a, b) = (rng.between(-1.0, 1.0), rng.between(-1.0, 1.0));
    if let Some(j) = r.frame_psf_jitter_px {
        jitter.psf_sigma_px = (jitter.psf_sigma_px + j * a).clamp(0.0, 5.0);
    }
    if let (Some(j), Some(c)) = (r.frame_contrast_jitter, jitter.contrast_sigma) {
        jitter.contrast_sigma = Some(c * (1.0 + j * b));
    }
    jitter
}

/// One line on what was drawn, for the summary printed after writing a clip.
pub fn describe(resolved: &Scenario) -> String {
    let p = &resolved.projectile;
    let contrast = match p.contrast_sigma {
        Some(c) => format!("{c:.2} sigma {:?}", p.polarity).to_lowercase(),
        None => format!("albedo {:.2}", p.albedo),
    };
    let pl = &resolved.plume;
    let plume = if pl.enabled && pl.brightness > 0.0 {
        format!(
            "{:?} {:.2}, {:.1} x {:.2} cal",
            pl.polarity, pl.brightness, pl.length_calibers, pl.width_calibers
        )
        .to_lowercase()
    } else {
        "none".to_string()
    };
    let t = &resolved.near_terrain;
    let terrain = if t.enabled {
        format!("cover {:.2}", t.cover)
    } else {
        "none".to_string()
    };
    format!(
        "body {contrast}; psf {:.2} px; read noise {:.1} e-; sky level {:.2}; plume {plume}; \
         filaments {}; near terrain {terrain}; visibility {:.0} m; second object {:?}",
        resolved.sensor.psf_sigma_px,
        resolved.sensor.read_noise_e,
        resolved.sensor.sky_level,
        resolved.filaments.count,
        resolved.scene.visibility_m,
        resolved.second_object.kind
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::scenario::RandomizeConfig;

    #[test]
    fn draws_stay_in_their_ranges_and_follow_the_seed() {
        let mut s: Scenario = toml::from_str("seed = 3").unwrap();
        assert_eq!(resolve(&s), s, "no [randomize]: nothing drawn");
        s.randomize = RandomizeConfig {
            contrast_sigma: Some([3.0, 5.0]),
            psf_sigma_px: Some([0.5, 1.5]),
            filament_count: Some([2, 6]),
            frame_psf_jitter_px: Some(0.1),
            ..RandomizeConfig::default()
        };
        let mut psfs = Vec::new();
        for seed in 0..200 {
            s.seed = seed;
            let r = resolve(&s);
            let c = r.projectile.contrast_sigma.unwrap();
            assert!((3.0..5.0).contains(&c));
            assert!((0.5..1.5).contains(&r.sensor.psf_sigma_px));
            assert!((2..=6).contains(&r.filaments.count));
            assert_eq!(r, resolve(&s));
            let j = frame_jitter(&r, 40);
            assert!((j.psf_sigma_px - r.sensor.psf_sigma_px).abs() <= 0.1);
            psfs.push(r.sensor.psf_sigma_px);
        }
        let (lo, hi) = psfs
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), &p| (a.min(p), b.max(p)));
        assert!(lo < 0.6 && hi > 1.4, "the draws cover the range: {lo} {hi}");
    }
}
