//! `liftwatch`: the command line of DATA.md §6.

mod args;
mod cmd;

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    let args = args::Args::parse();
    let Err(err) = args.command.run() else {
        return ExitCode::SUCCESS;
    };
    eprintln!("liftwatch: {err:#}"); // `:#` prints the whole cause chain on one line
    ExitCode::FAILURE
}
