//! The detection track across frames (the source paper's future direction 3): where the body
//! was in the chip, which way it lay and its polarity, carried to the next frame as a gate on
//! detection's candidates ([`TrackGate`]). The mount cuts each chip around its own track of the
//! projectile, so the body stays near where it was in the chip, give or take the mount's
//! tracking error, while its place in the full frame jumps with the mount's pointing.

use crate::config::BodyPolarity;
use crate::point::ImagePoint;
use crate::segment::{Target, TrackGate};

/// The track's tunables.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TrackConfig {
    /// The gate's radius around the last centre in the chip: this many px (the mount's tracking
    /// error between frames) ...
    pub gate_px: f32,
    /// ... plus this fraction of the body's last length.
    pub gate_length: f32,
    /// The largest angle between a candidate's axis and the track's, deg.
    pub gate_axis_deg: f32,
    /// A track whose last fix is older than this is dropped, s.
    pub max_age_s: f32,
}

impl TrackConfig {
    /// The defaults.
    pub const DEFAULT: TrackConfig = TrackConfig {
        gate_px: 30.0,
        gate_length: 0.25,
        gate_axis_deg: 20.0,
        max_age_s: 0.5,
    };
}

impl Default for TrackConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// One frame's detection.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Fix {
    time_s: f64,
    /// Centre, chip px.
    centre: ImagePoint,
    axis: ImagePoint,
    length_px: f32,
    polarity: BodyPolarity,
}

/// The track: the last fix of a frame with a pose.
#[derive(Debug, Clone, Default)]
pub struct Track {
    last: Option<Fix>,
}

impl Track {
    /// No track.
    pub const fn new() -> Self {
        Track { last: None }
    }

    /// Forgets the track (a new clip).
    pub fn reset(&mut self) {
        *self = Track::new();
    }

    /// The gate for a frame at `time_s`, in chip px; None without a recent fix.
    pub fn gate(&self, time_s: f64, config: &TrackConfig) -> Option<TrackGate> {
        let last = self.last?;
        let age = (time_s - last.time_s) as f32;
        if !(age > 0.0 && age <= config.max_age_s) {
            return None;
        }
        let gate = TrackGate {
            centre: last.centre,
            axis: last.axis,
            radius_px: config.gate_px + config.gate_length * last.length_px,
            min_axis_cos: libm::cosf(config.gate_axis_deg.to_radians()),
            polarity: last.polarity,
        };
        [
            gate.centre.x,
            gate.centre.y,
            gate.radius_px,
            gate.min_axis_cos,
        ]
        .iter()
        .all(|v| v.is_finite())
        .then_some(gate)
    }

    /// Takes the `target` of a frame at `time_s` that gave a pose as the track's newest fix.
    pub fn update(&mut self, time_s: f64, target: &Target) {
        let shape = &target.shape;
        self.last = Some(Fix {
            time_s,
            centre: shape.centre,
            axis: shape.axis,
            length_px: 2.0 * crate::segment::UNIFORM_BAR_HALF_SDS * shape.major_sd,
            polarity: target.polarity,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::segment::label::Moments;
    use crate::segment::select::Shape;

    /// A target whose mask is a horizontal bar of `length` px centred at (`x`, `y`), one row
    /// high, of `class` (-1 dark).
    fn bar(x: u16, y: u16, length: u16, class: i8) -> Target {
        let mut moments = Moments::empty(class);
        moments.add_run(
            y,
            x - length / 2,
            x + length / 2 - 1,
            -10.0 * f32::from(length),
            0,
        );
        Target {
            polarity: if class > 0 {
                BodyPolarity::Bright
            } else {
                BodyPolarity::Dark
            },
            moments,
            shape: Shape::of(&moments),
            parts: 1,
            components: 1,
            track: crate::segment::TrackUse::Fresh,
            found_by: crate::segment::FoundBy::Components,
        }
    }

    #[test]
    fn the_gate_admits_the_body_where_it_was_lying_its_way() {
        let config = TrackConfig::DEFAULT;
        let mut track = Track::new();
        assert!(track.gate(0.0, &config).is_none(), "no fix, no gate");
        track.update(1.0, &bar(100, 100, 60, -1));
        assert!(track.gate(1.0, &config).is_none(), "not after the fix");
        assert!(track.gate(2.0, &config).is_none(), "too old");
        let gate = track.gate(1.1, &config).expect("a recent fix gives a gate");
        // 30 px plus a quarter of the bar's length (sqrt 12 standard deviations: 60 px).
        assert!((gate.radius_px - 45.0).abs() < 0.5, "{}", gate.radius_px);
        assert!(
            gate.admits(&bar(120, 110, 50, -1).moments),
            "nearby, same way, dark"
        );
        assert!(!gate.admits(&bar(180, 100, 50, -1).moments), "too far");
        assert!(
            !gate.admits(&bar(100, 100, 50, 1).moments),
            "the other polarity"
        );
        let mut upright = Moments::empty(-1);
        for y in 80..120 {
            upright.add_run(y, 100, 100, -10.0, 0);
        }
        assert!(!gate.admits(&upright), "lying across the track's axis");
    }
}
