//! `liftwatch report`: figures and an HTML page about one input, read with a fitted model
//! (DATA.md §6).
//!
//! The slice of the pipeline: model file → aligned samples (either input layout), spilled to
//! disk → in one pass, features and both monitors (the paper's method and the fixed-threshold
//! baseline), keeping the rows of the last `--days` days (`monitor::Analysis::run_from`) → the
//! report crate, which writes each figure as SVG and PNG and `index.html` into `--out`.

use std::path::PathBuf;

use anyhow::Context;
use liftwatch::align::AlignConfig;
use liftwatch::file;
use liftwatch::monitor::Analysis;
use liftwatch::output::{AtomicDir, FileArg};
use liftwatch::sample::DAY_S;
use liftwatch_report::{write_report, ReportInputs};

use super::spill;
use super::step::{check_input_step, model_step};
use super::ui::{named, Ui, UiArgs};

/// Flags of `liftwatch report`.
#[derive(Debug, clap::Args)]
#[command(
    about = "Write figures (SVG and PNG) and an HTML report about telemetry, read with a fitted model"
)]
pub struct Args {
    /// Model file written by `fit`.
    #[arg(long)]
    pub model: PathBuf,
    /// Telemetry to report on, raw `time,signal,value` or aligned (`-`: stdin, `.gz`: gzip).
    #[arg(long)]
    pub input: PathBuf,
    /// Output directory (created if missing): figures as SVG and PNG, and index.html.
    #[arg(long)]
    pub out: PathBuf,
    /// Alignment step (s); default the model's, and another one is refused.
    #[arg(long)]
    pub step: Option<f64>,
    /// Days drawn: the figures show the input's last DAYS days, held in memory (about 570
    /// bytes a sample); the verdict is the whole input's.
    #[arg(long, default_value_t = DEFAULT_DAYS)]
    pub days: f64,
    /// Summary: --quiet, --json.
    #[command(flatten)]
    pub ui: UiArgs,
}

/// Days a report draws by default: a month, about 1.5 GB at 1 Hz.
const DEFAULT_DAYS: f64 = 31.0;

/// Runs `report` and names `index.html` (on stderr, or in the `--json` object on stdout).
pub fn run(args: Args) -> anyhow::Result<()> {
    anyhow::ensure!(
        !liftwatch::input::is_stdio(&args.out),
        "--out cannot be `-`: a report is a directory of files"
    );
    let ui = Ui::new(args.ui, &[])?;
    let files = [
        FileArg::input("--model", &args.model),
        FileArg::input("--input", &args.input),
        FileArg::output("--out", &args.out),
    ];
    liftwatch::output::check_file_args(&files).map_err(anyhow::Error::msg)?;
    let model = file::load(&args.model).context("cannot use the model")?;
    let (step, note) = model_step(&model, args.step)?;
    if let Some(n) = note {
        eprintln!("{n}"); // about the numbers themselves: shown even with --quiet or --json
    }
    anyhow::ensure!(
        args.days.is_finite() && args.days > 0.0,
        "--days must be a positive number of days, not {}",
        args.days
    );
    let input = named(&args.input, false);
    // The input waits on disk beside the report for the one pass that draws its last days.
    let spill_dir = spill::parent(&args.out);
    let align = AlignConfig::default().with_step(step)?;
    let (spilled, ingest) = spill::read("report", &args.input, &align, &spill_dir, &ui)
        .with_context(|| format!("cannot read {input}"))?;
    check_input_step(step, &ingest, &input)?;
    if ingest.bad_rows > 0 {
        super::ui::warn(
            &args.input,
            &format!("skipped {} bad rows", ingest.bad_rows),
        );
    }
    let from = spilled.last_time() - args.days * DAY_S;
    let (analysis, series) = Analysis::run_from(&model, &spilled, from)
        .with_context(|| format!("cannot read {input}"))?;
    let cut = series.len() as u64 != spilled.len();
    let drawn = if cut {
        format!(
            "; figures of its last {} days ({} samples)",
            liftwatch::error::number(args.days),
            series.len()
        )
    } else {
        String::new()
    };
    ui.say(format_args!(
        "report: {} samples from {input}{drawn}",
        spilled.len()
    ));
    let name = if liftwatch::input::is_stdio(&args.input) {
        input.clone()
    } else {
        args.input.file_name().map_or_else(
            || args.input.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        )
    };
    let source = if cut {
        format!(
            "{name}, its last {} of {:.1} days",
            liftwatch::error::number(args.days),
            spilled.duration_s() / DAY_S
        )
    } else {
        name
    };
    // Written into a temporary directory and moved in at the end: a failure (a full disk) leaves
    // no half-written figure behind.
    let cannot_write = || format!("cannot write the report to {}", args.out.display());
    let dir = AtomicDir::create(&args.out).with_context(cannot_write)?;
    write_report(
        dir.path(),
        &ReportInputs::new(&analysis, &model, &series, &source),
    )
    .with_context(cannot_write)?;
    dir.check_spares(&files)?;
    dir.commit().with_context(cannot_write)?;
    let index = args.out.join("index.html").display().to_string();
    ui.say(&index);
    ui.json(&serde_json::json!({
        "command": "report",
        "index": index,
        "samples": spilled.len(),
        "drawn_samples": series.len(),
        "step_s": step,
        "events": analysis.events.len(),
    }))
}
