//! Named scenarios: the three clips of the source paper's Table 1, and a few that stress what
//! Table 1 does not (a clear sky with terrain, a projectile flying at the camera, low contrast
//! with a bright plume).

use super::scenario::{
    AttitudeConfig, CameraConfig, ClipConfig, PlumeConfig, ProjectileConfig, Scenario, SceneConfig,
    SensorConfig, TrajectoryConfig, Weather,
};

/// Every preset: name and one line on what it is.
pub const PRESETS: [(&str, &str); 6] = [
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
    }
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
