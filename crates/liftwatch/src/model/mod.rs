//! Stage 4: the hybrid model, physics plus a correcting network (paper, Sec. 3.2-3.3).
//!
//! ```text
//! U_pred = U_phys(v, λ, a; θ) + δU(x)
//! F_pred = F_phys(v, λ, a; θ) + δF(x)
//! ```
//!
//! [`physics`] holds θ and the equations, [`net`] the network, [`train`] the fit,
//! [`file`] the versioned model file that `monitor` reads.

pub mod file;
pub mod loss;
pub mod net;
pub mod optim;
pub mod physics;
pub mod train;

use serde::{Deserialize, Serialize};

use crate::baseline::BaselineLimits;
use crate::elevator::Elevator;
use crate::error::Result;
use crate::features::{FeatureConfig, FeatureRow, Features};
use crate::risk::{CalibrationSettings, RiskConfig, TripEvidence};
use crate::sample::AlignedSeries;

pub use net::ResidualNet;
pub use physics::PhysParams;
pub use train::{FitSummary, TrainConfig};

/// Version of the model file this build writes and reads.
pub const FORMAT_VERSION: u32 = 1;

/// Healthy residual scales σ_U, σ_F from the fit: they make the residuals dimensionless.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ResidualScales {
    /// σ_U: robust standard deviation of r_U on healthy moving samples (V).
    pub sigma_u_v: f64,
    /// σ_F: robust standard deviation of r_F on healthy moving samples (N).
    pub sigma_f_n: f64,
}

/// What the hybrid model predicts for one sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prediction {
    /// U_pred: predicted motor voltage (V).
    pub u_pred: f64,
    /// F_pred: predicted driving force (N).
    pub f_pred: f64,
    /// F_U: the force the measured voltage implies (N); NaN at rest or without voltage.
    pub f_u: f64,
}

/// Everything `monitor` needs, as written by `fit` (DATA.md §5).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FittedModel {
    /// Format version, [`FORMAT_VERSION`] when written by this build.
    pub format_version: u32,
    /// The elevator description the model was fitted for.
    pub elevator: Elevator,
    /// Identified physical parameters θ.
    pub parameters: PhysParams,
    /// The correcting network.
    pub net: ResidualNet,
    /// Healthy residual scales.
    pub scales: ResidualScales,
    /// Feature settings, including the load-cell gain fitted on the training data.
    pub features: FeatureConfig,
    /// Risk settings, calibrated on the healthy residuals of the fit.
    pub risk: RiskConfig,
    /// The settings the model was trained with.
    pub train: TrainConfig,
    /// Standard errors, training history and warnings of the fit.
    pub fit: FitSummary,
}

impl FittedModel {
    /// Predicts voltage and force for one feature row and the force implied by its voltage.
    pub fn predict(&self, x: &FeatureRow) -> Prediction {
        let p = &self.parameters;
        let m_r = self.elevator.rated_load_kg;
        let [du, df] = self.net.forward(x.v, x.lambda, x.a);
        let q = PhysParams::relative_height(x.floor, self.elevator.floors);
        let f_phys = p.force(x.s, x.v, x.lambda, x.a, q, m_r);
        Prediction {
            u_pred: p.voltage(x.s, x.v, f_phys) + du,
            f_pred: f_phys + df,
            f_u: p.force_from_voltage(x.s, x.v, x.voltage),
        }
    }
}

/// Everything `fit` produces: the model, and the intermediate results a report shows.
#[derive(Clone, Debug)]
pub struct FitOutcome {
    /// The fitted, calibrated model.
    pub model: FittedModel,
    /// Features of the training data (with the fitted load-cell gain).
    pub features: Features,
    /// Per-trip evidence of the training data, on which the risk was calibrated.
    pub healthy_trips: Vec<TripEvidence>,
}

/// Margin of the fixed-threshold baseline above the healthy extremes (fraction).
pub const BASELINE_MARGIN: f64 = 0.5;

/// The whole identification: features (with the load-cell gain fitted on this history),
/// the hybrid model, healthy residual scales, the baseline's limits and the calibration of the
/// risk thresholds on the healthy trips.
///
/// `observer` sees each logged training point (progress, plots).
///
/// # Errors
/// [`Error::TooLittleMotion`](crate::Error::TooLittleMotion) and
/// [`Error::Unidentifiable`](crate::Error::Unidentifiable) when the data cannot determine the
/// model or calibrate the risk; [`Error::InvalidConfig`](crate::Error::InvalidConfig) for bad settings.
pub fn fit(
    series: &AlignedSeries,
    elevator: &Elevator,
    cfg: &TrainConfig,
    observer: &mut dyn FnMut(&train::TrainPoint),
) -> Result<FitOutcome> {
    let feature_cfg =
        crate::features::fit_load_cell(series, &FeatureConfig::for_elevator(elevator))?;
    let features = crate::features::extract(series, &feature_cfg);
    let prior = PhysParams::prior_centre(elevator);
    let (obs, _, n_rest) = train::observations_weighted(
        &features.rows,
        elevator.floors,
        cfg.standstill_share,
        prior.ke,
        0.005 * elevator.rated_voltage(),
    )?;
    let trained = train::train(&obs, elevator, cfg, observer)?;
    let mut summary = trained.summary;
    summary.standstill_samples = n_rest;
    let mut model = FittedModel {
        format_version: FORMAT_VERSION,
        elevator: elevator.clone(),
        parameters: trained.parameters,
        net: trained.net,
        scales: trained.scales,
        features: feature_cfg,
        risk: RiskConfig::default(),
        train: cfg.clone(),
        fit: summary,
    };
    let limits = BaselineLimits::calibrate(&model, &features.rows, BASELINE_MARGIN)?;
    let healthy_trips = crate::risk::trip_evidence(&model, &features.rows);
    model.risk = RiskConfig::calibrate(&healthy_trips, limits, &CalibrationSettings::default())?;
    Ok(FitOutcome {
        model,
        features,
        healthy_trips,
    })
}
