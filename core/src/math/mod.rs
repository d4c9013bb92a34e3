//! Numerical helpers shared by the fits, in pure f32 (the same bits on the host and the
//! Cortex-M4F).

pub mod least_squares;
pub mod normal;

use nalgebra::{SMatrix, SVector};

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
