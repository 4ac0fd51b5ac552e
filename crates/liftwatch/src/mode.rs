//! The one fault-mode vocabulary (paper, Sec. 5.3; DATA.md §4), shared by every stage that
//! names a fault: the risk stage's per-mode signatures, the levels and events, the baseline,
//! the simulator's scenarios and the evaluation's ground truth.
//!
//! ```text
//! motor     drive degradation: Kd up, a load-proportional voltage rise
//! brake     brake drag: a voltage rise going down or decelerating only
//! friction  guide-rail / lubrication degradation: more force in both directions
//! sensor    the data, not the machine, look wrong
//! unknown   evidence that no signature explains clearly
//! door      the doors: cycles slower or reopening more than the healthy reference
//! ```
//!
//! `door` is a subsystem of its own beside the machine (DATA.md §4): its advisory comes from
//! [`crate::operation`]'s door check, never from the machine risk, and it neither raises nor
//! lowers the machine's level.
//!
//! The three machine modes index the per-mode arrays of the risk stage
//! (`risk_modes[FaultMode::Motor as usize]`), in the order of [`MACHINE_MODES`].

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// What the evidence points at, or what a simulated run really has (DATA.md §4).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FaultMode {
    /// Drive degradation: Kd up, a load-proportional voltage rise.
    Motor = 0,
    /// Brake drag: a voltage rise going down or decelerating only.
    Brake = 1,
    /// Guide-rail or lubrication degradation: more force in both directions.
    Friction = 2,
    /// The data, not the machine, look wrong.
    Sensor = 3,
    /// No mode clearly dominates.
    #[default]
    Unknown = 4,
    /// The doors: cycles slower or reopening more than the healthy reference.
    Door = 5,
}

/// Number of machine fault modes with a physical signature: motor, brake, friction.
pub const N_MODES: usize = 3;

/// The machine modes in the order of the per-mode arrays.
pub const MACHINE_MODES: [FaultMode; N_MODES] =
    [FaultMode::Motor, FaultMode::Brake, FaultMode::Friction];

impl FaultMode {
    /// The name written in CSV, JSON and on the command line.
    pub fn as_str(self) -> &'static str {
        match self {
            FaultMode::Motor => "motor",
            FaultMode::Brake => "brake",
            FaultMode::Friction => "friction",
            FaultMode::Sensor => "sensor",
            FaultMode::Unknown => "unknown",
            FaultMode::Door => "door",
        }
    }

    /// The part of the installation the mode names, for people: `drive`, `brake`, …
    pub fn subsystem(self) -> &'static str {
        match self {
            FaultMode::Motor => "drive",
            FaultMode::Brake => "brake",
            FaultMode::Friction => "guide rails",
            FaultMode::Sensor => "sensors",
            FaultMode::Unknown => "machine (no single signature)",
            FaultMode::Door => "doors",
        }
    }

    /// What a maintenance engineer inspects when the evidence points at this mode.
    pub fn inspect(self) -> &'static str {
        match self {
            FaultMode::Motor => {
                "inspect the drive and the motor winding (resistance, connections, cooling)"
            }
            FaultMode::Brake => "inspect the brake: release, armature gap and lining",
            FaultMode::Friction => "inspect the guide rails and shoes: lubrication and alignment",
            FaultMode::Sensor => {
                "check the speed, load and floor sensors and their wiring: the data look wrong"
            }
            FaultMode::Unknown => {
                "inspect drive, brake and guides: the evidence fits no single signature yet"
            }
            FaultMode::Door => {
                "inspect the door operator: belt, track and rollers, the lock and the safety edge"
            }
        }
    }

    /// True for the three modes of the machine itself (not `sensor`, not `unknown`).
    pub fn is_machine(self) -> bool {
        (self as usize) < N_MODES
    }
}

impl std::fmt::Display for FaultMode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl std::str::FromStr for FaultMode {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self> {
        [
            FaultMode::Motor,
            FaultMode::Brake,
            FaultMode::Friction,
            FaultMode::Sensor,
            FaultMode::Unknown,
            FaultMode::Door,
        ]
        .into_iter()
        .find(|m| m.as_str() == s)
        .ok_or_else(|| Error::InvalidConfig {
            field: "mode",
            why: format!("`{s}`, expected motor, brake, friction, sensor, unknown or door"),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn machine_modes_index_their_arrays_in_order() {
        for (i, m) in MACHINE_MODES.iter().enumerate() {
            assert_eq!(*m as usize, i);
            assert!(m.is_machine());
        }
        assert!(!FaultMode::Sensor.is_machine() && !FaultMode::Unknown.is_machine());
        assert!(!FaultMode::Door.is_machine());
    }

    #[test]
    fn names_round_trip_through_text_and_json() {
        for m in [
            FaultMode::Motor,
            FaultMode::Sensor,
            FaultMode::Unknown,
            FaultMode::Door,
        ] {
            assert_eq!(m.as_str().parse::<FaultMode>().unwrap(), m);
            assert_eq!(serde_json::to_string(&m).unwrap(), format!("\"{m}\""));
        }
        assert!("healthy".parse::<FaultMode>().is_err());
    }
}
