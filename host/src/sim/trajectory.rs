//! The ballistic trajectory of the body origin, from the launcher to the target, in world frame W
//! (x east, y north, z up, m; t in s after launch).
//!
//! The muzzle speed comes from the range equation for the launch angle and the target's
//! horizontal distance and height; with drag (a = -g z - k |v| v) it is found by bisection so that
//! the trajectory still passes over the target, and the flight is integrated with fixed-step RK4.

use super::math::{Vec3, rad};
use super::scenario::TrajectoryConfig;
use anyhow::{bail, ensure};

/// Integration step with drag, s.
const STEP_S: f64 = 1e-3;
/// Bisection steps for the muzzle speed with drag (the bracket shrinks by 2^-44, far below
/// a micrometre per second).
const BISECTIONS: u32 = 44;

/// Position and velocity of the body origin in W.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct State {
    /// Position, m.
    pub position: Vec3,
    /// Velocity, m/s.
    pub velocity: Vec3,
}

/// A solved trajectory.
#[derive(Debug, Clone, PartialEq)]
pub struct Trajectory {
    launcher: Vec3,
    /// Horizontal unit vector from the launcher towards the target.
    heading: Vec3,
    launch_angle: f64,
    gravity: f64,
    drag: f64,
    muzzle_speed: f64,
    impact_time: f64,
}

impl Trajectory {
    /// Solves the trajectory of a scenario.
    pub fn new(cfg: &TrajectoryConfig) -> anyhow::Result<Trajectory> {
        let launcher = Vec3::from_array(cfg.launcher_m);
        let to_target = Vec3::from_array(cfg.target_m) - launcher;
        let horizontal = Vec3::new(to_target.x, to_target.y, 0.0);
        let dx = horizontal.norm();
        let dz = to_target.z;
        ensure!(
            dx > 1.0,
            "trajectory: the target must be downrange of the launcher"
        );
        let theta = rad(cfg.launch_angle_deg);
        let (st, ct) = (libm::sin(theta), libm::cos(theta));
        let denominator = 2.0 * ct * ct * (dx * st / ct - dz);
        if denominator <= 0.0 {
            bail!(
                "trajectory: a {} deg launch cannot reach a target {dz:.0} m higher at {dx:.0} m",
                cfg.launch_angle_deg
            );
        }
        let vacuum_speed = libm::sqrt(cfg.gravity_m_s2 * dx * dx / denominator);
        let mut trajectory = Trajectory {
            launcher,
            heading: horizontal.normalized(),
            launch_angle: theta,
            gravity: cfg.gravity_m_s2,
            drag: cfg.drag_per_m,
            muzzle_speed: vacuum_speed,
            impact_time: 0.0,
        };
        if trajectory.drag == 0.0 {
            let vz = vacuum_speed * st;
            trajectory.impact_time =
                (vz + libm::sqrt(vz * vz - 2.0 * trajectory.gravity * dz)) / trajectory.gravity;
        } else {
            trajectory.solve_with_drag(dx, dz)?;
        }
        Ok(trajectory)
    }

    /// Muzzle speed, m/s.
    pub fn muzzle_speed(&self) -> f64 {
        self.muzzle_speed
    }

    /// Time at which the body origin comes down to the target's height, s.
    pub fn impact_time_s(&self) -> f64 {
        self.impact_time
    }

    /// The states at the given times (s, ascending, within the flight).
    pub fn states(&self, times: &[f64]) -> Vec<State> {
        if self.drag == 0.0 {
            return times.iter().map(|&t| self.vacuum_state(t)).collect();
        }
        let mut state = self.initial_state();
        let mut now = 0.0;
        times
            .iter()
            .map(|&t| {
                while now < t {
                    let h = STEP_S.min(t - now);
                    state = self.rk4(state, h);
                    now += h;
                }
                state
            })
            .collect()
    }

    fn initial_state(&self) -> State {
        let (st, ct) = (libm::sin(self.launch_angle), libm::cos(self.launch_angle));
        State {
            position: self.launcher,
            velocity: (self.heading * ct + Vec3::new(0.0, 0.0, st)) * self.muzzle_speed,
        }
    }

    fn vacuum_state(&self, t: f64) -> State {
        let s = self.initial_state();
        let g = Vec3::new(0.0, 0.0, -self.gravity);
        State {
            position: s.position + s.velocity * t + g * (0.5 * t * t),
            velocity: s.velocity + g * t,
        }
    }

    fn acceleration(&self, v: Vec3) -> Vec3 {
        Vec3::new(0.0, 0.0, -self.gravity) - v * (self.drag * v.norm())
    }

    fn rk4(&self, s: State, h: f64) -> State {
        let k1v = self.acceleration(s.velocity);
        let k1x = s.velocity;
        let k2v = self.acceleration(s.velocity + k1v * (0.5 * h));
        let k2x = s.velocity + k1v * (0.5 * h);
        let k3v = self.acceleration(s.velocity + k2v * (0.5 * h));
        let k3x = s.velocity + k2v * (0.5 * h);
        let k4v = self.acceleration(s.velocity + k3v * h);
        let k4x = s.velocity + k3v * h;
        State {
            position: s.position + (k1x + k2x * 2.0 + k3x * 2.0 + k4x) * (h / 6.0),
            velocity: s.velocity + (k1v + k2v * 2.0 + k3v * 2.0 + k4v) * (h / 6.0),
        }
    }

    /// Flies the current muzzle speed until the body comes down through the target height;
    /// returns the horizontal distance travelled and the time, interpolated at the crossing.
    fn fly_to_height(&self, dz: f64) -> Option<(f64, f64)> {
        let mut state = self.initial_state();
        let mut now = 0.0;
        let limit = 4.0 * self.muzzle_speed / self.gravity + 10.0;
        while now < limit {
            let next = self.rk4(state, STEP_S);
            let (z0, z1) = (
                state.position.z - self.launcher.z,
                next.position.z - self.launcher.z,
            );
            if next.velocity.z < 0.0 && z0 >= dz && z1 < dz {
                let f = (z0 - dz) / (z0 - z1);
                let d0 = (state.position - self.launcher).dot(self.heading);
                let d1 = (next.position - self.launcher).dot(self.heading);
                return Some((d0 + f * (d1 - d0), now + f * STEP_S));
            }
            state = next;
            now += STEP_S;
        }
        None
    }

    fn solve_with_drag(&mut self, dx: f64, dz: f64) -> anyhow::Result<()> {
        let (mut lo, mut hi) = (self.muzzle_speed, 20.0 * self.muzzle_speed);
        self.muzzle_speed = hi;
        match self.fly_to_height(dz) {
            Some((reach, _)) if reach >= dx => {}
            _ => bail!(
                "trajectory: with drag_per_m = {} the target is out of reach",
                self.drag
            ),
        }
        for _ in 0..BISECTIONS {
            self.muzzle_speed = 0.5 * (lo + hi);
            match self.fly_to_height(dz) {
                Some((reach, _)) if reach >= dx => hi = self.muzzle_speed,
                _ => lo = self.muzzle_speed,
            }
        }
        self.muzzle_speed = hi;
        let (_, time) = self
            .fly_to_height(dz)
            .ok_or_else(|| anyhow::anyhow!("trajectory: the solved flight does not come down"))?;
        self.impact_time = time;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config(drag: f64, target_z: f64) -> TrajectoryConfig {
        TrajectoryConfig {
            launcher_m: [10.0, -20.0, 5.0],
            target_m: [10.0 + 1800.0, -20.0 + 2400.0, 5.0 + target_z],
            launch_angle_deg: 39.0,
            gravity_m_s2: 9.81,
            drag_per_m: drag,
        }
    }

    #[test]
    fn vacuum_flight_lands_on_the_target() {
        for target_z in [0.0, 150.0, -80.0] {
            let cfg = config(0.0, target_z);
            let tr = Trajectory::new(&cfg).unwrap();
            let end = tr.states(&[tr.impact_time_s()])[0].position;
            let target = Vec3::from_array(cfg.target_m);
            assert!((end - target).norm() < 1e-6, "{end:?} vs {target:?}");
        }
        // Flat ground: the textbook range equation.
        let tr = Trajectory::new(&config(0.0, 0.0)).unwrap();
        let expected = libm::sqrt(9.81 * 3000.0 / libm::sin(rad(78.0)));
        assert!((tr.muzzle_speed() - expected).abs() < 1e-9);
    }

    #[test]
    fn drag_flight_lands_on_the_target_faster() {
        let cfg = config(4.5e-5, 0.0);
        let tr = Trajectory::new(&cfg).unwrap();
        let vacuum = Trajectory::new(&config(0.0, 0.0)).unwrap();
        assert!(tr.muzzle_speed() > vacuum.muzzle_speed());
        let end = tr.states(&[tr.impact_time_s()])[0].position;
        assert!(
            (end - Vec3::from_array(cfg.target_m)).norm() < 0.5,
            "{end:?}"
        );
        // The integrator agrees with the closed form when drag is negligible.
        let tiny = Trajectory::new(&config(1e-12, 0.0)).unwrap();
        let a = tiny.states(&[7.3])[0];
        let b = vacuum.states(&[7.3])[0];
        assert!((a.position - b.position).norm() < 1e-3);
    }
}
