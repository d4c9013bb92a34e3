//! `imade run`: the core's pipeline over recorded clips, in parallel across clips; one
//! imade-results/1 CSV per clip (written atomically), optional per-stage masks, and a JSON summary.

use crate::clip::{Clip, FrameRow, save_mask, write_atomically};
use crate::exit::PartialFailure;
use crate::smooth::{Recorded, smoothed_results};
use crate::stages::{STAGES, mask_file_name};
use crate::summary::{ClipSummary, Problem, RunSummary, SUMMARY_FORMAT};
use anyhow::{Context, bail};
use imade_core::shape_guided::TetrisWeights;
use imade_core::world::Position;
use imade_core::{
    BodyPolarity, Config, FrameInput, GuidedMethod, Pipeline, RangeSmoothing, RangeUse, Status,
    results,
};
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Instant;

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

impl RangeArg {
    /// The name as given on the command line.
    pub fn name(self) -> &'static str {
        match self {
            RangeArg::Auto => "auto",
            RangeArg::Given => "given",
            RangeArg::Ignore => "ignore",
        }
    }

    /// The core configuration for this range use.
    pub fn config(self) -> Config {
        Config {
            range_use: match self {
                RangeArg::Auto | RangeArg::Given => RangeUse::Auto,
                RangeArg::Ignore => RangeUse::Ignore,
            },
            ..Config::DEFAULT
        }
    }
}

/// How the image range is smoothed across frames, as chosen with `--range-smoothing`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum SmoothingArg {
    /// The motion model: a Kalman filter of range, rate and acceleration, with `tz_sd_m`.
    #[default]
    MotionModel,
    /// The source paper's Eq. 5 (r = 0.1 per 1/30 s), for comparison; no `tz_sd_m`.
    Eq5,
}

impl SmoothingArg {
    /// The core's choice.
    fn smoothing(self) -> RangeSmoothing {
        match self {
            SmoothingArg::MotionModel => RangeSmoothing::MotionModel,
            SmoothingArg::Eq5 => RangeSmoothing::Eq5,
        }
    }
}

/// The body's contrast polarity against the sky, as chosen with `--polarity`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum PolarityArg {
    /// Darker than the sky (a body against a bright sky: the usual case, and the source paper's).
    #[default]
    Dark,
    /// Brighter than the sky (a sunlit body against a darker sky or cloud).
    Bright,
    /// Either: the more elongated candidate wins. For clean skies only: beside a plume of the
    /// other polarity the plume can win.
    Either,
}

impl PolarityArg {
    /// The core's choice (None: either).
    fn polarity(self) -> Option<BodyPolarity> {
        match self {
            PolarityArg::Dark => Some(BodyPolarity::Dark),
            PolarityArg::Bright => Some(BodyPolarity::Bright),
            PolarityArg::Either => None,
        }
    }
}

/// The shape-guided loop's method as chosen with `--refine`: a method, or none.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RefineChoice(pub Option<GuidedMethod>);

impl RefineChoice {
    /// The name on the command line: `none`, `sis-cut`, `gvf-asm` or `tetris`.
    pub fn as_str(self) -> &'static str {
        self.0.map_or("none", |m| m.as_str())
    }
}

/// Parses `--refine`: `none`, `sis-cut`, `gvf-asm` or `tetris`.
pub fn parse_refine(name: &str) -> Result<RefineChoice, String> {
    if name == "none" {
        return Ok(RefineChoice(None));
    }
    name.parse().map(|m| RefineChoice(Some(m))).map_err(|_| {
        let names: Vec<&str> = GuidedMethod::ALL.iter().map(|m| m.as_str()).collect();
        format!("expected one of none, {}", names.join(", "))
    })
}

/// The core configuration of a job: the range use's, with the shape-guided method and the
/// range smoothing.
fn job_config(job: &Job) -> Config {
    let mut config = job.range.config().with_guided_method(job.refine.0);
    config.temporal.range_smoothing = job.range_smoothing.smoothing();
    config.grey_fit.enabled = job.grey_fit;
    config.detect.polarity = job.polarity.polarity();
    config
}

/// Arguments of `imade run`.
#[derive(Debug, clap::Args)]
pub struct RunArgs {
    /// Clip folders (imade-clip/1).
    #[arg(required = true)]
    pub clips: Vec<PathBuf>,
    /// Output folder: `results.csv` for one clip, `<clip name>/results.csv` for several, and
    /// `summary.json`.
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
    /// How range measurements are used.
    #[arg(long, value_enum, default_value = "auto")]
    pub range: RangeArg,
    /// Also write each frame's mask of every segmentation stage beside the results
    /// (`masks/NNNNNN.png`, `priors/NNNNNN.png`, with `--refine` also `refined/NNNNNN.png`;
    /// 8-bit, 0 or 255).
    #[arg(long)]
    pub save_masks: bool,
    /// The projectile's model and silhouette table: `bundled` (`fixtures/models/<projectile>.model`),
    /// `none` (the bundled model without its table: closed form only), or a model file
    /// (`imade model build`) whose id is the clip's projectile.
    #[arg(long, default_value = "bundled")]
    pub lut: String,
    /// Shape-guided refinement of the table match: `none`, `sis-cut`, `gvf-asm` or `tetris`
    /// (needs a table; docs/shape-guided.md).
    #[arg(long, default_value = "none", value_parser = parse_refine)]
    pub refine: RefineChoice,
    /// TETRIS's weights for `--refine tetris` (`imade train tetris`); default the bundled
    /// `fixtures/tetris/tetris.weights`.
    #[arg(long)]
    pub tetris: Option<PathBuf>,
    /// How the range from the image is smoothed across frames: `motion-model` (a Kalman filter,
    /// with `tz_sd_m`) or `eq5` (the source paper's Eq. 5, for comparison).
    #[arg(long, value_enum, default_value = "motion-model")]
    pub range_smoothing: SmoothingArg,
    /// A recorded clip: smooth the motion model's range forwards and backwards, so that each
    /// frame's range, its sigma and the yaw side use the frames after it too (the default is
    /// causal, as on the mount).
    #[arg(long)]
    pub smooth: bool,
    /// Leave out the grey-level fit: each frame's pose comes from the table match, as on the
    /// firmware, which does not run the fit yet.
    #[arg(long)]
    pub no_grey_fit: bool,
    /// The body's contrast polarity against the sky: `dark` (darker than the sky), `bright`
    /// (brighter: sunlit against a darker background) or `either` (clean skies only).
    #[arg(long, value_enum, default_value = "dark")]
    pub polarity: PolarityArg,
}

/// One clip to process and where its results go.
#[derive(Debug, Clone)]
pub struct Job {
    /// The clip folder.
    pub clip: PathBuf,
    /// Folder for `results.csv` and the stage masks.
    pub out_dir: PathBuf,
    /// How range measurements are used.
    pub range: RangeArg,
    /// Write the stage masks.
    pub save_masks: bool,
    /// The table choice (see [`RunArgs::lut`]).
    pub lut: String,
    /// The shape-guided method (see [`RunArgs::refine`]).
    pub refine: RefineChoice,
    /// TETRIS's weights, where the method is TETRIS (see [`RunArgs::tetris`]).
    pub tetris: Option<TetrisWeights<'static>>,
    /// The range smoothing (see [`RunArgs::range_smoothing`]).
    pub range_smoothing: SmoothingArg,
    /// Smooth forwards and backwards (see [`RunArgs::smooth`]).
    pub smooth: bool,
    /// Run the grey-level fit (see [`RunArgs::no_grey_fit`]).
    pub grey_fit: bool,
    /// The body's polarity (see [`RunArgs::polarity`]).
    pub polarity: PolarityArg,
}

/// Runs `imade run`. Every clip is processed independently; the outcome is an error carrying
/// a [`PartialFailure`] when any frame or clip had unusable input.
pub fn run(args: &RunArgs) -> anyhow::Result<()> {
    let jobs = plan(args)?;
    let summary = run_jobs(&jobs);
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let path = args.out.join("summary.json");
    write_atomically(&path, serde_json::to_string_pretty(&summary)?.as_bytes())?;
    for clip in &summary.clips {
        if let Some(results) = &clip.results {
            eprintln!(
                "{}: {} frames, {} with a pose, {} with bad input -> {}",
                clip.clip.display(),
                clip.frames,
                clip.ok(),
                clip.problems.len(),
                results.display()
            );
        }
    }
    outcome(&summary)
}

/// The outcome of a run: Ok when every clip and frame was readable.
pub fn outcome(summary: &RunSummary) -> anyhow::Result<()> {
    let failed = summary.failed_clips();
    if failed > 0 {
        return Err(PartialFailure::BadClips {
            failed,
            total: summary.clips.len(),
        }
        .into());
    }
    match summary.bad_frames() {
        0 => Ok(()),
        frames => Err(PartialFailure::BadFrames { frames }.into()),
    }
}

/// One job per clip; output folders must not collide.
fn plan(args: &RunArgs) -> anyhow::Result<Vec<Job>> {
    let single = args.clips.len() == 1;
    let tetris = match args.refine.0 {
        Some(GuidedMethod::Tetris) => Some(crate::tetris_weights::load(
            &args
                .tetris
                .clone()
                .unwrap_or_else(crate::tetris_weights::bundled_path),
        )?),
        _ => None,
    };
    let jobs: Vec<Job> = args
        .clips
        .iter()
        .map(|clip| Job {
            clip: clip.clone(),
            out_dir: if single {
                args.out.clone()
            } else {
                args.out.join(clip_name(clip))
            },
            range: args.range,
            save_masks: args.save_masks,
            lut: args.lut.clone(),
            refine: args.refine,
            tetris,
            range_smoothing: args.range_smoothing,
            smooth: args.smooth,
            grey_fit: !args.no_grey_fit,
            polarity: args.polarity,
        })
        .collect();
    for (i, job) in jobs.iter().enumerate() {
        if jobs[..i].iter().any(|j| j.out_dir == job.out_dir) {
            bail!(
                "two clips would write to {}: give clips with distinct folder names",
                job.out_dir.display()
            );
        }
    }
    Ok(jobs)
}

fn clip_name(dir: &Path) -> String {
    dir.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "clip".into())
}

/// Runs the jobs in parallel (rayon), with one progress bar over all frames on a terminal
/// (nothing is drawn when stderr is not one). Problems are printed as they are found.
pub fn run_jobs(jobs: &[Job]) -> RunSummary {
    let opened: Vec<anyhow::Result<Clip>> = jobs.iter().map(|j| Clip::open(&j.clip)).collect();
    let total: usize = opened
        .iter()
        .filter_map(|c| c.as_ref().ok())
        .map(|c| c.frames.len())
        .sum();
    let bar = ProgressBar::new(total as u64);
    if let Ok(style) =
        ProgressStyle::with_template("{elapsed:>4} [{bar:40}] {pos}/{len} frames, eta {eta}")
    {
        bar.set_style(style.progress_chars("=> "));
    }
    let clips = jobs
        .par_iter()
        .zip(opened)
        .map(|(job, clip)| {
            let started = Instant::now();
            let mut summary = match clip.and_then(|clip| run_clip(&clip, job, &bar)) {
                Ok(summary) => summary,
                Err(error) => {
                    let error = format!("{error:#}");
                    bar.suspend(|| eprintln!("imade: error: {}: {error}", job.clip.display()));
                    ClipSummary {
                        clip: job.clip.clone(),
                        range: job.range.name().into(),
                        error: Some(error),
                        ..ClipSummary::default()
                    }
                }
            };
            summary.seconds = started.elapsed().as_secs_f64();
            summary
        })
        .collect();
    bar.finish_and_clear();
    RunSummary {
        format: SUMMARY_FORMAT.into(),
        clips,
    }
}

/// The pipeline for a clip's camera and projectile, with TETRIS's weights where given.
fn pipeline_for(
    clip: &Clip,
    config: Config,
    lut: &str,
    tetris: Option<TetrisWeights<'static>>,
) -> anyhow::Result<Box<Pipeline>> {
    let model = clip.model(lut)?;
    let pipeline = Pipeline::new(config, clip.meta.camera.camera(), model);
    let mut pipeline = Box::new(match crate::model::table_for(lut, &model) {
        Some(table) => pipeline.with_table(table),
        None => pipeline,
    });
    if let Some(weights) = tetris {
        pipeline.set_tetris(weights);
    }
    Ok(pipeline)
}

/// One row of a clip's results, before the results file is written.
enum Row {
    /// A frame the pipeline processed.
    Frame(u64, imade_core::FrameResult),
    /// A frame or line that could not be processed: its frame number where known, and status.
    Unusable(Option<u64>, &'static str),
}

/// Processes one opened clip and writes its results CSV atomically (and the stage masks).
pub fn run_clip(clip: &Clip, job: &Job, bar: &ProgressBar) -> anyhow::Result<ClipSummary> {
    let mut pipeline = pipeline_for(clip, job_config(job), &job.lut, job.tetris)?;
    pipeline.set_station(clip.station());
    prepare_mask_folders(&job.out_dir, job.save_masks)?;
    let mut summary = ClipSummary {
        clip: clip.dir.clone(),
        range: job.range.name().into(),
        ..ClipSummary::default()
    };
    let mut rows = Vec::with_capacity(clip.frames.len());
    let mut recorded = Vec::new();
    for entry in &clip.frames {
        bar.inc(1);
        let row = match entry {
            Ok(row) => match process_frame(clip, row, &mut pipeline) {
                Ok(result) => {
                    if job.save_masks && result.status != Status::BadInput {
                        save_stage_masks(&pipeline, &job.out_dir, row.frame)?;
                    }
                    recorded.push(Recorded {
                        row: rows.len(),
                        step: pipeline.last_range_step(),
                        flight: pipeline.last_flight_step(),
                        solved: pipeline.last_solved().copied(),
                        position: result.world.map(|world| Position {
                            time_s: row.time_s,
                            enu_m: world.pose.origin_enu_m,
                            range_used: result.range_used,
                        }),
                    });
                    Row::Frame(row.frame, result)
                }
                Err(error) => {
                    let message = format!(
                        "{}: frame {} (frames.csv line {}): {error:#}",
                        clip.dir.display(),
                        row.frame,
                        row.line
                    );
                    report(bar, &mut summary, row.line, Some(row.frame), message);
                    Row::Unusable(Some(row.frame), "bad_chip")
                }
            },
            Err(error) => {
                let message = format!("{}: {error}", clip.dir.display());
                report(bar, &mut summary, error.line, error.frame, message);
                Row::Unusable(error.frame, "bad_row")
            }
        };
        rows.push(row);
    }
    if job.smooth {
        for (index, result) in smoothed_results(&pipeline, &recorded) {
            if let Some(Row::Frame(_, kept)) = rows.get_mut(index) {
                *kept = result;
            }
        }
    }
    let mut csv = String::from(results::HEADER);
    if clip.has_mount {
        csv.push_str(results::WORLD_HEADER);
    }
    csv.push('\n');
    for row in &rows {
        let (status, world) = match row {
            Row::Frame(frame, result) => {
                results::write_row(&mut csv, *frame, result).context("formatting a results row")?;
                (result.status.as_str(), result.world)
            }
            Row::Unusable(frame, status) => {
                results::write_status_row(&mut csv, *frame, status)
                    .context("formatting a results row")?;
                (*status, None)
            }
        };
        if clip.has_mount {
            results::write_world_columns(&mut csv, world.as_ref())
                .context("formatting a results row")?;
        }
        summary.count(status);
        csv.push('\n');
    }
    let out = job.out_dir.join("results.csv");
    write_atomically(&out, csv.as_bytes())?;
    summary.results = Some(out);
    Ok(summary)
}

/// Records and prints one unusable frame.
fn report(
    bar: &ProgressBar,
    summary: &mut ClipSummary,
    line: u64,
    frame: Option<u64>,
    message: String,
) {
    bar.suspend(|| eprintln!("imade: {message}"));
    summary.problems.push(Problem {
        line,
        frame,
        message,
    });
}

/// Creates the output folder; removes stage masks of an earlier run (they would not match the
/// new results) and creates the stage folders when masks are to be written.
fn prepare_mask_folders(out_dir: &Path, save_masks: bool) -> anyhow::Result<()> {
    std::fs::create_dir_all(out_dir).with_context(|| format!("creating {}", out_dir.display()))?;
    for stage in STAGES {
        let dir = out_dir.join(stage.folder);
        if dir.is_dir() {
            for entry in
                std::fs::read_dir(&dir).with_context(|| format!("listing {}", dir.display()))?
            {
                let path = entry?.path();
                if is_mask_file(&path) {
                    std::fs::remove_file(&path)
                        .with_context(|| format!("removing {}", path.display()))?;
                }
            }
        }
        if save_masks {
            std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        }
    }
    Ok(())
}

/// True for a `NNNNNN.png` stage mask file name.
fn is_mask_file(path: &Path) -> bool {
    path.extension().is_some_and(|e| e == "png")
        && path
            .file_stem()
            .and_then(|s| s.to_str())
            .is_some_and(|s| s.len() >= 6 && s.bytes().all(|b| b.is_ascii_digit()))
}

/// Writes every stage's non-empty mask of the frame just processed.
fn save_stage_masks(pipeline: &Pipeline, out_dir: &Path, frame: u64) -> anyhow::Result<()> {
    for stage in STAGES {
        let mask = (stage.mask)(pipeline);
        if mask.count() > 0 {
            save_mask(
                mask,
                &out_dir.join(stage.folder).join(mask_file_name(frame)),
            )?;
        }
    }
    Ok(())
}

/// Loads a frame's chip and runs the pipeline on it.
fn process_frame(
    clip: &Clip,
    row: &FrameRow,
    pipeline: &mut Pipeline,
) -> anyhow::Result<imade_core::FrameResult> {
    let chip = clip.load_frame_chip(row)?;
    // Checked when loaded.
    let view = chip
        .view()
        .map_err(|e| anyhow::anyhow!("unusable chip: {e:?}"))?;
    Ok(pipeline.process(&FrameInput {
        chip: view,
        time_s: row.time_s,
        range_m: row.range_m.map(|r| r as f32),
        mount: row.mount,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stages::REFINED_FOLDER;

    #[test]
    fn refine_names_parse_and_others_are_refused() {
        for method in GuidedMethod::ALL {
            assert_eq!(
                parse_refine(method.as_str()),
                Ok(RefineChoice(Some(method)))
            );
        }
        assert_eq!(parse_refine("none"), Ok(RefineChoice(None)));
        let error = parse_refine("graph-cut").unwrap_err();
        assert!(error.contains("none, sis-cut, gvf-asm"), "{error}");
    }

    #[test]
    fn refined_masks_are_saved_and_scored() -> anyhow::Result<()> {
        let clip = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/small-known-range");
        let out = std::env::temp_dir().join(format!("imade-refine-{}", std::process::id()));
        run(&RunArgs {
            clips: vec![clip.clone()],
            out: out.clone(),
            range: RangeArg::Auto,
            save_masks: true,
            lut: "bundled".into(),
            refine: RefineChoice(Some(GuidedMethod::GvfAsm)),
            tetris: None,
            range_smoothing: SmoothingArg::default(),
            smooth: false,
            no_grey_fit: false,
            polarity: PolarityArg::default(),
        })?;
        let poses = std::fs::read_to_string(out.join("results.csv"))?
            .lines()
            .filter(|line| line.contains(",ok,"))
            .count();
        let refined = std::fs::read_dir(out.join(REFINED_FOLDER))?.count();
        let evaluation = crate::eval::evaluate(&clip, &out.join("results.csv"), "bundled")?;
        std::fs::remove_dir_all(&out)?;
        assert!(poses > 0);
        assert_eq!(refined, poses, "one refined mask per frame with a pose");
        let stage = evaluation
            .segmentation
            .iter()
            .find(|s| s.folder == REFINED_FOLDER)
            .expect("the refined stage is scored");
        assert_eq!(stage.frames - stage.missing, poses);
        assert!(
            stage.stats.is_some_and(|s| s.median > 0.5),
            "{:?}",
            stage.stats
        );
        Ok(())
    }
}
