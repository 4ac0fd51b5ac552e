//! Stages 3 and 5-7 as one streaming step: aligned sample in, monitor row out (paper, Sec. 4.3).
//!
//! ```text
//! Sample ─ FeatureTracker (lag 1) ─ FeatureRow ─ residuals r_U, r_F ─┬─ row
//!                                                                    └─ per trip: evidence
//!        ─ sensor plausibility ─────────────────────── trip verdict ─┴─ RiskTracker ─ AlarmState
//! ```
//!
//! Every caller (CLI, a server, the tests) drives the same [`Monitor::push`], so a batch run is
//! a loop over the online step and both give the same numbers. [`Method::Threshold`] swaps the
//! risk stage for the conventional fixed-threshold method of [`crate::baseline`] and keeps the
//! rows' shape.
//!
//! Resume: [`Monitor::state`] captures everything, including the sample whose row still waits
//! for its successor (the feature tracker's lag) and a trip in progress. A run that saves its
//! state instead of calling [`Monitor::finish`] and a next run that resumes from it write
//! exactly the rows one run over both inputs writes. The state records the identity of its
//! model; a state of another model is refused, which is also how acknowledging an alarm works:
//! refit, and monitoring starts afresh (see [`crate::alarm`]).
//!
//! Events: one per change of level (DATA.md §4), plus one when an episode that opened with
//! mode `unknown` gets its mode. The trip-level lens reacts within tens of trips, the
//! re-identification that names the mode within a few hundred, so an advisory first says
//! `unknown` and then, at the same level, `motor`, `brake` or `friction`.
//!
//! Sensor plausibility (DATA.md §4 `sensor`): a trip whose speed rose without the floor
//! indicator changing, that started on another floor than the previous trip ended, that lasted
//! longer than any healthy trip could (speed stuck), or during which the load reading left its
//! plausible range is not machine evidence. A load reading bit-identical over many door cycles
//! (a stuck cell) or a channel missing for long while the others report raises the `sensor`
//! advisory directly; so does a majority of implausible recent trips.

mod rows;

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::alarm::{diagnose, update_episode, AlarmState, Event, Evidence, FaultMode, Level};
use crate::baseline::Baseline;
use crate::error::{Error, Result};
use crate::features::{FeatureRow, FeatureTracker, Trip};
use crate::fit::FittedModel;
use crate::forecast::DriftHistory;
use crate::mode::MACHINE_MODES;
use crate::operation::{DayUsage, OperationEvent, OperationTracker};
use crate::output::write_atomic;
use crate::residual::{PredictionCache, Residuals};
use crate::risk::{
    friction_reference, heating_reference, Decision, DriftScale, Heating, RiskTracker,
    TripAccumulator,
};
use crate::sample::Sample;
use crate::sensor::{SensorCheck, SensorLimits};
use rows::TripSums;

pub use rows::{RowWriter, TimeFormat, TripRowWriter, TripSummary, CSV_HEADER, TRIP_CSV_HEADER};

// Indices of the per-mode arrays, in the order of `crate::mode::MACHINE_MODES`.
const MOTOR: usize = FaultMode::Motor as usize;
const BRAKE: usize = FaultMode::Brake as usize;
const FRICTION: usize = FaultMode::Friction as usize;

/// The parked readings witness a load cell's zero when they show at least this share of the
/// offset the changed trips show alone: a drift that began with the window shows about half
/// of its window's mean offset at parkings early in the window, and a shift of a few
/// hundredths of a per cent beside a drive fault is not the drive fault's explanation.
const WITNESS_SHARE: f64 = 0.25;

/// Version of the monitor state document.
pub const STATE_VERSION: u32 = 1;

/// Which method turns residuals into levels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Dual residuals, time-accumulated risk per fault mode (the paper's method).
    #[default]
    Pinn,
    /// Fixed thresholds on instantaneous signals (the paper's conventional baseline).
    Threshold,
}

impl Method {
    /// The method's name on the command line and in files: `pinn` or `threshold`.
    pub fn name(self) -> &'static str {
        match self {
            Method::Pinn => "pinn",
            Method::Threshold => "threshold",
        }
    }
}

impl std::str::FromStr for Method {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self> {
        match s {
            "pinn" => Ok(Method::Pinn),
            "threshold" => Ok(Method::Threshold),
            _ => Err(Error::InvalidConfig {
                field: "method",
                why: format!("`{s}`, expected `pinn` or `threshold`"),
            }),
        }
    }
}

/// One output row (DATA.md §4). `NaN` marks an empty field.
///
/// The event, the trip summary and the operation event are boxed: they come with one row in
/// tens to millions, and held inline they made every row 464 bytes instead of 128, copied
/// twice on every sample's way out of the step.
#[derive(Clone, Debug, PartialEq)]
pub struct MonitorRow {
    /// Time (s).
    pub time: f64,
    /// r_U (V).
    pub r_voltage: f64,
    /// r_F (N).
    pub r_force: f64,
    /// Combined risk (threshold method: alarm state 0/1).
    pub risk: f64,
    /// Motor risk (threshold method: voltage limit exceeded 0/1).
    pub risk_motor: f64,
    /// Brake risk (threshold method: 0, it has no brake check).
    pub risk_brake: f64,
    /// Friction risk (threshold method: friction limit exceeded 0/1).
    pub risk_friction: f64,
    /// Level after this sample.
    pub level: Level,
    /// Set when the level changed at this sample, or when an episode opened as `unknown`
    /// got its mode.
    pub event: Option<Box<Event>>,
    /// Extra column: combined scaled residual e.
    pub e: f64,
    /// Extra column: re-identified Kd change (percent).
    pub kd_drift_pct: f64,
    /// Extra column: re-identified friction change (percent).
    pub friction_drift_pct: f64,
    /// Extra column: re-identified brake drag (N).
    pub brake_drag_n: f64,
    /// The features stage's trip index of this sample, if moving ([`FeatureRow::trip`]); not
    /// written to the CSV.
    pub trip: Option<u32>,
    /// Set at the row where a trip is reported: the trip and its mean residuals (the rows
    /// of [`TripRowWriter`]).
    pub trip_end: Option<Box<TripSummary>>,
    /// An outage or door event of [`crate::operation`] handed out with this row (at most
    /// one per row; the rest wait for the next rows). Not written to the CSV.
    pub operation: Option<Box<OperationEvent>>,
}

impl MonitorRow {
    /// A row of nothing at time NaN: the place [`Monitor::push_into`] writes into.
    pub const EMPTY: MonitorRow = MonitorRow {
        time: f64::NAN,
        r_voltage: f64::NAN,
        r_force: f64::NAN,
        risk: f64::NAN,
        risk_motor: f64::NAN,
        risk_brake: f64::NAN,
        risk_friction: f64::NAN,
        level: Level::Normal,
        event: None,
        e: f64::NAN,
        kd_drift_pct: f64::NAN,
        friction_drift_pct: f64::NAN,
        brake_drag_n: f64::NAN,
        trip: None,
        trip_end: None,
        operation: None,
    };
}

/// Runs the streaming monitor of `method` over a whole series with no saved state: one row
/// per sample, in order. The batch form of [`Monitor::push`] that the CLI, the report, the demo
/// and the evaluation share.
pub fn run<'a>(
    model: &FittedModel,
    samples: impl IntoIterator<Item = &'a Sample>,
    method: Method,
) -> Vec<MonitorRow> {
    let mut m = Monitor::new(model, method);
    let mut rows: Vec<MonitorRow> = samples.into_iter().filter_map(|s| m.push(s)).collect();
    rows.extend(m.finish());
    rows
}

/// What a report or a demo is drawn from, computed once from a model and a series: its
/// features and both methods' rows over it, with the paper's method's events.
#[derive(Clone, Debug)]
pub struct Analysis {
    /// Features of the series, with the model's feature settings.
    pub features: crate::features::Features,
    /// Monitor rows of the paper's method.
    pub pinn: Vec<MonitorRow>,
    /// Monitor rows of the fixed-threshold baseline.
    pub threshold: Vec<MonitorRow>,
    /// The paper's method's events.
    pub events: Vec<Event>,
    /// The paper's method's state at the end of the series: what the verdict reads.
    pub state: MonitorState,
    /// Usage and availability of every day of the series (the state keeps only the last
    /// [`crate::operation::USAGE_DAYS`]).
    pub usage: Vec<DayUsage>,
    /// The outage and door events, in order.
    pub operation_events: Vec<OperationEvent>,
}

impl Analysis {
    /// Runs the features and both monitors over `series` ([`run`]).
    pub fn run(model: &FittedModel, series: &crate::sample::AlignedSeries) -> Self {
        // The caller holds the samples: none is copied.
        Analysis::run_keeping(model, series, f64::NEG_INFINITY, &mut |_| {})
            .unwrap_or_else(|e| unreachable!("a series in memory reads without error: {e}"))
    }

    /// Runs the features and both monitors over `history` in one pass, keeping what a report
    /// draws from time `from` on: the feature rows, the trips that start there, both methods'
    /// rows, the events and the days, with the samples themselves (returned beside it). The
    /// state is the whole history's, as the verdict reads it. A report of a long log holds
    /// only its last days this way (`liftwatch report --days`).
    ///
    /// # Errors
    /// What `history` fails with when it is read ([`crate::sample::History::read`]).
    pub fn run_from(
        model: &FittedModel,
        history: &dyn crate::sample::History,
        from: f64,
    ) -> Result<(Self, crate::sample::AlignedSeries)> {
        let mut series = crate::sample::AlignedSeries {
            step_s: history.step_s(),
            samples: Vec::new(),
        };
        let analysis =
            Analysis::run_keeping(model, history, from, &mut |s| series.samples.push(*s))?;
        Ok((analysis, series))
    }

    /// [`Analysis::run_from`]'s pass, handing each sample it keeps to `keep`.
    fn run_keeping(
        model: &FittedModel,
        history: &dyn crate::sample::History,
        from: f64,
        keep: &mut dyn FnMut(&Sample),
    ) -> Result<Self> {
        // NaN times (a row of a missing sample) are kept: nothing says they are earlier.
        let kept = |time: f64| time >= from || time.is_nan();
        let mut features = crate::features::Features::default();
        let mut pinn: Vec<MonitorRow> = Vec::new();
        let mut threshold: Vec<MonitorRow> = Vec::new();
        let mut usage: Vec<DayUsage> = Vec::new();
        let mut m = Monitor::new(model, Method::Pinn);
        let mut t = Monitor::new(model, Method::Threshold);
        crate::sample::pass(history, |samples| {
            let samples = samples.inspect(|s| {
                if kept(s.time) {
                    keep(s);
                }
                pinn.extend(m.push(s).filter(|r| kept(r.time)));
                // A day is copied when the next begins; outage seconds dated back into a day
                // already copied are taken again from the state below.
                let days = &m.state_ref().operation.days;
                if let (Some(&last), Some(&prev)) = (days.back(), days.iter().rev().nth(1)) {
                    if usage.last().map_or(true, |u| u.day < prev.day) && last.day > prev.day {
                        usage.push(prev);
                    }
                }
                threshold.extend(t.push(s).filter(|r| kept(r.time)));
            });
            for (row, trip) in crate::features::rows(samples, &model.features) {
                if kept(row.time) {
                    features.rows.push(row);
                }
                features.trips.extend(trip.filter(|t| kept(t.start_time)));
            }
        })?;
        pinn.extend(m.finish().into_iter().filter(|r| kept(r.time)));
        threshold.extend(t.finish().into_iter().filter(|r| kept(r.time)));
        let events = pinn
            .iter()
            .filter_map(|r| r.event.as_deref().copied())
            .collect();
        let operation_events = pinn
            .iter()
            .filter_map(|r| r.operation.as_deref().copied())
            .collect();
        let state = m.state();
        for d in &state.operation.days {
            match usage.iter_mut().find(|u| u.day == d.day) {
                Some(u) => *u = *d,
                None => usage.push(*d),
            }
        }
        let first_day = (from / crate::sample::DAY_S).floor();
        usage.retain(|u| u.day as f64 >= first_day);
        Ok(Analysis {
            features,
            pinn,
            threshold,
            events,
            state,
            usage,
            operation_events,
        })
    }
}

/// Everything a monitor carries from one sample to the next; a few KiB as JSON.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MonitorState {
    /// [`STATE_VERSION`].
    pub format_version: u32,
    /// [`crate::file::model_id`] of the model the state belongs to.
    pub model_id: String,
    /// The method in use.
    pub method: Method,
    features: FeatureTracker,
    risk: RiskTracker,
    alarm: AlarmState,
    trip: TripAccumulator,
    open_trip: Option<u32>,
    sensor: SensorCheck,
    baseline: Baseline,
    episode_mode: FaultMode,
    /// Residual sums of the trip in progress; states written before it start empty.
    #[serde(default)]
    trip_sums: TripSums,
    /// The winding's temperature state ([`Heating`]); states written before it was kept (or
    /// with the fixed lags of older models, `heating`, not read) start with a winding at
    /// ambient.
    #[serde(default)]
    winding: Heating,
    /// Samples seen.
    pub samples: u64,
    /// Time of the last sample seen (s), NaN before the first: input at or before it was
    /// already watched, and a run that feeds it again would count it twice.
    #[serde(with = "crate::exact", default = "crate::exact::nan")]
    pub last_time: f64,
    /// Complete trips seen.
    pub trips: u64,
    /// Trips refused as sensor-implausible.
    pub implausible_trips: u64,
    /// Events emitted.
    pub events: u64,
    /// Time of the event that opened the current episode (s), NaN at `normal`; states written
    /// before it was recorded read NaN.
    #[serde(with = "crate::exact", default = "crate::exact::nan")]
    pub episode_since: f64,
    /// The drifts per block of trips, for the time-to-maintenance forecast; empty in states
    /// written before it was kept (bounded: [`crate::forecast::MAX_POINTS`] blocks).
    #[serde(default)]
    pub drifts: DriftHistory,
    /// Door cycles, outages, usage per day and the door check ([`crate::operation`]); states
    /// written before it was kept start with nothing seen.
    #[serde(default)]
    pub operation: OperationTracker,
    /// Trips not taken as machine evidence because the car was serving the backlog of an
    /// outage ([`crate::operation::OUTAGE_BACKLOG_S`]); 0 in states written before.
    #[serde(default)]
    pub backlog_trips: u64,
}

/// The path of the first number of the risk stage's accumulators (its recursive
/// least-squares sums, R and the CUSUMs) that is not finite, if any: sums of finite trips, they
/// are finite in every state the monitor writes, and a NaN among them keeps the risk from ever
/// rising again. The latest assessment (`risk.last`) is left out: its drifts are NaN where
/// the decision holds no change, and the next trip forms it anew.
fn non_finite_accumulator(state: &serde_json::Value) -> Option<String> {
    use crate::limits::{walk_json, JsonPlace};
    let risk = state.get("risk")?.as_object()?;
    risk.iter()
        .filter(|(k, _)| k.as_str() != "last")
        .find_map(|(k, x)| {
            walk_json(x, &format!("risk.{k}"), &mut |at, place| match place {
                JsonPlace::Leaf(serde_json::Value::String(t))
                    if t.parse::<f64>().is_ok_and(|x| !x.is_finite()) =>
                {
                    Err(at.to_string())
                }
                _ => Ok(()),
            })
            .err()
        })
}

impl MonitorState {
    /// Whether this state continues `model`: its format is this build's and it records
    /// `model`'s identity ([`crate::file::model_id`]). The one check of [`Monitor::resume`]
    /// and of a reader of the state (`liftwatch status`).
    ///
    /// # Errors
    /// [`Error::StateMismatch`] naming both identities or both format versions.
    pub fn check_model(&self, model: &FittedModel) -> Result<()> {
        if self.format_version != STATE_VERSION {
            return Err(Error::StateMismatch(format!(
                "state format version {} is not {STATE_VERSION}",
                self.format_version
            )));
        }
        let id = crate::file::model_id(model);
        if self.model_id != id {
            return Err(Error::StateMismatch(format!(
                "state belongs to model {}, not to this model {id} (another model file, or a build before 2026-12, which took a model's identity otherwise); pass the model it was monitored with, or start afresh without the state",
                self.model_id
            )));
        }
        Ok(())
    }

    /// Reads a state file.
    ///
    /// # Errors
    /// [`Error::Io`] when unreadable, [`Error::BadDocument`] when it is not a monitor state
    /// of this version.
    pub fn load(path: &Path) -> Result<MonitorState> {
        let text =
            crate::limits::read_bounded(path, crate::limits::MAX_STATE_BYTES, "monitor state")?;
        MonitorState::from_slice(&text, path)
    }

    /// Reads a state document held in memory, as [`MonitorState::load`] does; `path` names
    /// it in messages.
    ///
    /// # Errors
    /// [`Error::BadDocument`] when it is not a monitor state of this version.
    pub fn from_slice(text: &[u8], path: &Path) -> Result<MonitorState> {
        let bad = |why: String| Error::BadDocument {
            path: path.into(),
            what: "monitor state",
            why,
        };
        // A byte-order mark, as an editor on Windows saves JSON, is not the document's.
        let text = text.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(text);
        let v: serde_json::Value = serde_json::from_slice(text).map_err(|e| bad(e.to_string()))?;
        let version = v.get("format_version").and_then(serde_json::Value::as_u64);
        if version != Some(u64::from(STATE_VERSION)) {
            let found = version.map_or("missing".to_string(), |n| n.to_string());
            return Err(bad(format!(
                "format_version {found}, expected {STATE_VERSION}"
            )));
        }
        if let Some(path) = non_finite_accumulator(&v) {
            return Err(bad(format!(
                "{path} is not a finite number, which no state the monitor writes holds there (edited or corrupted?): resumed, the risk would stay blind"
            )));
        }
        let state: MonitorState = serde_json::from_value(v).map_err(|e| bad(e.to_string()))?;
        let in_range = (-crate::ingest::MAX_ABS_TIME_S..=crate::ingest::MAX_ABS_TIME_S)
            .contains(&state.last_time);
        if state.samples > 0 && !in_range {
            return Err(bad(format!(
                "last_time is {} after {} samples, where no input time lies (|t| ≤ {:e} s): the time the state covers is lost (edited or corrupted?)",
                crate::error::number(state.last_time),
                state.samples,
                crate::ingest::MAX_ABS_TIME_S
            )));
        }
        Ok(state)
    }

    /// Writes the state atomically and durably ([`write_atomic`]).
    ///
    /// # Errors
    /// [`Error::Io`] when the file cannot be written.
    pub fn save(&self, path: &Path) -> Result<()> {
        let json =
            serde_json::to_vec(self).expect("a state of numbers and names always serialises");
        write_atomic(path, &json)
    }

    /// The current level.
    pub fn level(&self) -> Level {
        self.alarm.level()
    }

    /// The mode of the open episode (once the level is back at `normal`, the last one's:
    /// [`crate::verdict::Verdict`] says `unknown` there).
    pub fn episode_mode(&self) -> FaultMode {
        self.episode_mode
    }

    /// The channel the open `sensor` episode is about now, by the rule its events name it
    /// by; `None` outside such an episode or when nothing names one.
    pub fn sensor_channel(&self, model: &FittedModel) -> Option<crate::ingest::Signal> {
        if self.level() == Level::Normal {
            return None;
        }
        let witnessed = witnessed_mode(&self.risk.last.decision, &self.sensor, &model.sensor);
        sensor_channel(
            self.episode_mode,
            witnessed,
            &self.sensor,
            &model.sensor,
            self.last_time,
        )
    }

    /// The risk stage's latest assessment: risks, drifts with their errors, the decision.
    pub fn assessment(&self) -> &crate::risk::TripAssessment {
        &self.risk.last
    }

    /// Trips taken as machine evidence by the risk stage.
    pub fn risk_trips(&self) -> u64 {
        self.risk.trips
    }

    /// Trips of the longest change the sequential decision now holds (0 when none).
    pub fn held_window_trips(&self, cfg: &crate::risk::RiskConfig) -> u32 {
        self.risk.held_window_trips(cfg)
    }

    /// When the drifts' trends reach the advisory and alarm levels and each mode's physical
    /// limit, at the last sample seen: what the verdict and every event carry.
    pub fn forecast(&self, model: &FittedModel) -> crate::forecast::Forecast {
        crate::forecast::forecast(
            &self.drifts,
            &model.risk,
            &model.hybrid.elevator,
            friction_reference(&model.hybrid).0,
            self.level(),
            self.last_time,
            self.changed_since(&model.risk),
        )
    }

    /// Time at which the change the sequential decision now holds began (the block of its
    /// first changed trip), `None` when it holds none.
    pub fn changed_since(&self, cfg: &crate::risk::RiskConfig) -> Option<f64> {
        let held = self.risk.held_window_trips(cfg);
        if held == 0 {
            return None;
        }
        let first = self.drifts.trips.saturating_sub(u64::from(held)) + 1;
        self.drifts.time_of_trip(first)
    }
}

/// The model's aligned step, or alignment's default for a model without one (s).
fn model_step(model: &FittedModel) -> f64 {
    model
        .step_s
        .unwrap_or_else(|| crate::align::AlignConfig::default().step_s)
}

/// The streaming monitor: one aligned sample in, the row of the sample the feature tracker
/// releases out.
#[derive(Clone, Debug)]
pub struct Monitor {
    model: FittedModel,
    /// [`friction_reference`] of the model, computed once.
    friction: (f64, f64),
    /// [`DriftScale`] of the model, computed once.
    scale: DriftScale,
    /// [`heating_reference`] of the model and its winding's τ, computed once.
    thermal: (f64, f64),
    cache: PredictionCache,
    st: MonitorState,
    /// The aligned step (s): the model's, or alignment's default for a model written before
    /// the step was recorded (the CLI's step guard aligns at the same).
    step_s: f64,
    /// The decision's mode after the parked zero check's witness ([`witnessed_mode`]), with
    /// what it was judged on: the usable trips so far (the decision changes only with them)
    /// and the newest parking's time (the witnesses change only with it). The rows are per
    /// sample, the decision per trip: the witness is judged again only when either moved.
    /// Beside it the assessment's [`diagnose`] with that mode, which moves with the same two.
    witness: Option<((u64, Option<u64>), FaultMode, FaultMode)>,
}

/// The decision's mode once the parked zero check has been heard, the load cell's witness
/// (its readings since the changed trips began): a zero that moved the way and by a good part
/// of what the trips show makes the change the cell's, whatever the machine signatures could
/// not tell; one that plainly stayed takes the cell's name away from a change the trips gave
/// it.
fn witnessed_mode(d: &Decision, sensor: &SensorCheck, cfg: &SensorLimits) -> FaultMode {
    if !d.load_offset.is_finite() {
        return d.mode;
    }
    let Some((pct, se)) = sensor.load_zero_shift(cfg, d.window_start) else {
        return d.mode;
    };
    let need = WITNESS_SHARE * 100.0 * d.load_offset.abs();
    let shown = pct * d.load_offset.signum();
    let z = crate::sensor::ZERO_WITNESS_Z * se;
    if shown >= need.max(z) {
        FaultMode::Sensor
    } else if d.mode == FaultMode::Sensor && shown <= need - z {
        d.machine_mode
    } else {
        d.mode
    }
}

/// The channel a `sensor` episode is about at `time`: the one a channel check holds broken
/// ([`SensorCheck::channel`]), else the load cell when the isolation's witnessed mode
/// (`witnessed`, [`witnessed_mode`]) is `sensor`, its zero having explained the machine
/// evidence best; `None` outside a `sensor` episode or when nothing names one. The one rule
/// of the events and of the verdict.
fn sensor_channel(
    episode: FaultMode,
    witnessed: FaultMode,
    sensor: &SensorCheck,
    limits: &SensorLimits,
    time: f64,
) -> Option<crate::ingest::Signal> {
    if episode != FaultMode::Sensor {
        return None;
    }
    sensor
        .channel(limits, time)
        .or((witnessed == FaultMode::Sensor).then_some(crate::ingest::Signal::Load))
}

impl Monitor {
    /// A monitor at the healthy reference of `model`, no risk accumulated.
    pub fn new(model: &FittedModel, method: Method) -> Self {
        let st = MonitorState {
            format_version: STATE_VERSION,
            model_id: crate::file::model_id(model),
            method,
            features: FeatureTracker::new(model.features.clone()),
            risk: RiskTracker::new(&model.risk),
            alarm: AlarmState::default(),
            trip: TripAccumulator::default(),
            open_trip: None,
            sensor: SensorCheck::new(),
            baseline: Baseline::default(),
            episode_mode: FaultMode::Unknown,
            trip_sums: TripSums::default(),
            winding: Heating::default(),
            samples: 0,
            last_time: f64::NAN,
            trips: 0,
            implausible_trips: 0,
            events: 0,
            episode_since: f64::NAN,
            drifts: DriftHistory::default(),
            operation: OperationTracker::new(),
            backlog_trips: 0,
        };
        Monitor {
            model: model.clone(),
            friction: friction_reference(&model.hybrid),
            scale: DriftScale::of(&model.hybrid),
            thermal: (heating_reference(&model.hybrid), model.risk.winding.tau_s),
            cache: PredictionCache::default(),
            st,
            step_s: model_step(model),
            witness: None,
        }
    }

    /// Continues from a saved state.
    ///
    /// # Errors
    /// [`Error::StateMismatch`] when the state belongs to another model or version.
    pub fn resume(model: &FittedModel, state: MonitorState) -> Result<Monitor> {
        state.check_model(model)?;
        Ok(Monitor {
            model: model.clone(),
            friction: friction_reference(&model.hybrid),
            scale: DriftScale::of(&model.hybrid),
            thermal: (heating_reference(&model.hybrid), model.risk.winding.tau_s),
            cache: PredictionCache::default(),
            st: state,
            step_s: model_step(model),
            witness: None,
        })
    }

    /// The event as one JSON line (DATA.md §4, [`Event::to_json_line`]) with the forecast
    /// of its mode appended (`"forecast": {quantity, unit, trend, crossings}`) when it names
    /// a machine mode: when the drift is due to reach the next levels, as the event is
    /// raised. The one event line of the CLI and the service.
    pub fn event_line(&self, e: &Event) -> String {
        let line = e.to_json_line();
        let Some(m) = MACHINE_MODES.iter().position(|&m| m == e.mode) else {
            return line;
        };
        let fc = self.st.forecast(&self.model);
        let mode = serde_json::to_string(&fc.modes[m])
            .expect("a forecast of numbers and names always serialises");
        match line.strip_suffix('}') {
            Some(body) => format!(r#"{body},"forecast":{mode}}}"#),
            None => line,
        }
    }

    /// A copy of the state, to save and resume from.
    pub fn state(&self) -> MonitorState {
        self.st.clone()
    }

    /// The state, read-only (counters, level).
    pub fn state_ref(&self) -> &MonitorState {
        &self.st
    }

    /// Feeds one aligned sample; returns the row of the sample the feature tracker releases
    /// (the previous one: the tracker lags one sample).
    pub fn push(&mut self, x: &Sample) -> Option<MonitorRow> {
        let mut row = MonitorRow::EMPTY;
        self.push_into(x, &mut row).then_some(row)
    }

    /// [`Monitor::push`] into `out`: true when a row was written there. The streaming
    /// callers' per-sample path: the feature row and the monitor row are built in their
    /// places, not moved out of `Option`s (a copy of a row just stored field by field stalls
    /// the store forwarding on every sample: 7 % of a `monitor` run in `perf`).
    pub fn push_into(&mut self, x: &Sample, out: &mut MonitorRow) -> bool {
        self.st.samples = self.st.samples.saturating_add(1);
        self.st.last_time = x.time;
        if self.st.operation.open.is_some() {
            self.st.sensor.out_of_service();
        }
        self.st.sensor.sample(
            x,
            &self.model.sensor,
            self.model.features.moving_threshold_mps,
        );
        self.st.operation.push(
            x,
            self.step_s,
            self.model.features.moving_threshold_mps,
            self.model.operation.as_ref(),
        );
        let mut row = FeatureRow::MISSING;
        if !self.st.features.push_into(x, &mut row) {
            return false;
        }
        let trip = self.st.features.take_trip();
        if let Some(t) = &trip {
            self.st.operation.trip(t, self.model.operation.as_ref());
        }
        self.step(&row, trip, out);
        out.operation = self.st.operation.take_event().map(Box::new);
        true
    }

    /// The operation event as one JSON line (DATA.md §4, [`OperationEvent::to_json_line`]):
    /// an outage's start or end, or the door advisory raised or released.
    pub fn operation_event_line(&self, e: &OperationEvent) -> String {
        e.to_json_line()
    }

    /// End of data for good: the rows still held. Without it (a saved state instead), the
    /// held row is emitted first by the resumed run.
    pub fn finish(&mut self) -> Vec<MonitorRow> {
        let rows = self.st.features.finish();
        let n = rows.len();
        let mut out = Vec::with_capacity(n);
        for (i, row) in rows.iter().enumerate() {
            let trip = if i + 1 == n {
                self.st.features.take_trip()
            } else {
                None
            };
            if let Some(t) = &trip {
                self.st.operation.trip(t, self.model.operation.as_ref());
            }
            let mut r = MonitorRow::EMPTY;
            self.step(row, trip, &mut r);
            r.operation = self.st.operation.take_event().map(Box::new);
            out.push(r);
        }
        // The tracker drops a trip still running; so does the evidence.
        self.st.trip = TripAccumulator::default();
        self.st.open_trip = None;
        out
    }

    /// Residuals, trip bookkeeping, risk and level for one feature row, written into `out`
    /// (all but its operation event).
    fn step(&mut self, x: &FeatureRow, ended: Option<Trip>, out: &mut MonitorRow) {
        let model = &self.model.hybrid;
        let st = &mut self.st;
        let (res, pred) = if crate::residual::applicable(x) {
            let p = self.cache.predict(model, x);
            (Residuals::from_prediction(model, x, &p), Some(p))
        } else {
            (Residuals::MISSING, None)
        };
        if x.trip.is_some() && x.trip != st.open_trip {
            // A new trip; evidence of one cut by a gap (never reported) is dropped.
            st.trip = TripAccumulator::default();
            st.open_trip = x.trip;
        }
        st.winding.step_row(self.thermal, x, pred.as_ref());
        if let (Some(p), true) = (pred, x.s != 0 && x.trip.is_some()) {
            let heating = st.winding.basis(x.time);
            st.trip.push(model, self.friction, x, (&p, &res), heating);
        }
        if let Some(i) = x.trip {
            st.trip_sums.push(i, res.r_u, res.r_f, res.e);
        }
        let summary = ended.and_then(|t| st.trip_sums.finish(&t));
        if let Some(t) = ended {
            self.end_trip(&t);
        }
        let st = &mut self.st;
        let before = (st.alarm.level(), st.alarm.sensor());
        let sensor = st
            .sensor
            .verdict(&self.model.sensor, x.time, st.alarm.sensor());
        st.alarm.set_sensor(sensor);
        match st.method {
            Method::Pinn => self.pinn_row(x, &res, before, summary, out),
            Method::Threshold => self.threshold_row(x, &res, summary, out),
        }
    }

    /// The trip summary of a row at `level`, with the open episode's mode above `normal`.
    fn trip_end(&self, summary: Option<TripSummary>, level: Level) -> Option<Box<TripSummary>> {
        let mode = (level > Level::Normal).then_some(self.st.episode_mode);
        summary.map(|s| Box::new(TripSummary { mode, ..s }))
    }

    /// Closes the evidence of a reported trip and feeds the risk stage when plausible.
    fn end_trip(&mut self, t: &Trip) {
        let st = &mut self.st;
        st.trips = st.trips.saturating_add(1);
        let plausible = st.sensor.trip(
            t,
            &self.model.sensor,
            self.model.hybrid.elevator.floor_height(),
        );
        if st.open_trip != Some(t.index) {
            return;
        }
        st.open_trip = None;
        let Some(ev) = st.trip.finish(plausible) else {
            return;
        };
        // The risk stage and the drift history see the trip without the winding's heating.
        let ev = self.model.risk.winding.take_out(&ev);
        if st.operation.serving_backlog(t.start_time) {
            // Just back from an outage (or the rescue run of a stuck car): not machine
            // evidence, as crate::operation::OUTAGE_BACKLOG_S says why.
            st.backlog_trips = st.backlog_trips.saturating_add(1);
        } else if plausible {
            st.risk.push(&self.model.risk, &ev);
            st.drifts.push(&self.model.risk, &ev, ev.end);
        } else {
            st.implausible_trips = st.implausible_trips.saturating_add(1);
        }
    }

    /// The row of the paper's method into `out`; `before` is the level and the sensor
    /// override before this sample.
    fn pinn_row(
        &mut self,
        x: &FeatureRow,
        res: &Residuals,
        before: (Level, bool),
        summary: Option<TripSummary>,
        out: &mut MonitorRow,
    ) {
        let cfg = &self.model.risk;
        let st = &mut self.st;
        let key = (st.risk.trips, st.sensor.newest_zero_witness());
        let witnessed = |mode| {
            let mut w = st.risk.last;
            w.decision.mode = mode;
            w
        };
        let (mode, diagnosis) = match self.witness {
            Some((k, mode, diagnosis)) if k == key => (mode, diagnosis),
            _ => {
                let mode = witnessed_mode(&st.risk.last.decision, &st.sensor, &self.model.sensor);
                let diagnosis = diagnose(&witnessed(mode), cfg);
                self.witness = Some((key, mode, diagnosis));
                (mode, diagnosis)
            }
        };
        // The assessment with the witness's mode, copied only when the witness changed it.
        let copy;
        let a = if mode == st.risk.last.decision.mode {
            &st.risk.last
        } else {
            copy = witnessed(mode);
            &copy
        };
        let seq =
            st.alarm
                .raising_ratio(x.time, a.decision.ratio, diagnosis, a.decision.glr_alone());
        st.alarm.update_machine(a.risk, seq, cfg);
        let level = st.alarm.level();
        let mut event = None;
        if update_episode(&mut st.episode_mode, before, &st.alarm, a, cfg) {
            let evidence =
                Evidence::from_assessment(a, self.scale, st.risk.trips, st.implausible_trips);
            let channel = sensor_channel(
                st.episode_mode,
                a.decision.mode,
                &st.sensor,
                &self.model.sensor,
                x.time,
            );
            event = Some(Box::new(Event {
                time: x.time,
                level,
                mode: st.episode_mode,
                risk: a.risk,
                channel,
                evidence,
            }));
            st.events = st.events.saturating_add(1);
            if level == Level::Normal {
                st.episode_since = f64::NAN;
            } else if before.0 == Level::Normal {
                st.episode_since = x.time;
            }
        }
        let risk = [
            a.risk,
            a.risk_modes[MOTOR],
            a.risk_modes[BRAKE],
            a.risk_modes[FRICTION],
        ];
        let drifts = [
            100.0 * a.drift[MOTOR],
            100.0 * a.drift[FRICTION],
            self.scale.brake_n * a.drift[BRAKE],
        ];
        let trip_end = self.trip_end(summary, level);
        fill_row(out, (x, res), risk, drifts, (level, event, trip_end));
    }

    /// The row of the threshold method into `out`.
    fn threshold_row(
        &mut self,
        x: &FeatureRow,
        res: &Residuals,
        summary: Option<TripSummary>,
        out: &mut MonitorRow,
    ) {
        let v = self
            .st
            .baseline
            .push(&self.model.hybrid, &self.model.baseline, x);
        if v.event.is_some() {
            self.st.events = self.st.events.saturating_add(1);
        }
        let trip_end = self.trip_end(summary, v.level);
        fill_row(
            out,
            (x, res),
            [v.risk, v.risk_motor, 0.0, v.risk_friction],
            [f64::NAN; 3],
            (v.level, v.event.map(Box::new), trip_end),
        );
    }
}

/// Writes a monitor row into its place, field by field (the pattern names every field, so a
/// new one cannot be left out), its operation event none: the row of feature row `x` with
/// residuals `res`, risks (combined, motor, brake, friction), drifts (Kd %, friction %, brake
/// N), level, event and trip summary. A row built aside and copied in was read back in
/// 16-byte pieces just after its 8-byte stores: a store-forwarding stall on every sample,
/// two fifths of `Monitor::push_into`'s time in `perf`.
#[inline(always)]
fn fill_row(
    out: &mut MonitorRow,
    (x, res): (&FeatureRow, &Residuals),
    risk: [f64; 4],
    drifts: [f64; 3],
    (level, event, trip_end): (Level, Option<Box<Event>>, Option<Box<TripSummary>>),
) {
    let MonitorRow {
        time,
        r_voltage,
        r_force,
        risk: o_risk,
        risk_motor,
        risk_brake,
        risk_friction,
        level: o_level,
        event: o_event,
        e,
        kd_drift_pct,
        friction_drift_pct,
        brake_drag_n,
        trip,
        trip_end: o_trip_end,
        operation,
    } = out;
    *time = x.time;
    *r_voltage = res.r_u;
    *r_force = res.r_f;
    [*o_risk, *risk_motor, *risk_brake, *risk_friction] = risk;
    *o_level = level;
    *o_event = event;
    *e = res.e;
    [*kd_drift_pct, *friction_drift_pct, *brake_drag_n] = drifts;
    *trip = x.trip;
    *o_trip_end = trip_end;
    *operation = None;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::elevator::Elevator;
    use crate::ingest::Signal;
    use crate::residual::tests::{test_features, test_model as test_hybrid};
    use crate::sample::{DAY_S, HOUR_S};
    use crate::sim::{simulate, SensorFault, SimConfig};

    /// The unit-test hybrid model with uncalibrated later stages.
    fn test_model() -> FittedModel {
        FittedModel::uncalibrated(test_hybrid(), test_features())
    }

    fn samples(days: f64, seed: u64, fault: Option<SensorFault>) -> Vec<Sample> {
        let mut cfg = SimConfig::new(Elevator::new(1000.0, 1.75, 26), days, seed);
        cfg.sensor_fault = fault;
        simulate(&cfg)
            .expect("a valid simulation")
            .aligned()
            .samples
    }

    fn csv(rows: &[MonitorRow]) -> String {
        let mut w = RowWriter::new(Vec::new()).unwrap();
        for r in rows {
            w.write(r).unwrap();
        }
        String::from_utf8(w.into_inner().unwrap()).unwrap()
    }

    fn run_all(model: &FittedModel, method: Method, xs: &[Sample]) -> Vec<MonitorRow> {
        run(model, xs, method)
    }

    #[test]
    fn state_round_trip_equals_one_run() {
        // Prior-centre physics do not match the simulated elevator, so risk, levels and events
        // all move: the comparison covers every part of the state.
        let mut model = test_model();
        model.risk.advisory = 5.0;
        model.risk.alarm = 50.0;
        let xs = samples(0.4, 3, None);
        let mid_trip = xs
            .iter()
            .position(|x| x.time > 0.2 * DAY_S && x.speed > 1.0)
            .unwrap();
        for method in [Method::Pinn, Method::Threshold] {
            let whole = run_all(&model, method, &xs);
            assert_eq!(whole.len(), xs.len(), "one row per sample");
            let mut a = Monitor::new(&model, method);
            let mut rows: Vec<MonitorRow> =
                xs[..mid_trip].iter().filter_map(|x| a.push(x)).collect();
            let json = serde_json::to_string(&a.state()).unwrap();
            let state: MonitorState = serde_json::from_str(&json).unwrap();
            let mut b = Monitor::resume(&model, state).unwrap();
            rows.extend(xs[mid_trip..].iter().filter_map(|x| b.push(x)));
            rows.extend(b.finish());
            assert_eq!(csv(&rows), csv(&whole), "{method:?}");
            let events = |r: &[MonitorRow]| {
                r.iter()
                    .filter_map(|r| r.event.as_deref())
                    .map(Event::to_json_line)
                    .collect::<Vec<_>>()
            };
            assert_eq!(events(&rows), events(&whole));
            if method == Method::Pinn {
                assert!(
                    !events(&whole).is_empty(),
                    "the mismatched model must move the level"
                );
            }
        }
    }

    #[test]
    fn a_state_and_a_model_from_before_availability_still_work() {
        // A model without `operation` writes no such key, so its identity (and the states
        // saved with it) are those it had before; a state without `operation` or
        // `backlog_trips` resumes with nothing seen.
        let model = test_model();
        assert!(model.operation.is_none());
        let json = serde_json::to_value(&model).unwrap();
        assert!(json.get("operation").is_none());
        let xs = samples(0.05, 6, None);
        let mut m = Monitor::new(&model, Method::Pinn);
        for x in &xs[..1000] {
            let _ = m.push(x);
        }
        let mut state = serde_json::to_value(m.state()).unwrap();
        let obj = state.as_object_mut().unwrap();
        assert!(obj.remove("operation").is_some() && obj.remove("backlog_trips").is_some());
        let old: MonitorState = serde_json::from_value(state).unwrap();
        assert_eq!(old.operation.days.len(), 0);
        let mut b = Monitor::resume(&model, old).unwrap();
        for x in &xs[1000..] {
            let _ = b.push(x);
        }
        assert!(b.state_ref().operation.days.back().unwrap().observed_s > 0.0);
    }

    #[test]
    fn a_state_from_another_model_is_refused() {
        let model = test_model();
        let mut other = test_model();
        other.hybrid.parameters.kd *= 1.01;
        let state = Monitor::new(&model, Method::Pinn).state();
        assert!(matches!(
            Monitor::resume(&other, state.clone()),
            Err(Error::StateMismatch(_))
        ));
        // The one check a reader of the state (`status`) makes too: another format version.
        let mut newer = state.clone();
        newer.format_version += 1;
        assert!(matches!(
            newer.check_model(&model),
            Err(Error::StateMismatch(_))
        ));
        assert!(state.check_model(&model).is_ok());
        assert!(Monitor::resume(&model, state).is_ok());
    }

    #[test]
    fn a_state_with_a_non_finite_accumulator_or_time_is_refused() {
        let model = test_model();
        let mut m = Monitor::new(&model, Method::Pinn);
        for x in &samples(0.1, 4, None) {
            let _ = m.push(x);
        }
        assert!(m.state_ref().risk_trips() > 0, "the state has seen trips");
        let good = serde_json::to_value(m.state_ref()).unwrap();
        let read = |v: &serde_json::Value| {
            MonitorState::from_slice(&serde_json::to_vec(v).unwrap(), Path::new("s.json"))
        };
        // A state the monitor wrote reads back, NaN drifts of its last assessment and all.
        assert!(read(&good).is_ok());
        for (edit, named) in [
            (&["risk", "combined", "r"][..], "risk.combined.r"),
            (&["risk", "s2"][..], "risk.s2"),
            (&["last_time"][..], "last_time"),
        ] {
            let mut v = good.clone();
            let mut at = &mut v;
            for k in edit {
                at = &mut at[*k];
            }
            *at = "NaN".into();
            let err = read(&v).expect_err("a NaN there is refused").to_string();
            assert!(err.contains(named), "{err}");
        }
        let mut v = good.clone();
        v["risk"]["rls"]["a"][0] = "inf".into();
        let err = read(&v)
            .expect_err("an infinite sum is refused")
            .to_string();
        assert!(err.contains("risk.rls.a[0]"), "{err}");
        // A time no input can have, and a byte-order mark an editor put in front.
        let mut v = good.clone();
        v["last_time"] = 1e308.into();
        let err = read(&v)
            .expect_err("a time of 1e308 s is refused")
            .to_string();
        assert!(err.contains("last_time is 1e308"), "{err}");
        let mut bom = b"\xEF\xBB\xBF".to_vec();
        bom.extend(serde_json::to_vec(&good).unwrap());
        assert!(MonitorState::from_slice(&bom, Path::new("s.json")).is_ok());
    }

    #[test]
    fn state_is_a_few_kib() {
        let model = test_model();
        let xs = samples(0.1, 4, None);
        let mut m = Monitor::new(&model, Method::Pinn);
        for x in &xs {
            let _ = m.push(x);
        }
        let n = serde_json::to_vec(&m.state()).unwrap().len();
        assert!(n < 8 * 1024, "{n} bytes");
    }

    #[test]
    fn a_stuck_speed_is_reported_as_sensor_not_machine() {
        let mut model = test_model();
        // Machine risk cannot reach a level here: only the sensor checks can.
        model.risk.advisory = 1e30;
        model.risk.alarm = 1e31;
        let onset = 0.1 * DAY_S;
        let fault = SensorFault::StuckSpeed {
            onset_s: onset,
            duration_s: 3.0 * HOUR_S,
        };
        let xs = samples(0.3, 5, Some(fault));
        let mut m = Monitor::new(&model, Method::Pinn);
        let mut rows: Vec<MonitorRow> = xs.iter().filter_map(|x| m.push(x)).collect();
        rows.extend(m.finish());
        let events: Vec<Event> = rows
            .iter()
            .filter_map(|r| r.event.as_deref().copied())
            .collect();
        assert!(m.state_ref().implausible_trips > 0);
        let first = events
            .first()
            .expect("the stuck speed must raise the sensor advisory");
        assert_eq!(
            (first.level, first.mode, first.channel),
            (Level::Advisory, FaultMode::Sensor, Some(Signal::Speed))
        );
        assert!(first.time >= onset, "{events:?}");
        // And healthy data of the same seed raise nothing from the sensor checks.
        let healthy = run_all(&model, Method::Pinn, &samples(0.3, 5, None));
        assert!(healthy.iter().all(|r| r.level == Level::Normal));
    }

    #[test]
    fn a_speed_that_sticks_during_a_machine_advisory_is_an_event_of_its_own() {
        let mut model = test_model();
        // The machine's advisory stands from the first trip with any excess on (its release
        // asks R below half of 1e-300), so the stuck speed comes inside a machine episode.
        model.risk.advisory = 1e-300;
        model.risk.alarm = 1e300;
        let (onset, duration) = (0.2 * DAY_S, HOUR_S);
        let fault = SensorFault::StuckSpeed {
            onset_s: onset,
            duration_s: duration,
        };
        let xs = samples(0.3, 5, Some(fault));
        let rows = run_all(&model, Method::Pinn, &xs);
        let events: Vec<Event> = rows
            .iter()
            .filter_map(|r| r.event.as_deref().copied())
            .collect();
        let opened = events.first().expect("the machine's advisory");
        assert!(
            opened.time < onset && opened.mode != FaultMode::Sensor,
            "{events:?}"
        );
        let later: Vec<&Event> = events.iter().filter(|e| e.time >= onset).collect();
        assert!(
            later.iter().all(|e| e.level == Level::Advisory),
            "the level never changed: {events:?}"
        );
        let stuck = later.first().expect("the stuck speed must be an event");
        assert_eq!(
            (stuck.mode, stuck.channel),
            (FaultMode::Sensor, Some(Signal::Speed))
        );
        let back = later.get(1).expect("and so must its end");
        assert!(back.time > onset + 0.5 * duration && back.mode != FaultMode::Sensor);
        assert_eq!(later.len(), 2, "{events:?}");
        // What `status` says once the event was written: the sensor, and which, as the event.
        let mut m = Monitor::new(&model, Method::Pinn);
        // (The monitor holds one sample back for the central difference.)
        for x in xs.iter().take_while(|x| x.time <= stuck.time + 1.5) {
            let _ = m.push(x);
        }
        let v = crate::verdict::Verdict::new(&model, m.state_ref());
        assert_eq!(
            (v.level, v.mode, v.channel),
            (Level::Advisory, FaultMode::Sensor, Some(Signal::Speed))
        );
        // The headline names that sensor, and what to inspect is that sensor alone.
        assert!(
            v.lines()[0].contains(
                "sensors: the speed sensor (encoder) (speed channel); check the speed sensor \
                 (encoder) and its wiring: its data look wrong."
            ),
            "{}",
            v.lines()[0]
        );
        // And after the first trip that followed it: the car arrived at another floor than it
        // had left, travel the stuck speed hid, so the speed stays the channel named.
        let middle = 0.5 * (stuck.time + back.time);
        for x in xs
            .iter()
            .filter(|x| x.time > stuck.time + 1.5 && x.time < middle)
        {
            let _ = m.push(x);
        }
        assert!(m.state_ref().trips > 0);
        let v = crate::verdict::Verdict::new(&model, m.state_ref());
        assert_eq!(
            (v.mode, v.channel),
            (FaultMode::Sensor, Some(Signal::Speed))
        );
    }

    #[test]
    fn a_held_unnamed_change_is_not_reported_as_consistent_with_health() {
        let model = test_model();
        let mut m = Monitor::new(&model, Method::Pinn);
        for x in samples(0.05, 3, None).iter() {
            let _ = m.push(x);
        }
        let mut v = crate::verdict::Verdict::new(&model, m.state_ref());
        assert_eq!(v.level, Level::Normal);
        v.cusum_ratio = 0.4;
        assert!(v.lines()[0].contains(": consistent with the healthy reference"));
        // A crossing at `normal` is one held back unnamed (alarm::UNNAMED_RATIO).
        v.cusum_ratio = 1.31;
        let line = &v.lines()[0];
        assert!(
            line.contains(
                ", watching: a change the fault signatures cannot yet tell apart (G/h 1.31;"
            ) && !line.contains("consistent"),
            "{line}"
        );
    }

    #[test]
    fn a_voltage_offset_is_reported_as_the_voltage_sensor_within_a_few_stops() {
        let mut model = test_model();
        model.risk.advisory = 1e30;
        model.risk.alarm = 1e31;
        let thr = model.features.moving_threshold_mps;
        let rated_v =
            model
                .hybrid
                .parameters
                .voltage(1, model.hybrid.elevator.rated_speed_mps, 0.0);
        let mut sensor = model.sensor.clone();
        sensor.calibrate_rest_voltage(samples(0.5, 8, None), thr, rated_v);
        model.sensor = sensor;
        assert!(
            model.sensor.rest_voltage_v.is_some(),
            "half a day of stops calibrates it"
        );

        let onset = 0.3 * DAY_S;
        let fault = SensorFault::VoltageOffset {
            onset_s: onset,
            volts: 25.0,
        };
        let xs = samples(0.5, 9, Some(fault));
        let events: Vec<Event> = run_all(&model, Method::Pinn, &xs)
            .iter()
            .filter_map(|r| r.event.as_deref().copied())
            .collect();
        let first = events
            .first()
            .expect("the offset must raise the sensor advisory");
        assert_eq!(
            (first.level, first.mode, first.channel),
            (Level::Advisory, FaultMode::Sensor, Some(Signal::Voltage))
        );
        // Five stops past the onset by the CUSUM's arithmetic (2.5 of h = 12 a stop), so
        // within the six that follow it (the stops of a busy hour last about a minute).
        let stops_between = |a: f64, b: f64| {
            xs.windows(2)
                .filter(|w| {
                    w[1].time > a && w[1].time <= b && w[0].speed > thr && w[1].speed <= thr
                })
                .count()
        };
        assert!(first.time >= onset, "{events:?}");
        assert!(
            stops_between(onset, first.time) <= 6,
            "flagged after {} stops",
            stops_between(onset, first.time)
        );
        let healthy = run_all(&model, Method::Pinn, &samples(0.5, 9, None));
        assert!(healthy.iter().all(|r| r.level == Level::Normal));
    }

    #[test]
    fn csv_keeps_the_contract_column_order() {
        assert!(CSV_HEADER
            .starts_with("time,r_voltage,r_force,risk,risk_motor,risk_brake,risk_friction,level"));
        let r = MonitorRow {
            time: 1.0,
            r_voltage: f64::NAN,
            r_force: f64::NAN,
            risk: 0.5,
            risk_motor: 0.0,
            risk_brake: 0.0,
            risk_friction: 0.0,
            level: Level::Normal,
            event: None,
            e: f64::NAN,
            kd_drift_pct: 1.5,
            friction_drift_pct: f64::NAN,
            brake_drag_n: f64::NAN,
            trip: Some(3),
            trip_end: None,
            operation: None,
        };
        assert_eq!(
            csv(&[r]).lines().nth(1).unwrap(),
            "1,,,0.500,0.000,0.000,0.000,normal,,1.500,,"
        );
    }
}
