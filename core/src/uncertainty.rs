//! The pose's one-sigma uncertainties: how precisely the image places the body's ends, carried
//! through the closed form to pitch and yaw.
//!
//! Pitch and yaw come from the projected nose-tail vector. Its direction in the image (the
//! in-plane angle, a turn about the line of sight) is known to `sqrt 2` end sigmas over the
//! apparent length, an end being as uncertain across the axis as along it; its length,
//! against the model's length at the slant range, gives the aspect (the angle between the axis
//! and the line of sight), `sin(aspect) = L_image R / (f L)`. A fractional error `e` of the
//! apparent length moves the aspect as a fractional error `e` of the range does, so both are
//! carried through together by solving the pose again at `R (1 ± e)`, which also holds near a
//! broadside view where the aspect's sensitivity has no linear form. Without a range sensor among
//! clutter two more fractions join them (`Pipeline`'s result): the image range's systematic error
//! there ([`UncertaintyConfig::cluttered_range_fraction`], also in `tz_sd_m`), and the fraction by
//! which the frame's own image range disagrees with the range taken. The sigmas are those of the
//! chosen candidate, not counting the choice between the mirror candidates (the results format's
//! definition): `yaw_resolved` says how sure that choice is.
//!
//! An end is an edge blurred by the optics (`sigma_b` px) of contrast `C` over sky noise
//! `sigma_n`, crossed by about a diameter (`d` px) of rows: the Cramer-Rao bound of an edge's
//! place is `sigma_n / C sqrt(2 sqrt(pi) sigma_b / d)` px. Ends are less clean than that bound
//! (the nose tapers to a point, shading and a plume glow over the base), hence a gain over it and
//! a floor.

use crate::closed_form::Attitude;
use crate::extremes::Silhouette;
use crate::grey_fit::{FinsSeen, GreyFitted};
use crate::pose::{attitude_of, nose_direction, wrap_deg};
use nalgebra::{UnitQuaternion, Vector3};

/// The uncertainty's tunables.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct UncertaintyConfig {
    /// An end's sigma over the Cramer-Rao bound of a straight edge of the body's diameter.
    pub end_gain: f32,
    /// The least sigma of an end, px ...
    pub min_end_sd_px: f32,
    /// ... and in body diameters: the shading of the nose and the base, and a plume's glow over
    /// the base, which the silhouette does not model, reach a fraction of the diameter.
    pub min_end_sd_diameters: f32,
    /// An end's sigma along the axis per px of the table match's rms width residual: a frame
    /// whose silhouette the model fits badly has its ends badly placed too.
    pub residual_gain: f32,
    /// Where the grey-level fit placed the ends: their sigma over the one of its covariance (the
    /// model's misfit, the sky's texture and the pixels' correlation through the blur, which the
    /// covariance does not count) ...
    pub fit_gain: f32,
    /// ... and where it shaded the fins' faces as their own, which leaves less of the model's
    /// misfit (with 3, table1-test's pitch was within two sigmas in 99.4 % of its frames).
    pub fit_faces_gain: f32,
    /// ... with at least this many px in quadrature ...
    pub fit_min_end_sd_px: f32,
    /// ... and along the axis at least this many body diameters, in quadrature (the ends'
    /// shading and a plume's glow, which the fit models only roughly).
    pub fit_min_end_sd_diameters: f32,
    /// The roll's sigma: the fit's covariance's times [`UncertaintyConfig::fit_gain`], with at
    /// least this many deg in quadrature where the fit shaded the fins' faces as their own
    /// (their thin plates and the body's shading as a quadratic, which it models only roughly:
    /// 86-100 % of the bundled clips' and an outside renderer's rolls with the range known lie
    /// within two sigmas) ...
    pub fit_min_roll_sd_deg: f32,
    /// ... and at least this many where it shaded them as the body (under a strong sun that
    /// turns the roll some 4-9 deg) ...
    pub fit_min_roll_sd_as_body_deg: f32,
    /// ... and the roll is reported only where that sigma is at most this, deg ...
    pub max_roll_sd_deg: f32,
    /// ... and the body is tilted at least this far out of the image plane, deg: seen
    /// broadside, fins turned either way cast the same outline.
    pub min_roll_tilt_deg: f32,
    /// Without a range sensor, among clutter (a cluttered sky beside the body, or terrain in
    /// the chip: [`crate::table_match::Measurement::among_clutter`]): the image range's
    /// systematic error, one sigma as a fraction of the range, in quadrature with the filters'
    /// sigma (which counts the clear sky's). Filaments along the body, a plume over its base and
    /// a ridge beside it widen the silhouette, and the image ranges read short for many frames
    /// together.
    pub cluttered_range_fraction: f32,
}

impl UncertaintyConfig {
    /// The defaults.
    pub const DEFAULT: UncertaintyConfig = UncertaintyConfig {
        end_gain: 3.0,
        min_end_sd_px: 0.1,
        min_end_sd_diameters: 0.08,
        residual_gain: 1.5,
        fit_gain: 3.0,
        fit_faces_gain: 2.5,
        fit_min_end_sd_px: 0.05,
        fit_min_end_sd_diameters: 0.03,
        fit_min_roll_sd_deg: 1.5,
        fit_min_roll_sd_as_body_deg: 5.0,
        max_roll_sd_deg: 10.0,
        min_roll_tilt_deg: 5.0,
        cluttered_range_fraction: 0.2,
    };
}

impl Default for UncertaintyConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// One sigma of the place of an end of the silhouette, px, along the axis and across it.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EndSd {
    /// Along the axis (the apparent length's share), px.
    pub along_px: f32,
    /// Across the axis (the in-plane angle's share), px: the edge's bound and the floor in px;
    /// the axis is fitted along the whole body, so the diameter's share does not apply.
    pub across_px: f32,
}

/// One sigma of an end of `silhouette` on a sky of noise `noise_sigma` (grey levels), where the
/// table match left an rms width residual of `residual_px` (px, where it ran); the floor where
/// the inputs give no finite figure.
pub fn end_sd(
    silhouette: &Silhouette,
    noise_sigma: f32,
    residual_px: Option<f32>,
    config: &UncertaintyConfig,
) -> EndSd {
    let bound = noise_sigma / silhouette.contrast
        * libm::sqrtf(
            2.0 * libm::sqrtf(core::f32::consts::PI) * silhouette.sigma_px / silhouette.diameter_px,
        );
    let edge = config.end_gain * bound;
    let floor = config.min_end_sd_px;
    let unmodelled = config.min_end_sd_diameters * silhouette.diameter_px;
    let misfit = config.residual_gain * residual_px.unwrap_or(0.0);
    let across = libm::sqrtf(edge * edge + floor * floor);
    let along = libm::sqrtf(across * across + unmodelled * unmodelled + misfit * misfit);
    if along.is_finite() {
        EndSd {
            along_px: along,
            across_px: across,
        }
    } else {
        EndSd {
            along_px: floor,
            across_px: floor,
        }
    }
}

/// One sigma of an end placed by the grey-level fit `fitted` of a body `diameter_px` wide: its
/// covariance's sigmas of the length and of the axis's angle times
/// [`UncertaintyConfig::fit_gain`] (or [`UncertaintyConfig::fit_faces_gain`] where the fins'
/// faces were shaded as their own), with [`UncertaintyConfig::fit_min_end_sd_px`] in
/// quadrature, and along the axis also
/// [`UncertaintyConfig::fit_min_end_sd_diameters`]; None where the fit has no finite covariance.
pub fn fitted_end_sd(
    fitted: &GreyFitted,
    diameter_px: f32,
    config: &UncertaintyConfig,
) -> Option<EndSd> {
    let length_px = (fitted.ends[0] - fitted.ends[1]).norm();
    // Two ends: the length's variance is twice an end's, the angle's twice an end's over the
    // length squared.
    let gain = match fitted.fins_seen {
        FinsSeen::Faces => config.fit_faces_gain,
        FinsSeen::AsBody | FinsSeen::Barely => config.fit_gain,
    };
    let along = gain * fitted.length_sd_px * core::f32::consts::FRAC_1_SQRT_2;
    let across = gain * fitted.turn_sd_rad * length_px * core::f32::consts::FRAC_1_SQRT_2;
    let floor = config.fit_min_end_sd_px;
    let unmodelled = config.fit_min_end_sd_diameters * diameter_px;
    let sd = EndSd {
        along_px: libm::sqrtf(along * along + floor * floor + unmodelled * unmodelled),
        across_px: libm::sqrtf(across * across + floor * floor),
    };
    (sd.along_px.is_finite() && sd.across_px.is_finite()).then_some(sd)
}

/// One sigma of the roll the grey-level fit `fitted` measured, deg: its covariance's times
/// [`UncertaintyConfig::fit_gain`] with [`UncertaintyConfig::fit_min_roll_sd_deg`] (or, where
/// the fins were shaded as the body, [`UncertaintyConfig::fit_min_roll_sd_as_body_deg`]) in
/// quadrature; None where it has none (a model without fins), where the fins barely showed (a
/// faint body, a cluttered sky: [`FinsSeen::Barely`]), where it exceeds
/// [`UncertaintyConfig::max_roll_sd_deg`] or where the fitted tilt is below
/// [`UncertaintyConfig::min_roll_tilt_deg`].
pub fn fitted_roll_sd(fitted: &GreyFitted, config: &UncertaintyConfig) -> Option<f32> {
    let gained = config.fit_gain * fitted.roll_sd_deg;
    let floor = match fitted.fins_seen {
        FinsSeen::Faces => config.fit_min_roll_sd_deg,
        FinsSeen::AsBody => config.fit_min_roll_sd_as_body_deg,
        FinsSeen::Barely => return None,
    };
    let sd = libm::sqrtf(gained * gained + floor * floor);
    (sd <= config.max_roll_sd_deg && fitted.view.tilt_deg >= config.min_roll_tilt_deg).then_some(sd)
}

/// Variances of pitch and yaw, deg², summed term by term.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AngleVariance {
    pitch: f32,
    yaw: f32,
}

impl AngleVariance {
    /// Adds the square of half the gap between two attitudes (solved at either end of an
    /// interval of one sigma each way).
    pub fn add_half_gap(&mut self, a: &Attitude, b: &Attitude) {
        let pitch = 0.5 * (a.pitch_deg - b.pitch_deg);
        let yaw = 0.5 * wrap_deg(a.yaw_deg - b.yaw_deg);
        self.pitch += pitch * pitch;
        self.yaw += yaw * yaw;
    }

    /// Adds the in-plane angle's sigma `sd_rad`: the attitude turned that far either way about
    /// the line of sight `los` (camera frame C, any length).
    pub fn add_in_plane(&mut self, attitude: &Attitude, los: Vector3<f32>, sd_rad: f32) {
        let nose = nose_direction(attitude.pitch_deg, attitude.yaw_deg);
        let turned = |angle: f32| {
            let (pitch_deg, yaw_deg) =
                attitude_of(&(UnitQuaternion::from_scaled_axis(los.normalize() * angle) * nose));
            Attitude { pitch_deg, yaw_deg }
        };
        if los.norm() > 0.0 && sd_rad.is_finite() {
            self.add_half_gap(&turned(sd_rad), &turned(-sd_rad));
        }
    }

    /// One sigma of pitch and yaw, deg.
    pub fn sd_deg(&self) -> (f32, f32) {
        (libm::sqrtf(self.pitch), libm::sqrtf(self.yaw))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::extremes::Axis;
    use crate::point::ImagePoint;

    fn silhouette(contrast: f32, sigma_px: f32, diameter_px: f32) -> Silhouette {
        Silhouette {
            axis: Axis {
                centre: ImagePoint::new(64.0, 64.0),
                dir: ImagePoint::new(1.0, 0.0),
            },
            nose_t: 40.0,
            nose_ramp_offset_m: 0.0,
            tail_t: -40.0,
            diameter_px,
            contrast,
            sigma_px,
            nose_evidence: 0.0,
            plume_at_tail: false,
        }
    }

    /// By hand: ends 100 px apart, the fit's length sigma 0.1 px and angle sigma 1 mrad, gain 3,
    /// floor 0.1 px, 0.03 of an 8-px diameter along: along sqrt(0.2121² + 0.1² + 0.24²),
    /// across sqrt(0.2121² + 0.1²).
    #[test]
    fn a_fitted_end_sigma_is_the_covariance_with_gain_and_floors() {
        let fitted = GreyFitted {
            ends: [ImagePoint::new(100.0, 0.0), ImagePoint::new(0.0, 0.0)],
            px_per_m: 100.0,
            range_m: 1000.0,
            scale_sd: 0.0,
            length_sd_px: 0.1,
            turn_sd_rad: 1e-3,
            roll_sd_deg: 2.0,
            fins_seen: FinsSeen::Faces,
            view: crate::lut::render::View {
                tilt_deg: 10.0,
                roll_deg: 0.0,
            },
            sigma_px: 1.0,
            shading: [-100.0, 0.0, 0.0],
            glow: [0.0; 4],
            rms: 2.0,
            pixels: 1000,
            iterations: 5,
        };
        let config = UncertaintyConfig {
            fit_faces_gain: 3.0,
            fit_min_end_sd_px: 0.1,
            fit_min_end_sd_diameters: 0.03,
            ..UncertaintyConfig::DEFAULT
        };
        let sd = fitted_end_sd(&fitted, 8.0, &config).unwrap();
        let g = 0.3 / core::f32::consts::SQRT_2;
        let along = libm::sqrtf(g * g + 0.01 + 0.24 * 0.24);
        let across = libm::sqrtf(g * g + 0.01);
        assert!((sd.along_px - along).abs() < 1e-5, "{sd:?} vs {along}");
        assert!((sd.across_px - across).abs() < 1e-5, "{sd:?} vs {across}");
        let unmeasured = GreyFitted {
            turn_sd_rad: f32::NAN,
            ..fitted
        };
        assert_eq!(fitted_end_sd(&unmeasured, 8.0, &config), None);
        // Fins shaded as the body: the other gain, 1.5 here.
        let as_body = GreyFitted {
            fins_seen: FinsSeen::AsBody,
            ..fitted
        };
        let config_as_body = UncertaintyConfig {
            fit_gain: 1.5,
            ..config
        };
        let sd = fitted_end_sd(&as_body, 8.0, &config_as_body).unwrap();
        let g = 0.15 / core::f32::consts::SQRT_2;
        let across = libm::sqrtf(g * g + 0.01);
        assert!((sd.across_px - across).abs() < 1e-5, "{sd:?} vs {across}");
        // The roll: 2 deg times 3, with 1.5 deg in quadrature where the fins' faces were
        // shaded as their own, 5 where as the body; none beyond 10 deg, nearer broadside than
        // 5 deg of tilt, or where the fins barely showed.
        let roll = |f: &GreyFitted| fitted_roll_sd(f, &UncertaintyConfig::DEFAULT);
        let faces = roll(&fitted).unwrap();
        assert!((faces - libm::sqrtf(36.0 + 2.25)).abs() < 1e-5, "{faces}");
        let body = roll(&as_body).unwrap();
        assert!((body - libm::sqrtf(36.0 + 25.0)).abs() < 1e-5, "{body}");
        let loose = GreyFitted {
            roll_sd_deg: 3.2,
            ..as_body
        };
        assert_eq!(roll(&loose), None);
        let broadside = GreyFitted {
            view: crate::lut::render::View {
                tilt_deg: 4.0,
                roll_deg: 0.0,
            },
            ..fitted
        };
        assert_eq!(roll(&broadside), None);
        let barely = GreyFitted {
            fins_seen: FinsSeen::Barely,
            ..fitted
        };
        assert_eq!(roll(&barely), None);
    }

    /// The bound by hand: noise 2, contrast 40, blur 1 px, diameter 8 px:
    /// 0.05 sqrt(2 sqrt(pi) / 8) = 0.033284 px; times a gain of 3, with a floor of 0.1 px in
    /// quadrature across the axis, and along it also 0.05 diameters (0.4 px) and, at a gain of
    /// 1, the match's residual of 0.3 px.
    #[test]
    fn an_end_sigma_is_the_edge_bound_with_gain_and_floors() {
        let config = UncertaintyConfig {
            end_gain: 3.0,
            min_end_sd_px: 0.1,
            min_end_sd_diameters: 0.05,
            residual_gain: 1.0,
            ..UncertaintyConfig::DEFAULT
        };
        let sd = end_sd(&silhouette(40.0, 1.0, 8.0), 2.0, Some(0.3), &config);
        let across = libm::sqrtf(0.099852 * 0.099852 + 0.01);
        assert!((sd.across_px - across).abs() < 1e-4, "{sd:?} vs {across}");
        let along = libm::sqrtf(across * across + 0.16 + 0.09);
        assert!((sd.along_px - along).abs() < 1e-4, "{sd:?} vs {along}");
        // A fainter body places its ends worse, in proportion to noise over contrast.
        let faint = end_sd(&silhouette(4.0, 1.0, 8.0), 2.0, None, &config);
        let across = libm::sqrtf(0.99852 * 0.99852 + 0.01);
        assert!((faint.across_px - across).abs() < 1e-3, "{faint:?}");
        // Absurd inputs give the floor.
        let absurd = end_sd(&silhouette(0.0, 1.0, 8.0), 2.0, None, &config);
        assert_eq!((absurd.along_px, absurd.across_px), (0.1, 0.1));
    }

    /// Half gaps add in quadrature; yaw across the wrap counts the short way.
    #[test]
    fn half_gaps_add_in_quadrature() {
        let mut v = AngleVariance::default();
        let a = Attitude {
            pitch_deg: 10.0,
            yaw_deg: 179.0,
        };
        let b = Attitude {
            pitch_deg: 4.0,
            yaw_deg: -177.0,
        };
        v.add_half_gap(&a, &b);
        v.add_half_gap(&a, &b);
        let (pitch, yaw) = v.sd_deg();
        assert!((pitch - libm::sqrtf(18.0)).abs() < 1e-5, "{pitch}");
        assert!((yaw - libm::sqrtf(8.0)).abs() < 1e-4, "{yaw}");
    }

    /// A turn about the line of sight, worked by hand. Looking along +Z with the nose along +X
    /// (pitch 0, yaw 90), a turn of 0.01 rad moves the nose in the image plane: pitch by
    /// 0.573 deg, yaw not at all (first order). With the nose along the line of sight (yaw 0)
    /// the same turn changes nothing.
    #[test]
    fn an_in_plane_turn_moves_what_the_image_plane_holds() {
        let los = Vector3::new(0.0, 0.0, 1000.0);
        let mut across = AngleVariance::default();
        across.add_in_plane(
            &Attitude {
                pitch_deg: 0.0,
                yaw_deg: 90.0,
            },
            los,
            0.01,
        );
        let (pitch, yaw) = across.sd_deg();
        assert!((pitch - 0.5730).abs() < 1e-3, "{pitch}");
        assert!(yaw < 1e-3, "{yaw}");
        let mut along = AngleVariance::default();
        along.add_in_plane(
            &Attitude {
                pitch_deg: 0.0,
                yaw_deg: 0.0,
            },
            los,
            0.01,
        );
        let (pitch, yaw) = along.sd_deg();
        assert!(pitch < 1e-3 && yaw < 1e-3, "{pitch} {yaw}");
    }
}
