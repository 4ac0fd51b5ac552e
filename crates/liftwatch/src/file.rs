//! The model file (DATA.md §5): one versioned JSON document holding everything `monitor` needs.
//!
//! A document of another version, with a missing field or with a value that cannot be a
//! model (a non-finite parameter, a network of the wrong size) is refused with a one-line error.
//!
//! The document keeps the layout of format version 1: the hybrid model's fields at the top
//! level, and the sensor limits, the baseline's limits and the calibration report inside
//! `risk`. In memory each belongs to its own stage ([`FittedModel`]); `ModelDocument` maps
//! one onto the other, so models written by earlier builds still load.

use crate::sample::DAY_S;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::baseline::BaselineLimits;
use crate::calibrate::CalibrationReport;
use crate::elevator::Elevator;
use crate::error::{check_range, Error, Result};
use crate::features::FeatureConfig;
use crate::fit::{FittedModel, ReadFrom};
use crate::model::net::N_WEIGHTS;
use crate::model::{FitSummary, HybridModel, PhysParams, ResidualNet, ResidualScales, TrainConfig};
use crate::operation::OperationReference;
use crate::output::write_atomic;
use crate::risk::RiskConfig;
use crate::sensor::SensorLimits;

/// Version of the model file this build writes and reads.
pub const FORMAT_VERSION: u32 = 1;

/// The model file as written: field names and order are the file format.
#[derive(Serialize, Deserialize)]
struct ModelDocument {
    format_version: u32,
    elevator: Elevator,
    parameters: PhysParams,
    net: ResidualNet,
    scales: ResidualScales,
    features: FeatureConfig,
    risk: RiskSection,
    train: TrainConfig,
    fit: FitSummary,
    /// The aligned step of the training data (s); absent in files written before it was kept.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    step_s: Option<f64>,
    /// Trip rates, landings and the doors' reference (`crate::operation`); absent in files
    /// written before it was learnt (left out when absent, so such a model's identity, and
    /// the states saved with it, stay as they were).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    operation: Option<OperationReference>,
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
            step_s: m.step_s,
            operation: m.operation,
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
            step_s: d.step_s,
            operation: d.operation,
            read_from: ReadFrom::default(),
        }
    }
}

impl Serialize for FittedModel {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        ModelDocument::from(self.clone()).serialize(s)
    }
}

impl<'de> Deserialize<'de> for FittedModel {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        ModelDocument::deserialize(d).map(FittedModel::from)
    }
}

/// Writes the model atomically (see [`write_atomic`]), after the same checks a reader makes,
/// so no build writes a model that no build reads.
///
/// # Errors
/// [`Error::BadDocument`] for a model that fails the checks; [`Error::Io`] when the file
/// cannot be written.
pub fn save(path: &Path, model: &FittedModel) -> Result<()> {
    check(model).map_err(|why| Error::BadDocument {
        path: path.into(),
        what: "liftwatch model",
        why,
    })?;
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
    let text =
        crate::limits::read_bounded_text(path, crate::limits::MAX_MODEL_BYTES, "liftwatch model")?;
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
    // A byte-order mark, as an editor on Windows saves JSON, is not the document's.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
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
    // Before the typed parse, whose complaint would quote a long string instead of naming it.
    crate::limits::check_strings(&value, crate::limits::MAX_STRING_CHARS)
        .map_err(ParseError::Bad)?;
    let document = content_hash(&value);
    let mut model: FittedModel =
        serde_json::from_value(value).map_err(|e| ParseError::Bad(e.to_string()))?;
    check(&model).map_err(ParseError::Bad)?;
    model.read_from = ReadFrom(Some((document, own_hash(&model))));
    Ok(model)
}

/// The identity a monitor state records of its model (`MonitorState::model_id`), 16 hex digits:
/// the content of the document the model was read from, or, for a model made in memory or
/// changed since it was read, of the document it would be written as. The content is the
/// document's JSON values, not its text: key order and white space do not count (nor a float's
/// spelling: `1e3` is `1000.0`, though `1000` is an integer and another value), and a model
/// written by `fit` has the identity it had in memory. A state saved with a model file
/// therefore resumes with that file under any later build, even one that writes the same model
/// with a field more.
pub fn model_id(model: &FittedModel) -> String {
    let own = own_hash(model);
    let id = match model.read_from.0 {
        Some((document, read)) if read == own => document,
        _ => own,
    };
    format!("{id:016x}")
}

/// [`content_hash`] of the document `model` is written as.
fn own_hash(model: &FittedModel) -> u64 {
    let value =
        serde_json::to_value(model).expect("a model of numbers and names always serialises");
    content_hash(&value)
}

/// [`fnv1a`] over the compact JSON of `value`, whose objects keep their keys sorted (serde_json
/// without `preserve_order`) and whose numbers are written shortest: one text per content.
fn content_hash(value: &serde_json::Value) -> u64 {
    fnv1a(&serde_json::to_vec(value).expect("a JSON value always serialises"))
}

/// FNV-1a, 64 bits: the content key of model documents, here and in the fleet's model store
/// (a key, not a safeguard).
pub fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// Checks a parsed model for sense, not only syntax: every parameter and setting finite and
/// within a range derived from the elevator description (a finite but absurd value would make
/// the monitor blind or alarmed from the first trip, or a report's axis endless).
fn check(model: &FittedModel) -> std::result::Result<(), String> {
    let m = &model.hybrid;
    m.elevator.validate()?;
    check_parameters(&m.parameters, &m.elevator)?;
    if m.net.weights.len() != N_WEIGHTS || m.net.weights.iter().any(|w| !w.is_finite()) {
        return Err(format!(
            "network has {} weights, expected {N_WEIGHTS} finite numbers",
            m.net.weights.len()
        ));
    }
    if m.net.weights.iter().any(|w| w.abs() > MAX_WEIGHT) {
        return Err(format!(
            "a network weight exceeds {MAX_WEIGHT:e} in magnitude"
        ));
    }
    if let Some(d) = &m.net.domain {
        d.validate()?;
    }
    for &s in m.net.input_scale.iter().chain(&m.net.output_scale) {
        check_range("net scales", s, 1e-9, 1e9)
            .map_err(|_| "network scales must be positive".to_string())?;
    }
    let (volts, newtons) = scales_of(&m.elevator);
    check_range("scales.sigma_u_v", m.scales.sigma_u_v, 1e-9 * volts, volts)
        .map_err(|e| format!("residual scales must be positive: {e}"))?;
    check_range(
        "scales.sigma_f_n",
        m.scales.sigma_f_n,
        1e-9 * newtons,
        newtons,
    )
    .map_err(|e| format!("residual scales must be positive: {e}"))?;
    model.features.validate().map_err(|e| e.to_string())?;
    model.risk.validate().map_err(|e| e.to_string())?;
    model.sensor.validate()?;
    if let Some(op) = &model.operation {
        op.validate()?;
    }
    if let Some(step) = model.step_s {
        check_range("step_s", step, 1e-3, DAY_S)?;
    }
    model.baseline.validate()
}

/// Largest magnitude of a network weight: inputs and outputs are scaled to order one, so a
/// trained weight of a million is a corrupted file.
const MAX_WEIGHT: f64 = 1e6;

/// The voltage and force scales of an elevator: its rated voltage (V), and the weight of the
/// car with rated load (N), the largest force its drive plausibly sees.
fn scales_of(e: &Elevator) -> (f64, f64) {
    let weight = (e.car_mass() + e.rated_load_kg) * crate::elevator::G;
    (e.rated_voltage(), weight)
}

/// Each identified parameter within a plausible range of the described elevator; a fit that
/// ends outside one is refused when written, not only when read.
fn check_parameters(p: &PhysParams, e: &Elevator) -> std::result::Result<(), String> {
    for (name, v) in PhysParams::NAMES.iter().zip(p.to_array()) {
        if !v.is_finite() {
            return Err(format!(
                "parameter `{name}` is {v}, expected a finite number"
            ));
        }
    }
    if !(p.kd > 0.0 && p.alpha_down > 0.0) {
        return Err("parameters `kd` and `alpha_down` must be positive".into());
    }
    let (volts, newtons) = scales_of(e);
    let mass = e.car_mass() + e.rated_load_kg;
    // Generous bounds: ten times what a working drive of this description can show.
    let bound = PLAUSIBILITY_FACTOR;
    check_range("delta_m", p.delta_m, -bound * mass, bound * mass)?;
    check_range("m0", p.m0, -bound * mass, bound * bound * mass)?;
    check_range("m_rope", p.m_rope, -bound * mass, bound * mass)?;
    check_range("f_c", p.f_c, 0.0, bound * newtons)?;
    check_range("c_visc", p.c_visc, 0.0, bound * newtons / e.rated_speed_mps)?;
    check_range("kd", p.kd, 0.0, bound * volts / newtons)?;
    check_range("ke", p.ke, 0.0, bound * volts / e.rated_speed_mps)?;
    check_range("u0", p.u0, -bound * volts, bound * volts)?;
    check_range("alpha_down", p.alpha_down, 0.0, bound)?;
    // 1 ± ε is the resistive term's slope either way the power flows: both must be positive.
    check_range(
        "loss_asymmetry",
        p.loss_asymmetry,
        -crate::model::physics::EPS_MAX,
        crate::model::physics::EPS_MAX,
    )
}

/// How far beyond the elevator's own scales a parameter may lie before the file is refused.
const PLAUSIBILITY_FACTOR: f64 = 10.0;
