//! `liftwatch evaluate`: the seeded comparison suite of [`liftwatch::evaluate`] — liftwatch
//! against the fixed-threshold baseline, a CUSUM and an EWMA chart over simulated elevators
//! and degradations (paper, Sec. 5.3-5.4).
//!
//! Prints an aligned table and progress on stderr (people; `--json` puts the summary on
//! stdout), and writes `evaluation.json` (every case, every metric, the calibrations) into
//! `--out`.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use liftwatch::evaluate::{run_suite, table, SuiteConfig};

use super::simulate::DriveArg;
use super::ui::{Ui, UiArgs};

/// Flags of `liftwatch evaluate`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Output directory (created if missing) for `evaluation.json`.
    #[arg(long, default_value = "liftwatch-eval")]
    pub out: PathBuf,
    /// Run the small subset (one elevator, short spans) for tests and CI.
    #[arg(long)]
    pub quick: bool,
    /// Base seed: every simulated plant and run derives its seed from it.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Healthy training span per elevator (days; the paper's 3 hours are 0.125; one shorter
    /// than a day starts at 07:00).
    #[arg(long, default_value_t = 7.0)]
    pub train_days: f64,
    /// Monitored span of a fault case (days; onset at 40 % of it) [default: 25, quick 8].
    #[arg(long)]
    pub fault_days: Option<f64>,
    /// Monitored span of a healthy case (days) [default: 30, quick 8].
    #[arg(long)]
    pub healthy_days: Option<f64>,
    /// Days from onset to full severity of the linear and exponential faults [default: to
    /// the end of the run]; 0 makes every fault a step.
    #[arg(long)]
    pub ramp_days: Option<f64>,
    /// Multiplier of every fault's severity: 1 the maintenance-relevant default sizes (Kd
    /// +10 %, friction +25 %, brake drag 0.6·F_c), 5 the large final sizes of a field bench.
    #[arg(long, default_value_t = 1.0)]
    pub severity_scale: f64,
    /// Worker threads; the results do not depend on it.
    #[arg(long, default_value_t = 2)]
    pub threads: usize,
    /// Run only the cases whose name contains this text (repeatable, e.g. `--only "E3
    /// healthy" --only "E1 motor"`); each selected case runs exactly as in the whole suite.
    #[arg(long, value_name = "TEXT")]
    pub only: Vec<String>,
    /// Every plant's drive between trips: energised (the voltage shows U0) or off (the
    /// sensor's offset, with pre-torque while the brake lifts and drops), as most real drives.
    #[arg(long, value_enum, default_value_t = DriveArg::Energised)]
    pub drive_at_rest: DriveArg,
    /// Every plant's transmission efficiency η (0.5-1): the drive needs F/η while it drives
    /// the car and gives back F·η while the car drives it; 1 is lossless.
    #[arg(long, default_value_t = 1.0)]
    pub efficiency: f64,
    /// Seed of the network's initial weights in every training (as `fit --seed`); the
    /// plants and runs stay as they are, so the results' spread over it is the method's own.
    #[arg(long, default_value_t = 1)]
    pub net_seed: u64,
    /// Draws of the network in every training (as `fit --draws`): the better of two by
    /// default; 1 trains each from `--net-seed` alone.
    #[arg(long, default_value_t = liftwatch::model::DEFAULT_DRAWS as u64,
          value_parser = clap::value_parser!(u64).range(1..=64))]
    pub draws: u64,
    /// Keep each trained elevator's model (`E2-model.json`) and each case's aligned log as its
    /// monitors read it (`E2-motor-linear-S0.5.csv.zst`) in this directory (created if
    /// missing), to trace a case with `monitor`, `report` and `status`; meant with `--only`
    /// (a 25-day case is about 2.2 M samples).
    #[arg(long, value_name = "DIR")]
    pub keep_runs: Option<PathBuf>,
    /// Summary: --quiet, --json.
    #[command(flatten)]
    pub ui: UiArgs,
}

/// Creates the output directory `dir` (and its parents); `stdio` is the refusal of `-`.
fn directory(dir: &Path, stdio: &str) -> anyhow::Result<()> {
    anyhow::ensure!(!liftwatch::input::is_stdio(dir), "{stdio}");
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))
}

/// Runs `evaluate`.
pub fn run(args: Args) -> anyhow::Result<()> {
    anyhow::ensure!(args.threads >= 1, "--threads must be at least 1");
    directory(
        &args.out,
        "--out cannot be `-`: evaluate writes evaluation.json into a directory (--json puts the summary on stdout)",
    )?;
    let mut cfg = SuiteConfig::new(args.seed, args.quick);
    cfg.threads = args.threads;
    cfg.train_days = args.train_days;
    cfg.fault_days = args.fault_days.unwrap_or(cfg.fault_days);
    cfg.healthy_days = args.healthy_days.unwrap_or(cfg.healthy_days);
    cfg.ramp_days = args.ramp_days;
    cfg.severity_scale = args.severity_scale;
    cfg.only = args.only;
    cfg.drive_at_rest = args.drive_at_rest.plant();
    cfg.efficiency = args.efficiency;
    cfg.net_seed = args.net_seed;
    cfg.draws = args.draws as usize;
    if let Some(dir) = &args.keep_runs {
        directory(dir, "--keep-runs cannot be `-`: it names a directory")?;
    }
    cfg.keep_runs = args.keep_runs;
    let ui = Ui::new(args.ui, &[])?;
    let clock = Instant::now();
    ui.say(format_args!(
        "evaluate: {} suite, seed {}, trainings of {} days, faults over {} days ({}, severity x{}), healthy runs of {} days, drives {} at rest, transmission η {}, network seed {} ({} draw(s)), {} thread(s)",
        if args.quick { "quick" } else { "full" },
        args.seed,
        cfg.train_days,
        cfg.fault_days,
        cfg.ramp_days.map_or_else(
            || "ramps to the end".to_string(),
            |d| format!("ramps over {d} days")
        ),
        cfg.severity_scale,
        cfg.healthy_days,
        match args.drive_at_rest {
            DriveArg::Energised => "energised",
            DriveArg::Off => "off",
        },
        cfg.efficiency,
        cfg.net_seed,
        cfg.draws,
        args.threads
    ));
    let ev = run_suite(&cfg, &|line| ui.progress(format_args!("evaluate: {line}")))
        .context("evaluation")?;
    ui.progress_done();
    ui.say(table(&ev).trim_end());
    let path = args.out.join("evaluation.json");
    let json = serde_json::to_vec_pretty(&ev).context("serialising the evaluation")?;
    liftwatch::output::write_atomic(&path, &json)?;
    let figure = liftwatch_report::write_evaluation_figure(&args.out, &ev)
        .context("drawing the evaluation's figure")?;
    let seconds = clock.elapsed().as_secs_f64();
    ui.say(format_args!(
        "evaluate: {} cases in {seconds:.0} s, wrote {}{}",
        ev.cases.len(),
        path.display(),
        figure.map_or(String::new(), |[svg, _]| format!(
            " and {} (and .png): each machine fault's delay against the oracle floor and the threshold method",
            svg.display()
        ))
    ));
    ui.json(&serde_json::json!({
        "command": "evaluate",
        "out": path.display().to_string(),
        "cases": ev.cases.len(),
        "seconds": seconds,
        "aggregates": serde_json::to_value(&ev.aggregates)?,
        "delays": serde_json::to_value(ev.delays)?,
        "outages": ev
            .cases
            .iter()
            .filter_map(|c| {
                let r = c.methods.first()?.outage.as_ref()?;
                Some(serde_json::json!({
                    "case": c.case.name,
                    "reported": r.reported.is_some(),
                    "after_h": r.after_h,
                    "kind_correct": r.kind_correct,
                    "false_reports": r.false_reports,
                }))
            })
            .collect::<Vec<_>>(),
    }))
}
