//! One file per subcommand; each `run()` reads as its slice of the pipeline.

pub mod align;
pub mod demo;
pub mod evaluate;
pub mod fit;
pub mod monitor;
pub mod report;
pub mod simulate;

use crate::args::{Args, Command};

/// Runs the chosen subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    match args.command {
        Command::Demo(a) => demo::run(a),
        Command::Simulate(a) => simulate::run(a),
        Command::Align(a) => align::run(a),
        Command::Fit(a) => fit::run(a),
        Command::Monitor(a) => monitor::run(a),
        Command::Evaluate(a) => evaluate::run(a),
        Command::Report(a) => report::run(a),
    }
}
