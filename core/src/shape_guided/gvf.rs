//! Gradient vector flow (Xu and Prince 1998) of the chip on an oriented grid: the edge map
//! `f = |grad I|^2` (Sobel on the grid's samples, normalized to a maximum of 1) and the field
//! (u, v) that minimizes `mu |grad (u, v)|^2 + |grad f|^2 |(u, v) - grad f|^2`, found by a
//! fixed number of explicit diffusion sweeps `u += mu lap(u) - |grad f|^2 (u - f_x)`. The
//! sweeps update in place, alternating their direction so that neither is favoured; the borders
//! replicate. Field units are edge-map units per cell, in the grid's axes (along, across).

use super::grid::{Grid, sample_chip};
use crate::capacity::SHAPE_GRID_CELLS;
use crate::chip::ChipView;
use nalgebra::Vector2;

/// Largest diffusion weight for which the explicit sweeps are stable.
pub const MAX_MU: f32 = 0.25;

/// Edge-map levels of the u16 storage (1.0 is this).
const EDGE_SCALE: f32 = u16::MAX as f32;

/// The grid is larger than [`SHAPE_GRID_CELLS`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GridTooLarge;

/// The edge map and flow field buffers (about 30 KiB at the default capacity).
#[derive(Debug, Clone)]
pub struct Gvf {
    u: [f32; SHAPE_GRID_CELLS],
    v: [f32; SHAPE_GRID_CELLS],
    edge: [u16; SHAPE_GRID_CELLS],
    grid: Option<Grid>,
}

impl Default for Gvf {
    fn default() -> Self {
        Self::new()
    }
}

impl Gvf {
    /// Empty buffers.
    pub const fn new() -> Self {
        Gvf {
            u: [0.0; SHAPE_GRID_CELLS],
            v: [0.0; SHAPE_GRID_CELLS],
            edge: [0; SHAPE_GRID_CELLS],
            grid: None,
        }
    }

    /// Samples the chip on `grid`, makes its edge map and diffuses the edge map's gradient over
    /// `iterations` sweeps with weight `mu` (clamped to (0, [`MAX_MU`]]).
    pub fn compute(
        &mut self,
        chip: &ChipView,
        grid: &Grid,
        mu: f32,
        iterations: u32,
    ) -> Result<(), GridTooLarge> {
        let (w, h) = (grid.width(), grid.height());
        let n = grid.cells();
        if n > SHAPE_GRID_CELLS {
            return Err(GridTooLarge);
        }
        self.grid = Some(*grid);
        let (u, v, edge) = (&mut self.u, &mut self.v, &mut self.edge);
        // Grey levels into u (positions outside the chip take the nearest pixel centre).
        let (max_x, max_y) = (chip.width() as f32 - 1.0, chip.height() as f32 - 1.0);
        for j in 0..h {
            for i in 0..w {
                let p = grid.to_chip(i, j);
                let p = Vector2::new(p.x.clamp(0.0, max_x), p.y.clamp(0.0, max_y));
                if let Some(c) = u.get_mut(grid.index(i, j)) {
                    *c = sample_chip(chip, p).unwrap_or(0.0);
                }
            }
        }
        // Squared Sobel gradient into v, then normalized into the edge map.
        let mut max = 0.0f32;
        for j in 0..h {
            for i in 0..w {
                let at = |di: isize, dj: isize| clamped(u, w, h, i, j, di, dj);
                let gx = (at(1, -1) + 2.0 * at(1, 0) + at(1, 1))
                    - (at(-1, -1) + 2.0 * at(-1, 0) + at(-1, 1));
                let gy = (at(-1, 1) + 2.0 * at(0, 1) + at(1, 1))
                    - (at(-1, -1) + 2.0 * at(0, -1) + at(1, -1));
                let f = (gx * gx + gy * gy) / 64.0;
                max = max.max(f);
                if let Some(c) = v.get_mut(grid.index(i, j)) {
                    *c = f;
                }
            }
        }
        let scale = if max > 0.0 { EDGE_SCALE / max } else { 0.0 };
        for (e, f) in edge.iter_mut().zip(v.iter()).take(n) {
            *e = libm::roundf(f * scale).clamp(0.0, EDGE_SCALE) as u16;
        }
        // The field starts as the edge map's gradient.
        for j in 0..h {
            for i in 0..w {
                let at = Around::of(i, j, w, h);
                let (fx, fy) = at.edge_gradient(edge);
                if let (Some(a), Some(b)) = (u.get_mut(at.centre), v.get_mut(at.centre)) {
                    *a = fx;
                    *b = fy;
                }
            }
        }
        let mu = mu.clamp(0.0, MAX_MU);
        for sweep in 0..iterations {
            let forward = sweep % 2 == 0;
            for row in 0..h {
                let j = if forward { row } else { h - 1 - row };
                for col in 0..w {
                    let i = if forward { col } else { w - 1 - col };
                    let at = Around::of(i, j, w, h);
                    let (fx, fy) = at.edge_gradient(edge);
                    let b = fx * fx + fy * fy;
                    let (lap_u, lap_v) = (at.laplacian(u), at.laplacian(v));
                    if let (Some(a), Some(c)) = (u.get_mut(at.centre), v.get_mut(at.centre)) {
                        *a += mu * lap_u - b * (*a - fx);
                        *c += mu * lap_v - b * (*c - fy);
                    }
                }
            }
        }
        Ok(())
    }

    /// The field at fractional cell `c` of the grid last computed, in edge-map units per cell
    /// along and across the axis; `None` outside the grid or before any computation.
    pub fn field_at(&self, c: Vector2<f32>) -> Option<Vector2<f32>> {
        let grid = self.grid.as_ref()?;
        Some(Vector2::new(
            grid.interpolate(&self.u, c)?,
            grid.interpolate(&self.v, c)?,
        ))
    }

    /// The normalized edge map (0..1) at cell (i, j) of the grid last computed.
    pub fn edge_at(&self, i: usize, j: usize) -> f32 {
        let Some(grid) = self.grid.as_ref() else {
            return 0.0;
        };
        if i >= grid.width() || j >= grid.height() {
            return 0.0;
        }
        self.edge
            .get(grid.index(i, j))
            .map_or(0.0, |&e| f32::from(e) / EDGE_SCALE)
    }
}

/// `buf` at cell (i + di, j + dj) of a `w` x `h` grid, the position clamped to the grid.
#[inline]
fn clamped(buf: &[f32], w: usize, h: usize, i: usize, j: usize, di: isize, dj: isize) -> f32 {
    let x = i.saturating_add_signed(di).min(w.saturating_sub(1));
    let y = j.saturating_add_signed(dj).min(h.saturating_sub(1));
    buf.get(y * w + x).copied().unwrap_or(0.0)
}

/// Buffer indices of a cell and of its four neighbours, the neighbours clamped to the grid
/// (replicated borders).
#[derive(Debug, Clone, Copy)]
struct Around {
    centre: usize,
    left: usize,
    right: usize,
    up: usize,
    down: usize,
}

impl Around {
    /// Cell (i, j) of a `w` x `h` grid.
    #[inline]
    fn of(i: usize, j: usize, w: usize, h: usize) -> Around {
        let centre = j * w + i;
        Around {
            centre,
            left: if i > 0 { centre - 1 } else { centre },
            right: if i + 1 < w { centre + 1 } else { centre },
            up: if j > 0 { centre - w } else { centre },
            down: if j + 1 < h { centre + w } else { centre },
        }
    }

    /// Five-point Laplacian of `buf`.
    #[inline]
    fn laplacian(&self, buf: &[f32]) -> f32 {
        let at = |k: usize| buf.get(k).copied().unwrap_or(0.0);
        at(self.left) + at(self.right) + at(self.up) + at(self.down) - 4.0 * at(self.centre)
    }

    /// Central-difference gradient of the normalized edge map, per cell.
    #[inline]
    fn edge_gradient(&self, edge: &[u16]) -> (f32, f32) {
        let at = |k: usize| edge.get(k).map_or(0.0, |&e| f32::from(e));
        let half = 0.5 / EDGE_SCALE;
        (
            half * (at(self.right) - at(self.left)),
            half * (at(self.down) - at(self.up)),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::super::prior::PriorShape;
    use super::*;

    /// A 64 x 64 chip, sky 200, with a dark 40 x 8 px bar along x centred at (32, 32).
    fn bar_chip() -> [u8; 4096] {
        core::array::from_fn(|k| {
            let (x, y) = (k % 64, k / 64);
            if (12..52).contains(&x) && (28..36).contains(&y) {
                50
            } else {
                200
            }
        })
    }

    #[test]
    fn field_points_towards_the_nearest_edge_from_both_sides() {
        let data = bar_chip();
        let chip = ChipView::gray8(&data, 64, 64, 64, 0, 0).unwrap();
        let shape = PriorShape::for_tests(Vector2::new(31.5, 31.5), 0.0);
        let grid = Grid::around(&shape, 18.0, SHAPE_GRID_CELLS).unwrap();
        assert_eq!(grid.step(), 1.0);
        let mut gvf = Gvf::new();
        gvf.compute(&chip, &grid, 0.2, 80).unwrap();
        // The bar's top edge is between rows 27 and 28 (y = 27.5). Above it the field points
        // down (+v across a grid aligned with x), inside it up; both reach several px away.
        for (y, sign) in [(21.0, 1.0), (24.0, 1.0), (29.5, -1.0)] {
            let f = gvf
                .field_at(grid.to_cell(Vector2::new(32.0, y)))
                .expect("inside the grid");
            assert!(
                sign * f.y > 0.0 && f.y.abs() > 3.0 * f.x.abs(),
                "y {y}: {f:?}"
            );
        }
        // Left of the bar's end (x = 11.5) the field points right, towards the end.
        let f = gvf.field_at(grid.to_cell(Vector2::new(6.0, 32.0))).unwrap();
        assert!(f.x > 0.0 && f.x > 3.0 * f.y.abs(), "{f:?}");
        assert!(gvf.edge_at(20, 18) <= 1.0);
        assert!(gvf.field_at(Vector2::new(-1.0, 0.0)).is_none());
    }
}
