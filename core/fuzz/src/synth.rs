//! Chips synthesized from a fuzzer-chosen description: size, stride, bit depth, a sky with a
//! gradient and noise, bars and projectile silhouettes (drawn with the core's own silhouette
//! renderer at any tilt, roll, scale and direction), an optional blur, and raw bytes written
//! over the samples. Small inputs thus reach large, structured chips, which raw chip bytes
//! (64 KiB for one 256 x 256 chip) would not.

use arbitrary::Arbitrary;
use imade_core::lut::render::{self, Placement, View};
use imade_core::mask::ChipMask;
use imade_core::{ChipError, ChipView, ImagePoint};

/// Largest side drawn, px: beyond the core's 512 so that oversized chips are tried too.
const MAX_SIDE: usize = 540;
/// Largest side of the other chips, px: most chips are small, for speed.
const SMALL_SIDE: usize = 128;
/// Most shapes drawn in one chip.
const MAX_SHAPES: usize = 4;

/// A chip's description.
#[derive(Arbitrary, Debug, Clone)]
pub struct ChipSpec {
    /// Width and height, px, modulo [`MAX_SIDE`] when `large % 8 == 0`, else modulo
    /// [`SMALL_SIDE`] (0 and more than 512 are refused by the core).
    pub size: (u16, u16),
    /// Selects large sizes (one value in eight).
    pub large: u8,
    /// Extra samples per row: the stride is the width plus `pad % 8`.
    pub pad: u8,
    /// 0x5A: the buffer is one sample shorter than the view needs.
    pub cut: u8,
    /// 16-bit samples.
    pub wide: bool,
    /// Sky level, 1/65535 of full scale.
    pub sky: u16,
    /// Sky gradient along x and y, full-scale/256 per 16 px.
    pub gradient: (i8, i8),
    /// Uniform noise amplitude, full-scale/512 per unit.
    pub noise: u8,
    /// Noise seed.
    pub seed: u32,
    /// Blur with a 3 x 3 box after drawing (a point-spread function).
    pub blur: bool,
    /// Shapes, the first [`MAX_SHAPES`] drawn.
    pub shapes: Vec<Shape>,
    /// Raw bytes written over the samples.
    pub raw: Raw,
}

/// Bytes written into the sample buffer as they are, from sample `at` on.
#[derive(Arbitrary, Debug, Clone)]
pub struct Raw {
    /// First sample overwritten (modulo the buffer length).
    pub at: u32,
    /// The bytes (one per sample; a 16-bit sample repeats the byte in both halves).
    pub bytes: Vec<u8>,
}

/// A shape added to the sky, `level` (full-scale/32768 per unit, either sign) over its pixels.
#[derive(Arbitrary, Debug, Clone)]
pub enum Shape {
    /// A rotated rectangle.
    Bar {
        /// Centre, px.
        centre: (i16, i16),
        /// Length, px (modulo 1024).
        length: u16,
        /// Width, px.
        width: u8,
        /// Direction, 1/65536 turn.
        angle: u16,
        /// Contrast.
        level: i16,
    },
    /// The reference projectile's silhouette.
    Projectile {
        /// Body origin, px (modulo 1024, either sign: vertices stay within embedded-graphics'
        /// i32 triangle arithmetic).
        centre: (i16, i16),
        /// Scale, px per metre (modulo 256: up to a 353 px body).
        px_per_m: u16,
        /// Projected axis direction, 1/65536 turn.
        angle: u16,
        /// Tilt out of the image plane, deg (modulo 91).
        tilt: u8,
        /// Roll, deg (modulo 90).
        roll: u8,
        /// Contrast.
        level: i16,
    },
}

/// A synthesized sample buffer.
pub enum Samples {
    /// 8-bit samples.
    U8(Vec<u8>),
    /// 16-bit samples.
    U16(Vec<u16>),
}

/// A synthesized chip: its samples and the view's geometry.
pub struct Chip {
    /// The samples, rows `stride` apart.
    pub samples: Samples,
    /// Width, px.
    pub width: usize,
    /// Height, px.
    pub height: usize,
    /// Samples between rows.
    pub stride: usize,
}

impl Chip {
    /// The core's view of the chip at full-frame `origin` (an error for a refused geometry).
    pub fn view(&self, origin: (i32, i32)) -> Result<ChipView<'_>, ChipError> {
        let (w, h, s) = (self.width, self.height, self.stride);
        match &self.samples {
            Samples::U8(p) => ChipView::gray8(p, w, h, s, origin.0, origin.1),
            Samples::U16(p) => ChipView::gray16(p, w, h, s, origin.0, origin.1),
        }
    }
}

/// A pixel's uniform noise in [-1, 1) (SplitMix64 finalizer of seed and position).
fn noise(seed: u32, x: usize, y: usize) -> f32 {
    let mut z = ((u64::from(seed) << 40) ^ ((y as u64) << 20) ^ x as u64)
        .wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 23) as f32 - 1.0
}

/// The unit vector at `angle` (1/65536 turn).
fn direction(angle: u16) -> ImagePoint {
    let a = f32::from(angle) / 65536.0 * std::f32::consts::TAU;
    ImagePoint::new(a.cos(), a.sin())
}

/// Draws `spec`; `scratch` is a mask for the projectile silhouettes.
pub fn synthesize(spec: &ChipSpec, scratch: &mut ChipMask) -> Chip {
    let side = if spec.large.is_multiple_of(8) {
        MAX_SIDE
    } else {
        SMALL_SIDE
    };
    let width = usize::from(spec.size.0) % side;
    let height = usize::from(spec.size.1) % side;
    let full = if spec.wide { 65535.0 } else { 255.0 };
    let unit = full / 256.0;
    let sky = f32::from(spec.sky) / 65535.0 * full;
    let (gx, gy) = (
        f32::from(spec.gradient.0) * unit / 16.0,
        f32::from(spec.gradient.1) * unit / 16.0,
    );
    let amplitude = f32::from(spec.noise) * unit / 2.0;
    let mut image = vec![0.0f32; width * height];
    for (y, row) in image.chunks_exact_mut(width.max(1)).enumerate() {
        for (x, v) in row.iter_mut().enumerate() {
            *v = sky + gx * x as f32 + gy * y as f32;
            if amplitude > 0.0 {
                *v += amplitude * noise(spec.seed, x, y);
            }
        }
    }
    for shape in spec.shapes.iter().take(MAX_SHAPES) {
        let level = |l: i16| f32::from(l) / 32768.0 * full;
        match *shape {
            Shape::Bar {
                centre,
                length,
                width: bar_width,
                angle,
                level: l,
            } => draw_bar(
                &mut image,
                (width, height),
                (f32::from(centre.0), f32::from(centre.1)),
                (f32::from(length % 1024), f32::from(bar_width)),
                direction(angle),
                level(l),
            ),
            Shape::Projectile {
                centre,
                px_per_m,
                angle,
                tilt,
                roll,
                level: l,
            } => {
                let view = View {
                    tilt_deg: f32::from(tilt % 91),
                    roll_deg: f32::from(roll % 90),
                };
                let placement = Placement {
                    origin: ImagePoint::new(f32::from(centre.0 % 1024), f32::from(centre.1 % 1024)),
                    dir: direction(angle),
                    px_per_unit: f32::from(px_per_m % 256),
                };
                draw_projectile(
                    &mut image,
                    (width, height),
                    &view,
                    &placement,
                    level(l),
                    scratch,
                );
            }
        }
    }
    if spec.blur && width > 0 && height > 0 {
        box_blur(&mut image, width, height);
    }
    let stride = width + usize::from(spec.pad % 8);
    let mut len = stride * height.saturating_sub(1) + width;
    if spec.cut == 0x5A {
        len = len.saturating_sub(1);
    }
    // Row-major, the padding at the sky level, cut to `len` samples; then the raw bytes.
    let raw_at = spec.raw.at as usize % len.max(1);
    let samples = if spec.wide {
        let mut s = pack(&image, (width, height, stride), sky, len, |v| {
            v.clamp(0.0, 65535.0) as u16
        });
        for (slot, b) in s.iter_mut().skip(raw_at).zip(&spec.raw.bytes) {
            *slot = u16::from_le_bytes([*b, *b]);
        }
        Samples::U16(s)
    } else {
        let mut s = pack(&image, (width, height, stride), sky, len, |v| {
            v.clamp(0.0, 255.0) as u8
        });
        for (slot, b) in s.iter_mut().skip(raw_at).zip(&spec.raw.bytes) {
            *slot = *b;
        }
        Samples::U8(s)
    };
    Chip {
        samples,
        width,
        height,
        stride,
    }
}

/// Adds `level` over a rectangle of (length, width) px centred at `centre` along `dir`.
fn draw_bar(
    image: &mut [f32],
    (width, height): (usize, usize),
    centre: (f32, f32),
    size: (f32, f32),
    dir: ImagePoint,
    level: f32,
) {
    // The rectangle lies within its half-diagonal of the centre.
    let reach = 0.5 * size.0.hypot(size.1) + 1.0;
    let span = |c: f32, n: usize| {
        let lo = (c - reach).clamp(0.0, n as f32) as usize;
        lo..((c + reach).clamp(0.0, n as f32) as usize).max(lo)
    };
    for y in span(centre.1, height) {
        for x in span(centre.0, width) {
            let (dx, dy) = (x as f32 - centre.0, y as f32 - centre.1);
            let along = dx * dir.x + dy * dir.y;
            let across = -dx * dir.y + dy * dir.x;
            if 2.0 * along.abs() <= size.0 && 2.0 * across.abs() <= size.1 {
                image[y * width + x] += level;
            }
        }
    }
}

/// Adds `level` over the reference projectile's silhouette.
fn draw_projectile(
    image: &mut [f32],
    (width, height): (usize, usize),
    view: &View,
    placement: &Placement,
    level: f32,
    scratch: &mut ChipMask,
) {
    if scratch.reset(width, height).is_err() {
        return;
    }
    let Ok(()) = render::draw(scratch, &crate::reference(), view, placement);
    for (y, row) in image.chunks_exact_mut(width.max(1)).enumerate() {
        for (x, v) in row.iter_mut().enumerate() {
            if scratch.get(x, y) {
                *v += level;
            }
        }
    }
}

/// The samples of `image` (`width` x `height`) in rows of `stride`, the padding at `pad`, the
/// first `len` of them, converted by `convert`.
fn pack<T: Copy>(
    image: &[f32],
    (width, height, stride): (usize, usize, usize),
    pad: f32,
    len: usize,
    convert: impl Fn(f32) -> T,
) -> Vec<T> {
    let mut samples = Vec::with_capacity(stride * height);
    for row in image.chunks_exact(width.max(1)).take(height) {
        samples.extend(row.iter().map(|&v| convert(v)));
        samples.extend(std::iter::repeat_n(convert(pad), stride - width));
    }
    samples.truncate(len);
    samples.resize(len, convert(pad));
    samples
}

/// A 3 x 3 box blur: the mean of the neighbours inside the chip, a row pass then a column pass.
fn box_blur(image: &mut [f32], width: usize, height: usize) {
    let mut rows = image.to_vec();
    for (row, out) in image.chunks_exact(width).zip(rows.chunks_exact_mut(width)) {
        for (x, v) in out.iter_mut().enumerate() {
            let window = &row[x.saturating_sub(1)..(x + 2).min(width)];
            *v = window.iter().sum::<f32>() / window.len() as f32;
        }
    }
    for y in 0..height {
        let (lo, hi) = (y.saturating_sub(1), (y + 2).min(height));
        for x in 0..width {
            let sum: f32 = (lo..hi).map(|sy| rows[sy * width + x]).sum();
            image[y * width + x] = sum / (hi - lo) as f32;
        }
    }
}
