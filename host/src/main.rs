//! `imade`: run the attitude pipeline on recorded clips, simulate clips, and more.

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "imade",
    version,
    about = "Projectile attitude from ground-based monocular imagery"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Estimate the pose in every frame of recorded clips; write imade-results/1 CSVs.
    Run(imade_host::run::RunArgs),
    /// The main job: run a clip with and without its range, score both against the paper, plot.
    Demo(imade_host::demo::DemoArgs),
    /// Score a results file against the clip's ground truth, beside the paper's figures.
    Eval(imade_host::eval::EvalArgs),
    /// Draw figures like the paper's from results files (PNG).
    Plot(imade_host::plot::PlotArgs),
    /// Build model files (imade-model/1): the projectile's geometry and silhouette table.
    Model(imade_host::model::command::ModelArgs),
    /// The same as `model` (kept for scripts that build tables).
    Lut(imade_host::model::command::ModelArgs),
    /// Render a deterministic simulated clip (imade-clip/1) with ground truth.
    Simulate(imade_host::sim::SimulateArgs),
    /// Fuse one flight's clips from two or more stations: the nose and position where their
    /// views meet.
    Fuse(imade_host::fuse::FuseArgs),
    /// Pack a clip for the firmware under QEMU (imade-pack/1, see firmware-sim/).
    Pack(imade_host::pack::PackArgs),
    /// Train a learned stage on simulated chips: `imade train tetris --out FILE`.
    Train(imade_host::train::TrainArgs),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let outcome = match cli.command {
        Command::Run(args) => imade_host::run::run(&args),
        Command::Demo(args) => imade_host::demo::run(&args),
        Command::Eval(args) => imade_host::eval::run(&args),
        Command::Plot(args) => imade_host::plot::run(&args),
        Command::Model(args) | Command::Lut(args) => imade_host::model::command::run(&args),
        Command::Simulate(args) => imade_host::sim::run(&args),
        Command::Fuse(args) => imade_host::fuse::run(&args),
        Command::Pack(args) => imade_host::pack::run(&args),
        Command::Train(args) => imade_host::train::run(&args),
    };
    if let Err(error) = &outcome {
        eprintln!("imade: error: {error:#}");
    }
    std::process::ExitCode::from(imade_host::exit::exit_code(&outcome))
}
