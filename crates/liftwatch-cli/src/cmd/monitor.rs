//! `liftwatch monitor` (in progress).

use std::path::PathBuf;

/// Flags of `liftwatch monitor`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Input file.
    #[arg(long)]
    pub input: Option<PathBuf>,
}

/// Runs `monitor`.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("monitor is not built yet")
}
