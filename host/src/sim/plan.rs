//! The geometric truth of every frame: when it is taken, where the projectile is and how it is
//! turned, where the camera points, where the chip is cut, and the pose relative to the camera.
//!
//! The pose is computed from the world geometry, R_CB = R_CW * R_WB and T = R_CW (P - C), and
//! only then decomposed into the spec's pitch, yaw and roll.

use super::attitude::AttitudeLaw;
use super::camera::{CameraPose, Intrinsics};
use super::math::{Mat3, Vec3};
use super::pose::{Attitude, BodyPose};
use super::random::{Purpose, Random};
use super::scenario::{RangeSensor, Scenario};
use super::tracking::Tracker;
use super::trajectory::Trajectory;
use anyhow::{bail, ensure};

/// One frame's truth.
#[derive(Debug, Clone, PartialEq)]
pub struct FramePlan {
    /// Camera frame number (time_s * frame rate).
    pub frame: u64,
    /// Time after launch, s.
    pub time_s: f64,
    /// Camera placement.
    pub camera: CameraPose,
    /// Body position in W, m.
    pub body_world: Vec3,
    /// Body velocity in W, m/s.
    pub velocity_world: Vec3,
    /// R_WB: the body axes in W (columns x_B, y_B, z_B).
    pub body_axes_world: Mat3,
    /// Body pose in the camera frame.
    pub body: BodyPose,
    /// The spec attitude of `body`.
    pub attitude: Attitude,
    /// Full-frame (u, v) of the body origin, px.
    pub target_px: (f64, f64),
    /// Full-frame pixel of the chip's top-left pixel.
    pub chip_origin: (i64, i64),
    /// The range sensor's reading, m, if the clip has one.
    pub range_m: Option<f64>,
}

/// The intrinsics of a scenario's camera.
pub fn intrinsics(scenario: &Scenario) -> Intrinsics {
    let c = &scenario.camera;
    Intrinsics {
        fx: c.fx,
        fy: c.fy,
        cx: c.cx,
        cy: c.cy,
        width: c.width,
        height: c.height,
    }
}

/// Plans every frame of a (validated) scenario.
pub fn plan_frames(scenario: &Scenario, trajectory: &Trajectory) -> anyhow::Result<Vec<FramePlan>> {
    let clip = &scenario.clip;
    let k = intrinsics(scenario);
    let mut clip_rng = Random::new(scenario.seed, Purpose::Clip, 0);
    let law = AttitudeLaw::new(&scenario.attitude, &mut clip_rng);
    // The first station's mount draws on after the attitude, as a one-station clip's does.
    let mut station_rng = Random::new(scenario.station_seed(), Purpose::Clip, 0);
    let tracker_rng = match scenario.camera.station_stream {
        0 => &mut clip_rng,
        _ => &mut station_rng,
    };
    let tracker = Tracker::new(&scenario.camera, k, scenario.station_seed(), tracker_rng);

    let first = libm::round(clip.start_time_s * clip.frame_rate_hz) as u64;
    let frames: Vec<u64> = (0..u64::from(clip.frames))
        .map(|i| first + i * u64::from(clip.keep_every))
        .collect();
    let times: Vec<f64> = frames
        .iter()
        .map(|&n| n as f64 / clip.frame_rate_hz)
        .collect();
    let last = times.last().copied().unwrap_or(0.0);
    if last >= trajectory.impact_time_s() {
        bail!(
            "the clip runs to t = {last:.2} s but the projectile lands at t = {:.2} s: \
             fewer frames, a smaller keep_every or an earlier start_time_s",
            trajectory.impact_time_s()
        );
    }
    let states = trajectory.states(&times);

    frames
        .iter()
        .zip(&times)
        .zip(&states)
        .map(|((&frame, &t), state)| {
            let camera = tracker.camera(state.position, t);
            let r_wb = law.body_to_world(t, state.velocity);
            let body = BodyPose {
                translation: camera.to_camera(state.position),
                rotation: camera.r_cw * r_wb,
            };
            let target_px = k.project(body.translation).ok_or_else(|| {
                anyhow::anyhow!("frame {frame}: the projectile is behind the camera")
            })?;
            ensure!(
                (0.0..f64::from(k.width)).contains(&target_px.0)
                    && (0.0..f64::from(k.height)).contains(&target_px.1),
                "frame {frame}: the target at {target_px:?} px is outside the full frame"
            );
            let range = body.translation.norm();
            let range_m = match scenario.sensor.range_sensor {
                RangeSensor::Known => {
                    let mut rng = Random::new(scenario.station_seed(), Purpose::Range, frame);
                    Some(range + scenario.sensor.range_noise_m * rng.gaussian())
                }
                RangeSensor::Unknown => None,
            };
            Ok(FramePlan {
                frame,
                time_s: t,
                camera,
                body_world: state.position,
                velocity_world: state.velocity,
                body_axes_world: r_wb,
                body,
                attitude: body.attitude(),
                target_px,
                chip_origin: tracker.chip_origin(target_px, t, frame),
                range_m,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::math::rad;
    use crate::sim::presets;

    fn small_plan() -> Vec<FramePlan> {
        let mut s = presets::preset("table1-test").unwrap();
        s.clip.frames = 40;
        s.clip.keep_every = 4;
        let trajectory = Trajectory::new(&s.trajectory).unwrap();
        plan_frames(&s, &trajectory).unwrap()
    }

    #[test]
    fn pose_from_world_geometry_round_trips_through_the_spec_convention() {
        for p in small_plan() {
            // Spec angles back to R_CB reproduce the world-built rotation.
            let rebuilt = p.attitude.rotation_cb();
            assert!(
                rebuilt.max_abs_diff(&p.body.rotation) < 1e-12,
                "frame {}",
                p.frame
            );
            // The spec's nose-direction formula gives the world nose seen from the camera.
            let nose_camera = p.camera.r_cw * p.body_axes_world.col(0);
            assert!((p.attitude.nose_direction() - nose_camera).norm() < 1e-12);
            // Yaw > 0 puts the nose to the image right, pitch > 0 puts it up.
            let k = intrinsics(&presets::preset("table1-test").unwrap());
            let tip = k
                .project(p.body.to_camera(Vec3::new(0.689, 0.0, 0.0)))
                .unwrap();
            let tail = k
                .project(p.body.to_camera(Vec3::new(-0.689, 0.0, 0.0)))
                .unwrap();
            assert!((tip.0 - tail.0) * libm::sin(rad(p.attitude.yaw_deg)) > 0.0);
            assert!((tail.1 - tip.1) * p.attitude.pitch_deg > 0.0);
            // T is the body origin seen from the camera; its norm is the range.
            let back = p.camera.position + p.camera.r_cw.transpose() * p.body.translation;
            assert!((back - p.body_world).norm() < 1e-9);
            assert_eq!(p.range_m, Some(p.body.translation.norm()));
        }
    }

    #[test]
    fn chip_contains_the_target_off_centre() {
        let plans = small_plan();
        let mut offsets = Vec::new();
        for p in &plans {
            let (x0, y0) = p.chip_origin;
            let (u, v) = p.target_px;
            let (du, dv) = (u - (x0 as f64 + 127.5), v - (y0 as f64 + 127.5));
            assert!(
                du.abs() <= 30.5 && dv.abs() <= 30.5,
                "frame {}: {du}, {dv}",
                p.frame
            );
            offsets.push(libm::sqrt(du * du + dv * dv));
            // The mount's pointing error moves the target off the principal point.
            let wander = libm::sqrt((u - 1023.5) * (u - 1023.5) + (v - 1023.5) * (v - 1023.5));
            assert!(wander <= 250.0 * std::f64::consts::SQRT_2 + 1.0);
        }
        let mean = offsets.iter().sum::<f64>() / offsets.len() as f64;
        assert!(
            mean > 5.0,
            "the target sits too close to the chip centre: {mean} px"
        );
        assert!(offsets.iter().filter(|&&o| o > 10.0).count() > plans.len() / 4);
        let frames: Vec<u64> = plans.iter().map(|p| p.frame).collect();
        assert!(frames.windows(2).all(|w| w[1] == w[0] + 4));
    }
}
