//! The `risk` figure of stages 6-7: the combined risk R with the advisory and alarm thresholds,
//! the events and the start of the change the sequential decision holds; the per-mode risk R_m
//! with the per-mode thresholds (brake as dots, so it shows where it runs on friction); and the
//! drifts in physical units (Kd and friction in %, brake drag in N) with the Kd drift that
//! holds R at the alarm level and the brake's physical limit ([`liftwatch::forecast`]). Also the
//! risk axis and the level entries that the `comparison` figure shares.
//!
//! ```text
//! R_k = γ·R_{k−1} + x_k·exp(κ·min(D_k, D_max))    combined, per trip k; R_m per mode alike
//! level: normal below the advisory threshold, advisory from it, alarm from the alarm threshold
//! ```
//!
//! The risk axis turns logarithmic when some risk or threshold is more than 20 times the
//! lowest threshold of its panel, decided once for all risk panels so that they read alike.

use liftwatch::alarm::Level;
use liftwatch::mode::FaultMode;
use liftwatch::monitor::MonitorRow;

const MOTOR: usize = FaultMode::Motor as usize;
const BRAKE: usize = FaultMode::Brake as usize;
const FRICTION: usize = FaultMode::Friction as usize;

use liftwatch::forecast::{drift_for_risk, physical_limit, BRAKE_DRAG_LIMIT_SHARE};
use liftwatch::ingest::time::day_text;
use liftwatch::risk::friction_reference;

use super::{num, span_text, whole_line, Ctx, Section};
use crate::plot::{colors::*, quantile, robust_range, Axis, Dash, Figure, Legend, Mark, Panel};

/// Ratio of the top of a risk panel to its lowest threshold above which the axis is
/// logarithmic; the log axis starts this factor below the lowest threshold.
const LOG_RATIO: f64 = 20.0;
/// Room above the data of every risk panel, as a fraction of the range.
const RISK_HEADROOM: f64 = 0.08;
/// Events listed in the text at most.
const LISTED_EVENTS: usize = 12;

/// Times at which the level sequence of `rows` enters `level` from below.
pub(super) fn entries(rows: &[MonitorRow], level: Level) -> Vec<f64> {
    let mut prev = Level::Normal;
    let mut out = Vec::new();
    for r in rows {
        if r.level >= level && prev < level {
            out.push(r.time);
        }
        prev = r.level;
    }
    out
}

/// Top of a risk axis and its lowest positive threshold.
fn risk_span(values: &[f64], thresholds: &[f64]) -> (f64, f64) {
    let top = quantile(values.iter().copied(), 0.995).max(0.0);
    let t_hi = thresholds
        .iter()
        .copied()
        .filter(|t| t.is_finite())
        .fold(0.0, f64::max);
    let t_lo = thresholds
        .iter()
        .copied()
        .filter(|t| t.is_finite() && *t > 0.0)
        .fold(f64::INFINITY, f64::min);
    ((1.08 * top).max(1.2 * t_hi).max(1e-9), t_lo)
}

/// True when the risk figures use logarithmic axes: some risk or threshold is more than 20
/// times the lowest threshold of its panel, so that a linear axis would hide the lower one.
/// Decided once for all risk panels of the report, so that they read alike.
pub(super) fn risk_log(c: &Ctx) -> bool {
    let cfg = &c.inp.model.risk;
    let rows = c.inp.pinn;
    let combined: Vec<f64> = rows.iter().map(|r| r.risk).collect();
    let modes: Vec<f64> = rows
        .iter()
        .flat_map(|r| [r.risk_motor, r.risk_brake, r.risk_friction])
        .collect();
    [
        risk_span(&combined, &[cfg.advisory, cfg.alarm]),
        risk_span(&modes, &cfg.advisory_modes),
    ]
    .iter()
    .any(|(hi, lo)| lo.is_finite() && hi / lo > LOG_RATIO)
}

/// The risk axis: linear from zero, or logarithmic from a twentieth of the lowest threshold
/// (a risk of zero lies on the lower edge).
pub(super) fn risk_axis(values: &[f64], thresholds: &[f64], label: &str, log: bool) -> Axis {
    let (hi, t_lo) = risk_span(values, thresholds);
    if log && t_lo.is_finite() {
        Axis {
            min: t_lo / LOG_RATIO,
            max: 1.5 * hi,
            label: format!("{label}, log scale"),
            log: true,
        }
    } else {
        Axis::new(0.0, hi, label)
    }
}

/// The combined risk R of the paper's method with both thresholds (labelled by `labels`:
/// advisory, alarm), headroom set.
pub(super) fn combined_panel(c: &Ctx, title: &str, labels: [String; 2]) -> Panel {
    let cfg = &c.inp.model.risk;
    let rk: Vec<f64> = c.inp.pinn.iter().map(|r| r.risk).collect();
    let mut p = Panel::new(
        title,
        c.whole.axis(c.start, c.end),
        risk_axis(&rk, &[cfg.advisory, cfg.alarm], "risk R (1)", risk_log(c)),
    );
    let [adv, alm] = labels;
    p.marks.push(Mark::HLine {
        y: cfg.advisory,
        color: ORANGE,
        dash: Dash::Dashed,
        label: Some(adv),
    });
    p.marks.push(Mark::HLine {
        y: cfg.alarm,
        color: RED,
        dash: Dash::Dashed,
        label: Some(alm),
    });
    p.headroom = Some(RISK_HEADROOM);
    p
}

/// The line of the combined risk R.
pub(super) fn combined_line(c: &Ctx) -> Mark {
    let t: Vec<f64> = c.inp.pinn.iter().map(|r| r.time).collect();
    let rk: Vec<f64> = c.inp.pinn.iter().map(|r| r.risk).collect();
    Mark::Line {
        pts: whole_line(c, &t, &rk),
        color: INK,
        width: 3,
        label: Some("R".into()),
    }
}

/// Combined R with thresholds and events; per-mode R_m with the per-mode thresholds.
pub(super) fn risk(c: &Ctx) -> Section {
    let cfg = &c.inp.model.risk;
    let mut p1 = combined_panel(
        c,
        "Combined risk R (the paper's time-accumulated index)",
        [
            format!("advisory threshold {}", num(cfg.advisory)),
            format!("alarm threshold {}", num(cfg.alarm)),
        ],
    );
    p1.marks.extend(event_lines(c));
    p1.marks.extend(change_line(c));
    p1.marks.push(combined_line(c));
    p1.legend = Legend::UpperLeft;
    let (pct, newton) = drift_panels(c);
    Section {
        figure: Figure {
            name: "risk".into(),
            width: 1200,
            height: 1500,
            grid: (4, 1),
            panels: vec![p1, modes_panel(c), pct, newton],
        },
        heading: "Risk over time".into(),
        text: risk_text(c),
    }
}

/// A vertical line where the change the sequential decision holds at the end began.
fn change_line(c: &Ctx) -> Option<Mark> {
    let since = c.inp.state.changed_since(&c.inp.model.risk)?;
    Some(Mark::VLine {
        x: c.whole.x(since),
        color: BLUE,
        label: Some(format!("change began ({})", day_text(since))),
    })
}

/// The re-identified drifts in physical units: Kd and friction (%) with the Kd alarm-level
/// drift, and the brake drag (N) with its physical limit.
fn drift_panels(c: &Ctx) -> (Panel, Panel) {
    let rows = c.inp.pinn;
    let cfg = &c.inp.model.risk;
    let t: Vec<f64> = rows.iter().map(|r| r.time).collect();
    let kd: Vec<f64> = rows.iter().map(|r| r.kd_drift_pct).collect();
    let fr: Vec<f64> = rows.iter().map(|r| r.friction_drift_pct).collect();
    let br: Vec<f64> = rows.iter().map(|r| r.brake_drag_n).collect();
    let x = || c.whole.axis(c.start, c.end);
    let alarm_kd = 100.0 * drift_for_risk(cfg, MOTOR, cfg.alarm);
    let (lo, hi) = robust_range(
        &[kd.clone(), fr.clone()].concat(),
        0.002,
        0.998,
        &[0.0, alarm_kd],
    );
    let mut pct = Panel::new(
        "Drift of Kd and of friction from the healthy reference (re-identified, %)",
        x(),
        Axis::new(lo, hi, "drift (%)"),
    );
    pct.marks.push(Mark::HLine {
        y: alarm_kd,
        color: RED,
        dash: Dash::Dashed,
        label: Some(format!(
            "Kd drift that holds R at the alarm level ({alarm_kd:+.1} %)"
        )),
    });
    pct.marks.extend(change_line(c));
    pct.marks.push(Mark::Line {
        pts: whole_line(c, &t, &kd),
        color: BLUE,
        width: 3,
        label: Some("Kd (drive)".into()),
    });
    pct.marks.push(Mark::Line {
        pts: whole_line(c, &t, &fr),
        color: GREEN,
        width: 3,
        label: Some("friction (guides)".into()),
    });
    pct.legend = Legend::UpperLeft;
    pct.headroom = Some(0.3);
    let f_c = friction_reference(&c.inp.model.hybrid).0;
    let limit = f_c * physical_limit(BRAKE, &c.inp.model.hybrid.elevator, f_c);
    let (lo, hi) = robust_range(&br, 0.002, 0.998, &[0.0, limit]);
    let mut newton = Panel::new(
        "Brake drag (re-identified, N)",
        x(),
        Axis::new(lo, hi, "brake drag (N)"),
    );
    newton.marks.push(Mark::HLine {
        y: limit,
        color: RED,
        dash: Dash::Dashed,
        label: Some(format!(
            "physical limit {limit:.0} N ({:.0} % of car + rated load weight)",
            100.0 * BRAKE_DRAG_LIMIT_SHARE
        )),
    });
    newton.marks.push(Mark::Line {
        pts: whole_line(c, &t, &br),
        color: PURPLE,
        width: 3,
        label: Some("brake drag".into()),
    });
    newton.legend = Legend::UpperLeft;
    newton.headroom = Some(0.3);
    (pct, newton)
}

/// A vertical line per event, each level labelled once.
fn event_lines(c: &Ctx) -> Vec<Mark> {
    let mut labelled = [false; 3];
    let mut out = Vec::new();
    for e in c.inp.events {
        let (i, color, name) = match e.level {
            Level::Normal => (0, GREEN, "event: back to normal"),
            Level::Advisory => (1, ORANGE, "event: advisory"),
            Level::Alarm => (2, RED, "event: alarm"),
        };
        let label = (!labelled[i]).then(|| name.to_string());
        labelled[i] = true;
        out.push(Mark::VLine {
            x: c.whole.x(e.time),
            color,
            label,
        });
    }
    out
}

/// R_m of each fault mode, with one shared threshold line or one per mode.
fn modes_panel(c: &Ctx) -> Panel {
    let rows = c.inp.pinn;
    let cfg = &c.inp.model.risk;
    let t: Vec<f64> = rows.iter().map(|r| r.time).collect();
    let modes = [
        (MOTOR, "motor", BLUE),
        (FRICTION, "friction", GREEN),
        (BRAKE, "brake", PURPLE),
    ];
    let per: Vec<Vec<f64>> = modes
        .iter()
        .map(|(m, _, _)| {
            rows.iter()
                .map(|r| match *m {
                    MOTOR => r.risk_motor,
                    BRAKE => r.risk_brake,
                    _ => r.risk_friction,
                })
                .collect()
        })
        .collect();
    let y = risk_axis(
        &per.concat(),
        &cfg.advisory_modes,
        "risk R_m (1)",
        risk_log(c),
    );
    let mut p = Panel::new(
        "Risk per fault mode, with the per-mode threshold (dashed)",
        c.whole.axis(c.start, c.end),
        y,
    );
    let th = cfg.advisory_modes;
    let shared = th
        .iter()
        .all(|t| (t - th[0]).abs() <= 1e-9 * th[0].abs().max(1e-12));
    if shared {
        p.marks.push(Mark::HLine {
            y: th[0],
            color: INK,
            dash: Dash::Dashed,
            label: Some("per-mode threshold (same for all)".into()),
        });
    }
    for ((m, name, color), y) in modes.iter().zip(&per) {
        if !shared {
            p.marks.push(Mark::HLine {
                y: th[*m],
                color: *color,
                dash: Dash::Dashed,
                label: None,
            });
        }
        let pts = whole_line(c, &t, y);
        // Brake is drawn last as dots, so it stays visible where it runs on friction's line.
        p.marks.push(if *m == BRAKE {
            Mark::Dots {
                pts,
                color: *color,
                radius: 3,
                label: Some(format!("{name} (dots)")),
            }
        } else {
            Mark::Line {
                pts,
                color: *color,
                width: 3,
                label: Some(name.to_string()),
            }
        });
    }
    p.headroom = Some(RISK_HEADROOM);
    p.legend = Legend::UpperLeft;
    p
}

/// How the risk accumulates, where it peaks and crosses the thresholds, and the events.
fn risk_text(c: &Ctx) -> Vec<String> {
    let rows = c.inp.pinn;
    let cfg = &c.inp.model.risk;
    let max_r = rows
        .iter()
        .map(|r| r.risk)
        .filter(|x| x.is_finite())
        .fold(0.0, f64::max);
    let adv = entries(rows, Level::Advisory);
    let alm = entries(rows, Level::Alarm);
    let final_level = rows.last().map_or(Level::Normal, |r| r.level);
    let mut text = vec![format!(
        "The risk accumulates the excess of each trip's combined residual over the healthy boundary and decays by γ = {} \
         per trip. {} Over this input R peaks at {}; {}; {}. The level at the end of the data is <b>{}</b>.{} The \
         per-mode threshold is the largest risk each mode reached in the healthy bootstrap of the fit (motor {}, brake {}, \
         friction {}); it attributes an episode to a mode.",
        num(cfg.gamma),
        c.inp.model.calibration.as_ref().map_or("The thresholds are the model file's settings.".to_string(), |k| format!(
            "The thresholds were calibrated on {} healthy trips ({} h), bootstrapped to {} simulated years, for a target of {} \
             per year (validated: {}).",
            k.trips,
            num(k.hours),
            num(k.years_simulated),
            k.target_text(),
            num(k.validated_false_advisories_per_year)
        )),
        num(max_r),
        adv.first().map_or("it never reaches the advisory threshold".into(), |t| format!("it first reaches advisory after {}", span_text(t - c.start))),
        alm.first().map_or("no alarm is raised".into(), |t| format!("alarm after {}", span_text(t - c.start))),
        final_level.as_str(),
        if risk_log(c) { " On the logarithmic axes, a risk of zero lies on the lower edge." } else { "" },
        num(cfg.advisory_modes[MOTOR]),
        num(cfg.advisory_modes[BRAKE]),
        num(cfg.advisory_modes[FRICTION]),
    )];
    let events = c.inp.events;
    if !events.is_empty() {
        let items: Vec<String> = events
            .iter()
            .take(LISTED_EVENTS)
            .map(|e| {
                format!(
                    "<li>{}: {} ({}), R = {}</li>",
                    span_text(e.time - c.start),
                    e.level.as_str(),
                    e.mode.as_str(),
                    num(e.risk)
                )
            })
            .collect();
        text.push(format!(
            "Level changes ({} in all{}):<ul>{}</ul>",
            events.len(),
            if events.len() > LISTED_EVENTS {
                format!(", first {LISTED_EVENTS} shown")
            } else {
                String::new()
            },
            items.join("")
        ));
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::figures::fixture::{assert_drawn, Fixture};

    #[test]
    fn risk_is_drawn_from_a_small_series() {
        let f = Fixture::get();
        let inp = f.inputs();
        let c = Ctx::new(&inp);
        let s = risk(&c);
        assert_eq!(s.heading, "Risk over time");
        assert_eq!(s.figure.panels.len(), 4);
        assert_drawn(&s, "risk R_m (1)");
    }
}
