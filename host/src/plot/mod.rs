//! `imade plot`: PNG figures like the source paper's, from results files and their saved masks:
//!
//! | file | like the paper's | shows |
//! | --- | --- | --- |
//! | `pose-<run>.png` | Fig. 15 / 16 | estimated (orange) against true (blue) Tx, Ty, Tz, pitch, yaw over the frames, the mirrored candidate (grey), the slant range |
//! | `errors.png` | Fig. 22 / 23 | box plots of the 1-km-normalized errors per parameter, one box per run, the paper's accuracy in red |
//! | `iou.png` | Fig. 19 | box plots of the IoU of each segmentation stage, one box per run, the paper's median in red |
//! | `overlays-<run>.png` | Fig. 17 | the mask (green) and the shape prior's outline (red) on chips spread over the clip |
//! | `aoa-<run>.png` | (none) | where the results state the world frame: the angle of attack and its components up and right over the frames, and the damping plot of up against right, against the truth |

pub mod aoa;
pub mod boxes;
pub mod errors;
pub mod font;
pub mod iou_box;
pub mod loss;
pub mod overlay;
pub mod panel;
pub mod pose_series;

use crate::clip::{Clip, read_results};
use crate::eval::{Evaluation, evaluate};
use anyhow::Context;
use std::path::{Path, PathBuf};

/// Arguments of `imade plot`.
#[derive(Debug, clap::Args)]
pub struct PlotArgs {
    /// The clip folder (imade-clip/1, with ground truth).
    pub clip: PathBuf,
    /// Results files to compare (each a run); stage masks are read from their folders.
    #[arg(long, num_args = 1.., default_value = "out/results.csv")]
    pub results: Vec<PathBuf>,
    /// Folder for the PNGs (default: `plots/` beside the first results file).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// A run's name in the figures: its results folder's name.
pub fn run_label(results: &Path) -> String {
    results
        .parent()
        .and_then(Path::file_name)
        .map_or_else(|| "run".into(), |n| n.to_string_lossy().into_owned())
}

/// Writes every figure for the runs into `out`; returns the files written.
pub fn plot_all(
    clip: &Clip,
    runs: &[(String, &Evaluation)],
    out: &Path,
) -> anyhow::Result<Vec<PathBuf>> {
    font::register()?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let mut written = Vec::new();
    for (label, evaluation) in runs {
        let rows = read_results(&evaluation.results)?;
        let path = out.join(format!("pose-{label}.png"));
        let title = format!(
            "{}: estimated against true pose ({})",
            label,
            evaluation.pose.case.label()
        );
        pose_series::plot(clip, &rows, &title, &path)
            .with_context(|| format!("plotting {}", path.display()))?;
        written.push(path);
        let path = out.join(format!("aoa-{label}.png"));
        let title = format!("{label}: angle of attack in the world frame");
        if aoa::plot(clip, &rows, &title, &path)
            .with_context(|| format!("plotting {}", path.display()))?
        {
            written.push(path);
        }
        let path = out.join(format!("overlays-{label}.png"));
        let dir = evaluation.results.parent().unwrap_or(Path::new("."));
        if overlay::plot(clip, dir, &path)
            .with_context(|| format!("plotting {}", path.display()))?
        {
            written.push(path);
        }
    }
    let path = out.join("errors.png");
    errors::plot(runs, &path).with_context(|| format!("plotting {}", path.display()))?;
    written.push(path);
    let path = out.join("iou.png");
    if iou_box::plot(runs, &path).with_context(|| format!("plotting {}", path.display()))? {
        written.push(path);
    }
    Ok(written)
}

/// Runs `imade plot`.
pub fn run(args: &PlotArgs) -> anyhow::Result<()> {
    let clip = Clip::open(&args.clip)?;
    let evaluations = args
        .results
        .iter()
        .map(|r| evaluate(&args.clip, r, "bundled"))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let mut runs: Vec<(String, &Evaluation)> = Vec::new();
    for (i, e) in evaluations.iter().enumerate() {
        let mut label = run_label(&e.results);
        if runs.iter().any(|(l, _)| *l == label) {
            label = format!("{label}-{}", i + 1);
        }
        runs.push((label, e));
    }
    let out = match &args.out {
        Some(out) => out.clone(),
        None => args
            .results
            .first()
            .and_then(|r| r.parent())
            .unwrap_or(Path::new("."))
            .join("plots"),
    };
    for path in plot_all(&clip, &runs, &out)? {
        println!("{}", path.display());
    }
    Ok(())
}
