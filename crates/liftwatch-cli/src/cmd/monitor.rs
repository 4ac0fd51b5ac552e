//! `liftwatch monitor`: watch telemetry with a fitted model (DATA.md §4, §6).
//!
//! Streams `--input` (raw or aligned) through alignment and the library's one streaming step
//! [`Monitor::push`], writes one row per aligned sample to `--out` and, with `--events`, one
//! JSON line per change of level. Outputs go to temporary files renamed on success, so a failed
//! run leaves no half-written file. With `--state FILE` the run resumes from the state if the
//! file exists and saves the state at the end instead of flushing the last, still-held row:
//! today's output appended to yesterday's equals one run over both inputs.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use anyhow::Context;
use liftwatch::align::{align_file, AlignConfig, SampleSink};
use liftwatch::file;
use liftwatch::fit::FittedModel;
use liftwatch::monitor::{Method, Monitor, MonitorRow, MonitorState, RowWriter};
use liftwatch::Sample;

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
}

/// A file written under a temporary name and renamed into place by [`Staged::commit`].
struct Staged {
    tmp: PathBuf,
    path: PathBuf,
}

impl Staged {
    fn new(path: &Path) -> Staged {
        let dir = path
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        let name = path
            .file_name()
            .map_or_else(|| "out".into(), |n| n.to_string_lossy().into_owned());
        Staged {
            tmp: dir.join(format!(".{name}.tmp{}", std::process::id())),
            path: path.to_path_buf(),
        }
    }

    fn create(&self) -> anyhow::Result<BufWriter<File>> {
        let f = File::create(&self.tmp)
            .with_context(|| format!("cannot write {}", self.path.display()))?;
        Ok(BufWriter::with_capacity(1 << 16, f))
    }

    fn commit(&self) -> anyhow::Result<()> {
        std::fs::rename(&self.tmp, &self.path)
            .with_context(|| format!("cannot write {}", self.path.display()))
    }
}

impl Drop for Staged {
    fn drop(&mut self) {
        // After a commit the temporary name no longer exists; after a failure it is removed.
        let _ = std::fs::remove_file(&self.tmp);
    }
}

/// The alignment sink: feeds the monitor and writes its rows and events.
struct Sink<'a> {
    model: &'a FittedModel,
    method: Method,
    resume: Option<MonitorState>,
    monitor: Monitor,
    out: &'a Staged,
    events_file: Option<&'a Staged>,
    rows: Option<RowWriter<BufWriter<File>>>,
    events: Option<BufWriter<File>>,
    samples: u64,
    events_written: u64,
}

impl Sink<'_> {
    fn write(&mut self, r: &MonitorRow) -> std::io::Result<()> {
        if let Some(w) = &mut self.rows {
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
        let file = self.out.create()?;
        self.rows =
            Some(RowWriter::new(file).map_err(|e| liftwatch::Error::io(&self.out.path, e))?);
        self.events = match self.events_file {
            Some(s) => Some(s.create()?),
            None => None,
        };
        self.samples = 0;
        self.events_written = 0;
        Ok(())
    }

    fn push(&mut self, sample: &Sample) -> anyhow::Result<()> {
        self.samples += 1;
        if self.samples % 5_000_000 == 0 {
            eprintln!(
                "monitor: {} samples, level {}",
                self.samples,
                self.monitor.state_ref().level()
            );
        }
        if let Some(row) = self.monitor.push(sample) {
            self.write(&row)
                .with_context(|| format!("cannot write {}", self.out.path.display()))?;
        }
        Ok(())
    }
}

/// Runs `monitor`: model, streamed input, rows, events, state, one summary line.
pub fn run(args: Args) -> anyhow::Result<()> {
    let model = file::load(&args.model).context("cannot use the model")?;
    model
        .risk
        .validate()
        .with_context(|| format!("{}: risk settings", args.model.display()))?;
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
    let out = Staged::new(&args.out);
    let events = args.events.as_deref().map(Staged::new);
    let mut sink = Sink {
        model: &model,
        method,
        resume,
        monitor: Monitor::new(&model, method),
        out: &out,
        events_file: events.as_ref(),
        rows: None,
        events: None,
        samples: 0,
        events_written: 0,
    };
    let report = align_file(&args.input, &align, &mut sink)?;
    if let Some(w) = report.warning() {
        eprintln!("warning: {}: {w}", args.input.display());
    }
    match &args.state {
        Some(p) => sink.monitor.state().save(p)?,
        None => {
            for row in sink.monitor.finish() {
                sink.write(&row)
                    .with_context(|| format!("cannot write {}", args.out.display()))?;
            }
        }
    }
    if let Some(w) = sink.rows.take() {
        w.into_inner()
            .with_context(|| format!("cannot write {}", args.out.display()))?;
    }
    if let Some(mut f) = sink.events.take() {
        f.flush()
            .with_context(|| format!("cannot write events for {}", args.out.display()))?;
    }
    out.commit()?;
    if let Some(e) = &events {
        e.commit()?;
    }
    let st = sink.monitor.state_ref();
    eprintln!(
        "{}: {} samples, {} trips ({} sensor-implausible), final level {}, {} events ({})",
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
