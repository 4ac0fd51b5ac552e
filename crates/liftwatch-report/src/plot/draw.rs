//! Drawing a [`Figure`] description with plotters, the same way on every backend.
//!
//! Each panel is drawn in four steps: the frame (legend headroom, caption, axes and mesh,
//! own tick labels for custom and log axes), the marks in order (later on top), and the
//! legend. Coordinates are mapped by [`Axis`] (log10 on a log axis) before plotters sees them.
//!
//! ```text
//! headroom = legend_h / (plot_h − legend_h), clamped to [0.1, 0.5]
//! legend_h = 24 px + 27 px per entry
//! ```

use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::{Axis, Dash, Figure, Legend, Mark, Panel, DESC_PT, FONT, TICK_PT, TITLE_PT};

/// The text style of the bundled font at `size`, black.
fn font(size: f64) -> TextStyle<'static> {
    (FONT, size).into_font().color(&BLACK)
}

/// A tick label with as many decimals as the tick spacing needs (one more than the spacing's
/// leading digit, trailing zeros dropped: `0.25`, `0.5`, `1500`).
pub fn fmt_tick(v: f64, span: f64) -> String {
    let step = span.abs() / 6.0;
    let decimals = if step >= 10.0 || step <= 0.0 {
        0
    } else {
        ((-step.log10()).ceil() + 1.0).clamp(0.0, 7.0) as usize
    };
    let a = v.abs();
    if a != 0.0 && (a >= 1e6 || (decimals > 5 && a < 1e-4)) {
        return format!("{v:.1e}");
    }
    let mut s = format!("{v:.decimals$}");
    if s.contains('.') {
        s = s.trim_end_matches('0').trim_end_matches('.').to_string();
    }
    if s == "-0" {
        s = "0".into();
    }
    s
}

/// A decade label: `0.01`, `1`, `1000`, `1e-5`.
fn fmt_decade(e: f64) -> String {
    let v = 10f64.powf(e);
    if (-3.0..=4.0).contains(&e) {
        fmt_tick(v, v * 6.0)
    } else {
        format!("1e{e:.0}")
    }
}

/// Draws every panel of `fig` into its cell of `root`.
pub(super) fn draw_figure<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    fig: &Figure,
) -> Result<(), String> {
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let cells = root.split_evenly(fig.grid);
    let (rows, cols) = fig.grid;
    for (i, (panel, area)) in fig.panels.iter().zip(cells.iter()).enumerate() {
        // A single column shares its time axis: only the bottom panel names it.
        let x_desc = cols != 1 || i + 1 >= rows;
        draw_panel(area, panel, x_desc).map_err(|e| format!("panel `{}`: {e}", panel.title))?;
    }
    Ok(())
}

/// Splits a polyline at its non-finite points.
pub(super) fn segments(pts: &[(f64, f64)]) -> Vec<Vec<(f64, f64)>> {
    let mut out = Vec::new();
    let mut cur = Vec::new();
    for &(x, y) in pts {
        if x.is_finite() && y.is_finite() {
            cur.push((x, y));
        } else if !cur.is_empty() {
            out.push(std::mem::take(&mut cur));
        }
    }
    if !cur.is_empty() {
        out.push(cur);
    }
    out
}

/// Splits a polyline where it turns back sharply (more than 120° in pixel space, `scale`
/// px per data unit). The bitmap backend joins thick segments with unlimited miters, which
/// turn a min/max zig-zag into long spikes; pieces that meet at a vertex have no join there.
fn split_sharp_turns(seg: Vec<(f64, f64)>, scale: (f64, f64)) -> Vec<Vec<(f64, f64)>> {
    let mut out = Vec::new();
    let mut cur: Vec<(f64, f64)> = Vec::new();
    for p in seg {
        if cur.len() >= 2 {
            let (a, b) = (cur[cur.len() - 2], cur[cur.len() - 1]);
            let u = ((b.0 - a.0) * scale.0, (b.1 - a.1) * scale.1);
            let v = ((p.0 - b.0) * scale.0, (p.1 - b.1) * scale.1);
            let (nu, nv) = (u.0.hypot(u.1), v.0.hypot(v.1));
            if nu > 0.0 && nv > 0.0 && (u.0 * v.0 + u.1 * v.1) / (nu * nv) < -0.5 {
                out.push(std::mem::replace(&mut cur, vec![b]));
            }
        }
        if cur.last() != Some(&p) {
            cur.push(p);
        }
    }
    if !cur.is_empty() {
        out.push(cur);
    }
    out
}

/// Tick values for a log axis over `[a, b]` (values, a > 0): decades when it spans more
/// than one, else evenly spaced round values.
fn log_ticks(a: f64, b: f64) -> Vec<(f64, String)> {
    let (la, lb) = (a.log10(), b.log10());
    if lb - la >= 1.0 {
        let mut v: Vec<(f64, String)> = (la.ceil() as i32..=lb.floor() as i32)
            .map(|k| (f64::from(k), fmt_decade(f64::from(k))))
            .collect();
        if v.len() <= 2 {
            for k in la.floor() as i32..=lb.ceil() as i32 {
                for m in [2.0, 5.0] {
                    let x = f64::from(k) + f64::log10(m);
                    if x >= la && x <= lb {
                        v.push((x, fmt_tick(10f64.powf(x), 10f64.powf(x) * 3.0)));
                    }
                }
            }
        }
        v
    } else {
        let raw = (b - a) / 7.0;
        let mag = 10f64.powf(raw.log10().floor());
        let step = [1.0, 2.0, 2.5, 5.0, 10.0]
            .iter()
            .map(|m| m * mag)
            .find(|s| *s >= raw)
            .unwrap_or(10.0 * mag);
        let mut v = Vec::new();
        let mut x = (a / step).ceil() * step;
        while x <= b && v.len() < 12 {
            v.push((x.log10(), fmt_tick(x, 6.0 * step)));
            x += step;
        }
        v
    }
}

/// A chart with linear f64 coordinates on both axes (log axes are mapped before drawing).
type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// A drawing error, as text.
fn err<E: std::error::Error + Send + Sync>(e: DrawingAreaErrorKind<E>) -> String {
    e.to_string()
}

/// Where a panel draws: its coordinate ranges (after the legend headroom) and the pixels per
/// coordinate unit of its plotting area.
#[derive(Clone, Copy, Debug)]
struct Frame {
    /// Left end of the x range.
    x0: f64,
    /// Right end of the x range.
    x1: f64,
    /// Lower end of the y range.
    y0: f64,
    /// Upper end of the y range, headroom included.
    y1: f64,
    /// Pixels per unit (x, y).
    scale: (f64, f64),
}

/// Draws one panel: frame and mesh, the marks in order, the legend.
fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    p: &Panel,
    x_desc: bool,
) -> Result<(), String> {
    let (x0, x1) = p.x.range();
    let (y0, mut y1) = p.y.range();
    if let Some(h) = legend_headroom(area, p, x_desc) {
        y1 += (y1 - y0) * h;
    }
    let mut chart = ChartBuilder::on(area)
        .caption(&p.title, font(TITLE_PT))
        .margin_left(12)
        .margin_right(28)
        .margin_top(6)
        .margin_bottom(6)
        .x_label_area_size(if x_desc { 62 } else { 36 })
        .y_label_area_size(100)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(err)?;
    let (pw, ph) = chart.plotting_area().dim_in_pixel();
    let frame = Frame {
        x0,
        x1,
        y0,
        y1,
        scale: (
            f64::from(pw) / (x1 - x0).max(1e-300),
            f64::from(ph) / (y1 - y0).max(1e-300),
        ),
    };
    draw_mesh(&mut chart, p, x_desc, &frame)?;
    let mut any_label = false;
    for m in &p.marks {
        any_label |= draw_mark(&mut chart, p, m, &frame)?;
    }
    draw_legend(&mut chart, p.legend, any_label)
}

/// The legend entry of a mark, if it has one.
fn label_of(m: &Mark) -> Option<&String> {
    match m {
        Mark::Line { label, .. }
        | Mark::Dots { label, .. }
        | Mark::HLine { label, .. }
        | Mark::VLine { label, .. }
        | Mark::Bars { label, .. } => label.as_ref(),
        Mark::Band { .. } => None,
    }
}

/// Room to add above the data (fraction of the y range) so that a legend at the top does not
/// hide the data; `None` without a legend there.
fn legend_headroom<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    p: &Panel,
    x_desc: bool,
) -> Option<f64> {
    let n = p.marks.iter().filter(|m| label_of(m).is_some()).count();
    if n == 0 || !matches!(p.legend, Legend::UpperLeft | Legend::UpperRight) {
        return None;
    }
    // The legend box is about 16 px plus 27 px per entry; the plot about the area less
    // the caption and the x labels.
    let (_, area_h) = area.dim_in_pixel();
    let plot_h = f64::from(area_h) - if x_desc { 110.0 } else { 84.0 };
    let legend_h = 24.0 + 27.0 * n as f64;
    let auto = (legend_h / (plot_h - legend_h).max(1.0)).clamp(0.1, 0.5);
    Some(p.headroom.unwrap_or(auto))
}

/// Axes, descriptions, grid and tick labels; own tick labels (custom or log) drawn by hand.
fn draw_mesh<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    p: &Panel,
    x_desc: bool,
    f: &Frame,
) -> Result<(), String> {
    let (pw, _) = chart.plotting_area().dim_in_pixel();
    // The y labels' decimals follow the data range, headroom excluded.
    let (x_span, y_span) = (f.x1 - f.x0, p.y.range().1 - f.y0);
    // A log x axis is labelled at its decades (plotters places the labels in log10 units).
    let xf = |v: &f64| {
        if !p.x.log {
            fmt_tick(*v, x_span)
        } else if (v - v.round()).abs() < 1e-9 {
            fmt_decade(v.round())
        } else {
            String::new()
        }
    };
    // Own ticks (drawn below) for custom labels and log axes; plotters' for the rest.
    let own: Vec<(f64, String)> = if !p.y_ticks.is_empty() {
        p.y_ticks
            .iter()
            .map(|(v, s)| (p.y.map(*v), s.clone()))
            .collect()
    } else if p.y.log {
        log_ticks(p.y.min, 10f64.powf(f.y1))
    } else {
        Vec::new()
    };
    let yf = |v: &f64| fmt_tick(*v, y_span);
    let y_labels = if own.is_empty() { 6 } else { 0 };
    chart
        .configure_mesh()
        .x_desc(if x_desc { p.x.label.as_str() } else { "" })
        .y_desc(p.y.label.as_str())
        .label_style(font(TICK_PT))
        .axis_desc_style(font(DESC_PT))
        .x_labels((pw as usize / 100).clamp(5, 10))
        .y_labels(y_labels)
        .x_label_formatter(&xf)
        .y_label_formatter(&yf)
        .max_light_lines(1)
        .light_line_style(RGBColor(242, 242, 242))
        .bold_line_style(RGBColor(215, 215, 215))
        .draw()
        .map_err(err)?;
    draw_own_ticks(chart, &own, f)
}

/// Grid line, label and tick mark of each own y tick inside the range.
fn draw_own_ticks<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    own: &[(f64, String)],
    f: &Frame,
) -> Result<(), String> {
    let tick_style = font(TICK_PT).pos(Pos::new(HPos::Right, VPos::Center));
    for (v, text) in own.iter().filter(|(v, _)| *v >= f.y0 && *v <= f.y1) {
        chart
            .draw_series(LineSeries::new(
                vec![(f.x0, *v), (f.x1, *v)],
                RGBColor(215, 215, 215),
            ))
            .map_err(err)?;
        chart
            .draw_series(std::iter::once(
                EmptyElement::at((f.x0, *v))
                    + Text::new(text.clone(), (-10, 0), tick_style.clone()),
            ))
            .map_err(err)?;
        chart
            .draw_series(std::iter::once(
                EmptyElement::at((f.x0, *v)) + PathElement::new(vec![(-6, 0), (0, 0)], BLACK),
            ))
            .map_err(err)?;
    }
    Ok(())
}

/// Draws one mark; true when it added a legend entry.
fn draw_mark<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    p: &Panel,
    m: &Mark,
    f: &Frame,
) -> Result<bool, String> {
    match m {
        Mark::Band { x0, x1, color } => {
            let (a, b) = (p.x.map(*x0), p.x.map(*x1));
            if a.is_finite() && b.is_finite() && b > a {
                chart
                    .draw_series(std::iter::once(Rectangle::new(
                        [(a, f.y0), (b, f.y1)],
                        color.mix(0.15).filled(),
                    )))
                    .map_err(err)?;
            }
            Ok(false)
        }
        Mark::Line {
            pts,
            color,
            width,
            label,
        } => draw_line(chart, p, pts, *color, *width, label.as_deref(), f),
        Mark::Dots {
            pts,
            color,
            radius,
            label,
        } => draw_dots(chart, p, pts, *color, *radius, label.as_deref()),
        Mark::HLine {
            y,
            color,
            dash,
            label,
        } => draw_hline(chart, &p.y, *y, *color, *dash, label.as_deref(), f),
        Mark::VLine { x, color, label } => draw_vline(chart, &p.x, *x, *color, label.as_deref(), f),
        Mark::Bars { bars, color, label } => draw_bars(chart, p, bars, *color, label.as_deref(), f),
    }
}

/// A polyline, broken at non-finite points and (when thick) at sharp turns; a lone point is
/// a dot. The legend entry goes with the first piece.
fn draw_line<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    p: &Panel,
    pts: &[(f64, f64)],
    color: RGBColor,
    width: u32,
    label: Option<&str>,
    f: &Frame,
) -> Result<bool, String> {
    let mapped: Vec<(f64, f64)> = pts
        .iter()
        .map(|(x, y)| (p.x.map(*x), p.y.map(*y)))
        .collect();
    let style = color.stroke_width(width);
    let legend = move |(x, y): (i32, i32)| {
        PathElement::new(vec![(x, y), (x + 24, y)], color.stroke_width(3))
    };
    let mut first = true;
    let pieces = segments(&mapped).into_iter().flat_map(|s| {
        if width > 1 {
            split_sharp_turns(s, f.scale)
        } else {
            vec![s]
        }
    });
    for seg in pieces {
        if seg.len() == 1 {
            chart
                .draw_series(std::iter::once(Circle::new(
                    seg[0],
                    1 + width / 2,
                    color.filled(),
                )))
                .map_err(err)?;
            continue;
        }
        let ann = chart
            .draw_series(LineSeries::new(seg, style))
            .map_err(err)?;
        if let (Some(l), true) = (label, first) {
            ann.label(l).legend(legend);
            first = false;
        }
    }
    if let (Some(l), true) = (label, first) {
        // No segment drew a legend entry (all single points): add one anyway.
        chart
            .draw_series(std::iter::empty::<PathElement<(f64, f64)>>())
            .map_err(err)?
            .label(l)
            .legend(legend);
    }
    Ok(label.is_some())
}

/// Filled dots at the finite points.
fn draw_dots<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    p: &Panel,
    pts: &[(f64, f64)],
    c: RGBColor,
    r: u32,
    label: Option<&str>,
) -> Result<bool, String> {
    let mapped: Vec<(f64, f64)> = pts
        .iter()
        .map(|(x, y)| (p.x.map(*x), p.y.map(*y)))
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect();
    let ann = chart
        .draw_series(mapped.into_iter().map(|q| Circle::new(q, r, c.filled())))
        .map_err(err)?;
    if let Some(l) = label {
        ann.label(l)
            .legend(move |(x, y)| Circle::new((x + 12, y), r.max(4), c.filled()));
    }
    Ok(label.is_some())
}

/// A horizontal line across the panel at `y`, skipped outside the axis range.
fn draw_hline<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    axis: &Axis,
    y: f64,
    c: RGBColor,
    dash: Dash,
    label: Option<&str>,
    f: &Frame,
) -> Result<bool, String> {
    let yy = axis.map(y);
    if !yy.is_finite() || y > axis.max || y < axis.min {
        return Ok(false);
    }
    let style = c.stroke_width(2);
    let ends = vec![(f.x0, yy), (f.x1, yy)];
    let ann = match dash {
        Dash::Solid => chart
            .draw_series(LineSeries::new(ends, style))
            .map_err(err)?,
        Dash::Dashed => chart
            .draw_series(DashedLineSeries::new(ends, 10, 6, style))
            .map_err(err)?,
    };
    if let Some(l) = label {
        ann.label(l)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], c.stroke_width(2)));
    }
    Ok(label.is_some())
}

/// A dashed vertical line across the panel at `x`, skipped outside the axis range.
fn draw_vline<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    axis: &Axis,
    x: f64,
    c: RGBColor,
    label: Option<&str>,
    f: &Frame,
) -> Result<bool, String> {
    let xx = axis.map(x);
    if !xx.is_finite() || x < axis.min || x > axis.max {
        return Ok(false);
    }
    let ann = chart
        .draw_series(DashedLineSeries::new(
            vec![(xx, f.y0), (xx, f.y1)],
            8,
            5,
            c.stroke_width(2),
        ))
        .map_err(err)?;
    if let Some(l) = label {
        ann.label(l).legend(move |(x, y)| {
            PathElement::new(vec![(x + 12, y - 8), (x + 12, y + 8)], c.stroke_width(2))
        });
    }
    Ok(label.is_some())
}

/// Filled bars from the base (zero, or the lower edge of a log axis) to each value.
fn draw_bars<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    p: &Panel,
    bars: &[(f64, f64, f64)],
    c: RGBColor,
    label: Option<&str>,
    f: &Frame,
) -> Result<bool, String> {
    let base = if p.y.log {
        f.y0
    } else {
        0f64.clamp(f.y0, f.y1)
    };
    let ann = chart
        .draw_series(bars.iter().filter_map(|&(a, b, v)| {
            let (a, b, v) = (p.x.map(a), p.x.map(b), p.y.map(v));
            (a.is_finite() && b.is_finite() && v.is_finite())
                .then(|| Rectangle::new([(a, base), (b, v)], c.filled()))
        }))
        .map_err(err)?;
    if let Some(l) = label {
        ann.label(l)
            .legend(move |(x, y)| Rectangle::new([(x + 4, y - 6), (x + 20, y + 6)], c.filled()));
    }
    Ok(label.is_some())
}

/// The legend box, when the panel has one and some mark is labelled.
fn draw_legend<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    legend: Legend,
    any_label: bool,
) -> Result<(), String> {
    let pos = match legend {
        Legend::None => return Ok(()),
        Legend::UpperLeft => SeriesLabelPosition::UpperLeft,
        Legend::UpperRight => SeriesLabelPosition::UpperRight,
        Legend::LowerLeft => SeriesLabelPosition::LowerLeft,
        Legend::LowerRight => SeriesLabelPosition::LowerRight,
    };
    if !any_label {
        return Ok(());
    }
    chart
        .configure_series_labels()
        .position(pos)
        .margin(10)
        .legend_area_size(34)
        .label_font(font(TICK_PT))
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(120, 120, 120))
        .draw()
        .map_err(err)?;
    Ok(())
}
