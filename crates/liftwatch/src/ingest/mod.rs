//! Stage 1: streaming ingest of telemetry files (paper, Sec. 4.1; DATA.md §1-2).
//!
//! ```text
//! raw      time,signal,value                       one sensor reading per row, any order
//! aligned  time,speed,direction,voltage,load,door,floor[,extra...]   one instant per row
//! rows_read = rows_used + bad_rows + missing-value rows + unknown-signal rows   (raw layout)
//! ```
//!
//! The header tells the layouts apart (case-insensitive, trimmed, UTF-8 BOM stripped,
//! CRLF accepted). Rows are read one at a time into reused buffers ([`records`]), so memory
//! does not grow with the file; alignment ([`crate::align`]) consumes them as they come.
//! Bad rows are not errors: they are skipped and counted in an [`IngestReport`], whose
//! [`IngestReport::warning`] is the one line the CLI prints.
//!
//! Deviation from the paper: the paper aligns a clean 3 h record; real logs repeat,
//! reorder and garble rows, so the reader counts every kind of damage instead of failing.

pub mod csv;
pub mod records;
pub mod time;

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use crate::error::Result;
use crate::sample::Sample;

pub use self::time::{TimeForm, MAX_ABS_TIME_S};

/// How many bad line numbers an [`IngestReport`] keeps.
pub const KEPT_BAD_LINES: usize = 5;

/// How many distinct unknown signal names an [`IngestReport`] keeps; the rest are
/// counted under `(others)` so that a file of garbage names cannot grow memory.
pub const KEPT_UNKNOWN_NAMES: usize = 32;

/// The two file layouts of DATA.md, told apart by the header.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    /// `time,signal,value`: one reading per row (DATA.md §1).
    Raw,
    /// `time,speed,direction,voltage,load,door,floor[,...]`: one instant per row (DATA.md §2).
    Aligned,
}

/// A telemetry signal of DATA.md §1 (serialised by its name in files, e.g. in an event's
/// `channel`).
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "lowercase")]
pub enum Signal {
    /// Car speed magnitude (m/s).
    Speed,
    /// Travel direction: 1 up, -1 down, 0 none.
    Direction,
    /// Motor voltage magnitude (V).
    Voltage,
    /// Load-weighing sensor (percent of rated load).
    Load,
    /// Door: 1 open, 0 closed.
    Door,
    /// Floor indicator, 1-based.
    Floor,
    /// Motor current (A), optional.
    Current,
}

impl Signal {
    /// Every signal, in the column order of DATA.md §2 (`current` last).
    pub const ALL: [Signal; 7] = [
        Signal::Speed,
        Signal::Direction,
        Signal::Voltage,
        Signal::Load,
        Signal::Door,
        Signal::Floor,
        Signal::Current,
    ];

    /// The name used in files.
    pub fn name(self) -> &'static str {
        match self {
            Signal::Speed => "speed",
            Signal::Direction => "direction",
            Signal::Voltage => "voltage",
            Signal::Load => "load",
            Signal::Door => "door",
            Signal::Floor => "floor",
            Signal::Current => "current",
        }
    }

    /// The sensor behind the signal, in a maintenance engineer's words (what `status`, the
    /// report and the dashboard name when a check finds its readings wrong).
    pub fn sensor(self) -> &'static str {
        match self {
            Signal::Speed => "speed sensor (encoder)",
            Signal::Direction => "direction signal",
            Signal::Voltage => "motor voltage sensor",
            Signal::Load => "load-weighing sensor",
            Signal::Door => "door status signal",
            Signal::Floor => "floor indicator",
            Signal::Current => "motor current sensor",
        }
    }

    /// What to inspect when the checks find this signal's readings wrong: that one sensor,
    /// where [`FaultMode::Sensor`](crate::mode::FaultMode::Sensor) alone names the usual three.
    pub fn inspect(self) -> &'static str {
        match self {
            Signal::Speed => "check the speed sensor (encoder) and its wiring: its data look wrong",
            Signal::Direction => "check the direction signal and its wiring: its data look wrong",
            Signal::Voltage => "check the motor voltage sensor and its wiring: its data look wrong",
            Signal::Load => "check the load-weighing sensor and its wiring: its data look wrong",
            Signal::Door => "check the door status signal and its wiring: its data look wrong",
            Signal::Floor => "check the floor indicator and its wiring: its data look wrong",
            Signal::Current => "check the motor current sensor and its wiring: its data look wrong",
        }
    }

    /// The signal named `name` (ASCII case-insensitive, already trimmed).
    pub fn from_name(name: &[u8]) -> Option<Signal> {
        // Exact lowercase names first: the common case costs one slice comparison.
        let exact = match name {
            b"speed" => Some(Signal::Speed),
            b"direction" => Some(Signal::Direction),
            b"voltage" => Some(Signal::Voltage),
            b"load" => Some(Signal::Load),
            b"door" => Some(Signal::Door),
            b"floor" => Some(Signal::Floor),
            b"current" => Some(Signal::Current),
            _ => None,
        };
        exact.or_else(|| {
            Signal::ALL
                .into_iter()
                .find(|s| s.name().as_bytes().eq_ignore_ascii_case(name))
        })
    }

    /// Position in [`Signal::ALL`].
    pub fn index(self) -> usize {
        self as usize
    }

    /// Continuous signals are interpolated, discrete ones held (DATA.md §2).
    pub fn is_continuous(self) -> bool {
        matches!(
            self,
            Signal::Speed | Signal::Voltage | Signal::Load | Signal::Current
        )
    }

    /// This signal's field of a sample.
    pub fn get(self, s: &Sample) -> f64 {
        match self {
            Signal::Speed => s.speed,
            Signal::Direction => s.direction,
            Signal::Voltage => s.voltage,
            Signal::Load => s.load,
            Signal::Door => s.door,
            Signal::Floor => s.floor,
            Signal::Current => s.current,
        }
    }

    /// Sets this signal's field of a sample.
    pub fn set(self, s: &mut Sample, v: f64) {
        match self {
            Signal::Speed => s.speed = v,
            Signal::Direction => s.direction = v,
            Signal::Voltage => s.voltage = v,
            Signal::Load => s.load = v,
            Signal::Door => s.door = v,
            Signal::Floor => s.floor = v,
            Signal::Current => s.current = v,
        }
    }
}

/// What ingest and alignment found in one file: the basis of the CLI's warning and
/// summary lines. Filled by [`crate::align::align_file`] and [`crate::align::read_series`].
#[derive(Clone, Debug, PartialEq)]
pub struct IngestReport {
    /// Layout found from the header.
    pub layout: Layout,
    /// Form of the time column, once a row fixed it.
    pub time_form: Option<TimeForm>,
    /// Data rows read (the header and empty lines not counted).
    pub rows_read: u64,
    /// Rows whose values were used (raw: one value each; aligned: every row with a good time).
    pub rows_used: u64,
    /// Finite values handed to alignment.
    pub values_used: u64,
    /// Rows skipped: wrong field count, unreadable or out-of-range time, unreadable value.
    pub bad_rows: u64,
    /// Aligned layout only: unreadable fields read as missing in an otherwise good row.
    pub bad_values: u64,
    /// Line numbers (1-based, header is line 1) of the first bad rows or values.
    pub first_bad_lines: Vec<u64>,
    /// Why the first bad row or value was refused, with its line.
    pub first_bad_reason: Option<String>,
    /// Values that were empty, `NaN` or `nan` (missing, not bad).
    pub missing_values: u64,
    /// Rows of signal names this build does not know, by name.
    pub unknown_signals: BTreeMap<String, u64>,
    /// Readings (rows of a raw log, values of an aligned one) repeating the time of an
    /// earlier reading of the same signal (averaged or last kept).
    pub duplicate_timestamps: u64,
    /// Readings earlier than a reading of the same signal before them in the file.
    pub rows_reordered: u64,
    /// Line of the first row older than the reorder window, which forced a full sort.
    pub late_line: Option<u64>,
    /// True when the file was aligned by the in-memory full sort instead of streaming.
    pub full_sort: bool,
    /// Times the file was read (1, or more after a fallback).
    pub passes: u32,
    /// First and last usable time (s); NaN while none.
    pub time_range: (f64, f64),
    /// Aligned samples produced.
    pub samples: u64,
    /// Samples with at least one of the six core signals missing.
    pub samples_with_gaps: u64,
    /// Aligned layout: the step of the input as written, its first two rows apart (s); NaN
    /// for raw input or a single row. A caller can refuse data of another step than a
    /// model's before its re-stepped samples are used.
    pub input_step_s: f64,
}

impl IngestReport {
    /// An empty report for a file of `layout`.
    pub fn new(layout: Layout) -> Self {
        IngestReport {
            layout,
            time_form: None,
            rows_read: 0,
            rows_used: 0,
            values_used: 0,
            bad_rows: 0,
            bad_values: 0,
            first_bad_lines: Vec::new(),
            first_bad_reason: None,
            missing_values: 0,
            unknown_signals: BTreeMap::new(),
            duplicate_timestamps: 0,
            rows_reordered: 0,
            late_line: None,
            full_sort: false,
            passes: 0,
            time_range: (f64::NAN, f64::NAN),
            samples: 0,
            samples_with_gaps: 0,
            input_step_s: f64::NAN,
        }
    }

    /// Rows of unknown signals, all names together.
    pub fn unknown_rows(&self) -> u64 {
        self.unknown_signals.values().sum()
    }

    /// One line about damaged input (bad rows, unreadable values, unknown signals), or
    /// `None` when there is none. The CLI prints it after `warning: <file>: `.
    pub fn warning(&self) -> Option<String> {
        let mut parts = Vec::new();
        if self.bad_rows > 0 || self.bad_values > 0 {
            let mut s = String::new();
            if self.bad_rows > 0 {
                let _ = write!(
                    s,
                    "skipped {} bad row(s) of {}",
                    self.bad_rows, self.rows_read
                );
            }
            if self.bad_values > 0 {
                if !s.is_empty() {
                    s.push_str(", ");
                }
                let _ = write!(s, "read {} unreadable value(s) as missing", self.bad_values);
            }
            let lines: Vec<String> = self.first_bad_lines.iter().map(u64::to_string).collect();
            let more = if self.bad_rows + self.bad_values > lines.len() as u64 {
                ", ..."
            } else {
                ""
            };
            let _ = write!(s, " (lines {}{more}", lines.join(", "));
            if let Some(reason) = &self.first_bad_reason {
                let _ = write!(s, "; {reason}");
            }
            s.push(')');
            parts.push(s);
        }
        if !self.unknown_signals.is_empty() {
            let names: Vec<String> = self
                .unknown_signals
                .iter()
                .map(|(n, c)| format!("`{n}` x{c}"))
                .collect();
            parts.push(format!(
                "skipped {} row(s) of unknown signals ({})",
                self.unknown_rows(),
                names.join(", ")
            ));
        }
        (!parts.is_empty()).then(|| parts.join("; "))
    }

    /// One line on what was aligned: rows used, samples written, gaps, fallbacks.
    pub fn summary(&self) -> String {
        let mut s = format!(
            "used {} of {} rows, wrote {} samples ({} with gaps)",
            self.rows_used, self.rows_read, self.samples, self.samples_with_gaps
        );
        if self.missing_values > 0 {
            let _ = write!(s, ", {} missing values", self.missing_values);
        }
        if self.duplicate_timestamps > 0 {
            let _ = write!(
                s,
                ", {} readings at a repeated time",
                self.duplicate_timestamps
            );
        }
        if self.rows_reordered > 0 {
            let _ = write!(s, ", {} readings out of time order", self.rows_reordered);
        }
        if let Some(line) = self.late_line {
            let _ = write!(
                s,
                ", line {line} was older than the reorder window: sorted in memory"
            );
        }
        s
    }

    /// Counts a bad row (or, with `value_only`, an unreadable value in a kept row);
    /// `why` is only called for the first one, so bad rows cost no allocation.
    pub(crate) fn bad(&mut self, line: u64, value_only: bool, why: impl FnOnce() -> String) {
        if value_only {
            self.bad_values += 1;
        } else {
            self.bad_rows += 1;
        }
        if self.first_bad_lines.len() < KEPT_BAD_LINES {
            self.first_bad_lines.push(line);
        }
        if self.first_bad_reason.is_none() {
            self.first_bad_reason = Some(format!("line {line}: {}", why()));
        }
    }

    /// Counts a row of an unknown signal name.
    pub(crate) fn unknown(&mut self, name: &[u8]) {
        let name = self::csv::shown(name);
        if let Some(c) = self.unknown_signals.get_mut(&name) {
            *c += 1;
            return;
        }
        let key = if self.unknown_signals.len() < KEPT_UNKNOWN_NAMES {
            name
        } else {
            "(others)".to_string()
        };
        *self.unknown_signals.entry(key).or_insert(0) += 1;
    }
}

/// Reads only the header of `path` and tells its layout.
///
/// # Errors
/// [`Error::Io`](crate::Error::Io) if the file cannot be read,
/// [`Error::NoData`](crate::Error::NoData) if it is empty,
/// [`Error::UnknownLayout`](crate::Error::UnknownLayout) if the header is neither layout.
pub fn detect_layout(path: &Path) -> Result<Layout> {
    let input = crate::input::Input::open(path)?;
    let name = input.name().to_path_buf();
    Ok(self::csv::RowReader::new(input, &name)?.layout())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn signal_names_round_trip_case_insensitively() {
        for s in Signal::ALL {
            assert_eq!(Signal::from_name(s.name().as_bytes()), Some(s));
            assert_eq!(
                Signal::from_name(s.name().to_uppercase().as_bytes()),
                Some(s)
            );
            assert_eq!(Signal::ALL[s.index()], s);
        }
        assert_eq!(Signal::from_name(b"temperature"), None);
    }

    #[test]
    fn warning_is_one_line_naming_lines_and_names() {
        let mut r = IngestReport::new(Layout::Raw);
        assert_eq!(r.warning(), None);
        r.rows_read = 10;
        for line in 2..10 {
            r.bad(line, false, || format!("value `x{line}` is not a number"));
        }
        r.unknown(b"temp");
        r.unknown(b"temp");
        let w = r.warning().unwrap();
        assert!(!w.contains('\n'));
        assert!(w.contains("8 bad row(s) of 10"), "{w}");
        assert!(w.contains("lines 2, 3, 4, 5, 6, ..."), "{w}");
        assert!(w.contains("line 2: value `x2`"), "{w}");
        assert!(w.contains("`temp` x2"), "{w}");
    }

    #[test]
    fn unknown_names_beyond_the_cap_are_pooled() {
        let mut r = IngestReport::new(Layout::Raw);
        for i in 0..(KEPT_UNKNOWN_NAMES + 10) {
            r.unknown(format!("s{i}").as_bytes());
        }
        assert_eq!(r.unknown_signals.len(), KEPT_UNKNOWN_NAMES + 1);
        assert_eq!(r.unknown_signals["(others)"], 10);
        assert_eq!(r.unknown_rows(), (KEPT_UNKNOWN_NAMES + 10) as u64);
    }
}
