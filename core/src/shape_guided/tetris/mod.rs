//! 2D TETRIS (the source paper's Section 4.3.3, Fig. 10): a small convolutional network looks at
//! the chip and the shape prior, both resampled on a grid along the prior's axis
//! ([`input`]), and predicts the affine warp that moves the prior onto the body; the
//! segmentation is the prior so warped, always one model-shaped piece.
//!
//! The network ([`network`]: 38,958 parameters, 152 KiB of `f32` weights, 0.40 M
//! multiply-adds a pass) is trained on the host (`imade train tetris`) on simulated chips whose
//! priors are drawn at randomly perturbed true poses, and read here in place from its weights
//! file ([`weights`], `imade-tetris/1`).
//!
//! The warp, as the spatial transformer network that TETRIS builds on: the network's 6 outputs
//! `(a, b, c, d, e, f)` give the crop-normalized map `q = (I + [[a, b], [c, d]]) p + (e, f)`,
//! and the warped prior at crop point `p` is the prior at `q`. Zero outputs are the identity.
//!
//! The warp is kept only where it fits the chip better than the prior by more than the sky's
//! noise explains ([`check`]: the chip's own pixels in the crop, normalized as the network's
//! input, against the prior and the warped prior as the segmentation draws them). Else the prior
//! stands (the identity): a network trained on priors from far off to nearly right still moves a
//! right prior by a fraction of a pixel, which costs a thin body a tenth of its IoU. Where
//! configured ([`TetrisConfig::passes`]), a kept warp is followed by another pass around the
//! moved prior, which sees the body centred and refines the warp.

pub mod check;
pub mod input;
pub mod network;
pub mod weights;

pub use weights::{TetrisWeights, WeightsError};

use super::ShapeGuidedError;
use super::affine::Affine2;
use super::prior::PriorShape;
use crate::chip::ChipView;
use crate::mask::BitMask;
use check::PixelCheck;
use input::CropFrame;
use nalgebra::{Matrix2, Vector2};
use network::{Network, OUTPUTS};

/// The network's warp in the crop frame: the prior at crop point `q = linear p + offset` is the
/// segmentation at `p`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Warp {
    /// Linear part.
    pub linear: Matrix2<f32>,
    /// Offset, crop-normalized units.
    pub offset: Vector2<f32>,
}

impl Warp {
    /// The warp of the network's outputs.
    pub fn of_outputs(o: &[f32; OUTPUTS]) -> Warp {
        Warp {
            linear: Matrix2::new(1.0 + o[0], o[1], o[2], 1.0 + o[3]),
            offset: Vector2::new(o[4], o[5]),
        }
    }
}

/// TETRIS's tunables.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TetrisConfig {
    /// Most passes of the network a segmentation makes: each pass after the first crops around
    /// the prior as the passes before moved it and warps it further (1 to 8; 0 counts as 1).
    /// One by default: a second pass lifted the independent renderer's noisy chips (median IoU
    /// 0.711 -> 0.773) but lowered the Table 1 clip's refined masks in the loop (0.914 -> 0.894
    /// with the range, docs/shape-guided.md).
    pub passes: u8,
}

impl TetrisConfig {
    /// The defaults.
    pub const DEFAULT: TetrisConfig = TetrisConfig { passes: 1 };

    /// The passes to make: [`TetrisConfig::passes`] within 1 to 8.
    pub fn passes(&self) -> u8 {
        self.passes.clamp(1, 8)
    }
}

impl Default for TetrisConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// What a TETRIS segmentation did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TetrisResult {
    /// Chip px to chip px: the segmentation is the prior moved by it.
    pub transform: Affine2,
    /// Mean squared difference between the normalized chip pixels in the first pass's crop and
    /// the prior ([`check`]) ...
    pub residual_before: f32,
    /// ... and the prior as the last pass kept it.
    pub residual_after: f32,
    /// Passes whose warp was kept (0: the prior stands, the transform is the identity).
    pub passes_kept: u8,
}

/// The network's buffers (40 KiB).
#[derive(Debug, Clone, Default)]
pub struct Tetris {
    network: Network,
}

impl Tetris {
    /// Zeroed buffers.
    pub const fn new() -> Self {
        Tetris {
            network: Network::new(),
        }
    }

    /// Warps `prior` (measured as `shape`) onto the body in `chip` with the network `weights`,
    /// in up to `config.passes` passes; a pass whose warp does not fit the chip's pixels
    /// significantly better than its input ([`check`]) ends the segmentation.
    pub fn run<const W: usize>(
        &mut self,
        chip: &ChipView,
        prior: &BitMask<W>,
        shape: &PriorShape,
        weights: &TetrisWeights,
        config: &TetrisConfig,
    ) -> Result<TetrisResult, ShapeGuidedError> {
        let check = PixelCheck::new(chip, prior, CropFrame::around(shape, weights));
        let mut result = TetrisResult {
            transform: Affine2::IDENTITY,
            residual_before: f32::NAN,
            residual_after: f32::NAN,
            passes_kept: 0,
        };
        for pass in 0..config.passes() {
            let moved = if pass == 0 {
                *shape
            } else {
                shape
                    .moved(&result.transform)
                    .ok_or(ShapeGuidedError::Degenerate)?
            };
            let pull = result
                .transform
                .inverse()
                .ok_or(ShapeGuidedError::Degenerate)?;
            let step = self.pass(chip, prior, &moved, &pull, weights)?;
            // The new segmentation at x is the old one at step(x): the prior moves by its inverse.
            let push = step.inverse().ok_or(ShapeGuidedError::Degenerate)?;
            let transform = result.transform.then(&push);
            if !transform.is_finite() {
                return Err(ShapeGuidedError::Degenerate);
            }
            let comparison = check
                .compare(&result.transform, &transform)
                .ok_or(ShapeGuidedError::Degenerate)?;
            if pass == 0 {
                result.residual_before = comparison.current_mean();
                result.residual_after = result.residual_before;
            }
            if !comparison.candidate_is_better() {
                break;
            }
            result.transform = transform;
            result.residual_after = comparison.candidate_mean();
            result.passes_kept += 1;
        }
        Ok(result)
    }

    /// One pass of the network on the prior moved by the inverse of `pull` (whose shape is
    /// `moved`): its warp as a chip px map, the warped prior at chip x being the pass's input
    /// prior at the map's image of x.
    fn pass<const W: usize>(
        &mut self,
        chip: &ChipView,
        prior: &BitMask<W>,
        moved: &PriorShape,
        pull: &Affine2,
        weights: &TetrisWeights,
    ) -> Result<Affine2, ShapeGuidedError> {
        let frame = CropFrame::around(moved, weights);
        frame.fill(chip, prior, pull, self.network.input_mut());
        let warp = Warp::of_outputs(&self.network.run(weights));
        frame
            .chip_map(warp.linear, warp.offset)
            .filter(Affine2::is_finite)
            .ok_or(ShapeGuidedError::Degenerate)
    }
}
