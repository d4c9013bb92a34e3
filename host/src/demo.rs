//! `imade demo`: the main job in one command. Runs a clip twice in parallel, with its range
//! measurements (the paper's known-range case) and without them (unknown range), saving the
//! stage masks; evaluates both against the ground truth; prints the accuracy table beside the
//! paper's figures; writes the report and the figures.
//!
//! Output folder layout:
//!
//! | path | what |
//! | --- | --- |
//! | `known-range/`, `unknown-range/` | `results.csv`, `masks/`, `priors/`, `eval.md`, `eval.json` of each run |
//! | `summary.json` | what `imade run` would report for the two runs |
//! | `report.md` | the accuracy table of both runs against the paper |
//! | `plots/` | the figures of `imade plot` |

use crate::clip::{Clip, write_atomically};
use crate::eval::{Evaluation, evaluate, report, write_reports};
use crate::plot::plot_all;
use crate::run::{Job, PolarityArg, RangeArg, outcome, run_jobs};
use anyhow::Context;
use std::path::PathBuf;

/// Arguments of `imade demo`.
#[derive(Debug, clap::Args)]
pub struct DemoArgs {
    /// The clip folder (imade-clip/1, with ground truth and range measurements).
    #[arg(default_value = "fixtures/table1-test")]
    pub clip: PathBuf,
    /// Output folder.
    #[arg(long, default_value = "out/table1-test")]
    pub out: PathBuf,
    /// Silhouette table of the table match (as for `imade run --lut`).
    #[arg(long, default_value = "bundled")]
    pub lut: String,
}

/// The two runs: folder name and range use.
const RUNS: [(&str, RangeArg); 2] = [
    ("known-range", RangeArg::Given),
    ("unknown-range", RangeArg::Ignore),
];

/// Runs `imade demo`.
pub fn run(args: &DemoArgs) -> anyhow::Result<()> {
    let jobs: Vec<Job> = RUNS
        .iter()
        .map(|&(name, range)| Job {
            clip: args.clip.clone(),
            out_dir: args.out.join(name),
            range,
            save_masks: true,
            lut: args.lut.clone(),
            refine: crate::run::RefineChoice(None),
            tetris: None,
            range_smoothing: crate::run::SmoothingArg::default(),
            smooth: false,
            grey_fit: true,
            polarity: PolarityArg::default(),
        })
        .collect();
    eprintln!(
        "imade demo: running {} with and without its range measurements ...",
        args.clip.display()
    );
    let summary = run_jobs(&jobs);
    let json = serde_json::to_string_pretty(&summary)?;
    write_atomically(&args.out.join("summary.json"), json.as_bytes())?;
    let status = outcome(&summary);
    if summary.failed_clips() > 0 {
        return status.context("the clip could not be read; nothing evaluated");
    }
    let evaluations = jobs
        .iter()
        .map(|job| {
            let evaluation = evaluate(&args.clip, &job.out_dir.join("results.csv"), "bundled")?;
            write_reports(&evaluation, &job.out_dir)?;
            Ok(evaluation)
        })
        .collect::<anyhow::Result<Vec<Evaluation>>>()?;
    let refs: Vec<&Evaluation> = evaluations.iter().collect();
    let table = report::markdown(&refs);
    write_atomically(&args.out.join("report.md"), table.as_bytes())?;
    print!("{table}");
    let clip = Clip::open(&args.clip)?;
    let runs: Vec<(String, &Evaluation)> = RUNS
        .iter()
        .zip(&evaluations)
        .map(|((name, _), e)| ((*name).to_owned(), e))
        .collect();
    let plots = plot_all(&clip, &runs, &args.out.join("plots"))?;
    println!("Report: {}", args.out.join("report.md").display());
    println!("Figures:");
    for path in plots {
        println!("  {}", path.display());
    }
    status
}
