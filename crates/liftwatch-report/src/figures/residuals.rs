//! The `residuals` figure of stage 5: r_U and r_F of every moving sample over the whole
//! input, their mean per trip and a running mean of the trip means, against the healthy band.
//!
//! ```text
//! r_U = U − U_pred
//! r_F = F_pred − F_U
//! drift = (mean of the last tenth of the trip means − mean of the first tenth) / σ
//! ```

use liftwatch::features::FeatureRow;
use liftwatch::residual::Residuals;
use plotters::style::RGBColor;

use super::fit::sigma_lines;
use super::{light, num, whole_line, Ctx, Section};
use crate::plot::{colors::*, robust_range, Axis, Figure, Legend, Mark, Panel};

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

/// How one residual over the whole input is drawn and described.
struct WholeResidual {
    /// Name in the panel title.
    name: &'static str,
    /// Symbol, `r_U` or `r_F`.
    sym: &'static str,
    /// Unit.
    unit: &'static str,
    /// Healthy scale σ (unit).
    sigma: f64,
    /// Colour of the trip means.
    color: RGBColor,
    /// The residual of one row.
    get: fn(&Residuals) -> f64,
}

/// Drift of a residual's trip means: symbol, unit, first and last tenth of the trips, σ.
type Drift = (&'static str, &'static str, f64, f64, f64);

/// r_U and r_F of every moving sample over the whole input, trip means and their running mean.
pub(super) fn residuals(c: &Ctx) -> Section {
    let sc = c.inp.model.hybrid.scales;
    let mut panels = Vec::new();
    let mut drift = Vec::new();
    for q in [
        WholeResidual {
            name: "Voltage residual",
            sym: "r_U",
            unit: "V",
            sigma: sc.sigma_u_v,
            color: BLUE,
            get: |r| r.r_u,
        },
        WholeResidual {
            name: "Force residual",
            sym: "r_F",
            unit: "N",
            sigma: sc.sigma_f_n,
            color: ORANGE,
            get: |r| r.r_f,
        },
    ] {
        let (panel, d) = q.panel(c);
        panels.push(panel);
        drift.extend(d);
    }
    Section {
        figure: Figure {
            name: "residuals".into(),
            width: 1200,
            height: 860,
            grid: (2, 1),
            panels,
        },
        heading: "Fit: both residuals over time".into(),
        text: residuals_text(&drift),
    }
}

impl WholeResidual {
    /// The panel, and the drift of the trip means when there is any trip mean.
    fn panel(&self, c: &Ctx) -> (Panel, Option<Drift>) {
        let rows = c.rows();
        let t: Vec<f64> = rows.iter().map(|r| r.time).collect();
        let (sym, unit, sigma) = (self.sym, self.unit, self.sigma);
        let y: Vec<f64> = rows
            .iter()
            .zip(&c.res)
            .map(|(r, q)| if r.s != 0 { (self.get)(q) } else { f64::NAN })
            .collect();
        let means = trip_means(rows, &y);
        // The axis is the trip means' range (with ±3σ of the samples): a 0.7σ drift of the
        // means stays visible. Samples beyond it, up to ±40 V in jerk phases, are not drawn.
        let mv: Vec<f64> = means.iter().map(|p| p.1).collect();
        let (lo, hi) = robust_range(&mv, 0.002, 0.998, &[-3.0 * sigma, 3.0 * sigma]);
        let y: Vec<f64> = y
            .iter()
            .map(|v| if (lo..=hi).contains(v) { *v } else { f64::NAN })
            .collect();
        let mut p = Panel::new(
            format!(
                "{} {sym} while moving: trip means, and the samples within the axis (grey)",
                self.name
            ),
            c.whole.axis(c.start, c.end),
            Axis::new(lo, hi, format!("{sym} ({unit})")),
        );
        p.marks.push(Mark::Line {
            pts: whole_line(c, &t, &y),
            color: light(GREY),
            width: 1,
            label: Some("each sample".into()),
        });
        p.marks.extend(sigma_lines(sigma, unit));
        p.marks.push(Mark::Dots {
            pts: means.iter().map(|(t, v)| (c.whole.x(*t), *v)).collect(),
            color: self.color,
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
        let k = (mv.len() / 10).max(1);
        let first = mv.iter().take(k).sum::<f64>() / k.min(mv.len()).max(1) as f64;
        let last = mv.iter().rev().take(k).sum::<f64>() / k.min(mv.len()).max(1) as f64;
        let drift = (!mv.is_empty()).then_some((sym, unit, first, last, sigma));
        (p, drift)
    }
}

/// What the residual figure shows and how far the trip means drifted.
fn residuals_text(drift: &[Drift]) -> Vec<String> {
    vec![format!(
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
    )]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::figures::fixture::{assert_drawn, Fixture};

    #[test]
    fn residuals_are_drawn_from_a_small_series() {
        let f = Fixture::get();
        let inp = f.inputs();
        let c = Ctx::new(&inp);
        let s = residuals(&c);
        assert_eq!(s.heading, "Fit: both residuals over time");
        assert_drawn(&s, "r_U (V)");
    }

    #[test]
    fn running_mean_is_centred_on_full_windows() {
        let pts: Vec<(f64, f64)> = (0..6).map(|i| (f64::from(i), f64::from(i))).collect();
        assert_eq!(
            running_mean(&pts, 3),
            vec![(1.0, 1.0), (2.0, 2.0), (3.0, 3.0), (4.0, 4.0)]
        );
        assert!(running_mean(&pts, 7).is_empty());
    }
}
