//! `liftwatch demo`: the whole method on built-in defaults, from raw telemetry to a report.
//!
//! One simulated elevator (the paper's: 1000 kg, 1.75 m/s, 26 floors) is watched twice: a
//! healthy week to learn it, then a longer period in which one fault mode develops. Both runs
//! go through the same path a real log takes: raw `time,signal,value` telemetry on disk →
//! alignment → features → fit or monitor. liftwatch and the fixed-threshold baseline watch
//! the degradation; the report shows both.

use liftwatch::sample::DAY_S;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use liftwatch::alarm::Level;
use liftwatch::align::{read_series, AlignConfig};
use liftwatch::mode::FaultMode;
use liftwatch::model::TrainConfig;
use liftwatch::monitor::Analysis;
use liftwatch::monitor::MonitorRow;
use liftwatch::rng::Rng;
use liftwatch::sim::plant::SimElevator;
use liftwatch::sim::{write_dir, SimConfig, SimTruth};
use liftwatch::Elevator;
use liftwatch::{file, fit};
use liftwatch_report::{write_report, ReportInputs};

/// Start of the watched run on a Unix clock, so that the report and the verdict show dates:
/// 2026-02-26 00:00 UTC, day 20510 since the epoch, a multiple of 7 days, which the
/// simulator's week (its day 0 is a Monday) takes for a Monday. (The Unix epoch was a
/// Thursday, so the simulated weekends fall on calendar Tuesdays and Wednesdays.)
const WATCH_START_S: f64 = 20_510.0 * DAY_S;

/// Flags of `liftwatch demo`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Where to write everything.
    #[arg(long, default_value = "liftwatch-demo")]
    pub out: PathBuf,
    /// The fault that develops: motor (default), friction or brake.
    #[arg(long, value_enum, default_value_t = DemoFault::Motor)]
    pub scenario: DemoFault,
    /// Days watched after training; the fault starts at 40 % of them and ramps linearly.
    #[arg(long, default_value_t = 20.0)]
    pub days: f64,
    /// Healthy days to learn from (a week covers the daily thermal cycle and a weekend).
    #[arg(long, default_value_t = 7.0)]
    pub train_days: f64,
    /// Seed of the elevator, its traffic and its sensors.
    #[arg(long, default_value_t = 42)]
    pub seed: u64,
    /// Keep the raw and aligned CSV files of both runs (about 20 MB per simulated day).
    #[arg(long)]
    pub keep_raw: bool,
}

/// The fault modes the demo can show.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum DemoFault {
    /// Guide-rail lubrication: Coulomb and viscous friction +25 %.
    Friction,
    /// Drive: Kd +10 %.
    Motor,
    /// Brake drag in downward and decelerating travel.
    Brake,
}

impl DemoFault {
    fn mode(self) -> FaultMode {
        match self {
            DemoFault::Friction => FaultMode::Friction,
            DemoFault::Motor => FaultMode::Motor,
            DemoFault::Brake => FaultMode::Brake,
        }
    }
}

/// Runs `demo`.
pub fn run(args: Args) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.days.is_finite() && (2.0..=400.0).contains(&args.days),
        "--days must be between 2 and 400"
    );
    anyhow::ensure!(
        args.train_days.is_finite() && (0.5..=60.0).contains(&args.train_days),
        "--train-days must be between 0.5 and 60"
    );
    let started = Instant::now();
    let out = &args.out;
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let elevator = Elevator::new(1000.0, 1.75, 26);
    // One hidden plant for both runs, as one real elevator is learnt and then watched.
    let plant = SimElevator::from_elevator(&elevator, &mut Rng::new(args.seed));

    step(
        started,
        &format!(
            "simulating {} healthy days of telemetry to learn from",
            args.train_days
        ),
    );
    let train_dir = out.join("training");
    let mut train_cfg = SimConfig::new(elevator.clone(), args.train_days, args.seed ^ 0x7261_696E);
    train_cfg.plant = Some(plant.clone());
    write_dir(&train_cfg, &train_dir, &mut |_| {})?;

    step(
        started,
        "fitting the hybrid model on the raw log (raw → aligned → features → physics + network)",
    );
    let (series, report) = read_series(&train_dir.join("raw.csv"), &AlignConfig::default())?;
    if let Some(w) = report.warning() {
        eprintln!("warning: {w}");
    }
    let outcome = fit::fit(
        &series,
        &elevator,
        // The default logs a history point every 100 iterations: the report's training and
        // parameter figures are drawn from them (no progress is printed: the observer is silent).
        &TrainConfig::default(),
        &mut |_| {},
    )
    .context("fitting the training days")?;
    let model_path = out.join("model.json");
    file::save(&model_path, &outcome.model)?;
    let fitted = started.elapsed().as_secs_f64();

    step(
        started,
        &format!(
            "simulating {} days in which the {} degrades",
            args.days,
            args.scenario.mode().as_str()
        ),
    );
    let run_dir = out.join("degraded");
    let mut run_cfg = SimConfig::new(elevator.clone(), args.days, args.seed ^ 0x7761_7463);
    run_cfg.start_s = WATCH_START_S;
    let run_cfg = SimConfig {
        plant: Some(plant),
        ..run_cfg.with_mode(args.scenario.mode())
    };
    // Progress by the command line's one rule (`ui`): refreshed on a terminal, and nothing
    // in a log file, where each day's `\r` line once piled up on one line.
    let ui = super::ui::Ui::new(super::ui::UiArgs::default(), &[])?;
    let truth = write_dir(&run_cfg, &run_dir, &mut |d| {
        ui.progress(format_args!("  day {d:.0} of {}", args.days));
    })?;
    ui.progress_done();

    step(
        started,
        "watching it with liftwatch and with the fixed-threshold baseline",
    );
    let (watched, report) = read_series(&run_dir.join("raw.csv"), &AlignConfig::default())?;
    if let Some(w) = report.warning() {
        eprintln!("warning: {w}");
    }
    let m = &outcome.model;
    let analysis = Analysis::run(m, &watched);
    write_events(&out.join("events.jsonl"), &analysis.events)?;

    step(started, "writing the report");
    let report_dir = out.join("report");
    let written = write_report(
        &report_dir,
        &ReportInputs::new(&analysis, m, &watched, "demo: degraded run"),
    )
    .context("writing the report")?;
    let index = written
        .last()
        .cloned()
        .unwrap_or_else(|| report_dir.join("index.html"));
    if !args.keep_raw {
        for dir in [&train_dir, &run_dir] {
            for f in ["raw.csv", "aligned.csv"] {
                let _ = std::fs::remove_file(dir.join(f));
            }
        }
    }

    eprintln!();
    eprintln!("{}", super::fit::summary(m, outcome.trips.len(), fitted));
    eprintln!();
    eprint!(
        "{}",
        outcome_summary(&truth, &analysis.pinn, &analysis.threshold)
    );
    eprintln!("\nreport: {}", index.display());
    eprintln!(
        "model: {}   events: {}",
        model_path.display(),
        out.join("events.jsonl").display()
    );
    eprintln!("done in {:.0} s", started.elapsed().as_secs_f64());
    Ok(())
}

fn step(started: Instant, what: &str) {
    eprintln!("[{:>5.1} s] {what}", started.elapsed().as_secs_f64());
}

fn write_events(path: &Path, events: &[liftwatch::alarm::Event]) -> anyhow::Result<()> {
    let mut text = String::new();
    for e in events {
        text.push_str(&serde_json::to_string(e)?);
        text.push('\n');
    }
    liftwatch::output::write_atomic(path, text.as_bytes())?;
    Ok(())
}

/// What happened, in days from the start of the watched run, with the true severity then.
fn outcome_summary(truth: &SimTruth, pinn: &[MonitorRow], threshold: &[MonitorRow]) -> String {
    use std::fmt::Write;
    let sc = &truth.scenario;
    let day = |t: f64| (t - truth.start_s) / DAY_S;
    let sev = |t: f64| 100.0 * sc.severity_at(t);
    let mut s = String::new();
    let onset = sc.onset_s;
    let _ = writeln!(
        s,
        "fault: {} from day {:.1}, linear to full severity at day {:.1}",
        liftwatch::sim::truth_name(sc.mode),
        day(onset),
        day(sc.full_at_s)
    );
    let first =
        |rows: &[MonitorRow], level: Level| rows.iter().find(|r| r.level >= level).map(|r| r.time);
    match pinn.iter().find_map(|r| {
        r.event
            .as_deref()
            .copied()
            .filter(|e| e.level >= Level::Advisory)
    }) {
        Some(e) => {
            let _ = writeln!(
                s,
                "liftwatch: {} on day {:.1} ({:.1} days after onset, at {:.0} % of full severity), mode {}",
                e.level.as_str(),
                day(e.time),
                day(e.time) - day(onset),
                sev(e.time),
                e.mode.as_str()
            );
            if let Some(t) = first(pinn, Level::Alarm) {
                let _ = writeln!(
                    s,
                    "liftwatch: alarm on day {:.1} ({:.0} % of full severity)",
                    day(t),
                    sev(t)
                );
            }
        }
        None => {
            let _ = writeln!(s, "liftwatch: no advisory");
        }
    }
    let activations = threshold
        .windows(2)
        .filter(|w| w[0].level < Level::Alarm && w[1].level >= Level::Alarm)
        .count();
    match first(threshold, Level::Alarm) {
        Some(t) => {
            let _ = writeln!(
                s,
                "threshold baseline: first alarm on day {:.1} ({:.0} % of full severity); {activations} separate alarm activations in all",
                day(t),
                sev(t)
            );
        }
        None => {
            let _ = writeln!(s, "threshold baseline: no alarm");
        }
    }
    s
}
