//! The drawing layer of the report: figures described as data, drawn once per backend.
//!
//! A [`Figure`] is a grid of [`Panel`]s, each a list of [`Mark`]s on a linear (or decade
//! logarithmic) axis pair. [`emit`] draws the same description to an SVG and a PNG file, so the
//! two never disagree. Text uses the bundled DejaVu Sans through `ab_glyph`: no system font is
//! read, and the SVG names the family with a `sans-serif` fallback for browsers without it.
//!
//! Long series are thinned by [`decimate`] to the minimum and maximum of each pixel column (a
//! one-sample spike stays visible); missing values and time gaps break a line instead of
//! being bridged.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;

use crate::Error;

/// The family name registered for the bundled font; also what the SVG's `font-family` says.
pub const FONT: &str = "DejaVu Sans, sans-serif";

/// Font sizes in plotters units (the SVG writes `size / 1.24` px, so 18 gives 14.5 px).
pub const TICK_PT: f64 = 18.0;
/// Axis descriptions and legends.
pub const DESC_PT: f64 = 19.0;
/// Panel titles.
pub const TITLE_PT: f64 = 21.0;

/// Okabe-Ito colours, distinguishable with the common colour-vision deficiencies.
pub mod colors {
    use plotters::style::RGBColor;
    /// Blue.
    pub const BLUE: RGBColor = RGBColor(0, 114, 178);
    /// Orange.
    pub const ORANGE: RGBColor = RGBColor(230, 159, 0);
    /// Bluish green.
    pub const GREEN: RGBColor = RGBColor(0, 158, 115);
    /// Vermillion.
    pub const RED: RGBColor = RGBColor(213, 94, 0);
    /// Reddish purple.
    pub const PURPLE: RGBColor = RGBColor(204, 121, 167);
    /// Sky blue.
    pub const SKY: RGBColor = RGBColor(86, 180, 233);
    /// Near black for measured data.
    pub const INK: RGBColor = RGBColor(40, 40, 40);
    /// Grey for context.
    pub const GREY: RGBColor = RGBColor(150, 150, 150);
}

/// Registers the bundled font once per process.
///
/// # Errors
/// [`Error::Draw`] when the bundled file is not a font (a broken build).
pub fn register_font() -> Result<(), Error> {
    static DONE: OnceLock<bool> = OnceLock::new();
    let ok = *DONE.get_or_init(|| {
        plotters::style::register_font(
            FONT,
            FontStyle::Normal,
            include_bytes!("../assets/DejaVuSans.ttf"),
        )
        .is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(Error::Draw {
            figure: "font".into(),
            why: "the bundled DejaVuSans.ttf could not be read".into(),
        })
    }
}

/// One axis: its range and description.
#[derive(Clone, Debug)]
pub struct Axis {
    /// Lower end of the range (data units; decades for a log axis are taken from it).
    pub min: f64,
    /// Upper end.
    pub max: f64,
    /// Description with unit, e.g. `speed (m/s)`.
    pub label: String,
    /// Logarithmic axis; values at or below `min` (zero too) are drawn on its lower edge.
    pub log: bool,
}

impl Axis {
    /// A linear axis.
    pub fn new(min: f64, max: f64, label: impl Into<String>) -> Self {
        Axis {
            min,
            max,
            label: label.into(),
            log: false,
        }
    }

    /// A logarithmic axis over whole decades covering `min..max`.
    pub fn log(min: f64, max: f64, label: impl Into<String>) -> Self {
        let lo = min.max(1e-300).log10().floor();
        let hi = max.max(min * 10.0).log10().ceil().max(lo + 1.0);
        Axis {
            min: 10f64.powf(lo),
            max: 10f64.powf(hi),
            label: label.into(),
            log: true,
        }
    }

    /// Maps a value to the drawing coordinate (log10 on a log axis), clamped to the range;
    /// NaN where it cannot be drawn.
    fn map(&self, v: f64) -> f64 {
        if !v.is_finite() {
            return f64::NAN;
        }
        if self.log {
            // At or below the range (zero included) is drawn on the lower edge.
            v.max(self.min)
                .log10()
                .clamp(self.min.log10(), self.max.log10())
        } else {
            v.clamp(self.min, self.max)
        }
    }

    fn range(&self) -> (f64, f64) {
        if self.log {
            (self.min.log10(), self.max.log10())
        } else if self.max > self.min {
            (self.min, self.max)
        } else {
            (self.min - 0.5, self.min + 0.5)
        }
    }
}

/// Line pattern.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dash {
    /// Solid.
    Solid,
    /// Dashed.
    Dashed,
}

/// Something drawn in a panel.
#[derive(Clone, Debug)]
pub enum Mark {
    /// A polyline; a non-finite point breaks it.
    Line {
        /// Points (x, y).
        pts: Vec<(f64, f64)>,
        /// Colour.
        color: RGBColor,
        /// Width (px).
        width: u32,
        /// Legend entry.
        label: Option<String>,
    },
    /// Dots at the points.
    Dots {
        /// Points (x, y).
        pts: Vec<(f64, f64)>,
        /// Colour.
        color: RGBColor,
        /// Radius (px).
        radius: u32,
        /// Legend entry.
        label: Option<String>,
    },
    /// A horizontal reference line across the panel.
    HLine {
        /// Level.
        y: f64,
        /// Colour.
        color: RGBColor,
        /// Pattern.
        dash: Dash,
        /// Legend entry.
        label: Option<String>,
    },
    /// A vertical marker line across the panel.
    VLine {
        /// Position.
        x: f64,
        /// Colour.
        color: RGBColor,
        /// Legend entry.
        label: Option<String>,
    },
    /// Bars from `y = base` to `y`, each spanning `[x0, x1]`.
    Bars {
        /// (x0, x1, y) per bar.
        bars: Vec<(f64, f64, f64)>,
        /// Colour.
        color: RGBColor,
        /// Legend entry.
        label: Option<String>,
    },
    /// A shaded vertical band `[x0, x1]` behind the data.
    Band {
        /// Start.
        x0: f64,
        /// End.
        x1: f64,
        /// Colour (drawn light).
        color: RGBColor,
    },
}

/// Where the legend sits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Legend {
    /// No legend.
    None,
    /// Upper left corner.
    UpperLeft,
    /// Upper right corner.
    UpperRight,
    /// Lower left corner.
    LowerLeft,
    /// Lower right corner.
    LowerRight,
}

/// One chart of a figure.
#[derive(Clone, Debug)]
pub struct Panel {
    /// Title above the chart.
    pub title: String,
    /// Horizontal axis.
    pub x: Axis,
    /// Vertical axis.
    pub y: Axis,
    /// What is drawn, in order (later on top).
    pub marks: Vec<Mark>,
    /// Legend position.
    pub legend: Legend,
    /// Custom tick labels of the y axis (value, text); empty for automatic ticks.
    pub y_ticks: Vec<(f64, String)>,
    /// Room added above the data for the legend, as a fraction of the range; `None` sizes it
    /// by the number of legend entries when the legend sits at the top.
    pub headroom: Option<f64>,
}

impl Panel {
    /// A panel with no marks yet.
    pub fn new(title: impl Into<String>, x: Axis, y: Axis) -> Self {
        Panel {
            title: title.into(),
            x,
            y,
            marks: Vec::new(),
            legend: Legend::UpperRight,
            y_ticks: Vec::new(),
            headroom: None,
        }
    }
}

/// A grid of panels, filled row by row.
#[derive(Clone, Debug)]
pub struct Figure {
    /// File stem (`fit` → `fit.svg`, `fit.png`).
    pub name: String,
    /// Width (px).
    pub width: u32,
    /// Height (px).
    pub height: u32,
    /// Grid (rows, columns).
    pub grid: (usize, usize),
    /// The panels.
    pub panels: Vec<Panel>,
}

/// Draws `fig` to `<dir>/<name>.svg` and `<dir>/<name>.png`; returns both paths.
///
/// # Errors
/// [`Error::Draw`] when a backend fails (an unwritable directory, mostly).
pub fn emit(dir: &Path, fig: &Figure) -> Result<[PathBuf; 2], Error> {
    register_font()?;
    let svg = dir.join(format!("{}.svg", fig.name));
    let png = dir.join(format!("{}.png", fig.name));
    let fail = |path: &Path, e: String| Error::Draw {
        figure: path.display().to_string(),
        why: e,
    };
    {
        let root = SVGBackend::new(&svg, (fig.width, fig.height)).into_drawing_area();
        draw_figure(&root, fig).map_err(|e| fail(&svg, e))?;
        root.present().map_err(|e| fail(&svg, e.to_string()))?;
    }
    {
        let root = BitMapBackend::new(&png, (fig.width, fig.height)).into_drawing_area();
        draw_figure(&root, fig).map_err(|e| fail(&png, e))?;
        root.present().map_err(|e| fail(&png, e.to_string()))?;
    }
    Ok([svg, png])
}

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

fn draw_figure<DB: DrawingBackend>(
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
fn segments(pts: &[(f64, f64)]) -> Vec<Vec<(f64, f64)>> {
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

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    p: &Panel,
    x_desc: bool,
) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let (x0, x1) = p.x.range();
    let (y0, mut y1) = p.y.range();
    let labelled = p.marks.iter().any(|m| match m {
        Mark::Line { label, .. }
        | Mark::Dots { label, .. }
        | Mark::HLine { label, .. }
        | Mark::VLine { label, .. }
        | Mark::Bars { label, .. } => label.is_some(),
        Mark::Band { .. } => false,
    });
    if labelled && matches!(p.legend, Legend::UpperLeft | Legend::UpperRight) {
        // Headroom for the legend box, so that it does not hide the data.
        let n = p
            .marks
            .iter()
            .filter(|m| {
                matches!(
                    m,
                    Mark::Line { label: Some(_), .. }
                        | Mark::Dots { label: Some(_), .. }
                        | Mark::HLine { label: Some(_), .. }
                        | Mark::VLine { label: Some(_), .. }
                        | Mark::Bars { label: Some(_), .. }
                )
            })
            .count();
        // The legend box is about 16 px plus 27 px per entry; the plot about the area less
        // the caption and the x labels.
        let (_, area_h) = area.dim_in_pixel();
        let plot_h = f64::from(area_h) - if x_desc { 110.0 } else { 84.0 };
        let legend_h = 24.0 + 27.0 * n as f64;
        let auto = (legend_h / (plot_h - legend_h).max(1.0)).clamp(0.1, 0.5);
        y1 += (y1 - y0) * p.headroom.unwrap_or(auto);
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
        .map_err(e)?;
    let (pw, ph) = chart.plotting_area().dim_in_pixel();
    let scale = (
        f64::from(pw) / (x1 - x0).max(1e-300),
        f64::from(ph) / (y1 - y0).max(1e-300),
    );
    let (x_span, y_span) = (x1 - x0, p.y.range().1 - y0);
    let xf = |v: &f64| fmt_tick(*v, x_span);
    // Own ticks (drawn below) for custom labels and log axes; plotters' for the rest.
    let own: Vec<(f64, String)> = if !p.y_ticks.is_empty() {
        p.y_ticks
            .iter()
            .map(|(v, s)| (p.y.map(*v), s.clone()))
            .collect()
    } else if p.y.log {
        log_ticks(p.y.min, 10f64.powf(y1))
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
        .map_err(e)?;
    let tick_style = font(TICK_PT).pos(plotters::style::text_anchor::Pos::new(
        plotters::style::text_anchor::HPos::Right,
        plotters::style::text_anchor::VPos::Center,
    ));
    for (v, text) in own.iter().filter(|(v, _)| *v >= y0 && *v <= y1) {
        chart
            .draw_series(LineSeries::new(
                vec![(x0, *v), (x1, *v)],
                RGBColor(215, 215, 215),
            ))
            .map_err(e)?;
        chart
            .draw_series(std::iter::once(
                EmptyElement::at((x0, *v)) + Text::new(text.clone(), (-10, 0), tick_style.clone()),
            ))
            .map_err(e)?;
        chart
            .draw_series(std::iter::once(
                EmptyElement::at((x0, *v)) + PathElement::new(vec![(-6, 0), (0, 0)], BLACK),
            ))
            .map_err(e)?;
    }
    let mut any_label = false;
    for m in &p.marks {
        match m {
            Mark::Band { x0, x1, color } => {
                let (a, b) = (p.x.map(*x0), p.x.map(*x1));
                if a.is_finite() && b.is_finite() && b > a {
                    chart
                        .draw_series(std::iter::once(Rectangle::new(
                            [(a, y0), (b, y1)],
                            color.mix(0.15).filled(),
                        )))
                        .map_err(e)?;
                }
            }
            Mark::Line {
                pts,
                color,
                width,
                label,
            } => {
                let mapped: Vec<(f64, f64)> = pts
                    .iter()
                    .map(|(x, y)| (p.x.map(*x), p.y.map(*y)))
                    .collect();
                let style = color.stroke_width(*width);
                let mut first = true;
                let pieces = segments(&mapped).into_iter().flat_map(|s| {
                    if *width > 1 {
                        split_sharp_turns(s, scale)
                    } else {
                        vec![s]
                    }
                });
                for seg in pieces {
                    if seg.len() == 1 {
                        chart
                            .draw_series(std::iter::once(Circle::new(
                                seg[0],
                                1 + *width / 2,
                                color.filled(),
                            )))
                            .map_err(e)?;
                        continue;
                    }
                    let ann = chart.draw_series(LineSeries::new(seg, style)).map_err(e)?;
                    if let (Some(l), true) = (label, first) {
                        let c = *color;
                        ann.label(l.as_str()).legend(move |(x, y)| {
                            PathElement::new(vec![(x, y), (x + 24, y)], c.stroke_width(3))
                        });
                        any_label = true;
                        first = false;
                    }
                }
                if let (Some(l), true) = (label, first) {
                    // No segment drew a legend entry (all single points): add one anyway.
                    let c = *color;
                    chart
                        .draw_series(std::iter::empty::<PathElement<(f64, f64)>>())
                        .map_err(e)?
                        .label(l.as_str())
                        .legend(move |(x, y)| {
                            PathElement::new(vec![(x, y), (x + 24, y)], c.stroke_width(3))
                        });
                    any_label = true;
                }
            }
            Mark::Dots {
                pts,
                color,
                radius,
                label,
            } => {
                let mapped: Vec<(f64, f64)> = pts
                    .iter()
                    .map(|(x, y)| (p.x.map(*x), p.y.map(*y)))
                    .filter(|(x, y)| x.is_finite() && y.is_finite())
                    .collect();
                let r = *radius;
                let c = *color;
                let ann = chart
                    .draw_series(mapped.into_iter().map(|q| Circle::new(q, r, c.filled())))
                    .map_err(e)?;
                if let Some(l) = label {
                    ann.label(l.as_str())
                        .legend(move |(x, y)| Circle::new((x + 12, y), r.max(4), c.filled()));
                    any_label = true;
                }
            }
            Mark::HLine {
                y,
                color,
                dash,
                label,
            } => {
                let yy = p.y.map(*y);
                if !yy.is_finite() || *y > p.y.max || *y < p.y.min {
                    continue;
                }
                let c = *color;
                let style = c.stroke_width(2);
                let ann = match dash {
                    Dash::Solid => chart
                        .draw_series(LineSeries::new(vec![(x0, yy), (x1, yy)], style))
                        .map_err(e)?,
                    Dash::Dashed => chart
                        .draw_series(DashedLineSeries::new(
                            vec![(x0, yy), (x1, yy)],
                            10,
                            6,
                            style,
                        ))
                        .map_err(e)?,
                };
                if let Some(l) = label {
                    ann.label(l.as_str()).legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 24, y)], c.stroke_width(2))
                    });
                    any_label = true;
                }
            }
            Mark::VLine { x, color, label } => {
                let xx = p.x.map(*x);
                if !xx.is_finite() || *x < p.x.min || *x > p.x.max {
                    continue;
                }
                let c = *color;
                let ann = chart
                    .draw_series(DashedLineSeries::new(
                        vec![(xx, y0), (xx, y1)],
                        8,
                        5,
                        c.stroke_width(2),
                    ))
                    .map_err(e)?;
                if let Some(l) = label {
                    ann.label(l.as_str()).legend(move |(x, y)| {
                        PathElement::new(vec![(x + 12, y - 8), (x + 12, y + 8)], c.stroke_width(2))
                    });
                    any_label = true;
                }
            }
            Mark::Bars { bars, color, label } => {
                let base = if p.y.log { y0 } else { 0f64.clamp(y0, y1) };
                let c = *color;
                let ann = chart
                    .draw_series(bars.iter().filter_map(|&(a, b, v)| {
                        let (a, b, v) = (p.x.map(a), p.x.map(b), p.y.map(v));
                        (a.is_finite() && b.is_finite() && v.is_finite())
                            .then(|| Rectangle::new([(a, base), (b, v)], c.filled()))
                    }))
                    .map_err(e)?;
                if let Some(l) = label {
                    ann.label(l.as_str()).legend(move |(x, y)| {
                        Rectangle::new([(x + 4, y - 6), (x + 20, y + 6)], c.filled())
                    });
                    any_label = true;
                }
            }
        }
    }
    let pos = match p.legend {
        Legend::None => None,
        Legend::UpperLeft => Some(SeriesLabelPosition::UpperLeft),
        Legend::UpperRight => Some(SeriesLabelPosition::UpperRight),
        Legend::LowerLeft => Some(SeriesLabelPosition::LowerLeft),
        Legend::LowerRight => Some(SeriesLabelPosition::LowerRight),
    };
    if let (Some(pos), true) = (pos, any_label) {
        chart
            .configure_series_labels()
            .position(pos)
            .margin(10)
            .legend_area_size(34)
            .label_font(font(TICK_PT))
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(120, 120, 120))
            .draw()
            .map_err(e)?;
    }
    Ok(())
}

/// A pixel column in [`decimate`]: index, (t, y) of the minimum, (t, y) of the maximum.
type Column = (i64, (f64, f64), (f64, f64));

/// Thins `(t, y)` to at most about two points per pixel column of `columns` over `[x0, x1]`:
/// the minimum and the maximum of each column, in their time order, so a one-sample spike
/// survives. A non-finite `y` or a time step longer than `max_step` breaks the line (a NaN
/// point is emitted). Points outside `[x0, x1]` are dropped.
pub fn decimate(
    t: &[f64],
    y: &[f64],
    x0: f64,
    x1: f64,
    columns: usize,
    max_step: f64,
) -> Vec<(f64, f64)> {
    let columns = columns.max(1);
    let width = (x1 - x0) / columns as f64;
    let mut out: Vec<(f64, f64)> = Vec::new();
    // Current column: its index, (t, y) of its minimum and of its maximum.
    let mut col: Option<Column> = None;
    let mut last_t = f64::NAN;
    let brk = |out: &mut Vec<(f64, f64)>| {
        if out.last().is_some_and(|p| p.1.is_finite()) {
            out.push((f64::NAN, f64::NAN));
        }
    };
    let flush = |out: &mut Vec<(f64, f64)>, c: &mut Option<Column>| {
        if let Some((_, lo, hi)) = c.take() {
            if lo.0 <= hi.0 {
                out.push(lo);
                if hi != lo {
                    out.push(hi);
                }
            } else {
                out.push(hi);
                out.push(lo);
            }
        }
    };
    for (&ti, &yi) in t.iter().zip(y) {
        if !(ti >= x0 && ti <= x1) {
            continue;
        }
        let gap = last_t.is_finite() && ti - last_t > max_step;
        if !yi.is_finite() || gap {
            flush(&mut out, &mut col);
            brk(&mut out);
            if !yi.is_finite() {
                last_t = f64::NAN;
                continue;
            }
        }
        last_t = ti;
        let k = if width > 0.0 {
            ((ti - x0) / width).floor() as i64
        } else {
            0
        };
        match &mut col {
            Some((idx, lo, hi)) if *idx == k => {
                if yi < lo.1 {
                    *lo = (ti, yi);
                }
                if yi > hi.1 {
                    *hi = (ti, yi);
                }
            }
            _ => {
                flush(&mut out, &mut col);
                col = Some((k, (ti, yi), (ti, yi)));
            }
        }
    }
    flush(&mut out, &mut col);
    out
}

/// Quantile `q` (0..1) of the finite values, NaN when there is none.
pub fn quantile(values: impl IntoIterator<Item = f64>, q: f64) -> f64 {
    let mut v: Vec<f64> = values.into_iter().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let i = (q.clamp(0.0, 1.0) * (v.len() - 1) as f64).round() as usize;
    v[i.min(v.len() - 1)]
}

/// A range holding the `lo..hi` quantiles of the finite values and the `extra` values, padded
/// by 6 % each side; one outlier cannot blow it up. `(0, 1)` without data.
pub fn robust_range(values: &[f64], lo: f64, hi: f64, extra: &[f64]) -> (f64, f64) {
    let mut a = quantile(values.iter().copied(), lo);
    let mut b = quantile(values.iter().copied(), hi);
    for &x in extra.iter().filter(|x| x.is_finite()) {
        a = if a.is_finite() { a.min(x) } else { x };
        b = if b.is_finite() { b.max(x) } else { x };
    }
    if !(a.is_finite() && b.is_finite()) {
        return (0.0, 1.0);
    }
    if b - a < 1e-12 * a.abs().max(1.0) {
        let d = a.abs().max(1.0) * 0.05;
        return (a - d, b + d);
    }
    let pad = 0.06 * (b - a);
    (a - pad, b + pad)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimation_keeps_a_one_sample_spike() {
        let t: Vec<f64> = (0..100_000).map(f64::from).collect();
        let mut y = vec![0.0; t.len()];
        y[54_321] = 7.0;
        let pts = decimate(&t, &y, 0.0, 99_999.0, 1000, 1.5);
        assert!(pts.len() <= 2 * 1000 + 2, "{} points", pts.len());
        assert!(pts.iter().any(|p| p.1 == 7.0));
    }

    #[test]
    fn missing_values_and_time_gaps_break_the_line() {
        let t = [0.0, 1.0, 2.0, 3.0, 10.0, 11.0];
        let y = [1.0, 2.0, f64::NAN, 3.0, 4.0, 5.0];
        let pts = decimate(&t, &y, 0.0, 11.0, 10_000, 1.5);
        let segs = segments(&pts);
        assert_eq!(segs.len(), 3, "{pts:?}");
        assert_eq!(segs[0], vec![(0.0, 1.0), (1.0, 2.0)]);
        assert_eq!(segs[1], vec![(3.0, 3.0)]);
    }

    #[test]
    fn robust_range_ignores_one_outlier() {
        let mut v: Vec<f64> = (0..10_000).map(|i| f64::from(i % 100)).collect();
        v[17] = 1e9;
        let (lo, hi) = robust_range(&v, 0.001, 0.999, &[]);
        assert!(lo < 1.0 && hi > 98.0 && hi < 120.0, "{lo} {hi}");
    }

    #[test]
    fn tick_labels_have_the_decimals_the_spacing_needs() {
        assert_eq!(fmt_tick(0.25, 1.0), "0.25");
        assert_eq!(fmt_tick(1500.0, 3000.0), "1500");
        assert_eq!(fmt_tick(-0.0001, 1.0), "0");
        assert_eq!(fmt_tick(-436.5, 3.0), "-436.5");
        assert_eq!(fmt_tick(0.00415, 0.0001), "0.00415");
    }
}
