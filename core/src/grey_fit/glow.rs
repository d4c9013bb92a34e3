//! The plume's light next to the tail: a Gaussian on the projected axis, with its own sigmas along
//! and across it, centred one sigma along beyond the base.
//!
//! A bright plume lies behind the base: where the body is nearer, the body hides it, and the
//! blur carries its light across the base's edge onto the tail; where the plume is nearer (a base
//! turned towards the camera, the gas ahead of the nozzle, the optics' halo) it glows over the
//! body too. Left out of the fit, either shortens the body's dark tail: a finless body, whose
//! tilt only its length can tell, then reads its tilt degrees off. The fit gives the glow one
//! shape (the logs of its sigmas in body diameters; its place follows the base) and two peaks,
//! one hidden by the body and one in front of it (signed: smoke darkens).

/// The glow's centre beyond the base centre, in its sigmas along the axis.
const CENTRE_BEYOND_BASE: f32 = 1.0;

/// The glow's sigmas at the fit's start, body diameters.
pub const START_WIDTH_DIAMETERS: f32 = 0.4;

/// The least and largest sigma of the glow fitted, body diameters.
pub const WIDTH_RANGE_DIAMETERS: (f32, f32) = (0.3, 3.0);

/// The least sigma of the glow fitted, in blur sigmas: a glow no wider than the blur would
/// draw the tail's edge itself.
pub const MIN_SIGMA_BLURS: f32 = 3.0;

/// The glow of unit peak at one point, and its derivatives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GlowImage {
    /// The glow's value there.
    pub shape: f32,
    /// Its derivatives in the point's `u` and `v`, per m.
    pub d_u: f32,
    /// See `d_u`.
    pub d_v: f32,
    /// Its derivatives in the logs of the sigmas along and across the axis.
    pub d_log_sigmas: [f32; 2],
}

/// Where the glow lies: its widths along and across the axis and the body's base along it, m.
/// Found once per rendering of the window (the widths are exponentials, the base a cosine:
/// software floating point on the M4F), then [`GlowPlace::image`] at each point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GlowPlace {
    /// The widths along and across the axis, m.
    pub sigmas_m: [f32; 2],
    /// The base's place along the axis, m.
    pub base_u_m: f32,
}

impl GlowPlace {
    /// The glow's image at silhouette-frame point `(u, v)`, m ([`glow_image`]).
    pub fn image(&self, u: f32, v: f32) -> GlowImage {
        glow_image(self.sigmas_m, self.base_u_m, u, v)
    }
}

/// The glow of unit peak and sigmas `sigmas_m` (along and across the axis, m) beyond a base
/// centred at `base_u_m` on the axis, at the silhouette-frame point `(u, v)` (m, `u` towards
/// the nose).
pub fn glow_image(sigmas_m: [f32; 2], base_u_m: f32, u: f32, v: f32) -> GlowImage {
    let (inv_along, inv_across) = (1.0 / sigmas_m[0], 1.0 / sigmas_m[1]);
    // Along from the glow's centre, which lies beyond the base, away from the nose.
    let a = (u - base_u_m) * inv_along + CENTRE_BEYOND_BASE;
    let b = v * inv_across;
    let shape = libm::expf(-0.5 * (a * a + b * b));
    GlowImage {
        shape,
        d_u: -shape * a * inv_along,
        d_v: -shape * b * inv_across,
        // d/d(log s) of -(a² + b²)/2, with a = (u - base)/s_along + κ and b = v/s_across.
        d_log_sigmas: [shape * (a - CENTRE_BEYOND_BASE) * a, shape * b * b],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The analytic derivatives agree with central differences.
    #[test]
    fn the_derivatives_match_differences() {
        let (sigmas, base) = ([0.08f32, 0.05f32], -0.3f32);
        for (u, v) in [(-0.28f32, 0.01f32), (-0.35, -0.03), (-0.2, 0.04)] {
            let g = glow_image(sigmas, base, u, v);
            let h = 1e-4f32;
            let at = |u: f32, v: f32, s: [f32; 2]| glow_image(s, base, u, v).shape;
            let d_u = (at(u + h, v, sigmas) - at(u - h, v, sigmas)) / (2.0 * h);
            let d_v = (at(u, v + h, sigmas) - at(u, v - h, sigmas)) / (2.0 * h);
            let k = 1e-3f32;
            let scaled = |i: usize, f: f32| {
                let mut s = sigmas;
                s[i] *= libm::expf(f);
                s
            };
            let d_s =
                [0, 1].map(|i| (at(u, v, scaled(i, k)) - at(u, v, scaled(i, -k))) / (2.0 * k));
            for (analytic, numeric) in [
                (g.d_u, d_u),
                (g.d_v, d_v),
                (g.d_log_sigmas[0], d_s[0]),
                (g.d_log_sigmas[1], d_s[1]),
            ] {
                assert!(
                    (analytic - numeric).abs() <= 1e-2 * numeric.abs().max(0.1),
                    "{analytic} vs {numeric} at ({u}, {v})"
                );
            }
        }
    }

    /// The glow peaks one sigma along beyond the base, on the axis, and is exp(-1/2) of that at the
    /// base.
    #[test]
    fn the_glow_peaks_beyond_the_base() {
        let (sigmas, base) = ([0.08f32, 0.05f32], -0.3f32);
        let peak = glow_image(sigmas, base, base - sigmas[0], 0.0).shape;
        assert!((peak - 1.0).abs() < 1e-6);
        let at_base = glow_image(sigmas, base, base, 0.0).shape;
        assert!((at_base - libm::expf(-0.5)).abs() < 1e-6);
    }
}
