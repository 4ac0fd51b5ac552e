//! The availability figure: availability per day with the outages, and the door cycles' mean
//! duration and reopenings per day against the healthy reference (`liftwatch::operation`,
//! counted by the monitor over the whole input).
//!
//! ```text
//! availability(day) = 1 − outage s / observed s          UTC days of the data clock
//! door(day)         = mean duration of the day's scored cycles (≤ 120 s), reopenings / cycles
//! ```

use liftwatch::operation::{
    DayUsage, OperationEvent, DOOR_MIN_CYCLES, DOOR_MIN_DAYS, STUCK_LIMIT_S,
};
use liftwatch::sample::DAY_S;

use super::{num, Ctx, Section};
use crate::plot::{colors::*, Axis, Dash, Figure, Legend, Mark, Panel};

/// Room above the highest point, as a factor.
const HEADROOM: f64 = 1.15;

/// Availability, door cycle duration and reopenings per day.
pub(super) fn availability(c: &Ctx) -> Section {
    let days = c.inp.usage;
    let x0 = days.first().map_or(0.0, |d| d.day as f64);
    let x1 = days
        .last()
        .map_or(1.0, |d| d.day as f64 + 1.0)
        .max(x0 + 1.0);
    // Days are drawn on the whole series' axis, in its unit.
    let x = |day: f64| c.whole.x(day * DAY_S);
    let xaxis = || Axis::new(x(x0), x(x1), c.whole.label.clone());
    let bars: Vec<(f64, f64, f64)> = days
        .iter()
        .filter(|d| d.observed_s > 0.0)
        .map(|d| {
            let a = d.day as f64;
            (x(a + 0.1), x(a + 0.9), 100.0 * d.availability())
        })
        .collect();
    let low = bars.iter().map(|b| b.2).fold(100.0, f64::min);
    let mut avail = Panel::new(
        "Availability per day (share of the day not out of service)",
        xaxis(),
        Axis::new((low - 5.0).clamp(0.0, 90.0), 100.5, "availability (%)"),
    );
    avail.marks.push(Mark::Bars {
        bars,
        color: GREEN,
        label: None,
    });
    for e in c.inp.operation_events {
        if let OperationEvent::OutageStart(o) = e {
            avail.marks.push(Mark::VLine {
                x: c.whole.x(o.start),
                color: RED,
                label: Some("outage began".into()),
            });
        }
    }
    avail.legend = Legend::LowerLeft;

    let per_day = |f: &dyn Fn(&DayUsage) -> f64| -> Vec<(f64, f64)> {
        days.iter().map(|d| (x(d.day as f64 + 0.5), f(d))).collect()
    };
    let door_mean = per_day(&|d| d.mean_door_cycle_s());
    let reopen = per_day(&|d| {
        if d.door_cycles > 0 {
            100.0 * d.reopenings as f64 / d.door_cycles as f64
        } else {
            f64::NAN
        }
    });
    let reference = c.inp.model.operation.as_ref().and_then(|o| o.door.as_ref());
    let top = |pts: &[(f64, f64)], r: f64| {
        pts.iter()
            .map(|p| p.1)
            .filter(|v| v.is_finite())
            .fold(r, f64::max)
            * HEADROOM
    };
    let mut dur = Panel::new(
        "Door cycle duration per day (mean of cycles up to 120 s)",
        xaxis(),
        Axis::new(
            0.0,
            top(&door_mean, reference.map_or(1.0, |r| r.median_s)).max(1.0),
            "door open (s)",
        ),
    );
    dur.marks.push(Mark::Line {
        pts: door_mean.clone(),
        color: BLUE,
        width: 2,
        label: Some("mean per day".into()),
    });
    dur.marks.push(Mark::Dots {
        pts: door_mean,
        color: BLUE,
        radius: 3,
        label: None,
    });
    let mut reo = Panel::new(
        "Door reopenings per day (share of door cycles)",
        xaxis(),
        Axis::new(
            0.0,
            top(&reopen, reference.map_or(1.0, |r| 100.0 * r.reopen_rate)).max(1.0),
            "reopenings (% of cycles)",
        ),
    );
    reo.marks.push(Mark::Dots {
        pts: reopen,
        color: ORANGE,
        radius: 3,
        label: Some("per day".into()),
    });
    if let Some(r) = reference {
        dur.marks.push(Mark::HLine {
            y: r.median_s,
            color: GREY,
            dash: Dash::Dashed,
            label: Some("healthy median".into()),
        });
        reo.marks.push(Mark::HLine {
            y: 100.0 * r.reopen_rate,
            color: GREY,
            dash: Dash::Dashed,
            label: Some("healthy reference".into()),
        });
    }
    for e in c.inp.operation_events {
        if let OperationEvent::Door {
            time, raised: true, ..
        } = e
        {
            dur.marks.push(Mark::VLine {
                x: c.whole.x(*time),
                color: RED,
                label: Some("door advisory".into()),
            });
        }
    }
    dur.legend = Legend::LowerRight;
    reo.legend = Legend::UpperLeft;
    Section {
        figure: Figure {
            name: "availability".into(),
            width: 1200,
            height: 1100,
            grid: (3, 1),
            panels: vec![avail, dur, reo],
        },
        heading: "Availability and doors".into(),
        text: text(c, days),
    }
}

/// Availability over the input, the outages, and the doors against their reference.
fn text(c: &Ctx, days: &[DayUsage]) -> Vec<String> {
    let (obs, out) = days
        .iter()
        .fold((0.0, 0.0), |a, d| (a.0 + d.observed_s, a.1 + d.outage_s));
    let outages: Vec<String> = c
        .inp
        .operation_events
        .iter()
        .filter_map(|e| match e {
            OperationEvent::OutageEnd(o) => Some(format!(
                "{} for {} ({})",
                liftwatch::ingest::time::instant_text(o.start),
                super::span_text(o.end - o.start),
                o.reason()
            )),
            _ => None,
        })
        .collect();
    let cycles: u64 = days.iter().map(|d| d.door_cycles).sum();
    let reopenings: u64 = days.iter().map(|d| d.reopenings).sum();
    let operation = c.inp.model.operation.as_ref();
    let stuck = format!(
        "a car stopped between landings with its door closed for {:.0} minutes",
        STUCK_LIMIT_S / 60.0
    );
    let what = match operation {
        Some(o) if o.checks_silence() => format!(
            "An outage is a silence through hours in which the training travelled, or the \
             monitor since saw the car travel in hours the training never saw (at least {} \
             trips expected by then), or {stuck}.",
            num(o.outage_expected_trips)
        ),
        _ => format!(
            "An outage is {stuck}; silences are not judged, as the training did not see every \
             hour of the day."
        ),
    };
    let mut lines = vec![format!(
        "Availability {} % over {} days of data; {} outage{}{}{}. {what}",
        num(if obs > 0.0 {
            100.0 * (1.0 - out / obs)
        } else {
            f64::NAN
        }),
        days.len(),
        outages.len(),
        if outages.len() == 1 { "" } else { "s" },
        if outages.is_empty() { "" } else { ": " },
        outages.join("; "),
    )];
    lines.push(format!(
        "{cycles} door cycles, {reopenings} of them reopenings ({} %). {}",
        num(100.0 * reopenings as f64 / (cycles.max(1)) as f64),
        match operation.and_then(|o| o.door.as_ref()) {
            Some(r) => format!(
                "Healthy reference: median {} s, {} % reopenings, over {} training cycles.{}",
                num(r.median_s),
                num(100.0 * r.reopen_rate),
                r.cycles,
                r.transfer.map_or_else(String::new, |t| format!(
                    " The check scores each cycle beyond its passengers: {} s per % of rated \
                     load passing the door, {} s beyond it (spread {} s, against {} s for the \
                     whole cycle).",
                    num(t.s_per_load),
                    num(t.median_s),
                    num(t.sigma_s),
                    num(r.sigma_s)
                ))
            ),
            None => format!(
                "The model has no door reference: its training had fewer than \
                 {DOOR_MIN_CYCLES} door cycles or less than {DOOR_MIN_DAYS:.0} day, or it was \
                 fitted before the door check existed."
            ),
        }
    ));
    lines
}
