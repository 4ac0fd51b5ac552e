//! The report's figures, each with the sentences that explain it, numbers from the same data.
//!
//! Excerpts are chosen, not hand-picked: the preprocessing excerpt is the 20 minutes with the
//! most moving, fully measured samples; the fit excerpt is the busiest 20 minutes of the last
//! quarter of the data, where a developing fault shows most.

use liftwatch::alarm::Level;
use liftwatch::features::FeatureRow;
use liftwatch::mode::FaultMode;
use liftwatch::model::PhysParams;
use liftwatch::residual::Residuals;

const MOTOR: usize = FaultMode::Motor as usize;
const BRAKE: usize = FaultMode::Brake as usize;
const FRICTION: usize = FaultMode::Friction as usize;

use crate::plot::{
    colors::*, decimate, quantile, robust_range, Axis, Dash, Figure, Legend, Mark, Panel,
};
use crate::ReportInputs;

/// Pixel columns a full-width series is thinned to.
const COLUMNS: usize = 1100;
/// Length of the preprocessing excerpt (s).
const EXCERPT_S: f64 = 1200.0;
/// Length of the fit excerpt (s): short enough to see each trip's shape.
const FIT_EXCERPT_S: f64 = 360.0;

/// The paper's symbol of a physical parameter named as in [`PhysParams::NAMES`].
fn symbol(name: &str) -> &str {
    match name {
        "delta_m" => "Δm",
        "m0" => "M0",
        "f_c" => "F_c",
        "c_visc" => "c",
        "kd" => "Kd",
        "ke" => "Ke",
        "u0" => "U0",
        "alpha_down" => "α_down",
        other => other,
    }
}

/// One figure of the report and its text.
pub(crate) struct Section {
    /// The figure.
    pub figure: Figure,
    /// Heading in the report.
    pub heading: String,
    /// Paragraphs (already HTML: numbers and plain words only, no user text).
    pub text: Vec<String>,
}

/// A time axis: origin, unit and description.
#[derive(Clone, Debug)]
struct Time {
    origin: f64,
    unit_s: f64,
    label: String,
}

impl Time {
    /// Seconds, minutes, hours or days, whichever suits `span` seconds.
    fn unit(span: f64) -> (f64, &'static str) {
        if span <= 600.0 {
            (1.0, "s")
        } else if span <= 3.0 * 3600.0 {
            (60.0, "min")
        } else if span <= 3.0 * 86400.0 {
            (3600.0, "h")
        } else {
            (86400.0, "days")
        }
    }

    /// The axis of the whole series: time since its start.
    fn whole(start: f64, end: f64) -> Time {
        let (unit_s, u) = Time::unit(end - start);
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

    fn x(&self, t: f64) -> f64 {
        (t - self.origin) / self.unit_s
    }

    fn axis(&self, a: f64, b: f64) -> Axis {
        Axis::new(self.x(a), self.x(b), self.label.clone())
    }
}

/// A duration in words: `42 s`, `17.5 min`, `5.3 h`, `2.40 days`.
fn span_text(s: f64) -> String {
    if s < 120.0 {
        format!("{s:.0} s")
    } else if s < 2.0 * 3600.0 {
        format!("{:.1} min", s / 60.0)
    } else if s < 2.0 * 86400.0 {
        format!("{:.1} h", s / 3600.0)
    } else {
        format!("{:.2} days", s / 86400.0)
    }
}

/// A number with three significant digits, plainly written.
fn num(v: f64) -> String {
    if !v.is_finite() {
        return "n/a".into();
    }
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if !(1e-3..1e5).contains(&a) {
        format!("{v:.2e}")
    } else {
        let d = (2 - a.log10().floor() as i32).max(0) as usize;
        format!("{v:.d$}")
    }
}

/// Derived data several figures share.
struct Ctx<'a> {
    inp: &'a ReportInputs<'a>,
    start: f64,
    end: f64,
    step: f64,
    whole: Time,
    /// Residuals of each feature row.
    res: Vec<Residuals>,
}

impl<'a> Ctx<'a> {
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

    fn trips_in(&self, a: f64, b: f64) -> impl Iterator<Item = &'a liftwatch::features::Trip> {
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

/// All sections, in report order.
pub(crate) fn all(inp: &ReportInputs) -> Vec<Section> {
    let c = Ctx::new(inp);
    let (pa, pb) = c.busiest(0.0, EXCERPT_S);
    vec![
        preprocessing(&c, pa, pb),
        acceleration(&c, pa, pb),
        training(&c),
        parameters(&c),
        fit(&c),
        residuals(&c),
        risk(&c),
        comparison(&c),
        usage(&c),
    ]
}

fn preprocessing(c: &Ctx, a: f64, b: f64) -> Section {
    let s = &c.inp.series.samples;
    let time = Time::excerpt(c.start, a, b);
    let t: Vec<f64> = s.iter().map(|x| x.time).collect();
    let col = |f: fn(&liftwatch::Sample) -> f64| s.iter().map(f).collect::<Vec<f64>>();
    let (speed, load, door, floor) = (
        col(|x| x.speed),
        col(|x| x.load),
        col(|x| x.door),
        col(|x| x.floor),
    );
    let rows = c.rows();
    let rt: Vec<f64> = rows.iter().map(|r| r.time).collect();
    let v: Vec<f64> = rows.iter().map(|r| r.v).collect();
    let lam: Vec<f64> = rows.iter().map(|r| 100.0 * r.lambda).collect();
    let x = time.axis(a, b);
    let bands: Vec<Mark> = c
        .trips_in(a, b)
        .map(|tr| Mark::Band {
            x0: time.x(tr.start_time),
            x1: time.x(tr.end_time),
            color: SKY,
        })
        .collect();
    let in_win = |t: &[f64], y: &[f64]| -> Vec<f64> {
        t.iter()
            .zip(y)
            .filter(|(t, _)| **t >= a && **t <= b)
            .map(|p| *p.1)
            .collect()
    };
    let vin = in_win(&rt, &v);
    let (lo, hi) = robust_range(&vin, 0.0, 1.0, &[0.0]);
    let mut p1 = Panel::new(
        "Car velocity: encoder speed (grey) and signed v, + up (blue); shaded: trips",
        x.clone(),
        Axis::new(lo, hi, "velocity (m/s)"),
    );
    p1.marks = bands.clone();
    p1.marks.push(Mark::Line {
        pts: excerpt_line(&time, &t, &speed, a, b),
        color: GREY,
        width: 4,
        label: Some("speed, encoder (magnitude)".into()),
    });
    p1.marks.push(Mark::Line {
        pts: excerpt_line(&time, &rt, &v, a, b),
        color: BLUE,
        width: 2,
        label: Some("signed v (+ up)".into()),
    });
    p1.legend = Legend::None;
    let lin = in_win(&t, &load);
    let (lo, hi) = robust_range(&lin, 0.0, 1.0, &in_win(&rt, &lam));
    let mut p2 = Panel::new(
        "Load-weighing sensor: reading (black) and static λ held from door close (orange)",
        x.clone(),
        Axis::new(lo.min(0.0), hi, "load (% of rated)"),
    );
    p2.marks = bands.clone();
    p2.marks.push(Mark::Line {
        pts: excerpt_line(&time, &t, &load, a, b),
        color: INK,
        width: 2,
        label: Some("load reading".into()),
    });
    p2.marks.push(Mark::Line {
        pts: steps(&time, &rt, &lam, a, b, c.step),
        color: ORANGE,
        width: 3,
        label: Some("static λ, held from door close".into()),
    });
    p2.legend = Legend::None;
    let mut p3 = Panel::new("Door", x.clone(), Axis::new(-0.15, 1.15, "door state"));
    p3.marks = bands.clone();
    p3.marks.push(Mark::Line {
        pts: steps(&time, &t, &door, a, b, c.step),
        color: GREEN,
        width: 2,
        label: None,
    });
    p3.y_ticks = vec![(0.0, "closed".into()), (1.0, "open".into())];
    p3.legend = Legend::None;
    let fin = in_win(&t, &floor);
    let (flo, fhi) = (
        quantile(fin.iter().copied(), 0.0),
        quantile(fin.iter().copied(), 1.0),
    );
    // Whole floors, at least five of them, so that the ticks are floor numbers.
    let (flo, fhi) = if flo.is_finite() {
        let pad = (0.5 * (4.0 - (fhi - flo))).max(0.0).ceil();
        (flo - pad - 0.5, fhi + pad + 0.5)
    } else {
        (0.5, 5.5)
    };
    let mut p4 = Panel::new("Floor indicator", x, Axis::new(flo, fhi, "floor"));
    p4.marks = bands;
    p4.marks.push(Mark::Line {
        pts: steps(&time, &t, &floor, a, b, c.step),
        color: PURPLE,
        width: 2,
        label: None,
    });
    p4.legend = Legend::None;
    let n_trips = c.trips_in(a, b).count();
    let opens = door
        .windows(2)
        .zip(&t[1..])
        .filter(|(w, t)| **t >= a && **t <= b && w[0] < 0.5 && w[1] >= 0.5)
        .count();
    let missing = s
        .iter()
        .filter(|x| !x.speed.is_finite() || !x.voltage.is_finite() || !x.load.is_finite())
        .count();
    let text = vec![
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
    ];
    Section {
        figure: Figure {
            name: "preprocessing".into(),
            width: 1200,
            height: 1100,
            grid: (4, 1),
            panels: vec![p1, p2, p3, p4],
        },
        heading: "Preprocessing: the aligned signals".into(),
        text,
    }
}

fn acceleration(c: &Ctx, a: f64, b: f64) -> Section {
    let trips: Vec<_> = c
        .trips_in(a, b)
        .filter(|t| t.end_time - t.start_time >= 6.0 * c.step)
        .take(3)
        .collect();
    let (ta, tb) = match (trips.first(), trips.last()) {
        (Some(f), Some(l)) => (f.start_time - 6.0 * c.step, l.end_time + 6.0 * c.step),
        _ => (a, (a + 180.0).min(b)),
    };
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
    for t in &trips {
        p.marks.push(Mark::Band {
            x0: time.x(t.start_time),
            x1: time.x(t.end_time),
            color: SKY,
        });
    }
    p.marks.push(Mark::HLine {
        y: 0.0,
        color: GREY,
        dash: Dash::Solid,
        label: None,
    });
    p.marks.push(Mark::Line {
        pts: pts(|r| r.a_v),
        color: BLUE,
        width: 2,
        label: Some("a_v = Δv/Δt (speed path)".into()),
    });
    p.marks.push(Mark::Dots {
        pts: pts(|r| r.a_v),
        color: BLUE,
        radius: 3,
        label: None,
    });
    p.marks.push(Mark::Line {
        pts: pts(|r| r.a_l),
        color: ORANGE,
        width: 2,
        label: Some("a_L = k·(L − L_ref) (load-cell path)".into()),
    });
    p.marks.push(Mark::Dots {
        pts: pts(|r| r.a_l),
        color: ORANGE,
        radius: 3,
        label: None,
    });
    p.marks.push(Mark::Line {
        pts: pts(|r| r.a),
        color: INK,
        width: 3,
        label: Some("fused a".into()),
    });
    p.legend = Legend::UpperRight;
    // Agreement of the two paths over all moving samples of the data.
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
    let text = vec![format!(
        "At 1 Hz the speed difference a_v is fast but noisy; the load-cell path a_L reads the inertial swing of the load \
         cell while the door is closed (platform ratio k fitted on the healthy history: {}). The fused acceleration weighs \
         a_v by β = {} while starting and braking and by β = {} while cruising (at half load). {agreement}",
        num(cfg.load_cell_platform_ratio),
        num(cfg.beta_transient),
        num(cfg.beta_cruise),
    )];
    Section {
        figure: Figure {
            name: "acceleration".into(),
            width: 1200,
            height: 560,
            grid: (1, 1),
            panels: vec![p],
        },
        heading: "Preprocessing: acceleration from 1 Hz data".into(),
        text,
    }
}

fn training(c: &Ctx) -> Section {
    let fit = &c.inp.model.summary;
    let h = &fit.history;
    let it: Vec<f64> = h.iter().map(|p| p.iteration as f64).collect();
    let (x0, x1) = (
        it.first().copied().unwrap_or(0.0),
        it.last().copied().unwrap_or(1.0).max(1.0),
    );
    let x = Axis::new(x0, x1, "iteration");
    let stage2 = h.iter().find(|p| p.stage >= 2).map(|p| p.iteration as f64);
    let loss: Vec<f64> = h.iter().map(|p| p.loss).collect();
    let (lmin, lmax) = (
        quantile(loss.iter().copied(), 0.0),
        quantile(loss.iter().copied(), 1.0),
    );
    let y = if lmin > 0.0 && lmax / lmin > 20.0 {
        Axis::log(lmin, lmax, "loss L (log scale)")
    } else {
        // Less than about a decade: a tight log range, labelled with its own values.
        let (lo, hi) = if lmin > 0.0 {
            (
                lmin / (lmax / lmin).powf(0.08).max(1.002),
                lmax * (lmax / lmin).powf(0.08).max(1.002),
            )
        } else {
            (0.1, 1.0)
        };
        Axis {
            min: lo,
            max: hi,
            label: "loss L (log scale)".into(),
            log: true,
        }
    };
    let mut p1 = Panel::new("Training loss", x.clone(), y);
    p1.marks.push(Mark::Line {
        pts: it.iter().copied().zip(loss.iter().copied()).collect(),
        color: INK,
        width: 3,
        label: Some("loss".into()),
    });
    let mut p2 = Panel::new(
        "RMS residuals on moving samples",
        x.clone(),
        Axis::new(0.0, 1.0, ""),
    );
    let ru: Vec<f64> = h.iter().map(|p| p.rms_u_v).collect();
    let rf: Vec<f64> = h.iter().map(|p| p.rms_f_n).collect();
    let (_, hu) = robust_range(&ru, 0.0, 1.0, &[0.0]);
    p2.y = Axis::new(0.0, hu, "RMS r_U (V)");
    p2.marks.push(Mark::Line {
        pts: it.iter().copied().zip(ru.iter().copied()).collect(),
        color: BLUE,
        width: 3,
        label: Some("r_U".into()),
    });
    let (_, hf) = robust_range(&rf, 0.0, 1.0, &[0.0]);
    let mut p3 = Panel::new("", x, Axis::new(0.0, hf, "RMS r_F (N)"));
    p3.title = "RMS force residual".into();
    p3.marks.push(Mark::Line {
        pts: it.iter().copied().zip(rf.iter().copied()).collect(),
        color: ORANGE,
        width: 3,
        label: Some("r_F".into()),
    });
    p2.title = "RMS voltage residual".into();
    for p in [&mut p1, &mut p2, &mut p3] {
        if let Some(s) = stage2 {
            p.marks.insert(
                0,
                Mark::VLine {
                    x: s,
                    color: GREY,
                    label: Some("stage 2 starts".into()),
                },
            );
        }
        p.legend = Legend::UpperRight;
    }
    let first = h.first().map_or(f64::NAN, |p| p.loss);
    let text = vec![format!(
        "The fit has two stages: Gauss-Newton on the physical parameters θ alone (stage 1), then θ and the correcting \
         network together (stage 2, {} iterations). The loss went from {} to {} (a factor {}; {} at the end of stage 1). Final RMS \
         residuals on the {} moving training samples: r_U {} V and r_F {} N; the healthy scales that make residuals \
         dimensionless are σ_U = {} V and σ_F = {} N.",
        fit.iterations,
        num(first),
        num(fit.loss_final),
        num(first / fit.loss_final),
        num(fit.loss_stage1),
        fit.moving_samples,
        num(fit.rms_u_v),
        num(fit.rms_f_n),
        num(c.inp.model.hybrid.scales.sigma_u_v),
        num(c.inp.model.hybrid.scales.sigma_f_n),
    )];
    Section {
        figure: Figure {
            name: "training".into(),
            width: 1500,
            height: 520,
            grid: (1, 3),
            panels: vec![p1, p2, p3],
        },
        heading: "Training: loss and residuals".into(),
        text,
    }
}

fn parameters(c: &Ctx) -> Section {
    let fit = &c.inp.model.summary;
    let h = &fit.history;
    let it: Vec<f64> = h.iter().map(|p| p.iteration as f64).collect();
    let (x0, x1) = (
        it.first().copied().unwrap_or(0.0),
        it.last().copied().unwrap_or(1.0).max(1.0),
    );
    let final_theta = c.inp.model.hybrid.parameters.to_array();
    let mut panels = Vec::new();
    let mut rows_html = Vec::new();
    for (k, (&name, &unit)) in PhysParams::NAMES
        .iter()
        .zip(PhysParams::UNITS.iter())
        .enumerate()
    {
        let value = final_theta.get(k).copied().unwrap_or(f64::NAN);
        let vals: Vec<f64> = h
            .iter()
            .map(|p| p.theta.get(k).copied().unwrap_or(f64::NAN))
            .collect();
        let (lo, hi) = robust_range(&vals, 0.0, 1.0, &[value]);
        let report = fit.parameters.iter().find(|r| r.name == name);
        let se = report.and_then(|r| r.std_error).unwrap_or(f64::NAN);
        let sym = symbol(name);
        let mut p = Panel::new(
            format!(
                "{sym} = {}{}  ({name})",
                num(value),
                if unit == "1" {
                    String::new()
                } else {
                    format!(" {unit}")
                }
            ),
            Axis::new(x0, x1, "iteration"),
            Axis::new(lo, hi, format!("{sym} ({unit})")),
        );
        p.marks.push(Mark::HLine {
            y: value,
            color: GREY,
            dash: Dash::Dashed,
            label: None,
        });
        for sign in [-1.0, 1.0] {
            p.marks.push(Mark::HLine {
                y: value + sign * se,
                color: GREEN,
                dash: Dash::Dashed,
                label: None,
            });
        }
        p.marks.push(Mark::Line {
            pts: it.iter().copied().zip(vals).collect(),
            color: BLUE,
            width: 3,
            label: None,
        });
        p.legend = Legend::None;
        panels.push(p);
        let by = match report {
            Some(r) if r.determined => "data",
            Some(_) => "prior (weakly identifiable)",
            None => "n/a",
        };
        rows_html.push(format!(
            "<tr><td>{name}</td><td>{}</td><td>{}</td><td>{unit}</td><td>{by}</td></tr>",
            num(value),
            num(se)
        ));
    }
    let table = format!(
        "<table><tr><th>parameter</th><th>value</th><th>std. error</th><th>unit</th><th>decided by</th></tr>{}</table>",
        rows_html.join("")
    );
    let cols = if panels.len() == 8 { 4 } else { 3 };
    let grid = (panels.len().div_ceil(cols).max(1), cols);
    let determined = fit
        .parameters
        .iter()
        .filter(|r| r.determined && PhysParams::NAMES.contains(&r.name.as_str()))
        .count();
    let mut text = vec![
        format!(
            "Each panel follows one physical parameter through the fit (grey dashed: final value; green dashed: ± one \
             standard error, where it falls inside the panel). {determined} of the {} \
             parameters are determined by the data (standard error at least three times narrower than the prior); the \
             rest stay near their prior. Standard errors treat samples as independent, so they are lower bounds.",
            PhysParams::NAMES.len()
        ),
        table,
    ];
    for w in &fit.warnings {
        text.push(format!("Note from the fit: {}.", crate::html::escape(w)));
    }
    Section {
        figure: Figure {
            name: "parameters".into(),
            width: 400 * grid.1 as u32,
            height: 380 * grid.0 as u32,
            grid,
            panels,
        },
        heading: "Training: convergence of the physical parameters".into(),
        text,
    }
}

fn fit(c: &Ctx) -> Section {
    let (a, b) = c.busiest(0.75, FIT_EXCERPT_S);
    let time = Time::excerpt(c.start, a, b);
    let m = c.inp.model;
    let rows: Vec<&FeatureRow> = c
        .rows()
        .iter()
        .filter(|r| r.time >= a && r.time <= b)
        .collect();
    let preds: Vec<_> = rows
        .iter()
        .map(|r| liftwatch::residual::applicable(r).then(|| m.hybrid.predict(r)))
        .collect();
    let xs: Vec<f64> = rows.iter().map(|r| time.x(r.time)).collect();
    let u_meas: Vec<f64> = rows.iter().map(|r| r.voltage).collect();
    let u_pred: Vec<f64> = preds
        .iter()
        .map(|p| p.map_or(f64::NAN, |p| p.u_pred))
        .collect();
    let f_u: Vec<f64> = preds
        .iter()
        .map(|p| p.map_or(f64::NAN, |p| p.f_u))
        .collect();
    let f_pred: Vec<f64> = rows
        .iter()
        .zip(&preds)
        .map(|(r, p)| {
            if r.s != 0 {
                p.map_or(f64::NAN, |p| p.f_pred)
            } else {
                f64::NAN
            }
        })
        .collect();
    let zip = |y: &[f64]| {
        xs.iter()
            .copied()
            .zip(y.iter().copied())
            .collect::<Vec<_>>()
    };
    let x = time.axis(a, b);
    let (lo, hi) = robust_range(
        &[u_meas.clone(), u_pred.clone()].concat(),
        0.002,
        0.998,
        &[0.0],
    );
    let mut p1 = Panel::new(
        "Motor voltage: measured U (black) and predicted U_pred (orange)",
        x.clone(),
        Axis::new(lo, hi, "voltage (V)"),
    );
    p1.marks.push(Mark::Line {
        pts: zip(&u_meas),
        color: INK,
        width: 2,
        label: Some("U measured".into()),
    });
    p1.marks.push(Mark::Line {
        pts: zip(&u_pred),
        color: ORANGE,
        width: 2,
        label: Some("U_pred (physics + network)".into()),
    });
    let (lo, hi) = robust_range(
        &[f_u.clone(), f_pred.clone()].concat(),
        0.002,
        0.998,
        &[0.0],
    );
    let mut p2 = Panel::new(
        "Driving force: F_U implied by the measured voltage (black), F_pred predicted (blue)",
        x,
        Axis::new(lo, hi, "force (N, + up)"),
    );
    p2.marks.push(Mark::HLine {
        y: 0.0,
        color: GREY,
        dash: Dash::Solid,
        label: None,
    });
    p2.marks.push(Mark::Line {
        pts: zip(&f_u),
        color: INK,
        width: 2,
        label: Some("F_U from measured voltage".into()),
    });
    p2.marks.push(Mark::Line {
        pts: zip(&f_pred),
        color: BLUE,
        width: 2,
        label: Some("F_pred (physics + network)".into()),
    });
    p1.legend = Legend::None;
    p2.legend = Legend::None;
    let rms = |v: &[f64]| {
        let f: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
        if f.is_empty() {
            return f64::NAN;
        }
        (f.iter().map(|x| x * x).sum::<f64>() / f.len() as f64).sqrt()
    };
    let ru: Vec<f64> = u_meas.iter().zip(&u_pred).map(|(m, p)| m - p).collect();
    let rf: Vec<f64> = f_pred.iter().zip(&f_u).map(|(p, u)| p - u).collect();
    let sc = m.hybrid.scales;
    let res_panel = |title: &str, sym: &str, unit: &str, r: &[f64], sigma: f64, color| {
        let (lo, hi) = robust_range(r, 0.002, 0.998, &[-3.0 * sigma, 3.0 * sigma]);
        let mut p = Panel::new(
            title,
            time.axis(a, b),
            Axis::new(lo, hi, format!("{sym} ({unit})")),
        );
        p.marks.push(Mark::HLine {
            y: 0.0,
            color: INK,
            dash: Dash::Solid,
            label: None,
        });
        p.marks.push(Mark::HLine {
            y: 2.0 * sigma,
            color: GREEN,
            dash: Dash::Dashed,
            label: Some(format!("±2σ healthy ({} {unit})", num(2.0 * sigma))),
        });
        p.marks.push(Mark::HLine {
            y: -2.0 * sigma,
            color: GREEN,
            dash: Dash::Dashed,
            label: None,
        });
        p.marks.push(Mark::Line {
            pts: zip(r),
            color,
            width: 2,
            label: Some(sym.to_string()),
        });
        p.marks.push(Mark::Dots {
            pts: zip(r),
            color,
            radius: 2,
            label: None,
        });
        p
    };
    let p3 = res_panel(
        "Voltage residual r_U = U − U_pred",
        "r_U",
        "V",
        &ru,
        sc.sigma_u_v,
        BLUE,
    );
    let p4 = res_panel(
        "Force residual r_F = F_pred − F_U",
        "r_F",
        "N",
        &rf,
        sc.sigma_f_n,
        ORANGE,
    );
    let text = vec![format!(
        "The busiest {} near the end of the data ({} to {} after its start), where a developing fault shows most. \
         Here the voltage residual r_U = U − U_pred has an RMS of {} V and the force residual r_F = F_pred − F_U an RMS of \
         {} N, against {} V and {} N on the healthy training data. The voltage is predicted at standstill too; the force \
         only while moving (F_U divides by the direction).",
        span_text(b - a),
        span_text(a - c.start),
        span_text(b - c.start),
        num(rms(&ru)),
        num(rms(&rf)),
        num(m.summary.rms_u_v),
        num(m.summary.rms_f_n),
    )];
    Section {
        figure: Figure {
            name: "fit".into(),
            width: 1200,
            height: 1500,
            grid: (4, 1),
            panels: vec![p1, p2, p3, p4],
        },
        heading: "Fit: measured against predicted".into(),
        text,
    }
}

/// Trips in the running mean of the residual figure.
const RUN_TRIPS: usize = 50;

/// Centred running mean over `n` points of `(t, y)`, at each point with a full window.
fn running_mean(pts: &[(f64, f64)], n: usize) -> Vec<(f64, f64)> {
    if pts.len() < n || n == 0 {
        return Vec::new();
    }
    let mut sum: f64 = pts[..n].iter().map(|p| p.1).sum();
    let mut out = vec![(pts[n / 2].0, sum / n as f64)];
    for i in n..pts.len() {
        sum += pts[i].1 - pts[i - n].1;
        out.push((pts[i - n / 2].0, sum / n as f64));
    }
    out
}

/// Mean of `y` per trip over the rows: (mid time, mean) per trip with at least 3 values.
fn trip_means(rows: &[FeatureRow], y: &[f64]) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    let mut cur: Option<(u32, f64, f64, f64, u32)> = None; // trip, t0, t1, sum, n
    let mut flush = |c: &mut Option<(u32, f64, f64, f64, u32)>| {
        if let Some((_, t0, t1, s, n)) = c.take() {
            if n >= 3 {
                out.push((0.5 * (t0 + t1), s / f64::from(n)));
            }
        }
    };
    for (r, &v) in rows.iter().zip(y) {
        let Some(k) = r.trip.filter(|_| r.s != 0 && v.is_finite()) else {
            continue;
        };
        match &mut cur {
            Some((idx, _, t1, s, n)) if *idx == k => {
                *t1 = r.time;
                *s += v;
                *n += 1;
            }
            _ => {
                flush(&mut cur);
                cur = Some((k, r.time, r.time, v, 1));
            }
        }
    }
    flush(&mut cur);
    out
}

fn residuals(c: &Ctx) -> Section {
    let rows = c.rows();
    let t: Vec<f64> = rows.iter().map(|r| r.time).collect();
    let sc = c.inp.model.hybrid.scales;
    let x = c.whole.axis(c.start, c.end);
    let mut panels = Vec::new();
    let mut drift = Vec::new();
    for (name, sym, unit, sigma, color, get) in [
        (
            "Voltage residual",
            "r_U",
            "V",
            sc.sigma_u_v,
            BLUE,
            (|r: &Residuals| r.r_u) as fn(&Residuals) -> f64,
        ),
        (
            "Force residual",
            "r_F",
            "N",
            sc.sigma_f_n,
            ORANGE,
            |r: &Residuals| r.r_f,
        ),
    ] {
        let y: Vec<f64> = rows
            .iter()
            .zip(&c.res)
            .map(|(r, q)| if r.s != 0 { get(q) } else { f64::NAN })
            .collect();
        let means = trip_means(rows, &y);
        let mv: Vec<f64> = means.iter().map(|p| p.1).collect();
        let (lo, hi) = robust_range(&y, 0.002, 0.998, &[-3.0 * sigma, 3.0 * sigma]);
        let mut p = Panel::new(
            format!("{name} {sym} while moving: samples (grey) and trip means"),
            x.clone(),
            Axis::new(lo, hi, format!("{sym} ({unit})")),
        );
        p.marks.push(Mark::Line {
            pts: whole_line(c, &t, &y),
            color: RGBColorExt::light(GREY),
            width: 1,
            label: Some("each sample".into()),
        });
        p.marks.push(Mark::HLine {
            y: 0.0,
            color: INK,
            dash: Dash::Solid,
            label: None,
        });
        p.marks.push(Mark::HLine {
            y: 2.0 * sigma,
            color: GREEN,
            dash: Dash::Dashed,
            label: Some(format!("±2σ healthy ({} {unit})", num(2.0 * sigma))),
        });
        p.marks.push(Mark::HLine {
            y: -2.0 * sigma,
            color: GREEN,
            dash: Dash::Dashed,
            label: None,
        });
        p.marks.push(Mark::Dots {
            pts: means.iter().map(|(t, v)| (c.whole.x(*t), *v)).collect(),
            color,
            radius: 2,
            label: Some("mean per trip".into()),
        });
        p.marks.push(Mark::Line {
            pts: running_mean(&means, RUN_TRIPS)
                .into_iter()
                .map(|(t, v)| (c.whole.x(t), v))
                .collect(),
            color: INK,
            width: 3,
            label: Some(format!("running mean of {RUN_TRIPS} trips")),
        });
        p.legend = Legend::UpperLeft;
        panels.push(p);
        let k = (mv.len() / 10).max(1);
        let first = mv.iter().take(k).sum::<f64>() / k.min(mv.len()).max(1) as f64;
        let last = mv.iter().rev().take(k).sum::<f64>() / k.min(mv.len()).max(1) as f64;
        if !mv.is_empty() {
            drift.push((sym, unit, first, last, sigma));
        }
    }
    let text = vec![format!(
        "Residuals of every moving sample over the whole input (thinned to the minimum and maximum per pixel column, so \
         single spikes stay visible) and their mean over each trip. A healthy elevator keeps the trip means near zero. \
         {}",
        drift
            .iter()
            .map(|(s, u, f, l, sig)| format!(
                "The mean {s} per trip moved from {} {u} in the first tenth of the trips to {} {u} in the last tenth ({} σ).",
                num(*f),
                num(*l),
                num((l - f) / sig)
            ))
            .collect::<Vec<_>>()
            .join(" ")
            + if drift.is_empty() { "No trip has enough moving samples to average." } else { "" }
    )];
    Section {
        figure: Figure {
            name: "residuals".into(),
            width: 1200,
            height: 860,
            grid: (2, 1),
            panels,
        },
        heading: "Fit: both residuals over time".into(),
        text,
    }
}

/// Lighter variants of a colour.
trait RGBColorExt {
    fn light(self) -> Self;
}

impl RGBColorExt for plotters::style::RGBColor {
    fn light(self) -> Self {
        let l = |c: u8| (u16::from(c) + (255 - u16::from(c)) / 2) as u8;
        plotters::style::RGBColor(l(self.0), l(self.1), l(self.2))
    }
}

/// Times at which the level sequence of `rows` enters `level` from below.
fn entries(rows: &[liftwatch::monitor::MonitorRow], level: Level) -> Vec<f64> {
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
fn risk_log(c: &Ctx) -> bool {
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
    .any(|(hi, lo)| lo.is_finite() && hi / lo > 20.0)
}

/// The risk axis: linear from zero, or logarithmic from a twentieth of the lowest threshold
/// (a risk of zero lies on the lower edge).
fn risk_axis(values: &[f64], thresholds: &[f64], label: &str, log: bool) -> Axis {
    let (hi, t_lo) = risk_span(values, thresholds);
    if log && t_lo.is_finite() {
        Axis {
            min: t_lo / 20.0,
            max: 1.5 * hi,
            label: format!("{label}, log scale"),
            log: true,
        }
    } else {
        Axis::new(0.0, hi, label)
    }
}

fn risk(c: &Ctx) -> Section {
    let rows = c.inp.pinn;
    let cfg = &c.inp.model.risk;
    let t: Vec<f64> = rows.iter().map(|r| r.time).collect();
    let rk: Vec<f64> = rows.iter().map(|r| r.risk).collect();
    let x = c.whole.axis(c.start, c.end);
    let mut p1 = Panel::new(
        "Combined risk R (the paper's time-accumulated index)",
        x.clone(),
        risk_axis(&rk, &[cfg.advisory, cfg.alarm], "risk R (1)", risk_log(c)),
    );
    p1.marks.push(Mark::HLine {
        y: cfg.advisory,
        color: ORANGE,
        dash: Dash::Dashed,
        label: Some(format!("advisory threshold {}", num(cfg.advisory))),
    });
    p1.marks.push(Mark::HLine {
        y: cfg.alarm,
        color: RED,
        dash: Dash::Dashed,
        label: Some(format!("alarm threshold {}", num(cfg.alarm))),
    });
    let mut labelled = [false; 3];
    for e in c.inp.events {
        let (i, color, name) = match e.level {
            Level::Normal => (0, GREEN, "event: back to normal"),
            Level::Advisory => (1, ORANGE, "event: advisory"),
            Level::Alarm => (2, RED, "event: alarm"),
        };
        let label = (!labelled[i]).then(|| name.to_string());
        labelled[i] = true;
        p1.marks.push(Mark::VLine {
            x: c.whole.x(e.time),
            color,
            label,
        });
    }
    p1.marks.push(Mark::Line {
        pts: whole_line(c, &t, &rk),
        color: INK,
        width: 3,
        label: Some("R".into()),
    });
    p1.legend = Legend::UpperLeft;
    let modes = [
        (MOTOR, "motor", BLUE),
        (BRAKE, "brake", PURPLE),
        (FRICTION, "friction", GREEN),
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
    let y2 = risk_axis(
        &per.concat(),
        &cfg.advisory_modes,
        "risk R_m (1)",
        risk_log(c),
    );
    let mut p2 = Panel::new(
        "Risk per fault mode, with the per-mode threshold (dashed)",
        x,
        y2,
    );
    let th = cfg.advisory_modes;
    let shared = th
        .iter()
        .all(|t| (t - th[0]).abs() <= 1e-9 * th[0].abs().max(1e-12));
    if shared {
        p2.marks.push(Mark::HLine {
            y: th[0],
            color: INK,
            dash: Dash::Dashed,
            label: Some("per-mode threshold (same for all)".into()),
        });
    }
    for ((m, name, color), y) in modes.iter().zip(&per) {
        if !shared {
            p2.marks.push(Mark::HLine {
                y: th[*m],
                color: *color,
                dash: Dash::Dashed,
                label: None,
            });
        }
        p2.marks.push(Mark::Line {
            pts: whole_line(c, &t, y),
            color: *color,
            width: 3,
            label: Some(name.to_string()),
        });
    }
    p2.headroom = Some(0.08);
    p1.headroom = Some(0.08);
    p2.legend = Legend::UpperLeft;
    let max_r = rk
        .iter()
        .copied()
        .filter(|x| x.is_finite())
        .fold(0.0, f64::max);
    let adv = entries(rows, Level::Advisory);
    let alm = entries(rows, Level::Alarm);
    let final_level = rows.last().map_or(Level::Normal, |r| r.level);
    let events: Vec<String> = c
        .inp
        .events
        .iter()
        .take(12)
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
    let mut text = vec![format!(
        "The risk accumulates the excess of each trip's combined residual over the healthy boundary and decays by γ = {} \
         per trip. {} Over this input R peaks at {}; {}; {}. The level at the end of the data is <b>{}</b>.{} The \
         per-mode threshold is the largest risk each mode reached in the healthy bootstrap of the fit (motor {}, brake {}, \
         friction {}); it attributes an episode to a mode.",
        num(cfg.gamma),
        c.inp.model.calibration.as_ref().map_or("The thresholds are the model file's settings.".to_string(), |k| format!(
            "The thresholds were calibrated on {} healthy trips ({} h), bootstrapped to {} simulated years, for a target of {} \
             false advisories per year (validated: {}).",
            k.trips,
            num(k.hours),
            num(k.years_simulated),
            num(k.target_false_advisories_per_year),
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
    if !events.is_empty() {
        let more = c.inp.events.len().saturating_sub(12);
        text.push(format!(
            "Level changes ({} in all{}):<ul>{}</ul>",
            c.inp.events.len(),
            if more > 0 {
                ", first 12 shown".to_string()
            } else {
                String::new()
            },
            events.join("")
        ));
    }
    Section {
        figure: Figure {
            name: "risk".into(),
            width: 1200,
            height: 860,
            grid: (2, 1),
            panels: vec![p1, p2],
        },
        heading: "Risk over time".into(),
        text,
    }
}

fn comparison(c: &Ctx) -> Section {
    let thr = c.inp.threshold;
    let cfg = &c.inp.model.risk;
    let tt: Vec<f64> = thr.iter().map(|r| r.time).collect();
    let state: Vec<f64> = thr
        .iter()
        .map(|r| if r.level == Level::Alarm { 1.0 } else { 0.0 })
        .collect();
    let activations = entries(thr, Level::Alarm);
    let x = c.whole.axis(c.start, c.end);
    let adv = entries(c.inp.pinn, Level::Advisory);
    let alm = entries(c.inp.pinn, Level::Alarm);
    let mut p1 = Panel::new(
        format!(
            "Fixed-threshold baseline: {} alarm activations",
            activations.len()
        ),
        x.clone(),
        Axis::new(-0.1, 1.25, "baseline state"),
    );
    p1.y_ticks = vec![(0.0, "normal".into()), (1.0, "alarm".into())];
    // Each alarm run as a bar at least about two pixels wide, so a one-sample alarm shows.
    let min_w = (c.end - c.start) / 450.0;
    let mut bars: Vec<(f64, f64, f64)> = Vec::new();
    let mut run: Option<f64> = None;
    for (i, (&t, &on)) in tt.iter().zip(&state).enumerate() {
        if on > 0.5 && run.is_none() {
            run = Some(t);
        }
        let ends = on <= 0.5 || i + 1 == tt.len();
        if let (Some(t0), true) = (run, ends) {
            let t1 = if on > 0.5 { t + c.step } else { t };
            let mid = 0.5 * (t0 + t1);
            let half = 0.5 * (t1 - t0).max(min_w);
            bars.push((c.whole.x(mid - half), c.whole.x(mid + half), 1.0));
            run = None;
        }
    }
    p1.marks.push(Mark::HLine {
        y: 0.0,
        color: RED,
        dash: Dash::Solid,
        label: None,
    });
    p1.marks.push(Mark::Bars {
        bars,
        color: RED,
        label: Some("alarm (each sample judged alone)".into()),
    });
    let pt: Vec<f64> = c.inp.pinn.iter().map(|r| r.time).collect();
    let rk: Vec<f64> = c.inp.pinn.iter().map(|r| r.risk).collect();
    let mut p2 = Panel::new(
        "liftwatch: combined risk on the same data",
        x,
        risk_axis(&rk, &[cfg.advisory, cfg.alarm], "risk R (1)", risk_log(c)),
    );
    p2.marks.push(Mark::HLine {
        y: cfg.advisory,
        color: ORANGE,
        dash: Dash::Dashed,
        label: Some("advisory threshold".into()),
    });
    p2.marks.push(Mark::HLine {
        y: cfg.alarm,
        color: RED,
        dash: Dash::Dashed,
        label: Some("alarm threshold".into()),
    });
    p2.marks.push(Mark::Line {
        pts: whole_line(c, &pt, &rk),
        color: INK,
        width: 3,
        label: Some("R".into()),
    });
    p2.headroom = Some(0.08);
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
    let before = adv
        .first()
        .map(|t| activations.iter().filter(|a| *a < t).count());
    let persistent = longest_run(thr, c.step);
    let lim = &c.inp.model.baseline;
    let mut text =
        vec![format!(
        "The conventional method judges each moving sample alone against fixed limits set at the fit (friction-force \
         estimate {} N, voltage above the motor line {} V). On this input it switched to alarm {} times{}; its longest \
         uninterrupted alarm lasted {}.",
        num(lim.friction_limit_n),
        num(lim.voltage_limit_v),
        activations.len(),
        activations.first().map_or(String::new(), |t| format!(", the first after {}", span_text(t - c.start))),
        span_text(persistent),
    )];
    text.push(match (adv.first(), before) {
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
    });
    Section {
        figure: Figure {
            name: "comparison".into(),
            width: 1200,
            height: 800,
            grid: (2, 1),
            panels: vec![p1, p2],
        },
        heading: "Comparison with the fixed-threshold baseline".into(),
        text,
    }
}

/// Longest uninterrupted alarm of the baseline (s).
fn longest_run(rows: &[liftwatch::monitor::MonitorRow], step: f64) -> f64 {
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

fn usage(c: &Ctx) -> Section {
    let s = &c.inp.series.samples;
    let hour = |t: f64| ((t.rem_euclid(86400.0)) / 3600.0).floor().clamp(0.0, 23.0) as usize;
    let mut observed = [0.0f64; 24];
    let mut moving = [0.0f64; 24];
    let mut trips = [0.0f64; 24];
    let mut doors = [0.0f64; 24];
    for x in s.iter().filter(|x| x.speed.is_finite()) {
        observed[hour(x.time)] += c.step;
    }
    for r in c.rows().iter().filter(|r| r.s != 0) {
        moving[hour(r.time)] += c.step;
    }
    for t in &c.inp.features.trips {
        trips[hour(t.start_time)] += 1.0;
    }
    for w in s.windows(2) {
        if w[0].door < 0.5 && w[1].door >= 0.5 {
            doors[hour(w[1].time)] += 1.0;
        }
    }
    let per_hour = |n: &[f64; 24]| -> Vec<(f64, f64, f64)> {
        (0..24)
            .filter(|&h| observed[h] > 0.0)
            .map(|h| {
                (
                    h as f64 + 0.1,
                    h as f64 + 0.9,
                    n[h] / (observed[h] / 3600.0),
                )
            })
            .collect()
    };
    let x = Axis::new(0.0, 24.0, "hour of day");
    let bar_panel = |title: &str, ylabel: &str, bars: Vec<(f64, f64, f64)>, color| {
        let top = bars.iter().map(|b| b.2).fold(0.0, f64::max);
        let mut p = Panel::new(
            title,
            x.clone(),
            Axis::new(0.0, (1.12 * top).max(1e-9), ylabel),
        );
        p.marks.push(Mark::Bars {
            bars,
            color,
            label: None,
        });
        p.legend = Legend::None;
        p
    };
    let tb = per_hour(&trips);
    let db = per_hour(&doors);
    let mb: Vec<(f64, f64, f64)> = per_hour(&moving)
        .into_iter()
        .map(|(a, b, v)| (a, b, 100.0 * v / 3600.0))
        .collect();
    let lambdas: Vec<f64> = c
        .inp
        .features
        .trips
        .iter()
        .map(|t| 100.0 * t.load_ratio)
        .filter(|v| v.is_finite())
        .collect();
    let bin = 5.0;
    let top = quantile(lambdas.iter().copied(), 1.0).max(bin);
    let lo = quantile(lambdas.iter().copied(), 0.0).min(0.0);
    let (b0, b1) = ((lo / bin).floor() as i64, (top / bin).ceil() as i64);
    let mut hist: Vec<(f64, f64, f64)> = (b0..b1)
        .map(|k| (k as f64 * bin, (k + 1) as f64 * bin, 0.0))
        .collect();
    for v in &lambdas {
        let k = ((v / bin).floor() as i64 - b0).clamp(0, hist.len() as i64 - 1) as usize;
        if let Some(h) = hist.get_mut(k) {
            h.2 += 1.0;
        }
    }
    let hmax = hist.iter().map(|h| h.2).fold(0.0, f64::max);
    let mut p4 = Panel::new(
        "Load per trip (histogram, 5 % bins)",
        Axis::new(
            b0 as f64 * bin,
            b1 as f64 * bin,
            "static load λ (% of rated load)",
        ),
        Axis::new(0.0, (1.12 * hmax).max(1.0), "trips"),
    );
    p4.marks.push(Mark::Bars {
        bars: hist
            .iter()
            .map(|&(a, b, n)| (a + 0.4, b - 0.4, n))
            .collect(),
        color: PURPLE,
        label: None,
    });
    p4.legend = Legend::None;
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
            db,
            GREEN,
        ),
        bar_panel(
            "Time moving, by hour of day",
            "moving (% of the hour)",
            mb,
            ORANGE,
        ),
        p4,
    ];
    let days = observed.iter().sum::<f64>() / 86400.0;
    let n_trips = c.inp.features.trips.len();
    let busiest =
        tb.iter().copied().fold(
            (f64::NAN, 0.0),
            |acc, b| if b.2 > acc.1 { (b.0, b.2) } else { acc },
        );
    let total_moving: f64 = moving.iter().sum();
    let total_obs: f64 = observed.iter().sum();
    let mut text = Vec::new();
    if n_trips == 0 {
        text.push(format!(
            "No complete trip in {} of data with speed; the car moved {:.1} % of the time.",
            span_text(total_obs),
            100.0 * total_moving / total_obs.max(1e-9)
        ));
    }
    text.push(format!(
        "{n_trips} complete trips in {} of data with speed ({} per day), {} door openings per day; the car moved {:.1} % of the \
         time. The busiest hour of day starts at {:02}:00 with {} trips per hour on average. Trip loads (static λ, held from \
         door close): median {} %, 90th percentile {} % of the rated load. Hours of day are the time stamps modulo 24 h.",
        span_text(total_obs),
        num(n_trips as f64 / days.max(1e-9)),
        num(doors.iter().sum::<f64>() / days.max(1e-9)),
        100.0 * total_moving / total_obs.max(1e-9),
        busiest.0.floor() as i64,
        num(busiest.1),
        num(quantile(lambdas.iter().copied(), 0.5)),
        num(quantile(lambdas.iter().copied(), 0.9)),
    ));
    if n_trips == 0 {
        text.truncate(1);
    }
    Section {
        figure: Figure {
            name: "usage".into(),
            width: 1200,
            height: 860,
            grid: (2, 2),
            panels,
        },
        heading: "Usage".into(),
        text,
    }
}
