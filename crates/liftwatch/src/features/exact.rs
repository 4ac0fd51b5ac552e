//! Stage 3, the tracker's saved state: serde for its f64 fields (paper, Sec. 4.1).
//!
//! ```text
//! write  x -> "{x:?}"                 the shortest decimal that parses back to the same bits
//! read   "1.25" | 1.25 -> 1.25        a string or a number
//!        "NaN" | null  -> NaN         NaN survives JSON, and no parser rounds a value
//! ```
//!
//! Used as `#[serde(with = "exact")]` on the fields of [`FeatureTracker`](super::FeatureTracker)
//! and its parts, so a monitor that stops after one file and resumes on the next gives the
//! rows of one run bit for bit.

use serde::{Deserialize, Deserializer, Serializer};

#[derive(Deserialize)]
#[serde(untagged)]
enum Repr {
    Text(String),
    Number(f64),
}

pub fn serialize<S: Serializer>(x: &f64, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&format!("{x:?}"))
}

pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    match Option::<Repr>::deserialize(d)? {
        None => Ok(f64::NAN),
        Some(Repr::Number(x)) => Ok(x),
        Some(Repr::Text(t)) => t
            .parse()
            .map_err(|_| serde::de::Error::custom(format!("`{t}` is not a number"))),
    }
}
