//! The clip simulator (`imade simulate`): deterministic `imade-clip/1` clips with ground truth,
//! standing in for the source paper's Unity simulation. docs/simulator.md describes what it
//! models and the scenario file.
//!
//! It shares no projection, pose or silhouette code with `imade-core`: it has its own camera
//! ([`camera`]), pose convention ([`pose`]), mesh renderer ([`raster`], [`render`]) and f64 math
//! ([`math`]), all tested against the test vector of `docs/geometry.md` directly, so that a bug in
//! one cannot hide the same bug in the other.
//!
//! Determinism: every random draw comes from a PCG stream keyed by the seed, a purpose and a frame
//! number ([`random`]); transcendental functions come from the pure-Rust `libm`; no hash-map order
//! or thread count reaches the output.
//!
//! The modules, in the order a frame goes through them: [`scenario`] and [`presets`] (the knobs),
//! [`trajectory`], [`attitude`], [`tracking`] and [`plan`] (the geometric truth of each frame),
//! [`randomize`] (the physics drawn per clip and per frame from the scenario's ranges),
//! [`model`] and [`mesh`] (the shape), [`sky`] and [`noise`] (the background and the light),
//! [`clutter`] (filaments, a second object, the noise scale of contrasts), [`raster`], [`plume`]
//! and [`render`] (the radiance and the mask), [`sensor`] (blur, noise, quantization),
//! [`simulation`] (the clip on disk).

pub mod attitude;
pub mod camera;
pub mod clutter;
pub mod math;
pub mod mesh;
pub mod model;
pub mod noise;
pub mod plan;
pub mod plume;
pub mod pose;
pub mod presets;
pub mod random;
pub mod randomize;
pub mod raster;
pub mod render;
pub mod scenario;
pub mod sensor;
pub mod shapes;
pub mod simulation;
pub mod sky;
pub mod tracking;
pub mod trajectory;

#[cfg(test)]
mod tests;

pub use scenario::Scenario;
pub use simulation::{Simulation, Summary};

use anyhow::{Context, bail};
use scenario::RangeSensor;
use std::path::{Path, PathBuf};

/// Arguments of `imade simulate`.
#[derive(Debug, clap::Args)]
pub struct SimulateArgs {
    /// Output clip folder (created; must be empty or absent unless --force).
    #[arg(long, required_unless_present_any = ["list_presets", "print_scenario"])]
    pub out: Option<PathBuf>,
    /// A named preset (see --list-presets).
    #[arg(long, conflicts_with = "scenario")]
    pub preset: Option<String>,
    /// A scenario file (TOML; see docs/simulator.md).
    #[arg(long)]
    pub scenario: Option<PathBuf>,
    /// List the presets and exit.
    #[arg(long)]
    pub list_presets: bool,
    /// Print the scenario (after overrides) as TOML and exit: a starting point for a file.
    #[arg(long)]
    pub print_scenario: bool,
    /// Override the number of frames.
    #[arg(long)]
    pub frames: Option<u32>,
    /// Override the seed.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Override the frame sub-sampling (keep every n-th camera frame).
    #[arg(long)]
    pub keep_every: Option<u32>,
    /// Override the time of the first frame after launch, s.
    #[arg(long)]
    pub start_time: Option<f64>,
    /// Override whether the clip has a range measurement.
    #[arg(long, value_enum)]
    pub range: Option<RangeSensor>,
    /// Override the bits per chip sample (8 or 16).
    #[arg(long)]
    pub bit_depth: Option<u8>,
    /// Render threads (default: the machine's cores); the output does not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Replace the clip files (clip.json, frames.csv, scenario.toml, chips/, masks/) of an
    /// existing output folder.
    #[arg(long)]
    pub force: bool,
}

/// Runs `imade simulate`.
pub fn run(args: &SimulateArgs) -> anyhow::Result<()> {
    if args.list_presets {
        for (name, summary) in presets::PRESETS {
            println!("{name:20} {summary}");
        }
        return Ok(());
    }
    let scenario = resolve_scenario(args)?;
    if args.print_scenario {
        print!("{}", scenario.to_toml()?);
        return Ok(());
    }
    let out = args
        .out
        .as_deref()
        .context("--out is required to write a clip")?;
    let threads = args.threads.unwrap_or_else(|| {
        std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get)
    });
    // A several-station scenario writes one clip per station, `OUT/<station id>/`.
    let several = !scenario.stations.is_empty();
    for station in scenario.station_scenarios() {
        let clip_dir = if several {
            out.join(&station.camera.station_id)
        } else {
            out.to_path_buf()
        };
        prepare_output(&clip_dir, args.force)?;
        let started = std::time::Instant::now();
        let simulation = Simulation::new(station)?;
        let summary = simulation.write_clip(&clip_dir, threads)?;
        let seconds = started.elapsed().as_secs_f64();
        println!("wrote {}", clip_dir.display());
        println!("{summary}");
        println!(
            "render speed        {:.1} frames/s ({} threads, {seconds:.1} s)",
            summary.frames as f64 / seconds,
            threads
        );
    }
    Ok(())
}

/// The scenario named by the arguments, with their overrides applied.
fn resolve_scenario(args: &SimulateArgs) -> anyhow::Result<Scenario> {
    let mut scenario = match (&args.preset, &args.scenario) {
        (Some(name), None) => presets::preset(name).with_context(|| {
            format!("no preset {name:?}; `imade simulate --list-presets` lists them")
        })?,
        (None, Some(path)) => Scenario::from_file(path)?,
        (None, None) => {
            bail!("give --preset NAME or --scenario FILE (--list-presets lists presets)")
        }
        (Some(_), Some(_)) => bail!("give either --preset or --scenario, not both"),
    };
    if let Some(frames) = args.frames {
        scenario.clip.frames = frames;
    }
    if let Some(seed) = args.seed {
        scenario.seed = seed;
    }
    if let Some(keep) = args.keep_every {
        scenario.clip.keep_every = keep;
    }
    if let Some(start) = args.start_time {
        scenario.clip.start_time_s = start;
    }
    if let Some(range) = args.range {
        scenario.sensor.range_sensor = range;
    }
    if let Some(bits) = args.bit_depth {
        scenario.sensor.bit_depth = bits;
    }
    scenario.validate()?;
    Ok(scenario)
}

/// Makes sure the output folder holds no clip, removing an old one's files with `force`.
fn prepare_output(out: &Path, force: bool) -> anyhow::Result<()> {
    let Ok(entries) = std::fs::read_dir(out) else {
        return Ok(());
    };
    if entries.count() == 0 {
        return Ok(());
    }
    if !force {
        bail!(
            "{} exists and is not empty; pass --force to replace the clip in it",
            out.display()
        );
    }
    for file in ["clip.json", "frames.csv", "scenario.toml"] {
        let path = out.join(file);
        if path.exists() {
            std::fs::remove_file(&path).with_context(|| format!("removing {}", path.display()))?;
        }
    }
    for dir in ["chips", "masks"] {
        let path = out.join(dir);
        if path.exists() {
            std::fs::remove_dir_all(&path)
                .with_context(|| format!("removing {}", path.display()))?;
        }
    }
    Ok(())
}
