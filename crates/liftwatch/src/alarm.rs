//! Stage 7: levels, events and fault-mode attribution (paper, Sec. 4.3 and 5.3; DATA.md §4).
//!
//! ```text
//! q = max(R/advisory, G/h)                           G/h: the sequential decision's ratio
//! normal   → advisory   when q ≥ 1                 (schedule maintenance / inspect)
//! advisory → alarm      when R ≥ alarm             (intervention advised)
//! alarm    → advisory   when R < ρ·alarm           ρ = release ratio, e.g. 0.5
//! advisory → normal     when q < ρ
//! sensor:  advisory while the data, not the machine, look wrong
//! mode  = the sequential decision's mode while G/h ≥ ρ and it names one, else
//!         argmax_m R_m / A_m  when it is ≥ 0.5 and exceeds the runner-up by the dominance
//!         factor, else unknown
//! ```
//!
//! The advisory is decided by whichever detects first: the sequential test
//! ([`crate::risk::sequential`]), fastest for a change of a given size, or the accumulated
//! risk R, the paper's indicator. Alarm stays with R: it means a large, lasting deviation.
//!
//! The hysteresis band keeps a level from flickering while R hovers at a threshold: R decays
//! by γ per trip, so leaving a level takes a sustained return to healthy behaviour.
//!
//! Episodes: an episode is a stretch above `normal`. It takes its mode when it opens (`sensor`
//! when only the sensor override raised it), is named later when it opened as `unknown` and one
//! mode comes to dominate, and is named again on escalation; a channel fault that begins while
//! the machine holds an episode open turns it `sensor` until the fault ends, when it takes the
//! machine's mode again; each of these is an event ([`update_episode`]).
//!
//! Deviation from the paper: the paper leaves the warning rule open; here the thresholds are
//! calibrated to a stated false-alarm rate (see [`crate::calibrate`]).
//!
//! Acknowledgement: accumulated evidence is never reset by hand. After an inspection or a
//! repair the operator refits on fresh healthy data; the new model file carries a new
//! identity, so monitor states of the old model are refused and monitoring starts at R = 0
//! from the new healthy reference. A reset without a refit would only rebuild the same risk
//! from the same unrepaired drift.

use crate::sample::DAY_S;
use serde::{Deserialize, Serialize};

use crate::ingest::Signal;
use crate::mode::{MACHINE_MODES, N_MODES};
use crate::risk::{DriftScale, RiskConfig, TripAssessment};

// Indices of the per-mode arrays, in the order of `MACHINE_MODES`.
const MOTOR: usize = FaultMode::Motor as usize;
const BRAKE: usize = FaultMode::Brake as usize;
const FRICTION: usize = FaultMode::Friction as usize;

/// Health level of the elevator (DATA.md §4).
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
#[serde(rename_all = "lowercase")]
pub enum Level {
    /// Consistent with the healthy reference.
    #[default]
    Normal,
    /// Schedule maintenance or an inspection.
    Advisory,
    /// Intervention advised.
    Alarm,
}

impl Level {
    /// The name written in CSV and JSON.
    pub fn as_str(self) -> &'static str {
        match self {
            Level::Normal => "normal",
            Level::Advisory => "advisory",
            Level::Alarm => "alarm",
        }
    }
}

impl std::fmt::Display for Level {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

pub use crate::mode::FaultMode;

/// The evidence behind an event, written beside the DATA.md §4 fields.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Evidence {
    /// Per-mode risk of the motor.
    pub risk_motor: f64,
    /// Per-mode risk of the brake.
    pub risk_brake: f64,
    /// Per-mode risk of friction.
    pub risk_friction: f64,
    /// Re-identified change of Kd (percent), NaN (null) before the regression is determined.
    pub kd_drift_pct: f64,
    /// Its standard error (percent).
    pub kd_drift_se_pct: f64,
    /// Re-identified change of friction F_c, c (percent).
    pub friction_drift_pct: f64,
    /// Its standard error (percent).
    pub friction_drift_se_pct: f64,
    /// The same change as a force at the rated speed (N): what the data determine, whatever
    /// the friction level it is a share of (`risk::DriftScale`); null in events written
    /// before it was kept.
    #[serde(default = "crate::exact::nan")]
    pub friction_drift_n: f64,
    /// Its standard error (N).
    #[serde(default = "crate::exact::nan")]
    pub friction_drift_se_n: f64,
    /// Re-identified brake drag (N).
    pub brake_drag_n: f64,
    /// Its standard error (N).
    pub brake_drag_se_n: f64,
    /// Trips taken as machine evidence so far.
    pub trips: u64,
    /// Trips refused as sensor-implausible so far.
    pub implausible_trips: u64,
    /// The sequential decision's G/h (at least 1 when it detected the change).
    pub cusum_ratio: f64,
    /// Signature of its leading CUSUM.
    pub cusum_signature: FaultMode,
    /// Change size of its leading CUSUM, in standard errors of one trip; when the
    /// window-limited GLR leads (`cusum_glr`), the size its window shows.
    pub cusum_size: f64,
    /// Trips the leading CUSUM holds as changed (the drifts above are measured on them while
    /// `cusum_ratio` is at least the release ratio).
    pub cusum_trips: u32,
    /// Whether the window-limited GLR leads the decision (the detector of large changes:
    /// `cusum_ratio` is then its z²/h, `cusum_trips` its window); false in events written
    /// before it was kept.
    #[serde(default)]
    pub cusum_glr: bool,
    /// The bound each trip's score was clipped at in that statistic, in standard deviations
    /// of a trip: 3, or more where the GLR's window read a change that nearly all its trips
    /// showed at its own median (`risk::sequential::CONSISTENT_SHARE`); 3 in events written
    /// before it was kept, 0 in one raised before any trip was weighed (a sensor's).
    #[serde(default = "crate::risk::sequential::clip")]
    pub cusum_bound: f64,
    /// Log-likelihood ratio of the motor signature alone on those trips (the mode is named
    /// when the best of the three leads the runner-up by ln 20 ≈ 3.0; events written before it
    /// was kept read 0).
    #[serde(default)]
    pub llr_motor: f64,
    /// The same for the brake signature.
    #[serde(default)]
    pub llr_brake: f64,
    /// The same for the friction signature.
    #[serde(default)]
    pub llr_friction: f64,
    /// The same for the load cell's zero, the isolation's `sensor` hypothesis.
    #[serde(default)]
    pub llr_load: f64,
    /// The load cell's zero offset that window shows (% of the rated load, + reading high);
    /// null without a load reference in the model.
    #[serde(default)]
    pub load_offset_pct: f64,
    /// Log-likelihood ratio of the three signatures together against the named mode's alone
    /// on the trips the drifts are read from: how far they depart from one mode's change.
    /// Above 1, the drifts' standard errors are widened by its square root (the Birge ratio:
    /// `risk::sequential::Decision::misfit`); 0 while the drifts are the long memory's (and
    /// in events written before it was kept).
    #[serde(default)]
    pub llr_misfit: f64,
}

impl Evidence {
    /// The evidence of a tracker's latest assessment; `scale` turns the brake and friction
    /// coefficients into N.
    pub fn from_assessment(
        a: &TripAssessment,
        scale: DriftScale,
        trips: u64,
        implausible_trips: u64,
    ) -> Self {
        Evidence {
            risk_motor: a.risk_modes[MOTOR],
            risk_brake: a.risk_modes[BRAKE],
            risk_friction: a.risk_modes[FRICTION],
            kd_drift_pct: 100.0 * a.drift[MOTOR],
            kd_drift_se_pct: 100.0 * a.drift_se[MOTOR],
            friction_drift_pct: 100.0 * a.drift[FRICTION],
            friction_drift_se_pct: 100.0 * a.drift_se[FRICTION],
            friction_drift_n: scale.friction_n * a.drift[FRICTION],
            friction_drift_se_n: scale.friction_n * a.drift_se[FRICTION],
            brake_drag_n: scale.brake_n * a.drift[BRAKE],
            brake_drag_se_n: scale.brake_n * a.drift_se[BRAKE],
            trips,
            implausible_trips,
            cusum_ratio: a.decision.ratio,
            cusum_signature: a.decision.lead_signature,
            cusum_size: a.decision.lead_size,
            cusum_trips: a.decision.window_trips,
            cusum_glr: a.decision.lead_glr,
            cusum_bound: a.decision.lead_bound,
            llr_motor: a.decision.isolation[MOTOR],
            llr_brake: a.decision.isolation[BRAKE],
            llr_friction: a.decision.isolation[FRICTION],
            llr_load: a.decision.isolation_load,
            load_offset_pct: 100.0 * a.decision.load_offset,
            llr_misfit: a.decision.misfit,
        }
    }
}

/// A change of level (DATA.md §4), or of the open episode's mode at a standing level
/// ([`update_episode`]): one JSON line in the events file.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Event {
    /// Time of the sample at which the level or the episode's mode changed (s).
    pub time: f64,
    /// The new level.
    pub level: Level,
    /// What the evidence points at.
    pub mode: FaultMode,
    /// Combined risk at the change.
    pub risk: f64,
    /// The channel a `sensor` event is about (DATA.md §4: the event names the channel);
    /// absent on the other modes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub channel: Option<Signal>,
    /// Supporting figures.
    #[serde(flatten)]
    pub evidence: Evidence,
}

impl Event {
    /// The event as one JSON line without the newline; non-finite numbers become `null`.
    pub fn to_json_line(&self) -> String {
        serde_json::to_string(self).expect("an event of numbers and names always serialises")
    }
}

/// The level logic with hysteresis, and the sensor override.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct AlarmState {
    machine: Level,
    sensor: bool,
    /// Since when (data time, s) the sequential decision has held a change it cannot name
    /// without raising it ([`AlarmState::raising_ratio`]); `None` while it holds none (and in
    /// states saved before it was kept).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    unnamed_since: Option<f64>,
    /// Since when (data time, s) the window-limited GLR has led a crossing that has not yet
    /// stood for [`GLR_HOLD_S`]; `None` while it leads none (and in states saved before it
    /// was kept).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    glr_since: Option<f64>,
}

impl AlarmState {
    /// The level from machine evidence alone.
    pub fn machine_level(&self) -> Level {
        self.machine
    }

    /// The reported level: the machine level, raised to advisory while a sensor looks wrong.
    pub fn level(&self) -> Level {
        if self.sensor {
            self.machine.max(Level::Advisory)
        } else {
            self.machine
        }
    }

    /// True while the sensor override is active.
    pub fn sensor(&self) -> bool {
        self.sensor
    }

    /// Moves the machine level with hysteresis for combined risk `risk` and the sequential
    /// decision's ratio G/h `seq_ratio` (0 without one).
    pub fn update_machine(&mut self, risk: f64, seq_ratio: f64, cfg: &RiskConfig) {
        let rho = cfg.release_ratio;
        let q = (risk / cfg.advisory).max(seq_ratio);
        self.machine = match self.machine {
            _ if risk >= cfg.alarm => Level::Alarm,
            Level::Alarm if risk >= rho * cfg.alarm => Level::Alarm,
            _ if q >= 1.0 => Level::Advisory,
            Level::Alarm | Level::Advisory if q >= rho => Level::Advisory,
            _ => Level::Normal,
        };
    }

    /// The sequential ratio that may raise the machine level from `normal` at `time` (pass
    /// it to [`AlarmState::update_machine`]): the decision's G/h `ratio` when it names a mode
    /// (`mode`, the assessment's [`diagnose`]), when it has reached [`UNNAMED_RATIO`], when
    /// the change has stood unnamed for [`UNNAMED_HOLD_S`], or when the level already stands
    /// (the hysteresis holds an episode whatever its mode); 0 otherwise, which leaves the risk
    /// R alone to raise it. A crossing of the window-limited GLR alone (`glr`: no CUSUM
    /// crossed) must first have stood for [`GLR_HOLD_S`], unless it is [`GLR_STRONG_RATIO`]
    /// strong.
    pub fn raising_ratio(&mut self, time: f64, ratio: f64, mode: FaultMode, glr: bool) -> f64 {
        if self.machine == Level::Normal && glr && ratio >= 1.0 {
            let since = *self.glr_since.get_or_insert(time);
            if time - since < GLR_HOLD_S && ratio < GLR_STRONG_RATIO {
                return 0.0;
            }
        } else {
            self.glr_since = None;
        }
        let held = self.machine == Level::Normal && mode == FaultMode::Unknown && ratio >= 1.0;
        if !held {
            self.unnamed_since = None;
            return ratio;
        }
        let since = *self.unnamed_since.get_or_insert(time);
        if ratio >= UNNAMED_RATIO || time - since >= UNNAMED_HOLD_S {
            ratio
        } else {
            0.0
        }
    }

    /// Sets the sensor override.
    pub fn set_sensor(&mut self, active: bool) {
        self.sensor = active;
    }
}

/// How far an unnamed change must go before it raises an advisory: G/h of the sequential
/// decision at least this, where a change whose signature the isolation names raises one at 1.
/// A window that the healthy wander and the trips' noise leave between two modes either
/// names one as it grows, or becomes three times as strong as a crossing, a log-likelihood
/// ratio 2h beyond it (odds of e^(2h), e^28 and more, against no change), and is raised as
/// `unknown` with its evidence. Telling two near-collinear signatures apart takes more
/// evidence than telling either from no change (their log-likelihood ratio against each
/// other grows at a fraction of the rate of each against none), so the wait is counted in
/// crossings. On the field-like evaluation the modes named after an `unknown` crossing came
/// within minutes to three hours, the right one in five of six; with the isolation as it
/// first was, waiting for 1.25·h left four of its fifty-four first advisories `unknown`,
/// 1.5·h two, 2·h none; with the wander and the load cell's zero weighed as they are now,
/// 2·h left two `unknown` on the drive-off bench (a brake and a friction ramp on the 630 and
/// 1600 kg cars, each named right 27 and 45 minutes later), 3·h and 4·h none, and no other
/// case of the four field benches moved (no step was raised later).
/// Either way the engineer is not sent to a mode the data could not yet tell.
pub const UNNAMED_RATIO: f64 = 3.0;

/// The longest an unnamed change is held back (s of the data's clock): a day. A change too
/// slow to name itself or to triple its evidence within a day of traffic is raised as
/// `unknown` then; a slow half-size brake ramp on the 630 kg car with a drive off at rest
/// held its crossing unnamed for the last ten days of its run without the bound.
pub const UNNAMED_HOLD_S: f64 = DAY_S;

/// How long a crossing of the window-limited GLR must stand before it raises an advisory (s
/// of the data's clock): an hour, the scale on which a healthy car's levels wander (the
/// calibration draws a new level for every hour of service). The GLR weighs windows of
/// twenty to fifty trips against that wander as the training measured it, and a busy
/// morning the training did not show can exceed it for a while: on the field-like
/// evaluation four such crossings on the 630-1600 kg cars' 08:20-09:20 rush, 0.80 to 1.24
/// of the threshold, each gone within 1 to 30 minutes. A large step stands: it is raised an
/// hour after its crossing, or with the first trip after a quiet hour.
pub const GLR_HOLD_S: f64 = 3_600.0;

/// A crossing of the window-limited GLR alone this strong (z²/h) raises at once, without
/// standing [`GLR_HOLD_S`]: twice its threshold (z² beyond it by h, odds of e^h against no
/// change). It asks less than an unnamed change must show ([`UNNAMED_RATIO`]): the hold is
/// for a wander that passes, not for a name the window cannot give. The rush-hour excursions
/// the hold is for reached 1.24; a large step passes 2 within a few of its trips: on the field
/// bench's four settings 13 of its 36 steps were raised 0.03 to 0.9 hours sooner, each with
/// the same mode.
pub const GLR_STRONG_RATIO: f64 = 2.0;

/// A mode is named only once its risk has reached half the level its healthy bootstrap
/// reaches once in the simulated years: a trace of evidence is not a diagnosis.
pub const MIN_SCALED_RISK: f64 = 0.5;

/// The fault mode the per-mode risks point at: the largest scaled risk R_m/A_m when it is at
/// least [`MIN_SCALED_RISK`] and exceeds the runner-up by `dominance`, `Unknown` otherwise.
pub fn attribute(risk_modes: &[f64; N_MODES], cfg: &RiskConfig) -> FaultMode {
    let q: [f64; N_MODES] =
        std::array::from_fn(|m| risk_modes[m] / cfg.advisory_modes[m].max(f64::MIN_POSITIVE));
    let mut order = MACHINE_MODES;
    order.sort_by(|a, b| q[*b as usize].total_cmp(&q[*a as usize]));
    let (best, second) = (q[order[0] as usize], q[order[1] as usize]);
    if best.is_nan() || best < MIN_SCALED_RISK || best < cfg.dominance * second {
        return FaultMode::Unknown;
    }
    order[0]
}

/// The fault mode of an assessment: the sequential decision's, while it holds a change
/// (G/h ≥ ρ) and names a mode; else the per-mode risks' ([`attribute`]).
pub fn diagnose(a: &TripAssessment, cfg: &RiskConfig) -> FaultMode {
    let d = &a.decision;
    if d.ratio >= cfg.release_ratio && d.mode != FaultMode::Unknown {
        d.mode
    } else {
        attribute(&a.risk_modes, cfg)
    }
}

/// Moves the mode of the open episode for a sample whose level went from `before` to
/// `state.level()`, the sensor override from `sensor_before` to `state.sensor()`; returns true
/// when the sample is an event: a change of level, an episode opened as `unknown` that now
/// gets its mode, or a channel fault that begins or ends while the machine holds the episode
/// open.
///
/// An advisory may first say `unknown` and then name the mode, when the evidence that raised
/// it does not yet tell the signatures apart. A channel that fails while the machine holds an
/// advisory or an alarm does not raise the level (the override raises it to advisory, where
/// it already is), but the person reading the events must learn that a sensor is now wrong,
/// and which: the episode becomes `sensor` while the override holds, at an alarm too (while
/// a channel is wrong its trips are not taken as machine evidence, and the alarm's own event
/// stands above it in the file), and takes the machine's mode again (by [`diagnose`],
/// `unknown` until one is clear) when the override releases with the machine still above
/// `normal`, also at the sample an alarm is released to advisory. An escalation to alarm at
/// the sample a channel fails names the machine's mode: the alarm is the machine's.
pub fn update_episode(
    mode: &mut FaultMode,
    (before, sensor_before): (Level, bool),
    state: &AlarmState,
    a: &TripAssessment,
    cfg: &RiskConfig,
) -> bool {
    let level = state.level();
    let sensor_on = state.sensor() && !sensor_before;
    // The override released from a `sensor` episode the machine holds open.
    let sensor_off = !state.sensor()
        && sensor_before
        && *mode == FaultMode::Sensor
        && state.machine_level() > Level::Normal;
    // Where the override's move names the episode, at a standing level or a release.
    let moved = if sensor_on {
        Some(FaultMode::Sensor)
    } else if sensor_off {
        Some(diagnose(a, cfg))
    } else {
        None
    };
    if level == before {
        if level == Level::Normal {
            return false;
        }
        let was = *mode;
        if let Some(m) = moved {
            *mode = m;
        } else if *mode == FaultMode::Unknown {
            *mode = diagnose(a, cfg);
        }
        return *mode != was;
    }
    if before == Level::Normal {
        let m = diagnose(a, cfg);
        let sensor_only = state.machine_level() == Level::Normal;
        *mode = if sensor_only || (state.sensor() && m == FaultMode::Unknown) {
            FaultMode::Sensor
        } else {
            m
        };
    } else if level > before {
        // Escalation names the mode again: more evidence may have made it clear. It is the
        // machine's (only risk raises an alarm), so a channel failing at the same sample
        // waits for the alarm's release to be named.
        let m = diagnose(a, cfg);
        if m != FaultMode::Unknown || sensor_off {
            *mode = m;
        }
    } else if level > Level::Normal {
        // Released from alarm to advisory: the episode goes on, and a channel that failed or
        // recovered at the same sample moves its mode as it would at a standing level.
        if let Some(m) = moved {
            *mode = m;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg() -> RiskConfig {
        RiskConfig {
            advisory: 100.0,
            alarm: 400.0,
            advisory_modes: [100.0; N_MODES],
            ..RiskConfig::default()
        }
    }

    #[test]
    fn an_unnamed_change_raises_nothing_until_it_is_three_crossings_strong_or_a_day_old() {
        let cfg = cfg();
        let raise = |ratio: f64, mode: FaultMode| {
            let mut s = AlarmState::default();
            let seq = s.raising_ratio(0.0, ratio, mode, false);
            s.update_machine(0.0, seq, &cfg);
            s.level()
        };
        assert_eq!(raise(1.2, FaultMode::Motor), Level::Advisory);
        assert_eq!(raise(1.2, FaultMode::Unknown), Level::Normal);
        assert_eq!(raise(UNNAMED_RATIO, FaultMode::Unknown), Level::Advisory);
        // Held unnamed: nothing for a day, then raised; a ratio that fell below 1 meanwhile
        // starts the day again.
        let mut s = AlarmState::default();
        for (t, ratio, level) in [
            (0.0, 1.2, Level::Normal),
            (40_000.0, 1.3, Level::Normal),
            (50_000.0, 0.9, Level::Normal),
            (60_000.0, 1.1, Level::Normal),
            (60_000.0 + UNNAMED_HOLD_S - 1.0, 1.1, Level::Normal),
            (60_000.0 + UNNAMED_HOLD_S, 1.1, Level::Advisory),
        ] {
            let seq = s.raising_ratio(t, ratio, FaultMode::Unknown, false);
            s.update_machine(0.0, seq, &cfg);
            assert_eq!(s.level(), level, "at {t} s, G/h {ratio}");
        }
        // A standing advisory is held by its ratio whatever the mode says meanwhile.
        let mut s = AlarmState::default();
        let seq = s.raising_ratio(0.0, 1.2, FaultMode::Brake, false);
        s.update_machine(0.0, seq, &cfg);
        let held = s.raising_ratio(1.0, 0.7, FaultMode::Unknown, false);
        s.update_machine(0.0, held, &cfg);
        assert_eq!(s.level(), Level::Advisory);
    }

    #[test]
    fn a_glr_crossing_raises_once_it_has_stood_an_hour_or_is_twice_as_strong() {
        // A crossing the GLR leads is held for GLR_HOLD_S of data time; one that ends within
        // it (a busy morning's excursion) raises nothing and starts the hour again, and a
        // CUSUM's crossing raises at once, as does a GLR crossing twice its threshold.
        let cfg = cfg();
        let mut s = AlarmState::default();
        for (t, ratio, glr, level) in [
            (0.0, 1.2, true, Level::Normal),
            (1_200.0, 1.4, true, Level::Normal),
            (1_800.0, 0.8, true, Level::Normal),
            (2_000.0, 1.3, true, Level::Normal),
            (2_000.0 + GLR_HOLD_S - 1.0, 1.3, true, Level::Normal),
            (2_000.0 + GLR_HOLD_S, 1.1, true, Level::Advisory),
        ] {
            let seq = s.raising_ratio(t, ratio, FaultMode::Motor, glr);
            s.update_machine(0.0, seq, &cfg);
            assert_eq!(s.level(), level, "at {t} s, z²/h {ratio}");
        }
        let mut s = AlarmState::default();
        let seq = s.raising_ratio(0.0, 1.1, FaultMode::Motor, false);
        s.update_machine(0.0, seq, &cfg);
        assert_eq!(s.level(), Level::Advisory);
        let mut s = AlarmState::default();
        for (t, ratio, level) in [
            (0.0, 1.5, Level::Normal),
            (600.0, 0.999 * GLR_STRONG_RATIO, Level::Normal),
            (900.0, GLR_STRONG_RATIO, Level::Advisory),
        ] {
            let seq = s.raising_ratio(t, ratio, FaultMode::Motor, true);
            s.update_machine(0.0, seq, &cfg);
            assert_eq!(s.level(), level, "at {t} s, z²/h {ratio}");
        }
    }

    #[test]
    fn hysteresis_prevents_flicker() {
        // Risk hovering just around the advisory threshold changes the level once, not at
        // every crossing.
        let cfg = cfg();
        let mut s = AlarmState::default();
        let mut changes = 0;
        let mut last = s.level();
        for k in 0..200 {
            let risk = 100.0 + if k % 2 == 0 { 5.0 } else { -5.0 };
            s.update_machine(risk, 0.0, &cfg);
            if s.level() != last {
                changes += 1;
                last = s.level();
            }
        }
        assert_eq!(changes, 1);
        assert_eq!(s.level(), Level::Advisory);
        s.update_machine(49.0, 0.0, &cfg);
        assert_eq!(s.level(), Level::Normal, "released below ρ·advisory");
    }

    #[test]
    fn alarm_is_left_for_advisory_then_normal() {
        let cfg = cfg();
        let mut s = AlarmState::default();
        s.update_machine(500.0, 0.0, &cfg);
        assert_eq!(s.level(), Level::Alarm);
        s.update_machine(250.0, 0.0, &cfg);
        assert_eq!(s.level(), Level::Alarm, "still above ρ·alarm");
        s.update_machine(150.0, 0.0, &cfg);
        assert_eq!(s.level(), Level::Advisory);
        s.update_machine(10.0, 0.0, &cfg);
        assert_eq!(s.level(), Level::Normal);
    }

    #[test]
    fn a_sensor_fault_is_an_advisory_without_machine_risk() {
        let mut s = AlarmState::default();
        s.set_sensor(true);
        assert_eq!(
            (s.level(), s.machine_level()),
            (Level::Advisory, Level::Normal)
        );
    }

    /// One sample of a friction fault at risk R with the sensor override `sensor`: moves the
    /// levels and the episode's mode, and says whether the sample is an event.
    fn step(s: &mut AlarmState, mode: &mut FaultMode, sensor: bool, risk: f64) -> bool {
        let a = TripAssessment {
            risk,
            risk_modes: [0.0, 0.0, risk],
            ..TripAssessment::default()
        };
        let before = (s.level(), s.sensor());
        s.set_sensor(sensor);
        s.update_machine(risk, 0.0, &cfg());
        update_episode(mode, before, s, &a, &cfg())
    }

    #[test]
    fn a_channel_fault_during_a_machine_advisory_is_an_event_and_so_is_its_end() {
        let (mut s, mut mode) = (AlarmState::default(), FaultMode::Unknown);
        // A friction advisory: R at 1.5 times the threshold, the friction risk dominant.
        assert!(step(&mut s, &mut mode, false, 150.0));
        assert_eq!((s.level(), mode), (Level::Advisory, FaultMode::Friction));
        assert!(!step(&mut s, &mut mode, false, 150.0), "nothing changed");
        // The speed channel sticks: the level stays at advisory, the episode turns `sensor`.
        assert!(step(&mut s, &mut mode, true, 150.0));
        assert_eq!((s.level(), mode), (Level::Advisory, FaultMode::Sensor));
        let held = step(&mut s, &mut mode, true, 150.0);
        assert!(!held, "a fault that holds is one event");
        // It recovers with the machine still at advisory: the episode is friction's again.
        assert!(step(&mut s, &mut mode, false, 150.0));
        assert_eq!((s.level(), mode), (Level::Advisory, FaultMode::Friction));
        // A channel fault whose override ends with the machine released ends the episode as
        // before, by the change of level.
        assert!(step(&mut s, &mut mode, true, 150.0));
        assert!(step(&mut s, &mut mode, false, 0.0));
        assert_eq!(s.level(), Level::Normal);
    }

    #[test]
    fn a_channel_that_recovers_as_the_alarm_is_released_gives_the_episode_back() {
        let (mut s, mut mode) = (AlarmState::default(), FaultMode::Unknown);
        assert!(step(&mut s, &mut mode, false, 500.0));
        assert_eq!((s.level(), mode), (Level::Alarm, FaultMode::Friction));
        // A channel fails at the standing alarm.
        assert!(step(&mut s, &mut mode, true, 500.0));
        assert_eq!((s.level(), mode), (Level::Alarm, FaultMode::Sensor));
        // It recovers at the sample the alarm is released to advisory (R below ρ·alarm).
        assert!(step(&mut s, &mut mode, false, 150.0));
        assert_eq!((s.level(), mode), (Level::Advisory, FaultMode::Friction));
        // And one failing as the machine escalates: the alarm is the machine's.
        assert!(step(&mut s, &mut mode, true, 500.0));
        assert_eq!((s.level(), mode), (Level::Alarm, FaultMode::Friction));
    }

    #[test]
    fn attribution_needs_a_clear_winner() {
        let cfg = cfg();
        assert_eq!(attribute(&[300.0, 20.0, 50.0], &cfg), FaultMode::Motor);
        assert_eq!(attribute(&[300.0, 20.0, 280.0], &cfg), FaultMode::Unknown);
        assert_eq!(attribute(&[0.0, 0.0, 0.0], &cfg), FaultMode::Unknown);
        assert_eq!(
            attribute(&[10.0, 0.0, 0.0], &cfg),
            FaultMode::Unknown,
            "a trace is no diagnosis"
        );
        assert_eq!(attribute(&[1.0, 90.0, 5.0], &cfg), FaultMode::Brake);
    }

    #[test]
    fn event_is_one_json_line_with_the_contract_fields() {
        let e = Event {
            time: DAY_S,
            level: Level::Advisory,
            mode: FaultMode::Friction,
            risk: 412.5,
            channel: None,
            evidence: Evidence::default(),
        };
        let line = e.to_json_line();
        assert!(
            line.starts_with(
                r#"{"time":86400.0,"level":"advisory","mode":"friction","risk":412.5,"#
            ),
            "{line}"
        );
        assert!(!line.contains('\n'));
        let back: serde_json::Value = serde_json::from_str(&line).unwrap();
        assert_eq!(back["risk_motor"], 0.0);
    }
}
