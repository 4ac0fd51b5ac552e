//! The evaluation's aggregates: per method and true mode, misses, delays, severities at
//! detection, mode isolation, false signals per elevator-year, flicker and persistence.

use serde::Serialize;

use super::metrics::MethodResult;
use super::suite::CaseResult;
use super::YEAR_DAYS;
use crate::mode::FaultMode;
use crate::sim::scenario::healthy_or_mode;

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
    /// liftwatch on machine faults: detections whose reported drift of the true mode lies
    /// within two of its standard errors of the truth, and detections with a drift at all.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub drift_within_2se: Option<(usize, usize)>,
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
                drift_within_2se: (method == "liftwatch" && machine).then(|| {
                    let z: Vec<f64> = rs.iter().filter_map(|r| r.drift_z).collect();
                    (z.iter().filter(|z| z.abs() <= 2.0).count(), z.len())
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
