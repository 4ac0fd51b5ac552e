//! Evaluation, the metrics: per method and case the detection delay from the onset, the
//! true severity then, the false signals before it scaled to an elevator-year, the mode
//! named; per method and true mode their aggregates (paper, Sec. 5.4, made quantitative).
//!
//! ```text
//! delay       = (t_detect − t_onset)/day                  first detection at or after the onset
//! false/year  = false signals/(exposure days/365.25)      before the onset, or the whole healthy run
//! flicker     = threshold alarm activations, per trip, before it holds PERSISTENT_TRIPS trips
//! ```

use serde::Serialize;

use super::charts::{Chart, ChartCalibration};
use super::suite::{CaseResult, CaseSink};
use super::trips::TripSummary;
use super::{DAY_S, PERSISTENT_TRIPS, YEAR_DAYS};
use crate::alarm::Level;
use crate::mode::FaultMode;
use crate::sim::scenario::healthy_or_mode;

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
}

/// What the metrics of one case read: its timing, its truth and what its monitors kept.
pub(super) struct Metrics<'a> {
    /// Onset time (s); None when healthy.
    pub onset: Option<f64>,
    /// Span false signals are counted over (days).
    pub exposure_days: f64,
    /// What is really wrong; None when healthy.
    pub truth: Option<FaultMode>,
    /// The monitored run.
    pub sink: &'a CaseSink,
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
            method,
            delay_days,
            severity_at_detection,
            false_signals,
            exposure_days: self.exposure_days,
            false_per_year: false_signals as f64 / (self.exposure_days / YEAR_DAYS),
            mode: None,
            mode_correct: None,
            flicker: None,
            persistent_delay_days: None,
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
    /// for the fault that follows it.
    pub(super) fn liftwatch(&self) -> MethodResult {
        let mut level = Level::Normal;
        let mut false_signals = 0;
        let mut detected = None;
        let mut mode = None;
        for e in &self.sink.events {
            if level == Level::Normal && e.level > Level::Normal && self.before_onset(e.time) {
                false_signals += 1;
            }
            if detected.is_none() && e.level > level && !self.before_onset(e.time) {
                detected = Some(e.time);
                mode = Some(e.mode);
            }
            level = e.level;
        }
        let mut r = self.result("liftwatch", false_signals, detected);
        if self.truth.is_some() {
            r.mode = mode;
            r.mode_correct = mode.map(|m| self.mode_correct(m));
        }
        r
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

/// Aggregate of one method over the cases of one true mode.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Aggregate {
    /// The method.
    pub method: &'static str,
    /// The true mode; None for the healthy runs (written `healthy`).
    #[serde(with = "healthy_or_mode")]
    pub truth: Option<FaultMode>,
    /// Cases.
    pub cases: usize,
    /// Cases detected after the onset.
    pub detected: usize,
    /// Cases missed.
    pub missed: usize,
    /// Mean detection delay over detected cases (days).
    pub mean_delay_days: Option<f64>,
    /// Worst detection delay over detected cases (days).
    pub worst_delay_days: Option<f64>,
    /// Mean severity at detection.
    pub mean_severity_at_detection: Option<f64>,
    /// Detected cases whose named mode is right (None for methods that name none).
    pub mode_correct: Option<usize>,
    /// Sensor cases only: detected cases not blamed on a machine mode.
    pub not_machine: Option<usize>,
    /// False signals summed over the cases' exposure.
    pub false_signals: usize,
    /// Exposure (years).
    pub exposure_years: f64,
    /// False signals per elevator-year over that exposure.
    pub false_per_year: f64,
    /// Threshold method: mean flicker count.
    pub mean_flicker: Option<f64>,
    /// Threshold method: mean delay until the alarm is persistent, over the cases where it
    /// became persistent (days).
    pub mean_persistent_days: Option<f64>,
    /// Threshold method: cases where the alarm never became persistent.
    pub never_persistent: Option<usize>,
}

/// Aggregates per method and true mode (healthy rows carry the false-advisory rate of the
/// healthy runs; every row counts false signals over its cases' pre-onset spans).
pub fn aggregate(results: &[CaseResult]) -> Vec<Aggregate> {
    let mut out = Vec::new();
    for (mi, method) in ["liftwatch", "threshold", "cusum", "ewma"]
        .into_iter()
        .enumerate()
    {
        for truth in [
            None,
            Some(FaultMode::Motor),
            Some(FaultMode::Friction),
            Some(FaultMode::Brake),
            Some(FaultMode::Sensor),
        ] {
            let machine = truth.is_some_and(FaultMode::is_machine);
            let rs: Vec<&MethodResult> = results
                .iter()
                .filter(|c| c.case.truth == truth)
                .filter_map(|c| c.methods.get(mi))
                .collect();
            if rs.is_empty() {
                continue;
            }
            let delays: Vec<f64> = rs.iter().filter_map(|r| r.delay_days).collect();
            let sev: Vec<f64> = rs.iter().filter_map(|r| r.severity_at_detection).collect();
            let mean = |v: &[f64]| (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64);
            let names_mode = matches!(method, "liftwatch" | "threshold") && truth.is_some();
            let false_signals: usize = rs.iter().map(|r| r.false_signals).sum();
            let exposure_years = rs.iter().map(|r| r.exposure_days).sum::<f64>() / YEAR_DAYS;
            let flick: Vec<f64> = rs
                .iter()
                .filter_map(|r| r.flicker)
                .map(|f| f as f64)
                .collect();
            out.push(Aggregate {
                method,
                truth,
                cases: rs.len(),
                detected: delays.len(),
                missed: if truth.is_some() {
                    rs.len() - delays.len()
                } else {
                    0
                },
                mean_delay_days: mean(&delays),
                worst_delay_days: delays.iter().copied().reduce(f64::max),
                mean_severity_at_detection: mean(&sev),
                mode_correct: names_mode
                    .then(|| rs.iter().filter(|r| r.mode_correct == Some(true)).count()),
                not_machine: (names_mode && truth == Some(FaultMode::Sensor)).then(|| {
                    rs.iter()
                        .filter(|r| matches!(r.mode, Some(FaultMode::Sensor | FaultMode::Unknown)))
                        .count()
                }),
                false_signals,
                exposure_years,
                false_per_year: if exposure_years > 0.0 {
                    false_signals as f64 / exposure_years
                } else {
                    0.0
                },
                mean_flicker: if machine { mean(&flick) } else { None },
                mean_persistent_days: if method == "threshold" && machine {
                    let p: Vec<f64> = rs.iter().filter_map(|r| r.persistent_delay_days).collect();
                    mean(&p)
                } else {
                    None
                },
                never_persistent: (method == "threshold" && machine).then(|| {
                    rs.iter()
                        .filter(|r| r.persistent_delay_days.is_none())
                        .count()
                }),
            });
        }
    }
    out
}
