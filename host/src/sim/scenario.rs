//! Scenario files: every knob of a simulated clip, as TOML (serde). Every section and field has a
//! default, so a file names only what it changes. docs/simulator.md is the reference.

use anyhow::{Context, bail, ensure};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// A whole simulated clip: scene, camera, projectile, sensor and the seed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Seed of every random draw (pointing, tracker, attitude phases, plume, clouds, noise).
    pub seed: u64,
    /// Free text.
    #[serde(default)]
    pub description: String,
    /// Frames and timing.
    #[serde(default)]
    pub clip: ClipConfig,
    /// Which 3D model flies, and its paint.
    #[serde(default)]
    pub projectile: ProjectileConfig,
    /// Launcher, target and ballistics.
    #[serde(default)]
    pub trajectory: TrajectoryConfig,
    /// Coning, angle of attack and roll.
    #[serde(default)]
    pub attitude: AttitudeConfig,
    /// Camera placement, intrinsics and tracking.
    #[serde(default)]
    pub camera: CameraConfig,
    /// Sun, sky, clouds, haze and terrain.
    #[serde(default)]
    pub scene: SceneConfig,
    /// The exhaust plume.
    #[serde(default)]
    pub plume: PlumeConfig,
    /// Optics, noise, quantization and the range sensor.
    #[serde(default)]
    pub sensor: SensorConfig,
}

/// Frames and timing.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ClipConfig {
    /// Number of frames written.
    pub frames: u32,
    /// The camera's frame rate, Hz.
    pub frame_rate_hz: f64,
    /// Keep every n-th camera frame (1 keeps all).
    pub keep_every: u32,
    /// Time of the first written frame after launch, s.
    pub start_time_s: f64,
}

impl Default for ClipConfig {
    fn default() -> Self {
        ClipConfig {
            frames: 175,
            frame_rate_hz: 30.0,
            keep_every: 2,
            start_time_s: 1.0,
        }
    }
}

/// The model that flies: a built-in one by id, or a mesh file in body frame B.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ProjectileConfig {
    /// Id of a built-in model (`ref-1378x80`); ignored when `mesh` is given.
    pub model: String,
    /// A Wavefront OBJ or STL mesh in body frame B (+x towards the nose, origin at the middle of
    /// the length); a relative path is taken from the scenario file's folder.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mesh: Option<PathBuf>,
    /// Metres per mesh unit (0.001 for a mesh in millimetres).
    pub mesh_scale: f64,
    /// Lambertian albedo of the paint, 0..1.
    pub albedo: f64,
}

impl Default for ProjectileConfig {
    fn default() -> Self {
        ProjectileConfig {
            model: super::model::REFERENCE_ID.to_string(),
            mesh: None,
            mesh_scale: 1.0,
            albedo: 0.12,
        }
    }
}

/// Launcher, target and ballistics. World frame W: x east, y north, z up, m.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrajectoryConfig {
    /// Launcher position (the body origin at t = 0), m.
    pub launcher_m: [f64; 3],
    /// Target position, m; the muzzle speed is chosen so the trajectory passes through it.
    pub target_m: [f64; 3],
    /// Launch elevation, deg.
    pub launch_angle_deg: f64,
    /// Gravity, m/s^2.
    pub gravity_m_s2: f64,
    /// Quadratic drag coefficient k in a = -k |v| v, 1/m (0 = vacuum; rho Cd A / 2m).
    pub drag_per_m: f64,
}

impl Default for TrajectoryConfig {
    fn default() -> Self {
        TrajectoryConfig {
            launcher_m: [0.0, 0.0, 0.0],
            target_m: [0.0, 3000.0, 0.0],
            launch_angle_deg: 40.0,
            gravity_m_s2: 9.81,
            drag_per_m: 0.0,
        }
    }
}

/// The nose's motion about the velocity vector, and the roll.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AttitudeConfig {
    /// Mean angle between the nose and the velocity (coning half-angle), deg.
    pub angle_of_attack_deg: f64,
    /// Amplitude of the angle of attack's oscillation about its mean (nutation), deg.
    pub nutation_deg: f64,
    /// Period of one coning revolution of the nose about the velocity, s.
    pub coning_period_s: f64,
    /// Period of the nutation, s.
    pub nutation_period_s: f64,
    /// Roll rate about the body axis, deg/s.
    pub roll_rate_deg_s: f64,
    /// Roll at launch, deg (random when absent).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub initial_roll_deg: Option<f64>,
}

impl Default for AttitudeConfig {
    fn default() -> Self {
        AttitudeConfig {
            angle_of_attack_deg: 2.0,
            nutation_deg: 1.0,
            coning_period_s: 1.6,
            nutation_period_s: 0.45,
            roll_rate_deg_s: 45.0,
            initial_roll_deg: None,
        }
    }
}

/// Camera placement, intrinsics, and the tracker that points it and cuts the chips.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CameraConfig {
    /// Optical centre in W, m.
    pub position_m: [f64; 3],
    /// Focal length along x, px.
    pub fx: f64,
    /// Focal length along y, px.
    pub fy: f64,
    /// Principal point x, px.
    pub cx: f64,
    /// Principal point y, px.
    pub cy: f64,
    /// Full-frame width, px.
    pub width: u32,
    /// Full-frame height, px.
    pub height: u32,
    /// Chip width, px.
    pub chip_width: u32,
    /// Chip height, px.
    pub chip_height: u32,
    /// Largest offset of the target from the principal point caused by the mount's smooth
    /// pointing error, px.
    pub pointing_error_px: f64,
    /// Longest period of the pointing error's wander, s.
    pub pointing_period_s: f64,
    /// Largest offset of the chip centre from the projected body origin (tracker jitter), px.
    pub tracker_jitter_px: f64,
}

impl Default for CameraConfig {
    fn default() -> Self {
        CameraConfig {
            position_m: [-1000.0, 600.0, 2.0],
            fx: 100000.0,
            fy: 100000.0,
            cx: 1023.5,
            cy: 1023.5,
            width: 2048,
            height: 2048,
            chip_width: 256,
            chip_height: 256,
            pointing_error_px: 250.0,
            pointing_period_s: 7.0,
            tracker_jitter_px: 30.0,
        }
    }
}

/// Weather.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Weather {
    /// No clouds.
    Clear,
    /// A broken cloud layer.
    Cloudy,
}

/// Sun, sky, clouds, haze and terrain.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SceneConfig {
    /// Local solar time, "HH:MM" or "HH:MM:SS".
    pub time_of_day: String,
    /// Latitude of the range, deg north.
    pub latitude_deg: f64,
    /// Day of the year, 1..=366 (sets the sun's declination).
    pub day_of_year: u32,
    /// Clear or cloudy.
    pub weather: Weather,
    /// Fraction of the sky covered by cloud when cloudy, 0..1.
    pub cloud_cover: f64,
    /// Height of the cloud layer above the ground, m.
    pub cloud_altitude_m: f64,
    /// Size of the largest cloud features, m.
    pub cloud_scale_m: f64,
    /// Cloud drift (east, north), m/s.
    pub wind_m_s: [f64; 2],
    /// Distance over which haze leaves 1/e of an object's contrast, m.
    pub visibility_m: f64,
    /// Largest elevation of the hills on the horizon, deg.
    pub terrain_max_elevation_deg: f64,
    /// Distance to those hills, m (sets their haze).
    pub terrain_distance_m: f64,
}

impl Default for SceneConfig {
    fn default() -> Self {
        SceneConfig {
            time_of_day: "17:15".to_string(),
            latitude_deg: 35.0,
            day_of_year: 172,
            weather: Weather::Cloudy,
            cloud_cover: 0.65,
            cloud_altitude_m: 2500.0,
            cloud_scale_m: 800.0,
            wind_m_s: [6.0, 2.0],
            visibility_m: 20000.0,
            terrain_max_elevation_deg: 1.5,
            terrain_distance_m: 6000.0,
        }
    }
}

impl SceneConfig {
    /// `time_of_day` in hours after local solar midnight.
    pub fn time_of_day_h(&self) -> anyhow::Result<f64> {
        parse_time_of_day(&self.time_of_day)
            .with_context(|| format!("scene.time_of_day = {:?}", self.time_of_day))
    }
}

/// The exhaust plume behind the tail (emissive, never part of the mask).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlumeConfig {
    /// Whether there is a plume.
    pub enabled: bool,
    /// Peak radiance added by the plume's core, relative to the horizon sky's radiance.
    pub brightness: f64,
    /// Length of the visible plume, in body diameters.
    pub length_calibers: f64,
    /// Radius (Gaussian sigma) of the plume at the nozzle, in body diameters.
    pub width_calibers: f64,
    /// Log-normal spread of the frame-to-frame intensity flicker.
    pub flicker: f64,
}

impl Default for PlumeConfig {
    fn default() -> Self {
        PlumeConfig {
            enabled: true,
            brightness: 0.5,
            length_calibers: 5.0,
            width_calibers: 0.35,
            flicker: 0.3,
        }
    }
}

/// Whether the clip carries a range measurement.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum RangeSensor {
    /// `range_m` is the slant range |T| (plus `range_noise_m` of Gaussian noise).
    Known,
    /// `range_m` is empty.
    Unknown,
}

/// Optics, sensor and range sensor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SensorConfig {
    /// Sigma of the Gaussian point-spread function (atmosphere and optics), px.
    pub psf_sigma_px: f64,
    /// Mean sky signal at the first frame, as a fraction of full scale (the exposure).
    pub sky_level: f64,
    /// Electrons at full scale (sets the shot noise).
    pub full_well_e: f64,
    /// Read noise, electrons rms.
    pub read_noise_e: f64,
    /// Anti-aliasing samples per pixel along each axis (8 gives 64 samples a pixel).
    pub supersampling: u32,
    /// Bits per chip sample: 8 or 16.
    pub bit_depth: u8,
    /// Whether `range_m` is filled.
    pub range_sensor: RangeSensor,
    /// Gaussian noise of the range measurement, m rms.
    pub range_noise_m: f64,
}

impl Default for SensorConfig {
    fn default() -> Self {
        SensorConfig {
            psf_sigma_px: 0.9,
            sky_level: 0.7,
            full_well_e: 10000.0,
            read_noise_e: 15.0,
            supersampling: 8,
            bit_depth: 8,
            range_sensor: RangeSensor::Known,
            range_noise_m: 0.0,
        }
    }
}

impl Scenario {
    /// Reads a scenario file; a relative mesh path is made relative to the file's folder.
    pub fn from_file(path: &Path) -> anyhow::Result<Scenario> {
        let text =
            std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
        let mut scenario: Scenario =
            toml::from_str(&text).with_context(|| format!("parsing {}", path.display()))?;
        if let Some(mesh) = &scenario.projectile.mesh
            && mesh.is_relative()
        {
            let base = path.parent().unwrap_or(Path::new("."));
            scenario.projectile.mesh = Some(base.join(mesh));
        }
        Ok(scenario)
    }

    /// The scenario as TOML text.
    pub fn to_toml(&self) -> anyhow::Result<String> {
        toml::to_string(self).context("serializing the scenario")
    }

    /// Checks every knob's range, naming the offending field.
    pub fn validate(&self) -> anyhow::Result<()> {
        let c = &self.clip;
        ensure!(c.frames >= 1, "clip.frames must be at least 1");
        ensure!(c.keep_every >= 1, "clip.keep_every must be at least 1");
        ensure!(
            positive(c.frame_rate_hz),
            "clip.frame_rate_hz must be positive"
        );
        ensure!(
            c.start_time_s.is_finite() && c.start_time_s >= 0.0,
            "clip.start_time_s must be >= 0"
        );
        let p = &self.projectile;
        ensure!(
            positive(p.mesh_scale),
            "projectile.mesh_scale must be positive"
        );
        ensure!(
            (0.0..=1.0).contains(&p.albedo),
            "projectile.albedo must be in [0, 1]"
        );
        let t = &self.trajectory;
        ensure!(
            t.launch_angle_deg > 0.0 && t.launch_angle_deg < 90.0,
            "trajectory.launch_angle_deg must be in (0, 90)"
        );
        ensure!(
            positive(t.gravity_m_s2),
            "trajectory.gravity_m_s2 must be positive"
        );
        ensure!(
            t.drag_per_m.is_finite() && t.drag_per_m >= 0.0,
            "trajectory.drag_per_m must be >= 0"
        );
        let finite3 = |v: &[f64; 3]| v.iter().all(|x| x.is_finite());
        ensure!(
            finite3(&t.launcher_m) && finite3(&t.target_m),
            "trajectory positions must be finite"
        );
        let a = &self.attitude;
        ensure!(
            (0.0..45.0).contains(&(a.angle_of_attack_deg.abs() + a.nutation_deg.abs())),
            "attitude: angle_of_attack_deg + nutation_deg must stay below 45"
        );
        ensure!(
            positive(a.coning_period_s) && positive(a.nutation_period_s),
            "attitude periods must be positive"
        );
        ensure!(
            a.roll_rate_deg_s.is_finite(),
            "attitude.roll_rate_deg_s must be finite"
        );
        let k = &self.camera;
        ensure!(finite3(&k.position_m), "camera.position_m must be finite");
        ensure!(
            positive(k.fx) && positive(k.fy) && k.cx.is_finite() && k.cy.is_finite(),
            "camera intrinsics must be finite with fx, fy > 0"
        );
        ensure!(
            k.chip_width >= 16
                && k.chip_height >= 16
                && k.chip_width <= k.width
                && k.chip_height <= k.height,
            "camera chip must be at least 16 px and fit in the frame"
        );
        ensure!(
            k.pointing_error_px.is_finite() && k.pointing_error_px >= 0.0,
            "camera.pointing_error_px must be >= 0"
        );
        ensure!(
            positive(k.pointing_period_s),
            "camera.pointing_period_s must be positive"
        );
        ensure!(
            k.tracker_jitter_px.is_finite() && k.tracker_jitter_px >= 0.0,
            "camera.tracker_jitter_px must be >= 0"
        );
        let s = &self.scene;
        s.time_of_day_h()?;
        ensure!(
            (-90.0..=90.0).contains(&s.latitude_deg),
            "scene.latitude_deg must be in [-90, 90]"
        );
        ensure!(
            (1..=366).contains(&s.day_of_year),
            "scene.day_of_year must be in 1..=366"
        );
        ensure!(
            (0.0..=1.0).contains(&s.cloud_cover),
            "scene.cloud_cover must be in [0, 1]"
        );
        ensure!(
            positive(s.cloud_altitude_m) && positive(s.cloud_scale_m),
            "scene cloud altitude and scale must be positive"
        );
        ensure!(
            positive(s.visibility_m),
            "scene.visibility_m must be positive"
        );
        ensure!(
            (0.0..30.0).contains(&s.terrain_max_elevation_deg),
            "scene.terrain_max_elevation_deg must be in [0, 30)"
        );
        ensure!(
            positive(s.terrain_distance_m),
            "scene.terrain_distance_m must be positive"
        );
        let pl = &self.plume;
        ensure!(
            pl.brightness.is_finite() && pl.brightness >= 0.0,
            "plume.brightness must be >= 0"
        );
        ensure!(
            positive(pl.length_calibers) && positive(pl.width_calibers),
            "plume length and width must be positive"
        );
        ensure!(
            (0.0..=2.0).contains(&pl.flicker),
            "plume.flicker must be in [0, 2]"
        );
        let n = &self.sensor;
        ensure!(
            (0.0..=5.0).contains(&n.psf_sigma_px),
            "sensor.psf_sigma_px must be in [0, 5]"
        );
        ensure!(
            n.sky_level > 0.0 && n.sky_level < 1.0,
            "sensor.sky_level must be in (0, 1)"
        );
        ensure!(
            positive(n.full_well_e),
            "sensor.full_well_e must be positive"
        );
        ensure!(
            n.read_noise_e.is_finite() && n.read_noise_e >= 0.0,
            "sensor.read_noise_e must be >= 0"
        );
        ensure!(
            (1..=16).contains(&n.supersampling),
            "sensor.supersampling must be in 1..=16"
        );
        ensure!(
            n.bit_depth == 8 || n.bit_depth == 16,
            "sensor.bit_depth must be 8 or 16"
        );
        ensure!(
            n.range_noise_m.is_finite() && n.range_noise_m >= 0.0,
            "sensor.range_noise_m must be >= 0"
        );
        Ok(())
    }
}

fn positive(v: f64) -> bool {
    v.is_finite() && v > 0.0
}

/// Parses "HH:MM" or "HH:MM:SS" into hours.
fn parse_time_of_day(text: &str) -> anyhow::Result<f64> {
    let parts: Vec<&str> = text.trim().split(':').collect();
    if !(2..=3).contains(&parts.len()) {
        bail!("expected HH:MM or HH:MM:SS");
    }
    let mut fields = [0u32; 3];
    for (slot, part) in fields.iter_mut().zip(&parts) {
        *slot = part
            .parse()
            .with_context(|| format!("{part:?} is not a whole number"))?;
    }
    let [h, m, s] = fields;
    if h > 23 || m > 59 || s > 59 {
        bail!("out of range");
    }
    Ok(f64::from(h) + f64::from(m) / 60.0 + f64::from(s) / 3600.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_of_day_parses() {
        assert_eq!(parse_time_of_day("17:15").unwrap(), 17.25);
        assert_eq!(parse_time_of_day("06:00:36").unwrap(), 6.01);
        assert!(parse_time_of_day("25:00").is_err());
        assert!(parse_time_of_day("17").is_err());
        assert!(parse_time_of_day("aa:bb").is_err());
    }

    #[test]
    fn a_minimal_file_takes_the_defaults_and_unknown_keys_are_refused() {
        let s: Scenario = toml::from_str("seed = 5\n[clip]\nframes = 3\n").unwrap();
        assert_eq!(s.seed, 5);
        assert_eq!(s.clip.frames, 3);
        assert_eq!(s.camera, CameraConfig::default());
        s.validate().unwrap();
        assert!(toml::from_str::<Scenario>("seed = 5\n[clip]\nframez = 3\n").is_err());
    }

    #[test]
    fn validation_names_the_bad_field() {
        let mut s: Scenario = toml::from_str("seed = 1").unwrap();
        s.sensor.bit_depth = 12;
        let e = s.validate().unwrap_err().to_string();
        assert!(e.contains("sensor.bit_depth"), "{e}");
    }
}
