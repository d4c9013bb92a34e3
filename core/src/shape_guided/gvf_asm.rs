//! GVF-ASM, the source paper's Algorithm 1: the prior's boundary points are pushed along the
//! chip's gradient vector flow and a similarity transform (scale, rotation, translation) is
//! fitted to the pushed points in closed form; the fitted transform moves the points, and the
//! step repeats.
//!
//! Each point moves by the flow at it, as in Algorithm 1 (`X + dX` with `dX` the field there),
//! scaled by `gain_px` and capped at `step_px`: strong, nearby edges move the points most, and on
//! an edge the flow vanishes, so points sitting on it stay.

use super::ShapeGuidedError;
use super::affine::Affine2;
use super::boundary::Boundary;
use super::grid::Grid;
use super::gvf::{Gvf, MAX_MU};
use super::prior::PriorShape;
use super::similarity::SimilarityFit;
use crate::capacity::SHAPE_GRID_CELLS;
use crate::chip::ChipView;
use crate::mask::BitMask;

/// GVF-ASM's tunables.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GvfAsmConfig {
    /// Margin around the prior's extent box where the field is computed, px: how far the
    /// boundary can be pulled.
    pub capture_px: f32,
    /// Diffusion weight of the flow (at most [`MAX_MU`]).
    pub mu: f32,
    /// Diffusion sweeps.
    pub gvf_iterations: u32,
    /// Most move-and-fit iterations.
    pub asm_iterations: u32,
    /// Move of a boundary point per unit of flow (edge-map units per px), px.
    pub gain_px: f32,
    /// Largest move of a boundary point per iteration, px.
    pub step_px: f32,
    /// Stop when an iteration moves the prior's extent-box corners less than this, px.
    pub converged_px: f32,
}

impl GvfAsmConfig {
    /// The defaults.
    pub const DEFAULT: GvfAsmConfig = GvfAsmConfig {
        capture_px: 12.0,
        mu: 0.2,
        gvf_iterations: 80,
        asm_iterations: 60,
        gain_px: 4.0,
        step_px: 1.0,
        converged_px: 0.05,
    };
}

impl Default for GvfAsmConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// What GVF-ASM found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GvfAsmResult {
    /// The accumulated similarity, chip px to chip px.
    pub transform: Affine2,
    /// Mean normalized edge strength (0..1) under the prior's boundary points as given.
    pub edge_before: f32,
    /// The same under the moved points.
    pub edge_after: f32,
    /// Move-and-fit iterations run.
    pub iterations: u32,
    /// Boundary points used.
    pub points: usize,
}

/// GVF-ASM's buffers: the flow field and the boundary points (about 34 KiB at the default
/// capacities).
#[derive(Debug, Clone)]
pub struct GvfAsm {
    gvf: Gvf,
    boundary: Boundary,
}

impl Default for GvfAsm {
    fn default() -> Self {
        Self::new()
    }
}

impl GvfAsm {
    /// Empty buffers.
    pub const fn new() -> Self {
        GvfAsm {
            gvf: Gvf::new(),
            boundary: Boundary::new(),
        }
    }

    /// Runs Algorithm 1 for `prior` (measured as `shape`) on `chip`.
    pub fn run<const W: usize>(
        &mut self,
        chip: &ChipView,
        prior: &BitMask<W>,
        shape: &PriorShape,
        config: &GvfAsmConfig,
    ) -> Result<GvfAsmResult, ShapeGuidedError> {
        let grid = Grid::around(shape, config.capture_px, SHAPE_GRID_CELLS)
            .ok_or(ShapeGuidedError::Degenerate)?;
        self.gvf
            .compute(chip, &grid, config.mu.min(MAX_MU), config.gvf_iterations)
            .map_err(|_| ShapeGuidedError::Degenerate)?;
        self.boundary.collect(prior, shape);
        let corners = shape.corners();
        let mut transform = Affine2::IDENTITY;
        let mut iterations = 0;
        while iterations < config.asm_iterations {
            let mut fit = SimilarityFit::new(shape.centre);
            for &x0 in self.boundary.points() {
                let x = transform.apply(x0);
                let Some(f) = self.gvf.field_at(grid.to_cell(x)) else {
                    continue;
                };
                // The flow in chip axes, per px (the grid is a rotated, scaled copy of them).
                let flow = grid.cell_vector_to_chip(f) / (grid.step() * grid.step());
                let mut dx = flow * config.gain_px;
                let len = dx.norm();
                if len > config.step_px {
                    dx *= config.step_px / len;
                }
                fit.add(x, x + dx);
            }
            let Some(update) = fit.solve() else {
                return Err(ShapeGuidedError::NoEdges);
            };
            let next = transform.then(&update);
            iterations += 1;
            let moved_px = corners
                .iter()
                .map(|&c| (next.apply(c) - transform.apply(c)).norm())
                .fold(0.0f32, f32::max);
            transform = next;
            if moved_px < config.converged_px {
                break;
            }
        }
        Ok(GvfAsmResult {
            transform,
            edge_before: self.mean_edge(&grid, &Affine2::IDENTITY),
            edge_after: self.mean_edge(&grid, &transform),
            iterations,
            points: self.boundary.points().len(),
        })
    }

    /// Mean edge-map value at the nearest cells of the transformed boundary points (points
    /// off the grid count as no edge).
    fn mean_edge(&self, grid: &Grid, transform: &Affine2) -> f32 {
        let points = self.boundary.points();
        if points.is_empty() {
            return 0.0;
        }
        let sum: f32 = points
            .iter()
            .map(|&p| {
                let c = grid.to_cell(transform.apply(p));
                if c.x < -0.5 || c.y < -0.5 {
                    return 0.0;
                }
                let (i, j) = (libm::roundf(c.x) as usize, libm::roundf(c.y) as usize);
                self.gvf.edge_at(i, j)
            })
            .sum();
        sum / points.len() as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mask::ChipMask;
    use nalgebra::Vector2;

    /// A 96 x 64 chip, sky 190, body 70, of a `len` x `wid` px bar centred at `centre`, with
    /// the partly covered pixels shaded by their coverage (4 x 4 samples).
    fn bar_chip(centre: Vector2<f32>, len: f32, wid: f32) -> [u8; 96 * 64] {
        core::array::from_fn(|k| {
            let mut covered = 0.0;
            for s in 0..16 {
                let x = (k % 96) as f32 - 0.375 + 0.25 * (s % 4) as f32 - centre.x;
                let y = (k / 96) as f32 - 0.375 + 0.25 * (s / 4) as f32 - centre.y;
                if x.abs() <= 0.5 * len && y.abs() <= 0.5 * wid {
                    covered += 1.0 / 16.0;
                }
            }
            libm::roundf(190.0 - 120.0 * covered) as u8
        })
    }

    /// A 46 x 8 px bar mask centred at (47.5, 31.5).
    fn small_bar() -> ChipMask {
        let mut m = ChipMask::new();
        m.reset(96, 64).unwrap();
        for y in 28..=35 {
            m.set_run(y, 25, 70);
        }
        m
    }

    #[test]
    fn pulls_a_prior_onto_a_scaled_and_shifted_bar() {
        // The truth is the prior scaled by 1.1 about its centre and moved (4, -1) px.
        let truth_centre = Vector2::new(51.5, 30.5);
        let data = bar_chip(truth_centre, 46.0 * 1.1, 8.0 * 1.1);
        let chip = ChipView::gray8(&data, 96, 64, 96, 0, 0).unwrap();
        let prior = small_bar();
        let shape = PriorShape::measure(&prior).unwrap();
        let mut asm = GvfAsm::new();
        let r = asm
            .run(&chip, &prior, &shape, &GvfAsmConfig::DEFAULT)
            .unwrap();
        assert!(r.edge_after > r.edge_before, "{r:?}");
        let centre = r.transform.apply(shape.centre);
        assert!((centre - truth_centre).norm() < 0.5, "{centre:?}: {r:?}");
        let scale = libm::sqrtf(r.transform.matrix().determinant());
        assert!((scale - 1.1).abs() < 0.03, "scale {scale}");
    }

    #[test]
    fn a_featureless_chip_has_no_edges_to_follow() {
        let data = [120u8; 96 * 64];
        let chip = ChipView::gray8(&data, 96, 64, 96, 0, 0).unwrap();
        let prior = small_bar();
        let shape = PriorShape::measure(&prior).unwrap();
        let r = GvfAsm::new()
            .run(&chip, &prior, &shape, &GvfAsmConfig::DEFAULT)
            .unwrap();
        assert_eq!(r.edge_before, 0.0);
        let moved = (r.transform.apply(shape.centre) - shape.centre).norm();
        assert!(moved < 1e-3, "{r:?}");
    }
}
