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
    /// Render a deterministic simulated clip (imade-clip/1) with ground truth.
    Simulate(imade_host::sim::SimulateArgs),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let outcome = match cli.command {
        Command::Run(args) => imade_host::run::run(&args),
        Command::Simulate(args) => imade_host::sim::run(&args),
    };
    match outcome {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("imade: error: {error:#}");
            std::process::ExitCode::from(1)
        }
    }
}
