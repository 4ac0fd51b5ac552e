//! `liftwatch monitor`: watch telemetry with a fitted model (DATA.md §4, §6).
//!
//! Streams `--input` (raw or aligned) through alignment and the library's one streaming step
//! [`Monitor::push`], writes one row per aligned sample to `--out` and, with `--events`, one
//! JSON line per change of level. With `--state FILE` the run resumes from the state if the
//! file exists and saves the state at the end instead of flushing the last, still-held row:
//! today's output appended to yesterday's equals one run over both inputs.
//!
//! Crash safety: every output goes through the library's one atomic writer, and the outputs are
//! committed as a unit, rows first, events next, the state last. A failure or a kill at any
//! instant leaves either the old state (and the retry recomputes the same outputs from it) or
//! everything. Input at or before the time the state already covers is refused (it would count
//! trips twice), or skipped with `--skip-covered`.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Context;
use liftwatch::align::{align_file, AlignConfig, SampleSink};
use liftwatch::file;
use liftwatch::fit::FittedModel;
use liftwatch::monitor::{Method, Monitor, MonitorRow, MonitorState, RowWriter};
use liftwatch::output::{check_distinct, AtomicFile, FileArg};
use liftwatch::Sample;

/// Environment variable of the crash tests: `after-rows`, `after-events` or `before-state`
/// makes the process abort at that commit instant, as a power cut would.
pub const FAULT_ENV: &str = "LIFTWATCH_FAULT";

/// Flags of `liftwatch monitor`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Model file written by `fit`.
    #[arg(long)]
    pub model: PathBuf,
    /// Telemetry to watch, raw `time,signal,value` or aligned.
    #[arg(long)]
    pub input: PathBuf,
    /// Output CSV: one row per aligned sample.
    #[arg(long)]
    pub out: PathBuf,
    /// Events file: one JSON line per change of level.
    #[arg(long)]
    pub events: Option<PathBuf>,
    /// Method: pinn (risk from the dual residuals) or threshold (the conventional baseline).
    #[arg(long, default_value = "pinn", value_parser = ["pinn", "threshold"])]
    pub method: String,
    /// State file: resumed from when it exists, written at the end (the last row stays held).
    #[arg(long)]
    pub state: Option<PathBuf>,
    /// Alignment step for raw input (s).
    #[arg(long, default_value_t = 1.0)]
    pub step: f64,
    /// Skip input samples the state already covers instead of refusing the input.
    #[arg(long = "skip-covered")]
    pub skip_covered: bool,
}

/// The alignment sink: feeds the monitor and writes its rows and events.
struct Sink<'a> {
    model: &'a FittedModel,
    method: Method,
    resume: Option<MonitorState>,
    monitor: Monitor,
    /// Rows: the writer over the output file, or the file alone before the first start.
    rows: Rows,
    events: Option<AtomicFile>,
    /// Samples at or before this time were watched by an earlier run (NaN: none).
    covered_until: f64,
    skip_covered: bool,
    samples: u64,
    skipped: u64,
    events_written: u64,
}

/// The rows output: a file not yet started, or its CSV writer.
enum Rows {
    File(AtomicFile),
    Writing(RowWriter<AtomicFile>),
    Gone,
}

impl Rows {
    /// The file back, flushed.
    fn take(&mut self) -> std::io::Result<AtomicFile> {
        match std::mem::replace(self, Rows::Gone) {
            Rows::File(f) => Ok(f),
            Rows::Writing(w) => w.into_inner(),
            Rows::Gone => Err(std::io::Error::other("not written after an earlier error")),
        }
    }
}

impl Sink<'_> {
    fn write(&mut self, r: &MonitorRow) -> std::io::Result<()> {
        if let Rows::Writing(w) = &mut self.rows {
            w.write(r)?;
        }
        if let (Some(e), Some(f)) = (&r.event, &mut self.events) {
            writeln!(f, "{}", e.to_json_line())?;
            self.events_written += 1;
        }
        Ok(())
    }
}

impl SampleSink for Sink<'_> {
    /// The command's own error: alignment's errors convert into it, write errors carry the
    /// output's name as context.
    type Error = anyhow::Error;

    fn start(&mut self, _has_current: bool) -> anyhow::Result<()> {
        // A restart of alignment (a late row) replays the input: start over from the beginning.
        self.monitor = match self.resume.clone() {
            Some(st) => Monitor::resume(self.model, st)?,
            None => Monitor::new(self.model, self.method),
        };
        let restart = matches!(self.rows, Rows::Writing(_));
        let mut file = self.rows.take().context("cannot write the rows")?;
        if restart {
            file.restart()?;
            if let Some(e) = &mut self.events {
                e.restart()?;
            }
        }
        let path = file.path().display().to_string();
        let w = RowWriter::new(file).with_context(|| format!("cannot write {path}"))?;
        self.rows = Rows::Writing(w);
        self.samples = 0;
        self.skipped = 0;
        self.events_written = 0;
        Ok(())
    }

    fn push(&mut self, sample: &Sample) -> anyhow::Result<()> {
        if sample.time <= self.covered_until {
            if !self.skip_covered {
                anyhow::bail!(
                    "the input has a sample at t = {} s, at or before t = {} s, the last the state covers: it was watched already (pass --skip-covered to skip what the state covers)",
                    sample.time,
                    self.covered_until
                );
            }
            self.skipped += 1;
            return Ok(());
        }
        self.samples += 1;
        if self.samples % 5_000_000 == 0 {
            eprintln!(
                "monitor: {} samples, level {}",
                self.samples,
                self.monitor.state_ref().level()
            );
        }
        if let Some(row) = self.monitor.push(sample) {
            self.write(&row).context("cannot write the outputs")?;
        }
        Ok(())
    }
}

/// Aborts the process at a commit instant when the crash tests ask for it ([`FAULT_ENV`]).
fn fault_point(name: &str) {
    if std::env::var(FAULT_ENV).is_ok_and(|v| v == name) {
        std::process::abort();
    }
}

/// Runs `monitor`: model, streamed input, rows, events, state, one summary line.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut files = vec![
        FileArg::input("--model", &args.model),
        FileArg::input("--input", &args.input),
        FileArg::output("--out", &args.out),
    ];
    if let Some(p) = &args.events {
        files.push(FileArg::output("--events", p));
    }
    if let Some(p) = &args.state {
        files.push(FileArg::output("--state", p));
    }
    check_distinct(&files).map_err(anyhow::Error::msg)?;
    let model = file::load(&args.model).context("cannot use the model")?;
    let method: Method = args.method.parse()?;
    let resume = match &args.state {
        Some(p) if p.exists() => {
            let st = MonitorState::load(p)?;
            Monitor::resume(&model, st.clone()).with_context(|| format!("{}", p.display()))?;
            if st.method != method {
                anyhow::bail!(
                    "{}: state was written by method `{:?}`, not `{}`",
                    p.display(),
                    st.method,
                    args.method
                );
            }
            Some(st)
        }
        _ => None,
    };
    let align = AlignConfig::default().with_step(args.step)?;
    let cannot_write = |p: &std::path::Path| format!("cannot write {}", p.display());
    let rows = AtomicFile::create(&args.out).with_context(|| cannot_write(&args.out))?;
    let events = match &args.events {
        Some(p) => Some(AtomicFile::create(p).with_context(|| cannot_write(p))?),
        None => None,
    };
    let mut sink = Sink {
        model: &model,
        method,
        covered_until: resume.as_ref().map_or(f64::NAN, |s| s.last_time),
        resume,
        monitor: Monitor::new(&model, method),
        rows: Rows::File(rows),
        events,
        skip_covered: args.skip_covered,
        samples: 0,
        skipped: 0,
        events_written: 0,
    };
    let report = align_file(&args.input, &align, &mut sink)?;
    if let Some(w) = report.warning() {
        eprintln!("warning: {}: {w}", args.input.display());
    }
    if args.state.is_none() {
        for row in sink.monitor.finish() {
            sink.write(&row).with_context(|| cannot_write(&args.out))?;
        }
    }
    // Outputs first, state last: a crash in between leaves the old state, and the retry
    // recomputes exactly these outputs from it.
    let rows = sink.rows.take().with_context(|| cannot_write(&args.out))?;
    rows.commit().with_context(|| cannot_write(&args.out))?;
    fault_point("after-rows");
    if let Some(f) = sink.events.take() {
        f.commit().context("cannot write the events")?;
    }
    fault_point("after-events");
    if let Some(p) = &args.state {
        fault_point("before-state");
        sink.monitor.state().save(p)?;
    }
    let st = sink.monitor.state_ref();
    let skipped = if sink.skipped > 0 {
        format!(", {} already covered skipped", sink.skipped)
    } else {
        String::new()
    };
    eprintln!(
        "{}: {} samples{skipped}, {} trips ({} sensor-implausible), final level {}, {} events ({})",
        args.out.display(),
        sink.samples,
        st.trips,
        st.implausible_trips,
        st.level(),
        sink.events_written,
        args.method
    );
    Ok(())
}
