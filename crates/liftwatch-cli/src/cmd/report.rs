//! `liftwatch report`: figures and an HTML page about one input, read with a fitted model
//! (DATA.md §6).
//!
//! The slice of the pipeline: model file → aligned series (either input layout) → features →
//! both monitors (the paper's method and the fixed-threshold baseline) → the report crate,
//! which writes each figure as SVG and PNG and `index.html` into `--out`.

use std::path::PathBuf;

use anyhow::Context;
use liftwatch::align::{read_series, AlignConfig};
use liftwatch::file;
use liftwatch::monitor::Analysis;
use liftwatch::output::{AtomicDir, FileArg};
use liftwatch_report::{write_report, ReportInputs};

/// Flags of `liftwatch report`.
#[derive(Debug, clap::Args)]
#[command(
    about = "Write figures (SVG and PNG) and an HTML report about telemetry, read with a fitted model"
)]
pub struct Args {
    /// Model file written by `fit`.
    #[arg(long)]
    pub model: PathBuf,
    /// Telemetry to report on, raw `time,signal,value` or aligned.
    #[arg(long)]
    pub input: PathBuf,
    /// Output directory (created if missing): figures as SVG and PNG, and index.html.
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs `report` and prints the path of `index.html`.
pub fn run(args: Args) -> anyhow::Result<()> {
    liftwatch::output::check_distinct(&[
        FileArg::input("--model", &args.model),
        FileArg::input("--input", &args.input),
        FileArg::output("--out", &args.out),
    ])
    .map_err(anyhow::Error::msg)?;
    let model = file::load(&args.model).context("cannot use the model")?;
    let (series, ingest) = read_series(&args.input, &AlignConfig::default())
        .with_context(|| format!("cannot read {}", args.input.display()))?;
    if ingest.bad_rows > 0 {
        eprintln!(
            "warning: {}: skipped {} bad rows",
            args.input.display(),
            ingest.bad_rows
        );
    }
    eprintln!(
        "report: {} samples from {}",
        series.len(),
        args.input.display()
    );
    let analysis = Analysis::run(&model, &series);
    let source = args.input.file_name().map_or_else(
        || args.input.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    // Written into a temporary directory and moved in at the end: a failure (a full disk) leaves
    // no half-written figure behind.
    let cannot_write = || format!("cannot write the report to {}", args.out.display());
    let dir = AtomicDir::create(&args.out).with_context(cannot_write)?;
    write_report(
        dir.path(),
        &ReportInputs::new(&analysis, &model, &series, &source),
    )
    .with_context(cannot_write)?;
    dir.commit().with_context(cannot_write)?;
    println!("{}", args.out.join("index.html").display());
    Ok(())
}
