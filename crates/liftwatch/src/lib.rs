//! liftwatch: physics-informed health monitoring of a traction elevator from the 1 Hz
//! telemetry its controller already logs.
//!
//! The pipeline, one module per stage, declared below in stage order:
//! raw telemetry ([`ingest`]) → aligned series ([`align`]) → features ([`features`]) →
//! hybrid model ([`model`]) → dual residuals ([`residual`]) → risk ([`risk`]) →
//! levels and events ([`alarm`]). [`operation`] counts door cycles, out-of-service periods
//! and the daily availability, and checks the doors against their healthy reference, a
//! subsystem beside the machine with its own advisory. [`sensor`] tells a broken sensor from a broken machine;
//! [`baseline`] is the conventional fixed-threshold method with the same output;
//! [`calibrate`] sets the risk thresholds from healthy trips; [`fit`] runs the whole
//! identification into one artefact, [`fit::FittedModel`], whose file form is [`file`](mod@file);
//! [`monitor`] runs stages 3-7 as one streaming step (and [`monitor::run`] as a batch).
//! [`sim`] is a seeded traction-elevator simulator that writes raw telemetry; [`evaluate`]
//! the suite that compares the method with the baselines on it.
//!
//! Every module imports only the modules declared above it: the fitted artefact and the
//! calibration come after the stages they configure, so each stage can be used alone.
//!
//! ```
//! # fn main() -> Result<(), liftwatch::Error> {
//! use liftwatch::monitor::{Method, Monitor};
//! use liftwatch::sim::{simulate, SimConfig};
//! use liftwatch::{fit, model, Elevator};
//!
//! // Six busy morning hours of a simulated elevator stand in for a healthy log.
//! let elevator = Elevator::new(1000.0, 1.75, 20);
//! let mut sim = SimConfig::new(elevator.clone(), 0.25, 1);
//! sim.start_s = 7.0 * 3600.0;
//! let series = simulate(&sim)?.aligned();
//!
//! // Identify it, then watch the same data through the streaming monitor.
//! let cfg = model::TrainConfig { epochs: 100, log_every: 0, ..Default::default() };
//! let fit = fit::fit(&series, &elevator, &cfg, &mut |_| {})?;
//! assert!(fit.model.hybrid.parameters.kd > 0.0 && fit.model.hybrid.scales.sigma_u_v < 5.0);
//! let mut monitor = Monitor::new(&fit.model, Method::Pinn);
//! let rows: Vec<_> = series.samples.iter().filter_map(|s| monitor.push(s)).collect();
//! assert_eq!(rows.len() + monitor.finish().len(), series.len()); // one row per sample
//! # Ok(()) }
//! ```

// Base: errors, numbers, the sample type, the elevator description, the fault-mode
// vocabulary, the one reader and the one writer.
pub mod error;
pub mod exact;
pub mod linalg;
pub mod rng;
pub mod stats;
pub mod text;
pub mod wide;
pub mod sample;
pub mod limits;
pub mod elevator;
pub mod mode;
pub mod input;
pub mod output;

// The pipeline, in stage order. Every module imports only modules above it in this list
// (its tests may use any); `tests/pipeline/layers.rs` checks it.
pub mod ingest;
pub mod align;
pub mod features;
pub mod model;
pub mod residual;
pub mod sensor;
pub mod risk;
pub mod alarm;
pub mod forecast;
pub mod operation;
pub mod baseline;
pub mod calibrate;
pub mod fit;
pub mod file;
pub mod monitor;
pub mod verdict;

// Around the pipeline: a simulator to test it on, and the evaluation suite.
pub mod sim;
pub mod evaluate;

pub use elevator::Elevator;
pub use error::{Error, Result};
pub use sample::{AlignedSeries, Sample};
