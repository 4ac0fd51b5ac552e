//! `liftwatch align` (in progress).

use std::path::PathBuf;

/// Flags of `liftwatch align`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Input file.
    #[arg(long)]
    pub input: Option<PathBuf>,
}

/// Runs `align`.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("align is not built yet")
}
