//! A whole simulated clip: plans the frames, renders them (in parallel, with results that do not
//! depend on the thread count), and writes the `imade-clip/1` folder with its ground truth.

use super::camera::Intrinsics;
use super::clutter::{ClutterLayout, FrameClutter, RidgeLine};
use super::math::Vec3;
use super::model::ProjectileModel;
use super::plan::{FramePlan, intrinsics, plan_frames};
use super::plume::puffs;
use super::random::{Purpose, Random};
use super::randomize::{describe, frame_jitter, resolve};
use super::render::{FrameScene, RenderedChip, render};
use super::scenario::Scenario;
use super::sensor::Sensor;
use super::sky::Environment;
use super::trajectory::Trajectory;
use crate::clip::{
    CameraMeta, ChipImage, ChipSize, ClipMeta, ClipWriter, FORMAT_ID, FrameRow, GroundTruth,
    StationMeta, TrueAngleOfAttack, write_atomically,
};
use anyhow::Context;
use imade_core::world::{AngleOfAttack, Mount};
use std::path::Path;

/// A scenario made ready to render.
pub struct Simulation {
    /// The scenario as given (written beside the clip).
    scenario: Scenario,
    /// The scenario with its `[randomize]` ranges drawn: what is rendered.
    resolved: Scenario,
    clutter: ClutterLayout,
    model: ProjectileModel,
    intrinsics: Intrinsics,
    environment: Environment,
    trajectory: Trajectory,
    sensor: Sensor,
    plans: Vec<FramePlan>,
}

/// One rendered frame: the chip, its mask, and the number of mask pixels.
pub struct RenderedFrame {
    /// The chip.
    pub chip: ChipImage,
    /// The ground-truth mask.
    pub mask: image::GrayImage,
    /// Mask pixels set.
    pub mask_pixels: usize,
}

impl Simulation {
    /// Validates a scenario and plans its frames.
    pub fn new(scenario: Scenario) -> anyhow::Result<Simulation> {
        scenario.validate()?;
        let resolved = resolve(&scenario);
        resolved.validate().context("the randomized scenario")?;
        let model = ProjectileModel::from_config(&resolved.projectile)?;
        let environment = Environment::new(&resolved.scene, resolved.seed)?;
        let trajectory = Trajectory::new(&resolved.trajectory)?;
        let plans = plan_frames(&resolved, &trajectory)?;
        // Exposure: the clear sky behind the target in the first frame reads `sky_level`.
        let first = &plans[0];
        let line_of_sight = first.camera.r_cw.transpose() * first.body.translation.normalized();
        let sensor = Sensor::new(&resolved.sensor, environment.clear_sky(line_of_sight));
        Ok(Simulation {
            intrinsics: intrinsics(&resolved),
            clutter: ClutterLayout::new(&resolved),
            scenario,
            resolved,
            model,
            environment,
            trajectory,
            sensor,
            plans,
        })
    }

    /// The planned frames.
    pub fn plans(&self) -> &[FramePlan] {
        &self.plans
    }

    /// The camera's intrinsics.
    pub fn intrinsics(&self) -> &Intrinsics {
        &self.intrinsics
    }

    /// The model that flies.
    pub fn model(&self) -> &ProjectileModel {
        &self.model
    }

    /// The scenario with its `[randomize]` ranges drawn (what is rendered).
    pub fn resolved(&self) -> &Scenario {
        &self.resolved
    }

    /// The clip's clutter layout (filaments, second object).
    pub fn clutter_layout(&self) -> &ClutterLayout {
        &self.clutter
    }

    /// The clutter of frame `index` of the plan, or `None` when the scenario asks for none of it
    /// (the plain scene of the original simulator).
    pub fn frame_clutter(&self, index: usize) -> Option<FrameClutter<'_>> {
        let plan = &self.plans[index];
        let s = &self.resolved;
        let jitter = frame_jitter(s, plan.frame);
        let body_contrast_sigma = jitter
            .contrast_sigma
            .map(|c| c * s.projectile.polarity.sign());
        let ridge = s.near_terrain.enabled.then(|| {
            let t = &s.near_terrain;
            let (w, h) = (
                f64::from(s.camera.chip_width),
                f64::from(s.camera.chip_height),
            );
            let v = plan.chip_origin.1 as f64 + h
                - 0.5
                - (t.cover * h + t.rise_px_per_frame * index as f64);
            let u = plan.chip_origin.0 as f64 + 0.5 * (w - 1.0);
            let d = plan
                .camera
                .direction_to_world(self.intrinsics.ray(u, v))
                .normalized();
            RidgeLine {
                base_elevation: libm::asin(d.z.clamp(-1.0, 1.0)),
                relief: t.relief * h / s.camera.fy,
                rad_per_px: 1.0 / s.camera.fy,
                distance_m: t.distance_m,
            }
        });
        if self.clutter.is_empty() && ridge.is_none() && body_contrast_sigma.is_none() {
            return None;
        }
        Some(FrameClutter {
            layout: &self.clutter,
            index: index as f64,
            noise: self.sensor.noise_model(),
            body_contrast_sigma,
            ridge,
        })
    }

    /// Renders frame `index` of the plan before the sensor: radiance and mask.
    pub fn render_radiance(&self, index: usize) -> anyhow::Result<RenderedChip> {
        let plan = &self.plans[index];
        let seed = self.resolved.seed;
        let frame_puffs = puffs(
            &self.resolved.plume,
            &self.model,
            &mut Random::new(seed, Purpose::Plume, plan.frame),
        );
        let camera = &self.resolved.camera;
        let jitter = frame_jitter(&self.resolved, plan.frame);
        let scene = FrameScene {
            intrinsics: &self.intrinsics,
            camera: &plan.camera,
            chip_origin: plan.chip_origin,
            chip_size: (camera.chip_width, camera.chip_height),
            model: &self.model,
            body: &plan.body,
            albedo: self.resolved.projectile.albedo,
            time_s: plan.time_s,
            environment: &self.environment,
            puffs: &frame_puffs,
            psf_sigma_px: jitter.psf_sigma_px,
            supersampling: self.resolved.sensor.supersampling as usize,
            clutter: self.frame_clutter(index),
        };
        render(&scene).with_context(|| format!("rendering frame {}", plan.frame))
    }

    /// Renders frame `index` of the plan.
    pub fn render_frame(&self, index: usize) -> anyhow::Result<RenderedFrame> {
        let plan = &self.plans[index];
        let camera = &self.resolved.camera;
        let rendered = self.render_radiance(index)?;
        let pixels = self.sensor.expose(
            &rendered.radiance,
            &mut Random::new(self.resolved.station_seed(), Purpose::Sensor, plan.frame),
        );
        let mask_bytes: Vec<u8> = rendered
            .mask
            .iter()
            .map(|&m| if m { 255 } else { 0 })
            .collect();
        let mask_pixels = rendered.mask.iter().filter(|&&m| m).count();
        Ok(RenderedFrame {
            chip: ChipImage {
                width: camera.chip_width,
                height: camera.chip_height,
                pixels,
            },
            mask: image::GrayImage::from_raw(camera.chip_width, camera.chip_height, mask_bytes)
                .context("mask buffer does not match the chip size")?,
            mask_pixels,
        })
    }

    /// Renders every frame on `threads` threads and writes the clip to `out`, with the resolved
    /// scenario beside it as `scenario.toml`. The bytes do not depend on `threads`.
    pub fn write_clip(&self, out: &Path, threads: usize) -> anyhow::Result<Summary> {
        let camera = &self.resolved.camera;
        let meta = ClipMeta {
            format: FORMAT_ID.to_string(),
            camera: CameraMeta {
                fx: camera.fx,
                fy: camera.fy,
                cx: camera.cx,
                cy: camera.cy,
                width: camera.width,
                height: camera.height,
            },
            chip: ChipSize {
                width: camera.chip_width,
                height: camera.chip_height,
            },
            projectile: self.model.id.clone(),
            frame_rate_hz: self.resolved.clip.frame_rate_hz,
            // The simulator's world frame W is the range's East-North-Up frame.
            station: Some(StationMeta {
                id: self.scenario.camera.station_id.clone(),
                enu_m: self.scenario.camera.position_m,
            }),
        };
        let mut writer = ClipWriter::create(out, &meta)?;
        write_atomically(
            &out.join("scenario.toml"),
            self.scenario.to_toml()?.as_bytes(),
        )?;
        let mut summary = Summary::new(self);
        let threads = threads.max(1);
        for batch_start in (0..self.plans.len()).step_by(threads) {
            let batch_end = (batch_start + threads).min(self.plans.len());
            let rendered: Vec<anyhow::Result<RenderedFrame>> = std::thread::scope(|scope| {
                let handles: Vec<_> = (batch_start..batch_end)
                    .map(|i| scope.spawn(move || self.render_frame(i)))
                    .collect();
                handles
                    .into_iter()
                    .map(|h| {
                        h.join()
                            .unwrap_or_else(|_| Err(anyhow::anyhow!("a render thread panicked")))
                    })
                    .collect()
            });
            for (i, frame) in (batch_start..batch_end).zip(rendered) {
                let frame = frame?;
                let plan = &self.plans[i];
                writer.write_frame(&self.row(plan), &frame.chip, Some(&frame.mask))?;
                summary.add(self, plan, frame.mask_pixels);
            }
        }
        writer.finish()?;
        Ok(summary)
    }

    /// The `frames.csv` row of a planned frame (the writer fills in the file paths).
    fn row(&self, plan: &FramePlan) -> FrameRow {
        let t = plan.body.translation;
        FrameRow {
            line: 0,
            frame: plan.frame,
            time_s: plan.time_s,
            chip: String::new(),
            chip_x0: plan.chip_origin.0,
            chip_y0: plan.chip_origin.1,
            range_m: plan.range_m,
            mount: {
                let (az, el) = plan.camera.pointing();
                Mount::new_checked(az.to_degrees(), el.to_degrees()).ok()
            },
            truth: Some(GroundTruth {
                tx_m: t.x,
                ty_m: t.y,
                tz_m: t.z,
                pitch_deg: plan.attitude.pitch_deg,
                yaw_deg: plan.attitude.yaw_deg,
                roll_deg: plan.attitude.roll_deg,
            }),
            gt_mask: None,
            truth_aoa: true_angle_of_attack(plan),
        }
    }
}

/// The true angle of attack of a planned frame: the body's x axis against its velocity, both
/// in W (the range's East-North-Up frame), split as the core splits it.
fn true_angle_of_attack(plan: &FramePlan) -> Option<TrueAngleOfAttack> {
    let (n, v) = (plan.body_axes_world.col(0), plan.velocity_world);
    AngleOfAttack::of(&[n.x, n.y, n.z], &[v.x, v.y, v.z]).map(|a| TrueAngleOfAttack {
        total_deg: a.total_deg,
        up_deg: a.up_deg,
        right_deg: a.right_deg,
    })
}

/// A closed interval that grows to cover the values added to it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Span {
    /// Smallest value seen.
    pub min: f64,
    /// Largest value seen.
    pub max: f64,
}

impl Span {
    fn empty() -> Span {
        Span {
            min: f64::INFINITY,
            max: f64::NEG_INFINITY,
        }
    }

    fn add(&mut self, v: f64) {
        self.min = self.min.min(v);
        self.max = self.max.max(v);
    }
}

impl std::fmt::Display for Span {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let p = f.precision().unwrap_or(1);
        write!(f, "{:.p$} to {:.p$}", self.min, self.max)
    }
}

/// What a written clip spans, for the person who asked for it.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// Frames written.
    pub frames: usize,
    /// Muzzle speed, m/s.
    pub muzzle_speed_m_s: f64,
    /// Sun elevation, deg.
    pub sun_elevation_deg: f64,
    /// Capture times, s.
    pub time_s: Span,
    /// Slant range |T|, m.
    pub range_m: Span,
    /// Truth pitch, deg.
    pub pitch_deg: Span,
    /// Truth yaw, deg.
    pub yaw_deg: Span,
    /// Projected nose-to-base length, px.
    pub length_px: Span,
    /// Distance of the target from the principal point, px.
    pub pointing_offset_px: Span,
    /// Distance of the target from the chip centre, px.
    pub chip_offset_px: Span,
    /// Mask pixels per frame.
    pub mask_px: Span,
    /// What the `[randomize]` section drew, if the scenario has one.
    pub randomized: Option<String>,
}

impl Summary {
    fn new(sim: &Simulation) -> Summary {
        Summary {
            frames: 0,
            muzzle_speed_m_s: sim.trajectory.muzzle_speed(),
            sun_elevation_deg: sim.environment.sun_elevation_deg(),
            time_s: Span::empty(),
            range_m: Span::empty(),
            pitch_deg: Span::empty(),
            yaw_deg: Span::empty(),
            length_px: Span::empty(),
            pointing_offset_px: Span::empty(),
            chip_offset_px: Span::empty(),
            mask_px: Span::empty(),
            randomized: (sim.resolved != sim.scenario).then(|| describe(&sim.resolved)),
        }
    }

    fn add(&mut self, sim: &Simulation, plan: &FramePlan, mask_pixels: usize) {
        let k = &sim.intrinsics;
        let (u, v) = plan.target_px;
        let along = |x: f64| {
            k.project(plan.body.to_camera(Vec3::new(x, 0.0, 0.0)))
                .unwrap_or((u, v))
        };
        let nose_x = sim
            .model
            .mesh
            .vertices
            .iter()
            .map(|p| p.x)
            .fold(f64::NEG_INFINITY, f64::max);
        let (a, b) = (along(nose_x), along(sim.model.tail_x));
        let chip = &sim.resolved.camera;
        let centre = (
            plan.chip_origin.0 as f64 + 0.5 * (f64::from(chip.chip_width) - 1.0),
            plan.chip_origin.1 as f64 + 0.5 * (f64::from(chip.chip_height) - 1.0),
        );
        self.frames += 1;
        self.time_s.add(plan.time_s);
        self.range_m.add(plan.body.translation.norm());
        self.pitch_deg.add(plan.attitude.pitch_deg);
        self.yaw_deg.add(plan.attitude.yaw_deg);
        self.length_px.add(libm::hypot(a.0 - b.0, a.1 - b.1));
        self.pointing_offset_px.add(libm::hypot(u - k.cx, v - k.cy));
        self.chip_offset_px
            .add(libm::hypot(u - centre.0, v - centre.1));
        self.mask_px.add(mask_pixels as f64);
    }
}

impl std::fmt::Display for Summary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "frames              {}", self.frames)?;
        writeln!(f, "time                {:.3} s", self.time_s)?;
        writeln!(f, "muzzle speed        {:.1} m/s", self.muzzle_speed_m_s)?;
        writeln!(f, "sun elevation       {:.1} deg", self.sun_elevation_deg)?;
        writeln!(f, "range |T|           {:.0} m", self.range_m)?;
        writeln!(f, "pitch               {:.1} deg", self.pitch_deg)?;
        writeln!(f, "yaw                 {:.1} deg", self.yaw_deg)?;
        writeln!(f, "nose-to-base length {:.1} px", self.length_px)?;
        writeln!(
            f,
            "target off centre   {:.0} px (full frame)",
            self.pointing_offset_px
        )?;
        writeln!(
            f,
            "target off centre   {:.1} px (chip)",
            self.chip_offset_px
        )?;
        write!(f, "mask                {:.0} px", self.mask_px)?;
        if let Some(drawn) = &self.randomized {
            write!(f, "\nrandomized          {drawn}")?;
        }
        Ok(())
    }
}
