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
//! ```
//!
//! Times are UTC dates when the data's clock is Unix time, days of the data clock otherwise
//! ([`crate::ingest::time::day_text`]).

use serde::Serialize;

use crate::alarm::Level;
use crate::fit::FittedModel;
use crate::forecast::{unit_of, Forecast, ModeForecast, When};
use crate::ingest::time::{day_text, instant_text, is_calendar};
use crate::mode::{FaultMode, MACHINE_MODES, N_MODES};
use crate::monitor::MonitorState;
use crate::risk::friction_reference;

/// Hours of healthy training below which the verdict says the model is short of data: a
/// week holds seven thermal cycles of the winding and a weekend's traffic, what the
/// calibration's bootstrap needs to see to state its false-alarm rate (README, Method). The
/// hours are counted from the first to the last trip, so a week's log measures a few hours
/// less (no trips at night at its ends): 160 h.
pub const FULL_TRAINING_HOURS: f64 = 160.0;

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
}

/// The verdict: level, mode, drift, what to inspect, forecast, evidence and caveats.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Verdict {
    /// The monitor's level.
    pub level: Level,
    /// The open episode's mode (`unknown` at `normal`).
    pub mode: FaultMode,
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
    /// Trips taken as machine evidence, and refused as sensor-implausible.
    pub trips: [u64; 2],
    /// What the model cannot promise.
    pub caveats: Vec<String>,
}

impl Verdict {
    /// The verdict of `state`, a monitor state of `model`.
    pub fn new(model: &FittedModel, state: &MonitorState) -> Verdict {
        let cfg = &model.risk;
        let a = state.assessment();
        let f_c = friction_reference(&model.hybrid).0;
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
                let (k, unit, quantity) = unit_of(m, f_c);
                Drift {
                    mode: MACHINE_MODES[m],
                    quantity,
                    value: k * a.drift[m],
                    se: k * a.drift_se[m],
                    unit,
                }
            })
            .collect();
        let fc = state.forecast(model);
        Verdict {
            level,
            mode,
            time: state.last_time,
            since,
            drifts,
            inspect: if level == Level::Normal {
                "no action: keep monitoring"
            } else {
                mode.inspect()
            },
            forecast: fc,
            risk: [a.risk, cfg.advisory, cfg.alarm],
            cusum_ratio: a.decision.ratio,
            changed_trips: state.held_window_trips(cfg),
            trips: [state.risk_trips(), state.implausible_trips],
            caveats: caveats(model, state),
        }
    }

    /// The verdict as plain sentences, headline first: what `status` prints and the report
    /// opens with.
    pub fn lines(&self) -> Vec<String> {
        let mut out = vec![self.headline()];
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
            return format!(
                "NORMAL{at}: consistent with the healthy reference (drifts {}); {}.",
                ds.join(", "),
                self.inspect
            );
        }
        let since = self
            .since
            .map_or(String::new(), |t| format!(" since {}", day_text(t)));
        let what = match self.drifts.iter().find(|d| d.mode == self.mode) {
            Some(d) => drift_text(d),
            None => {
                let ds: Vec<String> = self.drifts.iter().map(drift_text).collect();
                format!("drifts {}", ds.join(", "))
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
            sig(r),
            sig(adv),
            sig(alm)
        );
        if self.cusum_ratio >= 0.5 {
            s.push_str(&format!(
                "; the sequential test stands at G/h = {:.2} (1 decides) over {} trips",
                self.cusum_ratio, self.changed_trips
            ));
        }
        s.push_str(&format!(
            "; {} trips taken as machine evidence, {} refused as sensor-implausible.",
            self.trips[0], self.trips[1]
        ));
        s
    }
}

/// `Kd +4.1 ± 0.7 %`, `brake drag n/a` before the regression is determined.
fn drift_text(d: &Drift) -> String {
    if !d.value.is_finite() {
        return format!("{} n/a", d.quantity);
    }
    format!("{} {:+.1} ± {:.1} {}", d.quantity, d.value, d.se, d.unit)
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
                    let days = |x: f64| (x - now) / 86_400.0;
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

/// Three significant digits, plainly.
fn sig(v: f64) -> String {
    if !v.is_finite() {
        return "n/a".into();
    }
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if !(1e-3..1e6).contains(&a) {
        format!("{v:.2e}")
    } else {
        let d = (2 - a.log10().floor() as i32).max(0) as usize;
        format!("{v:.d$}")
    }
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
        .filter(|p| p.prior_sd.is_some() && !p.determined)
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
