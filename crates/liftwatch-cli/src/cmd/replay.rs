//! `liftwatch replay`: sends a raw telemetry log to a running `liftwatch serve` in batches of
//! `--batch-s` seconds of log, at `--speed`× real time (0: as fast as the server accepts); a
//! failed batch is sent again (the server drops what it already has).

use std::io::IsTerminal;
use std::path::PathBuf;

use liftwatch_serve::replay::{replay, sender_for, ReplayOptions};

/// Default seconds of log per batch: a gateway's usual flush interval.
const DEFAULT_BATCH_S: f64 = 10.0;

/// Flags of `liftwatch replay`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Raw `time,signal,value` log (`-`: stdin, `.gz`: gzip).
    #[arg(long)]
    pub input: PathBuf,
    /// Elevator id, [A-Za-z0-9_-]{1,64}.
    #[arg(long)]
    pub id: String,
    /// Server: http://HOST:PORT.
    #[arg(long)]
    pub to: String,
    /// Multiple of real time; 0 sends as fast as accepted.
    #[arg(long, default_value_t = 0.0)]
    pub speed: f64,
    /// Seconds of log per batch.
    #[arg(long = "batch-s", default_value_t = DEFAULT_BATCH_S)]
    pub batch_s: f64,
    /// File whose first line is the token (else LIFTWATCH_TOKEN).
    #[arg(long = "token-file")]
    pub token_file: Option<PathBuf>,
    /// Print nothing on success.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Runs `replay`: one summary line on stderr.
pub fn run(args: Args) -> anyhow::Result<()> {
    let token = super::serve::token(args.token_file.as_ref())?;
    let mut sender = sender_for(&args.to, token).map_err(anyhow::Error::msg)?;
    let opts = ReplayOptions {
        batch_s: args.batch_s,
        speed: args.speed,
        progress: !args.quiet && std::io::stderr().is_terminal(),
    };
    let s = replay(&args.input, &args.id, sender.as_mut(), &opts).map_err(anyhow::Error::msg)?;
    if !args.quiet {
        eprintln!(
            "replay: {} rows in {} batches to {} ({}): {} accepted, {} bad, {} retries, {:.1} s",
            s.rows, s.batches, args.to, args.id, s.accepted, s.bad, s.retries, s.seconds
        );
    }
    Ok(())
}
