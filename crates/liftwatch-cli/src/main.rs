//! `liftwatch`: the command line of DATA.md §6.

mod args;
mod cmd;

use std::process::ExitCode;

use clap::Parser;

/// How a command that succeeded ended: the exit status scripts read (the README's Commands).
///
/// ```text
/// 0  success (and, under `monitor --fail-on LEVEL`, LEVEL not reached)
/// 1  error: one line `liftwatch: ...` on stderr
/// 2  bad command line (clap's usage message)
/// 3  `monitor --fail-on advisory`: the run reached advisory, not alarm
/// 4  `monitor --fail-on advisory|alarm`: the run reached alarm
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    /// Done, nothing to report.
    Ok,
    /// The monitored elevator reached advisory.
    Advisory,
    /// The monitored elevator reached alarm.
    Alarm,
}

impl Status {
    /// The exit status.
    pub fn code(self) -> u8 {
        match self {
            Status::Ok => 0,
            Status::Advisory => 3,
            Status::Alarm => 4,
        }
    }
}

fn main() -> ExitCode {
    let args = args::Args::parse();
    match args.command.run() {
        Ok(status) => ExitCode::from(status.code()),
        Err(err) => {
            eprintln!("liftwatch: {err:#}"); // `:#` prints the whole cause chain on one line
            ExitCode::FAILURE
        }
    }
}
