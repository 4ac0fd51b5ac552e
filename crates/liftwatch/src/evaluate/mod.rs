//! Evaluation: a seeded suite of simulated elevators and degradations that compares liftwatch
//! with the conventional fixed-threshold method and two classical control charts (paper,
//! Sec. 5.3-5.4, made quantitative).
//!
//! ```text
//! per elevator: draw the hidden plant once → healthy training run (1 day) → fit
//!               → per-trip mean voltage residual x_k = mean_i(r_U,i/σ_U) on the training run
//!               → chart limits calibrated to ≤ 1 false signal per elevator-year
//! per case:     same plant, other seed → monitored run (onset at 40 % of the span)
//!               → Monitor(Pinn), Monitor(Threshold), CUSUM and EWMA on x_k → metrics
//! trips:        the features stage's trips (the one segmenter), carried by the monitor rows
//! standardise:  z_k = (x_k − μ0)/σ0          μ0 median, σ0 = 1.4826·MAD of healthy x_k
//! CUSUM:        S⁺ = max(0, S⁺ + z − k),  S⁻ = max(0, S⁻ − z − k),  signal when S± > h, k = 0.5
//! EWMA:         w = λ·z + (1 − λ)·w,  signal when |w| > L·sqrt(λ/(2 − λ)),          λ = 0.1
//! ```
//!
//! Both charts are two-sided: a motor fault (Kd up) raises the voltage when motoring and
//! lowers it when regenerating, so its trip-mean residual moves either way; friction and brake
//! drag raise it. After a signal a chart restarts from zero, so false signals are counted the
//! way an operator would see them.
//!
//! Calibration of the chart limits (h, L): the healthy trip sequence of the training day is
//! resampled by a moving-block bootstrap (blocks of [`BLOCK_TRIPS`] trips, about an hour of
//! traffic, which keeps the within-hour correlation of load and winding temperature) into
//! [`CALIBRATION_YEARS`] years of trips at the training day's trip rate; the limit is the
//! smallest one (bisection) that signals at most once per simulated year. The same search on
//! independent N(0, 1) trips gives a floor, so the limit is never below the textbook value for
//! the same target (for the CUSUM the Siegmund approximation of the in-control ARL,
//! [`cusum_arl`], is reported beside it as a check).
//!
//! One training day cannot show how the healthy trip-mean residual varies from day to day
//! (traffic mix, weekends, the fit's own bias on unseen days), so the limits meet their target
//! on the bootstrap, not necessarily on new days: the suite's healthy runs and pre-onset spans
//! measure the out-of-sample false-signal rate, which is the figure to read.
//!
//! Metrics per method and case: detection delay from the onset (first advisory of liftwatch,
//! first alarm of the threshold method, first signal of a chart), true severity σ at detection
//! (a multiple of the mode's default effect, [`crate::sim::scenario`]), false signals before
//! the onset (or over a whole healthy run) scaled to an elevator-year, misses, the fault mode
//! named at detection, and for the threshold method its flicker count: alarm activations, per
//! trip, after the onset and before the alarm holds for [`PERSISTENT_TRIPS`] trips in a row.
//! Per machine fault, the oracle floor of its delay ([`floor`]): when the CUSUM that knows the
//! fault's mode and size at every trip would detect it. Over the suite, liftwatch's delays
//! against the threshold method's and the floor's ([`compare_delays`]; the text table's last
//! lines, and the figure `evaluate` draws beside `evaluation.json`).
//!
//! Outage cases: per elevator a healthy car out of service for 4 h at a landing, door open or
//! closed, and one stuck between landings for 1 h, each due at 10:00 on the first weekday at
//! or after the fault cases' onset ([`suite::outage_plan`]). Their metrics
//! ([`metrics::OutageResult`]) are whether liftwatch reported the outage, after how long,
//! how far its start and end lie from the truth, whether it named the kind, and its reports
//! where the car served; any fault advisory of theirs is false. They are a group of their
//! own, left out of the healthy rows and the threshold method's quiet elevators, so those
//! read as before the cases existed; the table gives each a line, and counts the outages
//! reported where a car served over every case.
//!
//! Mode implied by the threshold method: the voltage limit is the conventional motor check and
//! the friction-force limit the lubrication check; after the onset the limit that was exceeded
//! on more samples names the mode (`unknown` on a tie). The method has no brake check, so it
//! cannot name a brake fault. The control charts watch one scalar and name no mode.
//!
//! Deviation from the paper: the paper reports one field case per mode; this suite measures
//! delays, false-advisory rates and isolation over seeded simulated fleets instead, so the
//! comparison of Sec. 5.4 can be regenerated and used as a regression net.
//!
//! The rooms: [`charts`] (CUSUM, EWMA, their calibration), [`trips`] (monitor rows to trip
//! means), [`suite`] (fleet, cases, training, the monitored runs), [`metrics`] (per method
//! and case), [`floor`] (the oracle floor of a delay), [`aggregate`](mod@aggregate) (per method and mode,
//! and the delays compared), [`table`](mod@table) (the text summary); this module runs it all.

pub mod aggregate;
pub mod charts;
pub mod floor;
pub mod metrics;
pub mod suite;
pub mod table;
pub mod trips;

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use serde::Serialize;

pub use aggregate::{
    aggregate, compare_delays, delay_pairs, Aggregate, DelayComparison, DelayPair, DelayPairs,
    Versus,
};
pub use charts::{
    block_bootstrap, calibrate_limit, cusum_arl, cusum_h_for_arl, ChartCalibration, ChartKind,
    Cusum, Ewma, BLOCK_TRIPS, CALIBRATION_YEARS, CUSUM_K, EWMA_LAMBDA, TARGET_FALSE_PER_YEAR,
};
pub use metrics::MethodResult;
pub use suite::{
    cases, fleet, run_case, train, Case, CaseResult, ElevatorReport, FleetElevator, SuiteConfig,
    Trained,
};
pub use table::table;
pub use trips::{healthy_trip_means, TripGrouper, TripSummary};

use crate::error::{Error, Result};

/// Consecutive alarmed trips after which the threshold method's alarm counts as persistent.
pub const PERSISTENT_TRIPS: usize = 20;
/// Fewest moving rows with a voltage residual for a trip to enter the charts.
pub const MIN_TRIP_ROWS: usize = 3;

/// The whole evaluation as written to `evaluation.json`.
#[derive(Clone, Debug, Serialize)]
pub struct Evaluation {
    /// Settings.
    pub config: SuiteConfig,
    /// CUSUM k, EWMA λ, target, bootstrap block and years, persistence rule.
    pub chart_settings: ChartSettings,
    /// Per elevator training summary.
    pub elevators: Vec<ElevatorReport>,
    /// Per case results.
    pub cases: Vec<CaseResult>,
    /// Per method and true mode.
    pub aggregates: Vec<Aggregate>,
    /// liftwatch's delays against the threshold method's and the oracle floor's.
    pub delays: DelayComparison,
    /// Wall time (s).
    pub seconds: f64,
}

/// The fixed settings of the comparison.
#[derive(Clone, Debug, Serialize)]
pub struct ChartSettings {
    /// [`CUSUM_K`].
    pub cusum_k: f64,
    /// [`EWMA_LAMBDA`].
    pub ewma_lambda: f64,
    /// [`TARGET_FALSE_PER_YEAR`].
    pub target_false_per_year: f64,
    /// [`BLOCK_TRIPS`].
    pub block_trips: usize,
    /// [`CALIBRATION_YEARS`].
    pub calibration_years: f64,
    /// [`PERSISTENT_TRIPS`].
    pub persistent_trips: usize,
}

/// Runs `f(i)` for `i < n` on `threads` threads; results in index order.
fn par_map<T: Send>(n: usize, threads: usize, f: &(dyn Fn(usize) -> T + Sync)) -> Vec<T> {
    let next = AtomicUsize::new(0);
    let out: Mutex<Vec<Option<T>>> = Mutex::new((0..n).map(|_| None).collect());
    std::thread::scope(|s| {
        for _ in 0..threads.clamp(1, n.max(1)) {
            s.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                if i >= n {
                    break;
                }
                let r = f(i);
                out.lock()
                    .expect("a worker panicked while holding the result lock")[i] = Some(r);
            });
        }
    });
    out.into_inner()
        .expect("every worker has finished")
        .into_iter()
        .map(|r| r.expect("every index was processed"))
        .collect()
}

/// Runs the suite; `progress` receives one line per finished elevator and case.
///
/// # Errors
/// The first error of training or of a case, naming it.
pub fn run_suite(cfg: &SuiteConfig, progress: &(dyn Fn(&str) + Sync)) -> Result<Evaluation> {
    let clock = Instant::now();
    let fleet = fleet(cfg.quick);
    let cases = cases(cfg, &fleet)?;
    let done = AtomicUsize::new(0);
    // Only the elevators of the selected cases are trained; each keeps its place in the
    // fleet, so its seeds (and the whole run) are those of the full suite.
    let needed: Vec<usize> = (0..fleet.len())
        .filter(|e| cases.iter().any(|c| c.elevator == *e))
        .collect();
    let trained = par_map(needed.len(), cfg.threads, &|i| {
        let e = needed[i];
        let t0 = Instant::now();
        let r = train(&fleet[e], e, cfg);
        progress(&format!(
            "trained {} ({}): {:.1} s, elapsed {:.0} s",
            fleet[e].name,
            if r.is_ok() { "ok" } else { "failed" },
            t0.elapsed().as_secs_f64(),
            clock.elapsed().as_secs_f64()
        ));
        r.map(|t| (t, t0.elapsed().as_secs_f64()))
    });
    let mut refs: Vec<Option<Trained>> = vec![None; fleet.len()];
    let mut elevators = Vec::new();
    for (&e, r) in needed.iter().zip(trained) {
        let fe = &fleet[e];
        let (t, secs) =
            r.map_err(|err| Error::Unidentifiable(format!("training of {}: {err}", fe.name)))?;
        elevators.push(ElevatorReport {
            fleet: fe.clone(),
            charts: t.charts.clone(),
            advisory_threshold: t.model.risk.advisory,
            sigma_u_v: t.model.hybrid.scales.sigma_u_v,
            threshold_limits: (
                t.model.baseline.voltage_limit_v,
                t.model.baseline.friction_limit_n,
            ),
            seconds: secs,
        });
        if let Some(dir) = cfg.keep_runs.as_deref() {
            let name = format!("{}-model", fe.name);
            crate::file::save(&suite::kept_path(dir, &name, "json"), &t.model)?;
        }
        refs[e] = Some(t);
    }
    let n = cases.len();
    let results = par_map(n, cfg.threads, &|i| {
        let c = &cases[i];
        let trained = refs[c.elevator]
            .as_ref()
            .expect("every selected case's elevator was trained");
        let r = run_case(c, trained, cfg);
        let k = done.fetch_add(1, Ordering::Relaxed) + 1;
        progress(&format!(
            "case {k}/{n} {}: {:.1} s, elapsed {:.0} s",
            c.name,
            r.as_ref().map_or(f64::NAN, |r| r.seconds),
            clock.elapsed().as_secs_f64()
        ));
        r
    });
    let mut out = Vec::with_capacity(n);
    for (c, r) in cases.iter().zip(results) {
        out.push(r.map_err(|e| Error::Unidentifiable(format!("case {}: {e}", c.name)))?);
    }
    Ok(Evaluation {
        config: cfg.clone(),
        chart_settings: ChartSettings {
            cusum_k: CUSUM_K,
            ewma_lambda: EWMA_LAMBDA,
            target_false_per_year: TARGET_FALSE_PER_YEAR,
            block_trips: BLOCK_TRIPS,
            calibration_years: CALIBRATION_YEARS,
            persistent_trips: PERSISTENT_TRIPS,
        },
        elevators,
        aggregates: aggregate(&out),
        delays: compare_delays(&out),
        cases: out,
        seconds: clock.elapsed().as_secs_f64(),
    })
}
