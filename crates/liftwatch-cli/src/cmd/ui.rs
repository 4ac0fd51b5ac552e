//! What every verb says and where: the one rule of the command line.
//!
//! ```text
//! stdout   data only: an output named `-`, or with --json one JSON object on one line
//! stderr   people: summaries, notes, progress, warnings, errors (`liftwatch: ...`)
//! --quiet  no summary and no progress; warnings and errors still
//! progress `\r`-refreshed lines only when stderr is a terminal; in a log file nothing
//! ```
//!
//! So `liftwatch monitor --out - ... | next-tool` and `liftwatch fit --json ... | jq` both
//! get clean data, and a person at a terminal still reads everything on stderr.

use std::io::{IsTerminal, Write};
use std::path::Path;

use liftwatch::input::is_stdio;

/// The flags of the rule, shared by the verbs that have a summary.
#[derive(Clone, Copy, Debug, Default, clap::Args)]
pub struct UiArgs {
    /// Print no summary and no progress (warnings and errors still go to stderr).
    #[arg(long, short = 'q')]
    pub quiet: bool,
    /// Print the summary as one JSON object on stdout instead (the human lines are left out).
    #[arg(long)]
    pub json: bool,
}

/// Where a verb's words go, from its [`UiArgs`].
#[derive(Clone, Copy, Debug)]
pub struct Ui {
    quiet: bool,
    json: bool,
    terminal: bool,
}

impl Ui {
    /// The rule for `args`; `outputs` are the verb's file outputs (stdout can carry one of
    /// them or the JSON summary, not both).
    ///
    /// # Errors
    /// `--json` together with an output `-`.
    pub fn new(args: UiArgs, outputs: &[(&str, &Path)]) -> anyhow::Result<Ui> {
        if args.json {
            if let Some((flag, _)) = outputs.iter().find(|(_, p)| is_stdio(p)) {
                anyhow::bail!(
                    "--json and `{flag} -` both write standard output: give {flag} a file or leave out --json"
                );
            }
        }
        Ok(Ui {
            quiet: args.quiet,
            json: args.json,
            terminal: std::io::stderr().is_terminal(),
        })
    }

    /// True when human lines are printed (neither `--quiet` nor `--json`).
    pub fn talks(&self) -> bool {
        !self.quiet && !self.json
    }

    /// A human line on stderr, unless quiet or JSON.
    pub fn say(&self, line: impl std::fmt::Display) {
        if self.talks() {
            eprintln!("{line}");
        }
    }

    /// A progress line: refreshed in place on a terminal, nothing in a log file.
    pub fn progress(&self, line: impl std::fmt::Display) {
        if self.talks() && self.terminal {
            let mut err = std::io::stderr().lock();
            let _ = write!(err, "\r\x1b[2K{line}");
            let _ = err.flush();
        }
    }

    /// Ends a run of progress lines (the cursor back at the start of an empty line).
    pub fn progress_done(&self) {
        if self.talks() && self.terminal {
            eprint!("\r\x1b[2K");
        }
    }

    /// The JSON summary on stdout, one line, when `--json` was given.
    ///
    /// # Errors
    /// When stdout cannot be written (a closed pipe).
    pub fn json(&self, value: &serde_json::Value) -> anyhow::Result<()> {
        if self.json {
            let mut out = std::io::stdout().lock();
            writeln!(out, "{value}")?;
            out.flush()?;
        }
        Ok(())
    }
}

/// A warning line about input `source` on stderr: always, even with `--quiet` or `--json`.
pub fn warn(source: &Path, what: &str) {
    eprintln!("warning: {}: {what}", named(source, false));
}

/// A path for messages and JSON: `-` named as the stream it is.
pub fn named(path: &Path, output: bool) -> String {
    if is_stdio(path) {
        if output {
            liftwatch::output::STDOUT_NAME.to_string()
        } else {
            liftwatch::input::STDIN_NAME.to_string()
        }
    } else {
        path.display().to_string()
    }
}

/// What ingest found, as the `input` object of a JSON summary.
pub fn ingest_json(path: &Path, r: &liftwatch::ingest::IngestReport) -> serde_json::Value {
    serde_json::json!({
        "path": named(path, false),
        "layout": format!("{:?}", r.layout).to_lowercase(),
        "time_form": r.time_form.map(|f| f.name()),
        "rows_read": r.rows_read,
        "rows_used": r.rows_used,
        "bad_rows": r.bad_rows,
        "unknown_signal_rows": r.unknown_rows(),
        "samples": r.samples,
        "samples_with_gaps": r.samples_with_gaps,
        "first_time": finite(r.time_range.0),
        "last_time": finite(r.time_range.1),
        "full_sort": r.full_sort,
    })
}

/// A number for JSON: `null` when not finite.
pub fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}
