//! The training data: chips rendered by the simulator with their true masks and poses, and for
//! each training sample a shape prior drawn online at a randomly perturbed true pose (the
//! source paper's future direction 2), both resampled on the crop the core's TETRIS reads.

use crate::clip::ChipImage;
use crate::sim::camera::Intrinsics;
use crate::sim::math::{Mat3, Vec3};
use crate::sim::model::ProjectileModel;
use crate::sim::pose::BodyPose;
use crate::sim::random::{Purpose, Random, mix64};
use crate::sim::render::silhouette_mask;
use crate::sim::{Scenario, Simulation, presets};
use anyhow::Context;
use imade_core::mask::ChipMask;
use imade_core::shape_guided::tetris::input::{CropFrame, PLANE};
use imade_core::shape_guided::tetris::network::INPUT_LEN;
use imade_core::shape_guided::{Affine2, PriorShape};
use rayon::prelude::*;
use std::sync::Arc;

/// The presets the chips come from, each with its own seeds (never the bundled clips' scenes):
/// clear and cloudy skies, a body flying at the camera, a pale body with a bright plume, and
/// the three clutter presets (faint bodies, plumes, filaments, terrain, randomized physics).
pub const PRESETS: [&str; 7] = [
    "table1-train",
    "clear-sky",
    "towards-camera",
    "low-contrast-plume",
    "clutter-faint-plume",
    "clutter-terrain",
    "clutter-random",
];

/// The crop's length along the prior's axis, in prior lengths, and its width across, in prior
/// widths: room for the prior to be a fifth of its length or one and a half widths off.
pub const CROP_LENGTHS: f32 = 1.5;
/// See [`CROP_LENGTHS`].
pub const CROP_WIDTHS: f32 = 4.0;

/// How far the prior's pose is perturbed from the truth, one sigma each at scale 1; each draw
/// scales all but the roll by a factor log-uniform in `[min_scale, max_scale]`, so that the
/// network sees priors from nearly right (a table match on a clear sky) to far off (one in
/// clutter), and learns to leave a right one where it is.
#[derive(Debug, Clone, Copy)]
pub struct Perturbation {
    /// Shift of the body origin in the image, px, plus ...
    pub shift_px: f64,
    /// ... this fraction of the true mask's extent (its bounding box's diagonal).
    pub shift_fraction: f64,
    /// Log of the range's scale (the silhouette's size).
    pub log_scale: f64,
    /// Rotation about the line of sight (the silhouette's angle in the image), deg.
    pub in_plane_deg: f64,
    /// Rotation about an axis across the line of sight (its tilt out of the image), deg.
    pub out_of_plane_deg: f64,
    /// Roll about the body axis, deg (not scaled).
    pub roll_deg: f64,
    /// The least factor of a draw's sigmas ...
    pub min_scale: f64,
    /// ... and the greatest.
    pub max_scale: f64,
}

impl Perturbation {
    /// The trainer's defaults.
    pub const DEFAULT: Perturbation = Perturbation {
        shift_px: 0.5,
        shift_fraction: 0.02,
        log_scale: 0.04,
        in_plane_deg: 2.0,
        out_of_plane_deg: 4.0,
        roll_deg: 20.0,
        min_scale: 0.1,
        max_scale: 3.0,
    };
}

/// One rendered chip with what the prior needs: the camera, the model and the true pose.
pub struct TrainingChip {
    /// The chip as recorded.
    pub chip: ChipImage,
    /// The chip's full-frame origin, px.
    pub origin: (i64, i64),
    /// The true mask.
    pub truth: Box<ChipMask>,
    /// The extent of the true mask: its bounding box's diagonal, px.
    pub extent_px: f64,
    /// The camera.
    pub intrinsics: Intrinsics,
    /// The model that flies (shared by the clip's chips).
    pub model: Arc<ProjectileModel>,
    /// The true pose in the camera frame.
    pub body: BodyPose,
}

/// One sample: the network's input and the target plane (the true mask on the crop).
pub struct Sample {
    /// `[channel][row][column]`: the chip normalized, the prior.
    pub input: Box<[f32; INPUT_LEN]>,
    /// The true mask on the crop, `[row][column]`.
    pub target: Box<[f32; PLANE]>,
}

/// Renders `frames` chips of each clip of `clips` (clip `k` is preset `k` mod 7 with a seed of
/// its own from `seed`); a chip whose body is cut by the chip's edge is left out.
pub fn render_chips(
    seed: u64,
    clips: std::ops::Range<usize>,
    frames: usize,
) -> anyhow::Result<Vec<TrainingChip>> {
    let per_clip: Vec<anyhow::Result<Vec<TrainingChip>>> = clips
        .into_par_iter()
        .map(|clip| clip_chips(seed, clip, frames))
        .collect();
    let mut chips = Vec::new();
    for clip in per_clip {
        chips.extend(clip?);
    }
    anyhow::ensure!(!chips.is_empty(), "no training chip could be rendered");
    Ok(chips)
}

fn clip_chips(seed: u64, clip: usize, frames: usize) -> anyhow::Result<Vec<TrainingChip>> {
    let name = PRESETS[clip % PRESETS.len()];
    let mut scenario: Scenario = presets::preset(name).context("a training preset")?;
    scenario.seed = mix64(seed ^ mix64(clip as u64 + 0x7e7_0000));
    let simulation = Simulation::new(scenario).with_context(|| format!("preset {name}"))?;
    let model = Arc::new(simulation.model().clone());
    let mut random = Random::new(seed, Purpose::Training, clip as u64);
    let planned = simulation.plans().len();
    let mut chips = Vec::with_capacity(frames);
    for _ in 0..frames {
        let index = random.index(planned);
        let plan = &simulation.plans()[index];
        let rendered = simulation.render_frame(index)?;
        let (w, h) = (rendered.chip.width as usize, rendered.chip.height as usize);
        let truth = chip_mask(w, h, rendered.mask.pixels().map(|p| p.0[0] > 0))
            .with_context(|| format!("a {w} x {h} chip is larger than the core's masks"))?;
        // A body cut by the chip's edge or not in it is no sample.
        let Some(PriorShape {
            bbox: [x0, x1, y0, y1],
            ..
        }) = PriorShape::measure(&truth)
        else {
            continue;
        };
        if rendered.mask_pixels < 4 || x0 == 0 || y0 == 0 || x1 + 1 >= w || y1 + 1 >= h {
            continue;
        }
        chips.push(TrainingChip {
            chip: rendered.chip,
            origin: plan.chip_origin,
            truth,
            extent_px: ((x1 - x0) as f64).hypot((y1 - y0) as f64),
            intrinsics: *simulation.intrinsics(),
            model: Arc::clone(&model),
            body: plan.body,
        });
    }
    Ok(chips)
}

impl TrainingChip {
    /// The sample of this chip with a prior drawn at the true pose perturbed by `random`
    /// (`None` where the perturbed prior leaves the chip or is empty).
    pub fn sample(&self, perturbation: &Perturbation, random: &mut Random) -> Option<Sample> {
        let prior = self.prior(perturbation, random)?;
        let shape = PriorShape::measure(&prior)?;
        let frame = CropFrame::with_proportions(&shape, CROP_LENGTHS, CROP_WIDTHS);
        let view = self.view()?;
        let mut input = Box::new([0.0f32; INPUT_LEN]);
        frame.fill(&view, &prior, &Affine2::IDENTITY, &mut input);
        let mut target = Box::new([0.0f32; PLANE]);
        frame.sample_mask(&self.truth, &mut target[..]);
        Some(Sample { input, target })
    }

    /// The model's silhouette at the true pose perturbed by `random`, chip-sized (`None` where
    /// it cannot be drawn: behind the camera).
    pub fn prior(&self, perturbation: &Perturbation, random: &mut Random) -> Option<Box<ChipMask>> {
        let body = self.perturbed(perturbation, random);
        let (w, h) = (self.chip.width as usize, self.chip.height as usize);
        let drawn =
            silhouette_mask(&self.intrinsics, self.origin, (w, h), &self.model, &body, 1).ok()?;
        chip_mask(w, h, drawn.into_iter())
    }

    /// The chip as the core reads it.
    pub fn view(&self) -> Option<imade_core::ChipView<'_>> {
        self.chip
            .view(self.origin.0 as i32, self.origin.1 as i32)
            .ok()
    }

    /// The true pose moved by one draw of `perturbation`.
    fn perturbed(&self, p: &Perturbation, random: &mut Random) -> BodyPose {
        let t = self.body.translation;
        let sight = t.normalized();
        let k = &self.intrinsics;
        let size = random.between(p.min_scale.ln(), p.max_scale.ln()).exp();
        let shift = size * (p.shift_px + p.shift_fraction * self.extent_px);
        let (du, dv) = (shift * random.gaussian(), shift * random.gaussian());
        let scale = (size * p.log_scale * random.gaussian()).exp();
        let moved = Vec3::new(t.x + du * t.z / k.fx, t.y + dv * t.z / k.fy, t.z) * scale;
        // An axis across the line of sight, at a random angle about it.
        let across = sight.cross(Vec3::new(0.0, 1.0, 0.0)).normalized();
        let across = rotation(sight, random.between(0.0, std::f64::consts::TAU)) * across;
        let turn = rotation(
            sight,
            size * p.in_plane_deg.to_radians() * random.gaussian(),
        ) * rotation(
            across,
            size * p.out_of_plane_deg.to_radians() * random.gaussian(),
        );
        let roll = Mat3::rot_x(p.roll_deg.to_radians() * random.gaussian());
        BodyPose {
            translation: moved,
            rotation: turn * self.body.rotation * roll,
        }
    }
}

/// A `w` x `h` chip mask of `bits` (row-major), `None` where it is larger than a chip mask.
fn chip_mask(w: usize, h: usize, bits: impl Iterator<Item = bool>) -> Option<Box<ChipMask>> {
    let mut mask = Box::new(ChipMask::new());
    mask.reset(w, h).ok()?;
    for (i, _) in bits.enumerate().filter(|(_, on)| *on) {
        mask.set(i % w, i / w, true);
    }
    Some(mask)
}

/// The rotation by `angle` rad about unit `axis` (Rodrigues).
fn rotation(axis: Vec3, angle: f64) -> Mat3 {
    let (s, c) = angle.sin_cos();
    let (x, y, z) = (axis.x, axis.y, axis.z);
    let t = 1.0 - c;
    Mat3::from_cols(
        Vec3::new(t * x * x + c, t * x * y + s * z, t * x * z - s * y),
        Vec3::new(t * x * y - s * z, t * y * y + c, t * y * z + s * x),
        Vec3::new(t * x * z + s * y, t * y * z - s * x, t * z * z + c),
    )
}
