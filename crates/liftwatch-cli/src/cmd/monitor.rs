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
//!
//! Scripts: `--input -` reads standard input and `--out -` writes the rows to standard output
//! (in place, so a failure there leaves the rows already written); `.gz` names are gzip.
//! `--fail-on LEVEL` turns the highest level of the run into the exit status ([`Status`]).

use std::io::Write;
use std::path::PathBuf;

use anyhow::Context;
use liftwatch::alarm::Level;
use liftwatch::align::{align_file_pipelined, AlignConfig, SampleSink};
use liftwatch::file;
use liftwatch::fit::FittedModel;
use liftwatch::monitor::{
    Method, Monitor, MonitorRow, MonitorState, RowWriter, TimeFormat, TripRowWriter,
};
use liftwatch::output::{check_file_args, AtomicFile, FileArg};
use liftwatch::Sample;

use super::step::{check_input_step, model_step};
use super::ui::{ingest_json, named, warn, Ui, UiArgs};
use crate::Status;

/// Environment variable of the crash tests: `after-rows`, `after-events` or `before-state`
/// makes the process abort at that commit instant, as a power cut would.
pub const FAULT_ENV: &str = "LIFTWATCH_FAULT";

/// Samples between two progress lines on a terminal: about two months of one elevator at 1 s.
const PROGRESS_EVERY: u64 = 5_000_000;

/// Flags of `liftwatch monitor`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Model file written by `fit`.
    #[arg(long)]
    pub model: PathBuf,
    /// Telemetry to watch, raw `time,signal,value` or aligned (`-`: stdin, `.gz`: gzip).
    #[arg(long)]
    pub input: PathBuf,
    /// Output CSV: one row per aligned sample, or per trip with `--rows trip` (`-`: stdout,
    /// `.gz`: gzip).
    #[arg(long)]
    pub out: PathBuf,
    /// Events file: one JSON line per change of level (`-`: stdout, `.gz`: gzip).
    #[arg(long)]
    pub events: Option<PathBuf>,
    /// Method: pinn (risk from the dual residuals) or threshold (the conventional baseline).
    #[arg(long, value_enum, default_value_t = MethodArg::Pinn)]
    pub method: MethodArg,
    /// State file: resumed from when it exists, written at the end (the last row stays held).
    #[arg(long)]
    pub state: Option<PathBuf>,
    /// Alignment step (s); default the model's, and another one is refused.
    #[arg(long)]
    pub step: Option<f64>,
    /// Skip input samples the state already covers instead of refusing the input.
    #[arg(long = "skip-covered")]
    pub skip_covered: bool,
    /// One output row per aligned sample (second) or per finished trip (trip).
    #[arg(long, value_enum, default_value_t = RowsArg::Second)]
    pub rows: RowsArg,
    /// Time columns as epoch seconds, or RFC 3339 at the elevator's `timezone` (events then
    /// carry `time_rfc3339` beside `time`).
    #[arg(long = "time-format", value_enum, default_value_t = TimeFormatArg::Epoch)]
    pub time_format: TimeFormatArg,
    /// Exit with status 3 when the run reached advisory, 4 when it reached alarm, if that is
    /// at least LEVEL (the highest level of the run, the resumed one included).
    #[arg(long = "fail-on", value_enum)]
    pub fail_on: Option<FailOn>,
    /// Summary: --quiet, --json.
    #[command(flatten)]
    pub ui: UiArgs,
}

/// `--method`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum MethodArg {
    /// Dual residuals, time-accumulated risk per fault mode (the paper's method).
    Pinn,
    /// Fixed thresholds on instantaneous signals (the conventional baseline).
    Threshold,
}

impl MethodArg {
    fn method(self) -> Method {
        match self {
            MethodArg::Pinn => Method::Pinn,
            MethodArg::Threshold => Method::Threshold,
        }
    }

    fn name(self) -> &'static str {
        self.method().name()
    }
}

/// `--rows`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum RowsArg {
    /// One row per aligned sample (DATA.md §4).
    Second,
    /// One row per finished trip: times, direction, floors, load, mean residuals, risks, level.
    Trip,
}

/// `--time-format`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum TimeFormatArg {
    /// Seconds as numbers, as in the aligned series.
    Epoch,
    /// RFC 3339 instants at the elevator's `timezone` (UTC without one).
    Rfc3339,
}

/// `--fail-on`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum FailOn {
    /// Fail when the run reached advisory or alarm.
    Advisory,
    /// Fail only when the run reached alarm.
    Alarm,
}

impl FailOn {
    /// The exit status for the highest level of a run.
    fn status(self, highest: Level) -> Status {
        let floor = match self {
            FailOn::Advisory => Level::Advisory,
            FailOn::Alarm => Level::Alarm,
        };
        match highest {
            l if l < floor => Status::Ok,
            Level::Alarm => Status::Alarm,
            _ => Status::Advisory,
        }
    }
}

/// A resumed run's first sample further than this many steps after the last one the state
/// covers leaves samples out between them (the next step is the one expected; a sample held
/// back for the central difference is not a gap).
const RESUME_GAP_STEPS: f64 = 1.5;

/// The alignment sink: feeds the monitor and writes its rows and events.
struct Sink<'a> {
    model: &'a FittedModel,
    method: Method,
    resume: Option<MonitorState>,
    monitor: Monitor,
    /// Rows: the writer over the output file, or the file alone before the first start.
    rows: Rows,
    /// One row per sample or per trip.
    per_trip: bool,
    time: TimeFormat,
    events: Option<AtomicFile>,
    /// What every event line gets appended: the elevator's name and id, when given.
    event_extra: String,
    /// Samples at or before this time were watched by an earlier run (NaN: none).
    covered_until: f64,
    /// The aligned step (s), the model's.
    step: f64,
    skip_covered: bool,
    samples: u64,
    skipped: u64,
    /// The rows' and the events' files as messages name them.
    names: (String, String),
    /// Event lines written to `--events` (0 without it).
    events_written: u64,
    /// Events the run raised, written or not: what the summary line counts.
    events_raised: u64,
    /// The highest level of the run, the resumed level included.
    highest: Level,
    ui: Ui,
}

/// The rows output: a file not yet started, or its CSV writer. One per run, so the writers'
/// size (each keeps its columns' last texts, up to a KB) costs nothing worth a box.
#[allow(clippy::large_enum_variant)]
enum Rows {
    File(AtomicFile),
    Second(RowWriter<AtomicFile>),
    Trip(TripRowWriter<AtomicFile>),
    Gone,
}

impl Rows {
    /// The file back, flushed.
    fn take(&mut self) -> std::io::Result<AtomicFile> {
        match std::mem::replace(self, Rows::Gone) {
            Rows::File(f) => Ok(f),
            Rows::Second(w) => w.into_inner(),
            Rows::Trip(w) => w.into_inner(),
            Rows::Gone => Err(std::io::Error::other("not written after an earlier error")),
        }
    }
}

impl Sink<'_> {
    /// Writes the row and its events; an error names the file it could not write.
    fn write(&mut self, r: &MonitorRow) -> anyhow::Result<()> {
        match &mut self.rows {
            Rows::Second(w) => w.write(r),
            Rows::Trip(w) => w.write(r),
            Rows::File(_) | Rows::Gone => Ok(()),
        }
        .with_context(|| format!("cannot write {}", self.names.0))?;
        self.highest = self.highest.max(r.level);
        if let Some(e) = &r.event {
            let line = self.monitor.event_line(e);
            self.write_event(&line, e.time)
                .with_context(|| format!("cannot write {}", self.names.1))?;
        }
        if let Some(e) = &r.operation {
            let line = self.monitor.operation_event_line(e);
            self.write_event(&line, e.time())
                .with_context(|| format!("cannot write {}", self.names.1))?;
        }
        Ok(())
    }

    /// One event line with the elevator's name and id (and the time in RFC 3339 under
    /// `--time-format rfc3339`) appended.
    fn write_event(&mut self, line: &str, time: f64) -> std::io::Result<()> {
        self.events_raised += 1;
        let Some(f) = &mut self.events else {
            return Ok(());
        };
        let mut extra = self.event_extra.clone();
        if let TimeFormat::Rfc3339 { offset_s } = self.time {
            let at = liftwatch::ingest::time::format_rfc3339(time, offset_s);
            extra.push_str(&format!(r#","time_rfc3339":"{at}""#));
        }
        match line.strip_suffix('}') {
            Some(body) if !extra.is_empty() => writeln!(f, "{body}{extra}}}")?,
            _ => writeln!(f, "{line}")?,
        }
        self.events_written += 1;
        Ok(())
    }
}

/// The fields every event line gets appended (`,"elevator":"Lift A","elevator_id":"B-7"`),
/// empty when the elevator description has neither.
fn event_extra(model: &FittedModel) -> String {
    let e = &model.hybrid.elevator;
    let mut s = String::new();
    for (key, value) in [("elevator", &e.name), ("elevator_id", &e.id)] {
        if let Some(v) = value {
            let quoted = serde_json::to_string(v).expect("a string always serialises");
            s.push_str(&format!(r#","{key}":{quoted}"#));
        }
    }
    s
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
        let restart = matches!(self.rows, Rows::Second(_) | Rows::Trip(_));
        let mut file = self.rows.take().context("cannot write the rows")?;
        if restart {
            file.restart()?;
            if let Some(e) = &mut self.events {
                e.restart()?;
            }
        }
        let path = file.path().display().to_string();
        let cannot = || format!("cannot write {path}");
        self.rows = if self.per_trip {
            Rows::Trip(TripRowWriter::new(file, self.time).with_context(cannot)?)
        } else {
            Rows::Second(RowWriter::with_time(file, self.time).with_context(cannot)?)
        };
        self.samples = 0;
        self.skipped = 0;
        self.events_written = 0;
        self.events_raised = 0;
        self.highest = self.monitor.state_ref().level();
        Ok(())
    }

    fn push(&mut self, sample: &Sample) -> anyhow::Result<()> {
        if sample.time <= self.covered_until {
            if !self.skip_covered {
                anyhow::bail!(
                    "the input has a sample at t = {} s, at or before t = {} s, the last the state covers: it was watched already (pass --skip-covered to skip what the state covers)",
                    liftwatch::error::number(sample.time),
                    liftwatch::error::number(self.covered_until)
                );
            }
            self.skipped += 1;
            return Ok(());
        }
        self.samples += 1;
        if self.samples == 1 && sample.time - self.covered_until > RESUME_GAP_STEPS * self.step {
            // The samples between the state's last and this one are lost: each side of the
            // boundary was aligned without the other's readings.
            eprintln!(
                "warning: the input resumes {} s after the last sample the state covers, so the samples between are missing: for a raw log, feed the previous log's last minute again with --skip-covered (a single run and the two then give the same rows)",
                liftwatch::error::number(sample.time - self.covered_until)
            );
        }
        if self.samples % PROGRESS_EVERY == 0 {
            self.ui.progress(format_args!(
                "monitor: {} samples, level {}",
                self.samples,
                self.monitor.state_ref().level()
            ));
        }
        let mut row = MonitorRow::EMPTY;
        if self.monitor.push_into(sample, &mut row) {
            self.write(&row)?;
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

/// The saved state to resume from, checked against the model and the method.
fn resume_state(
    args: &Args,
    model: &FittedModel,
    method: Method,
) -> anyhow::Result<Option<MonitorState>> {
    let Some(p) = args.state.as_ref().filter(|p| p.exists()) else {
        return Ok(None);
    };
    let st = MonitorState::load(p)?;
    Monitor::resume(model, st.clone()).with_context(|| format!("{}", p.display()))?;
    if st.method != method {
        anyhow::bail!(
            "{}: state was written by method `{}`, not `{}`",
            p.display(),
            st.method.name(),
            args.method.name()
        );
    }
    Ok(Some(st))
}

/// Runs `monitor`: model, streamed input, rows, events, state, one summary line; the exit
/// status under `--fail-on`.
pub fn run(args: Args) -> anyhow::Result<Status> {
    let mut files = vec![
        FileArg::input("--model", &args.model),
        FileArg::input("--input", &args.input),
        FileArg::output("--out", &args.out),
    ];
    let mut outputs = vec![("--out", args.out.as_path())];
    if let Some(p) = &args.events {
        files.push(FileArg::output("--events", p));
        outputs.push(("--events", p));
    }
    if let Some(p) = &args.state {
        files.push(FileArg::output("--state", p));
        anyhow::ensure!(
            !liftwatch::input::is_stdio(p),
            "--state cannot be `-`: it is read and written back"
        );
    }
    let ui = Ui::new(args.ui, &outputs)?;
    check_file_args(&files).map_err(anyhow::Error::msg)?;
    let model = file::load(&args.model).context("cannot use the model")?;
    let (step, note) = model_step(&model, args.step)?;
    if let Some(n) = note {
        eprintln!("{n}"); // about the numbers themselves: shown even with --quiet or --json
    }
    let method = args.method.method();
    let resume = resume_state(&args, &model, method)?;
    let time = match args.time_format {
        TimeFormatArg::Epoch => TimeFormat::Epoch,
        TimeFormatArg::Rfc3339 => TimeFormat::Rfc3339 {
            offset_s: model
                .hybrid
                .elevator
                .utc_offset_s()
                .map_err(anyhow::Error::msg)?,
        },
    };
    let align = AlignConfig::default().with_step(step)?;
    let cannot_write = |p: &std::path::Path| format!("cannot write {}", named(p, true));
    let rows = AtomicFile::create_data(&args.out).with_context(|| cannot_write(&args.out))?;
    let events = match &args.events {
        Some(p) => Some(AtomicFile::create_data(p).with_context(|| cannot_write(p))?),
        None => None,
    };
    let mut sink = Sink {
        model: &model,
        method,
        covered_until: resume.as_ref().map_or(f64::NAN, |s| s.last_time),
        step,
        resume,
        monitor: Monitor::new(&model, method),
        rows: Rows::File(rows),
        per_trip: args.rows == RowsArg::Trip,
        time,
        events,
        event_extra: event_extra(&model),
        skip_covered: args.skip_covered,
        samples: 0,
        skipped: 0,
        names: (
            named(&args.out, true),
            args.events
                .as_deref()
                .map_or_else(String::new, |p| named(p, true)),
        ),
        events_written: 0,
        events_raised: 0,
        highest: Level::Normal,
        ui,
    };
    let report = align_file_pipelined(&args.input, &align, &mut sink)?;
    ui.progress_done();
    check_input_step(step, &report, &named(&args.input, false))?;
    if let Some(w) = report.warning() {
        warn(&args.input, &w);
    }
    if args.state.is_none() {
        for row in sink.monitor.finish() {
            sink.write(&row)?;
        }
    }
    commit(&args, &mut sink)?;
    let status = args.fail_on.map_or(Status::Ok, |f| f.status(sink.highest));
    summarise(&args, &sink, &report, step, status)?;
    Ok(status)
}

/// Outputs first, state last: a crash in between leaves the old state, and the retry
/// recomputes exactly these outputs from it.
fn commit(args: &Args, sink: &mut Sink) -> anyhow::Result<()> {
    let out = named(&args.out, true);
    let rows = sink
        .rows
        .take()
        .with_context(|| format!("cannot write {out}"))?;
    rows.commit()
        .with_context(|| format!("cannot write {out}"))?;
    fault_point("after-rows");
    if let Some(f) = sink.events.take() {
        f.commit()
            .with_context(|| format!("cannot write {}", sink.names.1))?;
    }
    fault_point("after-events");
    if let Some(p) = &args.state {
        fault_point("before-state");
        sink.monitor.state().save(p)?;
    }
    Ok(())
}

/// The summary line on stderr, or the `--json` object on stdout.
fn summarise(
    args: &Args,
    sink: &Sink,
    report: &liftwatch::ingest::IngestReport,
    step: f64,
    status: Status,
) -> anyhow::Result<()> {
    let st = sink.monitor.state_ref();
    let out = named(&args.out, true);
    let skipped = if sink.skipped > 0 {
        format!(", {} already covered skipped", sink.skipped)
    } else {
        String::new()
    };
    sink.ui.say(format_args!(
        "{out}: {} samples{skipped}, {} trips ({} sensor-implausible), final level {}, highest {}, {} events ({})",
        sink.samples,
        st.trips,
        st.implausible_trips,
        st.level(),
        sink.highest,
        sink.events_raised,
        args.method.name()
    ));
    let e = &sink.model.hybrid.elevator;
    sink.ui.json(&serde_json::json!({
        "command": "monitor",
        "out": out,
        "events": args.events.as_deref().map(|p| named(p, true)),
        "rows": if sink.per_trip { "trip" } else { "second" },
        "method": args.method.name(),
        "elevator": {"name": e.name, "id": e.id, "timezone": e.timezone},
        "step_s": step,
        "input": ingest_json(&args.input, report),
        "samples": sink.samples,
        "skipped": sink.skipped,
        "trips": st.trips,
        "implausible_trips": st.implausible_trips,
        "final_level": st.level().as_str(),
        "highest_level": sink.highest.as_str(),
        "events_written": sink.events_written,
        "events_raised": sink.events_raised,
        "exit_status": status.code(),
    }))
}
