//! `liftwatch align`: raw telemetry → aligned series.

use crate::args::AlignArgs;

/// Runs `align`.
pub fn run(args: AlignArgs) -> anyhow::Result<()> {
    anyhow::bail!("align is not built yet ({})", args.input.display())
}
