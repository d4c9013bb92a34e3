//! The a priori 3D model of the projectile, as data: a model file (`imade-model/1`, [`format`])
//! validated once and read in place, from flash on the firmware or from memory on the host.
//!
//! The model is a body of revolution given by its radius profile (piecewise linear, from the
//! nose tip to the base: any nose, cylinder or none, boat tail or none) and, optionally, a set of
//! identical flat fins evenly spaced in roll with a trapezoidal planform; the file can carry the
//! model's silhouette table (`imade-lut/1`). No stage assumes more than that.
//!
//! Body frame B (`docs/geometry.md`): origin at the middle of the overall length, +x_B along the
//! axis towards the nose. Stations `s` are measured aft of the nose tip: `x_B = L/2 - s`.

pub mod format;

use crate::bytes::{f32_at, text_at, u16_at};
use crate::lut::table::Table;
pub use format::ModelError;
use format::{FIELD, HEADER_LEN, MODEL_ID_LEN};

/// A radius at or above this fraction of the body's radius counts as the full diameter (the
/// cylinder the table match measures its cross-section on).
const FULL_RADIUS: f32 = 0.999;

/// A radius at or above this fraction of the body's radius counts as wide: where a body whose
/// full diameter is too short to measure (a tapered mortar) has its cross-section measured,
/// the diameter then corrected with the model's mean radius there ([`ProjectileModel::wide_s`]).
const WIDE_RADIUS: f32 = 0.75;

/// Samples of the radius profile in [`ProjectileModel::mean_radius_m`].
const MEAN_RADIUS_SAMPLES: usize = 16;

/// The fins: identical flat plates evenly spaced in roll, each with a trapezoidal planform whose
/// root chord lies on the body.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Fins {
    /// Number of fins (at least 1).
    pub count: u8,
    /// Root chord's leading and trailing edge, m aft of the nose tip.
    pub root_s: (f32, f32),
    /// Tip chord's leading and trailing edge, m aft of the nose tip.
    pub tip_s: (f32, f32),
    /// Distance of the tip chord from the axis, m.
    pub tip_radius_m: f32,
    /// Thickness, m.
    pub thickness_m: f32,
    /// Roll angle of fin 0 about +x_B from +y_B towards +z_B, deg.
    pub first_roll_deg: f32,
}

/// A validated model file, borrowed: its fields are read in place.
#[derive(Debug, Clone, Copy)]
pub struct ProjectileModel<'a> {
    bytes: &'a [u8],
    stations: usize,
    /// Overall length, nose tip to base, m.
    pub length_m: f32,
    /// Body diameter: the largest of the body of revolution, fins excluded, m.
    pub diameter_m: f32,
    /// Where the body is at its full diameter, m aft of the tip: from the nose's shoulder to the
    /// first station aft of it that narrows (a boat tail) or the fins' root leading edge.
    cylinder_s: (f32, f32),
    /// Where the body is at least [`WIDE_RADIUS`] of its full radius, likewise.
    wide_s: (f32, f32),
    table: Option<Table<'a>>,
}

impl<'a> ProjectileModel<'a> {
    /// Validates `bytes` as a model file (`imade-model/1`): magic, version, lengths, profile,
    /// fins, the embedded table (which must be for this model), and the checksum.
    pub fn parse(bytes: &'a [u8]) -> Result<ProjectileModel<'a>, ModelError> {
        let layout = format::check(bytes)?;
        let mut model = ProjectileModel {
            bytes,
            stations: layout.stations,
            length_m: f32_at(bytes, FIELD.length),
            diameter_m: f32_at(bytes, FIELD.diameter),
            cylinder_s: (0.0, 0.0),
            wide_s: (0.0, 0.0),
            table: None,
        };
        model.cylinder_s = model.stretch_at_least(FULL_RADIUS);
        model.wide_s = model.stretch_at_least(WIDE_RADIUS);
        if let Some(range) = layout.table {
            let table = Table::parse(bytes.get(range).unwrap_or(&[])).map_err(ModelError::Table)?;
            model.table = Some(table);
            if !model.matches_table(&table) {
                return Err(ModelError::TableModel);
            }
        }
        Ok(model)
    }

    /// The model id, as named in `clip.json`.
    pub fn id(&self) -> &'a str {
        text_at(self.bytes, FIELD.id, MODEL_ID_LEN)
    }

    /// The silhouette table the file carries, if any.
    pub fn table(&self) -> Option<Table<'a>> {
        self.table
    }

    /// True when `table` was built for this model (id and dimensions).
    pub fn matches_table(&self, table: &Table) -> bool {
        table.model_id() == self.id()
            && libm::fabsf(table.diameter_m() - self.diameter_m) <= 1e-6
            && libm::fabsf(table.length_m() - self.length_m) <= 1e-6
    }

    /// Body radius (half the diameter), m.
    pub fn radius_m(&self) -> f32 {
        0.5 * self.diameter_m
    }

    /// Stations of the radius profile.
    pub fn stations(&self) -> usize {
        self.stations
    }

    /// Station `i` of the radius profile: (m aft of the tip, radius m); (NaN, NaN) past the end.
    pub fn station(&self, i: usize) -> (f32, f32) {
        let at = HEADER_LEN + 8 * i;
        if i >= self.stations {
            return (f32::NAN, f32::NAN);
        }
        (f32_at(self.bytes, at), f32_at(self.bytes, at + 4))
    }

    /// Body radius (without fins) at `s` m aft of the nose tip, linear between stations; 0
    /// outside the body.
    pub fn radius_at(&self, s: f32) -> f32 {
        if !(0.0..=self.length_m).contains(&s) {
            return 0.0;
        }
        // The first station at or aft of s (stations increase strictly).
        let (mut lo, mut hi) = (0usize, self.stations.saturating_sub(1));
        while lo < hi {
            let mid = (lo + hi) / 2;
            if self.station(mid).0 < s {
                lo = mid + 1;
            } else {
                hi = mid;
            }
        }
        let (s1, r1) = self.station(lo);
        if lo == 0 || s1 <= s {
            return r1;
        }
        let (s0, r0) = self.station(lo - 1);
        r0 + (r1 - r0) * (s - s0) / (s1 - s0)
    }

    /// Radius of the base (the last station), m.
    pub fn base_radius_m(&self) -> f32 {
        self.station(self.stations.saturating_sub(1)).1
    }

    /// The fins, if the model has any.
    pub fn fins(&self) -> Option<Fins> {
        let count = u16_at(self.bytes, FIELD.fin_count);
        let f = |at| f32_at(self.bytes, at);
        (count > 0).then(|| Fins {
            count: count.min(u16::from(u8::MAX)) as u8,
            root_s: (f(FIELD.fin_root_le), f(FIELD.fin_root_te)),
            tip_s: (f(FIELD.fin_tip_le), f(FIELD.fin_tip_te)),
            tip_radius_m: f(FIELD.fin_tip_radius),
            thickness_m: f(FIELD.fin_thickness),
            first_roll_deg: f(FIELD.fin_first_roll),
        })
    }

    /// The roll between neighbouring fins, deg (360 over their count), which the body's roll is
    /// known modulo; None for a body without fins.
    pub fn fin_spacing_deg(&self) -> Option<f32> {
        self.fins().map(|f| 360.0 / f32::from(f.count.max(1)))
    }

    /// The rolls that give different silhouettes run from 0 to this, deg: half the fins' period
    /// (the silhouette is mirror-symmetric in roll), 0 for a body without fins, at most 90 (the
    /// table's rolls span [0, 90)).
    pub fn distinct_roll_deg(&self) -> f32 {
        self.fin_spacing_deg()
            .map_or(0.0, |spacing| (0.5 * spacing).min(90.0))
    }

    /// The largest distance of the model from its axis, fins included, m.
    pub fn max_radius_m(&self) -> f32 {
        let fins = self.fins().map_or(0.0, |f| f.tip_radius_m);
        self.radius_m().max(fins)
    }

    /// Where the body is at its full diameter, clear of the nose, a boat tail and the fins'
    /// roots: (start, end) m aft of the tip; start >= end where there is no such stretch.
    pub fn cylinder_s(&self) -> (f32, f32) {
        self.cylinder_s
    }

    /// Where the body is at least 75 % of its full radius, clear of the fins' roots: (start, end)
    /// m aft of the tip, as [`ProjectileModel::cylinder_s`]; it contains the cylinder.
    pub fn wide_s(&self) -> (f32, f32) {
        self.wide_s
    }

    /// The mean radius between `s0` and `s1` m aft of the tip (either order), m, over evenly
    /// spaced samples: a cross-section measured over a stretch where the radius varies has
    /// about twice this as its diameter.
    pub fn mean_radius_m(&self, s0: f32, s1: f32) -> f32 {
        let sum: f32 = self.radius_samples(s0, s1).sum();
        sum / MEAN_RADIUS_SAMPLES as f32
    }

    /// The body radius at [`MEAN_RADIUS_SAMPLES`] evenly spaced points between `s0` and `s1`
    /// m aft of the tip (the middles of equal steps), m.
    fn radius_samples(&self, s0: f32, s1: f32) -> impl Iterator<Item = f32> + '_ {
        (0..MEAN_RADIUS_SAMPLES).map(move |k| {
            let f = (k as f32 + 0.5) / MEAN_RADIUS_SAMPLES as f32;
            self.radius_at(s0 + (s1 - s0) * f)
        })
    }

    /// The smallest and the largest body radius between `s0` and `s1` m aft of the tip (either
    /// order), m, over the same evenly spaced samples as [`Self::mean_radius_m`].
    pub fn radius_extremes_m(&self, s0: f32, s1: f32) -> (f32, f32) {
        self.radius_samples(s0, s1)
            .fold((f32::INFINITY, 0.0f32), |(lo, hi), r| {
                (lo.min(r), hi.max(r))
            })
    }

    /// The full body diameter from a diameter `d` (any unit) measured over the stretch from
    /// `s0` to `s1` m aft of the tip: `d` itself inside the cylinder ([`Self::cylinder_s`]),
    /// else `d` scaled by the full radius over the stretch's mean ([`Self::mean_radius_m`]: a
    /// cross-section over a tapering stretch measures its mean diameter); None where that mean
    /// is not positive.
    pub fn full_diameter(&self, d: f32, s0: f32, s1: f32) -> Option<f32> {
        let (cylinder_start, cylinder_end) = self.cylinder_s;
        if s0 >= cylinder_start && s1 <= cylinder_end {
            return Some(d);
        }
        let mean_r = self.mean_radius_m(s0, s1);
        (mean_r > 0.0).then(|| d * self.radius_m() / mean_r)
    }

    /// The first contiguous stretch where the radius is at least `fraction` of the body's,
    /// ending at the fins' root leading edge at the latest.
    fn stretch_at_least(&self, fraction: f32) -> (f32, f32) {
        let full = fraction * self.radius_m();
        let mut start = None;
        let mut end = self.length_m;
        for i in 0..self.stations {
            let (s, r) = self.station(i);
            match start {
                None if r >= full => start = Some(s),
                Some(_) if r < full => {
                    end = s;
                    break;
                }
                _ => {}
            }
        }
        let end = self.fins().map_or(end, |f| end.min(f.root_s.0));
        (start.unwrap_or(self.length_m), end)
    }

    /// The nose's length, from the tip to where the body reaches its full diameter, m.
    pub fn nose_length_m(&self) -> f32 {
        self.cylinder_s.0.min(self.length_m)
    }

    /// Where a straight line fitted to the nose's silhouette width, between `lo` and `hi` of the
    /// body diameter, reaches zero width: metres aft of the true tip (negative: ahead of it).
    /// A convex nose extrapolates slightly ahead of its tip; the closed form uses this to correct
    /// its nose point.
    pub fn nose_ramp_zero_offset_m(&self, lo: f32, hi: f32) -> f32 {
        // Least-squares line w(s) over uniform samples of s where lo <= w/D <= hi, over the nose
        // (the profile up to the full diameter).
        const SAMPLES: usize = 200;
        let nose_length = self.nose_length_m();
        let (mut n, mut ss, mut sw, mut sss, mut ssw) = (0.0f32, 0.0, 0.0, 0.0, 0.0);
        for i in 0..SAMPLES {
            let s = nose_length * (i as f32 + 0.5) / SAMPLES as f32;
            let w = 2.0 * self.radius_at(s) / self.diameter_m;
            if (lo..=hi).contains(&w) {
                n += 1.0;
                ss += s;
                sw += w;
                sss += s * s;
                ssw += s * w;
            }
        }
        let det = n * sss - ss * ss;
        if n < 2.0 || libm::fabsf(det) < f32::EPSILON {
            return 0.0;
        }
        let slope = (n * ssw - ss * sw) / det;
        let intercept = (sw - slope * ss) / n;
        if libm::fabsf(slope) < f32::EPSILON {
            0.0
        } else {
            -intercept / slope
        }
    }
}

#[cfg(test)]
pub(crate) mod testing {
    //! The bundled reference model, for the core's unit tests.
    use super::ProjectileModel;

    /// The reference projectile's model file (`docs/projectile.md`), with its table.
    pub static REFERENCE_BYTES: &[u8] =
        include_bytes!("../../../fixtures/models/ref-1378x80.model");

    /// The reference projectile.
    pub fn reference() -> ProjectileModel<'static> {
        ProjectileModel::parse(REFERENCE_BYTES).expect("the bundled reference model is valid")
    }
}

#[cfg(test)]
mod tests {
    use super::testing::reference;

    #[test]
    fn the_reference_profile_is_the_tangent_ogive() {
        let m = reference();
        assert_eq!(m.id(), "ref-1378x80");
        assert_eq!((m.length_m, m.diameter_m), (1.378, 0.080));
        assert!(m.radius_at(0.0).abs() < 1e-4, "sharp tip");
        assert!(
            (m.radius_at(0.24) - 0.04).abs() < 1e-6,
            "tangent to the body"
        );
        assert!((m.radius_at(1.0) - 0.04).abs() < 1e-6);
        assert_eq!(m.radius_at(1.5), 0.0);
        // Hand value: s = 0.12 -> sqrt(0.5476 - 0.0144) + 0.04 - 0.74 = 0.030205.
        assert!((m.radius_at(0.12) - 0.030205).abs() < 2e-5);
        assert_eq!(m.base_radius_m(), 0.04);
        let fins = m.fins().expect("four fins");
        assert_eq!(fins.count, 4);
        assert!((fins.root_s.0 - 1.258).abs() < 1e-6 && fins.root_s.1 == 1.378);
        assert!((fins.tip_s.0 - 1.318).abs() < 1e-6 && fins.tip_s.1 == 1.378);
        assert_eq!((fins.tip_radius_m, fins.thickness_m), (0.1, 0.004));
        assert_eq!(m.max_radius_m(), 0.1);
        let (start, end) = m.cylinder_s();
        assert!(
            (start - 0.24).abs() < 0.01 && (end - 1.258).abs() < 1e-6,
            "{start} {end}"
        );
        assert!(m.table().is_some());
    }

    #[test]
    fn convex_nose_extrapolates_ahead_of_the_tip() {
        let off = reference().nose_ramp_zero_offset_m(0.2, 0.65);
        assert!(off < 0.0 && off > -0.03, "offset {off}");
    }
}
