//! Command-line arguments (DATA.md §6). Each verb's flags live in its own `cmd/<verb>.rs`.

use clap::{Parser, Subcommand};

use crate::cmd;
use crate::Status;

/// Physics-informed health monitoring of traction elevators.
#[derive(Debug, Parser)]
#[command(name = "liftwatch", version, about)]
pub struct Args {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run the whole method on built-in defaults: simulate, fit, watch a degradation, report.
    Demo(cmd::demo::Args),
    /// Simulate a traction elevator and write its raw telemetry, aligned series and truth.
    Simulate(cmd::simulate::Args),
    /// Align raw `time,signal,value` telemetry to a uniform step.
    Align(cmd::align::Args),
    /// Fit the hybrid physics + network model on healthy data.
    Fit(cmd::fit::Args),
    /// Watch telemetry with a fitted model: residuals, risk, levels, events.
    Monitor(cmd::monitor::Args),
    /// The verdict of a monitor's saved state: level, mode, drift, what to inspect, forecast.
    Status(cmd::status::Args),
    /// Compare liftwatch with the threshold baseline, CUSUM and EWMA on a seeded simulated suite.
    Evaluate(cmd::evaluate::Args),
    /// Write figures (SVG and PNG) and an HTML report about telemetry, read with a fitted model.
    Report(cmd::report::Args),
    /// Run the service: ingest telemetry over HTTP, monitor every elevator, keep models.
    Serve(cmd::serve::Args),
    /// Send a raw telemetry log to a running service, batch by batch.
    Replay(cmd::replay::Args),
}

impl Command {
    /// Runs the chosen subcommand; the status is [`Status::Ok`] but for `monitor --fail-on`.
    pub fn run(self) -> anyhow::Result<Status> {
        match self {
            Command::Demo(a) => cmd::demo::run(a).map(|()| Status::Ok),
            Command::Simulate(a) => cmd::simulate::run(a).map(|()| Status::Ok),
            Command::Align(a) => cmd::align::run(a).map(|()| Status::Ok),
            Command::Fit(a) => cmd::fit::run(a).map(|()| Status::Ok),
            Command::Monitor(a) => cmd::monitor::run(a),
            Command::Status(a) => cmd::status::run(a).map(|()| Status::Ok),
            Command::Evaluate(a) => cmd::evaluate::run(a).map(|()| Status::Ok),
            Command::Report(a) => cmd::report::run(a).map(|()| Status::Ok),
            Command::Serve(a) => cmd::serve::run(a).map(|()| Status::Ok),
            Command::Replay(a) => cmd::replay::run(a).map(|()| Status::Ok),
        }
    }
}
