//! The whole identification, stages 3-7 calibrated from one healthy history (paper, Sec. 3-4):
//! `fit()` turns an aligned history into the one artefact every later use reads, [`FittedModel`].
//!
//! ```text
//! aligned series ─ features (load-cell gain fitted here) ─ hybrid model θ, net, σ   (stage 4)
//!                ─ baseline limits from the healthy instantaneous signals       (Sec. 5.4)
//!                ─ per-trip evidence ─ calibrated risk thresholds, sensor limits (stages 6-7)
//! ```
//!
//! The artefact sits after every stage it configures, so no stage imports it: residuals take a
//! [`HybridModel`], the risk stage a [`RiskConfig`], the baseline its [`BaselineLimits`]. Its
//! file form (DATA.md §5) is [`crate::file`].

use crate::baseline::BaselineLimits;
use crate::calibrate::{
    calibrate, fit_error_along_signatures, winding_time_constant, CalibrationReport,
    CalibrationSettings, ENOUGH_TRAINING_DAYS, ENOUGH_TRAINING_HOURS,
};
use crate::elevator::Elevator;
use crate::error::Result;
use crate::features::{FeatureConfig, Trip};
use crate::model::train::{self, TrainPoint, TrainingRows};
use crate::model::{FitSummary, HybridModel, PhysParams, TrainConfig};
use crate::operation::{OperationReference, Silence};
use crate::risk::{evidence_predictions, trip_evidence_from, RiskConfig, TripEvidence, N_MODES};
use crate::sample::{pass, History, HOUR_S};
use crate::sensor::SensorLimits;

/// Everything `monitor` needs, as written by `fit` (DATA.md §5). Its JSON form, the model
/// file, is defined in [`crate::file`].
#[derive(Clone, Debug, PartialEq)]
pub struct FittedModel {
    /// The hybrid model: elevator, θ, network and healthy residual scales.
    pub hybrid: HybridModel,
    /// Feature settings, including the load-cell gain fitted on the training data.
    pub features: FeatureConfig,
    /// Risk settings, calibrated on the healthy residuals of the fit.
    pub risk: RiskConfig,
    /// Sensor plausibility limits.
    pub sensor: SensorLimits,
    /// Limits of the conventional fixed-threshold method.
    pub baseline: BaselineLimits,
    /// How the risk thresholds were set; `None` for uncalibrated defaults.
    pub calibration: Option<CalibrationReport>,
    /// The settings the model was trained with.
    pub train: TrainConfig,
    /// Standard errors, training history and warnings of the fit.
    pub summary: FitSummary,
    /// Δ: the aligned step the model was fitted on (s). Features, residual scales and the
    /// per-trip calibration hold only at this step; `None` in models written before it was
    /// recorded.
    pub step_s: Option<f64>,
    /// Trip rate per hour of the week, landings and the doors' healthy reference, for
    /// outages, availability and the door check ([`crate::operation`]); `None` in models
    /// written before they were learnt.
    pub operation: Option<OperationReference>,
    /// The document the model was read from, for its identity ([`crate::file::model_id`]);
    /// empty for a model made in memory.
    pub read_from: ReadFrom,
}

/// The identity of the model document a model was read from, and the hash of the model as it
/// was read: a model keeps the identity of its file for as long as it is unchanged, even where
/// a later build writes the same model otherwise (a field it added, a default it fills in). It
/// is provenance, not content: two models that differ only in it are equal.
#[derive(Clone, Debug, Default)]
pub struct ReadFrom(pub(crate) Option<(u64, u64)>);

impl PartialEq for ReadFrom {
    fn eq(&self, _: &ReadFrom) -> bool {
        true
    }
}

/// Everything `fit` produces: the model, and the intermediate results a report shows.
#[derive(Clone, Debug)]
pub struct FitOutcome {
    /// The fitted, calibrated model.
    pub model: FittedModel,
    /// The complete trips of the training data (with the fitted load-cell gain); its rows are
    /// [`crate::features::extract`]'s with `model.features`.
    pub trips: Vec<Trip>,
    /// Per-trip evidence of the training data, on which the risk was calibrated.
    pub healthy_trips: Vec<TripEvidence>,
}

/// Margin of the fixed-threshold baseline above the healthy extremes (fraction).
pub const BASELINE_MARGIN: f64 = 0.5;

/// The whole identification of a healthy `history` (read in a few passes, [`History`]):
/// features (with the load-cell gain fitted on this history),
/// the hybrid model, healthy residual scales, the baseline's limits and the calibration of the
/// risk thresholds on the healthy trips.
///
/// `observer` sees each logged training point (progress, plots).
///
/// # Errors
/// [`Error::TooLittleMotion`](crate::Error::TooLittleMotion) and
/// [`Error::Unidentifiable`](crate::Error::Unidentifiable) when the data cannot determine the
/// model or calibrate the risk; [`Error::InvalidConfig`](crate::Error::InvalidConfig) for bad
/// settings; what `history` fails with when it is read ([`History::read`]).
pub fn fit(
    history: &dyn History,
    elevator: &Elevator,
    cfg: &TrainConfig,
    observer: &mut dyn FnMut(&TrainPoint),
) -> Result<FitOutcome> {
    fit_with(
        history,
        elevator,
        cfg,
        &CalibrationSettings::default(),
        observer,
    )
}

/// [`fit`] with the calibration's settings given, e.g. another target of false advisories
/// per year ([`CalibrationSettings::for_target`]).
///
/// # Errors
/// As [`fit`], and [`Error::InvalidConfig`](crate::Error::InvalidConfig) for a target that is
/// not a positive number.
pub fn fit_with(
    history: &dyn History,
    elevator: &Elevator,
    cfg: &TrainConfig,
    calibration: &CalibrationSettings,
    observer: &mut dyn FnMut(&TrainPoint),
) -> Result<FitOutcome> {
    calibration.validate()?;
    let feature_cfg =
        crate::features::fit_load_cell(history, &FeatureConfig::for_elevator(elevator))?;
    // The rows are kept as the passes below read them (TrainingRows), never all of them whole:
    // a week of them took twice the memory of the series they came from.
    let mut trips = Vec::new();
    let rows = pass(history, |samples| {
        TrainingRows::from_rows(
            crate::features::rows(samples, &feature_cfg).map(|(row, trip)| {
                trips.extend(trip);
                row
            }),
        )
    })?;
    let prior = PhysParams::prior_centre(elevator);
    let observed = train::observations_of(
        &rows,
        elevator.floors,
        cfg.standstill_share,
        prior.ke,
        train::INTERPOLATION_NOISE_SHARE * elevator.rated_voltage(),
    )?;
    let trained = train::train(&observed, elevator, cfg, observer)?;
    let mut summary = trained.summary;
    summary.standstill_samples = observed.standstill;
    if observed.drive_off_at_rest {
        summary.warnings.push(format!(
            "the drive is off at standstill (median {:.2} V between trips): U0 comes from the moving intercept, which it shares with friction F_c, so the two are split by their priors",
            observed.rest_voltage_v
        ));
    }
    // A friction drift's per cent is of F_c + c·v_r as the fit split them
    // (crate::risk::DriftScale); where the prior made that split, the newtons are the figure
    // the data stand behind (a 1275 kg car with its drive off at rest: a base of 1,625 N
    // against a true 345 N, so +4.6 % stood for a true +12.5 %, its 75 ± 35 N for a true 43).
    let guessed: Vec<&str> = summary
        .parameters
        .iter()
        .filter(|p| !p.determined && (p.name == "f_c" || p.name == "c_visc"))
        .map(|p| p.name.as_str())
        .collect();
    if !guessed.is_empty() {
        summary.warnings.push(format!(
            "friction drifts in per cent (friction_drift_pct) are of F_c + c·v at the rated speed, and {} came mostly from the prior: read a friction change in newtons (the events' friction_drift_n)",
            guessed.join(" and ")
        ));
    }
    // What the observations hold (a copy of the moving rows' inputs) goes before the passes.
    drop(observed);
    let hybrid = HybridModel {
        elevator: elevator.clone(),
        parameters: trained.parameters,
        net: trained.net,
        scales: trained.scales,
    };
    let baseline = BaselineLimits::calibrate(&hybrid, &rows.moving, BASELINE_MARGIN)?;
    if baseline.measured_percentile < 0.999 {
        summary.warnings.push(format!(
            "the threshold baseline's 99.9th percentiles are extrapolated from the {:.1}th: the training has too few moving samples to measure them",
            100.0 * baseline.measured_percentile
        ));
    }
    // Each time constant the winding's search tries is a pass over the rows; the network's
    // predictions, the same in every pass, are made once. Rows at rest hold no evidence, no
    // baseline signal and no signature.
    let predictions = evidence_predictions(&hybrid, &rows.moving);
    let (tau_s, healthy_trips) =
        winding_time_constant(&mut |tau| trip_evidence_from(&hybrid, &rows, tau, &predictions));
    drop(predictions);
    let fit_error = trained.covariance.as_ref().map_or([0.0; N_MODES], |cov| {
        fit_error_along_signatures(&hybrid, &rows.moving, cov)
    });
    drop(rows);
    let mut calibrated = calibrate(&healthy_trips, tau_s, &fit_error, calibration)?;
    let thr = feature_cfg.moving_threshold_mps;
    pass(history, |samples| {
        calibrated.sensor.calibrate_load_zero(samples, thr)
    })?;
    let rated_voltage_v = hybrid
        .parameters
        .voltage(1, hybrid.elevator.rated_speed_mps, 0.0);
    pass(history, |samples| {
        calibrated
            .sensor
            .calibrate_rest_voltage(samples, thr, rated_voltage_v);
    })?;
    summary
        .warnings
        .extend(short_training_notes(&calibrated.report, &calibrated.risk));
    let learnt = OperationReference::learn(
        history,
        &trips,
        feature_cfg.moving_threshold_mps,
        elevator.floors as usize,
        calibration.target_false_advisories_per_year,
    )?;
    summary
        .warnings
        .extend(training_outage_note(&learnt.outages));
    let operation = learnt.reference;
    let model = FittedModel {
        hybrid,
        features: feature_cfg,
        risk: calibrated.risk,
        sensor: calibrated.sensor,
        baseline,
        calibration: Some(calibrated.report),
        train: cfg.clone(),
        summary,
        step_s: Some(history.step_s()),
        operation: Some(operation),
        read_from: ReadFrom::default(),
    };
    Ok(FitOutcome {
        model,
        trips,
        healthy_trips,
    })
}

/// What a training shorter than [`ENOUGH_TRAINING_HOURS`] (a week's log) cannot promise, in
/// two lines (three when it could not see the day's temperature cycle); none for a long
/// enough one.
fn short_training_notes(report: &CalibrationReport, risk: &RiskConfig) -> Vec<String> {
    if report.hours >= ENOUGH_TRAINING_HOURS {
        return Vec::new();
    }
    let days = report.hours / 24.0;
    let mut notes = vec![format!(
        "short training: {:.1} h ({} healthy trips) of the {ENOUGH_TRAINING_DAYS:.0} days the calibration needs; its bootstrap resamples {}, so the advisory threshold (R {:.1}) is only as wide as these hours' own wander and its 95 % bound",
        report.hours,
        report.trips,
        if days < 1.0 { "less than one day".to_string() } else { format!("{days:.1} days") },
        risk.advisory,
    )];
    if report.unseen_ambient_swing > 0.0 {
        notes.push(format!(
            "too short to see the day's temperature cycle: the thresholds allow for one of ±{:.1} % of Kd at a phase it could not measure, so a motor change is decided later than a longer training would",
            100.0 * report.unseen_ambient_swing
        ));
    }
    notes.push(format!(
        "it cannot promise its alarm budget of {} per elevator-year: days unlike these (weekends, runs of days that sit at another level, other seasons' temperatures, other traffic) were never seen; refit on {ENOUGH_TRAINING_DAYS:.0} days or more of healthy data",
        report.target_text()
    ));
    notes
}

/// The training's own outages, in one line: they are left out of the silences that set how
/// long a silence may last, and the owner should know the training held them.
fn training_outage_note(outages: &[Silence]) -> Option<String> {
    let longest = outages
        .iter()
        .max_by(|a, b| (a.end - a.start).total_cmp(&(b.end - b.start)))?;
    let when = crate::ingest::time::instant_text(longest.start);
    Some(format!(
        "the training holds {} silence{} that its other silences call an outage (the longest {:.1} h from {when}): left out of the silences that say how long this car may stand idle, so a silence as long is reported as an outage",
        outages.len(),
        if outages.len() == 1 { "" } else { "s" },
        (longest.end - longest.start) / HOUR_S,
    ))
}

impl FittedModel {
    /// A model of `hybrid` with uncalibrated default settings of every later stage: for tests
    /// and benchmarks that exercise the pipeline without a fit.
    pub fn uncalibrated(hybrid: HybridModel, features: FeatureConfig) -> FittedModel {
        FittedModel {
            hybrid,
            features,
            risk: RiskConfig::default(),
            sensor: SensorLimits::default(),
            baseline: BaselineLimits::default(),
            calibration: None,
            train: TrainConfig::default(),
            summary: FitSummary::default(),
            step_s: None,
            operation: None,
            read_from: ReadFrom::default(),
        }
    }
}
