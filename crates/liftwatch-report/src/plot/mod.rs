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
//!
//! This file holds the description (axes, marks, panels, figures) and [`emit`]; `draw.rs`
//! draws a description with plotters, `data.rs` thins and ranges the data.

mod data;
mod draw;
#[cfg(test)]
mod tests;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::prelude::*;
use plotters::style::FontStyle;

use crate::Error;

pub use data::{decimate, quantile, robust_range};
use draw::draw_figure;
pub use draw::fmt_tick;

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
            include_bytes!("../../assets/DejaVuSans.ttf"),
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
