//! SIS-Cut, the source paper's Algorithm 2: the prior's region is the foreground and its
//! dilation ring the background; a seven-parameter affine transform of both is searched by
//! Nelder-Mead for the largest symmetric Kullback-Leibler divergence (Eq. 7) between the grey-level
//! distributions of the two.
//!
//! The region and ring are labelled once on the oriented grid (prior space); a candidate
//! transform maps every labelled cell into the chip, where the grey level is sampled bilinearly.
//! An affine map has a constant Jacobian, so sampling in prior space weighs the chip's pixels
//! uniformly, as sampling them in image space would, and the objective varies continuously with
//! the parameters.

use super::ShapeGuidedError;
use super::affine::{Affine2, AffineParams};
use super::grid::{Grid, sample_chip};
use super::histogram::Histogram;
use super::nelder_mead::{self, NelderMeadConfig};
use super::prior::PriorShape;
use crate::capacity::SHAPE_GRID_CELLS;
use crate::chip::ChipView;
use crate::mask::BitMask;

/// SIS-Cut's tunables.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SisCutConfig {
    /// Width of the background ring (the dilation of Algorithm 2's step 1), px.
    pub ring_px: f32,
    /// Histogram bins (at most [`crate::capacity::SHAPE_HIST_BINS`]).
    pub bins: usize,
    /// Weight of the uniform distribution mixed into both before they are compared (keeps
    /// Eq. 7 finite where a bin is empty).
    pub uniform_mix: f32,
    /// Displacement of the prior's extent-box corners, px, by which each parameter's first
    /// simplex step moves them (sets the initial simplex to the prior's size).
    pub probe_px: f32,
    /// Bound on the scales: `|ln scale| <= max_log_scale`.
    pub max_log_scale: f32,
    /// Bound on the rotation, rad.
    pub max_rotation_rad: f32,
    /// Bound on each shear.
    pub max_shear: f32,
    /// Bound on each translation component, px.
    pub max_shift_px: f32,
    /// Simplex stop rule, per run.
    pub search: NelderMeadConfig,
    /// Fresh simplex runs started from the best point after the first one.
    pub restarts: u32,
}

impl SisCutConfig {
    /// The defaults.
    pub const DEFAULT: SisCutConfig = SisCutConfig {
        ring_px: 4.0,
        bins: 32,
        uniform_mix: 0.02,
        probe_px: 1.5,
        max_log_scale: 0.4,
        max_rotation_rad: 0.35,
        max_shear: 0.3,
        max_shift_px: 20.0,
        search: NelderMeadConfig {
            max_evaluations: 400,
            f_tolerance: 1e-4,
            x_tolerance: 1e-3,
        },
        restarts: 0,
    };
}

impl Default for SisCutConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// What SIS-Cut found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SisCutResult {
    /// The best parameters.
    pub params: AffineParams,
    /// The map they describe, chip px to chip px.
    pub transform: Affine2,
    /// Eq. 7 at the prior as given.
    pub divergence_before: f32,
    /// Eq. 7 at the best transform.
    pub divergence_after: f32,
    /// Objective evaluations.
    pub evaluations: u32,
}

/// Cell labels.
const FORE: u8 = 0;
const RING: u8 = 1;
const NONE: u8 = 2;

/// Chamfer weights (3-4 distance: about three units a cell).
const ORTHO: u8 = 3;
const DIAG: u8 = 4;

/// SIS-Cut's buffer: one label per grid cell (3 KiB at the default capacity).
#[derive(Debug, Clone)]
pub struct SisCut {
    labels: [u8; SHAPE_GRID_CELLS],
}

impl Default for SisCut {
    fn default() -> Self {
        Self::new()
    }
}

impl SisCut {
    /// An empty buffer.
    pub const fn new() -> Self {
        SisCut {
            labels: [NONE; SHAPE_GRID_CELLS],
        }
    }

    /// Runs Algorithm 2 for `prior` (measured as `shape`) on `chip`.
    pub fn run<const W: usize>(
        &mut self,
        chip: &ChipView,
        prior: &BitMask<W>,
        shape: &PriorShape,
        config: &SisCutConfig,
    ) -> Result<SisCutResult, ShapeGuidedError> {
        let ring_px = config.ring_px.max(1.0);
        let grid = Grid::around(shape, ring_px + 1.0, SHAPE_GRID_CELLS)
            .ok_or(ShapeGuidedError::Degenerate)?;
        self.label(prior, &grid, ring_px);
        let (lo, hi) = grey_range(chip, &grid);
        let mut fore = Histogram::new(config.bins, lo, hi);
        let mut ring = Histogram::new(config.bins, lo, hi);
        let mut divergence = |transform: &Affine2| {
            self.histograms(chip, &grid, transform, &mut fore, &mut ring);
            if fore.total() < 4.0 || ring.total() < 4.0 {
                return None;
            }
            Some(fore.symmetric_kl(&ring, config.uniform_mix))
        };
        let divergence_before =
            divergence(&Affine2::IDENTITY).ok_or(ShapeGuidedError::NoBackground)?;
        let limits = [
            config.max_log_scale,
            config.max_log_scale,
            config.max_rotation_rad,
            config.max_shear,
            config.max_shear,
            config.max_shift_px,
            config.max_shift_px,
        ];
        let mut objective = |x: &[f32; 7]| -> f32 {
            if x.iter()
                .zip(&limits)
                .any(|(v, l)| v.is_nan() || v.abs() > *l)
            {
                return f32::INFINITY;
            }
            divergence(&AffineParams::from_array(x).affine(shape)).map_or(f32::INFINITY, |d| -d)
        };
        let steps = initial_steps(shape, config.probe_px);
        let mut best =
            nelder_mead::minimize::<7, 8>(&mut objective, [0.0; 7], steps, &config.search);
        let mut evaluations = best.evaluations;
        for _ in 0..config.restarts {
            let again =
                nelder_mead::minimize::<7, 8>(&mut objective, best.x, steps, &config.search);
            evaluations += again.evaluations;
            if again.f < best.f {
                best = again;
            }
        }
        let params = AffineParams::from_array(&best.x);
        let (transform, divergence_after) = if best.f.is_finite() && -best.f > divergence_before {
            (params.affine(shape), -best.f)
        } else {
            (Affine2::IDENTITY, divergence_before)
        };
        Ok(SisCutResult {
            params,
            transform,
            divergence_before,
            divergence_after,
            evaluations,
        })
    }

    /// Labels the grid's cells: the prior's pixel nearest each cell makes it foreground; cells
    /// within `ring_px` of the foreground (3-4 chamfer distance) are the ring.
    fn label<const W: usize>(&mut self, prior: &BitMask<W>, grid: &Grid, ring_px: f32) {
        let (w, h) = (grid.width(), grid.height());
        for j in 0..h {
            for i in 0..w {
                let p = grid.to_chip(i, j);
                let (x, y) = (libm::roundf(p.x), libm::roundf(p.y));
                let inside = x >= 0.0 && y >= 0.0 && prior.get(x as usize, y as usize);
                if let Some(l) = self.labels.get_mut(grid.index(i, j)) {
                    *l = if inside { 0 } else { u8::MAX };
                }
            }
        }
        // Two chamfer passes: the distance to the foreground in thirds of a cell.
        let forward = [
            (-1, -1, DIAG),
            (0, -1, ORTHO),
            (1, -1, DIAG),
            (-1, 0, ORTHO),
        ];
        let backward = [(1, 1, DIAG), (0, 1, ORTHO), (-1, 1, DIAG), (1, 0, ORTHO)];
        for (order, offsets) in [(false, forward), (true, backward)] {
            for k in 0..grid.cells() {
                let k = if order { grid.cells() - 1 - k } else { k };
                let (i, j) = (k % w, k / w);
                let mut d = self.labels.get(k).copied().unwrap_or(u8::MAX);
                for (di, dj, cost) in offsets {
                    let (Some(ni), Some(nj)) = (i.checked_add_signed(di), j.checked_add_signed(dj))
                    else {
                        continue;
                    };
                    if ni < w && nj < h {
                        let n = self
                            .labels
                            .get(grid.index(ni, nj))
                            .copied()
                            .unwrap_or(u8::MAX);
                        d = d.min(n.saturating_add(cost));
                    }
                }
                if let Some(l) = self.labels.get_mut(k) {
                    *l = d;
                }
            }
        }
        let ring = (3.0 * ring_px / grid.step()).clamp(1.0, 254.0) as u8;
        for l in self.labels.iter_mut().take(grid.cells()) {
            *l = match *l {
                0 => FORE,
                d if d <= ring => RING,
                _ => NONE,
            };
        }
    }

    /// Fills the two histograms with the chip's grey levels at the transformed cells.
    fn histograms(
        &self,
        chip: &ChipView,
        grid: &Grid,
        transform: &Affine2,
        fore: &mut Histogram,
        ring: &mut Histogram,
    ) {
        fore.clear();
        ring.clear();
        for j in 0..grid.height() {
            for i in 0..grid.width() {
                let label = self.labels.get(grid.index(i, j)).copied().unwrap_or(NONE);
                if label == NONE {
                    continue;
                }
                if let Some(g) = sample_chip(chip, transform.apply(grid.to_chip(i, j))) {
                    if label == FORE {
                        fore.add(g);
                    } else {
                        ring.add(g);
                    }
                }
            }
        }
    }
}

/// Lowest and highest grey level sampled on the grid's cells.
fn grey_range(chip: &ChipView, grid: &Grid) -> (f32, f32) {
    let mut range = (f32::MAX, f32::MIN);
    for j in 0..grid.height() {
        for i in 0..grid.width() {
            if let Some(g) = sample_chip(chip, grid.to_chip(i, j)) {
                range = (range.0.min(g), range.1.max(g));
            }
        }
    }
    if range.0 > range.1 { (0.0, 1.0) } else { range }
}

/// First simplex steps that move the prior's extent-box corners by about `probe_px` each.
fn initial_steps(shape: &PriorShape, probe_px: f32) -> [f32; 7] {
    let [u0, u1, v0, v1] = shape.extent;
    let half_u = (0.5 * (u1 - u0)).max(1.0);
    let half_v = (0.5 * (v1 - v0)).max(1.0);
    let probe = probe_px.max(0.1);
    [
        probe / half_u,
        probe / half_v,
        probe / half_u,
        probe / half_v,
        probe / half_u,
        probe,
        probe,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mask::ChipMask;
    use nalgebra::Vector2;

    /// The label of the cell nearest chip position `p`.
    fn cell_label(s: &SisCut, grid: &Grid, p: Vector2<f32>) -> u8 {
        let c = grid.to_cell(p);
        let (i, j) = (libm::roundf(c.x) as usize, libm::roundf(c.y) as usize);
        s.labels.get(grid.index(i, j)).copied().unwrap_or(NONE)
    }

    /// A 96 x 64 chip, sky 180 with a slight gradient, and a dark 50 x 8 px bar tilted by
    /// `tilt` rad about (48, 32) shifted by `shift` px.
    fn bar_chip(tilt: f32, shift: (f32, f32)) -> [u8; 96 * 64] {
        let (s, c) = libm::sincosf(tilt);
        core::array::from_fn(|k| {
            let (x, y) = (
                (k % 96) as f32 - 48.0 - shift.0,
                (k / 96) as f32 - 32.0 - shift.1,
            );
            let (u, v) = (c * x + s * y, -s * x + c * y);
            let sky = 180.0 + 0.1 * (k % 96) as f32;
            if u.abs() <= 25.0 && v.abs() <= 4.0 {
                60
            } else {
                sky as u8
            }
        })
    }

    fn bar_mask(shift: (usize, usize)) -> ChipMask {
        let mut m = ChipMask::new();
        m.reset(96, 64).unwrap();
        for y in 28 + shift.1..=36 + shift.1 {
            m.set_run(y, 23 + shift.0, 73 + shift.0);
        }
        m
    }

    #[test]
    fn labels_make_a_ring_of_the_chosen_width() {
        let prior = bar_mask((0, 0));
        let shape = PriorShape::measure(&prior).unwrap();
        let grid = Grid::around(&shape, 5.0, SHAPE_GRID_CELLS).unwrap();
        let mut s = SisCut::new();
        s.label(&prior, &grid, 4.0);
        let at = |x: f32, y: f32| cell_label(&s, &grid, Vector2::new(x, y));
        assert_eq!(at(48.0, 32.0), FORE);
        assert_eq!(at(48.0, 26.0), RING); // 2 px above the bar
        assert_eq!(at(48.0, 23.5), RING); // 4.5 px: inside the 3-4 chamfer's rounding
        assert_eq!(at(48.0, 22.0), NONE);
        assert_eq!(at(18.0, 32.0), RING);
        assert_eq!(at(16.0, 32.0), NONE);
    }

    #[test]
    fn finds_a_shifted_and_turned_bar() {
        // The truth is the prior turned by 3 deg and moved (3, -2) px.
        let data = bar_chip(0.0524, (3.0, -2.0));
        let chip = ChipView::gray8(&data, 96, 64, 96, 0, 0).unwrap();
        let prior = bar_mask((0, 0));
        let shape = PriorShape::measure(&prior).unwrap();
        let mut s = SisCut::new();
        let r = s
            .run(&chip, &prior, &shape, &SisCutConfig::DEFAULT)
            .unwrap();
        assert!(r.divergence_after > r.divergence_before, "{r:?}");
        let centre = r.transform.apply(shape.centre);
        let want = shape.centre + Vector2::new(3.0, -2.0);
        assert!(
            (centre - want).norm() < 1.0,
            "centre {centre:?}, want {want:?}: {r:?}"
        );
        let m = r.transform.matrix();
        let turn = libm::atan2f(m[(1, 0)], m[(0, 0)]);
        assert!((turn - 0.0524).abs() < 0.02, "turn {turn}: {r:?}");
    }

    #[test]
    fn a_featureless_chip_leaves_the_prior_in_place() {
        let data = [100u8; 96 * 64];
        let chip = ChipView::gray8(&data, 96, 64, 96, 0, 0).unwrap();
        let prior = bar_mask((0, 0));
        let shape = PriorShape::measure(&prior).unwrap();
        let r = SisCut::new()
            .run(&chip, &prior, &shape, &SisCutConfig::DEFAULT)
            .unwrap();
        assert!(r.divergence_before.abs() < 1e-6, "{r:?}");
        assert_eq!(r.transform, Affine2::IDENTITY);
    }

    #[test]
    fn a_prior_covering_the_chip_has_no_background() {
        let data = [100u8; 96 * 64];
        let chip = ChipView::gray8(&data, 96, 64, 96, 0, 0).unwrap();
        let mut prior = ChipMask::new();
        prior.reset(96, 64).unwrap();
        (0..64).for_each(|y| prior.set_run(y, 0, 95));
        let shape = PriorShape::measure(&prior).unwrap();
        let r = SisCut::new().run(&chip, &prior, &shape, &SisCutConfig::DEFAULT);
        assert_eq!(r, Err(ShapeGuidedError::NoBackground));
    }
}
