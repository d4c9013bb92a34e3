//! Shape-guided segmentation, the source paper's third module (its Fig. 1): the shape prior (the
//! model's silhouette rendered at the estimated pose) guides a second segmentation of the chip,
//! which goes back to the profile match.
//!
//! Two methods, both moving the whole prior by one transform and drawing the moved prior as the
//! segmentation:
//!
//! | method | paper | transform | criterion |
//! | --- | --- | --- | --- |
//! | [`GuidedMethod::SisCut`] | Algorithm 2, Eq. 7 | affine, 7 parameters, Nelder-Mead | grey-level divergence between the region and its dilation ring |
//! | [`GuidedMethod::GvfAsm`] | Algorithm 1 | similarity, closed form, iterated | boundary points pushed along the gradient vector flow |
//!
//! Fixed memory: [`ShapeGuided`] owns every buffer (about 37 KiB at the capacities of
//! [`crate::capacity`]); the work is bounded by the configured iteration counts.

pub mod affine;
pub mod boundary;
pub mod grid;
pub mod gvf;
pub mod gvf_asm;
pub mod histogram;
pub mod nelder_mead;
pub mod prior;
pub mod similarity;
pub mod sis_cut;
pub mod warp;

pub use affine::{Affine2, AffineParams};
pub use gvf_asm::{GvfAsm, GvfAsmConfig, GvfAsmResult};
pub use prior::PriorShape;
pub use sis_cut::{SisCut, SisCutConfig, SisCutResult};

use crate::chip::ChipView;
use crate::mask::BitMask;
use crate::table_match::GuidedMethod;
use warp::{WarpError, warp_prior};

/// The tunables of both methods.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ShapeGuidedConfig {
    /// SIS-Cut's.
    pub sis_cut: SisCutConfig,
    /// GVF-ASM's.
    pub gvf_asm: GvfAsmConfig,
}

impl ShapeGuidedConfig {
    /// The defaults.
    pub const DEFAULT: ShapeGuidedConfig = ShapeGuidedConfig {
        sis_cut: SisCutConfig::DEFAULT,
        gvf_asm: GvfAsmConfig::DEFAULT,
    };
}

/// Why a guided segmentation could not be made (the caller keeps the prior as it was).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ShapeGuidedError {
    /// The prior has no pixel.
    EmptyPrior,
    /// The prior's size differs from the chip's.
    SizeMismatch,
    /// SIS-Cut: too few region or ring samples fall on the chip.
    NoBackground,
    /// GVF-ASM: no boundary point lies where the field is defined.
    NoEdges,
    /// A transform came out singular or not finite.
    Degenerate,
    /// The output mask does not fit its capacity.
    OutputTooLarge,
}

/// A guided segmentation: the transform that moves the prior onto the segmentation, and what it did.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GuidedSegmentation {
    /// The method that made it.
    pub method: GuidedMethod,
    /// Chip px to chip px: the segmentation is this map applied to the prior.
    pub transform: Affine2,
    /// Largest displacement of the corners of the prior's extent box (along and across its
    /// principal axis) under the transform, px.
    pub shift_px: f32,
    /// The method's own criterion at the prior as given: Eq. 7's divergence for SIS-Cut, the
    /// mean normalized edge strength (0..1) under the boundary for GVF-ASM.
    pub score_before: f32,
    /// The same criterion at the segmentation.
    pub score_after: f32,
    /// Work done: objective evaluations (SIS-Cut) or move-and-fit iterations (GVF-ASM).
    pub work: u32,
    /// Set pixels of the segmentation.
    pub area_px: usize,
}

/// The buffers of both methods; the table-match stage owns one and calls [`ShapeGuided::segment`].
#[derive(Debug, Clone)]
pub struct ShapeGuided {
    sis_cut: SisCut,
    gvf_asm: GvfAsm,
}

impl Default for ShapeGuided {
    fn default() -> Self {
        Self::new()
    }
}

impl ShapeGuided {
    /// Empty buffers.
    pub const fn new() -> Self {
        ShapeGuided {
            sis_cut: SisCut::new(),
            gvf_asm: GvfAsm::new(),
        }
    }

    /// Segments `chip` guided by `prior` (a chip-sized mask of the model's silhouette) with
    /// `method`, writing the moved prior into `out` (resized to the chip). On an error `out`
    /// is left empty or unchanged.
    pub fn segment<const W: usize>(
        &mut self,
        method: GuidedMethod,
        config: &ShapeGuidedConfig,
        chip: &ChipView,
        prior: &BitMask<W>,
        out: &mut BitMask<W>,
    ) -> Result<GuidedSegmentation, ShapeGuidedError> {
        if prior.width() != chip.width() || prior.height() != chip.height() {
            return Err(ShapeGuidedError::SizeMismatch);
        }
        let shape = PriorShape::measure(prior).ok_or(ShapeGuidedError::EmptyPrior)?;
        let (transform, score_before, score_after, work) = match method {
            GuidedMethod::SisCut => {
                let r = self.sis_cut.run(chip, prior, &shape, &config.sis_cut)?;
                (
                    r.transform,
                    r.divergence_before,
                    r.divergence_after,
                    r.evaluations,
                )
            }
            GuidedMethod::GvfAsm => {
                let r = self.gvf_asm.run(chip, prior, &shape, &config.gvf_asm)?;
                (r.transform, r.edge_before, r.edge_after, r.iterations)
            }
        };
        if !transform.is_finite() {
            return Err(ShapeGuidedError::Degenerate);
        }
        let area_px = warp_prior(prior, &shape, &transform, out).map_err(|e| match e {
            WarpError::Singular => ShapeGuidedError::Degenerate,
            WarpError::TooLarge(_) => ShapeGuidedError::OutputTooLarge,
        })?;
        let shift_px = shape
            .corners()
            .iter()
            .map(|&c| (transform.apply(c) - c).norm())
            .fold(0.0f32, f32::max);
        Ok(GuidedSegmentation {
            method,
            transform,
            shift_px,
            score_before,
            score_after,
            work,
            area_px,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mask::ChipMask;

    #[test]
    fn scratch_fits_the_firmware_budget() {
        let bytes = core::mem::size_of::<ShapeGuided>();
        assert!(bytes <= 40 * 1024, "{bytes} bytes");
    }

    #[test]
    fn method_names_round_trip() {
        for m in GuidedMethod::ALL {
            assert_eq!(m.as_str().parse::<GuidedMethod>(), Ok(m));
        }
        let unknown = "none".parse::<GuidedMethod>();
        assert_eq!(unknown, Err(crate::table_match::UnknownMethod));
    }

    #[test]
    fn rejects_mismatched_and_empty_priors() {
        let data = [0u8; 64];
        let chip = ChipView::gray8(&data, 8, 8, 8, 0, 0).unwrap();
        let mut prior = ChipMask::new();
        let mut out = ChipMask::new();
        let mut sg = ShapeGuided::new();
        let config = ShapeGuidedConfig::DEFAULT;
        prior.reset(8, 7).unwrap();
        for method in GuidedMethod::ALL {
            let r = sg.segment(method, &config, &chip, &prior, &mut out);
            assert_eq!(r, Err(ShapeGuidedError::SizeMismatch));
        }
        prior.reset(8, 8).unwrap();
        let r = sg.segment(GuidedMethod::GvfAsm, &config, &chip, &prior, &mut out);
        assert_eq!(r, Err(ShapeGuidedError::EmptyPrior));
    }
}
