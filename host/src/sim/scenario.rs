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
    /// Thin dark cloud filaments and streaks across the chip (none by default).
    #[serde(default, skip_serializing_if = "FilamentsConfig::is_off")]
    pub filaments: FilamentsConfig,
    /// A hillside whose ridge enters the chip from its lower edge (off by default).
    #[serde(default, skip_serializing_if = "NearTerrainConfig::is_off")]
    pub near_terrain: NearTerrainConfig,
    /// A second object crossing the chip: a bird or another projectile (none by default).
    #[serde(default, skip_serializing_if = "SecondObjectConfig::is_off")]
    pub second_object: SecondObjectConfig,
    /// Ranges the physics is drawn from, per clip, from the seed (nothing drawn by default).
    #[serde(default, skip_serializing_if = "RandomizeConfig::is_off")]
    pub randomize: RandomizeConfig,
    /// Several stations seeing the one flight, each rendered as its own clip (none: the one
    /// camera of `[camera]`, station `camera.station_id`). One flight: every station sees the
    /// same attitude, plume and sky; each mount and sensor has its own errors and noise.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub stations: Vec<StationConfig>,
}

/// One station of a several-station scenario: a camera of `[camera]`'s intrinsics and tracker
/// placed elsewhere, on the same clock.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StationConfig {
    /// The station's name: its clip's folder and `clip.json`'s `station.id`.
    pub id: String,
    /// Optical centre in W, m.
    pub position_m: [f64; 3],
    /// How much later than `clip.start_time_s` its first frame is taken, s, in [0, 1): stations
    /// whose frames do not coincide.
    #[serde(default)]
    pub time_offset_s: f64,
}

/// Which way a body or a plume differs from what is behind it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Polarity {
    /// Darker than the background.
    #[default]
    Dark,
    /// Brighter than the background.
    Bright,
}

impl Polarity {
    /// -1 for dark, +1 for bright.
    pub fn sign(self) -> f64 {
        match self {
            Polarity::Dark => -1.0,
            Polarity::Bright => 1.0,
        }
    }

    fn is_dark(&self) -> bool {
        *self == Polarity::Dark
    }

    fn is_bright(&self) -> bool {
        *self == Polarity::Bright
    }
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
    /// When given: the body's mean contrast against the background behind it, in units of the
    /// per-pixel noise sigma (shot, read and quantization noise) at that background's level, at
    /// the camera (after haze, before the PSF). The albedo's Lambertian shading then only sets the
    /// pattern across the body (its spread is 30 % of the contrast). Absent: the albedo alone
    /// decides.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub contrast_sigma: Option<f64>,
    /// With `contrast_sigma`: whether the body is darker ("dark") or brighter ("bright") than the
    /// background.
    #[serde(skip_serializing_if = "Polarity::is_dark")]
    pub polarity: Polarity,
}

impl Default for ProjectileConfig {
    fn default() -> Self {
        ProjectileConfig {
            model: super::model::REFERENCE_ID.to_string(),
            mesh: None,
            mesh_scale: 1.0,
            albedo: 0.12,
            contrast_sigma: None,
            polarity: Polarity::Dark,
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
    /// The station's name in `clip.json` (`station.id`).
    #[serde(skip_serializing_if = "is_default_station")]
    pub station_id: String,
    /// The stream of the station's own draws (the mount's pointing error and jitter, the
    /// sensor's and the range sensor's noise): 0, the first station's, draws them from `seed`
    /// as a one-station clip does; the flight's draws (attitude, plume, clouds, randomized
    /// physics, clutter) come from `seed` alone at every station.
    #[serde(skip_serializing_if = "is_zero")]
    pub station_stream: u64,
}

fn is_zero(v: &u64) -> bool {
    *v == 0
}

/// The station a scenario without `[[stations]]` is seen from.
pub const DEFAULT_STATION_ID: &str = "A";

fn is_default_station(id: &str) -> bool {
    id == DEFAULT_STATION_ID
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
            station_id: DEFAULT_STATION_ID.into(),
            station_stream: 0,
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
    /// "bright": glowing exhaust that adds `brightness` of radiance; "dark": smoke that absorbs,
    /// `brightness` then being the optical depth at the core (exp(-depth) of the background
    /// passes).
    #[serde(skip_serializing_if = "Polarity::is_bright")]
    pub polarity: Polarity,
    /// true: each puff is a whole 3-D Gaussian, so its glow reaches ahead of the base plane over
    /// the tail, like a halo of scattered light. false: the gas glows only behind the base
    /// plane: a camera ray collects a puff's light only on its stretch behind the base plane and
    /// in front of the body's surface (a base facing the camera gets the glow in front of it,
    /// a body side-on none).
    #[serde(skip_serializing_if = "is_true")]
    pub glow_ahead_of_base: bool,
}

/// For `skip_serializing_if`: a default-true flag left out of a written scenario.
fn is_true(flag: &bool) -> bool {
    *flag
}

impl Default for PlumeConfig {
    fn default() -> Self {
        PlumeConfig {
            enabled: true,
            brightness: 0.5,
            length_calibers: 5.0,
            width_calibers: 0.35,
            flicker: 0.3,
            polarity: Polarity::Bright,
            glow_ahead_of_base: true,
        }
    }
}

/// Thin dark cloud filaments and streaks, drawn in chip coordinates (the tracker holds the chip on
/// the target, so distant cloud moves slowly across it). Each filament is a slightly bowed line
/// with a Gaussian cross-section, tapered ends and a streaky, broken core; it drifts by a constant
/// velocity per written frame. Never part of the mask.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FilamentsConfig {
    /// Number of filaments in each chip (0: none).
    pub count: u32,
    /// Range [lo, hi] of each filament's depth at its core, in per-pixel noise sigmas at the
    /// local background (the scale of `projectile.contrast_sigma`, so "as dark as the body").
    pub darkness_sigma: [f64; 2],
    /// Range of the Gaussian sigma of each filament's cross-section, px.
    pub width_px: [f64; 2],
    /// Range of each filament's length, in chip widths.
    pub length_chips: [f64; 2],
    /// Largest bow of a filament off its chord, px.
    pub bow_px: f64,
    /// Largest drift speed of a filament, px per written frame (each draws its own velocity).
    pub drift_px_per_frame: f64,
    /// Fraction of the filaments aimed through the chip centre, where the tracker holds the body.
    pub through_centre_fraction: f64,
    /// Fraction of the filaments drawn in front of the body (the others pass behind it).
    pub in_front_fraction: f64,
}

impl Default for FilamentsConfig {
    fn default() -> Self {
        FilamentsConfig {
            count: 0,
            darkness_sigma: [3.0, 5.0],
            width_px: [0.8, 2.5],
            length_chips: [0.4, 1.4],
            bow_px: 12.0,
            drift_px_per_frame: 0.4,
            through_centre_fraction: 0.35,
            in_front_fraction: 0.0,
        }
    }
}

impl FilamentsConfig {
    fn is_off(&self) -> bool {
        *self == FilamentsConfig::default()
    }
}

/// A hillside nearer than the projectile whose ridge line enters the chip from its lower edge,
/// as when the line of sight grazes the terrain. The ridge's level is held relative to the chip
/// (so it stays in view), while its shape and texture are fixed in azimuth and elevation, so they
/// pan across the chip as the mount follows the projectile. Never part of the mask. (The horizon
/// hills of `scene.terrain_max_elevation_deg` sit at fixed elevations, so they are behind the
/// chip only while the projectile is that low, e.g. the first frames of `clear-sky`.)
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NearTerrainConfig {
    /// Whether the hillside is there.
    pub enabled: bool,
    /// Mean height of the ridge above the chip's lower edge at the first frame, as a fraction of
    /// the chip height.
    pub cover: f64,
    /// Peak-to-mean up-and-down of the ridge line, as a fraction of the chip height.
    pub relief: f64,
    /// How fast the ridge rises in the chip, px per written frame (negative: it sinks).
    pub rise_px_per_frame: f64,
    /// Distance to the hillside, m (its haze, with `scene.visibility_m`).
    pub distance_m: f64,
}

impl Default for NearTerrainConfig {
    fn default() -> Self {
        NearTerrainConfig {
            enabled: false,
            cover: 0.2,
            relief: 0.08,
            rise_px_per_frame: 0.0,
            distance_m: 1500.0,
        }
    }
}

impl NearTerrainConfig {
    fn is_off(&self) -> bool {
        *self == NearTerrainConfig::default()
    }
}

/// What the second object is.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SecondObjectKind {
    /// No second object.
    #[default]
    None,
    /// A bird-sized blob whose wings beat.
    Bird,
    /// Another projectile: an elongated capsule flying along its length.
    Projectile,
}

/// A second object crossing the chip on a straight line at constant speed (chip coordinates),
/// through a random point of the chip's middle at a random frame of the clip. It passes behind
/// the body and is never part of the mask.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SecondObjectConfig {
    /// "none", "bird" or "projectile".
    pub kind: SecondObjectKind,
    /// Bird: wingspan, px; projectile: body width, px.
    pub size_px: f64,
    /// Projectile only: its length, px.
    pub length_px: f64,
    /// Contrast against the background, in per-pixel noise sigmas.
    pub contrast_sigma: f64,
    /// Whether it is darker or brighter than the background.
    pub polarity: Polarity,
    /// Speed across the chip, px per written frame.
    pub speed_px_per_frame: f64,
}

impl Default for SecondObjectConfig {
    fn default() -> Self {
        SecondObjectConfig {
            kind: SecondObjectKind::None,
            size_px: 8.0,
            length_px: 50.0,
            contrast_sigma: 6.0,
            polarity: Polarity::Dark,
            speed_px_per_frame: 8.0,
        }
    }
}

impl SecondObjectConfig {
    fn is_off(&self) -> bool {
        *self == SecondObjectConfig::default()
    }
}

/// Ranges the physics is drawn from, once per clip, from the seed: each given key replaces the
/// value set elsewhere in the scenario with a uniform draw from [lo, hi] (or a coin with the given
/// probability). Absent keys leave their values alone. The draws come in a fixed order from their
/// own stream, so adding a key does not change the others' draws. Two keys vary per frame.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RandomizeConfig {
    /// `projectile.contrast_sigma`, noise sigmas.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub contrast_sigma: Option<[f64; 2]>,
    /// Probability that the body is bright (`projectile.polarity`), 0..1.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bright_body_probability: Option<f64>,
    /// `sensor.psf_sigma_px`, px.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub psf_sigma_px: Option<[f64; 2]>,
    /// `sensor.read_noise_e`, electrons rms.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub read_noise_e: Option<[f64; 2]>,
    /// `sensor.sky_level` (the exposure, and so the shot noise), fraction of full scale.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sky_level: Option<[f64; 2]>,
    /// `plume.brightness` (radiance over the horizon sky; optical depth for a dark plume).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub plume_brightness: Option<[f64; 2]>,
    /// `plume.length_calibers`, body diameters.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub plume_length_calibers: Option<[f64; 2]>,
    /// `plume.width_calibers`, body diameters.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub plume_width_calibers: Option<[f64; 2]>,
    /// Probability that the plume is dark smoke (`plume.polarity`), 0..1.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dark_plume_probability: Option<f64>,
    /// `filaments.count`, drawn as a whole number in [lo, hi].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub filament_count: Option<[u32; 2]>,
    /// Probability that the near hillside is there (`near_terrain.enabled`), 0..1.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub near_terrain_probability: Option<f64>,
    /// `near_terrain.cover`, fraction of the chip height.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub near_terrain_cover: Option<[f64; 2]>,
    /// `scene.visibility_m` (haze), m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub visibility_m: Option<[f64; 2]>,
    /// Probability of a second object, 0..1; its kind is `second_object.kind`, or a bird or a
    /// projectile with even odds when that is "none".
    #[serde(skip_serializing_if = "Option::is_none")]
    pub second_object_probability: Option<f64>,
    /// Per frame: the PSF sigma moves by up to this much either way (turbulence), px.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub frame_psf_jitter_px: Option<f64>,
    /// Per frame: the body's `contrast_sigma` scales by up to this fraction either way
    /// (scintillation, changing light).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub frame_contrast_jitter: Option<f64>,
}

impl RandomizeConfig {
    fn is_off(&self) -> bool {
        *self == RandomizeConfig::default()
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

    /// The scenario of each station of `[[stations]]`, in order, with its id: `[camera]` moved
    /// to the station, its first frame later by its offset, and the `i`-th station's own draws
    /// from stream `i` (`camera.station_stream`: each mount its own pointing error and jitter,
    /// each sensor its own noise). One scenario, the given one, where there are no stations.
    pub fn station_scenarios(&self) -> Vec<Scenario> {
        if self.stations.is_empty() {
            return vec![self.clone()];
        }
        self.stations
            .iter()
            .zip(0u64..)
            .map(|(station, i)| {
                let mut s = self.clone();
                s.stations.clear();
                s.camera.station_stream = i;
                s.camera.position_m = station.position_m;
                s.camera.station_id.clone_from(&station.id);
                s.clip.start_time_s += station.time_offset_s;
                s
            })
            .collect()
    }

    /// The seed of the station's own draws (`camera.station_stream`).
    pub fn station_seed(&self) -> u64 {
        match self.camera.station_stream {
            0 => self.seed,
            stream => super::random::mix64(self.seed ^ super::random::mix64(stream)),
        }
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
            is_station_name(&k.station_id),
            "camera.station_id must be 1-32 letters, digits, '-' or '_'"
        );
        for (i, st) in self.stations.iter().enumerate() {
            ensure!(
                is_station_name(&st.id),
                "stations[{i}].id must be 1-32 letters, digits, '-' or '_'"
            );
            ensure!(
                self.stations[..i].iter().all(|other| other.id != st.id),
                "stations[{i}].id {:?} is given twice",
                st.id
            );
            ensure!(
                finite3(&st.position_m),
                "stations[{i}].position_m must be finite"
            );
            ensure!(
                (0.0..1.0).contains(&st.time_offset_s),
                "stations[{i}].time_offset_s must be in [0, 1)"
            );
        }
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
        if let Some(c) = p.contrast_sigma {
            ensure!(
                (0.0..=1000.0).contains(&c),
                "projectile.contrast_sigma must be in [0, 1000]"
            );
        }
        self.validate_clutter()
    }

    /// The clutter sections and the randomize ranges.
    fn validate_clutter(&self) -> anyhow::Result<()> {
        let f = &self.filaments;
        ensure!(f.count <= 64, "filaments.count must be at most 64");
        range(f.darkness_sigma, 0.0, 1000.0, "filaments.darkness_sigma")?;
        range(f.width_px, 0.1, 50.0, "filaments.width_px")?;
        range(f.length_chips, 0.01, 10.0, "filaments.length_chips")?;
        ensure!(
            (0.0..=200.0).contains(&f.bow_px),
            "filaments.bow_px must be in [0, 200]"
        );
        ensure!(
            (0.0..=50.0).contains(&f.drift_px_per_frame),
            "filaments.drift_px_per_frame must be in [0, 50]"
        );
        ensure!(
            (0.0..=1.0).contains(&f.through_centre_fraction)
                && (0.0..=1.0).contains(&f.in_front_fraction),
            "filaments fractions must be in [0, 1]"
        );
        let t = &self.near_terrain;
        ensure!(
            (0.0..=1.0).contains(&t.cover) && (0.0..=1.0).contains(&t.relief),
            "near_terrain.cover and relief must be in [0, 1]"
        );
        ensure!(
            (-50.0..=50.0).contains(&t.rise_px_per_frame),
            "near_terrain.rise_px_per_frame must be in [-50, 50]"
        );
        ensure!(
            positive(t.distance_m),
            "near_terrain.distance_m must be positive"
        );
        let o = &self.second_object;
        ensure!(
            (0.5..=200.0).contains(&o.size_px) && (0.5..=1000.0).contains(&o.length_px),
            "second_object.size_px must be in [0.5, 200] and length_px in [0.5, 1000]"
        );
        ensure!(
            (0.0..=1000.0).contains(&o.contrast_sigma),
            "second_object.contrast_sigma must be in [0, 1000]"
        );
        ensure!(
            (0.0..=100.0).contains(&o.speed_px_per_frame),
            "second_object.speed_px_per_frame must be in [0, 100]"
        );
        let r = &self.randomize;
        let opt = |v: Option<[f64; 2]>, lo: f64, hi: f64, name: &str| match v {
            Some(v) => range(v, lo, hi, name),
            None => Ok(()),
        };
        let prob = |v: Option<f64>, name: &str| match v {
            Some(p) => {
                ensure!((0.0..=1.0).contains(&p), "{name} must be in [0, 1]");
                Ok(())
            }
            None => Ok(()),
        };
        opt(r.contrast_sigma, 0.0, 1000.0, "randomize.contrast_sigma")?;
        opt(r.psf_sigma_px, 0.0, 5.0, "randomize.psf_sigma_px")?;
        opt(r.read_noise_e, 0.0, 1e6, "randomize.read_noise_e")?;
        opt(r.sky_level, 0.01, 0.99, "randomize.sky_level")?;
        opt(
            r.plume_brightness,
            0.0,
            1000.0,
            "randomize.plume_brightness",
        )?;
        opt(
            r.plume_length_calibers,
            0.01,
            1000.0,
            "randomize.plume_length_calibers",
        )?;
        opt(
            r.plume_width_calibers,
            0.01,
            1000.0,
            "randomize.plume_width_calibers",
        )?;
        opt(
            r.near_terrain_cover,
            0.0,
            1.0,
            "randomize.near_terrain_cover",
        )?;
        opt(r.visibility_m, 1.0, 1e9, "randomize.visibility_m")?;
        prob(
            r.bright_body_probability,
            "randomize.bright_body_probability",
        )?;
        prob(r.dark_plume_probability, "randomize.dark_plume_probability")?;
        prob(
            r.near_terrain_probability,
            "randomize.near_terrain_probability",
        )?;
        prob(
            r.second_object_probability,
            "randomize.second_object_probability",
        )?;
        if let Some([lo, hi]) = r.filament_count {
            ensure!(
                lo <= hi && hi <= 64,
                "randomize.filament_count must be [lo, hi] with lo <= hi <= 64"
            );
        }
        ensure!(
            r.frame_psf_jitter_px
                .is_none_or(|j| (0.0..=2.0).contains(&j)),
            "randomize.frame_psf_jitter_px must be in [0, 2]"
        );
        ensure!(
            r.frame_contrast_jitter
                .is_none_or(|j| (0.0..=0.9).contains(&j)),
            "randomize.frame_contrast_jitter must be in [0, 0.9]"
        );
        Ok(())
    }
}

/// Checks that `[lo, hi]` is ordered and within [min, max].
fn range([lo, hi]: [f64; 2], min: f64, max: f64, name: &str) -> anyhow::Result<()> {
    ensure!(
        lo.is_finite() && hi.is_finite() && min <= lo && lo <= hi && hi <= max,
        "{name} must be [lo, hi] with {min} <= lo <= hi <= {max}"
    );
    Ok(())
}

/// A station name that is also a safe folder name.
fn is_station_name(id: &str) -> bool {
    (1..=32).contains(&id.len())
        && id
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
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
