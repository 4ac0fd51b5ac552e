//! The whole method through the library: simulate an elevator, learn it from two healthy
//! days, then watch a week in which its drive degrades, and check that liftwatch says so.
//!
//! Run: `cargo run --release -p liftwatch --example simulate_fit_monitor`

use liftwatch::alarm::{FaultMode, Level};
use liftwatch::fit;
use liftwatch::mode::FaultMode as Fault;
use liftwatch::model::TrainConfig;
use liftwatch::monitor::{Method, Monitor};
use liftwatch::rng::Rng;
use liftwatch::sample::DAY_S;
use liftwatch::sim::plant::SimElevator;
use liftwatch::sim::scenario::{Ramp, Scenario};
use liftwatch::sim::{simulate, SimConfig};
use liftwatch::Elevator;

fn main() -> Result<(), liftwatch::Error> {
    let elevator = Elevator::new(1000.0, 1.75, 20);
    let plant = SimElevator::from_elevator(&elevator, &mut Rng::new(3));

    // Learn: two healthy days of the simulator's aligned series.
    let mut train = SimConfig::new(elevator.clone(), 2.0, 30);
    train.plant = Some(plant.clone());
    let healthy = simulate(&train)?.aligned();
    let fit = fit::fit(
        &healthy,
        &elevator,
        &TrainConfig {
            log_every: 0,
            ..TrainConfig::default()
        },
        &mut |_| {},
    )?;
    let kd = fit.model.hybrid.parameters.kd;
    println!(
        "fitted: Kd = {kd:.5} V/N, σ_U = {:.2} V",
        fit.model.hybrid.scales.sigma_u_v
    );

    // Watch: a week in which Kd steps up by 20 % on day 2.
    let mut watch = SimConfig::new(elevator, 7.0, 31);
    watch.plant = Some(plant);
    watch.scenario = Scenario::new(Fault::Motor, 2.0 * DAY_S, Ramp::Step, 2.0 * DAY_S, 2.0)?;
    let series = simulate(&watch)?.aligned();
    let mut monitor = Monitor::new(&fit.model, Method::Pinn);
    let mut events = Vec::new();
    for s in &series.samples {
        events.extend(monitor.push(s).and_then(|row| row.event));
    }
    events.extend(monitor.finish().into_iter().filter_map(|row| row.event));
    for e in &events {
        println!(
            "day {:5.2}: {:<8} mode {:<8} Kd drift {:+.1} %",
            e.time / DAY_S,
            e.level.as_str(),
            e.mode.as_str(),
            e.evidence.kd_drift_pct
        );
    }
    // The first advisory may open as `unknown`: the re-identification names the mode once its
    // estimate has left the healthy band, in an event of its own.
    let first = events
        .iter()
        .find(|e| e.level >= Level::Advisory)
        .expect("a 20 % rise of Kd is reported");
    let named = events
        .iter()
        .find(|e| e.mode != FaultMode::Unknown)
        .expect("the mode is named");
    assert!(first.time > 2.0 * DAY_S, "nothing before the onset");
    assert!(first.time < 4.0 * DAY_S, "within two days of the onset");
    assert_eq!(named.mode, FaultMode::Motor);
    Ok(())
}
