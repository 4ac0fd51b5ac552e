//! The `fit` figure of stage 5: measured against predicted voltage and force, and both
//! residuals, over the busiest excerpt of the last quarter of the data.
//!
//! ```text
//! r_U = U − U_pred
//! r_F = F_pred − F_U        F_U: the force the measured voltage implies, moving only
//! ```

use liftwatch::features::FeatureRow;
use liftwatch::residual::applicable;
use plotters::style::RGBColor;

use super::{num, span_text, Ctx, Section, Time};
use crate::plot::{colors::*, robust_range, Axis, Dash, Figure, Legend, Mark, Panel};

/// Length of the fit excerpt (s): short enough to see each trip's shape.
const FIT_EXCERPT_S: f64 = 360.0;
/// Fraction of the data after which the fit excerpt starts: the last quarter.
const FIT_FROM: f64 = 0.75;

/// Measured and predicted voltage and force over the fit excerpt, one value per feature row.
struct Excerpt {
    /// Axis coordinate of each row.
    xs: Vec<f64>,
    /// U measured (V).
    u_meas: Vec<f64>,
    /// U_pred (V); NaN where the model does not apply.
    u_pred: Vec<f64>,
    /// F_U implied by the measured voltage (N).
    f_u: Vec<f64>,
    /// F_pred (N), moving rows only.
    f_pred: Vec<f64>,
}

impl Excerpt {
    /// Predicts every row of `[a, b]`.
    fn new(c: &Ctx, time: &Time, a: f64, b: f64) -> Excerpt {
        let m = c.inp.model;
        let rows: Vec<&FeatureRow> = c
            .rows()
            .iter()
            .filter(|r| r.time >= a && r.time <= b)
            .collect();
        let preds: Vec<_> = rows
            .iter()
            .map(|r| applicable(r).then(|| m.hybrid.predict(r)))
            .collect();
        let f_pred = rows
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
        Excerpt {
            xs: rows.iter().map(|r| time.x(r.time)).collect(),
            u_meas: rows.iter().map(|r| r.voltage).collect(),
            u_pred: preds
                .iter()
                .map(|p| p.map_or(f64::NAN, |p| p.u_pred))
                .collect(),
            f_u: preds
                .iter()
                .map(|p| p.map_or(f64::NAN, |p| p.f_u))
                .collect(),
            f_pred,
        }
    }

    /// Points `(x, y)` of a column.
    fn zip(&self, y: &[f64]) -> Vec<(f64, f64)> {
        self.xs.iter().copied().zip(y.iter().copied()).collect()
    }

    /// r_U of each row.
    fn r_u(&self) -> Vec<f64> {
        self.u_meas
            .iter()
            .zip(&self.u_pred)
            .map(|(m, p)| m - p)
            .collect()
    }

    /// r_F of each row.
    fn r_f(&self) -> Vec<f64> {
        self.f_pred
            .iter()
            .zip(&self.f_u)
            .map(|(p, u)| p - u)
            .collect()
    }
}

/// RMS of the finite values, NaN when there is none.
fn rms(v: &[f64]) -> f64 {
    let f: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    if f.is_empty() {
        return f64::NAN;
    }
    (f.iter().map(|x| x * x).sum::<f64>() / f.len() as f64).sqrt()
}

/// Zero and the healthy band ±2σ of a residual in `unit`.
pub(super) fn sigma_lines(sigma: f64, unit: &str) -> [Mark; 3] {
    [
        Mark::HLine {
            y: 0.0,
            color: INK,
            dash: Dash::Solid,
            label: None,
        },
        Mark::HLine {
            y: 2.0 * sigma,
            color: GREEN,
            dash: Dash::Dashed,
            label: Some(format!("±2σ healthy ({} {unit})", num(2.0 * sigma))),
        },
        Mark::HLine {
            y: -2.0 * sigma,
            color: GREEN,
            dash: Dash::Dashed,
            label: None,
        },
    ]
}

/// U vs U_pred, F_U vs F_pred and both residuals over the busiest excerpt near the end.
pub(super) fn fit(c: &Ctx) -> Section {
    let (a, b) = c.busiest(FIT_FROM, FIT_EXCERPT_S);
    let time = Time::excerpt(c.start, a, b);
    let ex = Excerpt::new(c, &time, a, b);
    let x = time.axis(a, b);
    let (ru, rf) = (ex.r_u(), ex.r_f());
    let sc = c.inp.model.hybrid.scales;
    let u = ExcerptResidual {
        title: "Voltage residual r_U = U − U_pred",
        sym: "r_U",
        unit: "V",
        sigma: sc.sigma_u_v,
        color: BLUE,
    };
    let f = ExcerptResidual {
        title: "Force residual r_F = F_pred − F_U",
        sym: "r_F",
        unit: "N",
        sigma: sc.sigma_f_n,
        color: ORANGE,
    };
    let panels = vec![
        voltage_panel(&ex, x.clone()),
        force_panel(&ex, x.clone()),
        u.panel(&ex, x.clone(), &ru),
        f.panel(&ex, x, &rf),
    ];
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
        num(c.inp.model.summary.rms_u_v),
        num(c.inp.model.summary.rms_f_n),
    )];
    Section {
        figure: Figure {
            name: "fit".into(),
            width: 1200,
            height: 1500,
            grid: (4, 1),
            panels,
        },
        heading: "Fit: measured against predicted".into(),
        text,
    }
}

/// U measured against U_pred.
fn voltage_panel(ex: &Excerpt, x: Axis) -> Panel {
    let (lo, hi) = robust_range(
        &[ex.u_meas.clone(), ex.u_pred.clone()].concat(),
        0.002,
        0.998,
        &[0.0],
    );
    let mut p = Panel::new(
        "Motor voltage: measured U (black) and predicted U_pred (orange)",
        x,
        Axis::new(lo, hi, "voltage (V)"),
    );
    p.marks.push(Mark::Line {
        pts: ex.zip(&ex.u_meas),
        color: INK,
        width: 2,
        label: Some("U measured".into()),
    });
    p.marks.push(Mark::Line {
        pts: ex.zip(&ex.u_pred),
        color: ORANGE,
        width: 2,
        label: Some("U_pred (physics + network)".into()),
    });
    p.legend = Legend::None;
    p
}

/// F_U implied by the measured voltage against F_pred.
fn force_panel(ex: &Excerpt, x: Axis) -> Panel {
    let (lo, hi) = robust_range(
        &[ex.f_u.clone(), ex.f_pred.clone()].concat(),
        0.002,
        0.998,
        &[0.0],
    );
    let mut p = Panel::new(
        "Driving force: F_U implied by the measured voltage (black), F_pred predicted (blue)",
        x,
        Axis::new(lo, hi, "force (N, + up)"),
    );
    p.marks.push(Mark::HLine {
        y: 0.0,
        color: GREY,
        dash: Dash::Solid,
        label: None,
    });
    p.marks.push(Mark::Line {
        pts: ex.zip(&ex.f_u),
        color: INK,
        width: 2,
        label: Some("F_U from measured voltage".into()),
    });
    p.marks.push(Mark::Line {
        pts: ex.zip(&ex.f_pred),
        color: BLUE,
        width: 2,
        label: Some("F_pred (physics + network)".into()),
    });
    p.legend = Legend::None;
    p
}

/// How one residual of the excerpt is drawn.
struct ExcerptResidual {
    /// Panel title.
    title: &'static str,
    /// Symbol, `r_U` or `r_F`.
    sym: &'static str,
    /// Unit.
    unit: &'static str,
    /// Healthy scale σ (unit).
    sigma: f64,
    /// Colour of the residual.
    color: RGBColor,
}

impl ExcerptResidual {
    /// The residual `r` of each row of `ex`, with zero and the healthy ±2σ band.
    fn panel(&self, ex: &Excerpt, x: Axis, r: &[f64]) -> Panel {
        let (sigma, color) = (self.sigma, self.color);
        let (lo, hi) = robust_range(r, 0.002, 0.998, &[-3.0 * sigma, 3.0 * sigma]);
        let mut p = Panel::new(
            self.title,
            x,
            Axis::new(lo, hi, format!("{} ({})", self.sym, self.unit)),
        );
        p.marks.extend(sigma_lines(sigma, self.unit));
        p.marks.push(Mark::Line {
            pts: ex.zip(r),
            color,
            width: 2,
            label: Some(self.sym.to_string()),
        });
        p.marks.push(Mark::Dots {
            pts: ex.zip(r),
            color,
            radius: 2,
            label: None,
        });
        p
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::figures::fixture::{assert_drawn, Fixture};

    #[test]
    fn fit_is_drawn_from_a_small_series() {
        let f = Fixture::get();
        let inp = f.inputs();
        let c = Ctx::new(&inp);
        let s = fit(&c);
        assert_eq!(s.heading, "Fit: measured against predicted");
        assert_eq!(s.figure.panels.len(), 4);
        assert_drawn(&s, "force (N, + up)");
    }
}
