//! The input of the verbs that read it in passes (`fit`, `report`): aligned once into a spill
//! on disk (`liftwatch::align::SpillSink`), with progress on a terminal.

use std::path::{Path, PathBuf};

use liftwatch::align::{align_file, AlignConfig, SampleSink, SpillSink, SpilledSeries};
use liftwatch::ingest::IngestReport;
use liftwatch::sample::DAY_S;
use liftwatch::Sample;

use super::ui::Ui;

/// Where the aligned samples wait for the passes over them when the output is the file `out`:
/// on a disk beside it, whose directory is writable or the output could not be saved (/tmp may
/// be memory); the system's temporary directory when the output goes to standard output or a
/// device (`/dev/null`).
pub fn beside_file(out: &Path) -> PathBuf {
    if out == Path::new("-") {
        return std::env::temp_dir();
    }
    match std::fs::canonicalize(out) {
        // A link is followed: the output replaces its target, beside which it is written.
        Ok(real) if real.is_file() => real
            .parent()
            .map_or_else(std::env::temp_dir, Path::to_path_buf),
        Ok(_) => std::env::temp_dir(),
        Err(_) => parent(out),
    }
}

/// The directory `out` names its entry in: `.` for a bare name.
pub fn parent(out: &Path) -> PathBuf {
    match out.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Samples between two progress lines while the input is read: about a week at 1 s.
const PROGRESS_EVERY: u64 = 500_000;

/// Reads and aligns `input` into a spill in `dir` (`align::read_spilled`), saying on a
/// terminal how far it has got, as `verb`: a month's raw log takes seconds.
pub fn read(
    verb: &str,
    input: &Path,
    align: &AlignConfig,
    dir: &Path,
    ui: &Ui,
) -> anyhow::Result<(SpilledSeries, IngestReport)> {
    let mut sink = Counted {
        spill: SpillSink::new_in(dir)?,
        samples: 0,
        step_s: align.step_s,
        verb,
        ui,
    };
    let report = align_file(input, align, &mut sink)?;
    ui.progress_done();
    Ok((sink.spill.finish(align.step_s)?, report))
}

/// The spill, counting the samples into progress lines.
struct Counted<'a> {
    spill: SpillSink,
    samples: u64,
    step_s: f64,
    verb: &'a str,
    ui: &'a Ui,
}

impl SampleSink for Counted<'_> {
    type Error = liftwatch::Error;

    fn start(&mut self, has_current: bool) -> liftwatch::error::Result<()> {
        self.samples = 0;
        self.spill.start(has_current)
    }

    fn push(&mut self, sample: &Sample) -> liftwatch::error::Result<()> {
        self.samples += 1;
        if self.samples % PROGRESS_EVERY == 0 {
            self.ui.progress(format_args!(
                "{}: reading, {} samples aligned ({:.0} days)",
                self.verb,
                self.samples,
                self.samples as f64 * self.step_s / DAY_S,
            ));
        }
        self.spill.push(sample)
    }
}
