//! Numerical helpers shared by the fits, in pure f32 (the same bits on the host and the
//! Cortex-M4F).

pub mod least_squares;
pub mod normal;

use nalgebra::{SMatrix, SVector};

/// The bilinear blend of a lattice cell's values `corners` (top left, top right, bottom left,
/// bottom right) at weights `wx` across and `wy` down, each row blended first.
#[inline]
pub fn bilinear_blend(corners: [f32; 4], wx: f32, wy: f32) -> f32 {
    let [top_left, top_right, bottom_left, bottom_right] = corners;
    let top = top_left * (1.0 - wx) + top_right * wx;
    let bottom = bottom_left * (1.0 - wx) + bottom_right * wx;
    top * (1.0 - wy) + bottom * wy
}

/// Adds `w g gᵀ` to the upper triangle of `jtj` and `w r g` to `jtr`: one point's share of a
/// least-squares fit's normal equations (residual `r`, model gradient `g`, weight `w`). Half the
/// work of the full outer product; complete the matrix with
/// `fill_lower_triangle_with_upper_triangle` before solving.
#[inline]
pub fn accumulate<const N: usize>(
    jtj: &mut SMatrix<f32, N, N>,
    jtr: &mut SVector<f32, N>,
    g: &SVector<f32, N>,
    w: f32,
    r: f32,
) {
    for a in 0..N {
        let wa = w * g[a];
        jtr[a] += wa * r;
        for b in a..N {
            jtj[(a, b)] += wa * g[b];
        }
    }
}

/// [`accumulate`] over the parameters `indices` alone (ascending, each once): where the
/// gradient `g` is zero elsewhere, the same sums at the cost of those.
pub fn accumulate_at<const N: usize>(
    jtj: &mut SMatrix<f32, N, N>,
    jtr: &mut SVector<f32, N>,
    g: &SVector<f32, N>,
    indices: impl Iterator<Item = usize> + Clone,
    w: f32,
    r: f32,
) {
    let mut rest = indices.clone();
    for a in indices {
        let wa = w * g[a];
        jtr[a] += wa * r;
        for b in rest.clone() {
            jtj[(a, b)] += wa * g[b];
        }
        rest.next();
    }
}
