//! The usage figure: trips, door cycles and time moving by hour of day, and a histogram of
//! the static load λ of each trip (features of stage 3, counted).
//!
//! ```text
//! rate(h) = count(h) / (time observed in hour of day h, in hours)
//! hour of day h = floor((t mod 86400 s) / 3600 s)
//! ```

use super::{num, span_text, Ctx, Section};
use crate::plot::{colors::*, quantile, Axis, Figure, Legend, Mark, Panel};
use liftwatch::sample::{DAY_S, HOUR_S};
use plotters::style::RGBColor;

/// Width of a bin of the load histogram (% of rated load).
const LOAD_BIN: f64 = 5.0;
/// Room above the tallest bar, as a factor.
const BAR_HEADROOM: f64 = 1.12;

/// One bar: from x0 to x1, height y.
type Bar = (f64, f64, f64);

/// Counts per hour of day (0-23).
struct Hours {
    /// Time with a speed reading (s).
    observed: [f64; 24],
    /// Time moving (s).
    moving: [f64; 24],
    /// Trips started.
    trips: [f64; 24],
    /// Door openings.
    doors: [f64; 24],
}

impl Hours {
    /// Counts the whole series.
    fn new(c: &Ctx) -> Hours {
        let s = &c.inp.series.samples;
        let hour = |t: f64| ((t.rem_euclid(DAY_S)) / HOUR_S).floor().clamp(0.0, 23.0) as usize;
        let mut h = Hours {
            observed: [0.0; 24],
            moving: [0.0; 24],
            trips: [0.0; 24],
            doors: [0.0; 24],
        };
        for x in s.iter().filter(|x| x.speed.is_finite()) {
            h.observed[hour(x.time)] += c.step;
        }
        for r in c.rows().iter().filter(|r| r.s != 0) {
            h.moving[hour(r.time)] += c.step;
        }
        for t in &c.inp.features.trips {
            h.trips[hour(t.start_time)] += 1.0;
        }
        for w in s.windows(2) {
            if w[0].door < 0.5 && w[1].door >= 0.5 {
                h.doors[hour(w[1].time)] += 1.0;
            }
        }
        h
    }

    /// `n` per observed hour, one bar per hour of day with data.
    fn per_hour(&self, n: &[f64; 24]) -> Vec<Bar> {
        (0..24)
            .filter(|&h| self.observed[h] > 0.0)
            .map(|h| {
                (
                    h as f64 + 0.1,
                    h as f64 + 0.9,
                    n[h] / (self.observed[h] / HOUR_S),
                )
            })
            .collect()
    }
}

/// Trips, door cycles and time moving by hour of day; the load histogram.
pub(super) fn usage(c: &Ctx) -> Section {
    let hours = Hours::new(c);
    let tb = hours.per_hour(&hours.trips);
    let mb: Vec<Bar> = hours
        .per_hour(&hours.moving)
        .into_iter()
        .map(|(a, b, v)| (a, b, 100.0 * v / HOUR_S))
        .collect();
    let lambdas: Vec<f64> = c
        .inp
        .features
        .trips
        .iter()
        .map(|t| 100.0 * t.load_ratio)
        .filter(|v| v.is_finite())
        .collect();
    let panels = vec![
        bar_panel(
            "Trips started per hour, by hour of day",
            "trips per hour",
            tb.clone(),
            BLUE,
        ),
        bar_panel(
            "Door cycles per hour, by hour of day",
            "door openings per hour",
            hours.per_hour(&hours.doors),
            GREEN,
        ),
        bar_panel(
            "Time moving, by hour of day",
            "moving (% of the hour)",
            mb,
            ORANGE,
        ),
        load_histogram(&lambdas),
    ];
    Section {
        figure: Figure {
            name: "usage".into(),
            width: 1200,
            height: 860,
            grid: (2, 2),
            panels,
        },
        heading: "Usage".into(),
        text: usage_text(c, &hours, &tb, &lambdas),
    }
}

/// Bars by hour of day.
fn bar_panel(title: &str, ylabel: &str, bars: Vec<Bar>, color: RGBColor) -> Panel {
    let top = bars.iter().map(|b| b.2).fold(0.0, f64::max);
    let mut p = Panel::new(
        title,
        Axis::new(0.0, 24.0, "hour of day"),
        Axis::new(0.0, (BAR_HEADROOM * top).max(1e-9), ylabel),
    );
    p.marks.push(Mark::Bars {
        bars,
        color,
        label: None,
    });
    p.legend = Legend::None;
    p
}

/// Histogram of the trips' static load λ (% of rated) in [`LOAD_BIN`] bins from zero or below.
fn load_histogram(lambdas: &[f64]) -> Panel {
    let bin = LOAD_BIN;
    let top = quantile(lambdas.iter().copied(), 1.0).max(bin);
    let lo = quantile(lambdas.iter().copied(), 0.0).min(0.0);
    let (b0, b1) = ((lo / bin).floor() as i64, (top / bin).ceil() as i64);
    let mut hist: Vec<Bar> = (b0..b1)
        .map(|k| (k as f64 * bin, (k + 1) as f64 * bin, 0.0))
        .collect();
    for v in lambdas {
        let k = ((v / bin).floor() as i64 - b0).clamp(0, hist.len() as i64 - 1) as usize;
        if let Some(h) = hist.get_mut(k) {
            h.2 += 1.0;
        }
    }
    let hmax = hist.iter().map(|h| h.2).fold(0.0, f64::max);
    let mut p = Panel::new(
        "Load per trip (histogram, 5 % bins)",
        Axis::new(
            b0 as f64 * bin,
            b1 as f64 * bin,
            "static load λ (% of rated load)",
        ),
        Axis::new(0.0, (BAR_HEADROOM * hmax).max(1.0), "trips"),
    );
    p.marks.push(Mark::Bars {
        bars: hist
            .iter()
            .map(|&(a, b, n)| (a + 0.4, b - 0.4, n))
            .collect(),
        color: PURPLE,
        label: None,
    });
    p.legend = Legend::None;
    p
}

/// Trips and door openings per day, time moving, the busiest hour and the trip loads.
fn usage_text(c: &Ctx, hours: &Hours, trips_per_hour: &[Bar], lambdas: &[f64]) -> Vec<String> {
    let days = hours.observed.iter().sum::<f64>() / DAY_S;
    let n_trips = c.inp.features.trips.len();
    let busiest = trips_per_hour
        .iter()
        .copied()
        .fold(
            (f64::NAN, 0.0),
            |acc, b| if b.2 > acc.1 { (b.0, b.2) } else { acc },
        );
    let total_moving: f64 = hours.moving.iter().sum();
    let total_obs: f64 = hours.observed.iter().sum();
    if n_trips == 0 {
        return vec![format!(
            "No complete trip in {} of data with speed; the car moved {:.1} % of the time.",
            span_text(total_obs),
            100.0 * total_moving / total_obs.max(1e-9)
        )];
    }
    vec![format!(
        "{n_trips} complete trips in {} of data with speed ({} per day), {} door openings per day; the car moved {:.1} % of the \
         time. The busiest hour of day starts at {:02}:00 with {} trips per hour on average. Trip loads (static λ, held from \
         door close): median {} %, 90th percentile {} % of the rated load. Hours of day are the time stamps modulo 24 h.",
        span_text(total_obs),
        num(n_trips as f64 / days.max(1e-9)),
        num(hours.doors.iter().sum::<f64>() / days.max(1e-9)),
        100.0 * total_moving / total_obs.max(1e-9),
        busiest.0.floor() as i64,
        num(busiest.1),
        num(quantile(lambdas.iter().copied(), 0.5)),
        num(quantile(lambdas.iter().copied(), 0.9)),
    )]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::figures::fixture::{assert_drawn, Fixture};

    #[test]
    fn usage_is_drawn_from_a_small_series() {
        let f = Fixture::get();
        let inp = f.inputs();
        let c = Ctx::new(&inp);
        let s = usage(&c);
        assert_eq!(s.heading, "Usage");
        assert_eq!(s.figure.panels.len(), 4);
        assert!(
            s.text[0].starts_with(&format!(
                "{} complete trips",
                f.analysis.features.trips.len()
            )),
            "{}",
            s.text[0]
        );
        assert_drawn(&s, "hour of day");
    }

    #[test]
    fn load_histogram_counts_every_trip_once() {
        let p = load_histogram(&[-3.0, 0.0, 4.9, 5.0, 61.0]);
        let Mark::Bars { bars, .. } = &p.marks[0] else {
            panic!("the histogram is drawn as bars");
        };
        assert_eq!(bars.iter().map(|b| b.2).sum::<f64>(), 5.0);
        assert_eq!(bars.len(), 14, "bins from -5 % to 65 %");
        assert_eq!(bars[1].2, 2.0, "0 and 4.9 share the bin 0-5 %");
    }
}
