//! Exact silhouettes of `ref-1378x80` by ray casting, and gray chips made from them.
//!
//! A ray through a sub-pixel sample is moved into the body frame and tested against the body of
//! revolution (tangent ogive and cylinder: the squared distance from the axis along the ray is
//! minimised against the squared profile radius) and against the four fins (each a convex slab,
//! clipped Cyrus-Beck style). Coverage is counted over `ss` x `ss` samples per pixel.

/// Spec geometry (`docs/projectile.md`), metres.
const HALF_LENGTH: f64 = 0.689;
const RADIUS: f64 = 0.040;
const NOSE_LENGTH: f64 = 0.240;
const FIN_TIP_RADIUS: f64 = 0.100;
const FIN_HALF_THICKNESS: f64 = 0.002;
/// Fin leading edge: root at s = 1.258, tip at s = 1.318 (s aft of the nose tip).
const FIN_ROOT_S: f64 = 1.258;
const FIN_TIP_S: f64 = 1.318;

/// Camera intrinsics.
#[derive(Debug, Clone, Copy)]
pub struct Intrinsics {
    pub fx: f64,
    pub fy: f64,
    pub cx: f64,
    pub cy: f64,
}

/// A true pose (`docs/geometry.md`).
#[derive(Debug, Clone, Copy)]
pub struct TruePose {
    pub t: [f64; 3],
    pub pitch_deg: f64,
    pub yaw_deg: f64,
    pub roll_deg: f64,
}

type V3 = [f64; 3];

fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// R_CB = P Rz(yaw) Ry(pitch) Rx(roll), row-major.
pub fn rotation(pitch_deg: f64, yaw_deg: f64, roll_deg: f64) -> [[f64; 3]; 3] {
    let (sp, cp) = pitch_deg.to_radians().sin_cos();
    let (sy, cy) = yaw_deg.to_radians().sin_cos();
    let (sr, cr) = roll_deg.to_radians().sin_cos();
    // Rz Ry Rx in the level frame (forward, right, down), then P maps it to C = (right, down, forward).
    let l = [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ];
    [l[1], l[2], l[0]]
}

/// Full-frame pixel of a body point.
pub fn project(cam: &Intrinsics, pose: &TruePose, b: V3) -> (f64, f64) {
    let r = rotation(pose.pitch_deg, pose.yaw_deg, pose.roll_deg);
    let p: Vec<f64> = (0..3).map(|i| pose.t[i] + dot(r[i], b)).collect();
    (cam.fx * p[0] / p[2] + cam.cx, cam.fy * p[1] / p[2] + cam.cy)
}

/// The full-frame origin of a `side` x `side` chip of camera `cam` centred on the body origin
/// of `pose`, px.
pub fn centred_origin(cam: &Intrinsics, pose: &TruePose, side: usize) -> (i64, i64) {
    let (u, v) = project(cam, pose, [0.0; 3]);
    let half = side as i64 / 2;
    (u.round() as i64 - half, v.round() as i64 - half)
}

fn profile_radius(x: f64) -> f64 {
    let s = HALF_LENGTH - x;
    if !(0.0..=2.0 * HALF_LENGTH).contains(&s) {
        return -1.0;
    }
    if s >= NOSE_LENGTH {
        return RADIUS;
    }
    let rho = (RADIUS * RADIUS + NOSE_LENGTH * NOSE_LENGTH) / (2.0 * RADIUS);
    (rho * rho - (NOSE_LENGTH - s).powi(2)).max(0.0).sqrt() + RADIUS - rho
}

/// Does the body-frame ray `o + l d` (l > 0) hit the body?
fn hits(o: V3, d: V3) -> bool {
    hits_revolution(o, d) || (0..4).any(|k| hits_fin(o, d, k))
}

fn hits_revolution(o: V3, d: V3) -> bool {
    // Parameter range where the ray is within the body's axial extent (or all, if parallel-ish).
    let (l0, l1) = if d[0].abs() > 1e-12 {
        let a = (-HALF_LENGTH - o[0]) / d[0];
        let b = (HALF_LENGTH - o[0]) / d[0];
        (a.min(b), a.max(b))
    } else if o[0].abs() <= HALF_LENGTH {
        (0.0, 1e9)
    } else {
        return false;
    };
    // Fast reject: the ray's closest approach to the axis line is farther than the body radius.
    let (a2, b1, c0) = (
        d[1] * d[1] + d[2] * d[2],
        2.0 * (o[1] * d[1] + o[2] * d[2]),
        o[1] * o[1] + o[2] * o[2],
    );
    let l_min = if a2 > 0.0 {
        (-b1 / (2.0 * a2)).clamp(l0, l1)
    } else {
        l0
    };
    if a2 * l_min * l_min + b1 * l_min + c0 > RADIUS * RADIUS * 1.0001 && a2 > 0.0 {
        let (ya, yb) = (a2 * l0 * l0 + b1 * l0 + c0, a2 * l1 * l1 + b1 * l1 + c0);
        if ya.min(yb) > RADIUS * RADIUS {
            return false;
        }
    }
    let g = |l: f64| {
        let x = o[0] + l * d[0];
        let (y, z) = (o[1] + l * d[1], o[2] + l * d[2]);
        let r = profile_radius(x);
        y * y + z * z - r * r.abs()
    };
    // Dense scan then golden-section refinement around the best sample.
    let n = 120;
    let mut best = (f64::INFINITY, l0);
    for i in 0..=n {
        let l = l0 + (l1 - l0) * i as f64 / n as f64;
        let v = g(l);
        if v <= 0.0 {
            return true;
        }
        if v < best.0 {
            best = (v, l);
        }
    }
    let step = (l1 - l0) / n as f64;
    let (mut a, mut b) = (best.1 - step, best.1 + step);
    for _ in 0..60 {
        let m1 = a + 0.382 * (b - a);
        let m2 = a + 0.618 * (b - a);
        if g(m1) < g(m2) {
            b = m2;
        } else {
            a = m1;
        }
        if g(0.5 * (a + b)) <= 0.0 {
            return true;
        }
    }
    false
}

fn hits_fin(o: V3, d: V3, k: usize) -> bool {
    // Fin k points along +z_B, +y_B, -z_B, -y_B (k = 0..3).
    let (e, n): (V3, V3) = match k {
        0 => ([0.0, 0.0, 1.0], [0.0, 1.0, 0.0]),
        1 => ([0.0, 1.0, 0.0], [0.0, 0.0, 1.0]),
        2 => ([0.0, 0.0, -1.0], [0.0, 1.0, 0.0]),
        _ => ([0.0, -1.0, 0.0], [0.0, 0.0, 1.0]),
    };
    // Half-spaces a . p <= c.
    let x_root = HALF_LENGTH - FIN_ROOT_S;
    let x_tip = HALF_LENGTH - FIN_TIP_S;
    // Leading edge through (x_root, R) and (x_tip, FIN_TIP_RADIUS) in (x, u): x <= x_root + (u - R) * slope.
    let slope = (x_tip - x_root) / (FIN_TIP_RADIUS - RADIUS);
    let planes: [(V3, f64); 6] = [
        (n, FIN_HALF_THICKNESS),
        ([-n[0], -n[1], -n[2]], FIN_HALF_THICKNESS),
        (e, FIN_TIP_RADIUS),
        ([-e[0], -e[1], -e[2]], -RADIUS * 0.5), // start inside the body
        ([-1.0, 0.0, 0.0], HALF_LENGTH),        // x >= -L/2
        (
            [1.0 - 0.0, -slope * e[1], -slope * e[2]],
            x_root - slope * RADIUS,
        ),
    ];
    let (mut lo, mut hi) = (0.0f64, f64::INFINITY);
    for (a, c) in planes {
        let denom = dot(a, d);
        let num = c - dot(a, o);
        if denom.abs() < 1e-15 {
            if num < 0.0 {
                return false;
            }
            continue;
        }
        let l = num / denom;
        if denom > 0.0 {
            hi = hi.min(l);
        } else {
            lo = lo.max(l);
        }
        if lo > hi {
            return false;
        }
    }
    true
}

/// Coverage (0..1) of each pixel of a `w` x `h` chip at full-frame origin (x0, y0), with
/// `ss` x `ss` samples per pixel; only pixels near the projected body are cast.
pub fn coverage(
    cam: &Intrinsics,
    pose: &TruePose,
    x0: i64,
    y0: i64,
    w: usize,
    h: usize,
    ss: usize,
) -> Vec<f64> {
    let r = rotation(pose.pitch_deg, pose.yaw_deg, pose.roll_deg);
    // Body-frame camera origin and ray directions: o_B = R^T (-T), d_B = R^T d_C.
    let rt = |v: V3| -> V3 { [0, 1, 2].map(|j| (0..3).map(|i| r[i][j] * v[i]).sum()) };
    let o = rt([-pose.t[0], -pose.t[1], -pose.t[2]]);
    // Bounding box from the projected corners of the body's bounding box.
    let (mut u0, mut u1, mut v0, mut v1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for sx in [-HALF_LENGTH, HALF_LENGTH] {
        for sy in [-FIN_TIP_RADIUS, FIN_TIP_RADIUS] {
            for sz in [-FIN_TIP_RADIUS, FIN_TIP_RADIUS] {
                let (u, v) = project(cam, pose, [sx, sy, sz]);
                u0 = u0.min(u);
                u1 = u1.max(u);
                v0 = v0.min(v);
                v1 = v1.max(v);
            }
        }
    }
    let mut out = vec![0.0; w * h];
    let clampi = |v: f64, lo: i64, hi: i64| (v.floor() as i64).clamp(lo, hi);
    let (i0, i1) = (
        clampi(u0 - 2.0 - x0 as f64, 0, w as i64),
        clampi(u1 + 3.0 - x0 as f64, 0, w as i64),
    );
    let (j0, j1) = (
        clampi(v0 - 2.0 - y0 as f64, 0, h as i64),
        clampi(v1 + 3.0 - y0 as f64, 0, h as i64),
    );
    // Only pixels near the projected axis segment can be covered.
    let (nu, nv) = project(cam, pose, [HALF_LENGTH, 0.0, 0.0]);
    let (tu, tv) = project(cam, pose, [-HALF_LENGTH, 0.0, 0.0]);
    let reach = FIN_TIP_RADIUS * cam.fx.max(cam.fy) / pose.t[2] + 2.0;
    let near_axis = |u: f64, v: f64| {
        let (ax, ay) = (nu - tu, nv - tv);
        let len2 = (ax * ax + ay * ay).max(1e-12);
        let k = (((u - tu) * ax + (v - tv) * ay) / len2).clamp(0.0, 1.0);
        let (px, py) = (tu + k * ax - u, tv + k * ay - v);
        px * px + py * py <= reach * reach
    };
    for j in j0..j1 {
        for i in i0..i1 {
            if !near_axis((x0 + i) as f64, (y0 + j) as f64) {
                continue;
            }
            let mut hit = 0usize;
            for sj in 0..ss {
                for si in 0..ss {
                    let u = (x0 + i) as f64 - 0.5 + (si as f64 + 0.5) / ss as f64;
                    let v = (y0 + j) as f64 - 0.5 + (sj as f64 + 0.5) / ss as f64;
                    let dc = [(u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1.0];
                    if hits(o, rt(dc)) {
                        hit += 1;
                    }
                }
            }
            out[j as usize * w + i as usize] = hit as f64 / (ss * ss) as f64;
        }
    }
    out
}

/// Gaussian blur (separable, truncated at 4 sigma) of a `w` x `h` image.
pub fn blur(img: &[f64], w: usize, h: usize, sigma: f64) -> Vec<f64> {
    if sigma <= 0.0 {
        return img.to_vec();
    }
    let radius = (4.0 * sigma).ceil() as i64;
    let kernel: Vec<f64> = (-radius..=radius)
        .map(|k| (-(k * k) as f64 / (2.0 * sigma * sigma)).exp())
        .collect();
    let norm: f64 = kernel.iter().sum();
    let pass = |src: &[f64], horizontal: bool| -> Vec<f64> {
        let mut dst = vec![0.0; w * h];
        for y in 0..h as i64 {
            for x in 0..w as i64 {
                let mut acc = 0.0;
                for (k, kv) in (-radius..=radius).zip(&kernel) {
                    let (sx, sy) = if horizontal {
                        ((x + k).clamp(0, w as i64 - 1), y)
                    } else {
                        (x, (y + k).clamp(0, h as i64 - 1))
                    };
                    acc += kv * src[(sy as usize) * w + sx as usize];
                }
                dst[y as usize * w + x as usize] = acc / norm;
            }
        }
        dst
    };
    pass(&pass(img, true), false)
}

/// A small deterministic PRNG (SplitMix64) for test noise.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn gaussian(&mut self) -> f64 {
        let (u1, u2) = (self.uniform().max(1e-300), self.uniform());
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}

/// Chip-making settings.
#[derive(Debug, Clone, Copy)]
pub struct ChipStyle {
    /// Sky level, grey levels.
    pub sky: f64,
    /// Body level, grey levels.
    pub body: f64,
    /// Sky gradient, grey levels per px along x and y.
    pub gradient: (f64, f64),
    /// PSF sigma, px.
    pub psf_sigma: f64,
    /// Gaussian noise sigma, grey levels.
    pub noise: f64,
}

/// An 8-bit chip of the projectile at `pose`, its half-coverage mask, and the coverage.
pub fn chip_u8(
    cam: &Intrinsics,
    pose: &TruePose,
    origin: (i64, i64),
    size: (usize, usize),
    style: &ChipStyle,
    rng: &mut Rng,
) -> (Vec<u8>, Vec<bool>) {
    let (w, h) = size;
    let cov = coverage(cam, pose, origin.0, origin.1, w, h, 8);
    let sharp: Vec<f64> = cov.iter().map(|c| c * (style.body - style.sky)).collect();
    let blurred = blur(&sharp, w, h, style.psf_sigma);
    let mut out = vec![0u8; w * h];
    for y in 0..h {
        for x in 0..w {
            let sky = style.sky + style.gradient.0 * x as f64 + style.gradient.1 * y as f64;
            let v = sky + blurred[y * w + x] + style.noise * rng.gaussian();
            out[y * w + x] = v.round().clamp(0.0, 255.0) as u8;
        }
    }
    (out, cov.iter().map(|&c| c >= 0.5).collect())
}
