//! `liftwatch simulate` (in progress).

use std::path::PathBuf;

/// Flags of `liftwatch simulate`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Input file.
    #[arg(long)]
    pub input: Option<PathBuf>,
}

/// Runs `simulate`.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("simulate is not built yet")
}
