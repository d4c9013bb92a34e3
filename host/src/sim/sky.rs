//! The environment: the sun's position from the time of day, the sky's radiance, a procedural
//! cloud layer, hills on the horizon, haze, and the light falling on the body.
//!
//! Radiance is in relative units where the clear sky at the horizon, away from the sun, is about
//! 1; the sensor's exposure turns it into electrons. Directions are unit vectors in W (east,
//! north, up).

use super::clutter::RidgeLine;
use super::math::{Vec3, deg, lerp, rad, smoothstep};
use super::noise::Fbm;
use super::random::{Purpose, Random, mix64};
use super::scenario::{SceneConfig, Weather};

/// Zenith radiance of the clear sky relative to its horizon.
const ZENITH_RATIO: f64 = 0.55;
/// Direct sun irradiance over pi, outside clouds and before air mass, relative to sky radiance.
const SUN_STRENGTH: f64 = 4.0;
/// Extinction of sunlight per unit of air mass beyond one.
const SUN_EXTINCTION: f64 = 0.25;
/// Mean radiance of the upper hemisphere of sky, relative units.
const SKY_AMBIENT: f64 = 0.8;
/// Albedo of the ground (for the light it bounces up and for the terrain's own look).
const GROUND_ALBEDO: f64 = 0.15;
/// Fraction of sunlight a thick cloud blocks.
const CLOUD_SHADOW: f64 = 0.85;
/// Distance over which clouds fade into the sky towards the horizon, m.
const CLOUD_FADE_M: f64 = 40000.0;

/// Unit vector towards the sun in W for local solar time `hours`, latitude and day of year
/// (a textbook declination and hour-angle model, good to about a degree).
pub fn sun_direction(hours: f64, latitude_deg: f64, day_of_year: u32) -> Vec3 {
    let tau = 2.0 * std::f64::consts::PI;
    let declination = rad(-23.44) * libm::cos(tau / 365.0 * (f64::from(day_of_year) + 10.0));
    let hour_angle = rad(15.0 * (hours - 12.0));
    let phi = rad(latitude_deg);
    let (sd, cd) = (libm::sin(declination), libm::cos(declination));
    let (sp, cp) = (libm::sin(phi), libm::cos(phi));
    let sin_el = (sp * sd + cp * cd * libm::cos(hour_angle)).clamp(-1.0, 1.0);
    let el = libm::asin(sin_el);
    let az = libm::atan2(
        -cd * libm::sin(hour_angle),
        sd * cp - cd * sp * libm::cos(hour_angle),
    );
    Vec3::new(
        libm::sin(az) * libm::cos(el),
        libm::cos(az) * libm::cos(el),
        sin_el,
    )
}

/// A broken cloud layer: a thresholded fBm field on a horizontal plane, drifting with the wind.
#[derive(Debug, Clone, PartialEq)]
struct CloudLayer {
    altitude: f64,
    scale: f64,
    wind: [f64; 2],
    threshold: f64,
    density: Fbm,
    shading: Fbm,
}

impl CloudLayer {
    /// Cloud opacity (0..1) and the cloud's own radiance where the ray from `origin` along `d`
    /// meets the layer at time `t`; `None` where it does not meet it.
    fn along(&self, origin: Vec3, d: Vec3, t: f64, sky: f64) -> Option<(f64, f64)> {
        if d.z <= 1e-4 || origin.z >= self.altitude {
            return None;
        }
        let distance = (self.altitude - origin.z) / d.z;
        let x = (origin.x + d.x * distance - self.wind[0] * t) / self.scale;
        let y = (origin.y + d.y * distance - self.wind[1] * t) / self.scale;
        let f = self.density.at(x, y);
        let alpha = smoothstep(self.threshold - 0.05, self.threshold + 0.05, f)
            * libm::exp(-distance / CLOUD_FADE_M);
        if alpha <= 0.0 {
            return Some((0.0, sky));
        }
        // Bright, textured edges; thicker, greyer cores.
        let thickness = smoothstep(self.threshold, self.threshold + 0.25, f);
        let texture = self.shading.at(4.0 * x + 11.0, 4.0 * y - 7.0) - 0.5;
        let radiance = sky * (1.3 + 1.6 * texture) * (1.0 - 0.35 * thickness);
        Some((alpha, radiance))
    }
}

/// The scene around the projectile for one clip.
#[derive(Debug, Clone, PartialEq)]
pub struct Environment {
    sun: Vec3,
    sun_irradiance: f64,
    clouds: Option<CloudLayer>,
    hills: Fbm,
    ground: Fbm,
    hills_max: f64,
    terrain_distance: f64,
    visibility: f64,
    near_ridge: Fbm,
    near_ground: Fbm,
}

/// Light falling on the body at one place and time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Illumination {
    /// Unit vector towards the sun, W.
    pub sun_direction: Vec3,
    /// Direct sun irradiance over pi (after air mass and cloud shadow), relative units.
    pub sun: f64,
    /// Sky light reaching an upward-facing surface, over pi.
    pub sky: f64,
    /// Light bounced by the ground onto a downward-facing surface, over pi.
    pub ground: f64,
}

impl Illumination {
    /// Radiance of a Lambertian surface with unit normal `n` (W) and `albedo`.
    pub fn radiance(&self, n: Vec3, albedo: f64) -> f64 {
        let up = 0.5 * (1.0 + n.z);
        albedo
            * (self.sun * n.dot(self.sun_direction).max(0.0)
                + self.sky * up
                + self.ground * (1.0 - up))
    }
}

impl Environment {
    /// The environment of a scenario (its cloud and terrain fields keyed by `seed`).
    pub fn new(cfg: &SceneConfig, seed: u64) -> anyhow::Result<Environment> {
        let sun = sun_direction(cfg.time_of_day_h()?, cfg.latitude_deg, cfg.day_of_year);
        let mut keys = Random::new(seed, Purpose::Field, 0);
        let mut key = || mix64((keys.uniform() * 9.007_199_254_740_992e15) as u64);
        let fbm = |key: u64, octaves: u32, gain: f64| Fbm {
            key,
            octaves,
            lacunarity: 2.0,
            gain,
        };
        let clouds =
            (cfg.weather == Weather::Cloudy && cfg.cloud_cover > 0.0).then(|| CloudLayer {
                altitude: cfg.cloud_altitude_m,
                scale: cfg.cloud_scale_m,
                wind: cfg.wind_m_s,
                threshold: 0.5 + 0.4 * (0.5 - cfg.cloud_cover),
                density: fbm(key(), 11, 0.6),
                shading: fbm(key(), 10, 0.8),
            });
        Ok(Environment {
            sun,
            sun_irradiance: SUN_STRENGTH * air_mass_transmission(sun.z),
            clouds,
            hills: fbm(key(), 10, 0.55),
            ground: fbm(key(), 8, 0.55),
            hills_max: rad(cfg.terrain_max_elevation_deg),
            terrain_distance: cfg.terrain_distance_m,
            visibility: cfg.visibility_m,
            near_ridge: fbm(key(), 7, 0.5),
            near_ground: fbm(key(), 7, 0.6),
        })
    }

    /// Sun elevation, deg.
    pub fn sun_elevation_deg(&self) -> f64 {
        deg(libm::asin(self.sun.z))
    }

    /// Radiance of the cloudless sky along `d` (the horizon's for rays below it).
    pub fn clear_sky(&self, d: Vec3) -> f64 {
        let sin_el = d.z.max(0.0);
        let h = 1.0 - sin_el;
        let gradient = ZENITH_RATIO + (1.0 - ZENITH_RATIO) * h * h * h;
        let cos_gamma = d.dot(self.sun).clamp(-1.0, 1.0);
        let gamma = libm::acos(cos_gamma);
        let sunward = 1.0 + 0.15 * cos_gamma + 0.8 * libm::exp(-gamma / 0.3);
        gradient * sunward
    }

    /// Fraction of an object's contrast left by the haze over `distance` m.
    pub fn transmission(&self, distance: f64) -> f64 {
        libm::exp(-distance / self.visibility)
    }

    /// Radiance of the background (sky, clouds or terrain) seen from `origin` along the unit
    /// direction `d` at time `t` (s).
    pub fn background(&self, origin: Vec3, d: Vec3, t: f64) -> f64 {
        let sky = self.clear_sky(d);
        let (az, el) = (libm::atan2(d.x, d.y), libm::asin(d.z.clamp(-1.0, 1.0)));
        if el < self.hills_max || el < 0.0 {
            let ridge = self.hills_max * self.hills.at1(az * 40.0 / (2.0 * std::f64::consts::PI));
            if el < ridge {
                return self.terrain(az, el, origin.z, sky);
            }
        }
        match self
            .clouds
            .as_ref()
            .and_then(|c| c.along(origin, d, t, sky))
        {
            Some((alpha, cloud)) => lerp(sky, cloud, alpha),
            None => sky,
        }
    }

    /// Hazy, textured ground below the ridge line.
    fn terrain(&self, az: f64, el: f64, height: f64, horizon_sky: f64) -> f64 {
        let distance = if el < 0.0 {
            (height.max(1.0) / libm::sin(-el)).min(self.terrain_distance)
        } else {
            self.terrain_distance
        };
        // Texture on an angular grid of about 1 mrad, so it shows at telescope scale.
        let texture = self.ground.at(az * 1000.0, el * 1000.0) - 0.5;
        let lit = GROUND_ALBEDO * (self.sun_irradiance * self.sun.z.max(0.0) + SKY_AMBIENT);
        let ground = lit * (1.0 + 1.2 * texture);
        lerp(horizon_sky, ground, self.transmission(distance))
    }

    /// Radiance of the near hillside along the unit direction `d` (W) where it lies below this
    /// frame's `ridge` line; `None` above the ridge. Its shape and texture are fixed in azimuth
    /// and elevation (ridge features about 80 px wide, texture down to a few px), seen through
    /// the haze of `ridge.distance_m`.
    pub fn near_terrain(&self, d: Vec3, ridge: &RidgeLine) -> Option<f64> {
        let (az, el) = (libm::atan2(d.x, d.y), libm::asin(d.z.clamp(-1.0, 1.0)));
        let scale = ridge.rad_per_px;
        let line = ridge.base_elevation
            + ridge.relief * 5.0 * (self.near_ridge.at1(az / (80.0 * scale)) - 0.5);
        if el >= line {
            return None;
        }
        // A darker band of trees or rock along the crest, then textured slopes.
        let below = (line - el) / scale;
        let crest = 1.0 - 0.35 * libm::exp(-below / 6.0);
        let texture = self
            .near_ground
            .at(az / (30.0 * scale), el / (30.0 * scale))
            - 0.5;
        let lit = GROUND_ALBEDO * (self.sun_irradiance * self.sun.z.max(0.0) + SKY_AMBIENT);
        let ground = lit * crest * (1.0 + 1.6 * texture).max(0.05);
        Some(lerp(
            self.clear_sky(d),
            ground,
            self.transmission(ridge.distance_m),
        ))
    }

    /// The light on a body at `point` (W) at time `t`: the sun is dimmed by any cloud between.
    pub fn illumination(&self, point: Vec3, t: f64) -> Illumination {
        let shade = self
            .clouds
            .as_ref()
            .and_then(|c| c.along(point, self.sun, t, 1.0))
            .map_or(0.0, |(alpha, _)| alpha);
        let sun = self.sun_irradiance * (1.0 - CLOUD_SHADOW * shade);
        Illumination {
            sun_direction: self.sun,
            sun,
            sky: SKY_AMBIENT,
            ground: GROUND_ALBEDO * (sun * self.sun.z.max(0.0) + SKY_AMBIENT),
        }
    }
}

/// Transmission of the atmosphere for the sun at `sin_el` (Kasten-Young air mass); 0 below the
/// horizon.
fn air_mass_transmission(sin_el: f64) -> f64 {
    if sin_el <= 0.0 {
        return 0.0;
    }
    let el_deg = deg(libm::asin(sin_el));
    let air_mass = 1.0 / (sin_el + 0.50572 * libm::pow(el_deg + 6.07995, -1.6364));
    libm::exp(-SUN_EXTINCTION * (air_mass - 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sun_is_south_at_noon_and_west_in_the_evening() {
        let noon = sun_direction(12.0, 35.0, 80);
        assert!(noon.x.abs() < 1e-3 && noon.y < 0.0);
        assert!((deg(libm::asin(noon.z)) - 55.0).abs() < 1.5);
        let evening = sun_direction(17.25, 35.0, 172);
        let el = deg(libm::asin(evening.z));
        assert!(evening.x < 0.0 && (15.0..30.0).contains(&el), "{evening:?}");
    }

    #[test]
    fn sky_is_brighter_at_the_horizon_and_terrain_is_below_it() {
        let cfg = SceneConfig {
            weather: Weather::Clear,
            ..SceneConfig::default()
        };
        let env = Environment::new(&cfg, 1).unwrap();
        let away = Vec3::new(1.0, 0.0, 0.0); // east, the sun is in the west
        let up = Vec3::new(1.0, 0.0, 3.0).normalized();
        assert!(env.clear_sky(away) > env.clear_sky(up));
        let origin = Vec3::new(0.0, 0.0, 2.0);
        let down = Vec3::new(1.0, 0.0, -0.05).normalized();
        assert_ne!(env.background(origin, down, 0.0), env.clear_sky(down));
        assert_eq!(env.background(origin, up, 0.0), env.clear_sky(up));
    }

    #[test]
    fn body_light_is_brighter_on_the_sunward_side() {
        let env = Environment::new(&SceneConfig::default(), 1).unwrap();
        let light = env.illumination(Vec3::new(0.0, 500.0, 300.0), 0.0);
        let sunward = light.radiance(light.sun_direction, 0.1);
        let away = light.radiance(-light.sun_direction, 0.1);
        assert!(sunward > away && away > 0.0);
    }
}
