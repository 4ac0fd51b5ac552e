//! Evaluation, the metrics: per method and case the detection delay from the onset, the
//! true severity then, the false signals before it scaled to an elevator-year, the mode
//! named; per method and true mode their aggregates (paper, Sec. 5.4, made quantitative).
//!
//! ```text
//! delay       = (t_detect − t_onset)/day                  first detection at or after the onset
//!                                                         (a rise of the level; for a sensor
//!                                                         fault also a `sensor` event inside a
//!                                                         standing episode)
//! mode ok     = the true mode named at detection; for a sensor fault `sensor` and its channel
//! false/year  = false signals/(exposure days/365.25)      before the onset, or the whole healthy run
//! flicker     = threshold alarm activations, per trip, before it holds PERSISTENT_TRIPS trips
//! drift z     = (reported − true drift of the true mode)/its reported SE, at detection
//!               (and at the first alarm after the onset: `drift_z_alarm`)
//!               Kd % = 100·(kd_factor − 1), friction % = 100·(friction_factor − 1), brake N
//! leak z      = max over the other machine modes of |reported drift|/its SE at detection
//!               (their truth is no change): a fault of one mode showing as another's
//! ```
//!
//! The true brake drag is the simulator's downward drag; liftwatch's brake signature weighs
//! downward and braking trips alike, so the brake figure compares like with nearly like.

use serde::Serialize;
use std::path::PathBuf;

use super::charts::{Chart, ChartCalibration};
use super::floor::{floor_delay_s, oracle_threshold};
use super::trips::{TripGrouper, TripSummary};
use super::PERSISTENT_TRIPS;
use crate::alarm::{Event, Evidence, Level};
use crate::align::AlignedWriter;
use crate::align::SampleSink;
use crate::error::{Error, Result};
use crate::fit::FittedModel;
use crate::ingest::Signal;
use crate::mode::{FaultMode, MACHINE_MODES};
use crate::monitor::{Monitor, MonitorRow};
use crate::operation::{OperationEvent, Outage};
use crate::output::AtomicFile;
use crate::risk::DriftScale;
use crate::sample::{Sample, DAY_S, HOUR_S, YEAR_DAYS};
use crate::sim::logger::RawAligner;
use crate::sim::service::OutageTruth;
use crate::sim::{self, SimSink, TruthRow};

/// One method's result on one case.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MethodResult {
    /// `liftwatch`, `threshold`, `cusum` or `ewma`.
    pub method: &'static str,
    /// Detection delay from the onset (days); None when missed or healthy.
    pub delay_days: Option<f64>,
    /// True severity σ at detection (multiple of the mode's default effect).
    pub severity_at_detection: Option<f64>,
    /// Signals before the onset (the whole run when healthy).
    pub false_signals: usize,
    /// Span those false signals were counted over (days).
    pub exposure_days: f64,
    /// False signals per elevator-year.
    pub false_per_year: f64,
    /// The mode named at detection (None when the method names none or did not detect).
    pub mode: Option<FaultMode>,
    /// Whether the named mode is right: the true machine mode, or `sensor` for a sensor fault.
    pub mode_correct: Option<bool>,
    /// Threshold method only: isolated per-trip alarm activations after the onset before the
    /// alarm is persistent (or to the end of the run when it never is).
    pub flicker: Option<usize>,
    /// Threshold method only: delay until the alarm is persistent (days).
    pub persistent_delay_days: Option<f64>,
    /// liftwatch on machine faults only: (reported − true drift of the true mode) over the
    /// reported standard error, at detection.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub drift_z: Option<f64>,
    /// The same at the first alarm after the onset, when the run reached one: the drift an
    /// engineer reads when the work is due, later on a ramp than the detection.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub drift_z_alarm: Option<f64>,
    /// liftwatch on machine faults only: the largest |drift|/SE of the other two machine
    /// modes at detection, whose truth is no change.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub leak_z: Option<f64>,
    /// liftwatch only: door advisories raised over the whole run. The suite's doors are
    /// healthy throughout, so every one is a nuisance.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub door_advisories: Option<usize>,
    /// liftwatch only: outages reported over the whole run (out of service or stuck). Only an
    /// outage case's car is ever out of service, so every other one is a nuisance.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub outages: Option<usize>,
    /// liftwatch on an outage case only: how its outage was reported.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub outage: Option<OutageResult>,
    /// liftwatch only: every outage it reported, so that a false one in the table can be read
    /// back in `evaluation.json` (when, where, after how many expected trips).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub outage_reports: Vec<Outage>,
    /// liftwatch only: every event of the run (level changes, mode named, evidence), so that
    /// a false advisory or a wrong mode in the table can be read back in `evaluation.json`.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub events: Vec<Event>,
}

impl MethodResult {
    /// The result of `method` with `false_signals` over `exposure_days` and nothing detected
    /// or named yet: what each method's metrics fill in.
    pub fn bare(method: &'static str, false_signals: usize, exposure_days: f64) -> MethodResult {
        MethodResult {
            method,
            delay_days: None,
            severity_at_detection: None,
            false_signals,
            exposure_days,
            false_per_year: false_signals as f64 / (exposure_days / YEAR_DAYS),
            mode: None,
            mode_correct: None,
            flicker: None,
            persistent_delay_days: None,
            drift_z: None,
            drift_z_alarm: None,
            leak_z: None,
            door_advisories: None,
            outages: None,
            outage: None,
            outage_reports: Vec::new(),
            events: Vec::new(),
        }
    }
}

/// How liftwatch reported an outage case's outage.
///
/// ```text
/// reported      a reported outage overlaps the true one (its start before the true end, its
///               end, or none yet, after the true start)
/// after h       (t_concluded − t_true start)/h: how long the owner waited to hear of it
/// start error   t_reported start − t_true start (s): the true start is the end of the car's
///               last door cycle, or the stuck car's stop; the report's the car's last motion
/// end error     t_reported end − t_true end (s): when the car moved again
/// false         reports that overlap no true outage (a freed car called stuck again)
/// ```
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct OutageResult {
    /// The outage as the simulator made it.
    pub truth: OutageTruth,
    /// The first report that overlaps it; None when it was missed.
    pub reported: Option<Outage>,
    /// Hours from the true start to the report's conclusion.
    pub after_h: Option<f64>,
    /// The report's start less the true start (s).
    pub start_error_s: Option<f64>,
    /// The report's end less the true end (s); None when missed or never ended.
    pub end_error_s: Option<f64>,
    /// Whether the report named the true kind (out of service, stuck between floors).
    pub kind_correct: Option<bool>,
    /// Reports that overlap no true outage.
    pub false_reports: usize,
}

impl OutageResult {
    /// The result for the true outage `truth` among the run's `reports`.
    pub fn of(truth: &OutageTruth, reports: &[Outage]) -> OutageResult {
        // An open report's end is NaN: it overlaps whatever started before it.
        let overlaps =
            |o: &Outage| o.start <= truth.end_s && (o.end.is_nan() || o.end >= truth.start_s);
        let reported = reports.iter().find(|o| overlaps(o)).copied();
        OutageResult {
            truth: truth.clone(),
            after_h: reported.map(|o| (o.detected_at - truth.start_s) / HOUR_S),
            start_error_s: reported.map(|o| o.start - truth.start_s),
            end_error_s: reported
                .map(|o| o.end - truth.end_s)
                .filter(|e| e.is_finite()),
            kind_correct: reported.map(|o| o.kind == truth.kind),
            false_reports: reports.iter().filter(|o| !overlaps(o)).count(),
            reported,
        }
    }
}

/// What the metrics of one case read: its timing, its truth and what its monitors kept.
pub(super) struct Metrics<'a> {
    /// Onset time (s); None when healthy.
    pub onset: Option<f64>,
    /// Span false signals are counted over (days).
    pub exposure_days: f64,
    /// What is really wrong; None when healthy.
    pub truth: Option<FaultMode>,
    /// The broken channel of a sensor fault: a `sensor` event is right only when it names it.
    pub channel: Option<Signal>,
    /// The monitored run.
    pub sink: &'a CaseSink,
    /// The degradation, for the true drift at detection.
    pub scenario: &'a sim::Scenario,
    /// The plant's true F_c (N), which scales the brake's drag.
    pub f_c: f64,
    /// The plant's true friction at the rated speed, F_c + c·v_r (N): what a friction
    /// change is a share of, in the newtons the events report it in.
    pub friction_n: f64,
    /// The outages the simulator made (an outage case's one; none elsewhere).
    pub outages: &'a [OutageTruth],
}

impl Metrics<'_> {
    fn result(
        &self,
        method: &'static str,
        false_signals: usize,
        detected: Option<f64>,
    ) -> MethodResult {
        let (delay_days, severity_at_detection) = match (self.onset, detected) {
            (Some(o), Some(t)) => (Some((t - o) / DAY_S), Some(self.sink.severity_at(t))),
            _ => (None, None),
        };
        MethodResult {
            delay_days,
            severity_at_detection,
            ..MethodResult::bare(method, false_signals, self.exposure_days)
        }
    }

    fn before_onset(&self, t: f64) -> bool {
        self.onset.map_or(true, |o| t < o)
    }

    /// The named mode is right when it is the true one (`sensor` for a sensor fault); on a
    /// healthy run no mode is right.
    fn mode_correct(&self, m: FaultMode) -> bool {
        self.truth == Some(m)
    }

    /// Detection is the first rise of the level (normal → advisory, or an escalation) at or
    /// after the onset; an advisory raised before the onset is a false one and earns no credit
    /// for the fault that follows it. A sensor fault is also detected by the first `sensor`
    /// event at or after the onset that keeps a standing level: a channel failing inside a
    /// machine episode, which the monitor reports as an event of its own
    /// ([`crate::alarm::update_episode`]) though the level cannot rise, or a standing
    /// `unknown` episode named `sensor`. The baselines have no such events, so they earn no
    /// such credit.
    pub(super) fn liftwatch(&self) -> MethodResult {
        let mut level = Level::Normal;
        let mut false_signals = 0;
        let mut detected = None;
        let mut mode = None;
        let mut at = None;
        for e in &self.sink.events {
            if level == Level::Normal && e.level > Level::Normal && self.before_onset(e.time) {
                false_signals += 1;
            }
            let sensor_inside = self.truth == Some(FaultMode::Sensor)
                && e.mode == FaultMode::Sensor
                && e.level == level
                && level > Level::Normal;
            if detected.is_none()
                && (e.level > level || sensor_inside)
                && !self.before_onset(e.time)
            {
                detected = Some(e.time);
                mode = Some(e.mode);
                at = Some(e);
            }
            level = e.level;
        }
        let mut r = self.result("liftwatch", false_signals, detected);
        r.door_advisories = Some(self.sink.door_advisories);
        r.outages = Some(self.sink.outages.len());
        r.outage = self
            .outages
            .first()
            .map(|t| OutageResult::of(t, &self.sink.outages));
        if self.truth.is_some() {
            r.mode = mode;
            r.mode_correct = mode.map(|m| {
                self.mode_correct(m)
                    && (m != FaultMode::Sensor || at.and_then(|e| e.channel) == self.channel)
            });
            r.drift_z = at.and_then(|e| self.drift_z(e));
            r.leak_z = at.and_then(|e| self.leak_z(e));
            r.drift_z_alarm = self
                .sink
                .events
                .iter()
                .find(|e| e.level == Level::Alarm && !self.before_onset(e.time))
                .and_then(|e| self.drift_z(e));
        }
        r.events = self.sink.events.clone();
        r.outage_reports = self.sink.outages.clone();
        r
    }

    /// The largest |drift|/SE of the machine modes other than the true one at the event `e`.
    fn leak_z(&self, e: &Event) -> Option<f64> {
        let truth = self.truth.filter(|t| t.is_machine())?;
        MACHINE_MODES
            .into_iter()
            .filter(|m| *m != truth)
            .filter_map(|m| reported_drift(&e.evidence, m))
            .map(|(d, se)| (d / se).abs())
            .filter(|z| z.is_finite())
            .reduce(f64::max)
    }

    /// (reported − true)/SE of the true machine mode's drift at the event `e`.
    fn drift_z(&self, e: &Event) -> Option<f64> {
        let (got, se) = reported_drift(&e.evidence, self.truth?)?;
        let z = (got - self.true_drift(e.time)?) / se;
        z.is_finite().then_some(z)
    }

    /// The true machine mode's drift at `t` in the units an event reports it (Kd %, friction
    /// N at the rated speed, brake drag N); `None` on a healthy or sensor case.
    fn true_drift(&self, t: f64) -> Option<f64> {
        let fx = self.scenario.effects_at(t, self.f_c);
        match self.truth? {
            FaultMode::Motor => Some(100.0 * (fx.kd_factor - 1.0)),
            FaultMode::Friction => Some(self.friction_n * (fx.friction_factor - 1.0)),
            FaultMode::Brake => Some(fx.brake_drag_n),
            FaultMode::Sensor | FaultMode::Unknown | FaultMode::Door => None,
        }
    }

    /// The oracle floor of this case's delay (days, [`super::floor`]): the CUSUM of the true
    /// mode's signature that knows the drift at every trip, with `model`'s trip noise and
    /// false-advisory budget. `None` on a healthy or sensor case, for a model without the
    /// sequential decision or its calibration, and when the trips never gather the evidence.
    pub(super) fn floor_delay_days(&self, model: &FittedModel) -> Option<f64> {
        let onset = self.onset?;
        let mode = self.truth.filter(|m| m.is_machine())?;
        let seq = model.risk.sequential.as_ref()?;
        let report = model.calibration.as_ref()?;
        let h = oracle_threshold(
            report.trips_per_year,
            report.target_false_advisories_per_year,
        )?;
        // The reported unit per unit of the signature's coefficient (`crate::risk::DriftScale`).
        let scale = DriftScale::of(&model.hybrid);
        let unit = match mode {
            FaultMode::Motor => 100.0,
            FaultMode::Friction => scale.friction_n,
            _ => scale.brake_n,
        };
        let m = mode as usize;
        let per_coefficient = (seq.info[m] / seq.s2[m]).sqrt();
        let size = |t: f64| {
            self.true_drift(t)
                .map_or(0.0, |d| d / unit * per_coefficient)
        };
        floor_delay_s(self.sink.trips.iter().map(|t| t.end), onset, h, size).map(|s| s / DAY_S)
    }

    /// The threshold method: detection at its first alarm after the onset, flicker and
    /// persistence per trip, the mode from the limit exceeded more often.
    pub(super) fn threshold(&self) -> MethodResult {
        let sink = self.sink;
        let false_signals = sink
            .thr_activations
            .iter()
            .filter(|&&t| self.before_onset(t))
            .count();
        let Some(o) = self.onset else {
            return self.result("threshold", false_signals, None);
        };
        let after: Vec<&TripSummary> = sink.thr_trips.iter().filter(|t| t.end >= o).collect();
        let detected = after
            .iter()
            .map(|t| t.first_alarm)
            .find(|t| t.is_finite())
            .map(|t| t.max(o));
        let flags: Vec<bool> = after.iter().map(|t| t.first_alarm.is_finite()).collect();
        let persistent = (0..flags.len()).find(|&k| {
            k + PERSISTENT_TRIPS <= flags.len() && flags[k..k + PERSISTENT_TRIPS].iter().all(|&a| a)
        });
        let until = persistent.unwrap_or(flags.len());
        let flicker = (0..until)
            .filter(|&k| flags[k] && (k == 0 || !flags[k - 1]))
            .count();
        // The mode is read over the flickering phase and the first persistent trips.
        let counted = persistent.map_or(after.len(), |p| (p + PERSISTENT_TRIPS).min(after.len()));
        let (motor, fric) = after[..counted]
            .iter()
            .fold((0, 0), |(m, f), t| (m + t.motor_hits, f + t.friction_hits));
        let mut out = self.result("threshold", false_signals, detected);
        if detected.is_some() {
            let mode = match motor.cmp(&fric) {
                std::cmp::Ordering::Greater => FaultMode::Motor,
                std::cmp::Ordering::Less => FaultMode::Friction,
                std::cmp::Ordering::Equal => FaultMode::Unknown,
            };
            out.mode = Some(mode);
            out.mode_correct = Some(self.mode_correct(mode));
        }
        if self.truth.is_some_and(FaultMode::is_machine) {
            out.flicker = Some(flicker);
            out.persistent_delay_days = persistent.map(|k| (after[k].end - o) / DAY_S);
        }
        out
    }

    /// A control chart on the standardised trip means: detection at its first signal after
    /// the onset.
    pub(super) fn chart<C: Chart>(
        &self,
        method: &'static str,
        mut c: C,
        cal: &ChartCalibration,
    ) -> MethodResult {
        let mut false_signals = 0;
        let mut detected = None;
        for t in &self.sink.trips {
            if c.signal(cal.standardise(t.mean_e_u)) {
                if self.before_onset(t.end) {
                    false_signals += 1;
                } else if detected.is_none() {
                    detected = Some(t.end);
                }
            }
        }
        self.result(method, false_signals, detected)
    }
}

/// The monitors of one case and what the metrics need of them: it receives the aligned
/// samples ([`SampleSink`], from [`AlignedLog`]) and the true severity per grid second.
pub(super) struct CaseSink {
    pub(super) pinn: Monitor,
    pub(super) thr: Monitor,
    pub(super) seg_pinn: TripGrouper,
    pub(super) seg_thr: TripGrouper,
    /// Trips of the liftwatch monitor's rows, in order.
    pub(super) trips: Vec<TripSummary>,
    /// Trips of the threshold monitor's rows, in order.
    pub(super) thr_trips: Vec<TripSummary>,
    /// Events of the liftwatch monitor.
    pub(super) events: Vec<Event>,
    /// Door advisories the liftwatch monitor raised.
    pub(super) door_advisories: usize,
    /// Outages the liftwatch monitor reported, each with its end once the car moved again.
    pub(super) outages: Vec<Outage>,
    /// Times the threshold method's alarm switched on.
    pub(super) thr_activations: Vec<f64>,
    pub(super) thr_prev: Level,
    /// True severity σ per second from the start (f32 keeps a month in a few MB).
    pub(super) severity: Vec<f32>,
    pub(super) start: f64,
    /// The aligned samples the monitors watch, written as they come (`--keep-runs`), and the
    /// file's path.
    pub(super) kept: Option<KeptLog>,
}

/// A case's aligned log being written for `--keep-runs` ([`super::SuiteConfig::keep_runs`]).
pub(super) struct KeptLog {
    path: PathBuf,
    writer: Option<AlignedWriter<AtomicFile>>,
}

impl KeptLog {
    /// A log to be written at `path` once the first sample says whether a current column comes.
    pub(super) fn new(path: PathBuf) -> KeptLog {
        KeptLog { path, writer: None }
    }

    fn start(&mut self, has_current: bool) -> Result<()> {
        let file = AtomicFile::create_data(&self.path)?;
        let writer = AlignedWriter::new(file, has_current).map_err(|e| Error::io(&self.path, e))?;
        self.writer = Some(writer);
        Ok(())
    }

    fn push(&mut self, s: &Sample) -> Result<()> {
        match self.writer.as_mut() {
            Some(w) => w.write(s).map_err(|e| Error::io(&self.path, e)),
            None => Ok(()),
        }
    }

    /// Commits the file into place.
    pub(super) fn commit(self) -> Result<()> {
        match self.writer {
            Some(w) => w.finish().map_err(|e| Error::io(&self.path, e))?.commit(),
            None => Ok(()),
        }
    }
}

impl CaseSink {
    fn pinn_row(&mut self, r: &MonitorRow) {
        if let Some(e) = r.event.as_deref() {
            self.events.push(*e);
        }
        match r.operation.as_deref() {
            Some(OperationEvent::Door { raised: true, .. }) => self.door_advisories += 1,
            Some(OperationEvent::OutageStart(o)) => self.outages.push(*o),
            Some(OperationEvent::OutageEnd(o)) => {
                match self.outages.iter_mut().rfind(|k| k.start == o.start) {
                    Some(k) => *k = *o,
                    None => self.outages.push(*o),
                }
            }
            _ => {}
        }
        self.trips.extend(self.seg_pinn.push(r));
    }

    fn thr_row(&mut self, r: &MonitorRow) {
        if r.level == Level::Alarm && self.thr_prev != Level::Alarm {
            self.thr_activations.push(r.time);
        }
        self.thr_prev = r.level;
        self.thr_trips.extend(self.seg_thr.push(r));
    }

    pub(super) fn finish(&mut self) {
        for r in self.pinn.finish() {
            self.pinn_row(&r);
        }
        for r in self.thr.finish() {
            self.thr_row(&r);
        }
        self.trips.extend(self.seg_pinn.close());
        self.thr_trips.extend(self.seg_thr.close());
    }

    pub(super) fn severity_at(&self, t: f64) -> f64 {
        let i = (t - self.start).round();
        if i < 0.0 {
            return 0.0;
        }
        self.severity
            .get(i as usize)
            .or(self.severity.last())
            .map_or(f64::NAN, |&s| f64::from(s))
    }

    /// Keeps the true severity of one grid second, indexed by its time: the aligned samples
    /// lag the truth by the aligner's reorder window and may start a second later, so the
    /// two are joined by time ([`CaseSink::severity_at`]), never by order.
    fn truth(&mut self, row: &TruthRow) {
        let i = (row.sample.time - self.start).round().max(0.0) as usize;
        if self.severity.len() <= i {
            let last = self.severity.last().copied().unwrap_or(0.0);
            self.severity.resize(i + 1, last);
        }
        self.severity[i] = row.severity as f32;
    }
}

impl SampleSink for CaseSink {
    type Error = Error;

    fn start(&mut self, has_current: bool) -> Result<()> {
        // The streaming pass never reads its input again (a late row is an error, see
        // `sim::logger::RawAligner`), so this comes once, before any sample.
        match self.kept.as_mut() {
            Some(k) => k.start(has_current),
            None => Ok(()),
        }
    }

    fn push(&mut self, sample: &Sample) -> Result<()> {
        if let Some(k) = self.kept.as_mut() {
            k.push(sample)?;
        }
        let mut r = MonitorRow::EMPTY;
        if self.pinn.push_into(sample, &mut r) {
            self.pinn_row(&r);
        }
        let mut r = MonitorRow::EMPTY;
        if self.thr.push_into(sample, &mut r) {
            self.thr_row(&r);
        }
        Ok(())
    }
}

/// What a case's monitors are fed, as the simulator produces it: the raw log aligned by the
/// one aligner ([`RawAligner`], the streaming pass of `liftwatch align`), as a user would
/// have it, not the sensors read at the grid instant ([`TruthRow::sample`]), which no aligner
/// can make of a log whose clocks are phase-shifted: its trip edges and accelerations carry
/// no interpolation error, and the evaluation must be no easier than the field. Memory stays
/// bounded by the aligner's reorder window.
pub(super) struct AlignedLog<'a> {
    aligner: RawAligner,
    sink: &'a mut CaseSink,
}

impl<'a> AlignedLog<'a> {
    pub(super) fn new(sink: &'a mut CaseSink) -> Result<Self> {
        Ok(AlignedLog {
            aligner: RawAligner::new()?,
            sink,
        })
    }

    /// Aligns the end of the log into the monitors (which the caller then finishes).
    pub(super) fn finish(mut self) -> Result<()> {
        self.aligner.flush(self.sink)
    }
}

impl SimSink for AlignedLog<'_> {
    fn raw(&mut self, row: sim::RawRow) -> Result<()> {
        self.aligner.push(&row, self.sink)
    }

    fn truth(&mut self, row: &TruthRow) -> Result<()> {
        self.sink.truth(row);
        Ok(())
    }
}

/// A machine mode's drift and its standard error as an event reports them (Kd %, friction N
/// at rated speed, brake drag N); `None` for the other modes. Friction is judged in newtons,
/// the quantity the data determine (`risk::DriftScale` says why its percent is not).
fn reported_drift(ev: &Evidence, m: FaultMode) -> Option<(f64, f64)> {
    match m {
        FaultMode::Motor => Some((ev.kd_drift_pct, ev.kd_drift_se_pct)),
        FaultMode::Friction => Some((ev.friction_drift_n, ev.friction_drift_se_n)),
        FaultMode::Brake => Some((ev.brake_drag_n, ev.brake_drag_se_n)),
        FaultMode::Sensor | FaultMode::Unknown | FaultMode::Door => None,
    }
}
