//! The clutter of range footage that is not the projectile: thin dark cloud filaments and streaks,
//! a second object (a bird or another projectile) crossing the chip, and the per-pixel noise scale
//! that sets their contrast and the body's (`projectile.contrast_sigma`). The near hillside is
//! part of the background (`sky.rs`); this module holds its per-frame ridge line. Nothing here is
//! ever part of the mask.
//!
//! Filaments and the second object live in chip coordinates (px, origin at the chip's top-left
//! pixel centre): the tracker holds the chip on the target, so what is far behind it drifts slowly
//! across the chip.

use super::math::smoothstep;
use super::noise::Fbm;
use super::random::{Purpose, Random, mix64};
use super::scenario::{Scenario, SecondObjectKind};

/// The per-pixel noise of the sensor in radiance units, as a function of the radiance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseModel {
    /// Electrons per unit of radiance (the exposure).
    pub electrons_per_radiance: f64,
    /// Read noise, electrons rms.
    pub read_noise_e: f64,
    /// Electrons per quantization step.
    pub step_e: f64,
}

impl NoiseModel {
    /// Standard deviation of a pixel's sample at radiance `l` (shot, read and quantization
    /// noise), in radiance units.
    pub fn sigma(&self, l: f64) -> f64 {
        let e = (l * self.electrons_per_radiance).max(0.0);
        let var = e + self.read_noise_e * self.read_noise_e + self.step_e * self.step_e / 12.0;
        libm::sqrt(var) / self.electrons_per_radiance
    }
}

/// One filament: a bowed line with a Gaussian cross-section, tapered ends and a streaky core.
#[derive(Debug, Clone, PartialEq)]
pub struct Filament {
    /// Centre at the clip's first frame, chip px.
    pub centre: (f64, f64),
    /// Unit direction of its chord.
    pub direction: (f64, f64),
    /// Half its length, px.
    pub half_length: f64,
    /// Bow off the chord at its middle, px (signed).
    pub bow: f64,
    /// Gaussian sigma of the cross-section, px.
    pub width: f64,
    /// Depth at the core, noise sigmas.
    pub depth_sigma: f64,
    /// Drift, px per written frame.
    pub velocity: (f64, f64),
    /// Whether it is drawn in front of the body.
    pub in_front: bool,
    /// The streaks along its length.
    streak: Fbm,
}

impl Filament {
    /// Depth (noise sigmas) this filament adds at chip point (x, y) at written frame `index`.
    fn depth_at(&self, x: f64, y: f64, index: f64) -> f64 {
        let cx = self.centre.0 + self.velocity.0 * index;
        let cy = self.centre.1 + self.velocity.1 * index;
        let (dx, dy) = (x - cx, y - cy);
        let (ux, uy) = self.direction;
        let along = dx * ux + dy * uy;
        if along.abs() >= self.half_length {
            return 0.0;
        }
        let across = -dx * uy + dy * ux;
        let t = along / self.half_length;
        let off = across - self.bow * (1.0 - t * t);
        let reach = 4.0 * self.width;
        if off.abs() >= reach {
            return 0.0;
        }
        let profile = libm::exp(-0.5 * off * off / (self.width * self.width));
        let taper = smoothstep(1.0, 0.8, t.abs());
        let streak = (0.8 + 1.6 * (self.streak.at1(along / 18.0) - 0.5)).clamp(0.35, 1.0);
        self.depth_sigma * profile * taper * streak
    }
}

/// The second object's path and look.
#[derive(Debug, Clone, PartialEq)]
pub struct Mover {
    /// Bird or projectile.
    pub kind: SecondObjectKind,
    /// Where it is at written frame `index_mid`, chip px.
    pub mid: (f64, f64),
    /// The written frame at which it is at `mid`.
    pub index_mid: f64,
    /// Velocity, px per written frame.
    pub velocity: (f64, f64),
    /// Wingspan (bird) or width (projectile), px.
    pub size: f64,
    /// Length (projectile), px.
    pub length: f64,
    /// Signed contrast, noise sigmas (negative: darker than the background).
    pub contrast_sigma: f64,
    /// Phase of the wing beat, rad.
    flap_phase: f64,
}

impl Mover {
    /// Its centre at written frame `index`, chip px.
    pub fn centre(&self, index: f64) -> (f64, f64) {
        let dt = index - self.index_mid;
        (
            self.mid.0 + self.velocity.0 * dt,
            self.mid.1 + self.velocity.1 * dt,
        )
    }

    /// Fraction of chip pixel (x, y) it covers at written frame `index` (a one-pixel ramp).
    fn coverage(&self, x: f64, y: f64, index: f64) -> f64 {
        let (cx, cy) = self.centre(index);
        let speed = libm::hypot(self.velocity.0, self.velocity.1);
        let (ux, uy) = if speed > 0.0 {
            (self.velocity.0 / speed, self.velocity.1 / speed)
        } else {
            (1.0, 0.0)
        };
        let (dx, dy) = (x - cx, y - cy);
        let along = dx * ux + dy * uy;
        let across = -dx * uy + dy * ux;
        let distance = match self.kind {
            SecondObjectKind::None => return 0.0,
            SecondObjectKind::Bird => {
                // Wings across the flight line, beating about three times a second of frames.
                let beat = libm::sin(self.flap_phase + 1.9 * index).abs();
                let a = 0.18 * self.size + 0.5;
                let b = 0.5 * self.size * (0.55 + 0.45 * beat) + 0.5;
                let k = libm::sqrt((along / a) * (along / a) + (across / b) * (across / b));
                (k - 1.0) * a.min(b)
            }
            SecondObjectKind::Projectile => {
                let half = 0.5 * (self.length - self.size).max(0.0);
                let on_axis = along.clamp(-half, half);
                libm::hypot(along - on_axis, across) - 0.5 * self.size
            }
        };
        (0.5 - distance).clamp(0.0, 1.0)
    }
}

/// The clip-wide layout of the clutter, drawn from the seed.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ClutterLayout {
    /// The filaments.
    pub filaments: Vec<Filament>,
    /// The second object, if any.
    pub mover: Option<Mover>,
}

impl ClutterLayout {
    /// The layout of a resolved scenario (its `[randomize]` ranges already drawn).
    pub fn new(s: &Scenario) -> ClutterLayout {
        let (w, h) = (
            f64::from(s.camera.chip_width),
            f64::from(s.camera.chip_height),
        );
        let mut rng = Random::new(s.seed, Purpose::Clutter, 0);
        let f = &s.filaments;
        let filaments = (0..f.count)
            .map(|_| {
                let through = rng.uniform() < f.through_centre_fraction;
                let centre = if through {
                    (
                        0.5 * (w - 1.0) + rng.between(-0.08, 0.08) * w,
                        0.5 * (h - 1.0) + rng.between(-0.08, 0.08) * h,
                    )
                } else {
                    (rng.between(0.0, w - 1.0), rng.between(0.0, h - 1.0))
                };
                let angle = rng.between(0.0, std::f64::consts::PI);
                let (sin, cos) = libm::sincos(angle);
                let drift = f.drift_px_per_frame * libm::sqrt(rng.uniform());
                let (dsin, dcos) = libm::sincos(rng.between(0.0, 2.0 * std::f64::consts::PI));
                Filament {
                    centre,
                    direction: (cos, sin),
                    half_length: 0.5 * w * rng.between(f.length_chips[0], f.length_chips[1]),
                    bow: f.bow_px * rng.between(-1.0, 1.0),
                    width: rng.between(f.width_px[0], f.width_px[1]),
                    depth_sigma: rng.between(f.darkness_sigma[0], f.darkness_sigma[1]),
                    velocity: (drift * dcos, drift * dsin),
                    in_front: rng.uniform() < f.in_front_fraction,
                    streak: Fbm {
                        key: mix64((rng.uniform() * 9.007_199_254_740_992e15) as u64),
                        octaves: 4,
                        lacunarity: 2.0,
                        gain: 0.6,
                    },
                }
            })
            .collect();
        let o = &s.second_object;
        let mover = (o.kind != SecondObjectKind::None).then(|| {
            let frames = f64::from(s.clip.frames.max(1) - 1);
            let (sin, cos) = libm::sincos(rng.between(0.0, 2.0 * std::f64::consts::PI));
            Mover {
                kind: o.kind,
                mid: (rng.between(0.2, 0.8) * w, rng.between(0.2, 0.8) * h),
                index_mid: rng.between(0.3, 0.7) * frames,
                velocity: (o.speed_px_per_frame * cos, o.speed_px_per_frame * sin),
                size: o.size_px,
                length: o.length_px,
                contrast_sigma: o.polarity.sign() * o.contrast_sigma,
                flap_phase: rng.between(0.0, 2.0 * std::f64::consts::PI),
            }
        });
        ClutterLayout { filaments, mover }
    }

    /// Whether there is nothing to draw.
    pub fn is_empty(&self) -> bool {
        self.filaments.is_empty() && self.mover.is_none()
    }
}

/// The near hillside's ridge line in one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RidgeLine {
    /// Mean elevation of the ridge, rad.
    pub base_elevation: f64,
    /// Scale of its up-and-down, rad.
    pub relief: f64,
    /// Radians per pixel (1 / fx), for the scale of its shape and texture.
    pub rad_per_px: f64,
    /// Distance to the hillside, m.
    pub distance_m: f64,
}

/// Everything beyond the plain scene that one frame draws.
#[derive(Debug, Clone, Copy)]
pub struct FrameClutter<'a> {
    /// The clip's clutter layout.
    pub layout: &'a ClutterLayout,
    /// The written frame's index in the clip (0 for the first).
    pub index: f64,
    /// The sensor's noise, which sets the contrasts given in sigmas.
    pub noise: NoiseModel,
    /// The body's signed contrast, noise sigmas (negative: darker), when the scenario sets it.
    pub body_contrast_sigma: Option<f64>,
    /// The near hillside's ridge line, if there is one.
    pub ridge: Option<RidgeLine>,
}

impl FrameClutter<'_> {
    /// Darkens a row-major window of `width` pixels whose top-left pixel is full-frame (x0, y0)
    /// with the filaments in front of the body (`in_front`) or behind it, and (behind only) draws
    /// the second object; `chip_origin` is the chip's top-left full-frame pixel.
    pub fn draw(
        &self,
        image: &mut [f64],
        (x0, y0, width): (i64, i64, usize),
        chip_origin: (i64, i64),
        in_front: bool,
    ) {
        let filaments: Vec<&Filament> = self
            .layout
            .filaments
            .iter()
            .filter(|f| f.in_front == in_front)
            .collect();
        let mover = self.layout.mover.as_ref().filter(|_| !in_front);
        if filaments.is_empty() && mover.is_none() {
            return;
        }
        for (i, value) in image.iter_mut().enumerate() {
            let x = (x0 + (i % width) as i64 - chip_origin.0) as f64;
            let y = (y0 + (i / width) as i64 - chip_origin.1) as f64;
            let depth: f64 = filaments.iter().map(|f| f.depth_at(x, y, self.index)).sum();
            let mut l = *value;
            if depth > 0.0 {
                l = (l - depth * self.noise.sigma(l)).max(0.0);
            }
            if let Some(m) = mover {
                let c = m.coverage(x, y, self.index);
                if c > 0.0 {
                    l = (l + c * m.contrast_sigma * self.noise.sigma(l)).max(0.0);
                }
            }
            *value = l;
        }
    }

    /// The depth (noise sigmas) of all filaments at chip point (x, y): for tests and the docs.
    pub fn filament_depth(&self, x: f64, y: f64) -> f64 {
        self.layout
            .filaments
            .iter()
            .map(|f| f.depth_at(x, y, self.index))
            .sum()
    }

    /// The fraction of chip point (x, y) the second object covers.
    pub fn mover_coverage(&self, x: f64, y: f64) -> f64 {
        self.layout
            .mover
            .as_ref()
            .map_or(0.0, |m| m.coverage(x, y, self.index))
    }
}
