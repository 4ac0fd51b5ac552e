//! Calibration of the risk stage on healthy trips: spreads, the healthy reference of the
//! re-identification, boundaries τ and the advisory/alarm thresholds at a stated false-alarm
//! rate (paper, Sec. 4.2; the paper gives no rule for its thresholds).
//!
//! ```text
//! var(mean e over a trip of n samples) = a + b/n          least squares on squared trip means
//! θ0, σ_θ = mean, sd of the re-identified coefficients after warm-up;  k = min(1, σ_θ/SE)
//! τ = μ_c + 3·σ_c of the healthy c = ln(1 + e_trip),  floored at ln 3
//! advisory = max R over `years` of a moving-block bootstrap of the healthy trips (blocks of a day)
//! alarm    = max(alarm_factor·advisory, steady R of a persistent z = alarm_z deviation)
//! heating:  β_k from r_U ≈ Σ θ_m·x_m + Σ β_k·x_heat,k on the healthy trips (risk::evidence),
//!           the winding's τ by profile least squares over candidates (winding_time_constant);
//!           kept when its Wald χ² ≥ HEATING_WALD, and taken out of every trip before the
//!           steps below with the levels θ_h = θ of that regression, the signatures scaled
//!           to the winding's present Kd (risk::evidence)
//! sequential: θ0, s², info pooled over the healthy trips (risk::sequential)
//!   h_mj = max(max G_mj over the same bootstrap years, ln(9·trips per year / target))
//! ```
//!
//! The floor of h is the CUSUM's own bound: with i.i.d. healthy increments a CUSUM at
//! threshold h signals falsely at most once per e^h trips on average (Lorden), so nine of them
//! at ln(9·N/target) give at most `target` false signals in a year of N trips. The bootstrap
//! maximum raises h where the healthy trips are not independent (the thermal cycle, the
//! traffic of a day), as far as the training shows it: a 3-day training shows three days of
//! that wander, so its thresholds are only as honest as three days are typical.
//!
//! A second, independent bootstrap counts the false advisories per year with the final
//! thresholds and the hysteresis of [`crate::alarm`]; the figure is kept in the model file
//! ([`CalibrationReport`]) so the thresholds can be audited.

// Per-mode arrays read best with explicit indices.
#![allow(clippy::needless_range_loop)]

use crate::sample::{DAY_S, HOUR_S, YEAR_S};
use serde::{Deserialize, Serialize};

use crate::alarm::{AlarmState, Level};
use crate::error::{Error, Result};
use crate::features::FeatureRow;
use crate::linalg::SquareMatrix;
use crate::mode::{FaultMode, N_MODES};
use crate::model::physics::{PhysParams, N_PHYS};
use crate::model::train::{interpolation_weight_of, INTERPOLATION_NOISE_SHARE};
use crate::model::HybridModel;
use crate::residual::PredictionCache;
use crate::risk::sequential::{GLR_LENGTHS, N_SIZES};
use crate::risk::{
    excess, friction_reference, signature, unpack, PreparedTrip, RiskConfig, RiskTracker, Rls,
    SequentialConfig, TripEvidence, Winding, HEAT_LAG, MAX_HEATING, MAX_WINDING_TAU_S,
    MIN_WINDING_TAU_S, N_HEAT, PACKED_DIAG,
};
use crate::rng::{moving_blocks, BlockStart, Rng};
use crate::sensor::SensorLimits;
use crate::stats::{chi_square_quantile, robust_sigma};

/// Independent forgetting windows of healthy trips needed before the standard errors of the
/// re-identification are widened to the healthy spread (with the default memory of 3000
/// trips, a busy week gives about one and a half, so the nominal errors stand).
const MIN_WINDOWS: f64 = 5.0;

/// Days of healthy data a calibration needs to keep its promise: the bootstrap draws whole
/// days, and a week holds every kind of day an elevator has (weekdays, a weekend, the daily
/// thermal cycle of the winding each time). Shorter trainings are calibrated, and `fit` says
/// what they cannot promise.
pub const ENOUGH_TRAINING_DAYS: f64 = 7.0;

/// The same in hours as a training report counts them, from the first to the last healthy
/// trip: a week's log measures a few hours less than 168 (no trips at night at its ends), so a
/// week is 160 h or more.
pub const ENOUGH_TRAINING_HOURS: f64 = 160.0;

/// The winding's temperature response is taken out of the evidence only when the training
/// shows it: the Wald statistic βᵀ·V⁻¹·β of its coefficients at least the χ² of their degrees
/// of freedom (1, 2, 3) at p = 0.0027 (three standard errors of one), so a training whose
/// traffic hardly varies (a few hours, one kind of hour) does not subtract coefficients it
/// cannot know from every later trip.
pub const HEATING_WALD: [f64; N_HEAT] = [9.0, 11.83, 14.16];

/// Shortest span of healthy trips on which the daily ambient harmonic is identified (s): two
/// days, so that the cycle repeats and is told from one day's traffic.
pub const AMBIENT_MIN_SPAN_S: f64 = 2.0 * DAY_S;

/// Half the peak-to-peak daily swing of Kd that a training too short to identify the ambient
/// cycle ([`AMBIENT_MIN_SPAN_S`]) cannot see, relative: a machine room's day of ±4 K at
/// copper's 0.39 %/K (MODEL.md puts the whole thermal range, ambient and self-heating, at
/// 10-20 %). The paper's 3 hours of a morning know nothing of the afternoon: its thresholds
/// are set as if each drawn day of the bootstrap sat at another, unknown phase of such a cycle
/// (`HourWander`). Measured on the evaluation with 3-hour trainings (07:00-10:00): all 60
/// false advisories in 1.7 elevator-years were the motor's, at +1.2 to +1.9 % of Kd, most of
/// them at 13:30 and 18:00.
pub const UNSEEN_AMBIENT_SWING: f64 = 0.0156;

/// Candidate winding time constants (s): 5 min to 8 h ([`MIN_WINDING_TAU_S`],
/// [`MAX_WINDING_TAU_S`]) in steps of about 1.4, each a pass of the training's rows; a
/// parabolic step in ln τ refines the best. A machine's winding lies at 30-60 min (MODEL.md),
/// but the search does not assume it: with a fixed basis (lags of 20 and 90 min) the busy
/// morning's heating of a 43-min winding was under-predicted by a quarter of a trip's noise,
/// enough for false motor advisories at 09:00 after a 3-day training.
pub const WINDING_TAU_CANDIDATES_S: [f64; 14] = [
    300.0, 420.0, 600.0, 840.0, 1200.0, 1680.0, 2400.0, 3360.0, 4800.0, 6720.0, 9600.0, 13_440.0,
    19_200.0, 28_800.0,
];

/// Fewest usable healthy trips a calibration accepts.
const MIN_HEALTHY_TRIPS: usize = 30;

/// The motor's index among the signatures.
const MOTOR_MODE: usize = FaultMode::Motor as usize;

/// Fewest trips of an hour that [`HourWander`] measures a level on: a busy hour has 40-150,
/// a quiet one a handful, whose level is mostly its own noise (that noise is subtracted, but
/// it would dominate the estimate).
const HOUR_MIN_TRIPS: usize = 10;

/// Confidence with which the bootstrap's hour wander covers the wander of the hours to come:
/// Ω is measured on the training's few dozen hours, and the thresholds are set with the upper
/// 95 % bound of what that many hours allow ([`HourWander`]): the fewer and the noisier the
/// hours, the farther beyond the measured wander the new ones are drawn, and a training
/// that measured none still draws some.
const HOUR_WANDER_CONFIDENCE: f64 = 0.95;

/// Fewest degrees of freedom the bound of the hour wander takes: below three the
/// Wilson-Hilferty χ² quantile falls apart (at ν = 2 it is 23 % low, at ν = 1.04 four
/// thousand times), and a bound from fewer than three hours' worth of levels is no bound.
const MIN_BOUND_DOF: f64 = 3.0;

/// What the calibration did, kept in the model file so the thresholds can be audited.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CalibrationReport {
    /// Healthy trips used.
    pub trips: usize,
    /// Hours of healthy data they span.
    pub hours: f64,
    /// Trips per year at the healthy trip rate.
    pub trips_per_year: f64,
    /// Years of healthy operation simulated by the bootstrap.
    pub years_simulated: f64,
    /// Length of a bootstrap block (s).
    pub block_s: f64,
    /// Seed of the bootstrap.
    pub seed: u64,
    /// The stated target: false advisories per elevator-year.
    pub target_false_advisories_per_year: f64,
    /// False advisories per year in an independent bootstrap run with the chosen thresholds.
    pub validated_false_advisories_per_year: f64,
    /// sd of the hour-to-hour level of each signature coefficient (motor, brake, friction)
    /// as the training measured it (`HourWander`); 0 in models calibrated before it was
    /// measured.
    #[serde(default)]
    pub hour_wander: [f64; N_MODES],
    /// sd of the hour-to-hour level the bootstrap draws new hours from, per signature: the
    /// upper `HOUR_WANDER_CONFIDENCE` bound of [`CalibrationReport::hour_wander`] given
    /// the hours it was measured on (`HourWander`); 0 when no hours were measured (fewer
    /// than three) and in models calibrated before it was kept.
    #[serde(default)]
    pub hour_wander_drawn: [f64; N_MODES],
    /// The daily swing of Kd the thresholds allow for because the training could not measure
    /// it ([`UNSEEN_AMBIENT_SWING`] when it spans less than [`AMBIENT_MIN_SPAN_S`], else 0;
    /// relative).
    #[serde(default)]
    pub unseen_ambient_swing: f64,
    /// The fitted parameters' error as each signature's level shows it
    /// ([`fit_error_along_signatures`], coefficient units): part of θ0's error as a new
    /// day's level ([`SequentialConfig::reference_se`]); 0 in models calibrated before it
    /// was measured.
    #[serde(default)]
    pub fit_error: [f64; N_MODES],
}

impl CalibrationReport {
    /// The stated target in words, its noun agreeing with the number: "1 false advisory",
    /// "0.5 false advisories".
    pub fn target_text(&self) -> String {
        let n = self.target_false_advisories_per_year;
        let noun = if n == 1.0 { "advisory" } else { "advisories" };
        format!("{n} false {noun}")
    }
}

/// Settings of [`calibrate`].
#[derive(Clone, Debug, PartialEq)]
pub struct CalibrationSettings {
    /// Years of healthy operation the bootstrap simulates; the advisory threshold is the
    /// highest risk reached in them, i.e. the level exceeded once in this many years.
    pub years: f64,
    /// Length of a bootstrap block (s). A day keeps the daily thermal cycle of the winding
    /// resistance whole: with blocks of a few hours the bootstrap chains afternoons (warm
    /// winding, Kd up) into "weeks" no real elevator sees and sets the thresholds far too high.
    pub block_s: f64,
    /// Seed of the bootstrap.
    pub seed: u64,
    /// Stated target of false advisories per elevator-year; calibration fails its own check
    /// (and says so in the report) when the validation run exceeds it.
    pub target_false_advisories_per_year: f64,
    /// Alarm threshold, at least this multiple of the advisory threshold.
    pub alarm_factor: f64,
    /// Alarm threshold, at least the risk a deviation of this many healthy spreads (z) reaches
    /// when it persists: alarm means a large deviation, not only a long one.
    pub alarm_z: f64,
}

impl Default for CalibrationSettings {
    fn default() -> Self {
        CalibrationSettings {
            years: 10.0,
            block_s: DAY_S,
            seed: 1,
            target_false_advisories_per_year: 1.0,
            alarm_factor: 4.0,
            alarm_z: 5.0,
        }
    }
}

/// The advisory's bootstrap spans this many times the years in which the target allows one
/// false advisory: 10 years at the default target of one a year, the margin [`calibrate`]
/// describes.
pub const YEARS_PER_ALLOWED_ADVISORY: f64 = 10.0;

/// Fewest and most years a bootstrap simulates, whatever the target: below a year the
/// maximum is no longer a yearly figure, above a century the fit takes minutes.
const BOOTSTRAP_YEARS: (f64, f64) = (1.0, 100.0);

impl CalibrationSettings {
    /// The settings for a user's alarm budget: `per_year` false advisories per
    /// elevator-year. The Lorden floor of the sequential thresholds takes the target as it is;
    /// the bootstrap of R spans [`YEARS_PER_ALLOWED_ADVISORY`]/`per_year` years (1 to 100), so
    /// its maximum keeps the same margin on the target.
    pub fn for_target(per_year: f64) -> CalibrationSettings {
        let years =
            (YEARS_PER_ALLOWED_ADVISORY / per_year).clamp(BOOTSTRAP_YEARS.0, BOOTSTRAP_YEARS.1);
        CalibrationSettings {
            target_false_advisories_per_year: per_year,
            years: if years.is_finite() {
                years
            } else {
                BOOTSTRAP_YEARS.1
            },
            ..CalibrationSettings::default()
        }
    }

    /// Checks the settings.
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] naming the first setting out of range.
    pub fn validate(&self) -> Result<()> {
        let check = |field, v: f64, lo: f64, hi: f64| {
            if v.is_finite() && (lo..=hi).contains(&v) {
                Ok(())
            } else {
                Err(Error::InvalidConfig {
                    field,
                    why: format!("{v} is outside {lo} to {hi}"),
                })
            }
        };
        check(
            "false_advisories_per_year",
            self.target_false_advisories_per_year,
            0.001,
            1000.0,
        )?;
        check("years", self.years, 0.1, 1000.0)?;
        check("block_s", self.block_s, 60.0, 30.0 * DAY_S)
    }
}

/// What [`calibrate`] sets: the risk settings, the sensor limits that depend on the healthy
/// trips (the longest plausible trip), and the audit of how it was done.
#[derive(Clone, Debug, PartialEq)]
pub struct Calibration {
    /// The calibrated risk settings.
    pub risk: RiskConfig,
    /// Sensor limits with the healthy trip durations taken into account.
    pub sensor: SensorLimits,
    /// How the thresholds were set.
    pub report: CalibrationReport,
}

/// Calibrates τ, the healthy spreads and the advisory/alarm thresholds on the healthy trips
/// of the training data, in time order, whose winding-temperature basis has the time
/// constant `tau_s` ([`winding_time_constant`] chooses it).
///
/// Method: (1) the trip spread var(mean e) = a + b/n is fitted by least squares on the
/// squared trip means; (2) the re-identification runs over the healthy trips, giving θ0
/// (mean of the estimates after warm-up), their healthy spread σ (estimation noise plus
/// the thermal drift of the winding resistance) and k = min(1, σ/rms SE);
/// (3) τ = μ_c + 3·σ_c of the healthy c (floored at ln 3: e below 2 is never anomalous);
/// (4) a moving-block bootstrap draws blocks of `block_s` of consecutive healthy trips
/// and runs the whole tracker over `years` of them at the healthy trip rate; the advisory
/// threshold is the highest combined risk it reaches (the level exceeded once in `years`
/// years, so a nominal 1/`years` false advisories per year: a margin for what a
/// bootstrap of a short record cannot show), never below [`RiskConfig::advisory_floor`];
/// the alarm threshold is `alarm_factor` times that, and at least the steady risk of a
/// persistent deviation of `alarm_z` healthy spreads. A second, independent bootstrap run
/// counts the false advisories per year with the final thresholds and hysteresis; the
/// figure is stored in [`CalibrationReport`].
///
/// `fit_error` is the fitted parameters' error as each signature's level shows it
/// ([`fit_error_along_signatures`]; zeros when not known): θ0's error as the level of a new
/// day includes it beside the spread between the training's days.
///
/// # Errors
/// [`Error::Unidentifiable`] with fewer than 30 usable healthy trips, or when they span
/// only one direction of travel.
pub fn calibrate(
    healthy: &[TripEvidence],
    tau_s: f64,
    fit_error: &[f64; N_MODES],
    settings: &CalibrationSettings,
) -> Result<Calibration> {
    let mut cfg = RiskConfig::default();
    let mut sensor = SensorLimits::default();
    let trips: Vec<TripEvidence> = healthy.iter().filter(|t| t.usable(&cfg)).cloned().collect();
    if trips.len() < MIN_HEALTHY_TRIPS {
        return Err(Error::Unidentifiable(format!(
            "risk calibration needs at least {MIN_HEALTHY_TRIPS} healthy trips with {} moving samples, found {}",
            cfg.min_trip_samples,
            trips.len()
        )));
    }
    if !trips.iter().any(|t| t.direction > 0) || !trips.iter().any(|t| t.direction < 0) {
        return Err(Error::Unidentifiable(
            "risk calibration needs healthy trips in both directions".into(),
        ));
    }
    // The heating is identified first and taken out of the trips, as the monitor takes it out
    // of every trip: everything below is calibrated on what is left. Each calendar day has it
    // taken out with the β of the other days, as a new day will: β fitted on a day itself
    // explains that day's own wander, and thresholds bootstrapped from such days were too low
    // for the days after the training.
    let terms = heating_terms(&trips);
    let heating = identify_heating(&trips, terms, 0..0);
    let trips = without_heating_out_of_day(&trips, terms, &heating);
    let longest = trips.iter().map(|t| t.end - t.start).fold(0.0, f64::max);
    sensor.max_trip_s = (2.0 * longest + 20.0).max(sensor.max_trip_s);
    cfg.trip_spread_u = fit_spread(trips.iter().map(|t| (t.mean_e_u, t.n)));
    cfg.trip_spread_f = fit_spread(trips.iter().map(|t| (t.mean_e_f, t.n)));
    calibrate_drift(&mut cfg, &trips);
    calibrate_tau(&mut cfg, &trips);

    let t0 = trips.first().map_or(0.0, |t| t.start);
    let t1 = trips.last().map_or(0.0, |t| t.end);
    let span_s = (t1 - t0).max(HOUR_S);
    let trips_per_year = trips.len() as f64 / span_s * YEAR_S;
    let total = (settings.years.max(0.1) * trips_per_year).ceil() as u64;
    cfg.sequential = SequentialConfig::reference(&trips, f64::INFINITY).map(|mut seq| {
        for m in 0..N_MODES {
            // An error that is not a number is not known: the day spread alone.
            let fit = if fit_error[m].is_finite() {
                fit_error[m]
            } else {
                0.0
            };
            seq.reference_se[m] = seq.reference_se[m].hypot(fit);
        }
        seq
    });
    let mut hours = cfg
        .sequential
        .as_ref()
        .map_or_else(HourWander::none, |seq| HourWander::measure(seq, &trips));
    if cfg.sequential.is_some() && !terms.contains(&(HEAT_LAG + 1)) {
        hours.ambient = UNSEEN_AMBIENT_SWING;
    }
    let mut rng = Rng::new(settings.seed);
    let draws = Draws::new(&cfg, &trips, settings.block_s, total, &hours);
    let (max_r, max_modes, max_g, max_glr) = bootstrap_maxima(&cfg, &draws, &mut rng);
    if let Some(seq) = &mut cfg.sequential {
        // Floors for a bootstrap too short to show the tail: a CUSUM's G exceeds h about
        // once in e^h trips per statistic, a one-sided z² beyond h once in e^(h/2) windows.
        // Statistics per mode: the CUSUMs' sizes and the GLR's window lengths. Not its step
        // window (risk::sequential::STEP_WINDOW_TRIPS): it is weighed only when all eight of
        // its trips are beyond the clip of 3 sd, which healthy Gaussian trips do with a
        // chance of 0.00135⁸ ≈ 10⁻²³, far below the e^(−h/2) each counted window has at the
        // floor; trips with heavier tails are the bootstrap's to show, running the same code.
        let statistics = (N_MODES * (N_SIZES + GLR_LENGTHS.len())) as f64;
        let target = settings.target_false_advisories_per_year.max(1e-3);
        let floor = (statistics * trips_per_year / target).ln().max(1.0);
        for m in 0..N_MODES {
            for j in 0..N_SIZES {
                seq.h[m][j] = max_g[m][j].max(floor);
            }
        }
        seq.glr_h = Some(std::array::from_fn(|m| max_glr[m].max(2.0 * floor)));
    }
    let floor = cfg.advisory_floor();
    cfg.advisory = max_r.max(floor);
    let tau_min = cfg.tau_modes.iter().fold(cfg.tau, |a, &b| a.min(b));
    let persistent = cfg.steady_state(excess(settings.alarm_z.ln_1p(), tau_min));
    cfg.alarm = (settings.alarm_factor.max(1.0) * cfg.advisory).max(persistent);
    for m in 0..N_MODES {
        cfg.advisory_modes[m] = max_modes[m].max(floor);
    }
    // The trips prepared for the first bootstrap serve the second: only thresholds changed.
    let mut rng = Rng::new(settings.seed ^ 0x5EED_CA11_B4A7_E000);
    let episodes = bootstrap_episodes(&cfg, &draws, &mut rng);
    let report = CalibrationReport {
        trips: trips.len(),
        hours: span_s / HOUR_S,
        trips_per_year,
        years_simulated: settings.years,
        block_s: settings.block_s,
        seed: settings.seed,
        target_false_advisories_per_year: settings.target_false_advisories_per_year,
        validated_false_advisories_per_year: episodes as f64 / settings.years.max(0.1),
        hour_wander: hours.measured,
        hour_wander_drawn: hours.drawn(),
        unseen_ambient_swing: hours.ambient,
        fit_error: *fit_error,
    };
    cfg.winding = Winding {
        tau_s: tau_s.clamp(MIN_WINDING_TAU_S, MAX_WINDING_TAU_S),
        beta: heating.beta,
        beta_se: heating.se,
        levels: Some(heating.levels),
    };
    cfg.validate()?;
    Ok(Calibration {
        risk: cfg,
        sensor,
        report,
    })
}

/// The fitted parameters' error as each signature's level shows it on every trip after the
/// training (coefficient units, per mode): what θ0, measured on the training's own residuals,
/// cannot see. A least-squares fit leaves its residuals orthogonal to its parameters'
/// gradients, so along the motor signature (the gradient of Kd, scaled) the training's
/// level is zero whatever Kd's error; a new day's residual carries −J·δθ, δθ the parameters'
/// error, and its level along signature m alone (as the CUSUMs and θ0's day spread read it)
/// −A_m·δθ/W_mm. δθ's covariance is the fit's Gauss-Newton
/// covariance C made robust to residuals that are correlated within an hour (a sandwich
/// with the hours as clusters, as `HourWander` finds the hours' levels wander):
///
/// ```text
/// over the training's moving samples (weights w as in the evidence, signatures x, J = ∂U/∂θ,
/// r = U − U_pred, σ their robust sd):
///   W_mm = Σ w·x_m²,  A = Σ w·x·Jᵀ (3×9),  B_m = A_m/W_mm
///   g_c = Σ over clock hour c of w·J·r,   V = G/(G − 1)·C·(Σ_c g_c·g_cᵀ)·C / σ⁴, G hours
///   var(level_m) = max((B·V·Bᵀ)_mm, (B·C·Bᵀ)_mm)
/// ```
///
/// With independent residuals of variance σ², V is C. Measured on a simulated 40-floor car
/// trained for a week: the motor level of the month that followed sat 0.16 % of Kd above the
/// training's on average (its days spread 0.13 %), where the spread of the training's days
/// allowed θ0 an error of 0.024 % and C alone 0.04 %; the slow CUSUM counted that offset as a
/// change and raised false advisories within days (10 in the evaluation's week-long runs, all
/// on that car). The hours' sandwich puts the error at 0.44 %, and the evaluation's false
/// advisories went to 2, at a slower slow CUSUM: a drift of Kd below about 1 % is not told
/// from the fit's own error by a week of training, and the reported drifts carry the error
/// in their standard errors ([`SequentialConfig::floor_var`]).
pub fn fit_error_along_signatures(
    model: &HybridModel,
    rows: &[FeatureRow],
    cov: &SquareMatrix,
) -> [f64; N_MODES] {
    let none = [0.0; N_MODES];
    let p = &model.parameters;
    let m_r = model.elevator.rated_load_kg;
    let friction = friction_reference(model);
    if cov.n() != N_PHYS {
        return none;
    }
    let noise = INTERPOLATION_NOISE_SHARE * model.elevator.rated_voltage();
    let mut cache = PredictionCache::default();
    let mut w_mm = [0.0; N_MODES];
    let mut a = [[0.0; N_PHYS]; N_MODES];
    let mut meat = SquareMatrix::zeros(N_PHYS);
    let mut g = [0.0; N_PHYS];
    let mut hour = None;
    let mut hours = 0usize;
    let mut residuals = Vec::new();
    for x in rows {
        if x.s == 0 || !crate::residual::applicable(x) || !x.time.is_finite() {
            continue;
        }
        let pred = cache.predict(model, x);
        let r = x.voltage - pred.u_pred;
        let w = interpolation_weight_of(x, p.ke, noise);
        let sig = signature(model, friction, x, pred.f_pred);
        let q = PhysParams::relative_height(x.floor, model.elevator.floors);
        let j = p.du_dtheta(x.s, x.v, x.lambda, x.a, q, m_r);
        if !(r.is_finite() && w.is_finite() && j.iter().chain(&sig).all(|v| v.is_finite())) {
            continue;
        }
        let h = (x.time / HOUR_S).floor();
        if hour.is_some_and(|c| c != h) {
            meat.add_outer(&g, 1.0);
            g = [0.0; N_PHYS];
            hours += 1;
        }
        hour = Some(h);
        residuals.push(r);
        for k in 0..N_PHYS {
            g[k] += w * j[k] * r;
        }
        for m in 0..N_MODES {
            w_mm[m] += w * sig[m] * sig[m];
            for k in 0..N_PHYS {
                a[m][k] += w * sig[m] * j[k];
            }
        }
    }
    if hour.is_some() {
        meat.add_outer(&g, 1.0);
        hours += 1;
    }
    let sigma = robust_sigma(residuals.into_iter());
    if sigma.is_nan() || sigma <= 0.0 || w_mm.iter().any(|w| w.is_nan() || *w <= 0.0) {
        return none;
    }
    // B, B·C, then B·C·Bᵀ (the fit's own covariance) and (B·C)·meat·(B·C)ᵀ/σ⁴ (the
    // hours' sandwich).
    let b: [[f64; N_PHYS]; N_MODES] =
        std::array::from_fn(|m| std::array::from_fn(|i| a[m][i] / w_mm[m]));
    let bc: [[f64; N_PHYS]; N_MODES] = std::array::from_fn(|m| {
        std::array::from_fn(|k| (0..N_PHYS).map(|i| b[m][i] * cov.get(i, k)).sum())
    });
    // The sandwich of G hours is scaled by G/(G − 1) (its clusters' scores sum to zero) and
    // never taken below the fit's own covariance: a training of a few hours has too few
    // clusters to show their correlation, not evidence that there is none.
    let g_factor = if hours > 1 {
        hours as f64 / (hours - 1) as f64
    } else {
        0.0
    };
    std::array::from_fn(|m| {
        let model_based = cov.quad_form(&b[m]);
        let robust = g_factor * meat.quad_form(&bc[m]) / sigma.powi(4);
        let var = model_based.max(robust);
        if var.is_finite() {
            var.max(0.0).sqrt()
        } else {
            0.0
        }
    })
}

/// The winding's temperature response identified on healthy trips ([`identify_heating`]).
#[derive(Clone, Copy, Debug, PartialEq)]
struct HeatingFit {
    /// β per basis term; zero where not identified.
    beta: [f64; N_HEAT],
    /// Standard errors of β.
    se: [f64; N_HEAT],
    /// θ_h, the signatures' levels in the same regression ([`Winding::levels`]); zero where
    /// β is.
    levels: [f64; N_MODES],
    /// Residual sum of squares of the joint regression (V², sum of trip means), whether or
    /// not β passed its test: what the time constant is chosen by.
    rss: f64,
}

/// The basis terms a training can identify: the lag always, the daily ambient harmonic only
/// when the trips span [`AMBIENT_MIN_SPAN_S`] (within a day a harmonic is a slow trend, and
/// one cycle leaves it confounded with the day's traffic).
fn heating_terms(trips: &[TripEvidence]) -> &'static [usize] {
    let span = match (trips.first(), trips.last()) {
        (Some(a), Some(b)) => b.end - a.start,
        _ => 0.0,
    };
    if span >= AMBIENT_MIN_SPAN_S {
        &[HEAT_LAG, HEAT_LAG + 1, HEAT_LAG + 2]
    } else {
        &[HEAT_LAG]
    }
}

/// β of the winding's temperature basis and their standard errors from the healthy trips:
/// least squares of r_U on the three signatures and the basis terms `terms` jointly (trip
/// means, each trip one observation, as the signatures' reference is pooled), with a sandwich
/// covariance Σ_t g_t·g_tᵀ of the trips' scores, which holds for residuals correlated within a
/// trip. β is zero when the training does not show it: a Wald statistic βᵀ·V⁻¹·β below
/// [`HEATING_WALD`] for its degrees of freedom, a coefficient beyond [`MAX_HEATING`], or
/// regressors that are not separable; a steady heating that lowers Kd (a warmer winding never
/// does) leaves the lag out and tries the ambient cycle alone.
/// The trips `skip` are left out (a day whose heating is to be taken out with the others' β).
fn identify_heating(
    trips: &[TripEvidence],
    terms: &[usize],
    skip: std::ops::Range<usize>,
) -> HeatingFit {
    let fit = heating_regression(trips, terms, skip.clone());
    if fit.beta.iter().all(|b| *b == 0.0) && terms.len() > 1 {
        // A lag that lowers Kd is no heating: the ambient cycle may still show alone.
        let ambient: Vec<usize> = terms.iter().copied().filter(|&p| p != HEAT_LAG).collect();
        let alone = heating_regression(trips, &ambient, skip);
        return HeatingFit {
            rss: fit.rss,
            ..alone
        };
    }
    fit
}

/// The regression of [`identify_heating`] on the basis terms `terms`.
fn heating_regression(
    trips: &[TripEvidence],
    terms: &[usize],
    skip: std::ops::Range<usize>,
) -> HeatingFit {
    let used = || trips[..skip.start].iter().chain(&trips[skip.end..]);
    let k = N_MODES + terms.len();
    let mut none = HeatingFit {
        beta: [0.0; N_HEAT],
        se: [0.0; N_HEAT],
        levels: [0.0; N_MODES],
        rss: f64::INFINITY,
    };
    // Row i of the design: the signatures, then the basis terms.
    let design = |t: &TripEvidence| -> (SquareMatrix, Vec<f64>) {
        let mut a = SquareMatrix::zeros(k);
        let mut b = vec![0.0; k];
        let xtx = unpack(&t.xtx);
        for i in 0..N_MODES {
            for j in 0..N_MODES {
                *a.at(i, j) = xtx[i][j];
            }
            b[i] = t.xtr[i];
        }
        for (l, &p) in terms.iter().enumerate() {
            for i in 0..N_MODES {
                *a.at(i, N_MODES + l) = t.thermal.xh[p][i];
                *a.at(N_MODES + l, i) = t.thermal.xh[p][i];
            }
            for (q, &r) in terms.iter().enumerate() {
                *a.at(N_MODES + l, N_MODES + q) = t.thermal.hh[p][r];
            }
            b[N_MODES + l] = t.thermal.hr[p];
        }
        (a, b)
    };
    let mut a = SquareMatrix::zeros(k);
    let mut b = vec![0.0; k];
    let mut rr = 0.0;
    for t in used() {
        let (at, bt) = design(t);
        for i in 0..k {
            for j in 0..k {
                *a.at(i, j) += at.get(i, j);
            }
            b[i] += bt[i];
        }
        rr += t.rr;
    }
    let Some(l) = a.cholesky() else {
        return none;
    };
    let theta = l.cholesky_solve(&b);
    none.rss = rr - theta.iter().zip(&b).map(|(t, b)| t * b).sum::<f64>();
    let inv = l.cholesky_inverse();
    let mut meat = SquareMatrix::zeros(k);
    for t in used() {
        let (at, bt) = design(t);
        let g: Vec<f64> = (0..k)
            .map(|i| bt[i] - (0..k).map(|j| at.get(i, j) * theta[j]).sum::<f64>())
            .collect();
        meat.add_outer(&g, 1.0);
    }
    // V = A⁻¹·M·A⁻¹ on the basis block.
    let nb = terms.len();
    let mut v = SquareMatrix::zeros(nb);
    for p in 0..nb {
        for q in 0..nb {
            let (rp, rq) = (N_MODES + p, N_MODES + q);
            *v.at(p, q) = (0..k)
                .map(|i| {
                    (0..k)
                        .map(|j| inv.get(rp, i) * meat.get(i, j) * inv.get(j, rq))
                        .sum::<f64>()
                })
                .sum();
        }
    }
    let beta: Vec<f64> = theta[N_MODES..].to_vec();
    let Some(vl) = v.cholesky() else {
        return none;
    };
    let wald: f64 = vl
        .cholesky_solve(&beta)
        .iter()
        .zip(&beta)
        .map(|(a, b)| a * b)
        .sum();
    let steady_ok = terms
        .iter()
        .position(|&p| p == HEAT_LAG)
        .map_or(true, |l| beta[l] > 0.0 && beta[l] <= MAX_HEATING);
    let ambient_ok = beta.iter().all(|b| b.abs() <= MAX_HEATING);
    if wald >= HEATING_WALD[nb - 1] && steady_ok && ambient_ok {
        for (l, &p) in terms.iter().enumerate() {
            none.beta[p] = beta[l];
            none.se[p] = v.get(l, l).max(0.0).sqrt();
        }
        none.levels = std::array::from_fn(|m| theta[m]);
    }
    none
}

/// The winding's time constant τ and the healthy trips' evidence at it: the τ of the
/// candidates ([`WINDING_TAU_CANDIDATES_S`], then one parabolic step in ln τ about the best)
/// whose basis leaves the least residual in the joint regression of r_U on the signatures and
/// the winding's temperature, a profile least squares. `evidence` gives the trips for a τ (a
/// pass over the training's rows). A training that does not show its heating keeps the first
/// best, which then carries no β.
pub fn winding_time_constant(
    evidence: &mut dyn FnMut(f64) -> Vec<TripEvidence>,
) -> (f64, Vec<TripEvidence>) {
    let cfg = RiskConfig::default();
    let mut rss_at = |tau: f64| {
        let trips = evidence(tau);
        let usable: Vec<TripEvidence> = trips.iter().filter(|t| t.usable(&cfg)).cloned().collect();
        let rss = identify_heating(&usable, heating_terms(&usable), 0..0).rss;
        (if rss.is_finite() { rss } else { f64::INFINITY }, trips)
    };
    let grid: Vec<(f64, f64)> = WINDING_TAU_CANDIDATES_S
        .iter()
        .map(|&tau| (tau, rss_at(tau).0))
        .collect();
    let best = (0..grid.len())
        .min_by(|&i, &j| grid[i].1.total_cmp(&grid[j].1))
        .unwrap_or(0);
    let mut tau = grid[best].0;
    let (rss, mut trips) = rss_at(tau);
    if best > 0 && best + 1 < grid.len() {
        // The vertex of the parabola through the best and its neighbours, in ln τ.
        let (x0, x1, x2) = (grid[best - 1].0.ln(), tau.ln(), grid[best + 1].0.ln());
        let (y0, y1, y2) = (grid[best - 1].1, grid[best].1, grid[best + 1].1);
        let den = (x1 - x0) * (y1 - y2) - (x1 - x2) * (y1 - y0);
        if den.abs() > 0.0 && [y0, y1, y2].iter().all(|y| y.is_finite()) {
            let x =
                x1 - 0.5 * ((x1 - x0).powi(2) * (y1 - y2) - (x1 - x2).powi(2) * (y1 - y0)) / den;
            let refined = x.clamp(x0, x2).exp();
            let (r, t) = rss_at(refined);
            if r < rss {
                (tau, trips) = (refined, t);
            }
        }
    }
    (tau, trips)
}

/// `trips` with the heating and the healthy levels taken out and the signatures following
/// the winding: each calendar day's heating with β identified on the other days
/// ([`identify_heating`]), a training of one day, or a day whose complement does not show the
/// heating, with `all`'s (the fit of the whole training); the levels θ_h always `all`'s. A
/// day's level measured against the other days' would count the reference's own error twice:
/// the decision adds it as θ0's error ([`SequentialConfig::reference`]), and on 3-day
/// trainings the brake's healthy spread rose by a third and its thresholds by half.
fn without_heating_out_of_day(
    trips: &[TripEvidence],
    terms: &[usize],
    all: &HeatingFit,
) -> Vec<TripEvidence> {
    let day = |t: &TripEvidence| (t.start / DAY_S).floor();
    let mut out = Vec::with_capacity(trips.len());
    let mut i = 0;
    while i < trips.len() {
        let d = day(&trips[i]);
        let end = i + trips[i..].iter().take_while(|t| day(t) == d).count();
        let others = trips.len() - (end - i);
        let fit = if all.beta.iter().all(|b| *b == 0.0) || others < MIN_HEALTHY_TRIPS {
            *all
        } else {
            match identify_heating(trips, terms, i..end) {
                f if f.beta.iter().any(|v| *v != 0.0) => f,
                _ => *all,
            }
        };
        out.extend(
            trips[i..end]
                .iter()
                .map(|t| t.without_heating(&fit.beta, Some(&all.levels))),
        );
        i = end;
    }
    out
}

/// Least-squares fit of mean² ≈ a + b/n with a, b ≥ small positive floors.
fn fit_spread(it: impl Iterator<Item = (f64, u32)>) -> [f64; 2] {
    let (mut s1, mut sx, mut sxx, mut sy, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (m, n) in it {
        if !m.is_finite() || n == 0 {
            continue;
        }
        let (x, y) = (1.0 / f64::from(n), m * m);
        s1 += 1.0;
        sx += x;
        sxx += x * x;
        sy += y;
        sxy += x * y;
    }
    if s1 < 2.0 {
        return RiskConfig::default().trip_spread_u;
    }
    let det = s1 * sxx - sx * sx;
    let mean_y = sy / s1;
    let (a, b) = if det > 1e-12 * s1 * sxx {
        let b = (s1 * sxy - sx * sy) / det;
        ((sy - b * sx) / s1, b)
    } else {
        (mean_y, 0.0)
    };
    // A negative component is an artefact of noise; give its share to the other one.
    match (a > 0.0, b > 0.0) {
        (true, true) => [a, b],
        (true, false) => [mean_y.max(1e-6), 0.0],
        (false, true) => [1e-3 * mean_y.max(1e-6), sy / sx.max(1e-12)],
        (false, false) => [mean_y.max(1e-6), 0.0],
    }
}

/// Floor of the healthy spread of the re-identified coefficients, joint and alone (relative
/// units: 0.5 % of Kd, of friction, of F_c as brake drag): keeps a very clean record from
/// declaring any wander anomalous.
const DRIFT_SD_FLOOR: f64 = 0.005;

/// Step 2 of the calibration: θ0, σ, the prior information and s² from a healthy pass.
fn calibrate_drift(cfg: &mut RiskConfig, trips: &[TripEvidence]) {
    let forget = cfg.forgetting();
    let mut rls = Rls::default();
    let warmup = (cfg.forgetting_trips as usize / 2).min(trips.len() / 3);
    let mut sum = [0.0; N_MODES];
    let mut sum2 = [0.0; N_MODES];
    let mut nominal = [0.0; N_MODES];
    let mut s2_sum = 0.0;
    let mut count = 0.0;
    for (k, t) in trips.iter().enumerate() {
        if k >= warmup {
            if let Some((theta, _)) = rls.estimate(1.0) {
                s2_sum += t.fit_error(&theta);
            }
        }
        rls.update(t, forget);
        if k < warmup {
            continue;
        }
        let Some((theta, var)) = rls.estimate(1.0) else {
            continue;
        };
        count += 1.0;
        for m in 0..N_MODES {
            sum[m] += theta[m];
            sum2[m] += theta[m] * theta[m];
            nominal[m] += var[m];
        }
    }
    if count < 2.0 {
        return;
    }
    cfg.prior_s2 = (s2_sum / count).max(1e-12);
    for m in 0..N_MODES {
        let mean = sum[m] / count;
        let var = (sum2[m] / count - mean * mean).max(0.0);
        cfg.healthy_coef[m] = mean;
        cfg.drift_sd[m] = var.sqrt().max(DRIFT_SD_FLOOR);
        // The variances above used s² = 1; the healthy s² turns them into SE².
        let se2 = cfg.prior_s2 * nominal[m] / count;
        // The spread of θ̂ is known only from many independent forgetting windows; with
        // fewer than MIN_WINDOWS the nominal errors stand unscaled.
        let windows = count / cfg.forgetting_trips;
        // Only ever widened: the in-sample spread of a training week understates new days.
        // Scaling the errors down gave brake advisories on drags of 30 N ± 43 N, inside one
        // standard error, on the evaluation's 630 kg car: with a floor of 0.1, 4-7 false
        // advisories per elevator-year; 0.5, about 5; 1.0, none in 1.6 elevator-years
        // (`liftwatch evaluate`), at the price of later detection of weak ramps.
        cfg.se_scale[m] = if se2 > 0.0 && windows >= MIN_WINDOWS {
            (var / se2).sqrt().clamp(1.0, 5.0)
        } else {
            1.0
        };
    }
    cfg.prior_info = rls.a;
    // The lenses' healthy spread: each signature's level alone in the same memory, measured
    // in a second pass against the θ0 just found.
    let mut rls = Rls::default();
    let (mut sum2, mut n) = ([0.0; N_MODES], [0.0; N_MODES]);
    for (k, t) in trips.iter().enumerate() {
        rls.update(t, forget);
        if k < warmup {
            continue;
        }
        for (m, lens) in rls.alone(&cfg.healthy_coef, 1.0).into_iter().enumerate() {
            if let Some((d, _)) = lens {
                sum2[m] += d * d;
                n[m] += 1.0;
            }
        }
    }
    if n.iter().all(|&n| n >= 2.0) {
        // The root mean square about zero, not about the training's own mean: the lens reads
        // the level against zero, and an offset the training already had is part of its
        // healthy spread.
        cfg.lens_sd = Some(std::array::from_fn(|m| {
            (sum2[m] / n[m]).sqrt().max(DRIFT_SD_FLOOR)
        }));
    }
}

/// Step 3 of the calibration: τ = μ + 3σ of the healthy c, combined and per mode.
fn calibrate_tau(cfg: &mut RiskConfig, trips: &[TripEvidence]) {
    let mut tracker = RiskTracker::new(cfg);
    let mut c = Vec::with_capacity(trips.len());
    let mut cm: [Vec<f64>; N_MODES] = Default::default();
    for t in trips {
        let s = tracker.statistics(cfg, t);
        c.push(s.c);
        for m in 0..N_MODES {
            cm[m].push(s.c_modes[m]);
        }
    }
    let floor = (1.0f64 + 2.0).ln();
    cfg.tau = mean_plus_3sd(&c).max(floor);
    for m in 0..N_MODES {
        cfg.tau_modes[m] = mean_plus_3sd(&cm[m]).max(floor);
    }
}

fn mean_plus_3sd(x: &[f64]) -> f64 {
    let n = x.len().max(1) as f64;
    let mean = x.iter().sum::<f64>() / n;
    let var = x.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n;
    mean + 3.0 * var.sqrt()
}

/// Draws a moving-block bootstrap sequence of `total` trips and hands each to `f`: blocks of
/// `block_s` of consecutive trips starting at any trip ([`moving_blocks`]).
/// The healthy wander of the signature scores between hours of service: each hour of a day
/// sits at its own level, beyond what its trips' noise explains. On a raw log whose channels
/// run on their own clocks, the phase between the speed and voltage readings drifts over
/// hours and days, and with it the interpolation error of each hour's trips (loaded cars in
/// the up-peak most): the same busy hour of two days differed by ±0.6 of a trip's standard
/// error along the motor signature on a simulated 20-floor car, and with exact clocks by
/// ±0.15. A training of a few days shows few such hours, and a bootstrap that only reuses
/// them set thresholds the next busy morning crossed.
///
/// ```text
/// cell c (trips of one clock hour, at least HOUR_MIN_TRIPS), per mode m, one signature alone:
///   y_c,m = Σ score_m / Σ info_m            the hour's level, as each CUSUM sees it
///   V_c[m][n] = s_m·s_n·W_c[m][n]/(W_c[m][m]·W_c[n][n])   its noise, s²_m the trips'
///                                            variance within their hour
/// Ω = Σ n_c·(y_c·y_cᵀ − V_c) / Σ n_c       n_c the hour's trips; diagonal floored at 0,
///                                            correlations within ±0.95
/// bootstrap: each hour of a drawn block is moved by a new level δ ~ N(0, Ω):
///   x_m·r_U += info_m·δ_m
/// ```
///
/// Levels are measured one signature at a time, as the CUSUMs decide: the joint coefficients
/// of an hour of a small car's trips are nearly collinear, and their spread is mostly noise.
/// So the thresholds are set by as many new hours as the bootstrap draws, each at a level of
/// the spread the training measured, not by the training's own few. The training's hours keep
/// their own levels (and its days theirs) under the new ones: the bootstrap's hours wander
/// about √2 times as far as the training's, a margin for what a few days cannot show, paid
/// for in detection delay.
///
/// And Ω itself is known only as well as a few dozen hours tell it, so the bootstrap draws
/// from its upper bound. The trip-weighted mean of y_c² estimates Ω + V̄, a weighted sum of
/// χ²₁ terms whose degrees of freedom ν follow Satterthwaite; the bound on the sum less the
/// noise bounds Ω, so a training whose hours looked calmer than their noise (Ω measured 0)
/// still draws a wander, as wide as its hours' noise leaves possible:
///
/// ```text
/// per mode:  V̄ = Σ n_c·V_c / Σ n_c,   a_c = n_c·(Ω + V_c),   ν = max((Σ a_c)²/Σ a_c², 3)
///            Ω_drawn = max((Ω + V̄)·ν/χ²(1 − HOUR_WANDER_CONFIDENCE; ν) − V̄, Ω)
///            correlations as measured
/// ```
///
/// A training that cannot see the day's ambient cycle ([`UNSEEN_AMBIENT_SWING`]) has each
/// drawn block (consecutive trips from a random start, up to a day: about half of a 3-hour
/// training on average) moved along the motor signature by δ = A·(cos ψ − cos ψ₀), ψ and ψ₀
/// uniform: the block at some phase of a daily cycle of half-swing A, the training at
/// another. ψ₀ is drawn anew with each block, so the false-advisory rate holds on average over
/// the phase the training happened to have; one taken at the cycle's trough sees more.
///
/// Measured on the evaluation's 20-floor car (seed 2): its 3-day training put the motor's
/// hour wander at 0.16 of a trip's standard error, the 30 days after it at 0.22 (0.25 at
/// 08:00, the loaded up-peak), and the morning hours beyond the training's thresholds raised
/// 9 false advisories in 210 days of its runs.
#[derive(Clone, Debug, PartialEq)]
struct HourWander {
    /// Cholesky factor of the Ω the bootstrap draws from, its bound (coefficient units of each
    /// signature alone).
    chol: [[f64; N_MODES]; N_MODES],
    /// sd of the hour levels per mode as the training measured them (coefficient units of
    /// each signature alone; 0 when none).
    measured: [f64; N_MODES],
    /// Half-swing A of the unseen daily cycle of Kd each drawn block sits on (relative; 0
    /// when the training showed the cycle).
    ambient: f64,
}

impl HourWander {
    fn none() -> Self {
        HourWander {
            chol: [[0.0; N_MODES]; N_MODES],
            measured: [0.0; N_MODES],
            ambient: 0.0,
        }
    }

    fn is_zero(&self) -> bool {
        self.ambient == 0.0 && self.chol.iter().flatten().all(|v| *v == 0.0)
    }

    /// A drawn block's place on the unseen daily cycle, against the training's: the motor
    /// level it moves every trip of the block by.
    fn draw_ambient(&self, rng: &mut Rng) -> f64 {
        if self.ambient == 0.0 {
            return 0.0;
        }
        let (psi, psi0) = (
            rng.uniform(0.0, std::f64::consts::TAU),
            rng.uniform(0.0, std::f64::consts::TAU),
        );
        self.ambient * (psi.cos() - psi0.cos())
    }

    /// sd of the hour levels per mode the bootstrap draws, the upper bound of the measured
    /// (coefficient units of each signature alone).
    fn drawn(&self) -> [f64; N_MODES] {
        std::array::from_fn(|m| self.chol[m].iter().map(|l| l * l).sum::<f64>().sqrt())
    }

    fn measure(seq: &SequentialConfig, trips: &[TripEvidence]) -> Self {
        // Cells: runs of consecutive trips within one clock hour.
        let mut ranges = Vec::new();
        let mut i = 0;
        while i < trips.len() {
            let hour = (trips[i].start / HOUR_S).floor();
            let end = i + trips[i..]
                .iter()
                .take_while(|t| (t.start / HOUR_S).floor() == hour)
                .count();
            if end - i >= HOUR_MIN_TRIPS {
                ranges.push(i..end);
            }
            i = end;
        }
        // Per cell: Σ score, Σ x·xᵀ.
        let sums: Vec<([f64; N_MODES], [f64; 6])> = ranges
            .iter()
            .map(|r| {
                trips[r.clone()]
                    .iter()
                    .fold(([0.0; N_MODES], [0.0; 6]), |(mut sc, mut w), t| {
                        let score = seq.trip_score(t);
                        for m in 0..N_MODES {
                            sc[m] += score[m];
                        }
                        for k in 0..6 {
                            w[k] += t.xtx[k];
                        }
                        (sc, w)
                    })
            })
            .collect();
        // The trips' own noise within their hour, per mode (s² pooled over the training
        // counts the hours' levels too).
        let (mut ss, mut si) = ([0.0; N_MODES], [0.0; N_MODES]);
        for (r, (sc, w)) in ranges.iter().zip(&sums) {
            for m in 0..N_MODES {
                let level = sc[m] / w[PACKED_DIAG[m]];
                for t in &trips[r.clone()] {
                    let info = t.xtx[PACKED_DIAG[m]];
                    ss[m] += (seq.trip_score(t)[m] - level * info).powi(2);
                    si[m] += info;
                }
            }
        }
        let s2: [f64; N_MODES] = std::array::from_fn(|m| {
            if si[m] > 0.0 {
                ss[m] / si[m]
            } else {
                seq.s2[m]
            }
        });
        let cells: Vec<(f64, [f64; N_MODES], [[f64; N_MODES]; N_MODES])> = sums
            .iter()
            .zip(&ranges)
            .filter(|((_, w), _)| PACKED_DIAG.iter().all(|&k| w[k] > 0.0))
            .map(|((sc, w), r)| {
                let x = unpack(w);
                let y = std::array::from_fn(|m| sc[m] / x[m][m]);
                let v = std::array::from_fn(|m| {
                    std::array::from_fn(|n| (s2[m] * s2[n]).sqrt() * x[m][n] / (x[m][m] * x[n][n]))
                });
                (r.len() as f64, y, v)
            })
            .collect();
        if cells.len() < 3 {
            return Self::none();
        }
        // Weighted by the hour's trips: a CUSUM gains an hour's level once per trip, so the
        // spread that sets its false alarms is that of the busy hours, where the channels'
        // interpolation errors are largest too (loaded cars up in the morning). Counting
        // every hour alike let the quiet hours' small spread stand for the busy ones': on the
        // evaluation, 12 false advisories with week-long trainings (10 of them the 40-floor
        // car's 09:00) and 8 with 3-day ones; weighted, 3 and 1.
        let n: f64 = cells.iter().map(|c| c.0).sum();
        let mut omega = [[0.0; N_MODES]; N_MODES];
        for (n_c, y, v) in &cells {
            for a in 0..N_MODES {
                for b in 0..N_MODES {
                    omega[a][b] += n_c * (y[a] * y[b] - v[a][b]) / n;
                }
            }
        }
        for a in 0..N_MODES {
            omega[a][a] = omega[a][a].max(0.0);
        }
        let measured: [f64; N_MODES] = std::array::from_fn(|a| omega[a][a].sqrt());
        // The upper bound of each diagonal, the correlations kept.
        let upper: [f64; N_MODES] = std::array::from_fn(|a| {
            let noise = cells.iter().map(|c| c.0 * c.2[a][a]).sum::<f64>() / n;
            let terms = cells.iter().map(|c| c.0 * (omega[a][a] + c.2[a][a]));
            let (sum, squares) = terms.fold((0.0, 0.0), |(s, q), x| (s + x, q + x * x));
            let dof = (sum * sum / squares).max(MIN_BOUND_DOF);
            let total = (omega[a][a] + noise) * dof
                / chi_square_quantile(1.0 - HOUR_WANDER_CONFIDENCE, dof);
            (total - noise).max(omega[a][a])
        });
        if upper.iter().any(|x| !x.is_finite()) {
            return Self::none();
        }
        let scale: [f64; N_MODES] = std::array::from_fn(|k| {
            if omega[k][k] > 0.0 {
                (upper[k] / omega[k][k]).sqrt()
            } else {
                0.0
            }
        });
        for a in 0..N_MODES {
            for b in 0..N_MODES {
                omega[a][b] = if a == b {
                    upper[a]
                } else {
                    omega[a][b] * scale[a] * scale[b]
                };
            }
        }
        for a in 0..N_MODES {
            for b in 0..N_MODES {
                if a != b {
                    let lim = 0.95 * (omega[a][a] * omega[b][b]).sqrt();
                    omega[a][b] = omega[a][b].clamp(-lim, lim);
                }
            }
        }
        if omega.iter().flatten().any(|x| !x.is_finite()) {
            return Self::none();
        }
        // Moments of a few dozen hours need not make a covariance: the correlations are
        // shrunk towards none until they do (a diagonal Ω always does; 200 shrinks take
        // them below 1e-19 of their start).
        // A signature that does not wander (a zero diagonal) gets a negligible ridge, so that
        // the factor of the others exists.
        let ridge = 1e-12 * (0..N_MODES).map(|a| omega[a][a]).fold(0.0, f64::max);
        for _ in 0..200 {
            let mut m = SquareMatrix::zeros(N_MODES);
            for a in 0..N_MODES {
                for b in 0..N_MODES {
                    *m.at(a, b) = omega[a][b] + if a == b { ridge } else { 0.0 };
                }
            }
            if let Some(l) = m.cholesky() {
                let chol = std::array::from_fn(|a| std::array::from_fn(|b| l.get(a, b)));
                return HourWander {
                    chol,
                    measured,
                    ambient: 0.0,
                };
            }
            for a in 0..N_MODES {
                for b in 0..N_MODES {
                    if a != b {
                        omega[a][b] *= 0.8;
                    }
                }
            }
        }
        Self::none()
    }

    /// A new hour's level δ ~ N(0, Ω).
    fn draw(&self, rng: &mut Rng) -> [f64; N_MODES] {
        let z: [f64; N_MODES] = std::array::from_fn(|_| rng.normal());
        std::array::from_fn(|a| (0..=a).map(|b| self.chol[a][b] * z[b]).sum())
    }
}

/// What a bootstrap draws from: the record's trips, each prepared for a tracker of one
/// [`RiskConfig`] ([`PreparedTrip`]: formed once per trip of the record, not per draw, and
/// still valid once the calibration has set the thresholds), the clock hour each began in,
/// and the settings of the draw.
struct Draws<'a> {
    trips: &'a [TripEvidence],
    prepared: Vec<PreparedTrip<'a>>,
    hour_of: Vec<f64>,
    block_s: f64,
    total: u64,
    hours: &'a HourWander,
}

impl<'a> Draws<'a> {
    fn new(
        cfg: &RiskConfig,
        trips: &'a [TripEvidence],
        block_s: f64,
        total: u64,
        hours: &'a HourWander,
    ) -> Self {
        Draws {
            trips,
            prepared: trips.iter().map(|t| PreparedTrip::new(cfg, t)).collect(),
            hour_of: trips.iter().map(|t| (t.start / HOUR_S).floor()).collect(),
            block_s,
            total,
            hours,
        }
    }

    /// A moving-block bootstrap of `total` trips of the record, each handed to `f` prepared,
    /// with the level its hour of service was drawn ([`HourWander`]) when the training
    /// measured any. The whole sequence is fixed by `rng`: a clone of it draws it again.
    fn run(&self, rng: &mut Rng, mut f: impl FnMut(&PreparedTrip, Option<&[f64; N_MODES]>)) {
        let (trips, hours) = (self.trips, self.hours);
        let total = usize::try_from(self.total).unwrap_or(usize::MAX);
        let ends = |first: usize, i: usize| trips[i].start - trips[first].start >= self.block_s;
        let mut draw = rng.fork();
        let mut cell: Option<(usize, f64)> = None;
        let mut offset = [0.0; N_MODES];
        let mut ambient = 0.0;
        moving_blocks(rng, trips.len(), BlockStart::Anywhere, total, ends, |i| {
            if hours.is_zero() {
                f(&self.prepared[i], None);
                return;
            }
            // A new block is a new place on the unseen daily cycle; a new hour of service (or
            // a new block) a new hour's level.
            let new_block = cell.map_or(true, |(j, _)| i != j + 1);
            if new_block {
                ambient = hours.draw_ambient(&mut draw);
            }
            let hour = self.hour_of[i];
            if new_block || cell.is_some_and(|(_, h)| h != hour) {
                offset = hours.draw(&mut draw);
                offset[MOTOR_MODE] += ambient;
            }
            cell = Some((i, hour));
            f(&self.prepared[i], Some(&offset));
        });
    }
}

/// Runs `risk` on this thread and `decision` on a second one, each over the same bootstrap
/// sequence (a clone of `rng` draws it again on the second thread; `rng` ends where one run
/// leaves it). The tracker's two halves share no state
/// ([`RiskTracker::push_risk_levels`]), so the results are the bits of one thread taking
/// both, at about the time of the longer half: the bootstraps were two thirds of a 3-hour
/// `fit`, the decision's CUSUMs and GLR windows the larger half of them.
fn side_by_side<R, D: Send>(
    rng: &mut Rng,
    risk: impl FnOnce(&mut Rng) -> R,
    decision: impl FnOnce(&mut Rng) -> D + Send,
) -> (R, D) {
    let mut again = rng.clone();
    std::thread::scope(|scope| {
        let other = scope.spawn(move || decision(&mut again));
        let r = risk(rng);
        let d = other
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        (r, d)
    })
}

fn bootstrap_maxima(
    cfg: &RiskConfig,
    draws: &Draws,
    rng: &mut Rng,
) -> (
    f64,
    [f64; N_MODES],
    [[f64; N_SIZES]; N_MODES],
    [f64; N_MODES],
) {
    let ((max_r, max_m), (max_g, max_glr)) = side_by_side(
        rng,
        |rng| {
            let mut tracker = RiskTracker::new(cfg);
            let (mut max_r, mut max_m) = (0.0f64, [0.0f64; N_MODES]);
            draws.run(rng, |t, offset| {
                let (r, modes) = tracker.push_risk_levels(cfg, t, offset);
                max_r = max_r.max(r);
                for m in 0..N_MODES {
                    max_m[m] = max_m[m].max(modes[m]);
                }
            });
            (max_r, max_m)
        },
        |rng| {
            let mut tracker = RiskTracker::new(cfg);
            let mut max_g = [[0.0f64; N_SIZES]; N_MODES];
            let mut max_glr = [0.0f64; N_MODES];
            draws.run(rng, |t, offset| {
                tracker.push_decision_levels(cfg, t, offset);
                let g = tracker.cusum_g();
                let z2 = tracker.glr_z2();
                for m in 0..N_MODES {
                    max_glr[m] = max_glr[m].max(z2[m]);
                    for j in 0..N_SIZES {
                        max_g[m][j] = max_g[m][j].max(g[m][j]);
                    }
                }
            });
            (max_g, max_glr)
        },
    );
    (max_r, max_m, max_g, max_glr)
}

/// The decision's ratios of a bootstrap run, handed over in batches of this many trips
/// (64 KiB each) from the thread that forms them to the one that pairs them with R.
const RATIO_BATCH: usize = 8192;

/// Batches of ratios formed and not yet taken: the decision's thread runs at most this far
/// ahead of R's.
const RATIOS_IN_FLIGHT: usize = 4;

/// Advisory episodes (with the hysteresis of [`crate::alarm`]) over a bootstrap run: R on
/// this thread, the decision's ratio on a second, each trip's two paired in order.
fn bootstrap_episodes(cfg: &RiskConfig, draws: &Draws, rng: &mut Rng) -> u64 {
    let (to_risk, ratios) = std::sync::mpsc::sync_channel::<Vec<f64>>(RATIOS_IN_FLIGHT);
    let (episodes, ()) = side_by_side(
        rng,
        // Both closures own their end of the channel: whichever side stops early (a panic)
        // drops it, and the other finds it gone instead of waiting on it.
        move |rng| {
            let mut tracker = RiskTracker::new(cfg);
            let mut alarm = AlarmState::default();
            let mut episodes = 0;
            let mut batch = Vec::new().into_iter();
            draws.run(rng, |t, offset| {
                let (risk, _) = tracker.push_risk_levels(cfg, t, offset);
                let ratio = batch.next().unwrap_or_else(|| {
                    // Both threads draw the same trips, so a batch ends only where another
                    // follows (the decision's thread ended otherwise: a panic, resumed below).
                    batch = ratios.recv().unwrap_or_default().into_iter();
                    batch.next().unwrap_or(f64::NAN)
                });
                let before = alarm.machine_level();
                alarm.update_machine(risk, ratio, cfg);
                if before == Level::Normal && alarm.machine_level() != Level::Normal {
                    episodes += 1;
                }
            });
            episodes
        },
        move |rng| {
            let mut tracker = RiskTracker::new(cfg);
            let mut batch = Vec::with_capacity(RATIO_BATCH);
            let mut receiving = true;
            draws.run(rng, |t, offset| {
                batch.push(tracker.push_decision_levels(cfg, t, offset));
                if batch.len() == RATIO_BATCH && receiving {
                    let full = std::mem::replace(&mut batch, Vec::with_capacity(RATIO_BATCH));
                    receiving = to_risk.send(full).is_ok();
                }
            });
            if receiving && !batch.is_empty() {
                let _ = to_risk.send(batch);
            }
        },
    );
    episodes
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::HybridModel;
    use crate::residual::tests::test_model;
    use crate::risk::tests::{offset_load_trips, synthetic_trips};
    use crate::risk::{TripAssessment, DEFAULT_WINDING_TAU_S};
    use crate::rng::Rng;

    const MOTOR: usize = crate::mode::FaultMode::Motor as usize;
    const BRAKE: usize = crate::mode::FaultMode::Brake as usize;
    const FRICTION: usize = crate::mode::FaultMode::Friction as usize;

    /// No error of the fitted parameters: the synthetic trips' model is the truth.
    const NO_FIT_ERROR: [f64; N_MODES] = [0.0; N_MODES];

    /// Risk settings calibrated on eight synthetic healthy days of `model` (a bootstrap of
    /// five years, for speed).
    pub(crate) fn calibrated(model: &HybridModel) -> Calibration {
        calibrated_with(
            model,
            &CalibrationSettings {
                years: 5.0,
                ..CalibrationSettings::default()
            },
        )
    }

    /// The same with `settings`.
    fn calibrated_with(model: &HybridModel, settings: &CalibrationSettings) -> Calibration {
        let healthy = synthetic_trips(model, 11, 8.0, 0.0, &|_, _| 0.0);
        calibrate(&healthy, DEFAULT_WINDING_TAU_S, &NO_FIT_ERROR, settings)
            .expect("synthetic healthy trips suffice")
    }

    /// The tracker over `trips` as the monitor feeds it (the heating taken out first).
    fn run(cfg: &RiskConfig, trips: &[TripEvidence]) -> Vec<TripAssessment> {
        let mut tr = RiskTracker::new(cfg);
        trips
            .iter()
            .map(|t| tr.push(cfg, &cfg.winding.take_out(t)))
            .collect()
    }

    /// The first trip after `onset` at which the decision holds a change (G/h ≥ 1) and `also`.
    fn first_decided(
        a: &[TripAssessment],
        trips: &[TripEvidence],
        onset: f64,
        also: impl Fn(&crate::risk::Decision) -> bool,
    ) -> Option<usize> {
        a.iter()
            .zip(trips)
            .position(|(a, t)| t.start > onset && a.decision.ratio >= 1.0 && also(&a.decision))
    }

    fn first_advisory(
        cfg: &RiskConfig,
        a: &[TripAssessment],
        trips: &[TripEvidence],
    ) -> Option<f64> {
        a.iter()
            .zip(trips)
            .find(|(a, _)| a.risk >= cfg.advisory)
            .map(|(_, t)| t.start)
    }

    #[test]
    fn the_alarm_budget_reads_in_words_with_its_noun_agreeing() {
        let m = test_model();
        let training = synthetic_trips(&m, 31, 2.0, 0.0, &|_, _| 0.0);
        let settings = CalibrationSettings {
            years: 0.5,
            ..CalibrationSettings::default()
        };
        let mut report = calibrate(&training, DEFAULT_WINDING_TAU_S, &NO_FIT_ERROR, &settings)
            .expect("calibrates")
            .report;
        for (target, words) in [
            (1.0, "1 false advisory"),
            (2.0, "2 false advisories"),
            (0.5, "0.5 false advisories"),
        ] {
            report.target_false_advisories_per_year = target;
            assert_eq!(report.target_text(), words);
        }
    }

    #[test]
    fn each_hour_has_its_own_level_and_the_thresholds_expect_new_ones() {
        // Every clock hour sits at its own Kd level, ±6 % (sd): the calibration of four days
        // measures that wander and sets thresholds that a month of new hours at new levels
        // does not cross (without the new hours in its bootstrap, it crossed at G/h = 1.18).
        let m = test_model();
        let sd = 0.06;
        let level = |salt: u64| {
            move |t: f64, x: &[f64; N_MODES]| {
                let hour = (t / HOUR_S).floor() as u64;
                sd * Rng::new(hour.wrapping_mul(0x9E37_79B9) ^ salt).normal() * x[MOTOR]
            }
        };
        let training = synthetic_trips(&m, 31, 4.0, 0.0, &level(1));
        let settings = CalibrationSettings {
            years: 5.0,
            ..CalibrationSettings::default()
        };
        let cal = calibrate(&training, DEFAULT_WINDING_TAU_S, &NO_FIT_ERROR, &settings)
            .expect("calibrates");
        let got = cal.report.hour_wander[MOTOR];
        assert!((got / sd - 1.0).abs() < 0.3, "hour wander {got}, true {sd}");
        let month = synthetic_trips(&m, 77, 30.0, 4.0 * DAY_S, &level(2));
        let seq_max = run(&cal.risk, &month)
            .iter()
            .filter(|a| a.decision.lead_signature == crate::mode::FaultMode::Motor)
            .map(|a| a.decision.ratio)
            .fold(0.0, f64::max);
        assert!(
            seq_max < 1.0,
            "a new hour's level crossed the motor CUSUM: G/h = {seq_max}"
        );
    }

    #[test]
    fn the_drawn_hour_wander_covers_the_true_one_as_often_as_it_promises() {
        // Forty 3-day trainings whose hours sit at Kd levels of sd 4 %: the wander each
        // measures falls below the truth in about half of them, the one its bootstrap draws
        // (the upper 95 % bound) in about one in twenty.
        let m = test_model();
        let sd = 0.04;
        let settings = CalibrationSettings {
            years: 0.5,
            ..CalibrationSettings::default()
        };
        let (mut measured_below, mut drawn_below) = (0, 0);
        for k in 0..40u64 {
            let level = move |t: f64, x: &[f64; N_MODES]| {
                let hour = (t / HOUR_S).floor() as u64;
                sd * Rng::new(hour.wrapping_mul(0x9E37_79B9) ^ (k + 100)).normal() * x[MOTOR]
            };
            let training = synthetic_trips(&m, 200 + k, 3.0, 0.0, &level);
            let report = calibrate(&training, DEFAULT_WINDING_TAU_S, &NO_FIT_ERROR, &settings)
                .expect("calibrates")
                .report;
            measured_below += usize::from(report.hour_wander[MOTOR] < sd);
            drawn_below += usize::from(report.hour_wander_drawn[MOTOR] < sd);
        }
        assert!(
            (10..=30).contains(&measured_below),
            "measured below the truth in {measured_below} of 40"
        );
        assert!(
            drawn_below <= 6,
            "drawn below the truth in {drawn_below} of 40"
        );
    }

    #[test]
    fn the_busy_hours_wander_sets_the_thresholds() {
        // Every other clock hour is busy (four times the trips) and sits at its own Kd
        // level, ±6 % (sd); the quiet hours do not wander. A CUSUM gains an hour's level once
        // per trip, so the busy hours' spread is the one the thresholds must expect: weighted
        // by trips, the measured wander is near the busy hours' own, and a month of new busy
        // hours stays below the motor threshold (counting every hour alike measures half the
        // busy hours' variance: 0.71 of their sd, where trips weigh 0.89).
        let m = test_model();
        let sd = 0.06;
        let busy = |t: f64| (t / HOUR_S).floor() as u64 % 2 == 0;
        let level = |salt: u64| {
            move |t: f64, x: &[f64; N_MODES]| {
                let hour = (t / HOUR_S).floor() as u64;
                let z = Rng::new(hour.wrapping_mul(0x9E37_79B9) ^ salt).normal();
                if busy(t) {
                    sd * z * x[MOTOR]
                } else {
                    0.0
                }
            }
        };
        let traffic = |seed: u64, days: f64, t0: f64, salt: u64| {
            let mut trips = synthetic_trips(&m, seed, days, t0, &level(salt));
            for k in 1..4 {
                let extra = synthetic_trips(&m, seed + 1000 * k, days, t0, &level(salt));
                trips.extend(extra.into_iter().filter(|t| busy(t.start)));
            }
            trips.sort_by(|a, b| a.start.total_cmp(&b.start));
            trips
        };
        let settings = CalibrationSettings {
            years: 5.0,
            ..CalibrationSettings::default()
        };
        let cal = calibrate(
            &traffic(41, 8.0, 0.0, 1),
            DEFAULT_WINDING_TAU_S,
            &NO_FIT_ERROR,
            &settings,
        )
        .expect("calibrates");
        // Four fifths of the trips are in busy hours: the trip-weighted variance is 0.8·sd².
        let got = cal.report.hour_wander[MOTOR];
        let expected = sd * 0.8f64.sqrt();
        assert!(
            (got / expected - 1.0).abs() < 0.12,
            "hour wander {got}, expected {expected}"
        );
        let month = traffic(87, 30.0, 8.0 * DAY_S, 2);
        let seq_max = run(&cal.risk, &month)
            .iter()
            .filter(|a| a.decision.lead_signature == crate::mode::FaultMode::Motor)
            .map(|a| a.decision.ratio)
            .fold(0.0, f64::max);
        assert!(
            seq_max < 1.0,
            "a new busy hour's level crossed the motor CUSUM: G/h = {seq_max}"
        );
    }

    #[test]
    fn a_motor_fault_reads_as_a_change_of_the_kd_the_winding_has() {
        // Kd +20 % on a winding that swings with its load (the lag, β = 4) and with the day
        // (±3 %): the fault's voltage passes through the Kd of the moment. Read against the
        // winding's present Kd, the trips of a warm winding and of a cool one give the same
        // drift; read against the fit's, each gives the step times its thermal factor.
        let m = test_model();
        let (beta, step, onset) = (4.0, 0.2, 10.0 * DAY_S);
        let heated = |seed: u64, days: f64, fault: crate::risk::tests::Injection| {
            crate::risk::tests::heated_trips(&m, seed, days, 0.0, fault, beta, 2700.0)
        };
        let healthy = heated(11, 8.0, &|_, _| 0.0);
        let settings = CalibrationSettings {
            years: 5.0,
            ..CalibrationSettings::default()
        };
        let cfg = calibrate(&healthy, 2700.0, &NO_FIT_ERROR, &settings)
            .expect("calibrates")
            .risk;
        let w = cfg.winding;
        assert!(w.levels.is_some(), "{w:?}");
        let month = heated(12, 20.0, &|t, x| {
            if t >= onset {
                step * x[MOTOR]
            } else {
                0.0
            }
        });
        let after: Vec<&TripEvidence> = month.iter().filter(|t| t.start >= onset).collect();
        // The warm and the cool half of the trips by their thermal factor 1 + Σ β_k·b̄_k.
        let warmth = |t: &TripEvidence| t.thermal.warmth(&w.beta);
        let mut by_warmth: Vec<f64> = after.iter().map(|t| warmth(t)).collect();
        by_warmth.sort_by(f64::total_cmp);
        let median = by_warmth[by_warmth.len() / 2];
        let theta0 = cfg.sequential.as_ref().expect("a reference").theta0[MOTOR];
        // The motor coefficient of a half alone (pooled trip means), less the healthy θ0.
        let drift = |winding: &Winding, warm: bool| -> f64 {
            let (mut xr, mut xx) = (0.0, 0.0);
            for t in after.iter().filter(|t| (warmth(t) > median) == warm) {
                let t = winding.take_out(t);
                xr += t.xtr[MOTOR];
                xx += t.xtx[PACKED_DIAG[MOTOR]];
            }
            xr / xx - theta0
        };
        let present = (drift(&w, true), drift(&w, false));
        let fit_kd = Winding { levels: None, ..w };
        let fits = (drift(&fit_kd, true), drift(&fit_kd, false));
        println!(
            "present Kd: warm {:.4}, cool {:.4}; the fit's: warm {:.4}, cool {:.4}",
            present.0, present.1, fits.0, fits.1
        );
        assert!(
            (present.0 - present.1).abs() < 0.002,
            "against the present Kd, warm {:.4} and cool {:.4} differ",
            present.0,
            present.1
        );
        assert!((present.0 - step).abs() < 0.005 && (present.1 - step).abs() < 0.005);
        assert!(
            fits.0 - fits.1 > 0.005,
            "the winding swung too little to test: warm {:.4}, cool {:.4}",
            fits.0,
            fits.1
        );
        // And the decision, at its first crossing, reads the step within its error.
        let a = run(&cfg, &month);
        let i = first_decided(&a, &month, onset, |d| d.mode == FaultMode::Motor)
            .expect("the step is decided, named motor");
        let d = &a[i].decision;
        assert!(
            (d.drift[MOTOR] - step).abs() < 2.0 * d.drift_se[MOTOR],
            "Kd drift {:.4} ± {:.4}, true {step}",
            d.drift[MOTOR],
            d.drift_se[MOTOR]
        );
    }

    #[test]
    fn the_windings_time_constant_and_heating_are_identified_and_taken_out() {
        // A winding whose Kd rises 400 % per unit of H through a lag of 45 min, and swings
        // ±3 % with the day (peak at 06:00): the calibration finds τ, β and the swing, and with them a heated healthy month stays
        // quiet while the same month read without them (β = 0) sees a motor change.
        let m = test_model();
        // The generator's cars run about one second in twenty (a quiet building), so H stays
        // at a few hundredths; β ten times a real winding's (0.4, about 100 K at the reference
        // force) gives these days the few % of Kd swing a busy building's winding shows.
        let beta = 4.0;
        let none = |_: f64, _: &[f64; N_MODES]| 0.0;
        let heated = |seed: u64, days: f64, tau: f64| {
            crate::risk::tests::heated_trips(&m, seed, days, 0.0, &none, beta, tau)
        };
        let (tau, healthy) = winding_time_constant(&mut |tau| heated(11, 8.0, tau));
        assert!(
            (tau / 2700.0 - 1.0).abs() < 0.25,
            "τ = {:.0} min, true 45",
            tau / 60.0
        );
        let settings = CalibrationSettings {
            years: 5.0,
            ..CalibrationSettings::default()
        };
        let cfg = calibrate(&healthy, tau, &NO_FIT_ERROR, &settings)
            .expect("calibrates")
            .risk;
        let w = cfg.winding;
        assert_eq!(w.tau_s, tau);
        assert!(
            (w.steady_rise() - beta).abs() < 0.1 * beta + 3.0 * w.beta_se[HEAT_LAG],
            "β = {:?} ± {:?}, true {beta}",
            w.beta,
            w.beta_se
        );
        let (swing, peak) = w.ambient_swing();
        assert!((swing - 0.03).abs() < 0.005, "swing {swing}, true 0.03");
        assert!((peak - 6.0).abs() < 0.5, "peak at {peak} h, true 06:00");
        // Unheated healthy trips show the daily swing and no lag.
        let cold = calibrated(&m).risk.winding;
        assert!(
            cold.beta[HEAT_LAG].abs() <= 3.0 * cold.beta_se[HEAT_LAG],
            "{cold:?}"
        );
        assert!((cold.ambient_swing().0 - 0.03).abs() < 0.005, "{cold:?}");
        let month = heated(99, 30.0, tau);
        let a = run(&cfg, &month);
        let seq = a.iter().map(|a| a.decision.ratio).fold(0.0, f64::max);
        assert!(seq < 1.0, "the heating crossed a CUSUM: G/h = {seq}");
        let blind = RiskConfig {
            winding: Winding::default(),
            ..cfg.clone()
        };
        let a = run(&blind, &month);
        let seq = a.iter().map(|a| a.decision.ratio).fold(0.0, f64::max);
        assert!(
            seq >= 1.0,
            "unheated, the month should have looked changed: G/h = {seq}"
        );
    }

    #[test]
    fn a_healthy_sequence_stays_normal() {
        // With the default bootstrap of ten years, whose maxima the promise of one false
        // advisory a year rests on (the helper's five years for speed hold six thresholds at
        // a 5-year maximum each, and validate at about one a year).
        let m = test_model();
        let cal = calibrated_with(&m, &CalibrationSettings::default());
        let cfg = cal.risk;
        // Thirty new healthy days, other seed, including the ±3 % daily Kd swing.
        let trips = synthetic_trips(&m, 99, 30.0, 0.0, &|_, _| 0.0);
        let a = run(&cfg, &trips);
        let max = a.iter().map(|a| a.risk).fold(0.0, f64::max);
        assert!(
            max < cfg.advisory,
            "healthy risk {max} reached the advisory {}",
            cfg.advisory
        );
        let seq = a.iter().map(|a| a.decision.ratio).fold(0.0, f64::max);
        assert!(seq < 1.0, "a healthy CUSUM crossed: G/h = {seq}");
        let report = &cal.report;
        assert!(
            report.validated_false_advisories_per_year <= report.target_false_advisories_per_year,
            "{report:?}"
        );
    }

    #[test]
    fn slow_drift_is_not_absorbed_by_the_boundary() {
        // Friction creeps up linearly to +30 % over 20 days. A boundary over the recent window
        // would rise with it; the healthy boundary does not, so evidence keeps accumulating.
        let m = test_model();
        let cal = calibrated(&m);
        let cfg = cal.risk;
        let days = 20.0;
        let ramp = move |t: f64, x: &[f64; N_MODES]| 0.30 * (t / (days * DAY_S)) * x[FRICTION];
        let trips = synthetic_trips(&m, 5, days, 0.0, &ramp);
        let a = run(&cfg, &trips);
        let first = first_advisory(&cfg, &a, &trips).expect("the drift must raise an advisory");
        assert!(
            first < 0.8 * days * DAY_S,
            "advisory only at day {}",
            first / DAY_S
        );
        // Once found, the drift stays found: the last fifth of the ramp is all above advisory.
        let tail = &a[a.len() * 4 / 5..];
        assert!(
            tail.iter().all(|a| a.risk >= cfg.advisory),
            "risk fell back while the drift grew"
        );
    }

    #[test]
    fn a_step_in_the_voltage_residual_raises_risk_and_names_friction() {
        // A constant +k·σ on every moving sample looks like more friction: the same extra
        // force in both directions at every load.
        let m = test_model();
        let cal = calibrated(&m);
        let cfg = cal.risk;
        let k = 1.0 * m.scales.sigma_u_v;
        let trips = synthetic_trips(&m, 6, 6.0, 0.0, &|t, _| if t > DAY_S { k } else { 0.0 });
        let a = run(&cfg, &trips);
        let last = a.last().unwrap();
        assert!(
            last.risk >= cfg.advisory,
            "{} < {}",
            last.risk,
            cfg.advisory
        );
        let q: Vec<f64> = (0..N_MODES)
            .map(|i| last.risk_modes[i] / cfg.advisory_modes[i])
            .collect();
        assert!(
            q[FRICTION] > cfg.dominance * q[MOTOR].max(q[BRAKE]),
            "{q:?}"
        );
        assert!(a
            .iter()
            .zip(&trips)
            .filter(|(_, t)| t.start < DAY_S)
            .all(|(a, _)| a.risk < cfg.advisory));
    }

    #[test]
    fn the_bootstraps_levels_are_the_full_steps_to_the_bit() {
        // The bootstraps take R from `push_risk_levels` and G and the ratio from
        // `push_decision_levels`, each on a tracker of its own (side by side on two threads),
        // which skip the decision's windows, isolation and drifts and take each trip prepared
        // once, its hour's level added as it is drawn: on healthy days and through a step that
        // crosses the CUSUMs, each of them must be the full step's, bit for bit, whether the
        // trip is taken as it is or moved by an hour's level.
        let m = test_model();
        let cfg = calibrated(&m).risk;
        let k = 1.0 * m.scales.sigma_u_v;
        let trips = synthetic_trips(&m, 6, 3.0, 0.0, &|t, _| if t > DAY_S { k } else { 0.0 });
        let offset = [0.004, -0.02, 0.01];
        let moved = |t: &TripEvidence, offset: &[f64; N_MODES]| {
            let mut t = t.clone();
            for m in 0..N_MODES {
                t.xtr[m] += t.xtx[PACKED_DIAG[m]] * offset[m];
            }
            t
        };
        for shift in [None, Some(&offset)] {
            let mut full = RiskTracker::new(&cfg);
            let (mut risks, mut decisions) = (RiskTracker::new(&cfg), RiskTracker::new(&cfg));
            let mut crossed = false;
            for t in &trips {
                let t = cfg.winding.take_out(t);
                let a = full.push(&cfg, &shift.map_or_else(|| t.clone(), |o| moved(&t, o)));
                let p = PreparedTrip::new(&cfg, &t);
                let (risk, risk_modes) = risks.push_risk_levels(&cfg, &p, shift);
                let ratio = decisions.push_decision_levels(&cfg, &p, shift);
                crossed |= a.decision.ratio >= 1.0;
                assert_eq!(a.risk.to_bits(), risk.to_bits());
                assert_eq!(a.risk_modes.map(f64::to_bits), risk_modes.map(f64::to_bits));
                assert_eq!(a.decision.ratio.to_bits(), ratio.to_bits());
                let g = |t: &RiskTracker| t.cusum_g().map(|row| row.map(f64::to_bits));
                assert_eq!(g(&full), g(&decisions));
                let z2 = |t: &RiskTracker| t.glr_z2().map(f64::to_bits);
                assert_eq!(z2(&full), z2(&decisions));
            }
            assert!(crossed, "the step never crossed a CUSUM");
        }
    }

    #[test]
    fn the_bootstraps_side_by_side_are_one_thread_to_the_bit() {
        // The two bootstraps run the tracker's halves on two threads over one drawn sequence
        // each; one thread taking both halves must give the same maxima and episodes, bit for
        // bit. The thresholds are lowered so that the run holds episodes, and the run is long
        // enough that the episodes' pairing of R with the ratio crosses several batches.
        let m = test_model();
        let mut cfg = calibrated(&m).risk;
        cfg.advisory *= 0.05;
        cfg.alarm *= 0.05;
        if let Some(seq) = &mut cfg.sequential {
            for row in &mut seq.h {
                for h in row {
                    *h *= 0.3;
                }
            }
        }
        let trips: Vec<TripEvidence> = synthetic_trips(&m, 8, 3.0, 0.0, &|_, _| 0.0)
            .iter()
            .map(|t| cfg.winding.take_out(t))
            .collect();
        let hours = HourWander::measure(cfg.sequential.as_ref().unwrap(), &trips);
        assert!(!hours.is_zero(), "the hours' levels are drawn too");
        let total = 3 * RATIO_BATCH as u64 + 17;
        let draws = Draws::new(&cfg, &trips, DAY_S, total, &hours);

        let mut tracker = RiskTracker::new(&cfg);
        let mut alarm = AlarmState::default();
        let (mut episodes, mut max_r, mut max_g, mut max_glr) =
            (0, 0.0f64, [[0.0f64; N_SIZES]; N_MODES], [0.0f64; N_MODES]);
        let mut taken = 0;
        draws.run(&mut Rng::new(5), |t, offset| {
            let (risk, _) = tracker.push_risk_levels(&cfg, t, offset);
            let ratio = tracker.push_decision_levels(&cfg, t, offset);
            max_r = max_r.max(risk);
            let (g, z2) = (tracker.cusum_g(), tracker.glr_z2());
            for m in 0..N_MODES {
                max_glr[m] = max_glr[m].max(z2[m]);
                for j in 0..N_SIZES {
                    max_g[m][j] = max_g[m][j].max(g[m][j]);
                }
            }
            let before = alarm.machine_level();
            alarm.update_machine(risk, ratio, &cfg);
            if before == Level::Normal && alarm.machine_level() != Level::Normal {
                episodes += 1;
            }
            taken += 1;
        });
        assert_eq!(taken, total);
        assert!(
            episodes > 1,
            "{episodes} episodes: the pairing is not tested"
        );
        let (r2, _, g2, glr2) = bootstrap_maxima(&cfg, &draws, &mut Rng::new(5));
        assert_eq!(max_r.to_bits(), r2.to_bits());
        assert_eq!(
            max_g.map(|row| row.map(f64::to_bits)),
            g2.map(|row| row.map(f64::to_bits))
        );
        assert_eq!(max_glr.map(f64::to_bits), glr2.map(f64::to_bits));
        assert_eq!(episodes, bootstrap_episodes(&cfg, &draws, &mut Rng::new(5)));
    }

    #[test]
    fn load_proportional_residual_raises_motor() {
        let m = test_model();
        let cal = calibrated(&m);
        let cfg = cal.risk;
        // 20 days: with a memory of 3000 trips (~8 synthetic days) the estimate needs that
        // long to settle on the new Kd; the tolerance is unchanged.
        let trips = synthetic_trips(&m, 7, 20.0, 0.0, &|t, x| {
            if t > DAY_S {
                0.10 * x[MOTOR]
            } else {
                0.0
            }
        });
        let last = *run(&cfg, &trips).last().unwrap();
        assert!(last.risk >= cfg.advisory);
        assert!(
            (last.drift[MOTOR] - 0.10).abs() < 0.03,
            "Kd drift {}",
            last.drift[MOTOR]
        );
        let q: Vec<f64> = (0..N_MODES)
            .map(|i| last.risk_modes[i] / cfg.advisory_modes[i])
            .collect();
        assert!(
            q[MOTOR] > cfg.dominance * q[FRICTION].max(q[BRAKE]),
            "{q:?}"
        );
    }

    #[test]
    fn asymmetric_residual_raises_brake_not_friction() {
        // Drag only going down or decelerating: the brake's signature, not friction's.
        let m = test_model();
        let cal = calibrated(&m);
        let cfg = cal.risk;
        let trips = synthetic_trips(&m, 8, 6.0, 0.0, &|t, x| {
            if t > DAY_S {
                0.5 * x[BRAKE]
            } else {
                0.0
            }
        });
        let last = *run(&cfg, &trips).last().unwrap();
        assert!(last.risk >= cfg.advisory);
        let q: Vec<f64> = (0..N_MODES)
            .map(|i| last.risk_modes[i] / cfg.advisory_modes[i])
            .collect();
        assert!(
            q[BRAKE] > cfg.dominance * q[FRICTION].max(q[MOTOR]),
            "{q:?}"
        );
        assert!(
            last.drift[FRICTION] < 0.1,
            "friction drift {}",
            last.drift[FRICTION]
        );
    }

    #[test]
    fn a_step_is_decided_within_tens_of_trips_with_its_mode_and_size() {
        // Kd +10 % from day 1 on: the sequential decision crosses within tens of trips, names
        // the motor and measures the step on the trips it holds as changed, where the
        // accumulated risk R alone takes hundreds.
        let m = test_model();
        let cfg = calibrated(&m).risk;
        let onset = DAY_S;
        let trips = synthetic_trips(&m, 17, 6.0, 0.0, &|t, x| {
            if t > onset {
                0.10 * x[MOTOR]
            } else {
                0.0
            }
        });
        let a = run(&cfg, &trips);
        let after: Vec<(&TripAssessment, &TripEvidence)> = a
            .iter()
            .zip(&trips)
            .filter(|(_, t)| t.start > onset)
            .collect();
        let k = after
            .iter()
            .position(|(a, _)| a.decision.ratio >= 1.0)
            .expect("the step must be decided");
        assert!(k < 60, "decided only {k} trips after the step");
        let r = after.iter().position(|(a, _)| a.risk >= cfg.advisory);
        assert!(
            r.map_or(true, |r| r > k),
            "R ({r:?}) before the decision ({k})"
        );
        let d = after[k].0.decision;
        assert_eq!(d.mode, crate::mode::FaultMode::Motor, "{d:?}");
        // Once the window holds enough trips, the Kd drift is the step's, within 2 SE.
        let later = after[k + 100].0.decision;
        assert!(
            (later.drift[MOTOR] - 0.10).abs() < 2.0 * later.drift_se[MOTOR],
            "Kd drift {} ± {}",
            later.drift[MOTOR],
            later.drift_se[MOTOR]
        );
        assert!(
            a.iter()
                .zip(&trips)
                .filter(|(_, t)| t.start < onset)
                .all(|(a, _)| a.decision.ratio < 1.0),
            "crossed before the step"
        );
    }

    /// A brake dragging by `drag` (brake coefficient) from `onset` on, that also rubs going
    /// up at a fifth of that (as the simulator's does): not quite the brake signature.
    fn rubbing_drag(onset: f64, drag: f64) -> impl Fn(f64, &[f64; N_MODES]) -> f64 {
        move |t, x| {
            if t <= onset {
                0.0
            } else if x[BRAKE] != 0.0 {
                drag * x[BRAKE]
            } else {
                0.2 * drag * x[FRICTION]
            }
        }
    }

    #[test]
    fn the_named_modes_drift_is_its_own_not_the_joint_fits() {
        // A dragging brake that rubs a little in every direction (a fifth of its downward
        // drag going up, as the simulator's): not quite the brake signature, and the joint
        // fit of three near-collinear signatures on the decision's short window spreads the
        // misfit over all three. Once the brake is named, its drift is the brake signature's
        // alone, within 2 SE of the downward drag.
        let m = test_model();
        let cfg = calibrated(&m).risk;
        let onset = DAY_S;
        let drag = 0.5;
        let trips = synthetic_trips(&m, 29, 4.0, 0.0, &rubbing_drag(onset, drag));
        let a = run(&cfg, &trips);
        let k = first_decided(&a, &trips, onset, |d| {
            d.machine_mode == crate::mode::FaultMode::Brake
        })
        .expect("the drag must be decided and named");
        // 200 trips later the joint fit reads 0.35 ± 0.08 (a third low, the uniform part
        // taken by friction); the brake alone 0.56 ± 0.05.
        let d = a[k + 200].decision;
        assert!(
            d.ratio >= cfg.release_ratio,
            "the change is still held: {d:?}"
        );
        assert_eq!(d.machine_mode, crate::mode::FaultMode::Brake, "{d:?}");
        assert!(
            (d.drift[BRAKE] - drag).abs() < (2.0 * d.drift_se[BRAKE]).min(0.2 * drag),
            "brake {} ± {} against {drag}",
            d.drift[BRAKE],
            d.drift_se[BRAKE]
        );
        // The drive did not change: what the brake leaves of the window reads Kd within
        // 0.3 % of nothing and of its own 2 SE (the joint fit of all three read +0.85 %,
        // beside the brake's misfit).
        assert!(
            d.drift[MOTOR].abs() < (2.0 * d.drift_se[MOTOR]).min(0.003),
            "Kd {} ± {}",
            d.drift[MOTOR],
            d.drift_se[MOTOR]
        );
    }

    #[test]
    fn a_drag_that_rubs_going_up_too_is_named_brake_and_a_friction_rise_friction() {
        // A dragging brake that rubs going up at a fifth of its downward drag: the friction
        // signature alone fits the first decision's window about as well as the brake's
        // alone, and the isolation left it `unknown`. What the brake's asymmetric part adds
        // to friction's names it. (At 30 % and more the friction signature still wins that
        // first window.) A friction rise of the same size, which has no asymmetric part,
        // stays `friction`.
        let m = test_model();
        let cfg = calibrated(&m).risk;
        let onset = DAY_S;
        let drag = 0.5;
        let first_mode = |fault: crate::risk::tests::Injection| {
            let trips = synthetic_trips(&m, 31, 4.0, 0.0, fault);
            let a = run(&cfg, &trips);
            let k = first_decided(&a, &trips, onset, |_| true).expect("the change is decided");
            a[k].decision.machine_mode
        };
        let brake = first_mode(&rubbing_drag(onset, drag));
        assert_eq!(brake, crate::mode::FaultMode::Brake);
        let friction = first_mode(&|t, x| if t <= onset { 0.0 } else { drag * x[FRICTION] });
        assert_eq!(friction, crate::mode::FaultMode::Friction);
    }

    #[test]
    fn a_drifting_load_cell_is_named_sensor_not_motor() {
        // The cell's zero creeps up by 4 % of the rated load a day from day 1: every expected
        // force grows by Q·(g + a)·Δλ, the voltage residual looks like the drive's. The
        // decision names the cell, with its offset, and the drive's step of the test above
        // stays `motor` (the isolation weighs both).
        let m = test_model();
        let cfg = calibrated(&m).risk;
        let onset = DAY_S;
        let rate = 0.04 / DAY_S;
        let trips = offset_load_trips(&m, 23, 4.0, &|t| rate * (t - onset).max(0.0));
        let a = run(&cfg, &trips);
        let k = first_decided(&a, &trips, onset, |_| true).expect("the drift must be decided");
        let d = a[k].decision;
        assert_eq!(d.mode, crate::mode::FaultMode::Sensor, "{d:?}");
        let now = rate * (trips[k].start - onset);
        assert!(
            d.load_offset > 0.0 && d.load_offset < 1.5 * now,
            "offset {} against {now} now",
            d.load_offset
        );
        let odds = crate::risk::sequential::ISOLATION_ODDS.ln();
        assert!(d.isolation_load > d.isolation[MOTOR] + odds, "{d:?}");
    }

    #[test]
    fn a_friction_change_reads_its_newtons_whatever_the_fitted_friction_level() {
        // The machine's friction is half the level the model fitted (a small car's level is
        // pinned by (1 − α_down)·Kd·F alone and came out 1.2-3× the truth) and rises by 40 %
        // in a step on day 1: 0.4 · ½ of the model's friction at the rated speed, which is
        // where the synthetic trips cruise. The event reads those newtons within 2 SE; its
        // percent, a share of the fitted level, reads 20 %, half the true rise.
        let m = test_model();
        let cfg = calibrated(&m).risk;
        let onset = DAY_S;
        let (level, rise) = (0.5, 0.4);
        let trips = synthetic_trips(&m, 29, 4.0, 0.0, &|t, x| {
            if t >= onset {
                rise * level * x[FRICTION]
            } else {
                0.0
            }
        });
        let a = run(&cfg, &trips);
        let k = first_decided(&a, &trips, onset, |d| {
            d.mode == crate::mode::FaultMode::Friction
        })
        .expect("the friction step must be decided as friction");
        let scale = crate::risk::DriftScale::of(&m);
        let ev = crate::alarm::Evidence::from_assessment(&a[k], scale, k as u64, 0);
        // The synthetic trips cruise at 1.75 m/s, where the injected friction force is the
        // reference's F_c + c·v.
        let (f_c, c_visc) = crate::risk::friction_reference(&m);
        let truth_n = rise * level * (f_c + c_visc * 1.75);
        assert!(
            (ev.friction_drift_n - truth_n).abs() < 2.0 * ev.friction_drift_se_n,
            "friction {} ± {} N against {truth_n} N",
            ev.friction_drift_n,
            ev.friction_drift_se_n
        );
        assert!(
            (ev.friction_drift_pct - 100.0 * rise * level).abs() < 2.0 * ev.friction_drift_se_pct,
            "friction {} ± {} % of the fitted level",
            ev.friction_drift_pct,
            ev.friction_drift_se_pct
        );
    }

    #[test]
    fn a_large_steps_drift_is_read_from_its_change_point() {
        // Kd +25 % in the middle of a busy day, on ten plants: the CUSUM's window begins
        // where its G last left zero, often some healthy trips before the step, and its mean
        // read the step low; the trips since the likeliest change point read it within 2 SE
        // at the decision.
        let m = test_model();
        let cfg = calibrated(&m).risk;
        let onset = DAY_S + 11.0 * HOUR_S;
        let mut missed = Vec::new();
        for seed in 0..10 {
            let trips = synthetic_trips(&m, 40 + seed, 2.0, 0.0, &|t, x| {
                if t > onset {
                    0.25 * x[MOTOR]
                } else {
                    0.0
                }
            });
            let a = run(&cfg, &trips);
            let k = first_decided(&a, &trips, onset, |_| true).expect("the step must be decided");
            let d = a[k].decision;
            if (d.drift[MOTOR] - 0.25).abs() > 2.0 * d.drift_se[MOTOR] {
                missed.push((seed, d.drift[MOTOR], d.drift_se[MOTOR], d.window_trips));
            }
        }
        assert!(missed.is_empty(), "Kd drift off the step: {missed:?}");
    }

    #[test]
    fn a_ramps_drift_is_where_it_stands_now_not_its_windows_mean() {
        // Kd grows by 1 % a day from day 1. Where the change is held, the drift the decision
        // reports is the ramp's level at the last trip within 2 SE; the window's mean, which
        // it reported before, sits at about half of it.
        let m = test_model();
        let cfg = calibrated(&m).risk;
        let onset = DAY_S;
        let rate = 0.01 / DAY_S;
        let trips = synthetic_trips(&m, 19, 12.0, 0.0, &|t, x| {
            (t - onset).max(0.0) * rate * x[MOTOR]
        });
        let a = run(&cfg, &trips);
        let (d, last) = (a.last().unwrap().decision, trips.last().unwrap());
        assert!(d.ratio >= 1.0, "the ramp must be held: {d:?}");
        let truth = (last.start - onset) * rate;
        assert!(
            (d.drift[MOTOR] - truth).abs() < 2.0 * d.drift_se[MOTOR],
            "Kd drift {} ± {} against {truth}",
            d.drift[MOTOR],
            d.drift_se[MOTOR]
        );
        assert!(
            d.drift[MOTOR] > 0.75 * truth,
            "Kd drift {} lags the ramp's {truth}",
            d.drift[MOTOR]
        );
    }

    #[test]
    fn a_healthy_level_off_a_short_trainings_own_is_not_a_change() {
        // The three days of a short training sit at Kd −1.5 %, 0 and +1.5 % of their mean
        // (traffic mix, the ambient), beside the daily ±3 % thermal swing. The days after it
        // sit at +0.8 %, a level those three days make plausible for a new day and below half
        // the larger CUSUM size (one trip's Kd error is about 4 % here): thirty of them must
        // not pile up into a change in the smallest size, as they do when θ0 is taken as exact.
        const DAY_KD: [f64; 3] = [-0.015, 0.0, 0.015];
        const LATER_KD: f64 = 0.008;
        let m = test_model();
        let training = synthetic_trips(&m, 41, 3.0, 0.0, &|t, x| {
            DAY_KD[((t / DAY_S) as usize).min(2)] * x[MOTOR]
        });
        let settings = CalibrationSettings {
            years: 5.0,
            ..CalibrationSettings::default()
        };
        let cfg = calibrate(&training, DEFAULT_WINDING_TAU_S, &NO_FIT_ERROR, &settings)
            .expect("three days suffice")
            .risk;
        let seq = cfg.sequential.as_ref().expect("separable signatures");
        // The days' spread shows in θ0's error: about 1.5 %/√3 beyond the pooled noise.
        let se = seq.reference_se[MOTOR];
        assert!(
            (0.5 * 0.015 / 3f64.sqrt()..0.02).contains(&se),
            "θ0's error {se}"
        );
        let later = synthetic_trips(&m, 43, 30.0, 10.0 * DAY_S, &|_, x| LATER_KD * x[MOTOR]);
        let ratio = |cfg: &RiskConfig| {
            run(cfg, &later)
                .iter()
                .map(|a| a.decision.ratio)
                .fold(0.0, f64::max)
        };
        assert!(
            ratio(&cfg) < 1.0,
            "a new day's level crossed: G/h = {}",
            ratio(&cfg)
        );
        // Taking θ0 as exact, the same month is a "change": the test can fail.
        let mut exact = cfg.clone();
        exact.sequential.as_mut().expect("set").reference_se = [0.0; N_MODES];
        assert!(
            ratio(&exact) >= 1.0,
            "G/h = {} with θ0 exact",
            ratio(&exact)
        );
    }

    #[test]
    fn a_morning_of_training_expects_the_afternoon_it_did_not_see() {
        // The paper's three hours of a morning (07:00-10:00) on a machine room whose day moves
        // Kd by ±2.5 % (±6.4 K), warmest at 15:00; the generator's own daily term is taken
        // out. The training cannot measure the cycle and allows for one
        // (UNSEEN_AMBIENT_SWING), beside the bound of an hour wander that three hours hardly
        // measure: ten days of afternoons stay below the thresholds (G/h 0.16), and a +8 %
        // step of Kd is still decided within the day. With neither the afternoons crossed
        // the motor CUSUM (G/h 1.43); with the allowance alone 0.38, the bound alone 0.26.
        use std::f64::consts::TAU;
        let m = test_model();
        let room = |t: f64| 0.025 * (TAU * (t / DAY_S - 15.0 / 24.0)).cos();
        let own = |t: f64| 0.03 * (TAU * t / DAY_S).sin();
        let training = synthetic_trips(&m, 51, 0.125, 7.0 * HOUR_S, &|t, x| {
            (room(t) - own(t)) * x[MOTOR]
        });
        let settings = CalibrationSettings {
            years: 5.0,
            ..CalibrationSettings::default()
        };
        let cal = calibrate(&training, DEFAULT_WINDING_TAU_S, &NO_FIT_ERROR, &settings)
            .expect("three hours suffice");
        assert_eq!(cal.report.unseen_ambient_swing, UNSEEN_AMBIENT_SWING);
        let later = synthetic_trips(&m, 53, 10.0, DAY_S, &|t, x| (room(t) - own(t)) * x[MOTOR]);
        let worst = run(&cal.risk, &later)
            .iter()
            .map(|a| a.decision.ratio)
            .fold(0.0, f64::max);
        assert!(worst < 1.0, "an afternoon crossed: G/h = {worst}");
        let onset = 3.5 * DAY_S;
        let step = synthetic_trips(&m, 53, 10.0, DAY_S, &|t, x| {
            (room(t) - own(t) + if t >= onset { 0.08 } else { 0.0 }) * x[MOTOR]
        });
        let a = run(&cal.risk, &step);
        let k = first_decided(&a, &step, onset, |_| true).expect("the step is decided");
        assert!(
            step[k].start - onset < DAY_S,
            "decided {} h after the step",
            (step[k].start - onset) / HOUR_S
        );
    }

    #[test]
    fn one_burst_of_odd_trips_is_not_a_change() {
        // Five consecutive trips far off (20 σ), then healthy again: the clip and the sizes
        // keep the decision below its threshold.
        let m = test_model();
        let cfg = calibrated(&m).risk;
        let k = 20.0 * m.scales.sigma_u_v;
        let burst = |t: f64| (DAY_S..DAY_S + 1500.0).contains(&t);
        let trips = synthetic_trips(&m, 21, 3.0, 0.0, &|t, _| if burst(t) { k } else { 0.0 });
        assert!(trips.iter().filter(|t| burst(t.start)).count() >= 3);
        let seq = run(&cfg, &trips)
            .iter()
            .map(|a| a.decision.ratio)
            .fold(0.0, f64::max);
        assert!(seq < 1.0, "a burst crossed: G/h = {seq}");
    }

    /// Moving rows of `hours` clock hours, 200 a hour, over speeds, loads, accelerations and
    /// floors; each hour's voltage carries a Kd offset δ_h ~ N(0, `hour_sd`) along the motor
    /// signature and noise of 1 V. Returns the rows and the model's Gauss-Newton covariance
    /// on them (σ the residuals' robust sd, as the fit takes it; a weak ridge standing for the
    /// fit's prior).
    fn hourly_rows(
        hours: u32,
        hour_sd: f64,
        seed: u64,
    ) -> (HybridModel, Vec<FeatureRow>, SquareMatrix) {
        let m = test_model();
        let friction = friction_reference(&m);
        let mut rng = Rng::new(seed);
        let mut rows = Vec::new();
        for h in 0..hours {
            let delta = hour_sd * rng.normal();
            for k in 0..200 {
                let v = [1.75, -1.75, 1.0, -1.0, 0.5, -0.5][k % 6];
                let a = [0.0, 0.8, -0.8][k % 3];
                let mut x = crate::residual::tests::row(
                    &m,
                    f64::from(h) * HOUR_S + f64::from(k as u32) * 10.0,
                    v,
                    rng.uniform(0.0, 1.0),
                    a,
                    0.0,
                );
                x.floor = rng.uniform(1.0, 26.0).floor();
                let pred = PredictionCache::default().predict(&m, &x);
                let sig = signature(&m, friction, &x, pred.f_pred);
                x.voltage = pred.u_pred + delta * sig[MOTOR] + rng.normal();
                rows.push(x);
            }
        }
        // As the fit builds it: the gradients over the residuals' robust sd.
        let p = &m.parameters;
        let sigma = robust_sigma(
            rows.iter()
                .map(|x| x.voltage - PredictionCache::default().predict(&m, x).u_pred),
        );
        let mut h = SquareMatrix::zeros(N_PHYS);
        for x in &rows {
            let q = PhysParams::relative_height(x.floor, m.elevator.floors);
            let j = p.du_dtheta(x.s, x.v, x.lambda, x.a, q, m.elevator.rated_load_kg);
            h.add_outer(&j.map(|v| v / sigma), 1.0);
        }
        for k in 0..N_PHYS {
            *h.at(k, k) += 1e-9 * h.get(k, k);
        }
        let cov = h.cholesky().expect("identified").cholesky_inverse();
        (m, rows, cov)
    }

    #[test]
    fn the_fits_own_error_is_the_hours_wander_over_their_number() {
        // Residuals independent from sample to sample: the fit's own covariance, about
        // 1 V/√Σx² of the motor signature.
        let (m, rows, cov) = hourly_rows(48, 0.0, 5);
        let iid = fit_error_along_signatures(&m, &rows, &cov)[MOTOR];
        let info: f64 = rows
            .iter()
            .map(|x| {
                let f = PredictionCache::default().predict(&m, x).f_pred;
                signature(&m, friction_reference(&m), x, f)[MOTOR].powi(2)
            })
            .sum();
        assert!(
            iid > 0.9 / info.sqrt() && iid < 3.0 / info.sqrt(),
            "{iid} against {}",
            1.0 / info.sqrt()
        );
        // Every hour at its own Kd level (sd 2 %): the motor level of a new day is off by
        // about their mean, 2 %/√48 = 0.29 %, which the independent covariance misses.
        let (m, rows, cov) = hourly_rows(48, 0.02, 5);
        let se = fit_error_along_signatures(&m, &rows, &cov)[MOTOR];
        let expected = (0.02f64.powi(2) / 48.0 + iid * iid).sqrt();
        assert!(
            se > 0.6 * expected && se < 1.5 * expected,
            "motor level error {se:.5} against {expected:.5}"
        );
        assert!(se > 3.0 * iid, "{se} against {iid}");
    }

    #[test]
    fn calibration_refuses_too_few_trips() {
        let m = test_model();
        let trips = synthetic_trips(&m, 1, 0.05, 0.0, &|_, _| 0.0);
        assert!(trips.len() < 30);
        let err = calibrate(
            &trips,
            DEFAULT_WINDING_TAU_S,
            &NO_FIT_ERROR,
            &CalibrationSettings::default(),
        )
        .unwrap_err();
        assert!(err.to_string().contains("30 healthy trips"), "{err}");
    }
}
