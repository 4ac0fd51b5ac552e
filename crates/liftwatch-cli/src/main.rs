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
/// 141 the reader of stdout went away (`liftwatch monitor … | head`): quietly, as a program
///    killed by SIGPIPE ends in a shell (128 + 13), so `set -o pipefail` sees what it expects
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

/// Exit status of a run whose stdout reader went away: 128 + SIGPIPE (13), what a shell
/// reports for a program SIGPIPE killed. Rust ignores SIGPIPE, so the write fails instead.
const EXIT_BROKEN_PIPE: u8 = 141;

/// True when the error is a write to a closed pipe, however deeply wrapped.
fn is_broken_pipe(err: &anyhow::Error) -> bool {
    err.chain().any(|cause| {
        let io = cause
            .downcast_ref::<std::io::Error>()
            .or(match cause.downcast_ref() {
                Some(liftwatch::Error::Io { err, .. }) => Some(err),
                _ => None,
            });
        io.is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

fn main() -> ExitCode {
    let args = args::Args::parse();
    match args.command.run() {
        Ok(status) => ExitCode::from(status.code()),
        Err(err) if is_broken_pipe(&err) => ExitCode::from(EXIT_BROKEN_PIPE),
        Err(err) => {
            eprintln!("liftwatch: {err:#}"); // `:#` prints the whole cause chain on one line
            ExitCode::FAILURE
        }
    }
}
