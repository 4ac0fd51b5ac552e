//! The model file (DATA.md §5): one versioned JSON document holding everything `monitor` needs.
//!
//! A document of another version, with a missing field or with a value that cannot be a
//! model (a non-finite parameter, a network of the wrong size) is refused with a one-line error.
//!
//! The document keeps the layout of format version 1: the hybrid model's fields at the top
//! level, and the sensor limits, the baseline's limits and the calibration report inside
//! `risk`. In memory each belongs to its own stage ([`FittedModel`]); [`ModelDocument`] maps
//! one onto the other, so models written by earlier builds still load.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::baseline::BaselineLimits;
use crate::calibrate::CalibrationReport;
use crate::elevator::Elevator;
use crate::error::{Error, Result};
use crate::features::FeatureConfig;
use crate::fit::FittedModel;
use crate::model::net::N_WEIGHTS;
use crate::model::{FitSummary, HybridModel, PhysParams, ResidualNet, ResidualScales, TrainConfig};
use crate::output::write_atomic;
use crate::risk::RiskConfig;
use crate::sensor::SensorLimits;

/// Version of the model file this build writes and reads.
pub const FORMAT_VERSION: u32 = 1;

/// The model file as written: field names and order are the file format.
#[derive(Serialize, Deserialize)]
pub struct ModelDocument {
    format_version: u32,
    elevator: Elevator,
    parameters: PhysParams,
    net: ResidualNet,
    scales: ResidualScales,
    features: FeatureConfig,
    risk: RiskSection,
    train: TrainConfig,
    fit: FitSummary,
}

/// The `risk` object of the file: the risk settings with the other stages' limits inside.
#[derive(Serialize, Deserialize)]
struct RiskSection {
    #[serde(flatten)]
    settings: RiskConfig,
    sensor: SensorLimits,
    baseline: BaselineLimits,
    calibration: Option<CalibrationReport>,
}

impl From<FittedModel> for ModelDocument {
    fn from(m: FittedModel) -> Self {
        let HybridModel {
            elevator,
            parameters,
            net,
            scales,
        } = m.hybrid;
        ModelDocument {
            format_version: FORMAT_VERSION,
            elevator,
            parameters,
            net,
            scales,
            features: m.features,
            risk: RiskSection {
                settings: m.risk,
                sensor: m.sensor,
                baseline: m.baseline,
                calibration: m.calibration,
            },
            train: m.train,
            fit: m.summary,
        }
    }
}

impl From<ModelDocument> for FittedModel {
    fn from(d: ModelDocument) -> Self {
        FittedModel {
            hybrid: HybridModel {
                elevator: d.elevator,
                parameters: d.parameters,
                net: d.net,
                scales: d.scales,
            },
            features: d.features,
            risk: d.risk.settings,
            sensor: d.risk.sensor,
            baseline: d.risk.baseline,
            calibration: d.risk.calibration,
            train: d.train,
            summary: d.fit,
        }
    }
}

/// Writes the model atomically (see [`write_atomic`]).
///
/// # Errors
/// [`Error::Io`] when the file cannot be written.
pub fn save(path: &Path, model: &FittedModel) -> Result<()> {
    let text = serde_json::to_string_pretty(model).map_err(|e| Error::BadDocument {
        path: path.into(),
        what: "model",
        why: e.to_string(),
    })?;
    write_atomic(path, text.as_bytes())
}

/// Reads and checks a model file.
///
/// # Errors
/// [`Error::Io`] when it cannot be read, [`Error::ModelVersion`] for another format version,
/// [`Error::BadDocument`] when it is not a complete, sane model.
pub fn load(path: &Path) -> Result<FittedModel> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    load_str(&text, path)
}

/// Reads and checks a model document held in memory, as [`load`] does; `path` names it in
/// messages.
///
/// # Errors
/// [`Error::ModelVersion`] for another format version, [`Error::BadDocument`] when it is not
/// a complete, sane model.
pub fn load_str(text: &str, path: &Path) -> Result<FittedModel> {
    parse(text).map_err(|e| match e {
        ParseError::Version(found) => Error::ModelVersion {
            path: path.into(),
            found,
            supported: FORMAT_VERSION,
        },
        ParseError::Bad(why) => Error::BadDocument {
            path: path.into(),
            what: "liftwatch model",
            why,
        },
    })
}

enum ParseError {
    Version(u32),
    Bad(String),
}

fn parse(text: &str) -> std::result::Result<FittedModel, ParseError> {
    let value: serde_json::Value =
        serde_json::from_str(text).map_err(|e| ParseError::Bad(e.to_string()))?;
    let version = value
        .get("format_version")
        .ok_or_else(|| ParseError::Bad("missing field `format_version`".into()))?
        .as_u64()
        .ok_or_else(|| ParseError::Bad("`format_version` is not a whole number".into()))?;
    if version != u64::from(FORMAT_VERSION) {
        return Err(ParseError::Version(
            u32::try_from(version).unwrap_or(u32::MAX),
        ));
    }
    let model: FittedModel =
        serde_json::from_value(value).map_err(|e| ParseError::Bad(e.to_string()))?;
    check(&model).map_err(ParseError::Bad)?;
    Ok(model)
}

fn check(m: &FittedModel) -> std::result::Result<(), String> {
    let m = &m.hybrid;
    m.elevator.validate()?;
    for (name, v) in PhysParams::NAMES.iter().zip(m.parameters.to_array()) {
        if !v.is_finite() {
            return Err(format!(
                "parameter `{name}` is {v}, expected a finite number"
            ));
        }
    }
    let p = &m.parameters;
    if !(p.kd > 0.0 && p.alpha_down > 0.0) {
        return Err("parameters `kd` and `alpha_down` must be positive".into());
    }
    if m.net.weights.len() != N_WEIGHTS || m.net.weights.iter().any(|w| !w.is_finite()) {
        return Err(format!(
            "network has {} weights, expected {N_WEIGHTS} finite numbers",
            m.net.weights.len()
        ));
    }
    if m.net
        .input_scale
        .iter()
        .chain(&m.net.output_scale)
        .any(|s| !(s.is_finite() && *s > 0.0))
    {
        return Err("network scales must be positive".into());
    }
    let s = &m.scales;
    if !(s.sigma_u_v > 0.0
        && s.sigma_f_n > 0.0
        && s.sigma_u_v.is_finite()
        && s.sigma_f_n.is_finite())
    {
        return Err("residual scales must be positive".into());
    }
    Ok(())
}
