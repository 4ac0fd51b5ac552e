//! Command-line arguments (DATA.md §6).

use std::path::PathBuf;

use clap::{Parser, Subcommand};

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
    /// Align raw `time,signal,value` telemetry to a uniform step.
    Align(AlignArgs),
}

/// `liftwatch align`.
#[derive(Debug, clap::Args)]
pub struct AlignArgs {
    /// Raw telemetry (or an aligned file, which is re-stepped).
    #[arg(long)]
    pub input: PathBuf,
    /// Where to write the aligned series.
    #[arg(long)]
    pub out: PathBuf,
    /// Uniform step (s).
    #[arg(long, default_value_t = 1.0)]
    pub step: f64,
    /// Longest gap (s) that is interpolated or held; longer gaps stay empty.
    #[arg(long, default_value_t = 5.0)]
    pub gap_limit: f64,
}
