//! `liftwatch fit` (in progress).

use std::path::PathBuf;

/// Flags of `liftwatch fit`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Input file.
    #[arg(long)]
    pub input: Option<PathBuf>,
}

/// Runs `fit`.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("fit is not built yet")
}
