//! Simulator: degradation scenarios and sensor faults (paper, Sec. 5.3).
//!
//! ```text
//! σ(t) = 0                                   t < onset
//!      = S·r((t − onset)/(full − onset))     onset ≤ t < full,   r = ramp shape
//!      = S                                   t ≥ full
//! step:        r(u) = 1
//! linear:      r(u) = u
//! exponential: r(u) = (e^{3u} − 1)/(e^3 − 1)   slow start, accelerating wear
//!
//! motor:    Kd    ← Kd·(1 + 0.10·σ)          winding resistance up / torque constant down
//! friction: F_c, c ← (1 + 0.25·σ)·(F_c, c)   guide-rail lubrication lost, both directions
//! brake:    F_brake = 0.6·σ·F_c·w·s          w = 1 down, 0.6 decelerating up, 0.2 otherwise
//! ```
//!
//! Full severity (σ = 1) is the default effect size of each mode. The sizes are chosen
//! to be maintenance-relevant yet not trivially visible at 1 Hz:
//! - motor +10 % Kd: a winding hot spot or demagnetisation that raises copper losses by a
//!   tenth shifts the voltage by only ~0.5 % of rated (Kd·F is ~7 % of it), below the 1 V
//!   noise on many single samples.
//! - friction +25 %: loss of guide-rail lubrication raises sliding friction by a quarter
//!   or more (dry vs. lubricated steel shoes), in both travel directions.
//! - brake 0.6·F_c: a dragging brake (weak release, worn armature gap) rubs with a force
//!   of the order of the guide friction, ~1 % of the suspended weight, which dissipates
//!   ~0.5 kW while moving and overheats the lining within weeks. In conventional drives
//!   the shoes sit closest to the drum in downward and decelerating travel (the paper's
//!   direction-asymmetric signature), hence the weights w.

use crate::sample::DAY_S;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::ingest::Signal;
use crate::mode::FaultMode;

/// The name of a run's truth: `healthy` for none, else the mode's (`motor`, `brake`, …);
/// the word `truth.json`, `evaluation.json` and the command line use.
pub fn truth_name(mode: Option<FaultMode>) -> &'static str {
    mode.map_or("healthy", FaultMode::as_str)
}

/// Parses a scenario name of the command line: `healthy` (None), `motor`, `brake` or
/// `friction`.
///
/// # Errors
/// [`Error::InvalidConfig`] for any other name, `sensor` and `unknown` included.
pub fn parse_scenario(s: &str) -> Result<Option<FaultMode>> {
    match s {
        "healthy" => Ok(None),
        "motor" => Ok(Some(FaultMode::Motor)),
        "brake" => Ok(Some(FaultMode::Brake)),
        "friction" => Ok(Some(FaultMode::Friction)),
        _ => Err(Error::InvalidConfig {
            field: "scenario",
            why: format!("`{s}` is not a scenario, expected healthy, motor, brake or friction"),
        }),
    }
}

/// Serde of an `Option<FaultMode>` truth as one name ([`truth_name`]): `healthy` for None.
/// Use as `#[serde(with = "crate::sim::scenario::healthy_or_mode")]`.
pub mod healthy_or_mode {
    use serde::{de::Error as _, Deserialize, Deserializer, Serializer};

    use super::{truth_name, FaultMode};

    /// Writes [`truth_name`].
    ///
    /// # Errors
    /// The serializer's.
    pub fn serialize<S: Serializer>(mode: &Option<FaultMode>, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(truth_name(*mode))
    }

    /// Reads `healthy` as None, a [`FaultMode`] name as that mode.
    ///
    /// # Errors
    /// Any other name.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<FaultMode>, D::Error> {
        let name = String::deserialize(d)?;
        if name == "healthy" {
            return Ok(None);
        }
        name.parse().map(Some).map_err(D::Error::custom)
    }
}

/// How severity grows from onset to full.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Ramp {
    /// Full severity at onset.
    Step,
    /// Linear growth to full severity.
    Linear,
    /// Slow start, accelerating growth: (e^{3u} − 1)/(e^3 − 1).
    Exponential,
}

impl std::str::FromStr for Ramp {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "step" => Ok(Ramp::Step),
            "linear" => Ok(Ramp::Linear),
            "exponential" => Ok(Ramp::Exponential),
            _ => Err(Error::InvalidConfig {
                field: "ramp",
                why: format!("`{s}` is not a ramp, expected step, linear or exponential"),
            }),
        }
    }
}

/// A machine degradation with its timing and size.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Scenario {
    /// Which degradation: a machine mode of [`FaultMode`], None when healthy (written
    /// `healthy`).
    #[serde(with = "healthy_or_mode")]
    pub mode: Option<FaultMode>,
    /// Onset time (s, same clock as the telemetry).
    pub onset_s: f64,
    /// Shape of the growth.
    pub ramp: Ramp,
    /// Time at which full severity is reached (s); equal to `onset_s` for a step.
    pub full_at_s: f64,
    /// Severity S reached at `full_at_s`, as a multiple of the mode's default effect.
    pub severity: f64,
    /// Relative Kd increase at σ = 1 for `motor` (default 0.10).
    pub motor_kd_gain: f64,
    /// Relative F_c and c increase at σ = 1 for `friction` (default 0.25).
    pub friction_gain: f64,
    /// Brake drag as a fraction of F_c at σ = 1 for `brake` (default 0.6).
    pub brake_drag_ratio: f64,
}

/// The degradation's effect on the plant at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Effects {
    /// σ: severity now (0 before onset).
    pub severity: f64,
    /// Multiplier of Kd (1 when healthy).
    pub kd_factor: f64,
    /// Multiplier of F_c and c (1 when healthy).
    pub friction_factor: f64,
    /// Brake drag before the directional weight (N).
    pub brake_drag_n: f64,
}

impl Scenario {
    /// No degradation at all.
    pub fn healthy() -> Self {
        Scenario {
            mode: None,
            onset_s: f64::INFINITY,
            ramp: Ramp::Step,
            full_at_s: f64::INFINITY,
            severity: 0.0,
            motor_kd_gain: 0.10,
            friction_gain: 0.25,
            brake_drag_ratio: 0.6,
        }
    }

    /// A degradation of the machine mode `mode` with explicit timing and severity.
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] when `mode` is not a machine mode (`sensor`, `unknown`), the
    /// times are not finite, full comes before onset or the severity is negative.
    pub fn new(
        mode: FaultMode,
        onset_s: f64,
        ramp: Ramp,
        full_at_s: f64,
        severity: f64,
    ) -> Result<Self> {
        if !mode.is_machine() {
            return Err(Error::InvalidConfig {
                field: "scenario",
                why: format!(
                    "`{mode}` is not a machine degradation, expected motor, brake or friction"
                ),
            });
        }
        let full_at_s = ramp_timing(
            ("onset_s", "full severity"),
            onset_s,
            ramp,
            full_at_s,
            severity,
        )?;
        Ok(Scenario {
            mode: Some(mode),
            onset_s,
            ramp,
            full_at_s,
            severity,
            ..Scenario::healthy()
        })
    }

    /// The training-friendly default over a run starting at `start_s` and lasting `span_s`:
    /// onset at 40 % of the span, linear growth to full severity (1) at the end.
    pub fn spread_over(mode: FaultMode, start_s: f64, span_s: f64) -> Self {
        Scenario::new(
            mode,
            start_s + 0.4 * span_s,
            Ramp::Linear,
            start_s + span_s,
            1.0,
        )
        .unwrap_or_else(|_| Scenario::healthy())
    }

    /// σ(t): the severity at time `t`.
    pub fn severity_at(&self, t: f64) -> f64 {
        if self.mode.is_none() || t < self.onset_s {
            return 0.0;
        }
        if t >= self.full_at_s || self.full_at_s <= self.onset_s {
            return self.severity;
        }
        let u = (t - self.onset_s) / (self.full_at_s - self.onset_s);
        let r = match self.ramp {
            Ramp::Step => 1.0,
            Ramp::Linear => u,
            Ramp::Exponential => ((3.0 * u).exp() - 1.0) / (3.0f64.exp() - 1.0),
        };
        self.severity * r
    }

    /// The effect on the plant at time `t`, for a plant whose nominal Coulomb friction is `f_c` (N).
    pub fn effects_at(&self, t: f64, f_c: f64) -> Effects {
        let sigma = self.severity_at(t);
        let mut e = Effects {
            severity: sigma,
            kd_factor: 1.0,
            friction_factor: 1.0,
            brake_drag_n: 0.0,
        };
        match self.mode {
            Some(FaultMode::Motor) => e.kd_factor += self.motor_kd_gain * sigma,
            Some(FaultMode::Friction) => e.friction_factor += self.friction_gain * sigma,
            Some(FaultMode::Brake) => e.brake_drag_n = self.brake_drag_ratio * sigma * f_c,
            // Healthy; `new` refuses the modes that are not the machine's.
            None | Some(FaultMode::Sensor | FaultMode::Unknown | FaultMode::Door) => {}
        }
        e
    }
}

/// Checks the timing of a degradation that starts at `onset_s` and reaches full `severity` at
/// `full_at_s` along `ramp`, and returns the effective full time (a step is full at its onset).
/// `(field, full)` name the onset's field and what "full" is in the message (a machine's full
/// severity, a door's full wear).
///
/// # Errors
/// [`Error::InvalidConfig`] for times that are not finite or out of order, or a severity that
/// is negative or not finite.
pub(crate) fn ramp_timing(
    (field, full): (&'static str, &str),
    onset_s: f64,
    ramp: Ramp,
    full_at_s: f64,
    severity: f64,
) -> Result<f64> {
    if !onset_s.is_finite() || !full_at_s.is_finite() || full_at_s < onset_s {
        return Err(Error::InvalidConfig {
            field,
            why: format!(
                "onset {onset_s} s and {full} at {full_at_s} s must be finite and in order"
            ),
        });
    }
    if !(severity.is_finite() && severity >= 0.0) {
        return Err(Error::InvalidConfig {
            field: "severity",
            why: format!("{severity} must be >= 0"),
        });
    }
    Ok(if ramp == Ramp::Step {
        onset_s
    } else {
        full_at_s
    })
}

/// Brake drag weight w by travel: 1 downward, 0.6 decelerating upward, 0.2 otherwise.
pub fn brake_weight(s: i8, accel: f64) -> f64 {
    if s < 0 {
        1.0
    } else if s > 0 && accel < 0.0 {
        0.6
    } else if s > 0 {
        0.2
    } else {
        0.0
    }
}

/// A sensor fault: the data, not the machine, goes wrong (for the `sensor` attribution).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum SensorFault {
    /// The load cell's zero drifts from `onset_s` at `pct_per_day` percent of rated load per day.
    LoadDrift {
        /// Onset (s).
        onset_s: f64,
        /// Drift rate (% of rated load per day).
        pct_per_day: f64,
    },
    /// The speed reading freezes at its value from `onset_s` for `duration_s`.
    StuckSpeed {
        /// Onset (s).
        onset_s: f64,
        /// How long it stays stuck (s).
        duration_s: f64,
    },
    /// The voltage sensor reads `volts` high from `onset_s` on, moving or not (a shifted
    /// transducer zero, a ground loop).
    VoltageOffset {
        /// Onset (s).
        onset_s: f64,
        /// The offset (V).
        volts: f64,
    },
}

/// The voltage-sensor offset of the evaluation and of `simulate --sensor-fault
/// voltage-offset` (V): 25 V, the size the independent test bench used, 5-10 % of a traction
/// drive's voltage at rated speed.
pub const VOLTAGE_OFFSET_V: f64 = 25.0;

impl SensorFault {
    /// Load-cell offset (% of rated) at time `t`: zero unless a drifting load cell.
    pub fn load_offset_pct(&self, t: f64) -> f64 {
        match *self {
            SensorFault::LoadDrift {
                onset_s,
                pct_per_day,
            } if t > onset_s => pct_per_day * (t - onset_s) / DAY_S,
            _ => 0.0,
        }
    }

    /// When the fault begins (s).
    pub fn onset_s(&self) -> f64 {
        match *self {
            SensorFault::LoadDrift { onset_s, .. }
            | SensorFault::StuckSpeed { onset_s, .. }
            | SensorFault::VoltageOffset { onset_s, .. } => onset_s,
        }
    }

    /// The channel the fault breaks.
    pub fn channel(&self) -> Signal {
        match self {
            SensorFault::LoadDrift { .. } => Signal::Load,
            SensorFault::StuckSpeed { .. } => Signal::Speed,
            SensorFault::VoltageOffset { .. } => Signal::Voltage,
        }
    }

    /// Voltage-sensor offset (V) at time `t`: zero unless an offset voltage sensor.
    pub fn voltage_offset_v(&self, t: f64) -> f64 {
        match *self {
            SensorFault::VoltageOffset { onset_s, volts } if t >= onset_s => volts,
            _ => 0.0,
        }
    }

    /// True while the speed reading is frozen.
    pub fn speed_stuck(&self, t: f64) -> bool {
        matches!(*self, SensorFault::StuckSpeed { onset_s, duration_s } if t >= onset_s && t < onset_s + duration_s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_ramp_starts_at_onset_and_reaches_severity_at_full() {
        let s = Scenario::new(FaultMode::Friction, 100.0, Ramp::Linear, 300.0, 0.8).unwrap();
        assert_eq!(s.severity_at(99.9), 0.0);
        assert!((s.severity_at(200.0) - 0.4).abs() < 1e-12);
        assert_eq!(s.severity_at(300.0), 0.8);
        assert_eq!(s.severity_at(1e9), 0.8);
        let e = s.effects_at(300.0, 400.0);
        assert!((e.friction_factor - 1.2).abs() < 1e-12);
        assert_eq!(e.kd_factor, 1.0);
    }

    #[test]
    fn exponential_ramp_lags_the_linear_one_and_step_jumps() {
        let e = Scenario::new(FaultMode::Motor, 0.0, Ramp::Exponential, 10.0, 1.0).unwrap();
        let l = Scenario::new(FaultMode::Motor, 0.0, Ramp::Linear, 10.0, 1.0).unwrap();
        for t in [1.0, 5.0, 9.0] {
            assert!(e.severity_at(t) < l.severity_at(t));
        }
        assert!((e.severity_at(10.0) - 1.0).abs() < 1e-12);
        let s = Scenario::new(FaultMode::Brake, 50.0, Ramp::Step, 80.0, 1.0).unwrap();
        assert_eq!(s.severity_at(50.0), 1.0);
        assert!((s.effects_at(60.0, 500.0).brake_drag_n - 300.0).abs() < 1e-9);
    }

    #[test]
    fn bad_timing_is_refused_and_names_are_parsed() {
        assert!(Scenario::new(FaultMode::Motor, 10.0, Ramp::Linear, 5.0, 1.0).is_err());
        assert!(Scenario::new(FaultMode::Motor, 0.0, Ramp::Linear, 5.0, -1.0).is_err());
        assert_eq!(parse_scenario("brake").unwrap(), Some(FaultMode::Brake));
        assert_eq!(parse_scenario("healthy").unwrap(), None);
        assert!(parse_scenario("rust").is_err() && parse_scenario("sensor").is_err());
        assert!(Scenario::new(FaultMode::Sensor, 0.0, Ramp::Step, 0.0, 1.0).is_err());
        assert_eq!(Scenario::healthy().severity_at(1e9), 0.0);
        let s = Scenario::spread_over(FaultMode::Motor, 0.0, 100.0);
        assert_eq!((s.onset_s, s.full_at_s), (40.0, 100.0));
    }

    #[test]
    fn truth_names_are_the_words_of_the_files() {
        let json = |m| {
            serde_json::to_string(&Scenario {
                mode: m,
                ..Scenario::healthy()
            })
            .unwrap()
        };
        assert!(json(None).starts_with(r#"{"mode":"healthy","#));
        let s = Scenario::new(FaultMode::Motor, 0.0, Ramp::Step, 0.0, 1.0).unwrap();
        let text = serde_json::to_string(&s).unwrap();
        assert!(text.starts_with(r#"{"mode":"motor","#), "{text}");
        assert_eq!(serde_json::from_str::<Scenario>(&text).unwrap(), s);
        assert_eq!(truth_name(Some(FaultMode::Sensor)), "sensor");
    }

    #[test]
    fn brake_drags_most_going_down_and_sensor_faults_act_after_onset() {
        assert!(brake_weight(-1, 0.5) > brake_weight(1, -0.5));
        assert!(brake_weight(1, -0.5) > brake_weight(1, 0.5));
        assert_eq!(brake_weight(0, 0.0), 0.0);
        let d = SensorFault::LoadDrift {
            onset_s: DAY_S,
            pct_per_day: 2.0,
        };
        assert_eq!(d.load_offset_pct(1000.0), 0.0);
        assert!((d.load_offset_pct(3.0 * DAY_S) - 4.0).abs() < 1e-12);
        let s = SensorFault::StuckSpeed {
            onset_s: 10.0,
            duration_s: 5.0,
        };
        assert!(!s.speed_stuck(9.0) && s.speed_stuck(12.0) && !s.speed_stuck(15.0));
    }
}
