//! Simulator: a seeded traction elevator that writes the telemetry its controller would log
//! (raw, DATA.md §1), its own aligned series (DATA.md §2) and the hidden truth.
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
//!   winding rise 25-35 K at a continuous force of (1 − q)·M_r·g (elevator machines are sized
//!   for starts per hour, so a steady travelling force leaves a wide thermal margin), time
//!   constant 30-60 min; copper +0.39 %/K, so Kd moves by about ±3 % over a day
//!   (healthy non-stationarity that must not raise alarms);
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

pub mod logger;
pub mod motion;
pub mod plant;
pub mod scenario;
pub mod stream;
pub mod traffic;

use std::collections::VecDeque;
use std::path::Path;

use serde::Serialize;

use crate::elevator::Elevator;
use crate::error::{Error, Result};
use crate::mode::FaultMode;
use crate::model::physics::PhysParams;
use crate::rng::Rng;
use crate::sample::{AlignedSeries, Sample};

pub use logger::{AlignedCsvWriter, RawCsvWriter, RawRow, Signal, ALIGNED_HEADER, SIMULATED};
pub use motion::{Kinematics, SCurve};
pub use plant::SimElevator;
pub use scenario::{parse_scenario, truth_name, Effects, Ramp, Scenario, SensorFault};
pub use traffic::{Call, Traffic};

use logger::{RawLogger, SensorClock};
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
        }
    }

    /// The same run with the machine mode `mode` spread over it: onset at 40 % of the span,
    /// linear ramp to full severity at the end ([`Scenario::spread_over`]).
    pub fn with_mode(mut self, mode: FaultMode) -> Self {
        self.scenario = Scenario::spread_over(mode, self.start_s, self.duration_s());
        self
    }

    /// Simulated span (s).
    pub fn duration_s(&self) -> f64 {
        self.days * 86_400.0
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
        if !self.start_s.is_finite() {
            return bad("start_s", format!("{} must be finite", self.start_s));
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
        }
        Ok(())
    }
}

/// One second of the simulator's own aligned series and its truth.
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
    /// One aligned second, in time order.
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
    /// Aligned seconds produced.
    pub truth_rows: u64,
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
}

/// An in-memory run, for tests and short spans.
#[derive(Clone, Debug)]
pub struct SimOutput {
    /// The raw rows in logging order.
    pub raw: Vec<RawRow>,
    /// The aligned seconds with their truth.
    pub rows: Vec<TruthRow>,
    /// The truth document.
    pub truth: SimTruth,
}

impl SimOutput {
    /// The simulator's own aligned series (DATA.md §2 signals only).
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
    let mut plant_rng = rng.fork();
    let plant = cfg
        .plant
        .clone()
        .unwrap_or_else(|| SimElevator::from_elevator(&cfg.elevator, &mut plant_rng));
    let mut engine = Engine::new(cfg, &plant, &mut rng, sink, progress);
    engine.run()?;
    let summary = engine.finish()?;
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
    })
}

/// The files [`write_dir`] writes.
pub const OUTPUT_FILES: [&str; 4] = ["raw.csv", "aligned.csv", "elevator.toml", "truth.json"];

/// Simulates the run and writes `raw.csv`, `aligned.csv`, `elevator.toml` and `truth.json`
/// into `dir` (created if missing), streaming: memory stays small whatever the span.
///
/// # Errors
/// [`Error::InvalidConfig`] for a bad setting, [`Error::Io`] when a file cannot be written.
pub fn write_dir(cfg: &SimConfig, dir: &Path, progress: &mut dyn FnMut(f64)) -> Result<SimTruth> {
    cfg.validate()?;
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    struct Files {
        raw: RawCsvWriter,
        aligned: AlignedCsvWriter,
    }
    impl SimSink for Files {
        fn raw(&mut self, row: RawRow) -> Result<()> {
            self.raw.write(&row)
        }
        fn truth(&mut self, row: &TruthRow) -> Result<()> {
            self.aligned.write(row)
        }
    }
    let mut files = Files {
        raw: RawCsvWriter::create(&dir.join("raw.csv"))?,
        aligned: AlignedCsvWriter::create(&dir.join("aligned.csv"))?,
    };
    let truth = run(cfg, &mut files, progress)?;
    files.raw.finish()?;
    files.aligned.finish()?;
    let toml_path = dir.join("elevator.toml");
    std::fs::write(&toml_path, truth.plant.to_elevator().to_toml_string())
        .map_err(|e| Error::io(&toml_path, e))?;
    let json_path = dir.join("truth.json");
    let json = serde_json::to_string_pretty(&truth)
        .map_err(|e| Error::io(&json_path, std::io::Error::other(e)))?;
    std::fs::write(&json_path, json + "\n").map_err(|e| Error::io(&json_path, e))?;
    Ok(truth)
}

/// Most calls waiting at once; beyond it new calls are dropped (people take the stairs).
const MAX_QUEUE: usize = 400;

/// Motion of the car during one stretch of time.
#[derive(Clone, Copy)]
enum Motion<'c> {
    /// Standing at the current position.
    Rest,
    /// Travelling along `curve`, started at `t0` from `from` in direction `dir`.
    Travel {
        curve: &'c SCurve,
        t0: f64,
        from: f64,
        dir: i8,
    },
}

/// The dispatcher and the time loop (door and brake timings in the module docs).
///
/// Calls are served one direction at a time: riders are dropped off nearest first, waiting
/// groups at a landing board when they go the car's way and fit in the rated load.
struct Engine<'a, S: SimSink> {
    cfg: &'a SimConfig,
    p: &'a SimElevator,
    sink: &'a mut S,
    progress: &'a mut dyn FnMut(f64),
    rng: Rng,
    noise_raw: Rng,
    noise_grid: Rng,
    traffic: Traffic,
    next_call: Call,
    queue: VecDeque<Call>,
    clocks: [SensorClock; 6],
    logger: RawLogger,
    t: f64,
    end: f64,
    next_grid: f64,
    next_day: f64,
    floor: usize,
    pos: f64,
    dir_travel: i8,
    riders: Vec<(usize, f64)>,
    load_kg: f64,
    door: bool,
    dir_signal: i8,
    rise_k: f64,
    stuck_speed: Option<f64>,
    summary: SimSummary,
    load_time: f64,
    imbalance_time: f64,
}

impl<'a, S: SimSink> Engine<'a, S> {
    fn new(
        cfg: &'a SimConfig,
        p: &'a SimElevator,
        rng: &mut Rng,
        sink: &'a mut S,
        progress: &'a mut dyn FnMut(f64),
    ) -> Self {
        let start = cfg.start_s;
        let floors = p.floor_positions_m.len();
        let mut traffic = Traffic::new(
            rng.fork(),
            floors,
            p.rated.rated_load_kg,
            cfg.traffic_scale,
            start,
        );
        let next_call = traffic.next_call();
        let sp = &p.sensors;
        let clocks = std::array::from_fn(|k| {
            SensorClock::new(
                rng.fork(),
                start,
                sp.clock_ppm[k],
                sp.jitter_s,
                cfg.dropouts_per_day,
            )
        });
        let floor = rng.below(floors as u64) as usize;
        Engine {
            cfg,
            p,
            sink,
            progress,
            rng: rng.fork(),
            noise_raw: rng.fork(),
            noise_grid: rng.fork(),
            traffic,
            next_call,
            queue: VecDeque::new(),
            clocks,
            logger: RawLogger::new(rng.fork(), start),
            t: start,
            end: start + cfg.duration_s(),
            next_grid: start.ceil(),
            next_day: start + 86_400.0,
            floor,
            pos: p.floor_positions_m[floor],
            dir_travel: 1,
            riders: Vec::new(),
            load_kg: 0.0,
            door: false,
            dir_signal: 0,
            rise_k: 0.09 * p.thermal.rise_full_k,
            stuck_speed: None,
            summary: SimSummary {
                kd_thermal_range: (f64::INFINITY, f64::NEG_INFINITY),
                ..SimSummary::default()
            },
            load_time: 0.0,
            imbalance_time: 0.0,
        }
    }

    fn run(&mut self) -> Result<()> {
        while self.t < self.end {
            self.admit_calls();
            if !self.riders.is_empty() {
                let dest = self.next_stop();
                self.travel_to(dest)?;
                self.stop_and_transfer()?;
            } else if let Some(origin) = self.queue.front().map(|c| c.origin) {
                self.travel_to(origin)?;
                self.stop_and_transfer()?;
            } else {
                let until = self.next_call.time.min(self.end);
                if self.floor != 0 && until - self.t > 300.0 && self.rng.chance(0.5) {
                    self.rest(self.t + 300.0)?;
                    self.travel_to(0)?;
                } else {
                    self.rest(until)?;
                }
            }
        }
        Ok(())
    }

    fn finish(&mut self) -> Result<SimSummary> {
        let sink = &mut *self.sink;
        let mut n = 0u64;
        self.logger.flush_all(&mut |r| {
            n += 1;
            sink.raw(r)
        })?;
        self.summary.raw_rows += n;
        self.summary.days = self.cfg.days;
        self.summary.mean_load_ratio_moving = if self.summary.moving_s > 0.0 {
            self.load_time / self.summary.moving_s
        } else {
            0.0
        };
        if self.summary.moving_s > 0.0 {
            self.summary.mean_imbalance_moving_kg = self.imbalance_time / self.summary.moving_s;
        }
        Ok(self.summary.clone())
    }

    fn admit_calls(&mut self) {
        while self.next_call.time <= self.t {
            let call = std::mem::replace(&mut self.next_call, self.traffic.next_call());
            if self.queue.len() < MAX_QUEUE {
                self.queue.push_back(call);
            } else {
                self.summary.dropped_calls += 1;
            }
        }
    }

    /// The nearest rider destination ahead in the travel direction, else the nearest behind.
    fn next_stop(&mut self) -> usize {
        let f = self.floor;
        let ahead = |d: i8| {
            self.riders
                .iter()
                .map(|r| r.0)
                .filter(|&x| if d > 0 { x > f } else { x < f })
                .min_by_key(|&x| x.abs_diff(f))
        };
        match ahead(self.dir_travel) {
            Some(x) => x,
            None => {
                self.dir_travel = -self.dir_travel;
                ahead(self.dir_travel).unwrap_or(f)
            }
        }
    }

    fn rest(&mut self, until: f64) -> Result<()> {
        self.advance(until, Motion::Rest)
    }

    /// Brake lift, S-curve trip, levelling; the car ends level with landing `dest`.
    fn travel_to(&mut self, dest: usize) -> Result<()> {
        if dest == self.floor {
            return Ok(());
        }
        let dir: i8 = if dest > self.floor { 1 } else { -1 };
        self.dir_travel = dir;
        self.dir_signal = dir;
        let lift = self.rng.uniform(0.5, 1.2);
        self.rest(self.t + lift)?;
        let target = self.p.floor_positions_m[dest];
        let p = self.p;
        let curve = SCurve::new(
            (target - self.pos).abs(),
            p.rated.rated_speed_mps,
            p.accel_mps2,
            p.jerk_mps3,
        );
        let t0 = self.t;
        self.advance(
            t0 + curve.duration(),
            Motion::Travel {
                curve: &curve,
                t0,
                from: self.pos,
                dir,
            },
        )?;
        self.pos = target;
        self.floor = dest;
        self.summary.trips += 1;
        let level = self.rng.uniform(0.3, 0.8);
        self.rest(self.t + level)?;
        self.dir_signal = 0;
        Ok(())
    }

    /// Door cycle: riders for this landing leave, waiting calls going our way board.
    fn stop_and_transfer(&mut self) -> Result<()> {
        self.door = true;
        let opening = self.rng.uniform(1.5, 2.5);
        self.rest(self.t + opening)?;
        let here = self.floor;
        let mut k = 0;
        while k < self.riders.len() {
            if self.riders[k].0 == here {
                let (_, m) = self.riders.swap_remove(k);
                let step = self.rng.uniform(0.8, 1.5);
                self.rest(self.t + step)?;
                self.load_kg = (self.load_kg - m).max(0.0);
                if self.riders.is_empty() {
                    self.load_kg = 0.0;
                }
            } else {
                k += 1;
            }
        }
        if self.riders.is_empty() {
            if let Some(c) = self.queue.iter().find(|c| c.origin == here) {
                self.dir_travel = c.direction();
            }
        }
        let mut i = 0;
        while i < self.queue.len() {
            let c = &self.queue[i];
            let room = self.p.rated.rated_load_kg - self.load_kg;
            let mass: f64 = c.riders.iter().map(|r| r.1).sum();
            if c.origin == here && c.direction() == self.dir_travel && mass <= room {
                let call = self
                    .queue
                    .remove(i)
                    .expect("index is below the queue length");
                for r in call.riders {
                    let step = self.rng.uniform(0.8, 1.5);
                    self.rest(self.t + step)?;
                    self.load_kg += r.1;
                    self.riders.push(r);
                    self.summary.riders += 1;
                }
            } else {
                i += 1;
            }
        }
        let open = self.rng.uniform(3.0, 6.0);
        self.rest(self.t + open)?;
        let closing = self.rng.uniform(2.0, 3.5);
        self.rest(self.t + closing)?;
        self.door = false;
        Ok(())
    }

    /// Position, signed velocity and acceleration at `t`.
    fn kin(&self, m: Motion, t: f64) -> (f64, f64, f64) {
        match m {
            Motion::Rest => (self.pos, 0.0, 0.0),
            Motion::Travel {
                curve,
                t0,
                from,
                dir,
            } => {
                let k = curve.at(t - t0);
                let d = f64::from(dir);
                (from + d * k.distance, d * k.speed, d * k.accel)
            }
        }
    }

    /// Advances time to `until` (capped at the end of the run), sampling every sensor and grid
    /// instant on the way. Travel is stepped at 10 Hz for the winding temperature; rest is
    /// one step, its thermal decay taken analytically.
    fn advance(&mut self, until: f64, m: Motion) -> Result<()> {
        let until = until.min(self.end);
        let travelling = matches!(m, Motion::Travel { .. });
        while self.t < until {
            let b = if travelling {
                (self.t + 0.1).min(until)
            } else {
                until
            };
            self.sample_until(b, m)?;
            let dt = b - self.t;
            let target = if travelling {
                let mid = 0.5 * (self.t + b);
                let (x, v, a) = self.kin(m, mid);
                let fx = self.cfg.scenario.effects_at(mid, self.p.f_c);
                self.summary.moving_s += dt;
                self.load_time += dt * self.load_kg / self.p.rated.rated_load_kg;
                self.imbalance_time += dt * self.p.imbalance_kg(x);
                self.p
                    .heating_k(self.p.force(x, v, a, self.load_kg, &fx), true)
            } else {
                0.0
            };
            self.rise_k = target + (self.rise_k - target) * (-dt / self.p.thermal.tau_s).exp();
            self.t = b;
            let sink = &mut *self.sink;
            let mut n = 0u64;
            self.logger.flush_until(b, &mut |r| {
                n += 1;
                sink.raw(r)
            })?;
            self.summary.raw_rows += n;
        }
        Ok(())
    }

    /// Emits, in time order, every raw sample and grid row before `b`.
    fn sample_until(&mut self, b: f64, m: Motion) -> Result<()> {
        loop {
            let mut which = SIMULATED.len();
            let mut tmin = self.next_grid;
            for (k, c) in self.clocks.iter().enumerate() {
                if c.next < tmin {
                    tmin = c.next;
                    which = k;
                }
            }
            if tmin >= b || tmin >= self.end {
                return Ok(());
            }
            if which == SIMULATED.len() {
                self.emit_grid(tmin, m)?;
                self.next_grid += 1.0;
            } else {
                let signal = SIMULATED[which];
                if !self.clocks[which].dropouts.silent(tmin) {
                    let mut rng = std::mem::replace(&mut self.noise_raw, Rng::new(0));
                    let value = self.reading(signal, tmin, m, &mut rng);
                    self.noise_raw = rng;
                    self.logger.push(RawRow {
                        time: tmin,
                        signal,
                        value,
                    });
                }
                self.clocks[which].advance();
            }
        }
    }

    /// Current Kd including the thermal factor and the motor degradation.
    fn kd_at(&self, t: f64, fx: &Effects) -> f64 {
        self.p.kd * self.p.kd_thermal_factor(t, self.rise_k) * fx.kd_factor
    }

    /// One sensor reading at `t`: the plant state `latency` earlier, plus noise and quantisation.
    fn reading(&mut self, signal: Signal, t: f64, m: Motion, rng: &mut Rng) -> f64 {
        let sp = &self.p.sensors;
        let ts = t - sp.latency_s[signal.index()];
        // `+ 0.0` turns a rounded −0 into 0, so files never show `-0.0`.
        let quant = |v: f64, q: f64| (v / q).round() * q + 0.0;
        match signal {
            Signal::Speed => {
                if let Some(f) = &self.cfg.sensor_fault {
                    if f.speed_stuck(t) {
                        let (_, v, _) = self.kin(m, ts);
                        return *self
                            .stuck_speed
                            .get_or_insert(quant(v.abs(), sp.speed_quant_mps));
                    }
                    self.stuck_speed = None;
                }
                let (_, v, _) = self.kin(m, ts);
                if sign(v) == 0 {
                    0.0
                } else {
                    quant(
                        (v.abs() + sp.speed_noise_mps * rng.normal()).max(0.0),
                        sp.speed_quant_mps,
                    )
                }
            }
            Signal::Direction => f64::from(self.dir_signal),
            Signal::Voltage => {
                let (x, v, a) = self.kin(m, ts);
                let fx = self.cfg.scenario.effects_at(ts, self.p.f_c);
                let f = self.p.force(x, v, a, self.load_kg, &fx);
                let u = self.p.voltage(v, f, self.kd_at(ts, &fx));
                quant(
                    (u + sp.voltage_noise_v * rng.normal()).max(0.0),
                    sp.voltage_quant_v,
                )
            }
            Signal::Load => {
                let (_, _, a) = self.kin(m, ts);
                let drift = self
                    .cfg
                    .sensor_fault
                    .as_ref()
                    .map_or(0.0, |f| f.load_offset_pct(t));
                let l = self.p.load_cell_pct(self.load_kg, a)
                    + drift
                    + sp.load_noise_pct * rng.normal();
                quant(l, sp.load_quant_pct)
            }
            Signal::Door => f64::from(u8::from(self.door)),
            // Not simulated: SIMULATED never yields it.
            Signal::Current => f64::NAN,
            Signal::Floor => {
                let (x, _, _) = self.kin(m, ts);
                let fl = &self.p.floor_positions_m;
                let i = fl.partition_point(|&h| h < x);
                let nearest = if i == 0 {
                    0
                } else if i >= fl.len() || x - fl[i - 1] < fl[i] - x {
                    i - 1
                } else {
                    i
                };
                (nearest + 1) as f64
            }
        }
    }

    /// One aligned second: sensor models at the grid instant (silent sensors missing) and truth.
    fn emit_grid(&mut self, t: f64, m: Motion) -> Result<()> {
        let mut rng = std::mem::replace(&mut self.noise_grid, Rng::new(0));
        let mut vals = [f64::NAN; 6];
        for s in SIMULATED {
            let k = s.index();
            if !self.clocks[k].dropouts.silent(t) {
                vals[k] = self.reading(s, t, m, &mut rng);
            }
        }
        self.noise_grid = rng;
        let (x, v, a) = self.kin(m, t);
        let fx = self.cfg.scenario.effects_at(t, self.p.f_c);
        let moving = sign(v) != 0;
        let kd = self.kd_at(t, &fx);
        let force = if moving {
            self.p.force(x, v, a, self.load_kg, &fx)
        } else {
            0.0
        };
        let thermal = self.p.kd_thermal_factor(t, self.rise_k);
        let r = &mut self.summary.kd_thermal_range;
        *r = (r.0.min(thermal), r.1.max(thermal));
        let row = TruthRow {
            sample: Sample {
                time: t,
                speed: vals[0],
                direction: vals[1],
                voltage: vals[2],
                load: vals[3],
                door: vals[4],
                floor: vals[5],
                current: f64::NAN,
            },
            v_true: v,
            accel_true: a,
            pos_true: x,
            load_true: self.load_kg / self.p.rated.rated_load_kg,
            force_true: force,
            voltage_true: self.p.voltage(v, force, kd),
            kd_true: kd,
            severity: fx.severity,
        };
        self.sink.truth(&row)?;
        self.summary.truth_rows += 1;
        if t >= self.next_day {
            (self.progress)((t - self.cfg.start_s) / 86_400.0);
            self.next_day += 86_400.0;
        }
        Ok(())
    }
}
