//! The verdict a person acts on, from a model and a monitor's state: what `liftwatch status`
//! prints and what the report opens with (one function, [`Verdict::new`], for both).
//!
//! ```text
//! level, mode                        the monitor's level and the open episode's mode
//! drift ± se, since                  the mode's physical drift (Kd %, friction %, brake drag N)
//!                                    with its standard error, since the change began (the
//!                                    sequential decision's first changed trip, else the event
//!                                    that opened the episode)
//! inspect                            what the mode says to look at (FaultMode::inspect)
//! forecast                           crate::forecast: when the trend reaches the levels
//! evidence                           R against its levels, the sequential decision, the trips
//! caveats                            what the model itself cannot promise: short training,
//!                                    parameters set by their priors, uncalibrated thresholds
//! availability                       the last day's and the last 7 days' (crate::operation),
//!                                    an outage under way or the last one
//! doors                              the door check's level, the recent cycles' median and
//!                                    reopening rate against the healthy reference
//! ```
//!
//! The doors are a subsystem of their own: their advisory is stated on its own line and
//! never changes the machine's level, mode or headline.
//!
//! Times are UTC dates when the data's clock is Unix time, days of the data clock otherwise
//! ([`crate::ingest::time::day_text`]).

use crate::sample::DAY_S;
use serde::Serialize;

use crate::alarm::Level;
use crate::fit::FittedModel;
use crate::forecast::{unit_of, Forecast, ModeForecast, When};
use crate::ingest::time::{day_text, instant_text, is_calendar};
use crate::mode::{FaultMode, MACHINE_MODES, N_MODES};
use crate::model::train::DecidedBy;
use crate::monitor::MonitorState;
use crate::operation::{Outage, DOOR_MIN_CYCLES, DOOR_MIN_DAYS};
use crate::risk::DriftScale;
use crate::text::sig3;

/// Hours of healthy training below which the verdict says the model is short of data: the
/// calibration's own bound, [`crate::calibrate::ENOUGH_TRAINING_HOURS`].
pub const FULL_TRAINING_HOURS: f64 = crate::calibrate::ENOUGH_TRAINING_HOURS;

/// One mode's drift now, in its physical unit.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Drift {
    /// The mode.
    pub mode: FaultMode,
    /// What drifts: `Kd`, `friction`, `brake drag`.
    pub quantity: &'static str,
    /// Drift (percent or N); NaN (null) before the regression is determined.
    pub value: f64,
    /// Its standard error.
    pub se: f64,
    /// `%` or `N`.
    pub unit: &'static str,
    /// Friction's drift as a force at the rated speed (N) and its standard error: what the
    /// data determine (`risk::DriftScale`); NaN (null) for the other modes.
    pub force_n: [f64; 2],
}

/// The verdict: level, mode, drift, what to inspect, forecast, evidence and caveats.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Verdict {
    /// The monitor's level.
    pub level: Level,
    /// The open episode's mode (`unknown` at `normal`).
    pub mode: FaultMode,
    /// The channel a `sensor` mode is about (`speed`, `voltage`, `load`, ...), when a check
    /// names one; null otherwise.
    pub channel: Option<crate::ingest::Signal>,
    /// Time of the last sample watched (s); NaN before any.
    pub time: f64,
    /// When the change began (s), `None` without one.
    pub since: Option<f64>,
    /// Drifts of the three machine modes now (motor, brake, friction).
    pub drifts: Vec<Drift>,
    /// What to inspect.
    pub inspect: &'static str,
    /// When the drifts' trends reach the levels.
    pub forecast: Forecast,
    /// Combined risk R and its advisory and alarm levels.
    pub risk: [f64; 3],
    /// The sequential decision's G/h and the trips it holds as changed.
    pub cusum_ratio: f64,
    /// Trips the longest change held spans.
    pub changed_trips: u32,
    /// How far the trips the drifts are read from depart from the named mode's signature
    /// alone: the log-likelihood ratio of the three signatures together against it (the
    /// event's `llr_misfit`); above 1 the drifts' standard errors are widened by its square
    /// root. 0 while the drifts are the long memory's.
    pub misfit: f64,
    /// Trips taken as machine evidence, and refused as sensor-implausible.
    pub trips: [u64; 2],
    /// What the model cannot promise.
    pub caveats: Vec<String>,
    /// Availability and doors.
    pub service: ServiceVerdict,
}

/// An outage as the verdict states it (plain numbers; `end` null while under way).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct OutageView {
    /// `out_of_service` or `stuck_between_floors`.
    pub kind: crate::operation::OutageKind,
    /// When the car last moved (s).
    pub start: f64,
    /// When it moved again (s), null while under way.
    pub end: Option<f64>,
    /// When the monitor concluded it (s).
    pub detected_at: f64,
    /// For people: where it stood, the door.
    pub reason: String,
}

impl From<&Outage> for OutageView {
    fn from(o: &Outage) -> Self {
        OutageView {
            kind: o.kind,
            start: o.start,
            end: o.end.is_finite().then_some(o.end),
            detected_at: o.detected_at,
            reason: o.reason(),
        }
    }
}

/// Availability and door health, beside the machine's verdict.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ServiceVerdict {
    /// Availability of the last day watched (0-1), NaN (null) without data.
    pub availability_last_day: f64,
    /// Availability over the last 7 days watched (0-1).
    pub availability_7_days: f64,
    /// Trips and door cycles of the last day watched.
    pub trips_last_day: u64,
    /// Door cycles of the last day watched.
    pub door_cycles_last_day: u64,
    /// The outage under way.
    pub outage: Option<OutageView>,
    /// The last outage that ended.
    pub last_outage: Option<OutageView>,
    /// The door check: `advisory` or `normal`; `unchecked` for a model without a door
    /// reference.
    pub door_level: &'static str,
    /// Median duration of the recent door cycles (s) and their reopenings per cycle.
    pub door_cycle_median_s: f64,
    /// Reopenings per recent cycle.
    pub door_reopen_rate: f64,
    /// The healthy reference's median (s) and reopening rate, NaN without one.
    pub reference: [f64; 2],
}

impl ServiceVerdict {
    /// From the monitor's operation tracker and the model's reference.
    pub fn new(model: &FittedModel, state: &MonitorState) -> ServiceVerdict {
        let op = &state.operation;
        let last = op.days.back().copied().unwrap_or_default();
        let (median, reopen, _) = op.recent_doors();
        let door = model.operation.as_ref().and_then(|o| o.door.as_ref());
        ServiceVerdict {
            availability_last_day: op.availability(1),
            availability_7_days: op.availability(7),
            trips_last_day: last.trips,
            door_cycles_last_day: last.door_cycles,
            outage: op.open.as_ref().map(OutageView::from),
            last_outage: op.last_outage.as_ref().map(OutageView::from),
            door_level: match door {
                None => "unchecked",
                Some(_) if op.door.raised => "advisory",
                Some(_) => "normal",
            },
            door_cycle_median_s: median,
            door_reopen_rate: reopen,
            reference: door.map_or([f64::NAN; 2], |d| [d.median_s, d.reopen_rate]),
        }
    }

    /// `Availability: 83.2 % on the day of the last sample (…), 97.6 % over the last 7 days;
    /// out of service since …`: the day is the calendar day of the data's clock the last
    /// sample fell on, so a log ending at midnight shows the new day, still empty.
    pub fn availability_line(&self) -> String {
        let pct = |x: f64| {
            if x.is_finite() {
                format!("{:.1} %", 100.0 * x)
            } else {
                "unknown".into()
            }
        };
        let mut s = format!(
            "Availability: {} on the day of the last sample ({} trips, {} door cycles), {} over the last 7 days",
            pct(self.availability_last_day),
            self.trips_last_day,
            self.door_cycles_last_day,
            pct(self.availability_7_days)
        );
        if let Some(o) = &self.outage {
            s.push_str(&format!(
                "; OUT OF SERVICE since {} ({}), concluded at {}",
                instant_text(o.start),
                o.reason,
                instant_text(o.detected_at)
            ));
        } else if let Some(o) = &self.last_outage {
            s.push_str(&format!(
                "; last outage {} to {} ({})",
                instant_text(o.start),
                o.end.map_or("now".into(), instant_text),
                o.reason
            ));
        }
        s.push('.');
        s
    }

    /// `Doors: ADVISORY, cycles 13 s (healthy 11 s), reopenings 9 % (healthy 3 %); inspect …`.
    pub fn door_line(&self) -> String {
        let figures = format!(
            "cycles {} (healthy {}), reopenings {} (healthy {})",
            secs(self.door_cycle_median_s),
            secs(self.reference[0]),
            share(self.door_reopen_rate),
            share(self.reference[1])
        );
        match self.door_level {
            "advisory" => format!(
                "Doors: ADVISORY, {figures}; {}.",
                FaultMode::Door.inspect()
            ),
            "normal" => format!("Doors: normal, {figures}."),
            _ => format!(
                "Doors: not checked (the model has no door reference: its training had fewer than {DOOR_MIN_CYCLES} cycles or less than {DOOR_MIN_DAYS:.0} day; refit on a longer one), cycles {}, reopenings {}.",
                secs(self.door_cycle_median_s),
                share(self.door_reopen_rate)
            ),
        }
    }
}

fn secs(x: f64) -> String {
    if x.is_finite() {
        format!("{x:.0} s")
    } else {
        "unknown".into()
    }
}

fn share(x: f64) -> String {
    if x.is_finite() {
        format!("{:.0} %", 100.0 * x)
    } else {
        "unknown".into()
    }
}

impl Verdict {
    /// The verdict of `state`, a monitor state of `model`.
    pub fn new(model: &FittedModel, state: &MonitorState) -> Verdict {
        let cfg = &model.risk;
        let a = state.assessment();
        let scale = DriftScale::of(&model.hybrid);
        let level = state.level();
        let mode = if level == Level::Normal {
            FaultMode::Unknown
        } else {
            state.episode_mode()
        };
        let changed = state.changed_since(cfg);
        let since = changed.or((level > Level::Normal).then_some(state.episode_since));
        let since = since.filter(|t| t.is_finite() && level > Level::Normal);
        let drifts = (0..N_MODES)
            .map(|m| {
                let (k, unit, quantity) = unit_of(m, scale.brake_n);
                Drift {
                    mode: MACHINE_MODES[m],
                    quantity,
                    value: k * a.drift[m],
                    se: k * a.drift_se[m],
                    unit,
                    force_n: if MACHINE_MODES[m] == FaultMode::Friction {
                        [
                            scale.friction_n * a.drift[m],
                            scale.friction_n * a.drift_se[m],
                        ]
                    } else {
                        [f64::NAN; 2]
                    },
                }
            })
            .collect();
        let fc = state.forecast(model);
        let channel = state.sensor_channel(model);
        Verdict {
            level,
            mode,
            channel,
            time: state.last_time,
            since,
            drifts,
            inspect: match (level, channel) {
                (Level::Normal, _) => "no action: keep monitoring",
                (_, Some(c)) if mode == FaultMode::Sensor => c.inspect(),
                _ => mode.inspect(),
            },
            forecast: fc,
            risk: [a.risk, cfg.advisory, cfg.alarm],
            cusum_ratio: a.decision.ratio,
            changed_trips: state.held_window_trips(cfg),
            misfit: a.decision.misfit,
            trips: [state.risk_trips(), state.implausible_trips],
            caveats: caveats(model, state),
            service: ServiceVerdict::new(model, state),
        }
    }

    /// The verdict as plain sentences, headline first: what `status` prints and the report
    /// opens with.
    pub fn lines(&self) -> Vec<String> {
        let mut out = vec![self.headline()];
        out.push(self.service.availability_line());
        out.push(self.service.door_line());
        out.push(format!(
            "Forecast: {}",
            self.forecast_text().unwrap_or_else(|| format!(
                "no drift is rising distinguishably from zero; no level is forecast within {} days.",
                crate::forecast::HORIZON_DAYS
            ))
        ));
        out.push(format!("Evidence: {}", self.evidence_text()));
        if self.caveats.is_empty() {
            out.push("Caveats: none from the model.".into());
        } else {
            out.push(format!("Caveats: {}", self.caveats.join("; ")));
        }
        out
    }

    /// `ADVISORY, drive: Kd +4.1 ± 0.7 % since 3 Mar 2026; inspect …`.
    fn headline(&self) -> String {
        let at = if self.time.is_finite() {
            format!(" (as of {})", instant_text(self.time))
        } else {
            " (no data watched yet)".into()
        };
        if self.level == Level::Normal {
            let ds: Vec<String> = self.drifts.iter().map(drift_text).collect();
            // At `normal` a crossing is one the isolation cannot name yet, held back
            // (crate::alarm::UNNAMED_RATIO): the data are not consistent with the healthy
            // reference, and the reader must not be told they are.
            if self.cusum_ratio >= 1.0 {
                return format!(
                    "NORMAL{at}, watching: a change the fault signatures cannot yet tell apart \
                     (G/h {:.2}; drifts {}); it becomes an advisory once it names its mode, \
                     triples, or has stood a day; {}.",
                    self.cusum_ratio,
                    ds.join(", "),
                    self.inspect
                );
            }
            return format!(
                "NORMAL{at}: consistent with the healthy reference (drifts {}); {}.",
                ds.join(", "),
                self.inspect
            );
        }
        let since = self
            .since
            .map_or(String::new(), |t| format!(" since {}", day_text(t)));
        // A sensor verdict that names its channel says which sensor, without the machine's
        // drifts (read through that sensor, they are not what is wrong) and without `since`,
        // the machine's change (the sensor's own event in the events file says when).
        let (what, since) = match (
            self.channel,
            self.drifts.iter().find(|d| d.mode == self.mode),
        ) {
            (Some(c), _) if self.mode == FaultMode::Sensor => (
                format!("the {} ({} channel)", c.sensor(), c.name()),
                String::new(),
            ),
            (_, Some(d)) => (drift_text(d), since),
            _ => {
                let ds: Vec<String> = self.drifts.iter().map(drift_text).collect();
                (format!("drifts {}", ds.join(", ")), since)
            }
        };
        format!(
            "{}{at}, {}: {what}{since}; {}.",
            self.level.as_str().to_uppercase(),
            self.mode.subsystem(),
            self.inspect
        )
    }

    /// The crossings of the verdict's mode (or, at `normal` and `unknown`, of every mode with
    /// a rising trend); `None` when nothing is rising.
    fn forecast_text(&self) -> Option<String> {
        let modes: Vec<&ModeForecast> = self
            .forecast
            .modes
            .iter()
            .filter(|f| f.mode == self.mode || !self.mode.is_machine())
            .filter(|f| {
                f.crossings
                    .iter()
                    .any(|c| matches!(c.when, When::At { .. } | When::NotWithinHorizon))
            })
            .collect();
        if modes.is_empty() {
            return None;
        }
        let parts: Vec<String> = modes
            .iter()
            .map(|f| mode_forecast_text(f, self.time))
            .collect();
        Some(parts.join(" "))
    }

    fn evidence_text(&self) -> String {
        let [r, adv, alm] = self.risk;
        let mut s = format!(
            "risk R = {} (advisory level {}, alarm level {})",
            sig3(r),
            sig3(adv),
            sig3(alm)
        );
        if self.cusum_ratio >= 0.5 {
            s.push_str(&format!(
                "; the sequential test stands at G/h = {:.2} (1 decides) over {} trips",
                self.cusum_ratio, self.changed_trips
            ));
            s.push_str(&misfit_text(self.misfit));
        }
        s.push_str(&format!(
            "; {} trips taken as machine evidence, {} refused as sensor-implausible.",
            self.trips[0], self.trips[1]
        ));
        s
    }
}

/// What a misfit above 1 does to the drifts (`; the trips the drifts are read from depart
/// from one mode's signature (misfit 35.2), which widens their standard errors 5.9 times`);
/// nothing at or below 1, where nothing is widened.
fn misfit_text(misfit: f64) -> String {
    if misfit > 1.0 {
        format!(
            "; the trips the drifts are read from depart from one mode's signature (misfit {misfit:.1}), which widens their standard errors {:.1} times",
            misfit.sqrt()
        )
    } else {
        String::new()
    }
}

/// `Kd +4.1 ± 0.7 %`, `brake drag n/a` before the regression is determined.
fn drift_text(d: &Drift) -> String {
    if !d.value.is_finite() {
        return format!("{} n/a", d.quantity);
    }
    let [f, f_se] = d.force_n;
    let force = if f.is_finite() {
        format!(" ({f:+.0} ± {f_se:.0} N at rated speed)")
    } else {
        String::new()
    };
    format!(
        "{} {:+.1} ± {:.1} {}{force}",
        d.quantity, d.value, d.se, d.unit
    )
}

/// `at this rate (Kd +0.8 ± 0.1 %/day since 3 Mar 2026): the alarm level (Kd +7.1 %) in ~6
/// days (3-11 days: 9 Mar 2026 to 17 Mar 2026); …`.
fn mode_forecast_text(f: &ModeForecast, now: f64) -> String {
    let Some(t) = &f.trend else {
        return String::new();
    };
    let rate = format!(
        "{} {:+.2} ± {:.2} {}/day over the blocks since {}",
        f.quantity,
        t.slope_per_day,
        t.slope_se,
        f.unit,
        day_text(t.since)
    );
    let items: Vec<String> = f
        .crossings
        .iter()
        .map(|c| {
            let level = format!(
                "the {} ({} {:+.1} {})",
                c.name, f.quantity, c.threshold, f.unit
            );
            match c.when {
                When::Reached => format!("{level} is reached"),
                When::NoTrend => format!("{level}: no rising trend"),
                When::NotWithinHorizon => {
                    format!("{level}: not within {} days", crate::forecast::HORIZON_DAYS)
                }
                When::At { time, early, late } => {
                    let days = |x: f64| (x - now) / DAY_S;
                    let late_text = late.map_or("beyond the horizon".to_string(), |l| {
                        format!("{:.0} days", days(l))
                    });
                    let dates = if is_calendar(time) {
                        format!(
                            ", {} to {}",
                            day_text(early),
                            late.map_or("later".into(), day_text)
                        )
                    } else {
                        String::new()
                    };
                    if time <= now {
                        // The trend line is past the level already, its interval not yet: the
                        // crossing is due, not "in −3 days".
                        return format!(
                            "{level} is due now (the trend is past it; its {:.0} % interval reaches it within {late_text})",
                            100.0 * crate::forecast::COVERAGE
                        );
                    }
                    format!(
                        "{level} in ~{:.0} days ({:.0} to {late_text}{dates}, {:.0} % interval)",
                        days(time),
                        days(early),
                        100.0 * crate::forecast::COVERAGE
                    )
                }
            }
        })
        .collect();
    format!("at this rate ({rate}): {}.", items.join("; "))
}

/// What the model cannot promise, from its fit summary and calibration.
fn caveats(model: &FittedModel, state: &MonitorState) -> Vec<String> {
    let mut out = Vec::new();
    match &model.calibration {
        Some(k) if k.hours < FULL_TRAINING_HOURS => out.push(format!(
            "the model learnt from {:.0} h of healthy data, less than the week that holds seven thermal cycles and a weekend: its thresholds are only as honest as those hours are typical",
            k.hours
        )),
        Some(_) => {}
        None => out.push("the model's risk thresholds are uncalibrated defaults".into()),
    }
    let by_prior: Vec<&str> = model
        .summary
        .parameters
        .iter()
        .filter(|p| p.prior_sd.is_some() && p.decided_by() == DecidedBy::Prior)
        .map(|p| p.name.as_str())
        .collect();
    if !by_prior.is_empty() {
        out.push(format!(
            "{} set by {} prior, not by the data",
            by_prior.join(", "),
            if by_prior.len() == 1 { "its" } else { "their" }
        ));
    }
    if model.risk.sequential.is_none() {
        out.push("the model predates the sequential decision: advisories come from R alone".into());
    }
    if state.drifts.points.len() < crate::forecast::MIN_TREND_POINTS {
        out.push(format!(
            "the state holds {} blocks of drift history, a forecast needs {} ({} trips each)",
            state.drifts.points.len(),
            crate::forecast::MIN_TREND_POINTS,
            crate::forecast::BLOCK_TRIPS
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::misfit_text;

    #[test]
    fn a_misfit_says_how_much_it_widened_the_drifts() {
        let text = misfit_text(35.2);
        assert!(
            text.contains("misfit 35.2") && text.contains("widens their standard errors 5.9 times"),
            "{text}"
        );
        // Nothing is widened at or below 1 (the Birge ratio's floor), nor for a NaN.
        assert_eq!(misfit_text(1.0), "");
        assert_eq!(misfit_text(0.3), "");
        assert_eq!(misfit_text(f64::NAN), "");
    }
}
