//! The time-to-maintenance forecast end to end: a simulated drive whose Kd rises linearly with
//! a known slope gets a crossing date of the physical limit whose interval holds the true
//! date; a healthy run of the same elevator forecasts no crossing.

use liftwatch::fit::fit;
use liftwatch::forecast::{When, KD_LIMIT};
use liftwatch::mode::FaultMode;
use liftwatch::model::TrainConfig;
use liftwatch::monitor::{Method, Monitor};
use liftwatch::rng::Rng;
use liftwatch::sample::DAY_S;
use liftwatch::sim::{simulate, Ramp, Scenario, SimConfig, SimElevator};
use liftwatch::verdict::Verdict;
use liftwatch::{AlignedSeries, Elevator};

fn series(
    plant: &SimElevator,
    start_days: f64,
    days: f64,
    seed: u64,
    sc: Scenario,
) -> AlignedSeries {
    let mut cfg = SimConfig::new(Elevator::new(1000.0, 1.75, 26), days, seed);
    cfg.plant = Some(plant.clone());
    cfg.start_s = start_days * DAY_S;
    cfg.scenario = sc;
    simulate(&cfg).expect("a valid simulation").aligned()
}

#[test]
fn a_linear_kd_ramp_is_dated_and_a_healthy_run_is_not() {
    let elevator = Elevator::new(1000.0, 1.75, 26);
    let plant = SimElevator::from_elevator(&elevator, &mut Rng::new(91));
    let train = series(&plant, 0.0, 2.0, 92, Scenario::healthy());
    // A short schedule: stage 1 (Gauss-Newton) fixes Kd; the network only polishes.
    let cfg = TrainConfig {
        epochs: 150,
        log_every: 0,
        ..TrainConfig::default()
    };
    let model = fit(&train, &elevator, &cfg, &mut |_| {})
        .expect("two days fit")
        .model;

    // Kd rises linearly from day 3 to +20 % on day 15, the physical limit: watched to day 10.
    let (onset, full) = (3.0 * DAY_S, 15.0 * DAY_S);
    let ramp = Scenario::new(FaultMode::Motor, onset, Ramp::Linear, full, 2.0).expect("valid");
    let watched = series(&plant, 2.0, 8.0, 93, ramp);
    let mut m = Monitor::new(&model, Method::Pinn);
    for x in &watched.samples {
        let _ = m.push(x);
    }
    let v = Verdict::new(&model, m.state_ref());
    let motor = &v.forecast.modes[FaultMode::Motor as usize];
    let limit = motor
        .crossings
        .iter()
        .find(|c| c.name == "physical limit")
        .expect("the limit is forecast");
    assert!((limit.threshold - 100.0 * KD_LIMIT).abs() < 1e-9);
    let trend = motor.trend.expect("a trend over the ramp");
    match limit.when {
        When::At { time, early, late } => {
            let late = late.unwrap_or(f64::INFINITY);
            assert!(
                early <= full && full <= late,
                "interval {:.2}-{:.2} days misses the true {:.2} (most likely {:.2}); trend {trend:?}",
                early / DAY_S,
                late / DAY_S,
                full / DAY_S,
                time / DAY_S
            );
        }
        other => panic!("the ramp is not dated: {other:?}; trend {trend:?}"),
    }
    // The slope's interval holds the true 20 %/12 days.
    let truth = 20.0 / 12.0;
    assert!(
        (trend.slope_per_day - truth).abs() <= 3.0 * trend.slope_se,
        "slope {trend:?} against {truth:.3} %/day"
    );
    assert_eq!(v.mode, FaultMode::Motor, "{:?}", v.lines());

    // Eight healthy days: nothing is dated, nothing reached.
    let healthy = series(&plant, 2.0, 8.0, 94, Scenario::healthy());
    let mut m = Monitor::new(&model, Method::Pinn);
    for x in &healthy.samples {
        let _ = m.push(x);
    }
    let v = Verdict::new(&model, m.state_ref());
    for f in &v.forecast.modes {
        for c in &f.crossings {
            assert!(
                matches!(c.when, When::NoTrend | When::NotWithinHorizon),
                "healthy {} {}: {:?}; trend {:?}",
                f.mode,
                c.name,
                c.when,
                f.trend
            );
        }
    }
}
