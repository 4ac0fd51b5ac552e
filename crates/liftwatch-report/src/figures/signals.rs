//! Figures of stages 2-3: the aligned signals over the busiest excerpt (`preprocessing`) and
//! the two acceleration paths with their fusion (`acceleration`).
//!
//! ```text
//! a_v = Δv/Δt                      speed path
//! a_L = k·(L − L_ref)              load-cell path, door closed
//! a   = β·a_v + (1 − β)·a_L        fused, β by phase of the trip and load
//! ```

use liftwatch::features::{FeatureRow, Trip};
use liftwatch::Sample;

use super::{excerpt_line, num, span_text, steps, Ctx, Section, Time};
use crate::plot::{colors::*, quantile, robust_range, Axis, Dash, Figure, Legend, Mark, Panel};

/// Floors the floor panel shows at least, so that its ticks are floor numbers.
const MIN_FLOORS: f64 = 4.0;
/// Trips the acceleration figure shows at most.
const ACCEL_TRIPS: usize = 3;
/// Samples a trip of the acceleration figure lasts at least, and the margin around them.
const ACCEL_MARGIN_STEPS: f64 = 6.0;
/// Length of the acceleration excerpt when the preprocessing excerpt has no trip (s).
const ACCEL_FALLBACK_S: f64 = 180.0;

/// The columns of the preprocessing figure: the aligned samples and, from the feature rows,
/// signed v and λ (% of rated load).
struct Signals {
    /// Sample times (s).
    t: Vec<f64>,
    /// Encoder speed, a magnitude (m/s).
    speed: Vec<f64>,
    /// Load reading (% of rated).
    load: Vec<f64>,
    /// Door state (1 open).
    door: Vec<f64>,
    /// Floor indicator.
    floor: Vec<f64>,
    /// Feature row times (s).
    rt: Vec<f64>,
    /// Signed velocity v, + up (m/s).
    v: Vec<f64>,
    /// Static load ratio λ held from door close (% of rated).
    lam: Vec<f64>,
}

impl Signals {
    /// The columns of the whole series.
    fn new(c: &Ctx) -> Signals {
        let s = &c.inp.series.samples;
        let col = |f: fn(&Sample) -> f64| s.iter().map(f).collect::<Vec<f64>>();
        let rows = c.rows();
        Signals {
            t: col(|x| x.time),
            speed: col(|x| x.speed),
            load: col(|x| x.load),
            door: col(|x| x.door),
            floor: col(|x| x.floor),
            rt: rows.iter().map(|r| r.time).collect(),
            v: rows.iter().map(|r| r.v).collect(),
            lam: rows.iter().map(|r| 100.0 * r.lambda).collect(),
        }
    }
}

/// The values of `y` whose time lies in `[a, b]`.
fn in_window(t: &[f64], y: &[f64], a: f64, b: f64) -> Vec<f64> {
    t.iter()
        .zip(y)
        .filter(|(t, _)| **t >= a && **t <= b)
        .map(|p| *p.1)
        .collect()
}

/// Shaded bands behind the data, one per trip.
fn trip_bands<'t>(time: &Time, trips: impl IntoIterator<Item = &'t Trip>) -> Vec<Mark> {
    trips
        .into_iter()
        .map(|tr| Mark::Band {
            x0: time.x(tr.start_time),
            x1: time.x(tr.end_time),
            color: SKY,
        })
        .collect()
}

/// Aligned signals over the excerpt `[a, b]`: velocity, load, door, floor.
pub(super) fn preprocessing(c: &Ctx, a: f64, b: f64) -> Section {
    let sig = Signals::new(c);
    let time = Time::excerpt(c.start, a, b);
    let x = time.axis(a, b);
    let bands = trip_bands(&time, c.trips_in(a, b));
    let mut panels = vec![
        velocity_panel(&sig, &time, x.clone(), a, b),
        load_panel(&sig, &time, x.clone(), a, b, c.step),
        door_panel(&sig, &time, x.clone(), a, b, c.step),
        floor_panel(&sig, &time, x, a, b, c.step),
    ];
    for p in &mut panels {
        p.marks.splice(0..0, bands.iter().cloned());
        p.legend = Legend::None;
    }
    Section {
        figure: Figure {
            name: "preprocessing".into(),
            width: 1200,
            height: 1100,
            grid: (4, 1),
            panels,
        },
        heading: "Preprocessing: the aligned signals".into(),
        text: preprocessing_text(c, &sig, a, b),
    }
}

/// Encoder speed and signed v.
fn velocity_panel(sig: &Signals, time: &Time, x: Axis, a: f64, b: f64) -> Panel {
    let vin = in_window(&sig.rt, &sig.v, a, b);
    let (lo, hi) = robust_range(&vin, 0.0, 1.0, &[0.0]);
    let mut p = Panel::new(
        "Car velocity: encoder speed (grey) and signed v, + up (blue); shaded: trips",
        x,
        Axis::new(lo, hi, "velocity (m/s)"),
    );
    p.marks.push(Mark::Line {
        pts: excerpt_line(time, &sig.t, &sig.speed, a, b),
        color: GREY,
        width: 4,
        label: Some("speed, encoder (magnitude)".into()),
    });
    p.marks.push(Mark::Line {
        pts: excerpt_line(time, &sig.rt, &sig.v, a, b),
        color: BLUE,
        width: 2,
        label: Some("signed v (+ up)".into()),
    });
    p
}

/// Load reading and the static λ held from door close.
fn load_panel(sig: &Signals, time: &Time, x: Axis, a: f64, b: f64, step: f64) -> Panel {
    let lin = in_window(&sig.t, &sig.load, a, b);
    let (lo, hi) = robust_range(&lin, 0.0, 1.0, &in_window(&sig.rt, &sig.lam, a, b));
    let mut p = Panel::new(
        "Load-weighing sensor: reading (black) and static λ held from door close (orange)",
        x,
        Axis::new(lo.min(0.0), hi, "load (% of rated)"),
    );
    p.marks.push(Mark::Line {
        pts: excerpt_line(time, &sig.t, &sig.load, a, b),
        color: INK,
        width: 2,
        label: Some("load reading".into()),
    });
    p.marks.push(Mark::Line {
        pts: steps(time, &sig.rt, &sig.lam, a, b, step),
        color: ORANGE,
        width: 3,
        label: Some("static λ, held from door close".into()),
    });
    p
}

/// Door state, closed or open.
fn door_panel(sig: &Signals, time: &Time, x: Axis, a: f64, b: f64, step: f64) -> Panel {
    let mut p = Panel::new("Door", x, Axis::new(-0.15, 1.15, "door state"));
    p.marks.push(Mark::Line {
        pts: steps(time, &sig.t, &sig.door, a, b, step),
        color: GREEN,
        width: 2,
        label: None,
    });
    p.y_ticks = vec![(0.0, "closed".into()), (1.0, "open".into())];
    p
}

/// Floor indicator over whole floors.
fn floor_panel(sig: &Signals, time: &Time, x: Axis, a: f64, b: f64, step: f64) -> Panel {
    let fin = in_window(&sig.t, &sig.floor, a, b);
    let (flo, fhi) = (
        quantile(fin.iter().copied(), 0.0),
        quantile(fin.iter().copied(), 1.0),
    );
    // Whole floors, at least five of them, so that the ticks are floor numbers.
    let (flo, fhi) = if flo.is_finite() {
        let pad = (0.5 * (MIN_FLOORS - (fhi - flo))).max(0.0).ceil();
        (flo - pad - 0.5, fhi + pad + 0.5)
    } else {
        (0.5, 5.5)
    };
    let mut p = Panel::new("Floor indicator", x, Axis::new(flo, fhi, "floor"));
    p.marks.push(Mark::Line {
        pts: steps(time, &sig.t, &sig.floor, a, b, step),
        color: PURPLE,
        width: 2,
        label: None,
    });
    p
}

/// Coverage of the input, then what the excerpt holds.
fn preprocessing_text(c: &Ctx, sig: &Signals, a: f64, b: f64) -> Vec<String> {
    let s = &c.inp.series.samples;
    let n_trips = c.trips_in(a, b).count();
    let opens = sig
        .door
        .windows(2)
        .zip(&sig.t[1..])
        .filter(|(w, t)| **t >= a && **t <= b && w[0] < 0.5 && w[1] >= 0.5)
        .count();
    let missing = s
        .iter()
        .filter(|x| !x.speed.is_finite() || !x.voltage.is_finite() || !x.load.is_finite())
        .count();
    vec![
        format!(
            "The input covers {} at a uniform step of {} s ({} samples); {:.2} % of them lack speed, voltage or load \
             (gaps longer than the alignment limit are left empty and break the lines below, never bridged).",
            span_text(c.end - c.start),
            num(c.step),
            s.len(),
            100.0 * missing as f64 / s.len().max(1) as f64
        ),
        format!(
            "Shown: the busiest {} of the data, from {} to {} after its start: {} complete trips and {} door openings. \
             The load cell swings while the car accelerates, because it also feels the inertia of the load; \
             the static load ratio λ is therefore the reading held from the last door close (orange).",
            span_text(b - a),
            span_text(a - c.start),
            span_text(b - c.start),
            n_trips,
            opens
        ),
    ]
}

/// a_v, a_L and the fused a over up to three trips of the excerpt `[a, b]`.
pub(super) fn acceleration(c: &Ctx, a: f64, b: f64) -> Section {
    let margin = ACCEL_MARGIN_STEPS * c.step;
    let trips: Vec<&Trip> = c
        .trips_in(a, b)
        .filter(|t| t.end_time - t.start_time >= margin)
        .take(ACCEL_TRIPS)
        .collect();
    let (ta, tb) = match (trips.first(), trips.last()) {
        (Some(f), Some(l)) => (f.start_time - margin, l.end_time + margin),
        _ => (a, (a + ACCEL_FALLBACK_S).min(b)),
    };
    Section {
        figure: Figure {
            name: "acceleration".into(),
            width: 1200,
            height: 560,
            grid: (1, 1),
            panels: vec![acceleration_panel(c, &trips, ta, tb)],
        },
        heading: "Preprocessing: acceleration from 1 Hz data".into(),
        text: acceleration_text(c),
    }
}

/// The three accelerations over `[ta, tb]`, the trips shaded.
fn acceleration_panel(c: &Ctx, trips: &[&Trip], ta: f64, tb: f64) -> Panel {
    let time = Time::excerpt(c.start, ta, tb);
    let rows: Vec<&FeatureRow> = c
        .rows()
        .iter()
        .filter(|r| r.time >= ta && r.time <= tb)
        .collect();
    let pts = |f: fn(&FeatureRow) -> f64| {
        rows.iter()
            .map(|r| (time.x(r.time), f(r)))
            .collect::<Vec<_>>()
    };
    let all: Vec<f64> = rows.iter().flat_map(|r| [r.a_v, r.a_l, r.a]).collect();
    let (lo, hi) = robust_range(&all, 0.0, 1.0, &[0.0]);
    let mut p = Panel::new(
        format!(
            "Acceleration over {} trips: two paths and their fusion",
            trips.len()
        ),
        time.axis(ta, tb),
        Axis::new(lo, hi, "acceleration (m/s²)"),
    );
    p.marks = trip_bands(&time, trips.iter().copied());
    p.marks.push(Mark::HLine {
        y: 0.0,
        color: GREY,
        dash: Dash::Solid,
        label: None,
    });
    for (f, color, label) in [
        (
            (|r: &FeatureRow| r.a_v) as fn(&FeatureRow) -> f64,
            BLUE,
            "a_v = Δv/Δt (speed path)",
        ),
        (|r| r.a_l, ORANGE, "a_L = k·(L − L_ref) (load-cell path)"),
    ] {
        p.marks.push(Mark::Line {
            pts: pts(f),
            color,
            width: 2,
            label: Some(label.into()),
        });
        p.marks.push(Mark::Dots {
            pts: pts(f),
            color,
            radius: 3,
            label: None,
        });
    }
    p.marks.push(Mark::Line {
        pts: pts(|r| r.a),
        color: INK,
        width: 3,
        label: Some("fused a".into()),
    });
    p.legend = Legend::UpperRight;
    p
}

/// The fusion's settings and how well the two paths agree over all moving samples.
fn acceleration_text(c: &Ctx) -> Vec<String> {
    let moving: Vec<&FeatureRow> = c
        .rows()
        .iter()
        .filter(|r| r.s != 0 && r.a_v.is_finite() && r.a_l.is_finite())
        .collect();
    let rms = |f: &dyn Fn(&FeatureRow) -> f64| {
        (moving.iter().map(|r| f(r).powi(2)).sum::<f64>() / moving.len().max(1) as f64).sqrt()
    };
    let cfg = &c.inp.model.features;
    let agreement = if moving.is_empty() {
        "The data hold no moving sample with both paths.".to_string()
    } else {
        format!(
            "Over all {} moving samples of the data the two paths differ by {} m/s² RMS, against an RMS acceleration \
             of {} m/s².",
            moving.len(),
            num(rms(&|r| r.a_v - r.a_l)),
            num(rms(&|r| r.a)),
        )
    };
    vec![format!(
        "At 1 Hz the speed difference a_v is fast but noisy; the load-cell path a_L reads the inertial swing of the load \
         cell while the door is closed (platform ratio k fitted on the healthy history: {}). The fused acceleration weighs \
         a_v by β = {} while starting and braking and by β = {} while cruising (at half load). {agreement}",
        num(cfg.load_cell_platform_ratio),
        num(cfg.beta_transient),
        num(cfg.beta_cruise),
    )]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::figures::fixture::{assert_drawn, Fixture};

    #[test]
    fn preprocessing_and_acceleration_are_drawn_from_a_small_series() {
        let f = Fixture::get();
        let inp = f.inputs();
        let c = Ctx::new(&inp);
        let (a, b) = c.busiest(0.0, super::super::EXCERPT_S);
        let s = preprocessing(&c, a, b);
        assert_eq!(s.heading, "Preprocessing: the aligned signals");
        assert_eq!(s.figure.panels.len(), 4);
        assert_drawn(&s, "velocity (m/s)");
        let s = acceleration(&c, a, b);
        assert_eq!(s.heading, "Preprocessing: acceleration from 1 Hz data");
        assert_drawn(&s, "acceleration (m/s²)");
    }
}
