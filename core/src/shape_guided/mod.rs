//! Shape-guided segmentation, the source paper's third module (its Fig. 1): the shape prior (the
//! model's silhouette rendered at the estimated pose) guides a second segmentation of the chip,
//! which goes back to the profile match.
//!
//! Three methods, each moving the whole prior by one transform and drawing the moved prior as the
//! segmentation:
//!
//! | method | paper | transform | criterion |
//! | --- | --- | --- | --- |
//! | [`GuidedMethod::SisCut`] | Algorithm 2, Eq. 7 | affine, 7 parameters, Nelder-Mead | grey-level divergence between the region and its dilation ring |
//! | [`GuidedMethod::GvfAsm`] | Algorithm 1 | similarity, closed form, iterated | boundary points pushed along the gradient vector flow |
//! | [`GuidedMethod::Tetris`] | Section 4.3.3, Fig. 10 | affine, one pass of a trained network ([`tetris`]) | learned from simulated chips |
//!
//! Fixed memory: [`ShapeGuided`] owns every buffer (about 77 KiB at the capacities of
//! [`crate::capacity`], 40 KiB of it TETRIS's); the work is bounded by the configured iteration
//! counts. TETRIS's weights are borrowed ([`ShapeGuided::set_tetris`]), in flash on a target.

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
pub mod tetris;
pub mod warp;

pub use affine::{Affine2, AffineParams};
pub use gvf_asm::{GvfAsm, GvfAsmConfig, GvfAsmResult};
pub use prior::PriorShape;
pub use sis_cut::{SisCut, SisCutConfig, SisCutResult};
pub use tetris::{Tetris, TetrisConfig, TetrisResult, TetrisWeights};

use crate::chip::ChipView;
use crate::mask::BitMask;
use crate::table_match::GuidedMethod;
use warp::{WarpError, warp_prior};

/// The tunables of the methods.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ShapeGuidedConfig {
    /// SIS-Cut's.
    pub sis_cut: SisCutConfig,
    /// GVF-ASM's.
    pub gvf_asm: GvfAsmConfig,
    /// TETRIS's.
    pub tetris: TetrisConfig,
}

impl ShapeGuidedConfig {
    /// The defaults.
    pub const DEFAULT: ShapeGuidedConfig = ShapeGuidedConfig {
        sis_cut: SisCutConfig::DEFAULT,
        gvf_asm: GvfAsmConfig::DEFAULT,
        tetris: TetrisConfig::DEFAULT,
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
    /// TETRIS was asked for but no weights were given ([`ShapeGuided::set_tetris`]).
    NoWeights,
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
    /// mean normalized edge strength (0..1) under the boundary for GVF-ASM, the mean squared
    /// difference between the normalized chip and the prior over the network's crop for TETRIS.
    pub score_before: f32,
    /// The same criterion at the segmentation.
    pub score_after: f32,
    /// Work done: objective evaluations (SIS-Cut), move-and-fit iterations (GVF-ASM) or network
    /// passes (TETRIS).
    pub work: u32,
    /// Set pixels of the segmentation.
    pub area_px: usize,
}

/// The buffers of the methods and TETRIS's weights; the table-match stage owns one and calls
/// [`ShapeGuided::segment`].
#[derive(Debug, Clone)]
pub struct ShapeGuided {
    sis_cut: SisCut,
    gvf_asm: GvfAsm,
    tetris: Tetris,
    tetris_weights: Option<TetrisWeights<'static>>,
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
            tetris: Tetris::new(),
            tetris_weights: None,
        }
    }

    /// TETRIS runs with `weights` from now on.
    pub const fn set_tetris(&mut self, weights: TetrisWeights<'static>) {
        self.tetris_weights = Some(weights);
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
            GuidedMethod::Tetris => {
                let weights = self
                    .tetris_weights
                    .as_ref()
                    .ok_or(ShapeGuidedError::NoWeights)?;
                let r = self
                    .tetris
                    .run(chip, prior, &shape, weights, &config.tetris)?;
                let work = u32::from((r.passes_kept + 1).min(config.tetris.passes()));
                (r.transform, r.residual_before, r.residual_after, work)
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
    fn workspace_stays_under_80_kib() {
        let bytes = core::mem::size_of::<ShapeGuided>();
        assert!(bytes <= 80 * 1024, "{bytes} bytes");
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
