//! Figures and the HTML report of liftwatch: what `liftwatch report` writes.
//!
//! The report reads the pipeline's intermediate results, never recomputes them differently:
//! the aligned series (stage 2), its features (stage 3), the fitted model with its training
//! history (stage 4), the residuals the model gives (stage 5, `r_U = U − U_pred`,
//! `r_F = F_pred − F_U`) and the monitor rows of both methods (stages 6-7 and the fixed-threshold
//! baseline of the paper, Sec. 5.4). Each figure is written as SVG and PNG; `index.html` shows the
//! SVGs with a few sentences each whose numbers come from the same data.
//!
//! ```no_run
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! use liftwatch::align::{read_series, AlignConfig};
//! use liftwatch::monitor::Method;
//! use liftwatch_report::{monitor_rows, write_report, ReportInputs};
//! let model = liftwatch::model::file::load("model.json".as_ref())?;
//! let (series, _) = read_series("data.csv".as_ref(), &AlignConfig::default())?;
//! let features = liftwatch::features::extract(&series, &model.features);
//! let pinn = monitor_rows(&model, &series, Method::Pinn);
//! let threshold = monitor_rows(&model, &series, Method::Threshold);
//! let events: Vec<_> = pinn.iter().filter_map(|r| r.event).collect();
//! let inputs = ReportInputs { model: &model, series: &series, features: &features, pinn: &pinn,
//!     threshold: &threshold, events: &events, source: "data.csv" };
//! let files = write_report("report".as_ref(), &inputs)?;
//! # Ok(()) }
//! ```
//!
//! Plotting lives in this crate so that the library stays free of drawing dependencies.

mod figures;
mod html;
pub mod plot;

use std::path::{Path, PathBuf};

use liftwatch::alarm::Event;
use liftwatch::features::Features;
use liftwatch::model::FittedModel;
use liftwatch::monitor::{Method, Monitor, MonitorRow};
use liftwatch::AlignedSeries;

/// What can go wrong while writing a report.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The output directory or a file in it could not be written.
    #[error("{}: {source}", .path.display())]
    Io {
        /// The file or directory concerned.
        path: PathBuf,
        /// The operating-system error.
        #[source]
        source: std::io::Error,
    },
    /// A figure could not be drawn.
    #[error("cannot draw {figure}: {why}")]
    Draw {
        /// The figure (file) concerned.
        figure: String,
        /// The backend's complaint.
        why: String,
    },
    /// The inputs hold nothing to show.
    #[error("nothing to report: {0}")]
    NoData(String),
}

/// Everything a report shows, borrowed from the pipeline's results.
#[derive(Clone, Copy, Debug)]
pub struct ReportInputs<'a> {
    /// The fitted model, with its training history.
    pub model: &'a FittedModel,
    /// The aligned series the report is about.
    pub series: &'a AlignedSeries,
    /// Its features (one row per sample, and the complete trips), computed with `model.features`.
    pub features: &'a Features,
    /// Monitor rows of the paper's method ([`Method::Pinn`]) over `series`.
    pub pinn: &'a [MonitorRow],
    /// Monitor rows of the fixed-threshold baseline ([`Method::Threshold`]) over `series`.
    pub threshold: &'a [MonitorRow],
    /// The level changes of the paper's method.
    pub events: &'a [Event],
    /// Name of the input shown in the report (a file name).
    pub source: &'a str,
}

/// The figures of a report, by file stem, in the order the report shows them.
pub const FIGURES: [&str; 9] = [
    "preprocessing",
    "acceleration",
    "training",
    "parameters",
    "fit",
    "residuals",
    "risk",
    "comparison",
    "usage",
];

/// Runs the streaming monitor of `method` over the whole series: one row per sample.
pub fn monitor_rows(model: &FittedModel, series: &AlignedSeries, method: Method) -> Vec<MonitorRow> {
    let mut m = Monitor::new(model, method);
    let mut rows: Vec<MonitorRow> = series.samples.iter().filter_map(|s| m.push(s)).collect();
    rows.extend(m.finish());
    rows
}

/// Writes every figure (SVG and PNG) and `index.html` into `dir` (created if missing);
/// returns the paths written, `index.html` last.
///
/// # Errors
/// [`Error::NoData`] for an empty series; [`Error::Io`] and [`Error::Draw`] when a file cannot
/// be written.
pub fn write_report(dir: &Path, inputs: &ReportInputs) -> Result<Vec<PathBuf>, Error> {
    if inputs.series.samples.len() < 2 {
        return Err(Error::NoData(format!(
            "the series holds {} samples, need at least 2",
            inputs.series.samples.len()
        )));
    }
    std::fs::create_dir_all(dir).map_err(|e| Error::Io {
        path: dir.into(),
        source: e,
    })?;
    let sections = figures::all(inputs);
    let mut written = Vec::new();
    for s in &sections {
        written.extend(plot::emit(dir, &s.figure)?);
    }
    let index = dir.join("index.html");
    let page = html::page(inputs, &sections);
    std::fs::write(&index, page).map_err(|e| Error::Io {
        path: index.clone(),
        source: e,
    })?;
    written.push(index);
    Ok(written)
}
