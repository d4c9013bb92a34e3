//! The clip simulator. (Placeholder: being written.)

/// Arguments of `imade simulate`.
#[derive(Debug, clap::Args)]
pub struct SimulateArgs {
    /// Output clip folder.
    #[arg(long)]
    pub out: std::path::PathBuf,
}

/// Runs `imade simulate`.
pub fn run(_args: &SimulateArgs) -> anyhow::Result<()> {
    anyhow::bail!("imade simulate is not built yet")
}
