//! Simulator: a seeded traction elevator that writes the telemetry its controller would log
//! (raw, DATA.md §1), the aligned series of that log (DATA.md §2, by the one aligner of
//! [`crate::align`]) and the hidden truth.
//!
//! Beside the log, each grid second also reads every sensor at the grid instant
//! ([`TruthRow::sample`], [`SimOutput::aligned`]): an idealised series that no aligner can
//! make of a log whose clocks are phase-shifted, kept in memory for tests of the stages behind
//! alignment. `aligned.csv` is not that series: it is what `liftwatch align` makes of
//! `raw.csv`, so that every command gives the same result on either file.
//!
//! ```text
//! traffic (calls by time of day) → dispatcher (single car, collective in one direction)
//!   → door cycles and S-curve trips → plant: F(x, v, a, load), U(v, F, Kd(t)), L%(load, a)
//!   → sensors on their own ~1 Hz clocks (noise, quantisation, latency, dropouts) → logger
//! F     = M_tot·a + m_eq(x)·g + F_c,s·s·(1 + k_st·e^{−(v/v_st)²}) + c·v (+ fault terms)
//! U     = U0 + Ke·|v| + φ(s)·Kd(t)·F·s,   φ(+1) = 1, φ(−1) = α_down
//! L%    = 100·(m_load·(g + a) + m_platform·a)/(M_r·g) + noise, quantised
//! ```
//!
//! The plant is deliberately richer than the identification model of MODEL.md (paper,
//! Sec. 2), so that fitting simulated data tests the method honestly rather than recovering
//! the generator: rope imbalance depends on car position and changes sign over the travel,
//! friction has a small direction asymmetry and a Stribeck rise, Kd drifts with winding
//! temperature, sensors have latency and clock jitter.
//!
//! # Numbers and where they come from
//! Drawn per installation by [`SimElevator::from_elevator`] (uniform in the range given):
//! - storey height 3.0-3.6 m (office buildings), lobby storey ×1.25-1.45 (taller entrance
//!   hall), every storey ±8 % (EN 81-20 levels are per landing, buildings are not regular);
//! - car mass 1.0-1.4·M_r (manufacturers' catalogues: a 1000 kg car weighs 1000-1400 kg);
//!   platform above the load cell 15-30 % of it;
//! - counterweight ratio q 0.40-0.50 (EN 81 practice: balance 40-50 % of rated load);
//! - suspension ropes 1.2-2.4 kg/m per tonne of rated load, 1:1 roping (e.g. five to seven
//!   8-10 mm ropes at 0.23-0.35 kg/m each for 1000 kg), no compensation chain, so the imbalance
//!   μ·(H − 2x) changes sign at mid-travel; travelling cable 0.4-1.0 kg/m hanging from mid-shaft;
//!   sheave overhead 3.5-5 m;
//! - rotating inertia (gearless sheave and rotor, J/r²) 6-14 % of car plus counterweight,
//!   i.e. 150-450 kg for a 1000 kg car (J ≈ 6-18 kg·m² at r ≈ 0.2 m);
//! - acceleration 0.6-1.0 m/s², jerk 0.8-1.5 m/s³ (ride-comfort practice, ISO 18738);
//! - Coulomb friction 1-2 % of the weight of car plus rated load (guide shoes, rope bending),
//!   up/down asymmetry ±5 %, Stribeck rise +20-40 % below 0.03-0.08 m/s; viscous
//!   c·v_rated = 30-70 % of F_c;
//! - Ke·v_rated = 80-90 % of rated voltage (back-EMF dominates a VVVF drive's output at
//!   speed); the resistive drop Kd·F at the full-load motoring force (1 − q)·M_r·g is 5-9 % of
//!   rated voltage; U0 = 1-3 % of rated voltage; α_down 0.80-0.95 (regeneration in the drive's
//!   down direction is handled by a different current path);
//! - winding thermal model: machine room 18-28 °C with a ±1.5-3 K daily swing (warmest at 15:00),
//!   winding rise 100-150 K at a continuous force of (1 − q)·M_r·g, driven by F² (copper
//!   losses) through a first-order lag of 30-60 min. An elevator machine is rated for
//!   intermittent duty (S5, about 40 % on-time at its rated torque) and reaches its class's
//!   80-100 K rise there; held at that torque without pause it would run 2-2.5 times the
//!   current-squared-time, hence 100-150 K. Real traffic runs far below it on average and
//!   near it in a rush: copper +0.39 %/K moves Kd by 5-15 % between a quiet night and a busy
//!   hour (MODEL.md: 10-20 % with the ambient cycle), healthy non-stationarity that must not
//!   raise alarms;
//! - sensors: speed noise 3-7 mm/s, 1 mm/s steps; voltage noise 0.6-1.2 V, steps 0.1, 0.25
//!   or 0.5 V; load-cell noise 0.3-0.7 %, 1 % steps; 10-40 ms clock jitter, 0-50 ms latency
//!   (a drive value read over a fieldbus is up to one bus cycle old; at 0.8 m/s² the back-EMF
//!   ramps at ~100 V/s, so latency alone shifts a voltage sample taken while accelerating by
//!   a few volts, a learnable function of a and direction).
//!
//! Traffic is documented in [`traffic`], degradations in [`scenario`]. Door cycle at every stop
//! (centre-opening doors, catalogue timings): opening 1.5-2.5 s, fully open 3-6 s plus
//! 0.8-1.5 s per rider leaving or entering, closing 2.0-3.5 s; the door signal is 1 from the
//! start of opening to the end of closing. Before each trip the brake lifts and the drive
//! magnetises for 0.5-1.2 s with the direction already set; after it the car levels and the
//! brake drops for 0.3-0.8 s. The car parks at the lobby with probability 1/2 after 5 minutes
//! idle elsewhere.
//!
//! Deviation from the paper: the paper validates on field data it cannot share; this
//! simulator replaces it so that every figure of the README can be regenerated from a seed.

mod engine;
pub mod logger;
pub mod motion;
pub mod plant;
pub mod scenario;
pub mod service;
pub mod stream;
pub mod traffic;

use std::collections::VecDeque;
use std::path::Path;

use serde::Serialize;

use crate::align::AlignConfig;
use crate::elevator::Elevator;
use crate::error::{Error, Result};
use crate::mode::FaultMode;
use crate::model::physics::PhysParams;
use crate::rng::Rng;
use crate::sample::{AlignedSeries, Sample, DAY_S};

pub use logger::{AlignedCsvWriter, RawCsvWriter, RawRow, Signal, ALIGNED_HEADER, SIMULATED};
pub use motion::{Kinematics, SCurve};
pub use plant::{DriveAtRest, SimElevator};
pub use scenario::{parse_scenario, truth_name, Effects, Ramp, Scenario, SensorFault};
pub use service::{DoorBehaviour, OutageKind, OutagePlan, OutageTruth};
pub use traffic::{Call, Traffic};

use engine::Engine;
use logger::{RawAligner, RawLogger, SensorClock};
use plant::sign;

/// Settings of one simulation run.
#[derive(Clone, Debug, PartialEq)]
pub struct SimConfig {
    /// The elevator as its owner describes it; hidden values are drawn from it.
    pub elevator: Elevator,
    /// Simulated span (days, fractional allowed).
    pub days: f64,
    /// Seed: the same seed gives the same elevator, traffic and telemetry.
    pub seed: u64,
    /// Start time (s); 0 is a Monday at midnight, so time of day is `start_s mod 86400`.
    pub start_s: f64,
    /// Machine degradation.
    pub scenario: Scenario,
    /// Optional sensor fault.
    pub sensor_fault: Option<SensorFault>,
    /// Multiplier of the traffic intensity (1 = office building of [`traffic`]).
    pub traffic_scale: f64,
    /// Dropouts per day and signal (each silent 1-15 min); 0 disables them.
    pub dropouts_per_day: f64,
    /// Hidden plant to use instead of drawing one from `elevator` and `seed`.
    pub plant: Option<SimElevator>,
    /// How the doors behave ([`service`]): ideal by default.
    pub doors: DoorBehaviour,
    /// Outages to simulate, in any order ([`service`]).
    pub outages: Vec<OutagePlan>,
}

impl SimConfig {
    /// A healthy run of `days` days for `elevator`, with a few dropouts (0.2 per day and signal).
    pub fn new(elevator: Elevator, days: f64, seed: u64) -> Self {
        SimConfig {
            elevator,
            days,
            seed,
            start_s: 0.0,
            scenario: Scenario::healthy(),
            sensor_fault: None,
            traffic_scale: 1.0,
            dropouts_per_day: 0.2,
            plant: None,
            doors: DoorBehaviour::Ideal,
            outages: Vec::new(),
        }
    }

    /// The same run with the machine mode `mode` spread over it: onset at 40 % of the span,
    /// linear ramp to full severity at the end ([`Scenario::spread_over`]).
    pub fn with_mode(mut self, mode: FaultMode) -> Self {
        self.scenario = Scenario::spread_over(mode, self.start_s, self.duration_s());
        self
    }

    /// The hidden plant of a run with these settings: `plant` when set, otherwise the one
    /// drawn from `elevator` and `seed` (the same as [`run`] draws).
    pub fn hidden_plant(&self) -> SimElevator {
        self.plant.clone().unwrap_or_else(|| {
            SimElevator::from_elevator(&self.elevator, &mut Rng::new(self.seed).fork())
        })
    }

    /// Simulated span (s).
    pub fn duration_s(&self) -> f64 {
        self.days * DAY_S
    }

    /// Checks every setting.
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] naming the first bad setting.
    pub fn validate(&self) -> Result<()> {
        let bad = |field: &'static str, why: String| Err(Error::InvalidConfig { field, why });
        if let Err(why) = self.elevator.validate() {
            return bad("elevator", why);
        }
        if !(self.days.is_finite() && self.days > 0.0 && self.days <= 3660.0) {
            return bad(
                "days",
                format!("{} must be above 0 and at most 3660", self.days),
            );
        }
        // Every time the run writes must be one the readers take back
        // (ingest::time::MAX_ABS_TIME_S): a start beyond it wrote logs no command could read,
        // and near 1e12 s a second no longer moved the clock, so the run never ended.
        let last = crate::ingest::time::MAX_ABS_TIME_S - self.days * DAY_S;
        if !(self.start_s.is_finite() && self.start_s.abs() <= last) {
            return bad(
                "start_s",
                format!(
                    "{} s must lie within ±{last:.0} s, so that the run's times stay within ±{:.0e} s",
                    crate::error::number(self.start_s),
                    crate::ingest::time::MAX_ABS_TIME_S
                ),
            );
        }
        if !(self.traffic_scale.is_finite()
            && self.traffic_scale > 0.0
            && self.traffic_scale <= 20.0)
        {
            return bad(
                "traffic_scale",
                format!("{} must be above 0 and at most 20", self.traffic_scale),
            );
        }
        if !(self.dropouts_per_day.is_finite() && (0.0..=100.0).contains(&self.dropouts_per_day)) {
            return bad(
                "dropouts_per_day",
                format!("{} must be between 0 and 100", self.dropouts_per_day),
            );
        }
        if let Some(p) = &self.plant {
            if p.floor_positions_m.len() < 2 {
                return bad("plant", "needs at least two landings".into());
            }
            if let Some(why) = plant::efficiency_problem(p.efficiency) {
                return bad("plant.efficiency", why);
            }
        }
        for o in &self.outages {
            o.validate()?;
        }
        Ok(())
    }
}

/// One grid second: every sensor read at the grid instant, and the truth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TruthRow {
    /// Sensor readings at the grid instant (NaN while the sensor is silent); `current` is NaN.
    pub sample: Sample,
    /// True signed velocity (m/s, + up).
    pub v_true: f64,
    /// True signed acceleration (m/s²).
    pub accel_true: f64,
    /// True car position above the lowest landing (m).
    pub pos_true: f64,
    /// True load ratio λ = m_load/M_r (1).
    pub load_true: f64,
    /// True driving force on the car side (N, + up); zero at rest.
    pub force_true: f64,
    /// Noise-free motor voltage (V).
    pub voltage_true: f64,
    /// True Kd(t) incl. thermal drift and motor degradation (V/N).
    pub kd_true: f64,
    /// Degradation severity σ(t) (0 = healthy).
    pub severity: f64,
}

/// Receives the simulator's output as it is produced.
pub trait SimSink {
    /// One raw row, in logging order.
    ///
    /// # Errors
    /// Whatever the sink fails with; the run stops.
    fn raw(&mut self, row: RawRow) -> Result<()>;
    /// One grid second, in time order.
    ///
    /// # Errors
    /// Whatever the sink fails with; the run stops.
    fn truth(&mut self, row: &TruthRow) -> Result<()>;
}

/// Counts of one run.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct SimSummary {
    /// Simulated span (days).
    pub days: f64,
    /// Trips travelled (a trip is one start-to-stop motion).
    pub trips: u64,
    /// Passengers and goods carried.
    pub riders: u64,
    /// Calls dropped because the queue was full.
    pub dropped_calls: u64,
    /// Raw rows produced.
    pub raw_rows: u64,
    /// Grid seconds produced (sensors read at the grid instant, with the truth).
    pub truth_rows: u64,
    /// Rows of `aligned.csv` ([`write_dir`]) or samples of [`simulate_aligned`]: the grid
    /// points of the raw log, a second or two fewer than `truth_rows` (0 for [`simulate`]).
    pub aligned_rows: u64,
    /// Time in motion (s).
    pub moving_s: f64,
    /// Mean true load ratio over time in motion (1).
    pub mean_load_ratio_moving: f64,
    /// Mean rope and travelling-cable imbalance over time in motion (kg): a fit without the
    /// position term m_rope·q absorbs car − counterweight + this value into Δm.
    pub mean_imbalance_moving_kg: f64,
    /// Lowest and highest thermal factor of Kd seen at the grid instants.
    pub kd_thermal_range: (f64, f64),
}

/// Everything true about a run, as written to `truth.json`.
#[derive(Clone, Debug, Serialize)]
pub struct SimTruth {
    /// Seed of the run.
    pub seed: u64,
    /// Start time (s).
    pub start_s: f64,
    /// Simulated span (s).
    pub duration_s: f64,
    /// True parameters in the identification model's terms (`model::physics` names and units;
    /// Δm and m_rope as the least-squares line of the true imbalance over the landings).
    pub parameters: PhysParams,
    /// Platform mass over rated load: the load-cell inertia ratio p of the features stage (1).
    pub load_cell_platform_ratio: f64,
    /// The degradation (`onset_s`, `full_at_s` are null when healthy).
    pub scenario: Scenario,
    /// The sensor fault, if any.
    pub sensor_fault: Option<SensorFault>,
    /// Every hidden value of the plant.
    pub plant: SimElevator,
    /// Counts of the run.
    pub summary: SimSummary,
    /// How the doors behaved; left out for the default ideal doors.
    #[serde(skip_serializing_if = "DoorBehaviour::is_ideal")]
    pub doors: DoorBehaviour,
    /// The outages as they happened; left out when none was asked for.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub outages: Vec<OutageTruth>,
}

/// An in-memory run, for tests and short spans.
#[derive(Clone, Debug)]
pub struct SimOutput {
    /// The raw rows in logging order.
    pub raw: Vec<RawRow>,
    /// The grid seconds with their truth.
    pub rows: Vec<TruthRow>,
    /// The truth document.
    pub truth: SimTruth,
}

impl SimOutput {
    /// The sensors read at the grid instant (DATA.md §2 signals only): an idealised series,
    /// not what aligning [`SimOutput::raw`] gives (that is what `aligned.csv` and
    /// [`simulate_aligned`] hold).
    pub fn aligned(&self) -> AlignedSeries {
        AlignedSeries {
            step_s: 1.0,
            samples: self.rows.iter().map(|r| r.sample).collect(),
        }
    }
}

struct Collect {
    raw: Vec<RawRow>,
    rows: Vec<TruthRow>,
}

impl SimSink for Collect {
    fn raw(&mut self, row: RawRow) -> Result<()> {
        self.raw.push(row);
        Ok(())
    }
    fn truth(&mut self, row: &TruthRow) -> Result<()> {
        self.rows.push(*row);
        Ok(())
    }
}

/// Simulates the whole run in memory.
///
/// # Errors
/// [`Error::InvalidConfig`] when a setting is out of range.
pub fn simulate(cfg: &SimConfig) -> Result<SimOutput> {
    let mut sink = Collect {
        raw: Vec::new(),
        rows: Vec::new(),
    };
    let truth = run(cfg, &mut sink, &mut |_| {})?;
    Ok(SimOutput {
        raw: sink.raw,
        rows: sink.rows,
        truth,
    })
}

/// Simulates the run and keeps what a user of its log would have: the alignment of the raw
/// rows by the one aligner of [`crate::align`], the series `aligned.csv` holds and `liftwatch
/// align` makes of `raw.csv` (not [`SimOutput::aligned`], the sensors read at the grid
/// instant). Only the aligned series is kept in memory, not the raw rows or the truth rows.
///
/// # Errors
/// [`Error::InvalidConfig`] when a setting is out of range.
pub fn simulate_aligned(cfg: &SimConfig) -> Result<(AlignedSeries, SimTruth)> {
    struct Aligned {
        aligner: RawAligner,
        samples: Vec<Sample>,
    }
    impl SimSink for Aligned {
        fn raw(&mut self, row: RawRow) -> Result<()> {
            self.aligner.push(&row, &mut self.samples)
        }
        fn truth(&mut self, _row: &TruthRow) -> Result<()> {
            Ok(())
        }
    }
    let mut sink = Aligned {
        aligner: RawAligner::new()?,
        samples: Vec::new(),
    };
    let mut truth = run(cfg, &mut sink, &mut |_| {})?;
    sink.aligner.flush(&mut sink.samples)?;
    truth.summary.aligned_rows = sink.samples.len() as u64;
    let series = AlignedSeries {
        step_s: AlignConfig::default().step_s,
        samples: sink.samples,
    };
    Ok((series, truth))
}

/// Simulates the run, handing rows to `sink` as they are produced; `progress` is called with
/// the simulated days completed, once per day.
///
/// # Errors
/// [`Error::InvalidConfig`] when a setting is out of range; whatever `sink` fails with.
pub fn run<S: SimSink>(
    cfg: &SimConfig,
    sink: &mut S,
    progress: &mut dyn FnMut(f64),
) -> Result<SimTruth> {
    cfg.validate()?;
    let mut rng = Rng::new(cfg.seed);
    // The plant's stream is forked off first, used or not, so the rest of the run is the same.
    let _plant_rng = rng.fork();
    let plant = cfg.hidden_plant();
    let mut engine = Engine::new(cfg, &plant, &mut rng, sink, progress);
    engine.run()?;
    let summary = engine.finish()?;
    let outages = engine.outages_done();
    Ok(SimTruth {
        seed: cfg.seed,
        start_s: cfg.start_s,
        duration_s: cfg.duration_s(),
        parameters: plant.true_params(),
        load_cell_platform_ratio: plant.platform_mass_kg / plant.rated.rated_load_kg,
        scenario: cfg.scenario.clone(),
        sensor_fault: cfg.sensor_fault.clone(),
        plant,
        summary,
        doors: cfg.doors.clone(),
        outages,
    })
}

/// The files [`write_dir`] writes.
pub const OUTPUT_FILES: [&str; 4] = ["raw.csv", "aligned.csv", "elevator.toml", "truth.json"];

/// Simulates the run and writes `raw.csv`, `aligned.csv`, `elevator.toml` and `truth.json`
/// into `dir` (created if missing), streaming: memory stays small whatever the span. The files
/// appear together at the end ([`crate::output::AtomicDir`]).
///
/// # Errors
/// [`Error::InvalidConfig`] for a bad setting, [`Error::Io`] when a file cannot be written.
pub fn write_dir(cfg: &SimConfig, dir: &Path, progress: &mut dyn FnMut(f64)) -> Result<SimTruth> {
    cfg.validate()?;
    // Written into a temporary directory moved in at the end: a failure (a full disk) leaves
    // no half-written file behind.
    let out = crate::output::AtomicDir::create(dir)?;
    let tmp = out.path().to_path_buf();
    struct Files {
        raw: RawCsvWriter,
        aligned: AlignedCsvWriter,
    }
    impl SimSink for Files {
        fn raw(&mut self, row: RawRow) -> Result<()> {
            self.raw.write(&row)?;
            self.aligned.raw(&row)
        }
        fn truth(&mut self, row: &TruthRow) -> Result<()> {
            self.aligned.truth(row)
        }
    }
    let mut files = Files {
        raw: RawCsvWriter::create(&tmp.join("raw.csv"))?,
        aligned: AlignedCsvWriter::create(&tmp.join("aligned.csv"))?,
    };
    let mut truth = run(cfg, &mut files, progress)?;
    files.raw.finish()?;
    truth.summary.aligned_rows = files.aligned.finish()?;
    let toml_path = tmp.join("elevator.toml");
    std::fs::write(&toml_path, truth.plant.to_elevator().to_toml_string())
        .map_err(|e| Error::io(&toml_path, e))?;
    let json_path = tmp.join("truth.json");
    let json = serde_json::to_string_pretty(&truth)
        .map_err(|e| Error::io(&json_path, std::io::Error::other(e)))?;
    std::fs::write(&json_path, json + "\n").map_err(|e| Error::io(&json_path, e))?;
    out.commit()?;
    Ok(truth)
}
