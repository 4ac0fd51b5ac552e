//! Availability and doors end to end: one elevator learnt from a healthy week with the
//! field's doors, then simulated outages, a car stuck between landings and slowly slowing
//! doors raise their events at the right times, and a healthy month raises none of them;
//! a save and resume in the middle of an outage gives the same events and usage as one run.

use liftwatch::sample::{DAY_S, HOUR_S};
use std::sync::OnceLock;

use liftwatch::fit::{fit, FittedModel};
use liftwatch::mode::FaultMode;
use liftwatch::model::TrainConfig;
use liftwatch::monitor::{Method, Monitor, MonitorRow, MonitorState};
use liftwatch::operation::{OperationEvent, OutageKind, STUCK_LIMIT_S};
use liftwatch::rng::Rng;
use liftwatch::sim::{
    self, DoorBehaviour, OutagePlan, Ramp, RawRow, SimConfig, SimElevator, SimSink, SimTruth,
    TruthRow,
};
use liftwatch::{Elevator, Sample};

/// The outage's start is dated from the last motion before it: in working hours the car
/// travels every few minutes, so it lies within this many seconds before the true start.
const START_TOLERANCE_S: f64 = 600.0;

/// The end is the first moving sample after the car is back in service: brake lift and the
/// grid's step put it within seconds.
const END_TOLERANCE_S: f64 = 10.0;

fn elevator() -> Elevator {
    Elevator::new(1000.0, 1.6, 16)
}

fn plant() -> SimElevator {
    SimElevator::from_elevator(&elevator(), &mut Rng::new(71))
}

fn config(start_days: f64, days: f64, seed: u64) -> SimConfig {
    let mut cfg = SimConfig::new(elevator(), days, seed);
    cfg.plant = Some(plant());
    cfg.start_s = start_days * DAY_S;
    cfg.doors = DoorBehaviour::Field;
    cfg
}

/// Feeds the simulator's own aligned seconds straight into a monitor (no raw rows kept: a
/// month of them would not fit in a test's memory).
struct Watch {
    model: &'static FittedModel,
    monitor: Monitor,
    rows: Vec<MonitorRow>,
    /// Save and resume the monitor every this many samples (0: never).
    resume_every: u64,
    n: u64,
}

impl SimSink for Watch {
    fn raw(&mut self, _row: RawRow) -> liftwatch::Result<()> {
        Ok(())
    }
    fn truth(&mut self, row: &TruthRow) -> liftwatch::Result<()> {
        self.push(&row.sample);
        Ok(())
    }
}

impl Watch {
    fn push(&mut self, x: &Sample) {
        if let Some(r) = self.monitor.push(x) {
            self.rows.push(r);
        }
        self.n += 1;
        if self.resume_every > 0 && self.n % self.resume_every == 0 {
            let json = serde_json::to_string(&self.monitor.state()).unwrap();
            let state: MonitorState = serde_json::from_str(&json).unwrap();
            self.monitor = Monitor::resume(self.model, state).unwrap();
        }
    }
}

/// Simulates `cfg` into the monitor of [`model`]; the rows, the final state and the truth.
fn watch(cfg: &SimConfig, resume_every: u64) -> (Vec<MonitorRow>, MonitorState, SimTruth) {
    watch_with(model(), cfg, resume_every)
}

/// [`watch`] with another model.
fn watch_with(
    model: &'static FittedModel,
    cfg: &SimConfig,
    resume_every: u64,
) -> (Vec<MonitorRow>, MonitorState, SimTruth) {
    let mut w = Watch {
        model,
        monitor: Monitor::new(model, Method::Pinn),
        rows: Vec::new(),
        resume_every,
        n: 0,
    };
    let truth = sim::run(cfg, &mut w, &mut |_| {}).expect("a valid simulation");
    w.rows.extend(w.monitor.finish());
    (w.rows, w.monitor.state(), truth)
}

/// The model fitted on the simulation `cfg` (150 epochs: the operation reference does not
/// depend on the network).
fn fitted(cfg: &SimConfig) -> FittedModel {
    let train = sim::simulate(cfg).expect("a valid simulation").aligned();
    let train_cfg = TrainConfig {
        epochs: 150,
        log_every: 0,
        ..TrainConfig::default()
    };
    fit(&train, &elevator(), &train_cfg, &mut |_| {})
        .expect("the training fits")
        .model
}

/// The model of a healthy week with the field's doors, fitted once for every test here.
fn model() -> &'static FittedModel {
    static MODEL: OnceLock<FittedModel> = OnceLock::new();
    MODEL.get_or_init(|| {
        let model = fitted(&config(0.0, 7.0, 72));
        let op = model.operation.as_ref().expect("the fit learns operation");
        assert!(op.door.is_some(), "a week has enough door cycles");
        assert_eq!(op.landings_m.len(), 16, "every landing was reached");
        model
    })
}

fn operation_events(rows: &[MonitorRow]) -> Vec<OperationEvent> {
    rows.iter()
        .filter_map(|r| r.operation.as_deref().copied())
        .collect()
}

fn machine_events(rows: &[MonitorRow]) -> Vec<String> {
    rows.iter()
        .filter_map(|r| r.event.as_deref().copied())
        .map(|e| e.to_json_line())
        .collect()
}

/// Tuesday of the second week, 10:05: working hours.
const OUTAGE_AT: f64 = 8.0 * DAY_S + 10.0 * HOUR_S + 300.0;

#[test]
fn an_outage_is_dated_and_ended_and_raises_no_machine_event() {
    let mut cfg = config(7.0, 3.0, 73);
    cfg.outages.push(OutagePlan {
        kind: sim::OutageKind::OutOfService,
        start_s: OUTAGE_AT,
        duration_s: 4.0 * HOUR_S,
    });
    let (rows, state, truth) = watch(&cfg, 0);
    let true_outage = &truth.outages[0];
    let events = operation_events(&rows);
    let outages: Vec<_> = events
        .iter()
        .filter(|e| !matches!(e, OperationEvent::Door { .. }))
        .collect();
    assert_eq!(outages.len(), 2, "one start and one end: {events:?}");
    let (OperationEvent::OutageStart(s), OperationEvent::OutageEnd(e)) = (outages[0], outages[1])
    else {
        panic!("{outages:?}")
    };
    assert_eq!(s.kind, OutageKind::OutOfService);
    assert!(
        s.start <= true_outage.start_s + END_TOLERANCE_S
            && s.start >= true_outage.start_s - START_TOLERANCE_S,
        "dated {:.0} s, truth {:.0} s",
        s.start,
        true_outage.start_s
    );
    // Concluded within the first two hours of a weekday morning, long before it ended (101
    // min on this car; 63 while the training's silences were measured at its own rates,
    // which made Λ_max too low: liftwatch::operation, "Why the other days' rates").
    assert!(
        s.detected_at > s.start && s.detected_at - true_outage.start_s < 7200.0,
        "{s:?}"
    );
    assert!(
        (e.end - true_outage.end_s).abs() <= END_TOLERANCE_S,
        "ended {:.0} s, truth {:.0} s",
        e.end,
        true_outage.end_s
    );
    assert_eq!(s.door_open, true_outage.door_open);
    assert!(
        machine_events(&rows).is_empty(),
        "{:?}",
        machine_events(&rows)
    );
    // That day's availability is what 4 h and a few minutes out of 24 h leave.
    let day = (OUTAGE_AT / DAY_S).floor() as i64;
    let u = state.operation.days.iter().find(|u| u.day == day).unwrap();
    let want = 1.0 - (true_outage.end_s - true_outage.start_s) / DAY_S;
    assert!(
        (u.availability() - want).abs() < START_TOLERANCE_S / DAY_S + 0.001,
        "{u:?}"
    );
    assert!(state.operation.availability(7) < 1.0);
}

/// Learnt from Monday to Wednesday only, then watched for eight days with a save and resume
/// every 99,991 samples: the car out of service for four hours on the first Friday stands
/// in hours the training never saw, and is not reported (the limit the module docs state);
/// by the second Thursday the monitor has counted Thursday's morning, and the same four hours
/// are reported, dated and ended as a week's model does. No other outage in the eight days
/// (two weekends judged at the rates counted on the first).
#[test]
fn a_monitor_learns_the_hours_its_short_training_never_saw() {
    // `watch_with` resumes the monitor from its state with the model it is given.
    let short: &'static FittedModel = Box::leak(Box::new(fitted(&config(0.0, 3.0, 72))));
    let unseen = &short.operation.as_ref().unwrap().unseen_hours;
    assert_eq!(unseen.len(), 4 * 24, "Thursday to Sunday");
    let mut cfg = config(3.0, 8.0, 74);
    let friday = 4.0 * DAY_S + 10.0 * HOUR_S + 300.0;
    let thursday = 10.0 * DAY_S + 10.0 * HOUR_S + 300.0;
    for start_s in [friday, thursday] {
        cfg.outages.push(OutagePlan {
            kind: sim::OutageKind::OutOfService,
            start_s,
            duration_s: 4.0 * HOUR_S,
        });
    }
    let (rows, state, truth) = watch_with(short, &cfg, 99_991);
    let starts: Vec<_> = operation_events(&rows)
        .into_iter()
        .filter_map(|e| match e {
            OperationEvent::OutageStart(o) => Some(o),
            _ => None,
        })
        .collect();
    assert_eq!(starts.len(), 1, "{starts:?}");
    let (s, t) = (starts[0], &truth.outages[1]);
    assert!(
        s.start <= t.start_s + END_TOLERANCE_S && s.start >= t.start_s - START_TOLERANCE_S,
        "dated {:.0} s, truth {:.0} s",
        s.start,
        t.start_s
    );
    assert!(s.detected_at - t.start_s < 7200.0, "{s:?}");
    assert_eq!(state.operation.outages, 1);
    let ended = state.operation.last_outage.expect("the outage ended");
    assert!((ended.end - t.end_s).abs() <= END_TOLERANCE_S, "{ended:?}");
}

/// The same week with the car out of service for four hours of a Wednesday: the training's
/// own outage. Kept among its silences it set Λ_max twelve times too high (411 expected
/// trips against 34 on another simulated week, `simulate --days 7 --seed 3 --outage
/// out-of-service --onset-days 2.42`), and an outage would be concluded after ten hours
/// instead of one.
#[test]
fn an_outage_in_the_training_is_left_out_of_how_long_the_car_may_stand_idle() {
    let mut cfg = config(0.0, 7.0, 72);
    cfg.outages.push(OutagePlan {
        kind: sim::OutageKind::OutOfService,
        start_s: 2.0 * DAY_S + 10.0 * HOUR_S,
        duration_s: 4.0 * HOUR_S,
    });
    let with_outage = fitted(&cfg);
    let with = with_outage
        .operation
        .as_ref()
        .unwrap()
        .outage_expected_trips;
    let healthy = model().operation.as_ref().unwrap().outage_expected_trips;
    // Four hours without trips move the day's rates and which days judge which, so Λ_max
    // moves too (54.5 against 41.7 expected trips here), but not by the outage's own length.
    assert!(
        (with / healthy - 1.0).abs() < 0.5,
        "Λ_max {with:.1} with the outage in the training, {healthy:.1} without"
    );
    let noted = |m: &FittedModel| {
        m.summary
            .warnings
            .iter()
            .any(|w| w.starts_with("the training holds 1 silence"))
    };
    assert!(noted(&with_outage), "{:?}", with_outage.summary.warnings);
    assert!(!noted(model()), "{:?}", model().summary.warnings);
}

#[test]
fn a_car_stuck_between_floors_is_an_outage_from_its_stop() {
    let mut cfg = config(7.0, 2.0, 74);
    cfg.outages.push(OutagePlan {
        kind: sim::OutageKind::StuckBetweenFloors,
        start_s: OUTAGE_AT,
        duration_s: 1800.0,
    });
    let (rows, _, truth) = watch(&cfg, 0);
    let true_outage = &truth.outages[0];
    let events: Vec<_> = operation_events(&rows)
        .into_iter()
        .filter(|e| !matches!(e, OperationEvent::Door { .. }))
        .collect();
    // One start and one end: the hop that frees the car starts off its landing, so its
    // distance ends it "between landings" again, but its door then opens, which no door
    // does away from a landing.
    assert_eq!(events.len(), 2, "{events:?}");
    let OperationEvent::OutageStart(s) = events[0] else {
        panic!("{events:?}")
    };
    assert_eq!(s.kind, OutageKind::StuckBetweenFloors, "{s:?}");
    assert!(
        (s.start - true_outage.start_s).abs() <= END_TOLERANCE_S,
        "{s:?} {true_outage:?}"
    );
    assert!(
        (s.detected_at - s.start - STUCK_LIMIT_S).abs() <= END_TOLERANCE_S,
        "{s:?}"
    );
    let OperationEvent::OutageEnd(e) = events[1] else {
        panic!("{events:?}")
    };
    assert!(
        (e.end - true_outage.end_s).abs() <= END_TOLERANCE_S,
        "{e:?}"
    );
    assert!(
        machine_events(&rows).is_empty(),
        "{:?}",
        machine_events(&rows)
    );
}

#[test]
fn slowly_slowing_doors_raise_the_door_advisory_after_the_onset() {
    let (onset, full) = (10.0 * DAY_S, 22.0 * DAY_S);
    let mut cfg = config(7.0, 15.0, 75);
    cfg.doors = DoorBehaviour::slowing(onset, Ramp::Linear, full, 1.0).unwrap();
    let (rows, state, _) = watch(&cfg, 0);
    let door: Vec<_> = operation_events(&rows)
        .into_iter()
        .filter_map(|e| match e {
            OperationEvent::Door { time, raised, .. } => Some((time, raised)),
            _ => None,
        })
        .collect();
    let first = door
        .first()
        .expect("the slowing doors raise the door advisory");
    assert!(first.1, "{door:?}");
    assert!(
        first.0 > onset && first.0 < full,
        "raised on day {:.2}",
        first.0 / DAY_S
    );
    let line = rows
        .iter()
        .find_map(|r| r.operation.as_deref().copied())
        .unwrap()
        .to_json_line();
    assert!(line.contains(r#""mode":"door""#) && line.contains(r#""level":"advisory""#));
    assert!(state.operation.door.raised);
    // No outage: the car kept travelling.
    assert!(operation_events(&rows)
        .iter()
        .all(|e| matches!(e, OperationEvent::Door { .. })));
    assert_eq!(FaultMode::Door.as_str(), "door");
}

#[test]
fn a_healthy_month_has_no_door_or_outage_event() {
    let (rows, state, _) = watch(&config(7.0, 30.0, 76), 0);
    let events = operation_events(&rows);
    assert!(events.is_empty(), "{events:?}");
    assert!(!state.operation.door.raised);
    assert_eq!(state.operation.availability(30), 1.0);
    let days = &state.operation.days;
    assert_eq!(days.len(), 30, "30 days from midnight");
    assert!(days.iter().all(|u| u.trips > 50 && u.door_cycles > 50));
}

#[test]
fn save_and_resume_equals_one_run() {
    let mut cfg = config(7.0, 2.0, 77);
    cfg.outages.push(OutagePlan {
        kind: sim::OutageKind::OutOfService,
        start_s: OUTAGE_AT,
        duration_s: 3.0 * HOUR_S,
    });
    let (whole, whole_state, _) = watch(&cfg, 0);
    // Every 997 samples: many of the saves fall inside the outage, between its start and
    // its detection, and inside door cycles.
    let (parts, parts_state, _) = watch(&cfg, 997);
    let lines = |rows: &[MonitorRow]| -> Vec<String> {
        operation_events(rows)
            .iter()
            .map(OperationEvent::to_json_line)
            .collect()
    };
    assert_eq!(lines(&whole).len(), 2, "{:?}", lines(&whole));
    assert_eq!(lines(&parts), lines(&whole));
    // As JSON: the state's exact numbers, NaN included (NaN ≠ NaN for PartialEq).
    let json = |s: &MonitorState| serde_json::to_string(&s.operation).unwrap();
    assert_eq!(json(&parts_state), json(&whole_state));
}
