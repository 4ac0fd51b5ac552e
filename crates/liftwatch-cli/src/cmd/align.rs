//! `liftwatch align`: raw `time,signal,value` telemetry (or an aligned file) to a uniform
//! step, written as DATA.md §2. Stages 1-2 of the pipeline: ingest, then align.
//!
//! The output is written through the library's one atomic writer: a temporary file beside
//! `--out`, renamed over it only when alignment succeeded, so a failed run leaves no output
//! file behind; a device, a FIFO or `-` (standard output) is written in place. `--input -`
//! reads standard input; a `.gz` name on either side is gzip.

use std::path::PathBuf;

use anyhow::Context as _;
use liftwatch::align::{align_file_pipelined, AlignConfig, AlignedFileSink};
use liftwatch::output::{check_file_args, FileArg};

use super::ui::{ingest_json, named, warn, Ui, UiArgs};

/// Flags of `liftwatch align`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Telemetry to align: raw `time,signal,value` or an aligned CSV (`-`: stdin, `.gz`: gzip).
    #[arg(long)]
    pub input: PathBuf,
    /// Aligned CSV to write (`time,speed,direction,voltage,load,door,floor[,current]`;
    /// `-`: stdout, `.gz`: gzip).
    #[arg(long)]
    pub out: PathBuf,
    /// Uniform step of the output (s).
    #[arg(long, default_value_t = 1.0)]
    pub step: f64,
    /// Longest gap between two readings that is still interpolated or held (s).
    #[arg(long = "gap-limit", default_value_t = 5.0)]
    pub gap_limit: f64,
    /// How far out of time order rows may come and still be streamed (s); later rows
    /// make the whole file be sorted in memory.
    #[arg(long = "reorder-window", default_value_t = 600.0)]
    pub reorder_window: f64,
    /// Summary: --quiet, --json.
    #[command(flatten)]
    pub ui: UiArgs,
}

/// Runs `align`: ingest and align `--input`, write `--out`, one warning and one summary line.
pub fn run(args: Args) -> anyhow::Result<()> {
    let ui = Ui::new(args.ui, &[("--out", &args.out)])?;
    let cfg = AlignConfig::default()
        .with_step(args.step)
        .and_then(|c| c.with_gap_limit(args.gap_limit))
        .and_then(|c| c.with_reorder_window(args.reorder_window))?;
    check_file_args(&[
        FileArg::input("--input", &args.input),
        FileArg::output("--out", &args.out),
    ])
    .map_err(anyhow::Error::msg)?;
    let out = named(&args.out, true);
    let cannot_write = || format!("cannot write {out}");
    // The library's errors carry no chained cause (`Error::Io` states its OS error in its own
    // message), so `{:#}` prints each once.
    let mut sink = AlignedFileSink::create(&args.out).with_context(cannot_write)?;
    let report = align_file_pipelined(&args.input, &cfg, &mut sink)?;
    sink.finish().with_context(cannot_write)?;
    if let Some(w) = report.warning() {
        warn(&args.input, &w);
    }
    ui.say(format_args!("{out}: {}", report.summary()));
    ui.json(&serde_json::json!({
        "command": "align",
        "out": out,
        "step_s": cfg.step_s,
        "input": ingest_json(&args.input, &report),
    }))
}
