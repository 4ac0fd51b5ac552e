//! `liftwatch simulate`: a seeded traction elevator's raw telemetry, aligned series and truth.
//!
//! Writes `raw.csv`, `aligned.csv`, `elevator.toml` and `truth.json` into `--out`. With a
//! fault scenario the degradation starts at 40 % of the span and grows linearly to full
//! severity at the end unless `--onset-days`, `--full-days` or `--ramp` say otherwise. The
//! same timing serves `--doors slowing` (the wear of the doors) and `--outage` (which starts
//! at the onset).

use liftwatch::sample::{DAY_S, HOUR_S};
use std::path::PathBuf;

use anyhow::Context;
use liftwatch::mode::FaultMode;
use liftwatch::sim::scenario::VOLTAGE_OFFSET_V;
use liftwatch::sim::{
    self, truth_name, DoorBehaviour, OutageKind, OutagePlan, Ramp, Scenario, SensorFault, SimConfig,
};
use liftwatch::Elevator;

use super::ui::{Ui, UiArgs};

/// Flags of `liftwatch simulate`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Output directory (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    /// Simulated span in days (fractions allowed).
    #[arg(long, default_value_t = 7.0)]
    pub days: f64,
    /// Machine degradation.
    #[arg(long, value_enum, default_value_t = ScenarioArg::Healthy)]
    pub scenario: ScenarioArg,
    /// Seed: the same seed gives the same elevator and telemetry; another seed draws another
    /// plant too (masses, friction, Kd, sensors), so hold out later days of one seed, not
    /// another seed, to test a model of this elevator.
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
    /// Growth of the degradation.
    #[arg(long, value_enum, default_value_t = RampArg::Linear)]
    pub ramp: RampArg,
    /// Severity at full, as a multiple of the mode's default effect.
    #[arg(long, default_value_t = 1.0)]
    pub severity: f64,
    /// Sensor fault from the onset.
    #[arg(long, value_enum, default_value_t = SensorFaultArg::None)]
    pub sensor_fault: SensorFaultArg,
    /// Sensor dropouts per day and signal (each 1-15 min); 0 disables them.
    #[arg(long, default_value_t = 0.2)]
    pub dropouts_per_day: f64,
    /// Hour of the first day the run starts at (0 = Monday midnight).
    #[arg(long, default_value_t = 0.0)]
    pub start_hour: f64,
    /// Traffic intensity multiplier.
    #[arg(long, default_value_t = 1.0)]
    pub traffic: f64,
    /// The drive between trips: energised (the voltage shows U0) or off (the sensor's 0.3 V
    /// offset, with pre-torque while the brake lifts and drops).
    #[arg(long, value_enum, default_value_t = DriveArg::Energised)]
    pub drive_at_rest: DriveArg,
    /// The load cell: under the platform (feels the passengers' inertia) or the paper's
    /// constant-k cell (feels a fixed mass only).
    #[arg(long, value_enum, default_value_t = LoadCellArg::Platform)]
    pub load_cell: LoadCellArg,
    /// The transmission's efficiency η between motor and car (0.5-1): the drive needs F/η
    /// while it drives the car and gives back F·η while the car drives it. 1 is lossless, the
    /// paper's model, whose only asymmetry is the direction of travel.
    #[arg(long, default_value_t = 1.0)]
    pub efficiency: f64,
    /// The doors: catalogue timings that never reopen (the default), the field's (3 % of
    /// cycles reopen), or the field's slowing and reopening more from the onset.
    #[arg(long, value_enum, default_value_t = DoorsArg::Ideal)]
    pub doors: DoorsArg,
    /// An outage from the onset: the car out of service at a landing, or stuck between two.
    #[arg(long, value_enum, default_value_t = OutageArg::None)]
    pub outage: OutageArg,
    /// How long the outage lasts (hours); default 4 out of service, 0.5 stuck.
    #[arg(long)]
    pub outage_hours: Option<f64>,
    /// Summary: --quiet, --json.
    #[command(flatten)]
    pub ui: UiArgs,
}

/// `--doors`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum DoorsArg {
    /// Catalogue timings, no reopening (every run before doors were modelled).
    Ideal,
    /// Catalogue timings, 3 % of cycles reopen.
    Field,
    /// The field's doors, slowing and reopening more from the onset.
    Slowing,
}

/// `--outage`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum OutageArg {
    /// No outage.
    None,
    /// Out of service at a landing, door open or closed.
    OutOfService,
    /// Stuck between two landings, door closed.
    Stuck,
}

/// Default length of an out-of-service period (hours): a fault lock-out until a technician
/// comes, half a working day.
const OUT_OF_SERVICE_HOURS: f64 = 4.0;

/// Default time stuck between landings (hours): a trapped car freed within half an hour.
const STUCK_HOURS: f64 = 0.5;

/// `--drive-at-rest`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum DriveArg {
    /// Energised between trips.
    Energised,
    /// Switched off between trips.
    Off,
}

impl DriveArg {
    /// The plant's drive at rest this flag asks for.
    pub fn plant(self) -> sim::DriveAtRest {
        match self {
            DriveArg::Energised => sim::DriveAtRest::Energised,
            DriveArg::Off => sim::DriveAtRest::Off {
                idle_v: sim::plant::DRIVE_OFF_IDLE_V,
            },
        }
    }
}

/// `--load-cell`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum LoadCellArg {
    /// Under the platform: load gain 1.
    Platform,
    /// The paper's constant-k cell: load gain 0.
    ConstantK,
}

/// `--scenario`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ScenarioArg {
    /// No degradation.
    Healthy,
    /// Drive: Kd +10 %.
    Motor,
    /// Brake drag in downward and decelerating travel.
    Brake,
    /// Coulomb and viscous friction +25 % in both directions.
    Friction,
}

/// `--ramp`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum RampArg {
    /// Full severity at the onset.
    Step,
    /// Linear growth to full severity.
    Linear,
    /// Slow start, accelerating growth.
    Exponential,
}

/// `--sensor-fault`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum SensorFaultArg {
    /// Sensors healthy.
    None,
    /// The load cell drifts 2 %/day from the onset.
    LoadDrift,
    /// The speed reading sticks for 1 h at the onset.
    StuckSpeed,
    /// The voltage sensor reads 25 V high from the onset on.
    VoltageOffset,
}

/// Runs `simulate`.
pub fn run(args: Args) -> anyhow::Result<()> {
    anyhow::ensure!(
        !liftwatch::input::is_stdio(&args.out),
        "--out cannot be `-`: simulate writes a directory of four files"
    );
    let elevator = Elevator::new(args.rated_load, args.rated_speed, args.floors);
    elevator
        .validate()
        .map_err(anyhow::Error::msg)
        .context("elevator flags")?;
    let mut cfg = SimConfig::new(elevator, args.days, args.seed);
    cfg.dropouts_per_day = args.dropouts_per_day;
    cfg.traffic_scale = args.traffic;
    cfg.start_s = args.start_hour * HOUR_S;
    let span = cfg.duration_s();
    let mode = match args.scenario {
        ScenarioArg::Healthy => None,
        ScenarioArg::Motor => Some(FaultMode::Motor),
        ScenarioArg::Brake => Some(FaultMode::Brake),
        ScenarioArg::Friction => Some(FaultMode::Friction),
    };
    let ramp = match args.ramp {
        RampArg::Step => Ramp::Step,
        RampArg::Linear => Ramp::Linear,
        RampArg::Exponential => Ramp::Exponential,
    };
    let onset = cfg.start_s + args.onset_days.map_or(0.4 * span, |d| d * DAY_S);
    // An explicit --full-days before the onset is an error; the default follows a late onset.
    let full = match args.full_days {
        Some(d) => cfg.start_s + d * DAY_S,
        None => (cfg.start_s + span).max(onset),
    };
    cfg.scenario = match mode {
        Some(mode) => Scenario::new(mode, onset, ramp, full, args.severity)?,
        None => Scenario::healthy(),
    };
    cfg.sensor_fault = match args.sensor_fault {
        SensorFaultArg::None => None,
        SensorFaultArg::LoadDrift => Some(SensorFault::LoadDrift {
            onset_s: onset,
            pct_per_day: 2.0,
        }),
        SensorFaultArg::StuckSpeed => Some(SensorFault::StuckSpeed {
            onset_s: onset,
            duration_s: HOUR_S,
        }),
        SensorFaultArg::VoltageOffset => Some(SensorFault::VoltageOffset {
            onset_s: onset,
            volts: VOLTAGE_OFFSET_V,
        }),
    };
    cfg.doors = match args.doors {
        DoorsArg::Ideal => DoorBehaviour::Ideal,
        DoorsArg::Field => DoorBehaviour::Field,
        DoorsArg::Slowing => DoorBehaviour::slowing(onset, ramp, full, args.severity)?,
    };
    let outage = match args.outage {
        OutageArg::None => None,
        OutageArg::OutOfService => Some((OutageKind::OutOfService, OUT_OF_SERVICE_HOURS)),
        OutageArg::Stuck => Some((OutageKind::StuckBetweenFloors, STUCK_HOURS)),
    };
    if let Some((kind, hours)) = outage {
        cfg.outages.push(OutagePlan {
            kind,
            start_s: onset,
            duration_s: args.outage_hours.unwrap_or(hours) * HOUR_S,
        });
    }
    cfg.validate()?;
    if let Some(why) = sim::plant::efficiency_problem(args.efficiency) {
        anyhow::bail!("--efficiency {why}");
    }
    if args.drive_at_rest != DriveArg::Energised
        || args.load_cell != LoadCellArg::Platform
        || args.efficiency != 1.0
    {
        let mut plant = cfg.hidden_plant();
        plant.drive_at_rest = args.drive_at_rest.plant();
        if args.load_cell == LoadCellArg::ConstantK {
            plant.load_cell_load_gain = 0.0;
        }
        plant.efficiency = args.efficiency;
        cfg.plant = Some(plant);
    }
    let ui = Ui::new(args.ui, &[])?;
    let days = args.days;
    let mut progress = |done: f64| ui.progress(format_args!("simulate: day {done:.0} of {days}"));
    let truth = sim::write_dir(&cfg, &args.out, &mut progress)
        .with_context(|| format!("simulating into {}", args.out.display()))?;
    ui.progress_done();
    let s = &truth.summary;
    ui.say(format_args!(
        "simulated {} days ({} scenario, seed {}): {} trips, {} raw rows, {} aligned rows; wrote {} in {}",
        s.days,
        truth_name(mode),
        args.seed,
        s.trips,
        s.raw_rows,
        s.aligned_rows,
        sim::OUTPUT_FILES.join(", "),
        args.out.display()
    ));
    ui.json(&serde_json::json!({
        "command": "simulate",
        "out": args.out.display().to_string(),
        "files": sim::OUTPUT_FILES,
        "days": s.days,
        "scenario": truth_name(mode),
        "seed": args.seed,
        "trips": s.trips,
        "raw_rows": s.raw_rows,
        "aligned_rows": s.aligned_rows,
    }))
}
