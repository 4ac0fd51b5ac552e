//! One file per subcommand; each `run()` reads as its slice of the pipeline.

mod align;

use crate::args::{Args, Command};

/// Runs the chosen subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    match args.command {
        Command::Align(a) => align::run(a),
    }
}
