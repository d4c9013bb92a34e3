//! Closed-form least-squares similarity between point pairs (Umeyama 1991, in 2D): the scale s,
//! rotation theta and translation t minimizing `sum |s R(theta) x_k + t - y_k|^2`.
//! Accumulated pair by pair, so no pair is stored.

use super::affine::Affine2;
use nalgebra::{Matrix2, Vector2};

/// Running sums of point pairs, taken relative to a reference point (any point near the
/// points, to keep the f32 sums well conditioned).
#[derive(Debug, Clone, Copy)]
pub struct SimilarityFit {
    reference: Vector2<f32>,
    n: f32,
    sum_x: Vector2<f32>,
    sum_y: Vector2<f32>,
    /// Sums of x . y, of x cross y and of |x|^2.
    dot: f32,
    cross: f32,
    norm_x: f32,
}

impl SimilarityFit {
    /// No pairs, sums relative to `reference` (px).
    pub fn new(reference: Vector2<f32>) -> Self {
        SimilarityFit {
            reference,
            n: 0.0,
            sum_x: Vector2::zeros(),
            sum_y: Vector2::zeros(),
            dot: 0.0,
            cross: 0.0,
            norm_x: 0.0,
        }
    }

    /// Adds the pair: `x` should map to `y`.
    pub fn add(&mut self, x: Vector2<f32>, y: Vector2<f32>) {
        let (x, y) = (x - self.reference, y - self.reference);
        self.n += 1.0;
        self.sum_x += x;
        self.sum_y += y;
        self.dot += x.dot(&y);
        self.cross += x.x * y.y - x.y * y.x;
        self.norm_x += x.norm_squared();
    }

    /// Pairs added.
    pub fn len(&self) -> usize {
        self.n as usize
    }

    /// True when no pair was added.
    pub fn is_empty(&self) -> bool {
        self.n == 0.0
    }

    /// The best similarity, or `None` with fewer than two pairs or coincident sources.
    pub fn solve(&self) -> Option<Affine2> {
        if self.n < 2.0 {
            return None;
        }
        let (mx, my) = (self.sum_x / self.n, self.sum_y / self.n);
        // Centred sums: sum (x - mx) . (y - my) = sum x . y - n mx . my, and likewise.
        let a = self.dot - self.n * mx.dot(&my);
        let b = self.cross - self.n * (mx.x * my.y - mx.y * my.x);
        let var = self.norm_x - self.n * mx.norm_squared();
        if var.is_nan() || var <= 1e-6 * self.n {
            return None;
        }
        let scale = libm::sqrtf(a * a + b * b) / var;
        let theta = libm::atan2f(b, a);
        let (s, c) = libm::sincosf(theta);
        let linear = Matrix2::new(c, -s, s, c) * scale;
        // p -> linear (p - ref - mx) + ref + my.
        let map = Affine2::about(self.reference + mx, linear, my - mx);
        map.is_finite().then_some(map)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_an_exact_similarity() {
        let truth = Affine2::about(
            Vector2::new(100.0, 80.0),
            Matrix2::new(0.98, -0.17, 0.17, 0.98) * 1.05,
            Vector2::new(2.5, -1.5),
        );
        let mut fit = SimilarityFit::new(Vector2::new(101.0, 79.0));
        assert!(fit.is_empty());
        for k in 0..40 {
            let t = k as f32 * 0.4;
            let x = Vector2::new(100.0 + 30.0 * libm::cosf(t), 80.0 + 6.0 * libm::sinf(t));
            fit.add(x, truth.apply(x));
        }
        assert_eq!(fit.len(), 40);
        let got = fit.solve().expect("well posed");
        let p = Vector2::new(120.0, 70.0);
        assert!((got.apply(p) - truth.apply(p)).norm() < 1e-3, "{got:?}");
    }

    #[test]
    fn least_squares_averages_opposite_moves() {
        // The long sides of a bar pushed outwards by 1 px: a similarity meets that with a
        // uniform scale-up, without a shift or a turn.
        let mut fit = SimilarityFit::new(Vector2::zeros());
        for k in -10..=10 {
            let x = k as f32;
            fit.add(Vector2::new(x, 2.0), Vector2::new(x, 3.0));
            fit.add(Vector2::new(x, -2.0), Vector2::new(x, -3.0));
        }
        let got = fit.solve().unwrap();
        let centre = got.apply(Vector2::zeros());
        assert!(centre.norm() < 1e-4, "no net shift: {centre:?}");
        let m = got.matrix();
        assert!(
            m[(0, 0)] > 1.0 && m[(0, 1)].abs() < 1e-5,
            "scale up, no turn: {m:?}"
        );
    }

    #[test]
    fn degenerate_inputs_give_none() {
        let mut fit = SimilarityFit::new(Vector2::zeros());
        fit.add(Vector2::new(1.0, 1.0), Vector2::new(2.0, 2.0));
        assert!(fit.solve().is_none());
        fit.add(Vector2::new(1.0, 1.0), Vector2::new(3.0, 2.0));
        assert!(fit.solve().is_none());
    }
}
