//! `liftwatch status`: the verdict a person acts on, from a model and the state `monitor
//! --state` saved (level, mode, drift ± error since when, what to inspect, the forecast, the
//! evidence and the model's caveats); the same text the report opens with
//! ([`liftwatch::verdict::Verdict`]).
//!
//! The slice of the pipeline: model file + monitor state → verdict. Nothing is recomputed
//! from telemetry and nothing is written.

use std::path::PathBuf;

use anyhow::Context;
use liftwatch::file;
use liftwatch::monitor::MonitorState;
use liftwatch::verdict::Verdict;
use std::io::Write;

/// Flags of `liftwatch status`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Model file written by `fit`.
    #[arg(long)]
    pub model: PathBuf,
    /// State file written by `monitor --state` with this model.
    #[arg(long)]
    pub state: PathBuf,
    /// Print one JSON object instead of sentences.
    #[arg(long)]
    pub json: bool,
}

/// Runs `status`: prints the verdict to stdout.
pub fn run(args: Args) -> anyhow::Result<()> {
    let model = file::load(&args.model).context("cannot use the model")?;
    let state = MonitorState::load(&args.state).context("cannot use the state")?;
    state
        .check_model(&model)
        .with_context(|| format!("{}", args.state.display()))?;
    let verdict = Verdict::new(&model, &state);
    // Written, not printed: a reader that goes away (`status | head -1`) is an I/O error
    // that ends the run quietly with 141, never a panic.
    let mut out = std::io::stdout().lock();
    if args.json {
        writeln!(out, "{}", serde_json::to_string(&verdict)?)?;
    } else {
        for line in verdict.lines() {
            writeln!(out, "{line}")?;
        }
    }
    out.flush()?;
    Ok(())
}
