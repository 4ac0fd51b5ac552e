//! Evaluation, the text table: one line per case (delay, severity, mode, flicker and false
//! signals per method), then one per method and true mode with the aggregates.

use super::aggregate::{DelayComparison, Versus};
use super::metrics::MethodResult;
use super::suite::OUTAGE_START_H;
use super::Evaluation;
use crate::mode::FaultMode;
use crate::operation::OutageKind;
use crate::sample::{HOUR_S, YEAR_DAYS};
use crate::sim::truth_name;

/// A figure with `prec` decimals, `-` when absent.
fn opt(x: Option<f64>, prec: usize) -> String {
    x.map_or_else(|| "-".into(), |v| format!("{v:.prec$}"))
}

/// The evaluation as a compact aligned text table: one line per case, then the aggregates.
pub fn table(ev: &Evaluation) -> String {
    let mut s = String::new();
    let w = ev
        .cases
        .iter()
        .map(|c| c.case.name.len())
        .max()
        .unwrap_or(4)
        .max(4);
    s.push_str(&format!(
        "{:w$}  {:>18}  {:>7}  {:>22}  {:>11}  {:>11}  {:>6}\n",
        "case",
        "liftwatch d/σ/mode",
        "floor d",
        "threshold d/σ/mode/fl",
        "cusum d/σ",
        "ewma d/σ",
        "late z"
    ));
    for c in &ev.cases {
        let cell = |r: &MethodResult, mode: bool, fl: bool| {
            let mut t = if r.delay_days.is_some() || c.case.onset_days.is_some() {
                format!(
                    "{}/{}",
                    opt(r.delay_days, 1),
                    opt(r.severity_at_detection, 2)
                )
            } else {
                String::new()
            };
            if mode && c.case.onset_days.is_some() {
                t.push('/');
                t.push_str(r.mode.map_or("-", |m| m.as_str()));
            }
            if fl && c.case.truth.is_some_and(FaultMode::is_machine) {
                t.push_str(&format!(
                    "/{}",
                    r.flicker.map_or("-".into(), |f| f.to_string())
                ));
            }
            if r.false_signals > 0 || c.case.onset_days.is_none() {
                t.push_str(&format!(" ({})", r.false_signals));
            }
            t
        };
        let m = &c.methods;
        s.push_str(&format!(
            "{:w$}  {:>18}  {:>7}  {:>22}  {:>11}  {:>11}  {:>6.2}\n",
            c.case.name,
            cell(&m[0], true, false),
            if c.case.truth.is_some_and(FaultMode::is_machine) {
                opt(c.floor_delay_days, 2)
            } else {
                String::new()
            },
            cell(&m[1], true, true),
            cell(&m[2], false, false),
            cell(&m[3], false, false),
            c.late_mean_z
        ));
    }
    s.push_str(&format!(
        "\n{:9}  {:8}  {:>5}  {:>6}  {:>9}  {:>9}  {:>7}  {:>8}  {:>8}  {:>9}  {:>7}  {:>9}\n",
        "method",
        "truth",
        "cases",
        "missed",
        "mean d",
        "worst d",
        "mean σ",
        "mode ok",
        "drift ok",
        "false/yr",
        "flicker",
        "persist d"
    ));
    for a in &ev.aggregates {
        let mode = match (a.mode_correct, a.not_machine) {
            (Some(k), Some(nm)) => format!("{k}/{}|{nm}", a.detected),
            (Some(k), None) => format!("{k}/{}", a.detected),
            _ => "-".into(),
        };
        s.push_str(&format!(
            "{:9}  {:8}  {:>5}  {:>6}  {:>9}  {:>9}  {:>7}  {:>8}  {:>8}  {:>9.2}  {:>7}  {:>9}\n",
            a.method,
            truth_name(a.truth),
            a.cases,
            a.missed,
            opt(a.mean_delay_days, 2),
            opt(a.worst_delay_days, 2),
            opt(a.mean_severity_at_detection, 2),
            mode,
            a.drift_within_2se
                .map_or_else(|| "-".into(), |(k, n)| format!("{k}/{n}")),
            a.false_per_year,
            opt(a.mean_flicker, 1),
            match (a.mean_persistent_days, a.never_persistent) {
                (p, Some(n)) if n > 0 => format!("{} ({n} never)", opt(p, 2)),
                (p, _) => opt(p, 2),
            }
        ));
    }
    s.push_str(&delays_text(&ev.delays));
    s.push_str(&outages_text(ev));
    let (mut doors, mut false_outages, mut outage_case_advisories, mut days) = (0, 0, 0, 0.0);
    for c in &ev.cases {
        let Some(lw) = c.methods.first() else {
            continue;
        };
        doors += lw.door_advisories.unwrap_or(0);
        match &lw.outage {
            Some(r) => {
                false_outages += r.false_reports;
                outage_case_advisories += lw.false_signals;
            }
            None => false_outages += lw.outages.unwrap_or(0),
        }
        days += c.case.days;
    }
    s.push_str(&format!(
        "\nliftwatch door advisories (every door of the suite is healthy): {doors}; outages reported where the car served: {false_outages}; fault advisories of the outage cases' healthy machines: {outage_case_advisories}; in {:.2} elevator-years of runs\n",
        days / YEAR_DAYS
    ));
    s.push_str(
        "\nd: delay from onset (days); σ: true severity at detection (1 = the mode's default effect); \
         fl: threshold activations (per trip) before its alarm holds for 20 trips; \
         (n): false signals before onset / on the healthy run; late z: mean standardised trip residual \
         in the last fifth of the span; floor d: delay of the oracle CUSUM that knows the fault's \
         mode and size at every trip, at the model's trip noise and false-advisory budget; mode ok: right mode / detected (sensor rows: |not blamed on \
         the machine); drift ok: reported drift of the true mode within 2 SE of the truth at \
         detection / detections with a drift; persist d: threshold delay until its alarm is persistent\n",
    );
    s
}

/// One line per outage case: whether, when and how right liftwatch reported the outage of
/// its healthy car, and its fault advisories (every one false); nothing when there is none.
fn outages_text(ev: &Evaluation) -> String {
    let mut s = String::new();
    for c in &ev.cases {
        let Some(r) = c.methods.first().and_then(|m| m.outage.as_ref()) else {
            continue;
        };
        if s.is_empty() {
            s.push_str(&format!(
                "\noutages of healthy cars (due at {OUTAGE_START_H:02.0}:00 on a weekday):\n"
            ));
        }
        let what = kind_text(r.truth.kind);
        let hours = (r.truth.end_s - r.truth.start_s) / HOUR_S;
        let report = match (&r.reported, r.after_h, r.start_error_s) {
            (Some(o), Some(after), Some(start)) => format!(
                "reported {} after {after:.2} h, its start {start:+.0} s, its end {}",
                if r.kind_correct == Some(true) {
                    "as such"
                } else {
                    kind_text(o.kind)
                },
                r.end_error_s
                    .map_or("never seen".into(), |e| format!("{e:+.0} s")),
            ),
            _ => "not reported".into(),
        };
        s.push_str(&format!(
            "{}: {what} {hours:.1} h, {report}; {} false report{}, {} fault advisor{}\n",
            c.case.name,
            r.false_reports,
            if r.false_reports == 1 { "" } else { "s" },
            c.methods[0].false_signals,
            if c.methods[0].false_signals == 1 {
                "y"
            } else {
                "ies"
            },
        ));
    }
    s
}

/// An outage's kind in the table's words.
fn kind_text(kind: OutageKind) -> &'static str {
    match kind {
        OutageKind::OutOfService => "out of service",
        OutageKind::StuckBetweenFloors => "stuck between floors",
    }
}

/// Two lines (three with the quiet elevators): liftwatch's delays against the threshold
/// method's on the cases both detected, and against the oracle floor.
fn delays_text(d: &DelayComparison) -> String {
    let line = |what: &str, v: &Option<Versus>, other: &str| {
        match v {
        Some(v) => format!(
            "liftwatch against {what}: median {:.2} d against {:.2} d on {} machine faults, ratio {:.2} (per case: median {})\n",
            v.liftwatch_median_days,
            v.other_median_days,
            v.cases,
            v.ratio_of_medians,
            opt(v.median_ratio, 2)
        ),
        None => format!("liftwatch against {what}: no machine fault {other}\n"),
    }
    };
    let mut s = String::from("\n");
    s.push_str(&line("the threshold method", &d.threshold, "both detected"));
    s.push_str(&line(
        "the threshold method where it was quiet when healthy",
        &d.threshold_quiet,
        "on an elevator where the threshold method raised no false signal",
    ));
    s.push_str(&line("the oracle floor", &d.floor, "detected with a floor"));
    s
}
