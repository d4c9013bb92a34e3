//! Named scenarios: the three clips of the source paper's Table 1, a few that stress what
//! Table 1 does not (a clear sky with terrain, a projectile flying at the camera, low contrast
//! with a bright plume), and the clutter of real range footage (a faint body under a bright
//! plume among cloud filaments, terrain entering the chip with a second object, and everything
//! randomized), with the physics drawn per clip from stated ranges.

use super::scenario::{
    AttitudeConfig, CameraConfig, ClipConfig, FilamentsConfig, NearTerrainConfig, PlumeConfig,
    ProjectileConfig, RandomizeConfig, RangeSensor, Scenario, SceneConfig, SecondObjectConfig,
    SensorConfig, StationConfig, TrajectoryConfig, Weather,
};

/// Every preset: name and one line on what it is.
pub const PRESETS: [(&str, &str); 10] = [
    (
        "table1-train",
        "Table 1 training clip: 40 deg launch, 17:00, cloudy, seed 539662031, 175 frames",
    ),
    (
        "table1-validation",
        "Table 1 validation clip: 41 deg launch, 17:30, cloudy, seed 539662032, 175 frames",
    ),
    (
        "table1-test",
        "Table 1 test clip: 39 deg launch, 17:15, cloudy, seed 539662033, 175 frames",
    ),
    (
        "clear-sky",
        "09:00 clear sky from just after launch: terrain behind the first frames, sun-side glow",
    ),
    (
        "towards-camera",
        "the descending projectile flies at the camera (|yaw| > 90), range 2.1 to 1.1 km",
    ),
    (
        "low-contrast-plume",
        "hazy overcast dusk, pale body close to the sky, bright flickering plume over the tail",
    ),
    (
        "clutter-faint-plume",
        "body 3-5 noise sigmas darker than the sky, brighter plume over the tail, dark filaments, \
         haze, PSF 0.5-1.5 px, all drawn per clip",
    ),
    (
        "clutter-terrain",
        "a hillside entering from the chip's lower edge, dark filaments, a bird or a second \
         projectile crossing, body 3-8 sigma, drawn per clip",
    ),
    (
        "clutter-random",
        "every clutter range at once, both polarities of body and plume: a different look per seed",
    ),
    (
        "two-stations",
        "the Table 1 flight seen from two stations 2.4 km apart, no range sensor, B's frames a \
         camera frame after A's: one clip per station for `imade fuse`",
    ),
];

/// The preset called `name`.
pub fn preset(name: &str) -> Option<Scenario> {
    let scenario = match name {
        "table1-train" => table1(40.0, "17:00", 539662031),
        "table1-validation" => table1(41.0, "17:30", 539662032),
        "table1-test" => table1(39.0, "17:15", 539662033),
        "clear-sky" => clear_sky(),
        "towards-camera" => towards_camera(),
        "low-contrast-plume" => low_contrast_plume(),
        "clutter-faint-plume" => clutter_faint_plume(20240904),
        "clutter-terrain" => clutter_terrain(20240905),
        "clutter-random" => clutter_random(20240906),
        "two-stations" => two_stations(),
        _ => return None,
    };
    Some(scenario)
}

/// The Table 1 scene: a launcher at the origin firing north at a target 3 km downrange, the
/// camera 1 km west of the line of fire and 600 m downrange, tracking the first 12 s of flight
/// (every second frame of a 30 Hz camera), the range over the clip 1.05-1.6 km.
fn table1(launch_angle_deg: f64, time_of_day: &str, seed: u64) -> Scenario {
    Scenario {
        seed,
        description: format!(
            "Source paper Table 1: launch angle {launch_angle_deg} deg, {time_of_day}, cloudy, \
             seed {seed}"
        ),
        clip: ClipConfig::default(),
        projectile: ProjectileConfig::default(),
        trajectory: TrajectoryConfig {
            launch_angle_deg,
            drag_per_m: 4.5e-5,
            ..TrajectoryConfig::default()
        },
        attitude: AttitudeConfig::default(),
        camera: CameraConfig::default(),
        scene: SceneConfig {
            time_of_day: time_of_day.to_string(),
            weather: Weather::Cloudy,
            ..SceneConfig::default()
        },
        plume: PlumeConfig::default(),
        sensor: SensorConfig::default(),
        filaments: FilamentsConfig::default(),
        near_terrain: NearTerrainConfig::default(),
        second_object: SecondObjectConfig::default(),
        randomize: RandomizeConfig::default(),
        stations: Vec::new(),
    }
}

/// The Table 1 flight from two stations: A, the Table 1 camera west of the line of fire, and
/// B, 1.3 km east of it and 1.4 km downrange, whose line of sight meets A's at 110-135 deg.
/// No range sensor; B's frames are taken a camera frame after A's.
fn two_stations() -> Scenario {
    let mut s = table1(39.0, "17:15", 20240907);
    s.description = "The Table 1 flight from two stations, no range sensor".into();
    s.clip.frames = 40;
    s.clip.keep_every = 4;
    s.sensor.range_sensor = RangeSensor::Unknown;
    let a = s.camera.position_m;
    s.stations = vec![
        StationConfig {
            id: "A".into(),
            position_m: a,
            time_offset_s: 0.0,
        },
        StationConfig {
            id: "B".into(),
            position_m: [1300.0, 1400.0, 2.0],
            time_offset_s: 1.0 / s.clip.frame_rate_hz,
        },
    ];
    s
}

fn clear_sky() -> Scenario {
    let mut s = table1(40.0, "09:00", 20240901);
    s.description =
        "Clear morning sky, from 0.1 s after launch: hills behind the first frames".into();
    s.clip = ClipConfig {
        frames: 120,
        start_time_s: 0.1,
        ..ClipConfig::default()
    };
    s.scene.weather = Weather::Clear;
    s.scene.terrain_max_elevation_deg = 2.5;
    s.sensor.psf_sigma_px = 0.7;
    s
}

fn towards_camera() -> Scenario {
    let mut s = table1(45.0, "17:15", 20240902);
    s.description =
        "Camera 600 m beyond the target and 400 m off the line of fire: the nose comes at it"
            .into();
    s.clip = ClipConfig {
        frames: 120,
        start_time_s: 14.0,
        ..ClipConfig::default()
    };
    s.camera.position_m = [-400.0, 3600.0, 2.0];
    s.trajectory.drag_per_m = 0.0;
    s
}

fn low_contrast_plume() -> Scenario {
    let mut s = table1(39.0, "18:00", 20240903);
    s.description =
        "Hazy overcast dusk: a pale body barely darker than the sky, a bright plume".into();
    s.clip.frames = 120;
    s.projectile.albedo = 0.5;
    s.scene.cloud_cover = 0.85;
    s.scene.visibility_m = 2500.0;
    s.plume.brightness = 1.6;
    s.plume.length_calibers = 8.0;
    s.plume.flicker = 0.45;
    s.sensor.psf_sigma_px = 1.1;
    s
}

/// The randomized sensor and haze every clutter preset shares: PSF 0.5-1.5 px (moving by up to
/// 0.1 px per frame), read noise 10-30 e-, exposure 0.5-0.75 of full scale, visibility 3-15 km,
/// the body's contrast moving by up to 10 % per frame.
fn clutter_sensor() -> RandomizeConfig {
    RandomizeConfig {
        psf_sigma_px: Some([0.5, 1.5]),
        read_noise_e: Some([10.0, 30.0]),
        sky_level: Some([0.5, 0.75]),
        visibility_m: Some([3000.0, 15000.0]),
        frame_psf_jitter_px: Some(0.1),
        frame_contrast_jitter: Some(0.1),
        ..RandomizeConfig::default()
    }
}

/// A faint body (3-5 noise sigmas darker than the sky) 5-7.5 px wide, a glowing plume over the
/// tail several times brighter than the body is dark, two to five dark filaments as dark as the
/// body (a third aimed through the chip centre), haze, PSF 0.5-1.5 px; 120 frames of the Table 1
/// flight.
pub fn clutter_faint_plume(seed: u64) -> Scenario {
    let mut s = table1(39.0, "17:15", seed);
    s.description = "Clutter: a faint body (3-5 sigma), a bright plume over the tail, dark cloud \
                     filaments, haze, PSF 0.5-1.5 px, drawn per clip"
        .into();
    s.clip.frames = 120;
    s.projectile.contrast_sigma = Some(4.0);
    s.plume.flicker = 0.35;
    s.filaments.count = 3;
    s.randomize = RandomizeConfig {
        contrast_sigma: Some([3.0, 5.0]),
        plume_brightness: Some([0.15, 0.6]),
        plume_length_calibers: Some([4.0, 9.0]),
        plume_width_calibers: Some([0.3, 0.6]),
        filament_count: Some([2, 5]),
        ..clutter_sensor()
    };
    s
}

/// A hillside whose ridge enters from the chip's lower edge (10-25 % of the chip, rising slowly),
/// one to four filaments, a bird or a second projectile crossing the chip, a body 3-8 sigma
/// darker than what is behind it, the plume drawn per clip; 120 frames of the Table 1 flight.
pub fn clutter_terrain(seed: u64) -> Scenario {
    let mut s = table1(39.0, "17:15", seed);
    s.description = "Clutter: terrain entering from the chip's lower edge, dark filaments, a \
                     second object crossing, body 3-8 sigma, drawn per clip"
        .into();
    s.clip.frames = 120;
    s.projectile.contrast_sigma = Some(5.0);
    s.near_terrain = NearTerrainConfig {
        enabled: true,
        cover: 0.18,
        relief: 0.08,
        rise_px_per_frame: 0.1,
        distance_m: 1500.0,
    };
    s.filaments.count = 2;
    s.second_object.speed_px_per_frame = 6.0;
    s.randomize = RandomizeConfig {
        contrast_sigma: Some([3.0, 8.0]),
        plume_brightness: Some([0.1, 0.8]),
        plume_length_calibers: Some([3.0, 8.0]),
        filament_count: Some([1, 4]),
        near_terrain_cover: Some([0.1, 0.25]),
        second_object_probability: Some(1.0),
        ..clutter_sensor()
    };
    s
}

/// Every clutter range at once, so that each seed gives another look: body 3-8 sigma, dark or
/// (one time in four) bright; plume bright or (one time in three) dark smoke, 0.05-0.8 strong;
/// zero to six filaments, one in five in front of the body; terrain half the time; a second
/// object half the time; the clutter sensor and haze ranges.
pub fn clutter_random(seed: u64) -> Scenario {
    let mut s = table1(39.0, "17:15", seed);
    s.description = "Clutter: every range randomized per clip, both polarities".into();
    s.clip.frames = 120;
    s.projectile.contrast_sigma = Some(5.0);
    s.near_terrain.rise_px_per_frame = 0.1;
    s.filaments.in_front_fraction = 0.2;
    s.randomize = RandomizeConfig {
        contrast_sigma: Some([3.0, 8.0]),
        bright_body_probability: Some(0.25),
        plume_brightness: Some([0.05, 0.8]),
        plume_length_calibers: Some([3.0, 10.0]),
        plume_width_calibers: Some([0.25, 0.6]),
        dark_plume_probability: Some(1.0 / 3.0),
        filament_count: Some([0, 6]),
        near_terrain_probability: Some(0.5),
        near_terrain_cover: Some([0.1, 0.3]),
        second_object_probability: Some(0.5),
        ..clutter_sensor()
    };
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::trajectory::Trajectory;

    #[test]
    fn every_preset_is_valid_and_survives_toml() {
        for (name, _) in PRESETS {
            let s = preset(name).unwrap();
            s.validate().unwrap();
            let text = s.to_toml().unwrap();
            let back: Scenario = toml::from_str(&text).unwrap();
            assert_eq!(back, s, "{name}");
            let trajectory = Trajectory::new(&s.trajectory).unwrap();
            crate::sim::plan::plan_frames(&s, &trajectory).unwrap();
        }
        assert!(preset("table2").is_none());
    }

    #[test]
    fn table1_presets_match_the_paper() {
        let expected = [
            ("table1-train", 40.0, "17:00", 539662031),
            ("table1-validation", 41.0, "17:30", 539662032),
            ("table1-test", 39.0, "17:15", 539662033),
        ];
        for (name, angle, time, seed) in expected {
            let s = preset(name).unwrap();
            assert_eq!(s.trajectory.launch_angle_deg, angle);
            assert_eq!(s.scene.time_of_day, time);
            assert_eq!(s.seed, seed);
            assert_eq!(s.scene.weather, Weather::Cloudy);
            assert_eq!(s.clip.frames, 175);
        }
    }
}
