//! `imade run`: the core's pipeline over recorded clips, one imade-results/1 CSV per clip.

use crate::clip::{Clip, FrameRow, load_chip, write_atomically};
use anyhow::{Context, bail};
use imade_core::{Camera, Config, FrameInput, Pipeline, RangeUse, Status, built_in_model, results};
use std::path::{Path, PathBuf};

/// How range measurements in a clip are used.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum RangeArg {
    /// Use `range_m` where a frame has it, else measure the distance from the image.
    Auto,
    /// Like `auto` (the range is used where given).
    Given,
    /// Always measure the distance from the image.
    Ignore,
}

/// Arguments of `imade run`.
#[derive(Debug, clap::Args)]
pub struct RunArgs {
    /// Clip folders (imade-clip/1).
    #[arg(required = true)]
    pub clips: Vec<PathBuf>,
    /// Output folder: `results.csv` for one clip, `<clip name>/results.csv` for several.
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
    /// How range measurements are used.
    #[arg(long, value_enum, default_value = "auto")]
    pub range: RangeArg,
}

/// Counts of a processed clip.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ClipSummary {
    /// Rows written (one per frame row of `frames.csv`).
    pub frames: usize,
    /// Frames with a pose.
    pub ok: usize,
    /// Frames whose input was unusable (bad row, bad chip).
    pub bad_input: usize,
}

/// Runs `imade run`: every clip, each independently (a clip that cannot be opened is reported and
/// the others still run).
pub fn run(args: &RunArgs) -> anyhow::Result<()> {
    let config = Config {
        range_use: match args.range {
            RangeArg::Auto | RangeArg::Given => RangeUse::Auto,
            RangeArg::Ignore => RangeUse::Ignore,
        },
        ..Config::DEFAULT
    };
    let mut failed = 0usize;
    for dir in &args.clips {
        let out = if args.clips.len() == 1 {
            args.out.join("results.csv")
        } else {
            args.out.join(clip_name(dir)).join("results.csv")
        };
        match run_clip(dir, &out, &config) {
            Ok(summary) => eprintln!(
                "{}: {} frames, {} with a pose, {} with bad input -> {}",
                dir.display(),
                summary.frames,
                summary.ok,
                summary.bad_input,
                out.display()
            ),
            Err(error) => {
                failed += 1;
                eprintln!("imade: error: {}: {error:#}", dir.display());
            }
        }
    }
    if failed > 0 {
        bail!(
            "{failed} of {} clips could not be processed",
            args.clips.len()
        );
    }
    Ok(())
}

fn clip_name(dir: &Path) -> String {
    dir.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "clip".into())
}

/// Processes one clip and writes its results CSV atomically.
pub fn run_clip(dir: &Path, out: &Path, config: &Config) -> anyhow::Result<ClipSummary> {
    let clip = Clip::open(dir)?;
    let model = built_in_model(&clip.meta.projectile).with_context(|| {
        format!(
            "{}: unknown projectile {:?}",
            dir.join("clip.json").display(),
            clip.meta.projectile
        )
    })?;
    let c = &clip.meta.camera;
    let camera = Camera {
        fx: c.fx as f32,
        fy: c.fy as f32,
        cx: c.cx as f32,
        cy: c.cy as f32,
    };
    let mut pipeline: Box<Pipeline> = Box::new(Pipeline::new(*config, camera, *model));
    let mut csv = String::from(results::HEADER);
    csv.push('\n');
    let mut summary = ClipSummary::default();
    for entry in &clip.frames {
        summary.frames += 1;
        let written = match entry {
            Ok(row) => match process_frame(&clip, row, &mut pipeline) {
                Ok(result) => {
                    summary.ok += usize::from(result.status == Status::Ok);
                    results::write_row(&mut csv, row.frame, &result)
                }
                Err(error) => {
                    summary.bad_input += 1;
                    eprintln!("imade: {}: frame {}: {error:#}", dir.display(), row.frame);
                    results::write_status_row(&mut csv, Some(row.frame), "bad_chip")
                }
            },
            Err(error) => {
                summary.bad_input += 1;
                eprintln!("imade: {}: {error}", dir.display());
                results::write_status_row(&mut csv, error.frame, "bad_row")
            }
        };
        written.context("formatting a results row")?;
        csv.push('\n');
    }
    if let Some(parent) = out.parent() {
        std::fs::create_dir_all(parent)
            .with_context(|| format!("creating {}", parent.display()))?;
    }
    write_atomically(out, csv.as_bytes())?;
    Ok(summary)
}

/// Loads a frame's chip and runs the pipeline on it.
fn process_frame(
    clip: &Clip,
    row: &FrameRow,
    pipeline: &mut Pipeline,
) -> anyhow::Result<imade_core::FrameResult> {
    let path = clip.path_of(&row.chip);
    let chip = load_chip(&path)?;
    let expected = clip.meta.chip;
    if (chip.width, chip.height) != (expected.width, expected.height) {
        bail!(
            "{}: chip is {}x{}, clip.json says {}x{}",
            path.display(),
            chip.width,
            chip.height,
            expected.width,
            expected.height
        );
    }
    let x0 = i32::try_from(row.chip_x0).context("chip_x0 out of range")?;
    let y0 = i32::try_from(row.chip_y0).context("chip_y0 out of range")?;
    let view = chip
        .view(x0, y0)
        .map_err(|e| anyhow::anyhow!("{}: unusable chip: {e:?}", path.display()))?;
    Ok(pipeline.process(&FrameInput {
        chip: view,
        time_s: row.time_s,
        range_m: row.range_m.map(|r| r as f32),
    }))
}
