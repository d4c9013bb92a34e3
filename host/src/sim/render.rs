//! Renders one chip: background (sky, clouds, terrain, the near hillside, the filaments behind the
//! body, the second object), the shaded body from the supersampled z-buffer, the plume, the
//! filaments in front of the body, the PSF; and the ground-truth mask (pixels at least half
//! covered by the body alone, before any blur).

use super::camera::{CameraPose, Intrinsics};
use super::clutter::{FrameClutter, NoiseModel};
use super::math::Vec3;
use super::mesh::Mesh;
use super::model::ProjectileModel;
use super::plume::{Puff, add_plume};
use super::pose::BodyPose;
use super::raster::{SampleBuffer, ScreenVertex};
use super::sensor::{blur_interior, psf_reach};
use super::sky::Environment;
use anyhow::ensure;

/// Everything that fixes one chip's radiance.
#[derive(Debug, Clone, Copy)]
pub struct FrameScene<'a> {
    /// Camera intrinsics.
    pub intrinsics: &'a Intrinsics,
    /// Where the camera is and points.
    pub camera: &'a CameraPose,
    /// Full-frame pixel of the chip's top-left pixel.
    pub chip_origin: (i64, i64),
    /// Chip width and height, px.
    pub chip_size: (u32, u32),
    /// The model that flies.
    pub model: &'a ProjectileModel,
    /// Its pose in the camera frame.
    pub body: &'a BodyPose,
    /// Paint albedo.
    pub albedo: f64,
    /// Time after launch, s (moves the clouds).
    pub time_s: f64,
    /// Sky, clouds, terrain, sun.
    pub environment: &'a Environment,
    /// This frame's plume.
    pub puffs: &'a [Puff],
    /// PSF sigma, px.
    pub psf_sigma_px: f64,
    /// Samples per pixel along each axis.
    pub supersampling: usize,
    /// Filaments, the second object, the near hillside and the body's set contrast, if any.
    pub clutter: Option<FrameClutter<'a>>,
}

/// One rendered chip before the sensor: radiance and the mask, row-major, chip-sized.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderedChip {
    /// Radiance after the PSF, relative units.
    pub radiance: Vec<f64>,
    /// Ground-truth mask: pixels at least half covered by the body.
    pub mask: Vec<bool>,
}

/// Renders a chip.
pub fn render(scene: &FrameScene) -> anyhow::Result<RenderedChip> {
    let (cw, ch) = (scene.chip_size.0 as usize, scene.chip_size.1 as usize);
    let margin = psf_reach(scene.psf_sigma_px) + 1;
    let (wx0, wy0) = (
        scene.chip_origin.0 - margin as i64,
        scene.chip_origin.1 - margin as i64,
    );
    let (ww, wh) = (cw + 2 * margin, ch + 2 * margin);
    let k = scene.intrinsics;

    // Background along each pixel's ray.
    let ridge = scene.clutter.and_then(|c| c.ridge);
    let mut image = Vec::with_capacity(ww * wh);
    for y in 0..wh {
        for x in 0..ww {
            let ray = k.ray((wx0 + x as i64) as f64, (wy0 + y as i64) as f64);
            let d = scene.camera.direction_to_world(ray).normalized();
            let near = ridge.and_then(|r| scene.environment.near_terrain(d, &r));
            image.push(near.unwrap_or_else(|| {
                scene
                    .environment
                    .background(scene.camera.position, d, scene.time_s)
            }));
        }
    }
    if let Some(clutter) = &scene.clutter {
        clutter.draw(&mut image, (wx0, wy0, ww), scene.chip_origin, false);
    }

    // The body: project, shade per triangle, rasterize over its bounding box.
    let mesh = &scene.model.mesh;
    let (points, screen) = project(k, scene.model, scene.body)?;
    let samples = body_samples(&screen, (wx0, wy0, ww, wh), scene.supersampling, mesh);
    let mut shades = triangle_radiance(scene, &points);
    if let Some(clutter) = &scene.clutter
        && let Some(contrast) = clutter.body_contrast_sigma
    {
        set_contrast(
            &mut shades,
            &image,
            (wx0, wy0, ww),
            &samples,
            contrast,
            &clutter.noise,
        );
    }
    let s2 = samples.samples_per_pixel() as f64;
    let (bx0, by0) = samples.origin();
    let (bw, bh) = samples.size();
    for py in 0..bh {
        for px in 0..bw {
            let (x, y) = (bx0 + px as i64 - wx0, by0 + py as i64 - wy0);
            let index = y as usize * ww + x as usize;
            let (mut covered, mut body) = (0.0, 0.0);
            for (t, _) in samples.pixel_samples(px, py) {
                if let Some(t) = t {
                    covered += 1.0;
                    body += shades[t as usize];
                }
            }
            image[index] = image[index] * (1.0 - covered / s2) + body / s2;
        }
    }

    let range = scene.body.translation.norm();
    let transmission = scene.environment.transmission(range);
    add_plume(
        &mut image,
        (wx0, wy0, ww),
        scene.puffs,
        scene.body,
        k,
        &samples,
        transmission,
    );

    if let Some(clutter) = &scene.clutter {
        clutter.draw(&mut image, (wx0, wy0, ww), scene.chip_origin, true);
    }

    let radiance = blur_interior(&image, ww, wh, scene.psf_sigma_px, margin);
    let mask = chip_mask(&samples, scene.chip_origin, (cw, ch));
    Ok(RenderedChip { radiance, mask })
}

/// The mask of the body alone at pose `body` (pixels at least half covered by `supersampling`²
/// samples, row-major, chip-sized), without rendering the radiance: the trainer's shape prior
/// at a perturbed pose.
pub fn silhouette_mask(
    intrinsics: &Intrinsics,
    chip_origin: (i64, i64),
    (cw, ch): (usize, usize),
    model: &ProjectileModel,
    body: &BodyPose,
    supersampling: usize,
) -> anyhow::Result<Vec<bool>> {
    let (_, screen) = project(intrinsics, model, body)?;
    let window = (chip_origin.0, chip_origin.1, cw, ch);
    let samples = body_samples(&screen, window, supersampling, &model.mesh);
    Ok(chip_mask(&samples, chip_origin, (cw, ch)))
}

/// The mesh's vertices in the camera frame, m, and on the full frame, px; an error where one
/// is not in front of the camera.
fn project(
    k: &Intrinsics,
    model: &ProjectileModel,
    body: &BodyPose,
) -> anyhow::Result<(Vec<Vec3>, Vec<ScreenVertex>)> {
    let mut points = Vec::with_capacity(model.mesh.vertices.len());
    for &b in &model.mesh.vertices {
        let p = body.to_camera(b);
        ensure!(
            p.z > 1.0,
            "the projectile is behind or at the camera (depth {} m)",
            p.z
        );
        points.push(p);
    }
    let screen = points
        .iter()
        .map(|p| ScreenVertex {
            u: k.fx * p.x / p.z + k.cx,
            v: k.fy * p.y / p.z + k.cy,
            z: p.z,
        })
        .collect();
    Ok((points, screen))
}

/// The chip's pixels at least half covered in `samples`.
fn chip_mask(
    samples: &SampleBuffer,
    chip_origin: (i64, i64),
    (cw, ch): (usize, usize),
) -> Vec<bool> {
    let mut mask = vec![false; cw * ch];
    for (i, m) in mask.iter_mut().enumerate() {
        let (x, y) = (
            chip_origin.0 + (i % cw) as i64,
            chip_origin.1 + (i / cw) as i64,
        );
        if let Some((px, py)) = samples.window_pixel(x, y) {
            *m = 2 * samples.covered(px, py) >= samples.samples_per_pixel();
        }
    }
    mask
}

/// The radiance each triangle sends to the camera: Lambertian shading of the side facing the
/// camera, seen through the haze.
fn triangle_radiance(scene: &FrameScene, points: &[Vec3]) -> Vec<f64> {
    let camera_to_world = scene.camera.r_cw.transpose();
    let centre_w = scene.camera.position + camera_to_world * scene.body.translation;
    let light = scene.environment.illumination(centre_w, scene.time_s);
    let line_of_sight = camera_to_world * scene.body.translation.normalized();
    let airlight = scene.environment.clear_sky(line_of_sight);
    let transmission = scene
        .environment
        .transmission(scene.body.translation.norm());
    scene
        .model
        .mesh
        .triangles
        .iter()
        .map(|&[a, b, c]| {
            let (pa, pb, pc) = (points[a as usize], points[b as usize], points[c as usize]);
            let mut n = (pb - pa).cross(pc - pa).normalized();
            if n.dot(pa) > 0.0 {
                n = -n;
            }
            let lit = light.radiance(camera_to_world * n, scene.albedo);
            lit * transmission + airlight * (1.0 - transmission)
        })
        .collect()
}

/// Share of the body's contrast that its shading spreads about the mean, either way.
const SHADING_SPREAD: f64 = 0.3;

/// Sets the body's radiance so that its mean over the visible samples differs from the mean
/// background behind it (`image` before the body) by `contrast` noise sigmas at that background,
/// keeping the Lambertian shading's pattern across the triangles as a spread of
/// [`SHADING_SPREAD`] of the contrast.
fn set_contrast(
    shades: &mut [f64],
    image: &[f64],
    (wx0, wy0, ww): (i64, i64, usize),
    samples: &SampleBuffer,
    contrast: f64,
    noise: &NoiseModel,
) {
    let mut counts = vec![0usize; shades.len()];
    let (mut behind, mut weight) = (0.0, 0.0);
    let (bx0, by0) = samples.origin();
    let (bw, bh) = samples.size();
    for py in 0..bh {
        for px in 0..bw {
            let mut covered = 0usize;
            for (t, _) in samples.pixel_samples(px, py) {
                if let Some(t) = t {
                    counts[t as usize] += 1;
                    covered += 1;
                }
            }
            if covered > 0 {
                let (x, y) = (bx0 + px as i64 - wx0, by0 + py as i64 - wy0);
                behind += covered as f64 * image[y as usize * ww + x as usize];
                weight += covered as f64;
            }
        }
    }
    if weight == 0.0 {
        return;
    }
    let background = behind / weight;
    let mean = counts
        .iter()
        .zip(shades.iter())
        .map(|(&n, &s)| n as f64 * s)
        .sum::<f64>()
        / weight;
    let spread = counts
        .iter()
        .zip(shades.iter())
        .filter(|(n, _)| **n > 0)
        .map(|(_, &s)| (s - mean).abs())
        .fold(0.0, f64::max);
    let delta = contrast * noise.sigma(background);
    for s in shades.iter_mut() {
        let pattern = if spread > 0.0 {
            (*s - mean) / spread
        } else {
            0.0
        };
        *s = (background + delta + SHADING_SPREAD * delta.abs() * pattern).max(0.0);
    }
}

/// Rasterizes the mesh into a sample buffer over its bounding box within the window.
fn body_samples(
    screen: &[ScreenVertex],
    (wx0, wy0, ww, wh): (i64, i64, usize, usize),
    supersampling: usize,
    mesh: &Mesh,
) -> SampleBuffer {
    let (mut u0, mut u1, mut v0, mut v1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for p in screen {
        u0 = u0.min(p.u);
        u1 = u1.max(p.u);
        v0 = v0.min(p.v);
        v1 = v1.max(p.v);
    }
    let clamp_x = |u: f64| (libm::round(u) as i64).clamp(wx0, wx0 + ww as i64 - 1);
    let clamp_y = |v: f64| (libm::round(v) as i64).clamp(wy0, wy0 + wh as i64 - 1);
    let (x0, x1, y0, y1) = (clamp_x(u0), clamp_x(u1), clamp_y(v0), clamp_y(v1));
    let mut buffer = SampleBuffer::new(
        x0,
        y0,
        (x1 - x0 + 1) as usize,
        (y1 - y0 + 1) as usize,
        supersampling,
    );
    for (id, &[a, b, c]) in mesh.triangles.iter().enumerate() {
        buffer.draw(
            id as u32,
            [screen[a as usize], screen[b as usize], screen[c as usize]],
        );
    }
    buffer
}
