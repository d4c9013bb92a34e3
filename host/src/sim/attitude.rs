//! The body's attitude in the world: the nose cones about the velocity vector at a small,
//! nutating angle of attack, and the body rolls slowly about its axis.

use super::math::{Mat3, Vec3, rad};
use super::random::Random;
use super::scenario::AttitudeConfig;

/// World up (W is east, north, up).
const UP: Vec3 = Vec3::new(0.0, 0.0, 1.0);

/// The attitude law of one clip (its random phases drawn once).
#[derive(Debug, Clone, PartialEq)]
pub struct AttitudeLaw {
    angle_of_attack: f64,
    nutation: f64,
    coning_rate: f64,
    nutation_rate: f64,
    roll_rate: f64,
    coning_phase: f64,
    nutation_phase: f64,
    initial_roll: f64,
}

impl AttitudeLaw {
    /// The law of a scenario; phases (and the initial roll, unless given) come from `rng`.
    pub fn new(cfg: &AttitudeConfig, rng: &mut Random) -> AttitudeLaw {
        let tau = 2.0 * std::f64::consts::PI;
        let coning_phase = rng.between(0.0, tau);
        let nutation_phase = rng.between(0.0, tau);
        let random_roll = rng.between(0.0, tau);
        AttitudeLaw {
            angle_of_attack: rad(cfg.angle_of_attack_deg),
            nutation: rad(cfg.nutation_deg),
            coning_rate: tau / cfg.coning_period_s,
            nutation_rate: tau / cfg.nutation_period_s,
            roll_rate: rad(cfg.roll_rate_deg_s),
            coning_phase,
            nutation_phase,
            initial_roll: cfg.initial_roll_deg.map_or(random_roll, rad),
        }
    }

    /// R_WB at time `t` (s) for a body moving with `velocity` (W, m/s): its columns are the body
    /// axes x_B (nose), y_B, z_B in W.
    pub fn body_to_world(&self, t: f64, velocity: Vec3) -> Mat3 {
        let v = velocity.normalized();
        // A frame about the velocity: e1 horizontal (to its right), e2 "up" across it.
        let e1 = perpendicular_right(v);
        let e2 = e1.cross(v);
        let alpha = self.angle_of_attack
            + self.nutation * libm::sin(self.nutation_rate * t + self.nutation_phase);
        let phi = self.coning_rate * t + self.coning_phase;
        let nose =
            v * libm::cos(alpha) + (e1 * libm::cos(phi) + e2 * libm::sin(phi)) * libm::sin(alpha);
        // Roll reference: z0 is world up projected across the nose, y0 completes x, y, z.
        let z0 = (UP - nose * UP.dot(nose)).normalized();
        let y0 = z0.cross(nose);
        let psi = self.initial_roll + self.roll_rate * t;
        let (s, c) = (libm::sin(psi), libm::cos(psi));
        // Rx(psi) in the body: y_B -> c y0 + s z0, z_B -> -s y0 + c z0.
        Mat3::from_cols(nose, y0 * c + z0 * s, z0 * c - y0 * s)
    }
}

/// A horizontal unit vector perpendicular to `v`, to its right (north if `v` is vertical).
fn perpendicular_right(v: Vec3) -> Vec3 {
    let r = v.cross(UP);
    if r.norm() > 1e-9 {
        r.normalized()
    } else {
        Vec3::new(0.0, 1.0, 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::math::deg;
    use crate::sim::random::Purpose;

    #[test]
    fn nose_stays_within_the_angle_of_attack_and_the_frame_is_a_rotation() {
        let cfg = AttitudeConfig::default();
        let law = AttitudeLaw::new(&cfg, &mut Random::new(3, Purpose::Clip, 0));
        let v = Vec3::new(30.0, 150.0, 80.0);
        let mut largest: f64 = 0.0;
        for i in 0..400 {
            let r = law.body_to_world(f64::from(i) * 0.01, v);
            let rrt = r * r.transpose();
            assert!(rrt.max_abs_diff(&Mat3::IDENTITY) < 1e-12);
            assert!(
                (r.col(0).cross(r.col(1)) - r.col(2)).norm() < 1e-12,
                "right-handed"
            );
            let angle = deg(libm::acos(r.col(0).dot(v.normalized()).min(1.0)));
            assert!(angle <= cfg.angle_of_attack_deg + cfg.nutation_deg + 1e-9);
            largest = largest.max(angle);
        }
        assert!(largest > cfg.angle_of_attack_deg);
    }

    #[test]
    fn roll_turns_the_fins_at_the_roll_rate() {
        let cfg = AttitudeConfig {
            angle_of_attack_deg: 0.0,
            nutation_deg: 0.0,
            initial_roll_deg: Some(0.0),
            ..AttitudeConfig::default()
        };
        let law = AttitudeLaw::new(&cfg, &mut Random::new(3, Purpose::Clip, 0));
        let v = Vec3::new(0.0, 100.0, 0.0);
        // At t = 2 s, 90 deg of roll: +z_B is where -y_B was at launch.
        let t = 90.0 / cfg.roll_rate_deg_s;
        let r0 = law.body_to_world(0.0, v);
        let r1 = law.body_to_world(t, v);
        assert!((r1.col(2) + r0.col(1)).norm() < 1e-12);
        assert!((r0.col(2) - UP).norm() < 1e-12, "zero roll puts +z_B up");
    }
}
