//! `liftwatch fit`: healthy telemetry → features → hybrid model → calibrated risk → model file.

use liftwatch::sample::HOUR_S;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use liftwatch::align::AlignConfig;
use liftwatch::calibrate::CalibrationSettings;
use liftwatch::model::train::{Optimizer, TrainPoint};
use liftwatch::model::TrainConfig;
use liftwatch::Elevator;
use liftwatch::{file, fit};

use super::spill;
use super::step::{differs, input_step, DEFAULT_STEP_S};
use super::ui::{finite, ingest_json, named, warn, Ui, UiArgs};

/// Flags of `liftwatch fit`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Healthy telemetry, raw or aligned (`-`: stdin, `.gz`: gzip).
    #[arg(long)]
    pub input: PathBuf,
    /// Elevator description (TOML).
    #[arg(long)]
    pub elevator: PathBuf,
    /// Where to write the model (JSON; `-`: stdout).
    #[arg(long)]
    pub out: PathBuf,
    /// Optimiser of the hybrid stage: lbfgs (default) or adam (the paper's schedule).
    #[arg(long, value_enum, default_value_t = OptimizerArg::Lbfgs)]
    pub optimizer: OptimizerArg,
    /// Iterations of the hybrid stage (L-BFGS iterations or Adam epochs; default 1500 or 20000).
    #[arg(long)]
    pub epochs: Option<usize>,
    /// Adam's learning rate.
    #[arg(long, default_value_t = 1e-3)]
    pub learning_rate: f64,
    /// Seed of the network's initial weights (of the first draw).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Draws of the network's initial weights the L-BFGS stage runs from, each on a thread of
    /// its own; the one that ends at the lowest loss is kept (1: `--seed` alone).
    #[arg(long, default_value_t = liftwatch::model::DEFAULT_DRAWS as u64,
          value_parser = clap::value_parser!(u64).range(1..=64))]
    pub draws: u64,
    /// Step (s) the model is fitted at: raw input is aligned at it (1 s when left out);
    /// aligned input is read at its own step unless this asks for another.
    #[arg(long)]
    pub step: Option<f64>,
    /// The alarm budget: false advisories per elevator-year the calibration aims at (stored
    /// in the model).
    #[arg(long = "false-advisories-per-year", default_value_t = 1.0)]
    pub false_advisories_per_year: f64,
    /// Summary: --quiet, --json.
    #[command(flatten)]
    pub ui: UiArgs,
}

/// The optimiser choice on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum OptimizerArg {
    /// Gauss-Newton on the physics, then L-BFGS on the network with the physics held.
    Lbfgs,
    /// Adam on everything from the prior, full batch (the paper).
    Adam,
}

/// What a fit that fails or ends in an impossible model most often means.
const UNITS_HINT: &str = "check that each channel is in DATA.md's units (speed m/s, voltage V, load % of the rated load) and not empty";

/// Runs `fit`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let ui = Ui::new(args.ui, &[("--out", &args.out)])?;
    liftwatch::output::check_file_args(&[
        liftwatch::output::FileArg::input("--input", &args.input),
        liftwatch::output::FileArg::input("--elevator", &args.elevator),
        liftwatch::output::FileArg::output("--out", &args.out),
    ])
    .map_err(anyhow::Error::msg)?;
    let calibration = CalibrationSettings::for_target(args.false_advisories_per_year);
    calibration
        .validate()
        .context("--false-advisories-per-year")?;
    let elevator = Elevator::from_toml_file(&args.elevator)?;
    let align = AlignConfig::default().with_step(args.step.unwrap_or(DEFAULT_STEP_S))?;
    let spill_dir = spill::beside_file(&args.out);
    let (mut series, mut report) = spill::read("fit", &args.input, &align, &spill_dir, &ui)?;
    if let Some(found) = input_step(&report).filter(|&f| differs(f, align.step_s)) {
        if args.step.is_none() {
            // Aligned input keeps its step: re-stepped by interpolation it would be fitted at
            // a step the data do not have, and the model would record that step.
            let align = AlignConfig::default().with_step(found)?;
            (series, report) = spill::read("fit", &args.input, &align, &spill_dir, &ui)?;
        } else {
            warn(
                &args.input,
                &format!(
                    "aligned at a step of {found} s, re-stepped to --step {} s by interpolation",
                    align.step_s
                ),
            );
        }
    }
    if let Some(w) = report.warning() {
        warn(&args.input, &w);
    }
    let cfg = train_config(&args);
    let input = named(&args.input, false);
    ui.say(format_args!(
        "fit: {} samples ({:.1} h) from {input}",
        series.len(),
        series.duration_s() / HOUR_S,
    ));
    let started = Instant::now();
    let mut progress = |p: &TrainPoint| {
        ui.progress(format_args!(
            "  stage {} iteration {:>5}  loss {:.4e}  rms r_U {:.2} V  rms r_F {:.0} N",
            p.stage, p.iteration, p.loss, p.rms_u_v, p.rms_f_n
        ));
    };
    let outcome = fit::fit_with(&series, &elevator, &cfg, &calibration, &mut progress)
        .with_context(|| format!("fitting {input} ({UNITS_HINT})"))?;
    ui.progress_done();
    let seconds = started.elapsed().as_secs_f64();
    file::save(&args.out, &outcome.model).map_err(|e| match e {
        // The checks every model is saved through: a fit that ends outside them was fed
        // something other than an elevator's channels in their units.
        liftwatch::Error::BadDocument { why, .. } => anyhow::anyhow!(
            "fitting {input} gave no model a monitor could use ({why}): {UNITS_HINT}"
        ),
        e => e.into(),
    })?;
    let out = named(&args.out, true);
    ui.say(summary(&outcome.model, outcome.trips.len(), seconds));
    ui.say(format_args!("wrote {out}"));
    ui.json(&json_summary(&outcome, &args, &report, seconds))
}

/// The training settings from the flags.
fn train_config(args: &Args) -> TrainConfig {
    let (optimizer, epochs) = match args.optimizer {
        OptimizerArg::Lbfgs => (
            Optimizer::Lbfgs,
            args.epochs.unwrap_or(TrainConfig::default().epochs),
        ),
        OptimizerArg::Adam => (Optimizer::Adam, args.epochs.unwrap_or(20_000)),
    };
    TrainConfig {
        optimizer,
        epochs,
        learning_rate: args.learning_rate,
        seed: args.seed,
        draws: args.draws as usize,
        log_every: if optimizer == Optimizer::Adam {
            1000
        } else {
            50
        },
        ..TrainConfig::default()
    }
}

/// The `--json` object of a fit.
fn json_summary(
    outcome: &fit::FitOutcome,
    args: &Args,
    report: &liftwatch::ingest::IngestReport,
    seconds: f64,
) -> serde_json::Value {
    let m = &outcome.model;
    let f = &m.summary;
    let parameters: serde_json::Map<String, serde_json::Value> = f
        .parameters
        .iter()
        .map(|r| {
            let v = serde_json::json!({
                "value": finite(r.value),
                "std_error": r.std_error.and_then(finite),
                "quarters_se": r.quarters_se.and_then(finite),
                "unit": r.unit,
                "decided_by": r.decided_by().code(),
                "corrected": r.corrected.and_then(finite),
            });
            (r.name.to_string(), v)
        })
        .collect();
    let e = &m.hybrid.elevator;
    serde_json::json!({
        "command": "fit",
        "out": named(&args.out, true),
        "elevator": {"name": e.name, "id": e.id, "timezone": e.timezone},
        "input": ingest_json(&args.input, report),
        "step_s": m.step_s,
        "seconds": seconds,
        "moving_samples": f.moving_samples,
        "standstill_samples": f.standstill_samples,
        "speed_noise_mps": f.speed_noise_mps,
        "trips": outcome.trips.len(),
        "rms_r_voltage_v": finite(f.rms_u_v),
        "rms_r_force_n": finite(f.rms_f_n),
        "iterations": f.iterations,
        "stage2_stop": f.stage2_stop.map(|st| serde_json::json!({
            "reason": st.reason,
            "recent_gain": finite(st.recent_gain),
            "converged": st.reason.converged(),
        })),
        "draws": f.draws,
        "parameters": parameters,
        "sigma_u_v": m.hybrid.scales.sigma_u_v,
        "sigma_f_n": m.hybrid.scales.sigma_f_n,
        "advisory": m.risk.advisory,
        "alarm": m.risk.alarm,
        "calibration": m.calibration,
        "notes": f.warnings,
    })
}

/// The on-screen summary of a fit: parameters with standard errors, warnings, calibration.
pub fn summary(m: &fit::FittedModel, trips: usize, seconds: f64) -> String {
    use std::fmt::Write;
    let f = &m.summary;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "fitted in {seconds:.2} s: {} moving samples in {trips} trips, {}; rms r_U {:.2} V, rms r_F {:.0} N",
        f.moving_samples,
        // None are taken only from a drive off between trips (train::observations_of).
        if f.standstill_samples == 0 {
            "no standstill sample (the drive is off between trips)".to_string()
        } else {
            format!("{} at standstill", f.standstill_samples)
        },
        f.rms_u_v,
        f.rms_f_n
    );
    let _ = writeln!(
        s,
        "{:<27} {:>12} {:>11} {:>11} {:>12}  {:<6} decided by",
        "parameter", "value", "std error", "quarters", "corrected", "unit"
    );
    // Five decimals; a value that rounds to zero is written 0.00000, not -0.00000 (a held ε
    // of −3·10⁻¹⁶).
    let five = |v: f64| format!("{:.5}", if v.abs() < 5e-6 { 0.0 } else { v });
    let cell = |v: Option<f64>, none: &str| v.map_or_else(|| none.to_string(), five);
    for r in &f.parameters {
        let (se, quarters, corrected) = (
            cell(r.std_error, "n/a"),
            cell(r.quarters_se, "-"),
            cell(r.corrected, "-"),
        );
        let _ = writeln!(
            s,
            "{:<27} {:>12} {:>11} {:>11} {:>12}  {:<6} {}",
            r.name,
            five(r.value),
            se,
            quarters,
            corrected,
            r.unit,
            r.decided_by().words()
        );
    }
    if f.parameters.iter().any(|r| r.quarters_se.is_some()) {
        let _ = writeln!(
            s,
            "quarters: the standard error from the spread of the values fitted on each quarter of the training alone; where it is the wider, the values moved through the training more than its noise explains (winding temperature, traffic, sensor clocks sliding in phase), and it is the honest error"
        );
    }
    if f.speed_noise_mps > 0.0 {
        let _ = writeln!(
            s,
            "corrected: the values with the speed reading's noise ({:.4} m/s, measured while cruising) taken out, the physical constants; the model predicts with the plain values, the better predictors from readings this noisy",
            f.speed_noise_mps
        );
    }
    if let Some(stop) = &f.stage2_stop {
        let _ = writeln!(s, "{}", stop.describe(f.iterations));
    }
    if let Some(draws) = f.kept_draw() {
        let _ = writeln!(s, "network: {draws}");
    }
    for w in &f.warnings {
        let _ = writeln!(s, "note: {w}");
    }
    let fc = &m.features;
    let _ = writeln!(
        s,
        "load cell: feels k = {:.2} of the load's inertia and p = {:.3} of M_r ({}); empty-car zero {}",
        fc.load_cell_load_gain,
        fc.load_cell_platform_ratio,
        if fc.load_cell_load_gain == 1.0 {
            "under the platform"
        } else if fc.load_cell_load_gain < 0.5 {
            "the paper's constant-k cell"
        } else {
            "part of the load"
        },
        m.sensor.load_zero_pct.map_or_else(
            || "not checked (fewer than 5 parkings of 5 min with the door closed)".to_string(),
            |z| format!("reads {z:.2} %, checked to ±{:.2} %", m.sensor.load_zero_limit_pct)
        )
    );
    let w = &m.risk.winding;
    let heating = if w.steady_rise() > 0.0 {
        format!(
            "time constant {:.0} min, Kd +{:.1} ± {:.1} % at a steady full-load force",
            w.tau_s / 60.0,
            100.0 * w.steady_rise(),
            100.0 * w.beta_se[liftwatch::risk::HEAT_LAG],
        )
    } else {
        "no heating shown".to_string()
    };
    let (swing, peak) = w.ambient_swing();
    let daily = if swing > 0.0 {
        format!(
            "daily swing ±{:.1} % peaking at {:02.0}:{:02.0}",
            100.0 * swing,
            peak.trunc(),
            (peak.fract() * 60.0).trunc()
        )
    } else {
        "no daily swing shown".to_string()
    };
    let taken = match (w.identified(), w.levels.is_some()) {
        (true, true) => "taken out of every trip, drifts read at the winding's present Kd",
        (true, false) => "taken out of every trip",
        (false, _) => "taken as none",
    };
    let _ = writeln!(s, "winding: {heating}; {daily}; {taken}");
    if let Some(op) = &m.operation {
        let doors = match &op.door {
            None => format!(
                "not checked (fewer than {} cycles or less than {:.0} day of training)",
                liftwatch::operation::DOOR_MIN_CYCLES,
                liftwatch::operation::DOOR_MIN_DAYS
            ),
            Some(d) => format!(
                "{} cycles, median {:.0} s, {} reopen; {}",
                d.cycles,
                d.median_s,
                if d.reopen_rate <= liftwatch::operation::REOPEN_RATE_FLOOR {
                    format!(
                        "at most {:.0} %",
                        100.0 * liftwatch::operation::REOPEN_RATE_FLOOR
                    )
                } else {
                    format!("{:.1} %", 100.0 * d.reopen_rate)
                },
                d.transfer.map_or_else(
                    || "the whole cycle scored (no load readings to tell the riders from the door)"
                        .to_string(),
                    |t| format!(
                        "{:.2} s per % of rated load passing the door, {:.1} s beyond it (σ̂ {:.1} s against {:.1} s for the whole cycle)",
                        t.s_per_load, t.median_s, t.sigma_s, d.sigma_s
                    )
                )
            ),
        };
        let silence = if op.checks_silence() {
            let unseen = match op.unseen_hours.len() {
                0 => String::new(),
                n => format!(
                    " ({n} hours of the week unseen: judged once the monitor has watched them)"
                ),
            };
            format!(
                "out of service after {:.1} expected trips of silence{unseen}",
                op.outage_expected_trips
            )
        } else {
            "silences not judged (the training did not see every hour of the day), a car stuck between landings still is".to_string()
        };
        let _ = writeln!(
            s,
            "operation: {} landings placed, a trip level within {:.1} m of one; {silence}; doors: {doors}",
            op.landings_m.len(),
            op.level_tolerance_m,
        );
    }
    let _ = writeln!(
        s,
        "healthy scales: σ_U {:.2} V, σ_F {:.0} N; risk thresholds: advisory {:.3}, alarm {:.3}",
        m.hybrid.scales.sigma_u_v, m.hybrid.scales.sigma_f_n, m.risk.advisory, m.risk.alarm
    );
    if let Some(c) = &m.calibration {
        let _ = writeln!(
            s,
            "alarm budget: at most {} per elevator-year targeted, {:.2} in an independent bootstrap of {} years",
            c.target_text(),
            c.validated_false_advisories_per_year,
            c.years_simulated
        );
    }
    s.trim_end().to_string()
}
