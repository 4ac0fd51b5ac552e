//! The `comparison` figure: the fixed-threshold baseline of the paper (Sec. 5.4), which judges
//! each moving sample alone against limits set at the fit, over the liftwatch risk on the
//! same data.
//!
//! ```text
//! baseline: alarm ⇔ F_fric > limit_F  or  ΔU > limit_U     on each sample, no memory
//! liftwatch: advisory ⇔ R ≥ advisory threshold             R accumulated per trip (stage 6)
//! ```

use liftwatch::alarm::Level;
use liftwatch::monitor::MonitorRow;

use super::risk::{combined_line, combined_panel, entries};
use super::{num, span_text, Ctx, Section};
use crate::plot::{colors::*, Axis, Dash, Figure, Legend, Mark, Panel};

/// A bar of the baseline's alarm runs is at least the whole span divided by this wide, about
/// two pixels, so that a one-sample alarm shows.
const MIN_BAR_DIVISOR: f64 = 450.0;

/// The baseline's alarm state as bars over the liftwatch risk on the same data.
pub(super) fn comparison(c: &Ctx) -> Section {
    let thr = c.inp.threshold;
    let activations = entries(thr, Level::Alarm);
    let adv = entries(c.inp.pinn, Level::Advisory);
    let alm = entries(c.inp.pinn, Level::Alarm);
    let mut p1 = baseline_panel(c, activations.len());
    let mut p2 = combined_panel(
        c,
        "liftwatch: combined risk on the same data",
        ["advisory threshold".into(), "alarm threshold".into()],
    );
    p2.marks.push(combined_line(c));
    for (p, with_label) in [(&mut p1, true), (&mut p2, false)] {
        if let Some(&t) = adv.first() {
            p.marks.push(Mark::VLine {
                x: c.whole.x(t),
                color: ORANGE,
                label: with_label.then(|| "liftwatch: first advisory".into()),
            });
        }
        if let Some(&t) = alm.first() {
            p.marks.push(Mark::VLine {
                x: c.whole.x(t),
                color: PURPLE,
                label: with_label.then(|| "liftwatch: first alarm".into()),
            });
        }
        p.legend = Legend::UpperLeft;
    }
    Section {
        figure: Figure {
            name: "comparison".into(),
            width: 1200,
            height: 800,
            grid: (2, 1),
            panels: vec![p1, p2],
        },
        heading: "Comparison with the fixed-threshold baseline".into(),
        text: comparison_text(c, &activations, adv.first().copied()),
    }
}

/// The baseline's state, each alarm run a bar.
fn baseline_panel(c: &Ctx, activations: usize) -> Panel {
    let mut p = Panel::new(
        format!("Fixed-threshold baseline: {activations} alarm activations"),
        c.whole.axis(c.start, c.end),
        Axis::new(-0.1, 1.25, "baseline state"),
    );
    p.y_ticks = vec![(0.0, "normal".into()), (1.0, "alarm".into())];
    p.marks.push(Mark::HLine {
        y: 0.0,
        color: RED,
        dash: Dash::Solid,
        label: None,
    });
    p.marks.push(Mark::Bars {
        bars: alarm_bars(c),
        color: RED,
        label: Some("alarm (each sample judged alone)".into()),
    });
    p
}

/// Each alarm run of the baseline as a bar at least about two pixels wide, so that a
/// one-sample alarm shows.
fn alarm_bars(c: &Ctx) -> Vec<(f64, f64, f64)> {
    let thr = c.inp.threshold;
    let min_w = (c.end - c.start) / MIN_BAR_DIVISOR;
    let mut bars: Vec<(f64, f64, f64)> = Vec::new();
    let mut run: Option<f64> = None;
    for (i, r) in thr.iter().enumerate() {
        let (t, on) = (r.time, r.level == Level::Alarm);
        if on && run.is_none() {
            run = Some(t);
        }
        let ends = !on || i + 1 == thr.len();
        if let (Some(t0), true) = (run, ends) {
            let t1 = if on { t + c.step } else { t };
            let mid = 0.5 * (t0 + t1);
            let half = 0.5 * (t1 - t0).max(min_w);
            bars.push((c.whole.x(mid - half), c.whole.x(mid + half), 1.0));
            run = None;
        }
    }
    bars
}

/// The baseline's limits, its activations and longest alarm, and which method was first.
fn comparison_text(c: &Ctx, activations: &[f64], first_adv: Option<f64>) -> Vec<String> {
    let lim = &c.inp.model.baseline;
    let before = first_adv.map(|t| activations.iter().filter(|a| **a < t).count());
    let persistent = longest_run(c.inp.threshold, c.step);
    let first = format!(
        "The conventional method judges each moving sample alone against fixed limits set at the fit (friction-force \
         estimate {} N, voltage above the motor line {} V). On this input it switched to alarm {} times{}; its longest \
         uninterrupted alarm lasted {}.",
        num(lim.friction_limit_n),
        num(lim.voltage_limit_v),
        activations.len(),
        activations.first().map_or(String::new(), |t| format!(", the first after {}", span_text(t - c.start))),
        span_text(persistent),
    );
    let second = match (first_adv, before) {
        (Some(t), Some(0)) => format!(
            "liftwatch reached advisory after {}, before the baseline's first alarm.",
            span_text(t - c.start)
        ),
        (Some(t), Some(n)) => format!(
            "liftwatch reached advisory after {}, by which time the baseline had flickered into alarm {n} times; \
             its risk rises smoothly instead of switching on isolated samples.",
            span_text(t - c.start)
        ),
        _ => "liftwatch did not reach advisory on this input.".into(),
    };
    vec![first, second]
}

/// Longest uninterrupted alarm of the baseline (s).
fn longest_run(rows: &[MonitorRow], step: f64) -> f64 {
    let (mut best, mut run) = (0.0f64, 0.0f64);
    for r in rows {
        if r.level == Level::Alarm {
            run += step;
            best = best.max(run);
        } else {
            run = 0.0;
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::figures::fixture::{assert_drawn, Fixture};

    #[test]
    fn comparison_is_drawn_from_a_small_series() {
        let f = Fixture::get();
        let inp = f.inputs();
        let c = Ctx::new(&inp);
        let s = comparison(&c);
        assert_eq!(s.heading, "Comparison with the fixed-threshold baseline");
        assert_drawn(&s, "baseline state");
    }

    #[test]
    fn entries_count_each_rise_into_a_level_once() {
        let f = Fixture::get();
        let row = |time: f64, level: Level| MonitorRow {
            time,
            level,
            ..f.analysis.pinn[0].clone()
        };
        let rows = [
            row(0.0, Level::Normal),
            row(1.0, Level::Alarm),
            row(2.0, Level::Advisory),
            row(3.0, Level::Alarm),
        ];
        assert_eq!(entries(&rows, Level::Advisory), vec![1.0]);
        assert_eq!(entries(&rows, Level::Alarm), vec![1.0, 3.0]);
        assert_eq!(longest_run(&rows, 1.0), 1.0);
    }
}
