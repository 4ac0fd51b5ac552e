//! `liftwatch simulate`: a seeded traction elevator's raw telemetry, aligned series and truth.
//!
//! Writes `raw.csv`, `aligned.csv`, `elevator.toml` and `truth.json` into `--out`. With a
//! fault scenario the degradation starts at 40 % of the span and grows linearly to full
//! severity at the end unless `--onset-days`, `--full-days` or `--ramp` say otherwise.

use std::path::PathBuf;

use anyhow::Context;
use liftwatch::sim::{self, parse_scenario, truth_name, Ramp, Scenario, SensorFault, SimConfig};
use liftwatch::Elevator;

/// Flags of `liftwatch simulate`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Output directory (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    /// Simulated span in days (fractions allowed).
    #[arg(long, default_value_t = 7.0)]
    pub days: f64,
    /// Machine degradation: healthy, motor, brake or friction.
    #[arg(long, default_value = "healthy")]
    pub scenario: String,
    /// Seed: the same seed gives the same elevator and telemetry.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Rated load (kg).
    #[arg(long, default_value_t = 1000.0)]
    pub rated_load: f64,
    /// Rated speed (m/s).
    #[arg(long, default_value_t = 1.6)]
    pub rated_speed: f64,
    /// Number of floors.
    #[arg(long, default_value_t = 16)]
    pub floors: u32,
    /// Onset of the degradation (days from the start); default 40 % of the span.
    #[arg(long)]
    pub onset_days: Option<f64>,
    /// When full severity is reached (days from the start); default the end of the span.
    #[arg(long)]
    pub full_days: Option<f64>,
    /// Growth of the degradation: step, linear or exponential.
    #[arg(long, default_value = "linear")]
    pub ramp: String,
    /// Severity at full, as a multiple of the mode's default effect.
    #[arg(long, default_value_t = 1.0)]
    pub severity: f64,
    /// Sensor fault: none, load-drift (2 %/day from the onset) or stuck-speed (1 h at the onset).
    #[arg(long, default_value = "none")]
    pub sensor_fault: String,
    /// Sensor dropouts per day and signal (each 1-15 min); 0 disables them.
    #[arg(long, default_value_t = 0.2)]
    pub dropouts_per_day: f64,
    /// Hour of the first day the run starts at (0 = Monday midnight).
    #[arg(long, default_value_t = 0.0)]
    pub start_hour: f64,
    /// Traffic intensity multiplier.
    #[arg(long, default_value_t = 1.0)]
    pub traffic: f64,
}

/// Runs `simulate`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let elevator = Elevator::new(args.rated_load, args.rated_speed, args.floors);
    elevator
        .validate()
        .map_err(anyhow::Error::msg)
        .context("elevator flags")?;
    let mut cfg = SimConfig::new(elevator, args.days, args.seed);
    cfg.dropouts_per_day = args.dropouts_per_day;
    cfg.traffic_scale = args.traffic;
    cfg.start_s = args.start_hour * 3600.0;
    let span = cfg.duration_s();
    let mode = parse_scenario(&args.scenario)?;
    let ramp: Ramp = args.ramp.parse()?;
    let onset = cfg.start_s + args.onset_days.map_or(0.4 * span, |d| d * 86_400.0);
    // An explicit --full-days before the onset is an error; the default follows a late onset.
    let full = match args.full_days {
        Some(d) => cfg.start_s + d * 86_400.0,
        None => (cfg.start_s + span).max(onset),
    };
    cfg.scenario = match mode {
        Some(mode) => Scenario::new(mode, onset, ramp, full, args.severity)?,
        None => Scenario::healthy(),
    };
    cfg.sensor_fault = match args.sensor_fault.as_str() {
        "none" => None,
        "load-drift" => Some(SensorFault::LoadDrift {
            onset_s: onset,
            pct_per_day: 2.0,
        }),
        "stuck-speed" => Some(SensorFault::StuckSpeed {
            onset_s: onset,
            duration_s: 3600.0,
        }),
        other => anyhow::bail!(
            "--sensor-fault `{other}` is not known, expected none, load-drift or stuck-speed"
        ),
    };
    cfg.validate()?;
    let long = args.days >= 2.0;
    let days = args.days;
    let mut progress = |done: f64| {
        if long {
            eprintln!("simulate: day {done:.0} of {days}");
        }
    };
    let truth = sim::write_dir(&cfg, &args.out, &mut progress)
        .with_context(|| format!("simulating into {}", args.out.display()))?;
    let s = &truth.summary;
    println!(
        "simulated {} days ({} scenario, seed {}): {} trips, {} raw rows, {} aligned rows; wrote {} in {}",
        s.days,
        truth_name(mode),
        args.seed,
        s.trips,
        s.raw_rows,
        s.truth_rows,
        sim::OUTPUT_FILES.join(", "),
        args.out.display()
    );
    Ok(())
}
