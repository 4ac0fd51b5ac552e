//! The guard rail of `monitor` and `report`: a model watches data at the step it was fitted on.
//!
//! Features (the central-difference accelerations), the healthy residual scales and the
//! per-trip calibration all hold at one aligned step only; the same drive seen at 2 s instead
//! of 1 s gives other accelerations and, within days, a false advisory. So the step is taken
//! from the model, an explicit `--step` that differs is refused, and so is aligned input
//! written at another step (it would be re-stepped by interpolation). A model written before
//! the step was recorded is accepted at `--step` (1 s by default), with a note.

use liftwatch::fit::FittedModel;
use liftwatch::ingest::IngestReport;

/// Two steps are the same when they differ by less than this share of the model's: the
/// tolerance alignment itself uses for a uniform series.
const STEP_TOLERANCE: f64 = 1e-3;

/// The default step of models that do not record theirs, and of `fit` on raw input (s):
/// alignment's default.
pub const DEFAULT_STEP_S: f64 = 1.0;

/// Whether step `a` is another than `b`, beyond [`STEP_TOLERANCE`] of `b`.
pub fn differs(a: f64, b: f64) -> bool {
    (a - b).abs() > STEP_TOLERANCE * b
}

/// The step an aligned input was written at, as its rows come (a file written newest first
/// shows −1 s, and alignment sorts it); `None` for raw input and rows all at one time.
pub fn input_step(report: &IngestReport) -> Option<f64> {
    let found = report.input_step_s.abs();
    (found.is_finite() && found > 0.0).then_some(found)
}

/// The step to align at: the model's; `--step` only when it agrees (or the model is old).
/// The note for an old model is returned for the caller to print.
///
/// # Errors
/// `--step` differing from the model's step, in one line naming both.
pub fn model_step(model: &FittedModel, flag: Option<f64>) -> anyhow::Result<(f64, Option<String>)> {
    match (model.step_s, flag) {
        (Some(m), Some(f)) if differs(f, m) => anyhow::bail!(
            "--step {f} s differs from the model's step of {m} s: a model watches data at the step it was fitted on (refit at {f} s, or leave out --step)"
        ),
        (Some(m), _) => Ok((m, None)),
        (None, f) => {
            let step = f.unwrap_or(DEFAULT_STEP_S);
            Ok((
                step,
                Some(format!(
                    "note: the model does not record the step it was fitted on (written by an older build); watching at {step} s, which must be its step"
                )),
            ))
        }
    }
}

/// Refuses aligned input written at another step than `step`.
///
/// # Errors
/// One line naming both steps.
pub fn check_input_step(step: f64, report: &IngestReport, input: &str) -> anyhow::Result<()> {
    if let Some(found) = input_step(report).filter(|&f| differs(f, step)) {
        anyhow::bail!(
            "{input}: aligned at a step of {found} s, the model's step is {step} s: align the raw log at {step} s or refit at {found} s"
        );
    }
    Ok(())
}
