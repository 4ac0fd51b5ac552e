//! liftwatch: physics-informed health monitoring of a traction elevator from the 1 Hz
//! telemetry its controller already logs.
//!
//! The pipeline, one module per stage:
//! raw telemetry ([`ingest`]) → aligned series ([`align`]) → features ([`features`]) →
//! hybrid model ([`model`]) → dual residuals ([`residual`]) → risk ([`risk`]) →
//! levels and events ([`alarm`]). [`monitor`] runs the last four as one streaming step;
//! [`baseline`] is the conventional fixed-threshold method with the same output;
//! [`sim`] is a seeded traction-elevator simulator that writes raw telemetry.
//!
//! ```
//! # fn main() -> Result<(), liftwatch::Error> {
//! use liftwatch::monitor::{Method, Monitor};
//! use liftwatch::sim::{simulate, SimConfig};
//! use liftwatch::{model, Elevator};
//!
//! // Six busy morning hours of a simulated elevator stand in for a healthy log.
//! let elevator = Elevator::new(1000.0, 1.75, 20);
//! let mut sim = SimConfig::new(elevator.clone(), 0.25, 1);
//! sim.start_s = 7.0 * 3600.0;
//! let series = simulate(&sim)?.aligned();
//!
//! // Identify it, then watch the same data through the streaming monitor.
//! let cfg = model::TrainConfig { epochs: 100, log_every: 0, ..Default::default() };
//! let fit = model::fit(&series, &elevator, &cfg, &mut |_| {})?;
//! assert!(fit.model.parameters.kd > 0.0 && fit.model.scales.sigma_u_v < 5.0);
//! let mut monitor = Monitor::new(&fit.model, Method::Pinn);
//! let rows: Vec<_> = series.samples.iter().filter_map(|s| monitor.push(s)).collect();
//! assert_eq!(rows.len() + monitor.finish().len(), series.len()); // one row per sample
//! # Ok(()) }
//! ```

pub mod alarm;
pub mod align;
pub mod baseline;
pub mod elevator;
pub mod error;
pub mod evaluate;
pub mod features;
pub mod ingest;
pub mod linalg;
pub mod model;
pub mod monitor;
pub mod residual;
pub mod risk;
pub mod rng;
pub mod sample;
pub mod sim;
pub mod stats;

pub use elevator::Elevator;
pub use error::{Error, Result};
pub use sample::{AlignedSeries, Sample};
