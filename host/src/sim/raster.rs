//! A supersampled z-buffer over a small pixel window: each pixel holds S x S samples on a regular
//! grid, each remembering the nearest triangle that covers it. Coverage (for anti-aliasing and
//! the mask's half-area rule) and depth (for the plume's occlusion) are read from it.
//!
//! Coordinates are full-frame pixels with pixel centres at integers: pixel (x, y) spans
//! [x - 0.5, x + 0.5] x [y - 0.5, y + 0.5].

/// No triangle covers the sample.
const EMPTY: u32 = u32::MAX;

/// A vertex in window-relative pixel coordinates with its inverse depth: (x, y, 1/z).
type Local = (f64, f64, f64);

/// A projected triangle vertex: full-frame pixel coordinates and camera depth (m, > 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScreenVertex {
    /// Full-frame u, px.
    pub u: f64,
    /// Full-frame v, px.
    pub v: f64,
    /// Camera-frame depth Z, m.
    pub z: f64,
}

/// The sample buffer of a window of pixels.
#[derive(Debug, Clone)]
pub struct SampleBuffer {
    x0: i64,
    y0: i64,
    width: usize,
    height: usize,
    s: usize,
    /// 1 / depth of the nearest surface per sample (0 where empty), row-major over samples.
    inv_depth: Vec<f64>,
    /// The nearest triangle per sample, [`EMPTY`] where none.
    triangle: Vec<u32>,
}

impl SampleBuffer {
    /// An empty buffer over the `width` x `height` pixels whose top-left pixel is full-frame
    /// (x0, y0), with `s` x `s` samples per pixel.
    pub fn new(x0: i64, y0: i64, width: usize, height: usize, s: usize) -> SampleBuffer {
        let n = width * height * s * s;
        SampleBuffer {
            x0,
            y0,
            width,
            height,
            s,
            inv_depth: vec![0.0; n],
            triangle: vec![EMPTY; n],
        }
    }

    /// Full-frame pixel of the window's top-left pixel.
    pub fn origin(&self) -> (i64, i64) {
        (self.x0, self.y0)
    }

    /// Window size in pixels.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// Samples per pixel.
    pub fn samples_per_pixel(&self) -> usize {
        self.s * self.s
    }

    /// Draws triangle number `id` (kept where it is the nearest surface). Samples on an edge
    /// count as inside, so triangles sharing an edge leave no crack.
    pub fn draw(&mut self, id: u32, tri: [ScreenVertex; 3]) {
        let s = self.s as f64;
        // Window-relative coordinates keep the edge functions well conditioned.
        let local = |p: ScreenVertex| (p.u - self.x0 as f64, p.v - self.y0 as f64, 1.0 / p.z);
        let (a, mut b, mut c) = (local(tri[0]), local(tri[1]), local(tri[2]));
        let edge =
            |p: Local, q: Local, x: f64, y: f64| (q.0 - p.0) * (y - p.1) - (q.1 - p.1) * (x - p.0);
        let mut area = edge(a, b, c.0, c.1);
        if area == 0.0 || !area.is_finite() {
            return;
        }
        if area < 0.0 {
            std::mem::swap(&mut b, &mut c);
            area = -area;
        }
        // Sample k along an axis sits at (k + 0.5) / s - 0.5 in window pixel coordinates.
        let span = |lo: f64, hi: f64, n: usize| -> Option<(usize, usize)> {
            let first = libm::ceil((lo + 0.5) * s - 0.5).max(0.0);
            let last = libm::floor((hi + 0.5) * s - 0.5).min((n * self.s) as f64 - 1.0);
            (first <= last).then_some((first as usize, last as usize))
        };
        let Some((kx0, kx1)) = span(a.0.min(b.0).min(c.0), a.0.max(b.0).max(c.0), self.width)
        else {
            return;
        };
        let Some((ky0, ky1)) = span(a.1.min(b.1).min(c.1), a.1.max(b.1).max(c.1), self.height)
        else {
            return;
        };
        let row_len = self.width * self.s;
        for ky in ky0..=ky1 {
            let y = (ky as f64 + 0.5) / s - 0.5;
            // The row's span inside all three edges, widened by a sample: the exact test below
            // decides, the span only saves visiting the whole bounding box.
            let Some((x_lo, x_hi)) = row_span([(b, c), (c, a), (a, b)], y) else {
                continue;
            };
            let first = (libm::ceil((x_lo + 0.5) * s - 0.5) - 1.0).max(kx0 as f64) as usize;
            let last = (libm::floor((x_hi + 0.5) * s - 0.5) + 1.0).min(kx1 as f64) as usize;
            for kx in first..=last {
                let x = (kx as f64 + 0.5) / s - 0.5;
                let wa = edge(b, c, x, y);
                let wb = edge(c, a, x, y);
                let wc = edge(a, b, x, y);
                if wa < 0.0 || wb < 0.0 || wc < 0.0 {
                    continue;
                }
                let inv_z = (wa * a.2 + wb * b.2 + wc * c.2) / area;
                let index = ky * row_len + kx;
                if inv_z > self.inv_depth[index] {
                    self.inv_depth[index] = inv_z;
                    self.triangle[index] = id;
                }
            }
        }
    }

    /// The samples of window pixel (px, py): (triangle or `None`, depth in m) for each.
    pub fn pixel_samples(
        &self,
        px: usize,
        py: usize,
    ) -> impl Iterator<Item = (Option<u32>, f64)> + '_ {
        let row_len = self.width * self.s;
        (0..self.s).flat_map(move |j| {
            let start = (py * self.s + j) * row_len + px * self.s;
            (start..start + self.s).map(move |i| {
                let t = self.triangle[i];
                if t == EMPTY {
                    (None, f64::INFINITY)
                } else {
                    (Some(t), 1.0 / self.inv_depth[i])
                }
            })
        })
    }

    /// Number of covered samples of window pixel (px, py).
    pub fn covered(&self, px: usize, py: usize) -> usize {
        self.pixel_samples(px, py)
            .filter(|(t, _)| t.is_some())
            .count()
    }

    /// The window pixel holding full-frame pixel (x, y), if it is inside the window.
    pub fn window_pixel(&self, x: i64, y: i64) -> Option<(usize, usize)> {
        let (px, py) = (x - self.x0, y - self.y0);
        (px >= 0 && py >= 0 && (px as usize) < self.width && (py as usize) < self.height)
            .then_some((px as usize, py as usize))
    }
}

/// The interval of x where the edge functions of the three (p, q) edges are all >= 0 on row y
/// (`None` where it is empty). An edge function (q - p) x (point - p) is linear in x.
fn row_span(edges: [(Local, Local); 3], y: f64) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
    for (p, q) in edges {
        // E(x) = c - d x with d = q.y - p.y.
        let d = q.1 - p.1;
        let c = (q.0 - p.0) * (y - p.1) + d * p.0;
        if d > 0.0 {
            hi = hi.min(c / d);
        } else if d < 0.0 {
            lo = lo.max(c / d);
        } else if c < 0.0 {
            return None;
        }
    }
    (lo <= hi + 1e-9).then_some((lo, hi))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(u: f64, v: f64) -> ScreenVertex {
        ScreenVertex { u, v, z: 10.0 }
    }

    #[test]
    fn a_square_of_two_triangles_covers_its_area_exactly() {
        let mut buf = SampleBuffer::new(100, 200, 20, 20, 8);
        // The square [102.5, 110.5] x [203.5, 207.25]: 8 x 3.75 = 30 px^2.
        let (a, b, c, d) = (
            v(102.5, 203.5),
            v(110.5, 203.5),
            v(110.5, 207.25),
            v(102.5, 207.25),
        );
        buf.draw(0, [a, b, c]);
        buf.draw(1, [a, d, c]);
        let total: usize = (0..20)
            .flat_map(|y| (0..20).map(move |x| (x, y)))
            .map(|(x, y)| buf.covered(x, y))
            .sum();
        assert_eq!(total as f64 / 64.0, 30.0);
        // A pixel cut in half on its row (y = 207: the edge at 207.25 covers 6 of 8 sub-rows).
        let p = buf.window_pixel(105, 207).unwrap();
        assert_eq!(buf.covered(p.0, p.1), 6 * 8);
        assert!(buf.window_pixel(99, 207).is_none());
    }

    #[test]
    fn the_nearer_triangle_wins() {
        let mut buf = SampleBuffer::new(0, 0, 4, 4, 2);
        let far = |u, w| ScreenVertex { u, v: w, z: 20.0 };
        let near = |u, w| ScreenVertex { u, v: w, z: 10.0 };
        buf.draw(7, [near(-1.0, -1.0), near(5.0, -1.0), near(-1.0, 5.0)]);
        buf.draw(3, [far(-1.0, -1.0), far(9.0, -1.0), far(-1.0, 9.0)]);
        let (t, z) = buf.pixel_samples(0, 0).next().unwrap();
        assert_eq!(t, Some(7));
        assert!((z - 10.0).abs() < 1e-9);
        let (t, _) = buf.pixel_samples(3, 3).last().unwrap();
        assert_eq!(t, Some(3));
    }
}
