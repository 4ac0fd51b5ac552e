//! Integration tests of the pipeline, one module per stage.
mod align;
mod drive;
mod evaluate;
mod features;
mod forecast;
mod layers;
mod monitor;
mod operation;
mod paper;
mod sim;
mod tester;

use std::path::PathBuf;

use liftwatch::fit::{fit, FitOutcome};
use liftwatch::model::TrainConfig;
use liftwatch::{AlignedSeries, Elevator, Sample};

/// The default fit of 1 Hz `samples` of `e`, without progress lines; `what` names the data
/// in the panic of a fit that fails.
pub(crate) fn fitted(samples: Vec<Sample>, e: &Elevator, what: &str) -> FitOutcome {
    let series = AlignedSeries {
        step_s: 1.0,
        samples,
    };
    let cfg = TrainConfig {
        log_every: 0,
        ..TrainConfig::default()
    };
    fit(&series, e, &cfg, &mut |_| {}).unwrap_or_else(|err| panic!("{what} fit: {err}"))
}

/// A fresh directory for one test, removed at the end.
pub(crate) struct Dir(pub(crate) PathBuf);

impl Dir {
    pub(crate) fn new(name: &str) -> Dir {
        let dir =
            std::env::temp_dir().join(format!("liftwatch-pipeline-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("temp dir is writable");
        Dir(dir)
    }
}

impl Drop for Dir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}
