//! `imade train`: trains the core's learned stages on simulated data. One model so far:
//! `imade train tetris`, the shape-guided segmentation's network ([`tetris`]).

pub mod tetris;

/// Arguments of `imade train`.
#[derive(Debug, clap::Args)]
pub struct TrainArgs {
    /// What to train.
    #[command(subcommand)]
    pub model: TrainModel,
}

/// The trainable models.
#[derive(Debug, clap::Subcommand)]
pub enum TrainModel {
    /// 2D TETRIS: the network that warps the shape prior onto the body (`--refine tetris`).
    Tetris(tetris::TetrisArgs),
}

/// Runs `imade train`.
pub fn run(args: &TrainArgs) -> anyhow::Result<()> {
    match &args.model {
        TrainModel::Tetris(args) => tetris::run(args).map(|_| ()),
    }
}
