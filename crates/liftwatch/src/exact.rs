//! Serde for the floats of saved states: the shortest decimal that parses back to the same
//! bits, written as a string, so that NaN survives JSON and no parser rounds the last digit.
//! A resumed run must give exactly the rows of one uninterrupted run, so every `f64` a monitor
//! state carries goes through here (`#[serde(with = "crate::exact")]`).
//!
//! Reading is lenient: the string form, a plain JSON number, or `null` (NaN).

use serde::de::Error as _;
use serde::{Deserialize, Deserializer, Serializer};

/// One float as it may appear in a state document.
#[derive(Deserialize)]
#[serde(untagged)]
enum Repr {
    Text(String),
    Number(f64),
}

fn parse<E: serde::de::Error>(repr: Option<Repr>) -> Result<f64, E> {
    match repr {
        None => Ok(f64::NAN),
        Some(Repr::Number(x)) => Ok(x),
        Some(Repr::Text(t)) => t
            .parse()
            .map_err(|_| E::custom(format!("`{t}` is not a number"))),
    }
}

/// NaN: the default of a float a document written before it was kept lacks
/// (`#[serde(default = "crate::exact::nan")]`).
pub fn nan() -> f64 {
    f64::NAN
}

/// Three NaNs: the default of a per-mode array a document written before it was kept lacks
/// (`#[serde(with = "crate::exact::array", default = "crate::exact::nan_array")]`).
pub fn nan_array() -> [f64; 3] {
    [f64::NAN; 3]
}

/// Writes `x` as its shortest round-trip decimal string.
///
/// # Errors
/// The serializer's error.
pub fn serialize<S: Serializer>(x: &f64, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&format!("{x:?}"))
}

/// Reads a float written by [`serialize`], a number or `null`.
///
/// # Errors
/// A string that is not a number.
pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    parse(Option::<Repr>::deserialize(d)?)
}

/// The same for fixed-size arrays.
pub mod array {
    use super::*;

    /// Writes each element as [`super::serialize`] does.
    ///
    /// # Errors
    /// The serializer's error.
    pub fn serialize<S: Serializer, const N: usize>(x: &[f64; N], s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(x.iter().map(|v| format!("{v:?}")))
    }

    /// Reads exactly `N` floats.
    ///
    /// # Errors
    /// An element that is not a number, or another count.
    pub fn deserialize<'de, D: Deserializer<'de>, const N: usize>(
        d: D,
    ) -> Result<[f64; N], D::Error> {
        let v = Vec::<Option<Repr>>::deserialize(d)?;
        let parsed = v
            .into_iter()
            .map(parse)
            .collect::<Result<Vec<f64>, D::Error>>()?;
        let n = parsed.len();
        parsed
            .try_into()
            .map_err(|_| D::Error::custom(format!("expected {N} numbers, found {n}")))
    }
}

#[cfg(test)]
mod tests {
    use serde::{Deserialize, Serialize};

    #[derive(Debug, PartialEq, Serialize, Deserialize)]
    struct Doc {
        #[serde(with = "crate::exact")]
        x: f64,
        #[serde(with = "crate::exact::array")]
        a: [f64; 2],
    }

    #[test]
    fn every_bit_pattern_and_nan_survive_a_round_trip() {
        for x in [0.1 + 0.2, -0.0, 1e-308, f64::MAX, 5e-324] {
            let doc = Doc { x, a: [x, -x] };
            let back: Doc = serde_json::from_str(&serde_json::to_string(&doc).unwrap()).unwrap();
            assert_eq!(back.x.to_bits(), x.to_bits());
            assert_eq!(back.a[1].to_bits(), (-x).to_bits());
        }
        let nan: Doc = serde_json::from_str(r#"{"x":"NaN","a":[null,1.5]}"#).unwrap();
        assert!(nan.x.is_nan() && nan.a[0].is_nan() && nan.a[1] == 1.5);
    }

    #[test]
    fn a_word_or_a_wrong_count_is_refused() {
        assert!(serde_json::from_str::<Doc>(r#"{"x":"fast","a":[1,2]}"#).is_err());
        assert!(serde_json::from_str::<Doc>(r#"{"x":1,"a":[1,2,3]}"#).is_err());
    }
}
