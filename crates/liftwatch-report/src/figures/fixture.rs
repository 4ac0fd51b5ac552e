//! Test fixture of the figure families: a short simulated healthy series, a model fitted on
//! it with few epochs and the analysis of the series, built once per test process.

use liftwatch::sample::HOUR_S;
use std::path::PathBuf;
use std::sync::OnceLock;

use liftwatch::fit::FittedModel;
use liftwatch::model::TrainConfig;
use liftwatch::sim::SimConfig;
use liftwatch::{AlignedSeries, Elevator};

use crate::plot::emit;
use crate::section::Section;
use crate::{Analysis, ReportInputs};

/// Simulated span (days): enough trips to fit and calibrate, little enough to stay fast.
const DAYS: f64 = 0.25;
/// Start of the simulation (s after Monday midnight): 07:00, so that the span is busy.
const START_S: f64 = 7.0 * HOUR_S;
/// Seed of the simulated elevator and its traffic.
const SEED: u64 = 5;
/// Training epochs: the figures need a history, not a good model.
const EPOCHS: usize = 30;

/// A model and the analysis of the series it was fitted on.
pub(crate) struct Fixture {
    /// The fitted model.
    pub model: FittedModel,
    /// The simulated series.
    pub series: AlignedSeries,
    /// Features and both monitors over `series`.
    pub analysis: Analysis,
}

impl Fixture {
    /// The fixture, simulated and fitted on first use.
    pub fn get() -> &'static Fixture {
        static FIXTURE: OnceLock<Fixture> = OnceLock::new();
        FIXTURE.get_or_init(|| {
            let elevator = Elevator::new(1000.0, 1.6, 16);
            let sim = liftwatch::sim::simulate(&SimConfig {
                start_s: START_S,
                ..SimConfig::new(elevator.clone(), DAYS, SEED)
            })
            .expect("valid simulator settings");
            let series = sim.aligned();
            let cfg = TrainConfig {
                epochs: EPOCHS,
                ..TrainConfig::default()
            };
            let model = liftwatch::fit::fit(&series, &elevator, &cfg, &mut |_| {})
                .expect("a quarter of a simulated day fits")
                .model;
            let analysis = Analysis::run(&model, &series);
            Fixture {
                model,
                series,
                analysis,
            }
        })
    }

    /// The report inputs of the fixture.
    pub fn inputs(&self) -> ReportInputs<'_> {
        ReportInputs::new(
            &self.analysis,
            &self.model,
            &self.series,
            "fixture <seed 5>.csv",
        )
    }
}

/// Draws the section's figure into a fresh directory and checks that its SVG is a complete,
/// non-empty drawing that shows `text` (an axis label or title) and that its PNG is written.
pub(crate) fn assert_drawn(section: &Section, text: &str) {
    let name = &section.figure.name;
    let dir: PathBuf =
        std::env::temp_dir().join(format!("liftwatch-figure-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temporary directory is writable");
    let [svg, png] = emit(&dir, &section.figure).expect("the figure is drawn");
    let drawing = std::fs::read_to_string(&svg).expect("the svg is text");
    let png_len = std::fs::metadata(&png).map_or(0, |m| m.len());
    let _ = std::fs::remove_dir_all(&dir);
    assert!(
        drawing.len() > 1000,
        "{name}.svg has {} bytes",
        drawing.len()
    );
    assert!(
        drawing.trim_start().starts_with("<svg") && drawing.trim_end().ends_with("</svg>"),
        "{name}.svg is complete"
    );
    assert!(drawing.contains(text), "{name}.svg lacks `{text}`");
    assert!(png_len > 1000, "{name}.png has {png_len} bytes");
}
