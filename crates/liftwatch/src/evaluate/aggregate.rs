//! The evaluation's aggregates: per method and true mode, misses, delays, severities at
//! detection, mode isolation, false signals per elevator-year, flicker and persistence; and
//! over the whole suite, liftwatch's delays against the threshold method's and against the
//! oracle floor ([`DelayComparison`]).

use serde::Serialize;

use super::metrics::MethodResult;
use super::suite::CaseResult;
use crate::mode::FaultMode;
use crate::sample::YEAR_DAYS;
use crate::sim::scenario::healthy_or_mode;
use crate::stats::median;

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
/// healthy runs; every row counts false signals over its cases' pre-onset spans). The outage
/// cases, healthy machines whose car stops for hours, are a group of their own: the table
/// reports each on a line ([`super::metrics::OutageResult`]), so the healthy rows and the
/// threshold method's quiet elevators read as they did before those cases existed.
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
                .filter(|c| c.case.truth == truth && c.case.outage.is_none())
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

/// liftwatch's delays against another's over the same fault cases.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Versus {
    /// Cases with both delays.
    pub cases: usize,
    /// Median delay of liftwatch over them (days).
    pub liftwatch_median_days: f64,
    /// Median delay of the other over them (days).
    pub other_median_days: f64,
    /// The first median over the second: issue 8 asks at most 1/3 against the threshold.
    pub ratio_of_medians: f64,
    /// Median over the cases of liftwatch's delay over the other's, over the cases whose
    /// other delay is positive; `None` when there are none.
    pub median_ratio: Option<f64>,
}

impl Versus {
    /// The comparison of `pairs` (liftwatch's delay, the other's); `None` for no pairs.
    pub fn of(pairs: &[(f64, f64)]) -> Option<Versus> {
        if pairs.is_empty() {
            return None;
        }
        let ours: Vec<f64> = pairs.iter().map(|p| p.0).collect();
        let theirs: Vec<f64> = pairs.iter().map(|p| p.1).collect();
        let ratios: Vec<f64> = pairs
            .iter()
            .filter(|p| p.1 > 0.0)
            .map(|p| p.0 / p.1)
            .collect();
        let (a, b) = (median(&ours), median(&theirs));
        Some(Versus {
            cases: pairs.len(),
            liftwatch_median_days: a,
            other_median_days: b,
            ratio_of_medians: a / b,
            median_ratio: (!ratios.is_empty()).then(|| median(&ratios)),
        })
    }
}

/// liftwatch's delays on the suite's machine faults against the threshold method's and the
/// oracle floor's ([`super::floor`]). Sensor faults are left out: the threshold method is a
/// machine check (MODEL.md's conventional baseline), which "detects" a voltage sensor reading
/// 25 V high on its first sample as a voltage over its limit and names it friction, and the
/// oracle floor is a floor of the signatures' CUSUMs.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct DelayComparison {
    /// Against the threshold method, on every machine fault both detected.
    pub threshold: Option<Versus>,
    /// The same on the elevators where the threshold method raised no false signal in any
    /// run (before an onset or on the healthy run): elsewhere its first alarm after an onset
    /// may be its own flicker, which a busy morning raises with or without the fault (the
    /// drive-off 40-floor car's raised 8-10 in a healthy week), and its delay is no
    /// detection to compare with.
    pub threshold_quiet: Option<Versus>,
    /// Against the oracle floor, on the machine faults liftwatch detected that have one.
    pub floor: Option<Versus>,
}

/// One detected machine fault's delay beside a reference's (days after the onset).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct DelayPair {
    /// liftwatch's delay.
    pub liftwatch_days: f64,
    /// The reference's: the oracle floor, or the threshold method's first alarm.
    pub other_days: f64,
    /// The true mode.
    pub mode: FaultMode,
    /// Whether the threshold method raised no false signal in any run of the case's elevator
    /// (before an onset or on its healthy run).
    pub threshold_quiet: bool,
}

/// The machine faults liftwatch detected, beside the oracle floor (where the case has one)
/// and beside the threshold method (where it detected them too): what [`DelayComparison`]
/// summarises and the evaluation's figure draws.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DelayPairs {
    /// Beside the oracle floor.
    pub floor: Vec<DelayPair>,
    /// Beside the threshold method.
    pub threshold: Vec<DelayPair>,
}

/// The suite's [`DelayPairs`]: liftwatch is the first method of every case, the threshold
/// method the second.
pub fn delay_pairs(results: &[CaseResult]) -> DelayPairs {
    let delay = |c: &CaseResult, i: usize| c.methods.get(i).and_then(|m| m.delay_days);
    let quiet = |e: usize| {
        !results
            .iter()
            .filter(|c| c.case.elevator == e && c.case.outage.is_none())
            .any(|c| c.methods.get(1).is_some_and(|m| m.false_signals > 0))
    };
    let mut out = DelayPairs::default();
    for c in results {
        let (Some(mode), Some(ours)) = (c.case.truth.filter(|m| m.is_machine()), delay(c, 0))
        else {
            continue;
        };
        let pair = |other_days| DelayPair {
            liftwatch_days: ours,
            other_days,
            mode,
            threshold_quiet: quiet(c.case.elevator),
        };
        out.floor.extend(c.floor_delay_days.map(pair));
        out.threshold.extend(delay(c, 1).map(pair));
    }
    out
}

/// The suite's [`DelayComparison`], from its [`delay_pairs`].
pub fn compare_delays(results: &[CaseResult]) -> DelayComparison {
    let p = delay_pairs(results);
    let of = |pairs: &mut dyn Iterator<Item = &DelayPair>| {
        Versus::of(
            &pairs
                .map(|p| (p.liftwatch_days, p.other_days))
                .collect::<Vec<_>>(),
        )
    };
    DelayComparison {
        threshold: of(&mut p.threshold.iter()),
        threshold_quiet: of(&mut p.threshold.iter().filter(|p| p.threshold_quiet)),
        floor: of(&mut p.floor.iter()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::evaluate::Case;
    use crate::sim::Scenario;

    fn method(name: &'static str, delay: Option<f64>, false_signals: usize) -> MethodResult {
        MethodResult {
            delay_days: delay,
            ..MethodResult::bare(name, false_signals, 3.0)
        }
    }

    /// A case of `elevator` with liftwatch's and the threshold's delays, the threshold's
    /// false signals before the onset, and the floor.
    fn case(
        elevator: usize,
        truth: Option<FaultMode>,
        ours: Option<f64>,
        theirs: Option<f64>,
        noisy: usize,
        floor: Option<f64>,
    ) -> CaseResult {
        CaseResult {
            case: Case {
                name: format!("E{elevator} {truth:?}"),
                elevator,
                truth,
                scenario: Scenario::healthy(),
                sensor_fault: None,
                days: 7.0,
                onset_days: truth.map(|_| 3.0),
                outage: None,
            },
            trips: 1000,
            late_mean_z: 0.0,
            methods: vec![
                method("liftwatch", ours, 0),
                method("threshold", theirs, noisy),
            ],
            floor_delay_days: floor,
            seconds: 0.0,
        }
    }

    /// Machine faults only; the quiet comparison drops every case of an elevator whose
    /// threshold method raised a false signal in any of its runs; medians and per-case ratios.
    #[test]
    fn delays_compare_on_the_same_machine_faults_and_quiet_elevators() {
        let m = Some(FaultMode::Motor);
        let results = [
            case(0, m, Some(0.5), Some(2.0), 0, Some(0.25)),
            case(
                0,
                Some(FaultMode::Brake),
                Some(1.0),
                Some(2.0),
                0,
                Some(0.5),
            ),
            // A sensor fault: the threshold's first-sample alarm is no machine check.
            case(0, Some(FaultMode::Sensor), Some(0.01), Some(0.001), 0, None),
            case(1, None, None, None, 3, None),
            case(
                1,
                Some(FaultMode::Friction),
                Some(0.6),
                Some(0.3),
                0,
                Some(0.4),
            ),
            // liftwatch missed it: no pair with the floor or the threshold.
            case(1, m, None, Some(0.2), 0, Some(0.1)),
        ];
        let d = compare_delays(&results);
        let t = d.threshold.unwrap();
        assert_eq!(t.cases, 3);
        assert_eq!((t.liftwatch_median_days, t.other_median_days), (0.6, 2.0));
        assert!((t.ratio_of_medians - 0.3).abs() < 1e-12);
        assert_eq!(t.median_ratio, Some(0.5));
        let q = d.threshold_quiet.unwrap();
        assert_eq!(
            (q.cases, q.liftwatch_median_days, q.other_median_days),
            (2, 0.75, 2.0)
        );
        let f = d.floor.unwrap();
        assert_eq!((f.cases, f.median_ratio), (3, Some(2.0)));
        assert_eq!(compare_delays(&results[3..4]).floor, None);
        let pairs = delay_pairs(&results);
        assert_eq!(pairs.threshold.len(), 3);
        assert_eq!(
            pairs
                .threshold
                .iter()
                .map(|p| p.threshold_quiet)
                .collect::<Vec<_>>(),
            [true, true, false]
        );
        assert_eq!(Versus::of(&[(1.0, 0.0)]).unwrap().median_ratio, None);
    }
}
