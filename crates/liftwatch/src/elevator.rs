//! The elevator description `elevator.toml` (DATA.md §3) and the prior knowledge derived from it.
//!
//! Only the rated values are required. Every optional key has a default derived from them,
//! documented on its field; the fit uses these as the centres of wide priors, never as
//! fixed values.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// Standard gravity (m/s²).
pub const G: f64 = 9.81;

/// Longest `name` or `id` (characters): a label for a screen, far below the model file's
/// own string limit.
pub const MAX_LABEL_CHARS: usize = 200;

/// A traction elevator as described by its owner.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Elevator {
    /// Rated load M_r (kg).
    pub rated_load_kg: f64,
    /// Rated speed (m/s).
    pub rated_speed_mps: f64,
    /// Number of floors served.
    pub floors: u32,
    /// Empty car mass (kg); default 1.2 × rated load.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub car_mass_kg: Option<f64>,
    /// Counterweight balance ratio q: counterweight = car + q·M_r; default 0.45.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub counterweight_ratio: Option<f64>,
    /// Motor voltage at rated speed (V); default 380.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rated_voltage_v: Option<f64>,
    /// Typical floor height (m); default 3.0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub floor_height_m: Option<f64>,
    /// A name for people, any text (`"Lift A"`); carried into the model and the events.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// An identifier for machines (an asset number); carried into the model and the events.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub id: Option<String>,
    /// The local time of the site as a fixed UTC offset, `"+01:00"`, `"-05:30"` or `"UTC"`:
    /// RFC 3339 times are written at it. No time-zone database is built in, so a name such as
    /// `"Europe/Berlin"` is refused and summer time is not followed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub timezone: Option<String>,
}

impl Elevator {
    /// An elevator with only the rated values set; every other value takes its default.
    pub fn new(rated_load_kg: f64, rated_speed_mps: f64, floors: u32) -> Self {
        Elevator {
            rated_load_kg,
            rated_speed_mps,
            floors,
            car_mass_kg: None,
            counterweight_ratio: None,
            rated_voltage_v: None,
            floor_height_m: None,
            name: None,
            id: None,
            timezone: None,
        }
    }

    /// Reads and validates `elevator.toml`.
    ///
    /// # Errors
    /// [`Error::Io`] when the file cannot be read, [`Error::Elevator`] when it is not valid
    /// TOML, lacks a rated value or holds an implausible one.
    pub fn from_toml_file(path: &Path) -> Result<Self> {
        let text = crate::limits::read_bounded_text(
            path,
            crate::limits::MAX_TOML_BYTES,
            "elevator description",
        )?;
        Self::from_toml_str(&text).map_err(|why| Error::Elevator {
            path: path.into(),
            why,
        })
    }

    /// Parses and validates an elevator description; the error is a one-line reason.
    ///
    /// # Errors
    /// A message naming the offending key when the text is not a valid description.
    pub fn from_toml_str(text: &str) -> std::result::Result<Self, String> {
        let e: Elevator = toml::from_str(text).map_err(|e| e.message().replace('\n', " "))?;
        e.validate()?;
        Ok(e)
    }

    /// Writes the description as TOML.
    pub fn to_toml_string(&self) -> String {
        let mut s = format!(
            "rated_load_kg = {:?}\nrated_speed_mps = {:?}\nfloors = {}\n",
            self.rated_load_kg, self.rated_speed_mps, self.floors
        );
        for (k, v) in [
            ("car_mass_kg", self.car_mass_kg),
            ("counterweight_ratio", self.counterweight_ratio),
            ("rated_voltage_v", self.rated_voltage_v),
            ("floor_height_m", self.floor_height_m),
        ] {
            if let Some(v) = v {
                s.push_str(&format!("{k} = {v:?}\n"));
            }
        }
        for (k, v) in [
            ("name", &self.name),
            ("id", &self.id),
            ("timezone", &self.timezone),
        ] {
            if let Some(v) = v {
                // A JSON string is a TOML basic string: the same quotes and escapes.
                let quoted = serde_json::to_string(v).expect("a string always serialises");
                s.push_str(&format!("{k} = {quoted}\n"));
            }
        }
        s
    }

    /// Checks every value against a physically plausible range.
    ///
    /// # Errors
    /// A message naming the first key out of range.
    pub fn validate(&self) -> std::result::Result<(), String> {
        let check = crate::error::check_range;
        check("rated_load_kg", self.rated_load_kg, 100.0, 10_000.0)?;
        check("rated_speed_mps", self.rated_speed_mps, 0.1, 12.0)?;
        check("floors", f64::from(self.floors), 2.0, 200.0)?;
        if let Some(v) = self.car_mass_kg {
            check("car_mass_kg", v, 50.0, 20_000.0)?;
        }
        if let Some(v) = self.counterweight_ratio {
            check("counterweight_ratio", v, 0.0, 1.0)?;
        }
        if let Some(v) = self.rated_voltage_v {
            check("rated_voltage_v", v, 10.0, 2_000.0)?;
        }
        if let Some(v) = self.floor_height_m {
            check("floor_height_m", v, 1.5, 20.0)?;
        }
        for (k, v) in [("name", &self.name), ("id", &self.id)] {
            if let Some(v) = v {
                if v.chars().count() > MAX_LABEL_CHARS || v.chars().any(char::is_control) {
                    return Err(format!(
                        "`{k}` must be at most {MAX_LABEL_CHARS} characters without line breaks or control characters"
                    ));
                }
            }
        }
        self.utc_offset_s()?;
        Ok(())
    }

    /// The site's UTC offset (s) from `timezone`; 0 (UTC) when it is not given.
    ///
    /// # Errors
    /// A message naming `timezone` when it is neither `UTC`, `Z` nor `±HH:MM` within ±18 h.
    pub fn utc_offset_s(&self) -> std::result::Result<i32, String> {
        let Some(tz) = self.timezone.as_deref() else {
            return Ok(0);
        };
        parse_utc_offset(tz).ok_or_else(|| {
            format!(
                "`timezone` `{}`: expected a fixed offset such as \"+01:00\" or \"UTC\" (no time-zone database is built in)",
                tz.chars().take(40).collect::<String>()
            )
        })
    }

    /// The label of the elevator for people: `name`, else `id`, else none.
    pub fn label(&self) -> Option<&str> {
        self.name.as_deref().or(self.id.as_deref())
    }

    /// Empty car mass (kg).
    pub fn car_mass(&self) -> f64 {
        self.car_mass_kg.unwrap_or(1.2 * self.rated_load_kg)
    }

    /// Counterweight balance ratio q.
    pub fn counterweight_ratio(&self) -> f64 {
        self.counterweight_ratio.unwrap_or(0.45)
    }

    /// Motor voltage at rated speed (V).
    pub fn rated_voltage(&self) -> f64 {
        self.rated_voltage_v.unwrap_or(380.0)
    }

    /// Typical floor height (m).
    pub fn floor_height(&self) -> f64 {
        self.floor_height_m.unwrap_or(3.0)
    }

    /// Expected unbalanced mass with an empty car, Δm = −q·M_r (kg).
    pub fn expected_delta_m(&self) -> f64 {
        -self.counterweight_ratio() * self.rated_load_kg
    }

    /// Expected moving mass M0 with an empty car, rotating inertia included (kg):
    /// car + counterweight + ropes and sheave as about 15 % of those.
    pub fn expected_m0(&self) -> f64 {
        let car = self.car_mass();
        let cw = car + self.counterweight_ratio() * self.rated_load_kg;
        1.15 * (car + cw)
    }
}

/// `UTC`, `Z`, `+HH:MM` or `-HH:MM` (within ±18 h, RFC 3339's range) as seconds east of UTC.
fn parse_utc_offset(tz: &str) -> Option<i32> {
    if tz.eq_ignore_ascii_case("utc") || tz == "Z" {
        return Some(0);
    }
    let (sign, rest) = match tz.as_bytes().first()? {
        b'+' => (1, &tz[1..]),
        b'-' => (-1, &tz[1..]),
        _ => return None,
    };
    let (h, m) = rest.split_once(':')?;
    if h.len() != 2 || m.len() != 2 {
        return None;
    }
    let (h, m): (i32, i32) = (h.parse().ok()?, m.parse().ok()?);
    (h <= 18 && m < 60 && h * 60 + m <= 18 * 60).then_some(sign * (h * 3600 + m * 60))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rated_values_alone_are_enough() {
        let e = Elevator::from_toml_str(
            "rated_load_kg = 1000.0\nrated_speed_mps = 1.75\nfloors = 26\n",
        )
        .unwrap();
        assert_eq!(e.floors, 26);
        assert!((e.expected_delta_m() + 450.0).abs() < 1e-9);
        assert_eq!(Elevator::from_toml_str(&e.to_toml_string()).unwrap(), e);
    }

    #[test]
    fn missing_or_implausible_values_are_refused() {
        assert!(
            Elevator::from_toml_str("rated_load_kg = 1000.0\nfloors = 26\n")
                .unwrap_err()
                .contains("rated_speed_mps")
        );
        let err =
            Elevator::from_toml_str("rated_load_kg = -5.0\nrated_speed_mps = 1.0\nfloors = 8\n")
                .unwrap_err();
        assert!(err.contains("rated_load_kg"), "{err}");
        assert!(Elevator::from_toml_str(
            "rated_load_kg = 1000.0\nrated_speed_mps = 1.0\nfloors = 8\nspeed = 3\n"
        )
        .is_err());
    }

    #[test]
    fn a_name_id_and_fixed_offset_are_kept_and_round_trip() {
        let text = "name = \"Lift A\"\nid = \"B-7/2\"\ntimezone = \"+01:00\"\nrated_load_kg = 1000.0\nrated_speed_mps = 1.75\nfloors = 26\n";
        let e = Elevator::from_toml_str(text).unwrap();
        assert_eq!(e.name.as_deref(), Some("Lift A"));
        assert_eq!(e.label(), Some("Lift A"));
        assert_eq!(e.utc_offset_s(), Ok(3600));
        assert_eq!(Elevator::from_toml_str(&e.to_toml_string()).unwrap(), e);
        for (tz, off) in [
            ("UTC", Some(0)),
            ("-05:30", Some(-19_800)),
            ("+18:00", Some(64_800)),
        ] {
            assert_eq!(parse_utc_offset(tz), off, "{tz}");
        }
        for tz in ["Europe/Berlin", "+1:00", "+19:00", "01:00", ""] {
            assert_eq!(parse_utc_offset(tz), None, "{tz}");
        }
        let berlin = text.replace("+01:00", "Europe/Berlin");
        let err = Elevator::from_toml_str(&berlin).unwrap_err();
        assert!(
            err.contains("`timezone`") && err.contains("no time-zone database"),
            "{err}"
        );
        let two_lines = text.replace("Lift A", "Lift\\nA");
        assert!(Elevator::from_toml_str(&two_lines)
            .unwrap_err()
            .contains("`name`"));
    }
}
