//! Figures of stage 4, the fit of the hybrid model: loss and RMS residuals against the
//! iteration (`training`), and each physical parameter θ_k through the fit with its final value
//! and ± one standard error (`parameters`).
//!
//! ```text
//! L = w_U·mean(r_U²) + w_F·mean(r_F²) + w_P·prior(θ)
//! stage 1: Gauss-Newton on θ alone; stage 2: the network on θ held (L-BFGS, the default),
//!          or θ and the network together (Adam, the paper's schedule)
//! ```

use liftwatch::model::train::{Optimizer, TrainPoint};
use liftwatch::model::{FitSummary, PhysParams};
use plotters::style::RGBColor;

use super::{num, Ctx, Section};
use crate::plot::{colors::*, quantile, robust_range, Axis, Dash, Figure, Legend, Mark, Panel};
use crate::section::escape;

/// Ratio of the largest to the smallest loss above which the loss axis spans whole decades.
const LOSS_DECADES_RATIO: f64 = 20.0;
/// Width of a parameter panel (px).
const PARAM_W: u32 = 400;
/// Height of a parameter panel (px).
const PARAM_H: u32 = 380;

/// A value below this share of its prior width is shown as zero: a positive parameter whose
/// softplus map sits there (c_visc 2.3e-16 against a width of tens of N·s/m) is at its bound
/// 0, and sixteen digits of nothing mean nothing.
const AT_BOUND_SHARE: f64 = 1e-6;

/// The parameters kept positive by the fit's softplus map (MODEL.md, Hybrid PINN).
const POSITIVE: [&str; 6] = ["m0", "f_c", "c_visc", "kd", "ke", "alpha_down"];

/// A parameter value for people: [`num`], or `≈ 0 (at its bound)` for a positive parameter
/// pressed against zero.
fn value_text(name: &str, value: f64, prior_sd: Option<f64>) -> String {
    let width = prior_sd.unwrap_or(1.0).abs();
    if value.abs() < AT_BOUND_SHARE * width {
        if POSITIVE.contains(&name) {
            return "≈ 0 (at its bound)".into();
        }
        return "≈ 0".into();
    }
    num(value)
}

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

/// The iterations of the history, and the range of the iteration axis.
fn iterations(h: &[TrainPoint]) -> (Vec<f64>, f64, f64) {
    let it: Vec<f64> = h.iter().map(|p| p.iteration as f64).collect();
    let (x0, x1) = (
        it.first().copied().unwrap_or(0.0),
        it.last().copied().unwrap_or(1.0).max(1.0),
    );
    (it, x0, x1)
}

/// Loss (log scale), RMS r_U and RMS r_F against the iteration; stage 2 marked.
pub(super) fn training(c: &Ctx) -> Section {
    let fit = &c.inp.model.summary;
    let h = &fit.history;
    let (it, x0, x1) = iterations(h);
    let x = Axis::new(x0, x1, "iteration");
    // Stage 2 starts where stage 1's last point stands (its first logged point comes
    // `log_every` iterations later).
    let stage2 = h
        .iter()
        .any(|p| p.stage >= 2)
        .then(|| h.iter().filter(|p| p.stage == 1).map(|p| p.iteration).max())
        .flatten()
        .map(|it| it as f64);
    let loss: Vec<f64> = h.iter().map(|p| p.loss).collect();
    let ru: Vec<f64> = h.iter().map(|p| p.rms_u_v).collect();
    let rf: Vec<f64> = h.iter().map(|p| p.rms_f_n).collect();
    let curve = |y: &[f64]| it.iter().copied().zip(y.iter().copied()).collect();
    let (_, hu) = robust_range(&ru, 0.0, 1.0, &[0.0]);
    let (_, hf) = robust_range(&rf, 0.0, 1.0, &[0.0]);
    let mut panels = vec![
        curve_panel(
            "Training loss",
            x.clone(),
            loss_axis(&loss),
            curve(&loss),
            INK,
            "loss",
        ),
        curve_panel(
            "RMS voltage residual",
            x.clone(),
            Axis::new(0.0, hu, "RMS r_U (V)"),
            curve(&ru),
            BLUE,
            "r_U",
        ),
        curve_panel(
            "RMS force residual",
            x,
            Axis::new(0.0, hf, "RMS r_F (N)"),
            curve(&rf),
            ORANGE,
            "r_F",
        ),
    ];
    for p in &mut panels {
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
    }
    Section {
        figure: Figure {
            name: "training".into(),
            width: 1500,
            height: 520,
            grid: (1, 3),
            panels,
        },
        heading: "Training: loss and residuals".into(),
        text: training_text(c),
    }
}

/// A panel with one labelled curve, the legend upper right.
fn curve_panel(
    title: &str,
    x: Axis,
    y: Axis,
    pts: Vec<(f64, f64)>,
    color: RGBColor,
    label: &str,
) -> Panel {
    let mut p = Panel::new(title, x, y);
    p.marks.push(Mark::Line {
        pts,
        color,
        width: 3,
        label: Some(label.into()),
    });
    p.legend = Legend::UpperRight;
    p
}

/// The loss axis: whole decades when the loss falls by more than [`LOSS_DECADES_RATIO`], else a
/// tight log range labelled with its own values.
fn loss_axis(loss: &[f64]) -> Axis {
    let (lmin, lmax) = (
        quantile(loss.iter().copied(), 0.0),
        quantile(loss.iter().copied(), 1.0),
    );
    if lmin > 0.0 && lmax / lmin > LOSS_DECADES_RATIO {
        return Axis::log(lmin, lmax, "loss L (log scale)");
    }
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
}

/// The two stages, the fall of the loss and the final residuals.
fn training_text(c: &Ctx) -> Vec<String> {
    let fit = &c.inp.model.summary;
    let first = fit.history.first().map_or(f64::NAN, |p| p.loss);
    let stage2 = match c.inp.model.train.optimizer {
        Optimizer::Lbfgs => "the correcting network by L-BFGS with θ held at stage 1's",
        Optimizer::Adam => {
            "θ and the correcting network together by Adam from the prior, as the paper trains"
        }
    };
    let mut stop = fit.stage2_stop.map_or_else(String::new, |st| {
        format!(" {}.", st.describe(fit.iterations))
    });
    if let Some(draws) = fit.kept_draw() {
        stop.push_str(&format!(
            " Stage 2 ran from several draws of the network's initial weights: {draws}; the history shown is the kept one's."
        ));
    }
    vec![format!(
        "The fit has two stages: Gauss-Newton on the physical parameters θ alone (stage 1), then {stage2} \
         (stage 2, {} iterations). The loss went from {} to {} (a factor {}; {} at the end of stage 1).{stop} Final RMS \
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
    )]
}

/// One small panel per physical parameter θ_k, and a table of the final values.
pub(super) fn parameters(c: &Ctx) -> Section {
    let fit = &c.inp.model.summary;
    let final_theta = c.inp.model.hybrid.parameters.to_array();
    let mut panels = Vec::new();
    let mut rows_html = Vec::new();
    for (k, (&name, &unit)) in PhysParams::NAMES
        .iter()
        .zip(PhysParams::UNITS.iter())
        .enumerate()
    {
        let value = final_theta.get(k).copied().unwrap_or(f64::NAN);
        let report = fit.parameters.iter().find(|r| r.name == name);
        let se = report.and_then(|r| r.std_error).unwrap_or(f64::NAN);
        let shown = value_text(name, value, report.and_then(|r| r.prior_sd));
        panels.push(parameter_panel(fit, k, (name, unit), value, se, &shown));
        let by = report.map_or("n/a", |r| r.decided_by().words());
        let corrected = report
            .and_then(|r| r.corrected)
            .map_or_else(|| "-".to_string(), num);
        rows_html.push(format!(
            "<tr><td>{name}</td><td>{shown}</td><td>{}</td><td>{corrected}</td><td>{unit}</td><td>{by}</td></tr>",
            num(se)
        ));
    }
    let cols = if panels.len() == 8 { 4 } else { 3 };
    let grid = (panels.len().div_ceil(cols).max(1), cols);
    Section {
        figure: Figure {
            name: "parameters".into(),
            width: PARAM_W * grid.1 as u32,
            height: PARAM_H * grid.0 as u32,
            grid,
            panels,
        },
        heading: "Training: convergence of the physical parameters".into(),
        text: parameters_text(fit, c.inp.model.train.optimizer, &rows_html),
    }
}

/// θ_k (index `k` of [`PhysParams::NAMES`]) through the fit, its final `value` and ± `se`.
fn parameter_panel(
    fit: &FitSummary,
    k: usize,
    (name, unit): (&str, &str),
    value: f64,
    se: f64,
    shown: &str,
) -> Panel {
    let (it, x0, x1) = iterations(&fit.history);
    let vals: Vec<f64> = fit
        .history
        .iter()
        .map(|p| p.theta.get(k).copied().unwrap_or(f64::NAN))
        .collect();
    let (lo, hi) = robust_range(&vals, 0.0, 1.0, &[value]);
    let sym = symbol(name);
    let mut p = Panel::new(
        format!(
            "{sym} {}{shown}{}  ({name})",
            if shown.starts_with('≈') { "" } else { "= " },
            if unit == "1" || shown.starts_with('≈') {
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
    p
}

/// What the panels show, the table of final values and the fit's warnings.
fn parameters_text(fit: &FitSummary, optimizer: Optimizer, rows_html: &[String]) -> Vec<String> {
    let table = format!(
        "<table><tr><th>parameter</th><th>value</th><th>std. error</th><th>corrected for speed noise</th><th>unit</th><th>decided by</th></tr>{}</table>",
        rows_html.join("")
    );
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
             rest stay near their prior. Standard errors treat samples as independent, so they are lower bounds.{}",
            PhysParams::NAMES.len(),
            if optimizer == Optimizer::Lbfgs {
                " θ is held while the network learns (stage 2), so each line is flat after stage 1: the parameters \
                 are the physics' own least-squares fit, whatever the network's training did."
            } else {
                ""
            }
        ),
        table,
    ];
    if fit.speed_noise_mps > 0.0 {
        text.push(format!(
            "The speed reading carries {:.4} m/s of noise (measured while cruising). Least squares on a noisy speed \
             shrinks the back-EMF slope Ke, and the Coulomb friction F_c, constant in each direction as the cruising speed \
             nearly is, makes the voltage up: the corrected column takes the noise's share out and gives the physical \
             values. The model predicts with the plain values, which are the better predictors from readings as noisy \
             as these.",
            fit.speed_noise_mps
        ));
    }
    for w in &fit.warnings {
        text.push(format!("Note from the fit: {}.", escape(w)));
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::figures::fixture::{assert_drawn, Fixture};

    #[test]
    fn training_and_parameters_are_drawn_from_a_short_fit() {
        let f = Fixture::get();
        let inp = f.inputs();
        let c = Ctx::new(&inp);
        let s = training(&c);
        assert_eq!(s.heading, "Training: loss and residuals");
        assert_drawn(&s, "iteration");
        let s = parameters(&c);
        assert_eq!(
            s.heading,
            "Training: convergence of the physical parameters"
        );
        assert_eq!(s.figure.panels.len(), PhysParams::NAMES.len());
        assert!(s.text[1].starts_with("<table>"), "{}", s.text[1]);
        assert_drawn(&s, symbol(PhysParams::NAMES[0]));
    }
}
