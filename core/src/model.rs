//! The a priori 3D model of the projectile: the only place its dimensions live.
//!
//! Body frame B (`docs/geometry.md`): origin at the middle of the overall length, +x_B
//! along the axis towards the nose.

/// External geometry of a finned projectile with a tangent-ogive nose and a cylindrical body.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ProjectileModel {
    /// Model id, as named in `clip.json`.
    pub id: &'static str,
    /// Overall length, nose tip to tail base, m.
    pub length_m: f32,
    /// Body diameter, m.
    pub diameter_m: f32,
    /// Length of the tangent-ogive nose, m.
    pub nose_length_m: f32,
    /// Number of identical fins, evenly spaced in roll.
    pub fin_count: u8,
    /// Distance of a fin tip from the axis, m.
    pub fin_tip_radius_m: f32,
    /// Fin root chord on the body, m (the trailing edge is flush with the base).
    pub fin_root_chord_m: f32,
    /// Fin tip chord, m.
    pub fin_tip_chord_m: f32,
    /// Fin thickness, m.
    pub fin_thickness_m: f32,
}

/// The reference projectile `ref-1378x80` (`docs/projectile.md`).
pub const REF_1378X80: ProjectileModel = ProjectileModel {
    id: "ref-1378x80",
    length_m: 1.378,
    diameter_m: 0.080,
    nose_length_m: 0.240,
    fin_count: 4,
    fin_tip_radius_m: 0.100,
    fin_root_chord_m: 0.120,
    fin_tip_chord_m: 0.060,
    fin_thickness_m: 0.004,
};

/// The built-in models.
pub const BUILT_IN_MODELS: [ProjectileModel; 1] = [REF_1378X80];

/// The built-in model with this id.
pub fn built_in_model(id: &str) -> Option<&'static ProjectileModel> {
    BUILT_IN_MODELS.iter().find(|m| m.id == id)
}

impl ProjectileModel {
    /// Body radius, m.
    pub fn radius_m(&self) -> f32 {
        0.5 * self.diameter_m
    }

    /// Radius of the tangent ogive's generating arc, m: (R^2 + Ln^2) / (2 R).
    pub fn ogive_rho_m(&self) -> f32 {
        let r = self.radius_m();
        (r * r + self.nose_length_m * self.nose_length_m) / (2.0 * r)
    }

    /// Body radius (without fins) at distance `s` aft of the nose tip, m; 0 outside the body.
    pub fn radius_at(&self, s: f32) -> f32 {
        if !(0.0..=self.length_m).contains(&s) {
            return 0.0;
        }
        if s >= self.nose_length_m {
            return self.radius_m();
        }
        let rho = self.ogive_rho_m();
        let a = self.nose_length_m - s;
        libm::sqrtf((rho * rho - a * a).max(0.0)) + self.radius_m() - rho
    }

    /// Where a straight line fitted to the nose's silhouette width, between `lo` and `hi` of the
    /// body diameter, reaches zero width: metres aft of the true tip (negative: ahead of it).
    /// The ogive is convex, so the extrapolated tip lies slightly ahead of the real one; the
    /// closed form uses this to correct its nose point.
    pub fn nose_ramp_zero_offset_m(&self, lo: f32, hi: f32) -> f32 {
        // Least-squares line w(s) over uniform samples of s where lo <= w/D <= hi.
        const SAMPLES: usize = 200;
        let (mut n, mut ss, mut sw, mut sss, mut ssw) = (0.0f32, 0.0, 0.0, 0.0, 0.0);
        for i in 0..SAMPLES {
            let s = self.nose_length_m * (i as f32 + 0.5) / SAMPLES as f32;
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
        if n < 2.0 || det.abs() < f32::EPSILON {
            return 0.0;
        }
        let slope = (n * ssw - ss * sw) / det;
        let intercept = (sw - slope * ss) / n;
        if slope.abs() < f32::EPSILON {
            0.0
        } else {
            -intercept / slope
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ogive_matches_spec() {
        let m = REF_1378X80;
        // docs/projectile.md: rho = (R^2 + Ln^2) / (2R) = 0.740 m.
        assert!((m.ogive_rho_m() - 0.740).abs() < 1e-4);
        assert!(m.radius_at(0.0).abs() < 1e-4, "sharp tip");
        assert!(
            (m.radius_at(0.24) - 0.04).abs() < 1e-6,
            "tangent to the body"
        );
        assert!((m.radius_at(1.0) - 0.04).abs() < 1e-6);
        assert_eq!(m.radius_at(1.5), 0.0);
        // Hand value: s = 0.12 -> sqrt(0.5476 - 0.0144) + 0.04 - 0.74 = 0.030205.
        assert!((m.radius_at(0.12) - 0.030205).abs() < 1e-4);
    }

    #[test]
    fn convex_nose_extrapolates_ahead_of_the_tip() {
        let off = REF_1378X80.nose_ramp_zero_offset_m(0.2, 0.65);
        assert!(off < 0.0 && off > -0.03, "offset {off}");
    }

    #[test]
    fn finds_built_in_by_id() {
        assert_eq!(built_in_model("ref-1378x80"), Some(&REF_1378X80));
        assert_eq!(built_in_model("nope"), None);
    }
}
