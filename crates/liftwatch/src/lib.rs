//! liftwatch: physics-informed health monitoring of a traction elevator from the 1 Hz
//! telemetry its controller already logs.
//!
//! The pipeline, one module per stage:
//! raw telemetry ([`ingest`]) → aligned series ([`align`]) → features ([`features`]) →
//! hybrid model ([`model`]) → dual residuals ([`residual`]) → risk ([`risk`]) →
//! levels and events ([`alarm`]). [`monitor`] runs the last four as one streaming step;
//! [`baseline`] is the conventional fixed-threshold method with the same output;
//! [`sim`] is a seeded traction-elevator simulator that writes raw telemetry.

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

pub use elevator::Elevator;
pub use error::{Error, Result};
pub use sample::{AlignedSeries, Sample};
