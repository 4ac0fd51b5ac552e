//! Stage 2, the aligned CSV writer (DATA.md §2).
//!
//! ```text
//! header  time,speed,direction,voltage,load,door,floor[,current]
//! time    as the grid gives it, `-0` written `0`
//! value   rounded to 1e-6 below 1e9, empty for NaN, `-0` written `0`
//! ```

use std::io::{self, BufWriter, Write};
use std::path::Path;

use super::ALIGNED_HEADER;
use crate::error::{Error, Result};
use crate::output::AtomicFile;
use crate::sample::Sample;

/// Appends a value compactly: empty for NaN, rounded to 1e-6 below 1e9, no `-0`.
fn push_number(line: &mut String, v: f64) {
    use std::fmt::Write as _;
    if !v.is_finite() {
        return;
    }
    let r = if v.abs() < 1e9 {
        (v * 1e6).round() / 1e6
    } else {
        v
    };
    let r = if r == 0.0 { 0.0 } else { r };
    let _ = write!(line, "{r}");
}

/// Appends the DATA.md §2 fields of `s`, `time,speed,direction,voltage,load,door,floor`, as
/// every aligned file is written: the time as the grid gives it (no rounding, `-0` as `0`),
/// the values through [`push_number`].
pub(crate) fn push_sample(line: &mut String, s: &Sample) {
    use std::fmt::Write as _;
    let t = if s.time == 0.0 { 0.0 } else { s.time };
    let _ = write!(line, "{t}");
    for v in [s.speed, s.direction, s.voltage, s.load, s.door, s.floor] {
        line.push(',');
        push_number(line, v);
    }
}

/// Writes aligned samples as CSV (DATA.md §2): the header, then one row per sample,
/// empty fields for missing values.
pub struct AlignedWriter<W: Write> {
    out: W,
    with_current: bool,
    line: String,
}

impl<W: Write> AlignedWriter<W> {
    /// Writes the header (with `,current` when `with_current`).
    ///
    /// # Errors
    /// The writer's error.
    pub fn new(mut out: W, with_current: bool) -> io::Result<Self> {
        let tail = if with_current { ",current\n" } else { "\n" };
        out.write_all(ALIGNED_HEADER.as_bytes())?;
        out.write_all(tail.as_bytes())?;
        Ok(AlignedWriter {
            out,
            with_current,
            line: String::with_capacity(128),
        })
    }

    /// Writes one sample.
    ///
    /// # Errors
    /// The writer's error.
    pub fn write(&mut self, s: &Sample) -> io::Result<()> {
        self.line.clear();
        push_sample(&mut self.line, s);
        if self.with_current {
            self.line.push(',');
            push_number(&mut self.line, s.current);
        }
        self.line.push('\n');
        self.out.write_all(self.line.as_bytes())
    }

    /// The underlying writer.
    pub fn get_ref(&self) -> &W {
        &self.out
    }

    /// Flushes and gives the writer back.
    ///
    /// # Errors
    /// The writer's error on flush.
    pub fn finish(mut self) -> io::Result<W> {
        self.out.flush()?;
        Ok(self.out)
    }
}

/// Writes `samples` as an aligned CSV; the `current` column appears when any sample has one.
///
/// # Errors
/// The writer's error.
pub fn write_aligned<W: Write>(out: W, samples: &[Sample]) -> io::Result<()> {
    let with_current = samples.iter().any(|s| s.current.is_finite());
    let mut w = AlignedWriter::new(BufWriter::new(out), with_current)?;
    for s in samples {
        w.write(s)?;
    }
    w.finish()?.flush()
}

/// Writes `samples` as an aligned CSV file at `path` (replacing it whole, see
/// [`AtomicFile`]).
///
/// # Errors
/// [`Error::Io`] naming `path`.
pub fn write_aligned_file(path: &Path, samples: &[Sample]) -> Result<()> {
    let mut file = AtomicFile::create_data(path)?;
    write_aligned(&mut file, samples).map_err(|e| Error::io(path, e))?;
    file.commit()
}
#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writer_leaves_missing_fields_empty_and_rounds() {
        let mut s = Sample::missing(3.0);
        s.speed = 1.0 / 3.0;
        s.floor = 2.0;
        s.direction = -0.0;
        let mut out = Vec::new();
        write_aligned(&mut out, &[s]).unwrap();
        assert_eq!(
            String::from_utf8(out).unwrap(),
            format!("{ALIGNED_HEADER}\n3,0.333333,0,,,,2\n")
        );
    }
}
