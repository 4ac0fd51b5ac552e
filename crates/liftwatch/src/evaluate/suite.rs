//! Evaluation, the suite: the simulated fleet and its cases, the training of each elevator
//! (hidden plant, healthy day, fit, chart limits) and the monitored run of each case.
//!
//! ```text
//! per elevator: plant (seed tag 1) → healthy training run (tag 2) → fit → chart limits (tag 3)
//! per case:     same plant, seed tag 100 + hash of the case's name → monitored run, onset at
//!               40 % of the span (a case added or removed leaves every other case's run as it was)
//!               → Monitor(Pinn), Monitor(Threshold), trips → metrics
//! ```

use crate::sample::{DAY_S, HOUR_S};
use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;

use super::charts::{ChartCalibration, Cusum, Ewma, CUSUM_K, EWMA_LAMBDA};
use super::metrics::{AlignedLog, CaseSink, KeptLog, MethodResult, Metrics};
use super::trips::{healthy_trip_means, TripGrouper};
use crate::alarm::Level;
use crate::elevator::Elevator;
use crate::error::{Error, Result};
use crate::fit::{fit, FittedModel};
use crate::mode::FaultMode;
use crate::model::TrainConfig;
use crate::monitor::{Method, Monitor};
use crate::rng::Rng;
use crate::sim::plant::efficiency_problem;
use crate::sim::scenario::healthy_or_mode;
use crate::sim::scenario::VOLTAGE_OFFSET_V;
use crate::sim::service::{OutageKind, OutagePlan};
use crate::sim::{self, DriveAtRest, Ramp, Scenario, SensorFault, SimConfig, SimElevator};

/// Hour of the day at which a training shorter than a day starts: 07:00, the morning peak
/// of the simulator's office traffic, as a technician would record the paper's 3 hours.
pub const SHORT_TRAINING_START_H: f64 = 7.0;

/// Hour of the day at which an outage case's outage is due: 10:00 on a weekday, when the
/// simulator's office building is in service and a stopped car is missed, as it would be on
/// the days an owner asks about. A car stopped at night is an outage the traffic cannot tell
/// from a quiet night until the morning, which measures the traffic, not the monitor.
/// The stuck speed sensor's hour is due then too ([`service_hour`]): a reading frozen at rest
/// is a fault only once the car moves, and the hour it once had, from the onset at midnight,
/// saw the 1000 kg car of seed 3 stand still throughout, a fault no method could have seen.
pub const OUTAGE_START_H: f64 = 10.0;
/// How long an outage case's car stays out of service: 4 h, a maintenance visit or a car
/// switched off for the morning (long enough for the office's mid-morning traffic to miss it).
pub const OUT_OF_SERVICE_S: f64 = 4.0 * HOUR_S;
/// How long an outage case's car stays stuck between landings: 1 h, within the 20-60 min a
/// rescue takes (`crate::sim::service`).
pub const STUCK_S: f64 = HOUR_S;
/// Time an outage case keeps after its outage ends (s): the car's return to service must be
/// seen, and a second report after it (as a freed stuck car once raised) must have the time
/// to appear.
pub const AFTER_OUTAGE_S: f64 = 6.0 * HOUR_S;

/// One elevator of the suite.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FleetElevator {
    /// Short name used in case names.
    pub name: String,
    /// Its description.
    pub elevator: Elevator,
}

/// One case of the suite.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Case {
    /// Unique name, e.g. `E2 friction linear S1.0`.
    pub name: String,
    /// Index into the suite's elevators.
    pub elevator: usize,
    /// What is wrong: a [`FaultMode`], None when healthy (written `healthy`).
    #[serde(with = "healthy_or_mode")]
    pub truth: Option<FaultMode>,
    /// Machine degradation (healthy for sensor cases).
    pub scenario: Scenario,
    /// Sensor fault, if any.
    pub sensor_fault: Option<SensorFault>,
    /// Monitored span (days).
    pub days: f64,
    /// Onset (days from the start); None when healthy.
    pub onset_days: Option<f64>,
    /// An outage of a healthy car ([`outage_plan`]): the machine stays healthy, so any fault
    /// advisory of the run is false, and the metrics ask whether the outage was reported, when
    /// and how right ([`super::metrics::OutageResult`]). None in every other case.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub outage: Option<OutagePlan>,
}

/// Settings of a suite.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SuiteConfig {
    /// Base seed; every run's seed derives from it.
    pub seed: u64,
    /// The small subset for tests and CI.
    pub quick: bool,
    /// Healthy training span per elevator (days).
    pub train_days: f64,
    /// Monitored span of a fault case (days).
    pub fault_days: f64,
    /// Monitored span of a healthy case (days).
    pub healthy_days: f64,
    /// Days from onset to full severity of the linear and exponential degradations; None:
    /// to the end of the run (a slow ramp that a short run sees only the start of).
    pub ramp_days: Option<f64>,
    /// Multiplier of every degradation's severity (1: the maintenance-relevant default
    /// sizes of [`crate::sim::scenario`], at which the threshold method seldom fires; 5 gives
    /// the large final sizes of a field bench, Kd +50 %).
    pub severity_scale: f64,
    /// Worker threads (results do not depend on it).
    pub threads: usize,
    /// Keep only the cases whose name contains one of these (all when empty). A case's run
    /// and its elevator's training are the same as in the whole suite: every seed derives
    /// from the elevator's place in the fleet and the case's name, never from the selection.
    pub only: Vec<String>,
    /// What every plant's drive does at standstill: energised (the default) or off, as most
    /// real drives are ([`DriveAtRest`]).
    pub drive_at_rest: DriveAtRest,
    /// Every plant's transmission efficiency η ([`SimElevator::efficiency`]); 1, lossless, by
    /// default.
    pub efficiency: f64,
    /// Seed of the network's initial weights in every training ([`TrainConfig::seed`], as
    /// `fit --seed`). The plants, runs and faults do not move with it: what moves is the
    /// method's own spread over the network's draw, against which a few first modes gained or
    /// lost between two builds must be read (stage 2 ends where its budget stops a
    /// non-convex walk, and a walk started from θ a billionth apart ends elsewhere too).
    pub net_seed: u64,
    /// Draws of the network in every training ([`TrainConfig::draws`], as `fit --draws`).
    pub draws: usize,
    /// A directory to keep what each run was (`evaluate --keep-runs`): every trained
    /// elevator's model (`E2-model.json`) and every case's aligned log as its monitors read it
    /// (`E2-motor-linear-S0.5.csv.zst`, zstd: a 25-day run is about 2.2 M samples), so that one
    /// case can be traced with `monitor`, `report` and `status`. None: nothing is kept.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub keep_runs: Option<PathBuf>,
}

impl SuiteConfig {
    /// The full suite (`quick = false`) or its small subset.
    pub fn new(seed: u64, quick: bool) -> Self {
        SuiteConfig {
            seed,
            quick,
            train_days: 7.0,
            fault_days: if quick { 8.0 } else { 25.0 },
            healthy_days: if quick { 8.0 } else { 30.0 },
            ramp_days: None,
            severity_scale: 1.0,
            threads: 2,
            only: Vec::new(),
            drive_at_rest: DriveAtRest::Energised,
            efficiency: 1.0,
            net_seed: TrainConfig::default().seed,
            draws: TrainConfig::default().draws,
            keep_runs: None,
        }
    }
}

/// The elevators of the suite: 630-1600 kg, 1-2.5 m/s, 8-40 floors (the quick subset uses
/// the middle one).
pub fn fleet(quick: bool) -> Vec<FleetElevator> {
    let all = [
        ("E1", Elevator::new(630.0, 1.0, 8)),
        ("E2", Elevator::new(1000.0, 1.75, 20)),
        ("E3", Elevator::new(1600.0, 2.5, 40)),
    ];
    all.into_iter()
        .filter(|(n, _)| !quick || *n == "E2")
        .map(|(n, e)| FleetElevator {
            name: n.into(),
            elevator: e,
        })
        .collect()
}

/// The cases of the suite for `fleet`.
///
/// # Errors
/// [`Error::InvalidConfig`] when a span is not positive.
pub fn cases(cfg: &SuiteConfig, fleet: &[FleetElevator]) -> Result<Vec<Case>> {
    if !(cfg.fault_days > 0.0 && cfg.healthy_days > 0.0 && cfg.train_days > 0.0) {
        return Err(Error::InvalidConfig {
            field: "evaluate.days",
            why: "every span must be positive".into(),
        });
    }
    if !(cfg.severity_scale.is_finite() && cfg.severity_scale > 0.0) {
        return Err(Error::InvalidConfig {
            field: "evaluate.severity_scale",
            why: format!("{} must be positive", cfg.severity_scale),
        });
    }
    if let Some(why) = efficiency_problem(cfg.efficiency) {
        return Err(Error::InvalidConfig {
            field: "evaluate.efficiency",
            why,
        });
    }
    let span = cfg.fault_days * DAY_S;
    let onset = 0.4 * span;
    let full_at = match cfg.ramp_days {
        None => span,
        Some(d) if d.is_finite() && d >= 0.0 => onset + d * DAY_S,
        Some(d) => {
            return Err(Error::InvalidConfig {
                field: "evaluate.ramp_days",
                why: format!("{d} must be at least 0"),
            })
        }
    };
    let mut out = Vec::new();
    for (ei, fe) in fleet.iter().enumerate() {
        out.push(Case {
            name: format!("{} healthy", fe.name),
            elevator: ei,
            truth: None,
            scenario: Scenario::healthy(),
            sensor_fault: None,
            days: cfg.healthy_days,
            onset_days: None,
            outage: None,
        });
        let shapes: Vec<(Ramp, f64)> = if cfg.quick {
            vec![(Ramp::Linear, 1.0)]
        } else {
            vec![
                (Ramp::Linear, 1.0),
                (Ramp::Linear, 0.5),
                (Ramp::Exponential, 1.0),
                (Ramp::Exponential, 0.5),
                (Ramp::Step, 0.5),
            ]
        };
        let modes: &[FaultMode] = if cfg.quick {
            &[FaultMode::Friction, FaultMode::Motor]
        } else {
            &[FaultMode::Motor, FaultMode::Friction, FaultMode::Brake]
        };
        for &mode in modes {
            for &(ramp, sev) in &shapes {
                let sev = sev * cfg.severity_scale;
                out.push(Case {
                    name: format!(
                        "{} {} {} S{:.1}",
                        fe.name,
                        mode.as_str(),
                        ramp_name(ramp),
                        sev
                    ),
                    elevator: ei,
                    truth: Some(mode),
                    scenario: Scenario::new(mode, onset, ramp, full_at, sev)?,
                    sensor_fault: None,
                    days: cfg.fault_days,
                    onset_days: Some(onset / DAY_S),
                    outage: None,
                });
            }
        }
        let mut sensors = vec![(
            "stuck-speed",
            SensorFault::StuckSpeed {
                onset_s: service_hour(onset),
                duration_s: HOUR_S,
            },
        )];
        if !cfg.quick {
            sensors.push((
                "load-drift",
                SensorFault::LoadDrift {
                    onset_s: onset,
                    pct_per_day: 2.0,
                },
            ));
            sensors.push((
                "voltage-offset",
                SensorFault::VoltageOffset {
                    onset_s: onset,
                    volts: VOLTAGE_OFFSET_V,
                },
            ));
        }
        for (name, f) in sensors {
            let onset = f.onset_s();
            out.push(Case {
                name: format!("{} sensor {name}", fe.name),
                elevator: ei,
                truth: Some(FaultMode::Sensor),
                scenario: Scenario::healthy(),
                sensor_fault: Some(f),
                days: cfg.fault_days,
                onset_days: Some(onset / DAY_S),
                outage: None,
            });
        }
        let outages: &[OutageKind] = if cfg.quick {
            &[OutageKind::StuckBetweenFloors]
        } else {
            &[OutageKind::OutOfService, OutageKind::StuckBetweenFloors]
        };
        for &kind in outages {
            if let Some(plan) = outage_plan(kind, onset, span) {
                out.push(Case {
                    name: format!("{} outage {}", fe.name, outage_name(kind)),
                    elevator: ei,
                    truth: None,
                    scenario: Scenario::healthy(),
                    sensor_fault: None,
                    days: cfg.fault_days,
                    onset_days: None,
                    outage: Some(plan),
                });
            }
        }
    }
    if !cfg.only.is_empty() {
        out.retain(|c| cfg.only.iter().any(|o| c.name.contains(o.as_str())));
        if out.is_empty() {
            return Err(Error::InvalidConfig {
                field: "evaluate.only",
                why: format!("no case name contains any of {:?}", cfg.only),
            });
        }
    }
    Ok(out)
}

/// The outage of an outage case of `kind` in a run of `span` seconds: due at the first
/// [`OUTAGE_START_H`] of a weekday at or after `onset` (the fault cases' onset, so that it
/// follows as much monitoring as they do), lasting [`OUT_OF_SERVICE_S`] or [`STUCK_S`]; `None`
/// when the run ends less than [`AFTER_OUTAGE_S`] after it (no outage case then).
pub fn outage_plan(kind: OutageKind, onset: f64, span: f64) -> Option<OutagePlan> {
    let duration_s = match kind {
        OutageKind::OutOfService => OUT_OF_SERVICE_S,
        OutageKind::StuckBetweenFloors => STUCK_S,
    };
    let start_s = service_hour(onset);
    (start_s + duration_s + AFTER_OUTAGE_S <= span).then_some(OutagePlan {
        kind,
        start_s,
        duration_s,
    })
}

/// The first [`OUTAGE_START_H`] of a weekday at or after `onset` (s): when an outage case's
/// outage and the stuck speed sensor's hour are due.
pub fn service_hour(onset: f64) -> f64 {
    let at = OUTAGE_START_H * HOUR_S;
    // Day 0 of a run is a Monday (`SimConfig::start_s`): days 5 and 6 of each week are its
    // weekend.
    let mut day = ((onset - at) / DAY_S).ceil().max(0.0);
    while day.rem_euclid(7.0) >= 5.0 {
        day += 1.0;
    }
    day * DAY_S + at
}

/// An outage kind as a case name has it.
fn outage_name(kind: OutageKind) -> &'static str {
    match kind {
        OutageKind::OutOfService => "out-of-service",
        OutageKind::StuckBetweenFloors => "stuck",
    }
}

fn ramp_name(r: Ramp) -> &'static str {
    match r {
        Ramp::Step => "step",
        Ramp::Linear => "linear",
        Ramp::Exponential => "exponential",
    }
}

/// Seed of run `tag` of elevator `e`: distinct for the plant, training and each case.
fn derive_seed(base: u64, e: usize, tag: u64) -> u64 {
    let mut r = Rng::new(base ^ ((e as u64 + 1) << 40) ^ tag.wrapping_mul(0x9E37_79B9_7F4A_7C15));
    r.next_u64()
}

/// The file of `name` (a case's or an elevator's, its spaces as dashes) with `extension` in
/// the `--keep-runs` directory `dir`.
pub fn kept_path(dir: &Path, name: &str, extension: &str) -> PathBuf {
    dir.join(format!("{}.{extension}", name.replace(' ', "-")))
}

/// A case's seed tag from its name (FNV-1a, 64 bits, [`crate::file::fnv1a`]): stable when
/// cases are added, removed or reordered, as an index into the list is not.
fn name_tag(name: &str) -> u64 {
    crate::file::fnv1a(name.as_bytes())
}

/// The trained reference of one elevator: hidden plant, model and chart limits.
#[derive(Clone, Debug)]
pub struct Trained {
    /// The hidden plant shared by the training and the monitored runs.
    pub plant: SimElevator,
    /// The fitted model.
    pub model: FittedModel,
    /// The charts' standardisation and limits.
    pub charts: ChartCalibration,
}

/// Summary of one elevator's training for the report.
#[derive(Clone, Debug, Serialize)]
pub struct ElevatorReport {
    /// Name and description.
    #[serde(flatten)]
    pub fleet: FleetElevator,
    /// Chart calibration.
    pub charts: ChartCalibration,
    /// liftwatch's advisory threshold on R.
    pub advisory_threshold: f64,
    /// σ_U of the fit (V).
    pub sigma_u_v: f64,
    /// Threshold method's voltage limit (V) and friction limit (N).
    pub threshold_limits: (f64, f64),
    /// Wall time of simulation, fit and calibration (s).
    pub seconds: f64,
}

/// Draws the plant, simulates the healthy training run, fits and calibrates the charts.
///
/// # Errors
/// Whatever simulation, fit or calibration fail with.
pub fn train(fe: &FleetElevator, e: usize, cfg: &SuiteConfig) -> Result<Trained> {
    let mut plant =
        SimElevator::from_elevator(&fe.elevator, &mut Rng::new(derive_seed(cfg.seed, e, 1)));
    plant.drive_at_rest = cfg.drive_at_rest;
    plant.efficiency = cfg.efficiency;
    let mut sc = SimConfig::new(
        fe.elevator.clone(),
        cfg.train_days,
        derive_seed(cfg.seed, e, 2),
    );
    sc.plant = Some(plant.clone());
    if cfg.train_days < 1.0 {
        // A training shorter than a day (the paper's 3 hours) is a stretch of daytime
        // service, not the empty small hours a midnight start would give it.
        sc.start_s = SHORT_TRAINING_START_H * HOUR_S;
    }
    // Fitted on what the technician would have: the training log aligned by the one aligner,
    // with its interpolation error at trip edges, as the monitored runs are watched.
    let (series, _) = sim::simulate_aligned(&sc)?;
    let train = TrainConfig {
        seed: cfg.net_seed,
        draws: cfg.draws,
        ..TrainConfig::default()
    };
    let outcome = fit(&series, &fe.elevator, &train, &mut |_| {})?;
    let model = outcome.model;
    let means = healthy_trip_means(&model, &series);
    let charts = ChartCalibration::calibrate(&means, cfg.train_days, derive_seed(cfg.seed, e, 3))?;
    Ok(Trained {
        plant,
        model,
        charts,
    })
}

/// One case's results.
#[derive(Clone, Debug, Serialize)]
pub struct CaseResult {
    /// The case.
    #[serde(flatten)]
    pub case: Case,
    /// Trips seen by the charts.
    pub trips: usize,
    /// Mean standardised trip residual z over the last fifth of the span: the shift the charts
    /// had to see at (nearly) full severity, in units of the healthy trip-mean spread σ0.
    pub late_mean_z: f64,
    /// Results of liftwatch, threshold, CUSUM, EWMA in that order.
    pub methods: Vec<MethodResult>,
    /// The oracle floor of a machine fault's delay (days, [`super::floor`]): when the CUSUM
    /// that knows the fault's mode and size at every trip would detect it; `None` on healthy
    /// and sensor cases, and when the run never gathers that evidence.
    pub floor_delay_days: Option<f64>,
    /// Wall time of the case (s).
    pub seconds: f64,
}

/// Simulates and monitors one case with its elevator's trained reference.
///
/// # Errors
/// Whatever the simulation fails with.
pub fn run_case(case: &Case, trained: &Trained, cfg: &SuiteConfig) -> Result<CaseResult> {
    let clock = Instant::now();
    let mut sc = SimConfig::new(
        trained.model.hybrid.elevator.clone(),
        case.days,
        derive_seed(cfg.seed, case.elevator, 100 + name_tag(&case.name)),
    );
    sc.plant = Some(trained.plant.clone());
    sc.scenario = case.scenario.clone();
    sc.sensor_fault = case.sensor_fault.clone();
    sc.outages.extend(case.outage);
    let model = &trained.model;
    let mut sink = CaseSink {
        pinn: Monitor::new(model, Method::Pinn),
        thr: Monitor::new(model, Method::Threshold),
        seg_pinn: TripGrouper::new(model.hybrid.scales.sigma_u_v),
        seg_thr: TripGrouper::new(model.hybrid.scales.sigma_u_v),
        trips: Vec::new(),
        thr_trips: Vec::new(),
        events: Vec::new(),
        door_advisories: 0,
        outages: Vec::new(),
        thr_activations: Vec::new(),
        thr_prev: Level::Normal,
        severity: Vec::with_capacity((case.days * DAY_S) as usize + 2),
        start: sc.start_s,
        kept: cfg
            .keep_runs
            .as_deref()
            .map(|dir| KeptLog::new(kept_path(dir, &case.name, "csv.zst"))),
    };
    // The monitors watch the raw log aligned as it is logged, as in the field; the truth rows
    // only give the severity per second.
    let mut log = AlignedLog::new(&mut sink)?;
    let truth = sim::run(&sc, &mut log, &mut |_| {})?;
    log.finish()?;
    sink.finish();
    if let Some(k) = sink.kept.take() {
        k.commit()?;
    }
    let onset = case.onset_days.map(|d| sc.start_s + d * DAY_S);
    let end = sc.start_s + sc.duration_s();
    let exposure_days = (onset.unwrap_or(end) - sc.start_s) / DAY_S;
    let ctx = Metrics {
        onset,
        exposure_days,
        truth: case.truth,
        channel: case.sensor_fault.as_ref().map(SensorFault::channel),
        sink: &sink,
        scenario: &case.scenario,
        f_c: trained.plant.f_c,
        friction_n: trained.plant.f_c + trained.plant.c_visc * trained.plant.rated.rated_speed_mps,
        outages: &truth.outages,
    };
    let methods = vec![
        ctx.liftwatch(),
        ctx.threshold(),
        ctx.chart(
            "cusum",
            Cusum::new(CUSUM_K, trained.charts.cusum_h),
            &trained.charts,
        ),
        ctx.chart(
            "ewma",
            Ewma::new(EWMA_LAMBDA, trained.charts.ewma_l),
            &trained.charts,
        ),
    ];
    Ok(CaseResult {
        case: case.clone(),
        trips: sink.trips.len(),
        late_mean_z: {
            let late = end - 0.2 * sc.duration_s();
            let z: Vec<f64> = sink
                .trips
                .iter()
                .filter(|t| t.end >= late)
                .map(|t| trained.charts.standardise(t.mean_e_u))
                .collect();
            z.iter().sum::<f64>() / z.len().max(1) as f64
        },
        methods,
        floor_delay_days: ctx.floor_delay_days(model),
        seconds: clock.elapsed().as_secs_f64(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `--net-seed` draws another network for the same plant and training: θ (stage 1, which
    /// no random draw enters) stays to the bit, the network's weights move.
    #[test]
    fn the_network_seed_moves_the_network_and_nothing_of_the_plant() {
        let mut cfg = SuiteConfig::new(1, true);
        cfg.train_days = 0.125;
        let fe = &fleet(true)[0];
        let one = train(fe, 0, &cfg).expect("the paper's 3 hours train");
        cfg.net_seed += 1;
        let other = train(fe, 0, &cfg).expect("the paper's 3 hours train");
        assert_eq!(one.plant, other.plant);
        assert_eq!(
            one.model.hybrid.parameters, other.model.hybrid.parameters,
            "θ is stage 1's and draws nothing"
        );
        assert_ne!(one.model.hybrid.net.weights, other.model.hybrid.net.weights);
    }

    /// An outage case's outage is due at 10:00 on the first weekday at or after the onset
    /// (day 0 a Monday), and there is none when the run ends too soon after it.
    #[test]
    fn an_outage_falls_on_the_first_weekday_morning_after_the_onset() {
        let start = |onset_days: f64, span_days: f64| {
            outage_plan(
                OutageKind::OutOfService,
                onset_days * DAY_S,
                span_days * DAY_S,
            )
            .map(|p| p.start_s / DAY_S)
        };
        let ten = OUTAGE_START_H / 24.0;
        // The 7-day runs' onset, day 2.8: Thursday morning, day 3.
        assert_eq!(start(2.8, 7.0), Some(3.0 + ten));
        // Before 10:00 on a Wednesday: that morning.
        assert_eq!(start(2.2, 7.0), Some(2.0 + ten));
        // A Friday afternoon: over the weekend to Monday, day 7.
        assert_eq!(start(4.6, 14.0), Some(7.0 + ten));
        // A run that ends before the outage and the hours after it: no case.
        assert_eq!(start(2.8, 3.5), None);
        let stuck = outage_plan(OutageKind::StuckBetweenFloors, 0.0, DAY_S).unwrap();
        assert_eq!(
            (stuck.start_s, stuck.duration_s),
            (OUTAGE_START_H * HOUR_S, STUCK_S)
        );
        let names: Vec<String> = cases(&SuiteConfig::new(1, true), &fleet(true))
            .unwrap()
            .into_iter()
            .filter(|c| c.outage.is_some())
            .map(|c| c.name)
            .collect();
        assert_eq!(names, ["E2 outage stuck"]);
        // The stuck speed sensor's hour is due then too, and the case's onset is that hour's
        // (the default suite's onset is day 10, a Thursday, at midnight).
        let stuck = cases(&SuiteConfig::new(1, false), &fleet(true))
            .unwrap()
            .into_iter()
            .find(|c| c.name.ends_with("sensor stuck-speed"))
            .unwrap();
        assert_eq!(stuck.onset_days, Some(10.0 + ten));
        assert_eq!(
            stuck.sensor_fault.as_ref().map(SensorFault::onset_s),
            Some((10.0 + ten) * DAY_S)
        );
    }

    /// `--only` keeps the named cases as the whole suite has them (their elevator's place in
    /// the fleet included, which their seeds derive from), and refuses a selection of none.
    #[test]
    fn a_selection_keeps_its_cases_as_the_whole_suite_has_them() {
        let fleet = fleet(false);
        let mut cfg = SuiteConfig::new(1, false);
        let all = cases(&cfg, &fleet).unwrap();
        cfg.only = vec!["E3 healthy".into(), "E1 motor step".into()];
        let some = cases(&cfg, &fleet).unwrap();
        let names: Vec<&str> = some.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["E1 motor step S0.5", "E3 healthy"]);
        assert!(some.iter().all(|c| all.contains(c)));
        assert_eq!(some[1].elevator, 2);
        cfg.only = vec!["E9".into()];
        assert!(matches!(
            cases(&cfg, &fleet),
            Err(Error::InvalidConfig {
                field: "evaluate.only",
                ..
            })
        ));
    }
}
