//! The model file (DATA.md §5): one versioned JSON document holding everything `monitor` needs.
//!
//! A document of another version, with a missing field or with a value that cannot be a
//! model (a non-finite parameter, a network of the wrong size) is refused with a one-line error.

use std::io::Write;
use std::path::Path;

use crate::error::{Error, Result};
use crate::model::net::N_WEIGHTS;
use crate::model::{FittedModel, FORMAT_VERSION};

/// Writes the model atomically: a temporary file beside `path`, renamed on success.
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

/// Writes `bytes` to a temporary file beside `path` and renames it into place, so that a failed
/// run never leaves a half-written file behind.
///
/// # Errors
/// [`Error::Io`] when the file cannot be written.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let tmp = dir.join(format!(".{name}.tmp{}", std::process::id()));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    result.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        Error::io(path, e)
    })
}

/// Reads and checks a model file.
///
/// # Errors
/// [`Error::Io`] when it cannot be read, [`Error::ModelVersion`] for another format version,
/// [`Error::BadDocument`] when it is not a complete, sane model.
pub fn load(path: &Path) -> Result<FittedModel> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    parse(&text).map_err(|e| match e {
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
    m.elevator.validate()?;
    for (name, v) in crate::model::PhysParams::NAMES
        .iter()
        .zip(m.parameters.to_array())
    {
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
