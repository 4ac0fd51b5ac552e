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
//! use liftwatch::monitor::Analysis;
//! use liftwatch_report::{write_report, ReportInputs};
//! let model = liftwatch::file::load("model.json".as_ref())?;
//! let (series, _) = read_series("data.csv".as_ref(), &AlignConfig::default())?;
//! let analysis = Analysis::run(&model, &series); // features, both monitors, events
//! let files = write_report("report".as_ref(), &ReportInputs::new(&analysis, &model, &series, "data.csv"))?;
//! # Ok(()) }
//! ```
//!
//! The page opens with the verdict ([`liftwatch::verdict::Verdict`], the text `liftwatch
//! status` prints): level, mode, drift ± error since when, what to inspect, the forecast, the
//! evidence and the model's caveats. Then the figures, in report order (file stems of
//! [`FIGURES`]), the specialist ones in an appendix ([`APPENDIX`]):
//!
//! | stem | what it shows |
//! |------|---------------|
//! | `risk`          | combined R with advisory/alarm thresholds, events and the change's start; per-mode R_m; the drifts in physical units (Kd %, friction %, brake drag N) |
//! | `residuals`     | r_U and r_F of every moving sample over the whole input, trip means, running mean |
//! | `fit`           | U vs U_pred, F_U vs F_pred and both residuals over a busy 6 min near the end |
//! | `comparison`    | fixed-threshold baseline alarm state (activations counted) over the liftwatch risk |
//! | `usage`         | trips, door cycles and time moving by hour of day; histogram of trip λ |
//! | `availability`  | availability per day with the outages; door cycle duration and reopenings per day against the healthy reference, the door advisory |
//! | `preprocessing` | (appendix) aligned speed and signed v, load reading and held λ, door, floor over the busiest 20 min |
//! | `acceleration`  | (appendix) a_v, a_L and the fused a over three trips of that excerpt |
//! | `training`      | (appendix) loss (log scale), RMS r_U and RMS r_F against the iteration, stage 2 marked |
//! | `parameters`    | (appendix) one small panel per physical parameter θ_k, final value and ± one standard error |
//!
//! Design choices: whole-span time axes in days (or h, min, s) since midnight UTC of the first
//! day when the data's clock is Unix time (the zone is said on the axis), since the data's
//! start otherwise; whole-span series thinned to the
//! minimum and maximum of each pixel column; missing values and time gaps break lines; ranges from
//! quantiles so one outlier cannot squash a panel; the risk axis turns logarithmic when the
//! advisory and alarm thresholds are more than a factor 50 apart.
//!
//! Plotting lives in this crate so that the library stays free of drawing dependencies.

mod evaluation;
mod figures;
mod html;
pub mod plot;
mod section;

use std::path::{Path, PathBuf};

pub use evaluation::write_evaluation_figure;
use liftwatch::alarm::Event;
use liftwatch::features::Features;
use liftwatch::fit::FittedModel;
pub use liftwatch::monitor::Analysis;
use liftwatch::monitor::{MonitorRow, MonitorState};
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
    /// Monitor rows of the paper's method ([`liftwatch::monitor::Method::Pinn`]) over `series`.
    pub pinn: &'a [MonitorRow],
    /// Monitor rows of the fixed-threshold baseline ([`liftwatch::monitor::Method::Threshold`]) over `series`.
    pub threshold: &'a [MonitorRow],
    /// The level changes of the paper's method.
    pub events: &'a [Event],
    /// The paper's method's state at the end of `series`: the verdict the report opens with.
    pub state: &'a MonitorState,
    /// Usage and availability per day of `series` ([`Analysis::usage`]).
    pub usage: &'a [liftwatch::operation::DayUsage],
    /// Outage and door events over `series`.
    pub operation_events: &'a [liftwatch::operation::OperationEvent],
    /// Name of the input shown in the report (a file name).
    pub source: &'a str,
}

impl<'a> ReportInputs<'a> {
    /// The report inputs borrowing an analysis of `series` with `model`
    /// ([`liftwatch::monitor::Analysis`]: features, both monitors, events).
    pub fn new(
        analysis: &'a Analysis,
        model: &'a FittedModel,
        series: &'a AlignedSeries,
        source: &'a str,
    ) -> Self {
        ReportInputs {
            model,
            series,
            features: &analysis.features,
            pinn: &analysis.pinn,
            threshold: &analysis.threshold,
            events: &analysis.events,
            state: &analysis.state,
            usage: &analysis.usage,
            operation_events: &analysis.operation_events,
            source,
        }
    }
}

/// The figures of a report, by file stem, in the order the report shows them: after the
/// verdict what a maintenance engineer reads, then the specialist figures ([`APPENDIX`]).
pub const FIGURES: [&str; 10] = [
    "risk",
    "residuals",
    "fit",
    "comparison",
    "usage",
    "availability",
    "preprocessing",
    "acceleration",
    "training",
    "parameters",
];

/// The specialist figures, shown in the report's appendix: the preprocessing and the training.
pub const APPENDIX: [&str; 4] = ["preprocessing", "acceleration", "training", "parameters"];

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

#[cfg(test)]
mod tests {
    use super::*;
    use liftwatch::model::TrainConfig;
    use liftwatch::monitor::Method;
    use liftwatch::sim::SimConfig;
    use liftwatch::Elevator;

    /// A temporary directory removed on drop.
    struct TempDir(PathBuf);

    impl TempDir {
        fn new(tag: &str) -> TempDir {
            let p =
                std::env::temp_dir().join(format!("liftwatch-report-{tag}-{}", std::process::id()));
            let _ = std::fs::remove_dir_all(&p);
            TempDir(p)
        }
    }

    impl Drop for TempDir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    #[test]
    fn report_writes_every_figure_and_an_index_that_shows_them() {
        let elevator = Elevator::new(1000.0, 1.6, 16);
        let sim = liftwatch::sim::simulate(&SimConfig::new(elevator.clone(), 0.4, 11))
            .expect("valid simulator settings");
        let series = sim.aligned();
        let cfg = TrainConfig {
            epochs: 60,
            log_every: 10,
            ..TrainConfig::default()
        };
        let model = liftwatch::fit::fit(&series, &elevator, &cfg, &mut |_| {})
            .expect("0.4 simulated days fit")
            .model;
        let analysis = Analysis::run(&model, &series);
        assert_eq!(
            analysis.pinn.len(),
            series.len(),
            "one monitor row per sample"
        );
        // The last half alone, as `report --days` draws it: the same rows from the same
        // one pass, and the whole input's state.
        let half = series.len() / 2;
        let (late, window) = Analysis::run_from(&model, &series, series.samples[half].time)
            .expect("a series in memory reads");
        let debug = |x: &dyn std::fmt::Debug| format!("{x:?}");
        assert_eq!(debug(&window.samples), debug(&&series.samples[half..]));
        assert_eq!(debug(&late.pinn), debug(&&analysis.pinn[half..]));
        assert_eq!(debug(&late.threshold), debug(&&analysis.threshold[half..]));
        assert_eq!(
            debug(&late.features.rows),
            debug(&&analysis.features.rows[half..])
        );
        assert_eq!(debug(&late.state), debug(&analysis.state));
        let from = window.samples[0].time;
        let late_trips: Vec<_> = analysis
            .features
            .trips
            .iter()
            .filter(|t| t.start_time >= from)
            .collect();
        assert_eq!(debug(&late.features.trips), debug(&late_trips));
        assert!(late.features.trips.len() < analysis.features.trips.len());
        let features = &analysis.features;
        let inputs = ReportInputs::new(&analysis, &model, &series, "sim <seed 11>.csv");
        let dir = TempDir::new("all");
        let written = write_report(&dir.0, &inputs).expect("report is written");
        assert_eq!(written.len(), 2 * FIGURES.len() + 1);
        let index = std::fs::read_to_string(dir.0.join("index.html")).expect("index.html exists");
        assert!(
            index.contains("sim &lt;seed 11&gt;.csv"),
            "the source name is escaped"
        );
        for name in FIGURES {
            for ext in ["svg", "png"] {
                let path = dir.0.join(format!("{name}.{ext}"));
                let len = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
                assert!(len > 1000, "{} has {len} bytes", path.display());
            }
            let png = std::fs::read(dir.0.join(format!("{name}.png"))).expect("png is readable");
            assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n", "{name}.png is a PNG");
            let svg =
                std::fs::read_to_string(dir.0.join(format!("{name}.svg"))).expect("svg is text");
            assert!(
                svg.trim_start().starts_with("<svg"),
                "{name}.svg starts with <svg"
            );
            assert!(svg.trim_end().ends_with("</svg>"), "{name}.svg is complete");
            assert_eq!(
                svg.matches("<text").count(),
                svg.matches("</text>").count(),
                "{name}.svg text elements balance"
            );
            assert!(
                index.contains(&format!("<img src=\"{name}.svg\"")),
                "index.html shows {name}.svg"
            );
        }
        // The axis descriptions are in the SVGs as text.
        let text = |name: &str| {
            std::fs::read_to_string(dir.0.join(format!("{name}.svg"))).expect("svg is text")
        };
        for (name, label) in [
            ("preprocessing", "velocity (m/s)"),
            ("preprocessing", "load (% of rated)"),
            ("acceleration", "acceleration (m/s²)"),
            ("training", "iteration"),
            ("fit", "voltage (V)"),
            ("fit", "force (N, + up)"),
            ("residuals", "r_U (V)"),
            ("risk", "risk R (1)"),
            ("risk", "time since start of data (h)"),
            ("comparison", "baseline state"),
            ("usage", "hour of day"),
            ("availability", "availability (%)"),
            ("availability", "door open (s)"),
        ] {
            let svg = text(name);
            let escaped = label.replace('&', "&amp;");
            assert!(
                svg.contains(label) || svg.contains(&escaped),
                "{name}.svg lacks the axis label `{label}`"
            );
        }
        // Numbers come from the data: the trip count of the usage text is the features' count.
        assert!(index.contains(&format!("{} complete trips", features.trips.len())));
        assert!(!index.contains("NaN") && !index.contains("TODO"));
        // The page opens with the verdict, the text `status` prints, before any figure.
        let verdict = liftwatch::verdict::Verdict::new(&model, &analysis.state).lines();
        let at = index.find("id=\"verdict\"").expect("a verdict section");
        assert!(
            at < index.find("<img").expect("figures"),
            "the verdict comes first"
        );
        assert!(
            index.contains(&section::escape(&verdict[0])),
            "{}",
            verdict[0]
        );
        assert!(
            index.find("id=\"appendix\"").expect("an appendix") > index.find("risk.svg").unwrap()
        );
        // A short excerpt with a gap and no complete trip still gives a full report.
        let mut short = AlignedSeries {
            step_s: 1.0,
            samples: series.samples[..400].to_vec(),
        };
        for s in &mut short.samples[100..150] {
            *s = liftwatch::Sample::missing(s.time);
        }
        let f_short = liftwatch::features::extract(&short, &model.features);
        let p_short = liftwatch::monitor::run(&model, &short.samples, Method::Pinn);
        let t_short = liftwatch::monitor::run(&model, &short.samples, Method::Threshold);
        let small = ReportInputs {
            series: &short,
            features: &f_short,
            pinn: &p_short,
            threshold: &t_short,
            events: &[],
            ..inputs
        };
        let dir_short = TempDir::new("short");
        let written = write_report(&dir_short.0, &small).expect("a short report is written");
        assert_eq!(written.len(), 2 * FIGURES.len() + 1);
        let index =
            std::fs::read_to_string(dir_short.0.join("index.html")).expect("index.html exists");
        assert!(!index.contains("NaN") && !index.contains("inf"), "{index}");
        // An empty series is refused before anything is written.
        let empty = AlignedSeries::default();
        let none = ReportInputs {
            series: &empty,
            pinn: &[],
            threshold: &[],
            events: &[],
            ..inputs
        };
        let missing = dir.0.join("empty");
        assert!(matches!(
            write_report(&missing, &none),
            Err(Error::NoData(_))
        ));
        assert!(!missing.exists());
    }
}
