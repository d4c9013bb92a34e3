//! `imade eval`: a results file against the clip's ground truth: 1-km-normalized pose errors and
//! the segmentation IoU of each stage, beside the source paper's published figures; written as
//! markdown (printed, and `eval.md`) and JSON (`eval.json`).

pub mod iou;
pub mod paper;
pub mod pose_errors;
pub mod report;
pub mod stats;
pub mod world_errors;

use crate::clip::{Clip, GroundTruth, read_results, write_atomically};
use anyhow::{Context, bail};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Arguments of `imade eval`.
#[derive(Debug, clap::Args)]
pub struct EvalArgs {
    /// The clip folder (imade-clip/1, with ground truth).
    pub clip: PathBuf,
    /// The results file of the clip; stage masks are read from its folder.
    #[arg(long, default_value = "out/results.csv")]
    pub results: PathBuf,
    /// Folder for `eval.md` and `eval.json` (default: the results file's folder).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// The model the run used, as `imade run --lut` took it (`bundled`, `none` or a model
    /// file): the roll is scored modulo its fins' spacing (modulo 90 where the model cannot be
    /// had).
    #[arg(long, default_value = "bundled")]
    pub lut: String,
}

/// The evaluation of one results file.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Evaluation {
    /// The clip folder.
    pub clip: PathBuf,
    /// The results file.
    pub results: PathBuf,
    /// Result rows in the file.
    pub result_rows: usize,
    /// Pose errors.
    pub pose: pose_errors::PoseEvaluation,
    /// IoU per segmentation stage with saved masks.
    pub segmentation: Vec<iou::StageIou>,
    /// World-frame errors, where the clip gives the mount's pointing and the results a world
    /// pose.
    pub world: Option<world_errors::WorldEvaluation>,
}

/// Evaluates `results` (an imade-results/1 file) against the truth of the clip in `clip_dir`,
/// written by a run with the model choice `lut` (`imade run --lut`).
pub fn evaluate(clip_dir: &Path, results: &Path, lut: &str) -> anyhow::Result<Evaluation> {
    let clip = Clip::open(clip_dir)?;
    let truth: Vec<(u64, GroundTruth)> = clip
        .frames
        .iter()
        .filter_map(|f| f.as_ref().ok())
        .filter_map(|row| Some((row.frame, row.truth?)))
        .collect();
    if truth.is_empty() {
        bail!(
            "{}: no frame has ground truth (the gt_ columns)",
            clip_dir.join("frames.csv").display()
        );
    }
    let rows = read_results(results)?;
    let results_dir = results.parent().unwrap_or(Path::new("."));
    let roll_period_deg = roll_period_deg(&clip.meta.projectile, lut);
    Ok(Evaluation {
        clip: clip_dir.to_path_buf(),
        results: results.to_path_buf(),
        result_rows: rows.len(),
        pose: pose_errors::evaluate(&truth, &rows, roll_period_deg),
        segmentation: iou::evaluate(&clip, results_dir)?,
        world: world_errors::evaluate(&clip, &rows),
    })
}

/// The spacing of the fins of the model the run used (`lut`, as `imade run --lut` takes it, for
/// the clip's `projectile`), deg, which its roll is given modulo; 90 (the spec's four fins) for
/// a model without fins, or where the model cannot be had (a projectile without a bundled model
/// and no model file given).
fn roll_period_deg(projectile: &str, lut: &str) -> f64 {
    let file = match lut {
        "bundled" | "none" => None,
        path => Some(Path::new(path)),
    };
    crate::model::for_clip(projectile, file)
        .ok()
        .and_then(|model| model.fin_spacing_deg())
        .map_or(90.0, f64::from)
}

/// Writes `eval.md` and `eval.json` of an evaluation into `dir`.
pub fn write_reports(evaluation: &Evaluation, dir: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let markdown = report::markdown(&[evaluation]);
    write_atomically(&dir.join("eval.md"), markdown.as_bytes())?;
    let json = serde_json::to_string_pretty(evaluation)?;
    write_atomically(&dir.join("eval.json"), json.as_bytes())
}

/// Runs `imade eval`: prints the markdown report and writes it with the JSON.
pub fn run(args: &EvalArgs) -> anyhow::Result<()> {
    let evaluation = evaluate(&args.clip, &args.results, &args.lut)?;
    print!("{}", report::markdown(&[&evaluation]));
    let dir = match &args.out {
        Some(dir) => dir.clone(),
        None => args
            .results
            .parent()
            .unwrap_or(Path::new("."))
            .to_path_buf(),
    };
    write_reports(&evaluation, &dir)
}
