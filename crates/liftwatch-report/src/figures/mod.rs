//! The report's figures, each with the sentences that explain it, numbers from the same data.
//!
//! Excerpts are chosen, not hand-picked: the preprocessing excerpt is the 20 minutes with the
//! most moving, fully measured samples; the fit excerpt is the busiest 20 minutes of the last
//! quarter of the data, where a developing fault shows most.
//!
//! One file per figure family, in report order: [`signals`] (stages 2-3: the aligned signals
//! and the fused acceleration), [`training`] (stage 4: loss and θ), [`fit`] and [`residuals`]
//! (stage 5: `r_U = U − U_pred`, `r_F = F_pred − F_U`), [`risk`] (stages 6-7), [`comparison`]
//! (the fixed-threshold baseline), [`usage`], [`availability`] (outages and doors). This file holds what they share: the derived
//! data [`Ctx`], the time axis [`Time`], number formatting and line builders.

mod availability;
mod comparison;
mod fit;
#[cfg(test)]
mod fixture;
mod residuals;
mod risk;
mod signals;
mod training;
mod usage;

use liftwatch::features::{FeatureRow, Trip};
use liftwatch::ingest::time::{instant_text, is_calendar};
use liftwatch::residual::Residuals;
use liftwatch::sample::{DAY_S, HOUR_S};
/// A number with three significant digits, plainly written (the one writer of numbers in a
/// sentence, the verdict's and the fit's too).
use liftwatch::text::sig3 as num;
use plotters::style::RGBColor;

use crate::plot::{decimate, Axis};
use crate::section::Section;
use crate::ReportInputs;

/// Pixel columns a full-width series is thinned to.
const COLUMNS: usize = 1100;
/// Length of the preprocessing excerpt (s).
const EXCERPT_S: f64 = 1200.0;

/// All sections, in report order.
pub(crate) fn all(inp: &ReportInputs) -> Vec<Section> {
    let c = Ctx::new(inp);
    let (pa, pb) = c.busiest(0.0, EXCERPT_S);
    let mut out = vec![
        risk::risk(&c),
        residuals::residuals(&c),
        fit::fit(&c),
        comparison::comparison(&c),
        usage::usage(&c),
        availability::availability(&c),
        signals::preprocessing(&c, pa, pb),
        signals::acceleration(&c, pa, pb),
    ];
    // A history of two points (a fit that logged only its stage ends) is no curve to show.
    if c.inp.model.summary.history.len() > 2 {
        out.push(training::training(&c));
        out.push(training::parameters(&c));
    }
    out
}

/// A time axis: origin, unit and description.
#[derive(Clone, Debug)]
struct Time {
    /// Time drawn at x = 0 (s).
    origin: f64,
    /// Seconds per axis unit.
    unit_s: f64,
    /// Axis description with its unit.
    label: String,
}

impl Time {
    /// Seconds, minutes, hours or days, whichever suits `span` seconds.
    fn unit(span: f64) -> (f64, &'static str) {
        if span <= 600.0 {
            (1.0, "s")
        } else if span <= 3.0 * HOUR_S {
            (60.0, "min")
        } else if span <= 3.0 * DAY_S {
            (HOUR_S, "h")
        } else {
            (DAY_S, "days")
        }
    }

    /// The axis of the whole series: on a Unix clock, time since midnight UTC of its first
    /// day (the zone said); on a relative clock, time since its start.
    fn whole(start: f64, end: f64) -> Time {
        let (unit_s, u) = Time::unit(end - start);
        if is_calendar(start) {
            let midnight = (start / DAY_S).floor() * DAY_S;
            return Time {
                origin: midnight,
                unit_s,
                label: format!("{u} since {}", instant_text(midnight)),
            };
        }
        Time {
            origin: start,
            unit_s,
            label: format!("time since start of data ({u})"),
        }
    }

    /// The axis of an excerpt `[a, b]` of a series starting at `start`.
    fn excerpt(start: f64, a: f64, b: f64) -> Time {
        let (unit_s, u) = Time::unit(b - a);
        let label = if a - start < 0.5 {
            format!("time since start of data ({u})")
        } else {
            format!("time ({u}) after {} into the data", span_text(a - start))
        };
        Time {
            origin: a,
            unit_s,
            label,
        }
    }

    /// The axis coordinate of time `t` (s).
    fn x(&self, t: f64) -> f64 {
        (t - self.origin) / self.unit_s
    }

    /// The axis over `[a, b]` (s).
    fn axis(&self, a: f64, b: f64) -> Axis {
        Axis::new(self.x(a), self.x(b), self.label.clone())
    }
}

/// A duration in words: `42 s`, `17.5 min`, `5.3 h`, `2.40 days`.
fn span_text(s: f64) -> String {
    if s < 120.0 {
        format!("{s:.0} s")
    } else if s < 2.0 * HOUR_S {
        format!("{:.1} min", s / 60.0)
    } else if s < 2.0 * DAY_S {
        format!("{:.1} h", s / HOUR_S)
    } else {
        format!("{:.2} days", s / DAY_S)
    }
}

/// A lighter variant of a colour, halfway to white.
fn light(c: RGBColor) -> RGBColor {
    let l = |c: u8| (u16::from(c) + (255 - u16::from(c)) / 2) as u8;
    RGBColor(l(c.0), l(c.1), l(c.2))
}

/// Derived data several figures share.
struct Ctx<'a> {
    /// What the report shows.
    inp: &'a ReportInputs<'a>,
    /// Time of the first sample (s).
    start: f64,
    /// Time of the last sample (s), at least one second after `start`.
    end: f64,
    /// Sample step (s), 1 when the series does not say.
    step: f64,
    /// The axis of the whole series.
    whole: Time,
    /// Residuals of each feature row.
    res: Vec<Residuals>,
}

impl<'a> Ctx<'a> {
    /// Derives the shared data of `inp`, the residuals of every feature row among them.
    fn new(inp: &'a ReportInputs<'a>) -> Ctx<'a> {
        let s = &inp.series.samples;
        let start = s.first().map_or(0.0, |x| x.time);
        let end = s.last().map_or(1.0, |x| x.time).max(start + 1.0);
        let step = if inp.series.step_s > 0.0 {
            inp.series.step_s
        } else {
            1.0
        };
        let res = inp
            .features
            .rows
            .iter()
            .map(|r| Residuals::compute(&inp.model.hybrid, r))
            .collect();
        Ctx {
            inp,
            start,
            end,
            step,
            whole: Time::whole(start, end),
            res,
        }
    }

    /// The feature rows, one per sample.
    fn rows(&self) -> &'a [FeatureRow] {
        &self.inp.features.rows
    }

    /// The `len_s` window with the most moving samples that have voltage and load, among
    /// windows starting at or after fraction `from` of the data.
    fn busiest(&self, from: f64, len_s: f64) -> (f64, f64) {
        let rows = self.rows();
        let n = rows.len();
        let w = ((len_s / self.step).round() as usize).max(2);
        if n <= w {
            return (self.start, self.end);
        }
        let good =
            |r: &FeatureRow| u32::from(r.s != 0 && r.voltage.is_finite() && r.lambda.is_finite());
        let first = ((from.clamp(0.0, 1.0) * n as f64) as usize).min(n - w);
        let mut sum: u32 = rows[first..first + w].iter().map(good).sum();
        let (mut best, mut best_i) = (sum, first);
        for i in first + 1..=n - w {
            sum = sum + good(&rows[i + w - 1]) - good(&rows[i - 1]);
            if sum > best {
                best = sum;
                best_i = i;
            }
        }
        (rows[best_i].time, rows[best_i + w - 1].time)
    }

    /// The complete trips inside `[a, b]`.
    fn trips_in(&self, a: f64, b: f64) -> impl Iterator<Item = &'a Trip> {
        self.inp
            .features
            .trips
            .iter()
            .filter(move |t| t.start_time >= a && t.end_time <= b)
    }
}

/// Points `(x(t), y)` of the samples in `[a, b]`, a NaN breaking the line.
fn excerpt_line(time: &Time, t: &[f64], y: &[f64], a: f64, b: f64) -> Vec<(f64, f64)> {
    t.iter()
        .zip(y)
        .filter(|(t, _)| **t >= a && **t <= b)
        .map(|(t, y)| (time.x(*t), *y))
        .collect()
}

/// A held (step) signal as a polyline: each value lasts until the next sample.
fn steps(time: &Time, t: &[f64], y: &[f64], a: f64, b: f64, step: f64) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    for (i, (&ti, &yi)) in t.iter().zip(y).enumerate() {
        if ti < a || ti > b {
            continue;
        }
        if !yi.is_finite() {
            out.push((f64::NAN, f64::NAN));
            continue;
        }
        let next = t
            .get(i + 1)
            .copied()
            .filter(|n| n - ti <= 1.5 * step)
            .unwrap_or(ti + step)
            .min(b);
        out.push((time.x(ti), yi));
        out.push((time.x(next), yi));
    }
    out
}

/// Whole-span thinned line of `y` over the series' time axis.
fn whole_line(c: &Ctx, t: &[f64], y: &[f64]) -> Vec<(f64, f64)> {
    decimate(t, y, c.start, c.end, COLUMNS, 1.5 * c.step)
        .into_iter()
        .map(|(t, y)| (c.whole.x(t), y))
        .collect()
}
