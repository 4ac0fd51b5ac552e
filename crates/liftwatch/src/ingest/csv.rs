//! Stage 1, the CSV reader: header to [`Layout`], rows to `(time, signal, value)` readings
//! (paper, Sec. 4.1; DATA.md §1-2).
//!
//! ```text
//! raw row      time,signal,value          -> one reading, or skipped and counted
//! aligned row  time,speed,...,floor[,...] -> one reading per finite column
//! value        ""  | NaN | nan            -> missing (counted, not bad)
//!              number, finite             -> used
//!              anything else, ±inf        -> bad row (raw) / bad value read as missing (aligned)
//! ```
//!
//! Records come from [`Records`] into reused buffers; fields are trimmed as bytes and parsed
//! with [`parse_f64`] (the same bits as `str::parse::<f64>`), so a good row allocates
//! nothing.
//!
//! Deviation from the paper: none; the paper does not describe its file format.

use std::io::Read;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};

use super::records::Records;
use super::time::{parse_time_field, TimeError, TimeForm};
use super::{IngestReport, Layout, Signal};
use crate::error::{Error, Result};
use crate::sample::Sample;
use crate::text::parse_f64;

const RAW_HEADER: [&str; 3] = ["time", "signal", "value"];
const ALIGNED_HEADER: [&str; 7] = [
    "time",
    "speed",
    "direction",
    "voltage",
    "load",
    "door",
    "floor",
];

/// Outcome of reading one field as a value.
enum Value {
    Number(f64),
    Missing,
    Bad,
}

fn parse_value(field: &[u8]) -> Value {
    if field.is_empty() {
        return Value::Missing;
    }
    match parse_f64(field) {
        Some(v) if v.is_nan() => Value::Missing,
        Some(v) if v.is_finite() => Value::Number(v),
        _ => Value::Bad,
    }
}

/// A field as shown in a message: at most 40 characters, control characters as `?`
/// so that the message stays on one line.
pub(crate) fn shown(field: &[u8]) -> String {
    let s = String::from_utf8_lossy(field);
    let mut out: String = s
        .chars()
        .take(40)
        .map(|c| if c.is_control() { '?' } else { c })
        .collect();
    if s.chars().count() > 40 {
        out.push_str("...");
    }
    out
}

fn time_reason(field: &[u8], err: TimeError, form: Option<TimeForm>) -> String {
    let f = shown(field);
    match err {
        TimeError::Unreadable => format!("time `{f}` is neither seconds nor RFC 3339"),
        TimeError::OtherForm(found) => format!(
            "time `{f}` is {} but the file uses {}",
            found.name(),
            form.map_or("another form", TimeForm::name)
        ),
        TimeError::OutOfRange => format!(
            "time `{f}` is outside the accepted range ±{:e} s",
            super::time::MAX_ABS_TIME_S
        ),
    }
}

/// A streaming reader of one telemetry file, either layout.
pub struct RowReader<R: Read> {
    rec: Records<R>,
    layout: Layout,
    /// Fields a row has: the header's count; it may have fewer where the header ends in
    /// blank names (down to `min_fields`), or more that are blank (a trailing comma on the
    /// rows or the header alone).
    fields: usize,
    min_fields: usize,
    /// Aligned layout: column of the optional `current` signal.
    current_col: Option<usize>,
    form: Option<TimeForm>,
    path: PathBuf,
}

impl<R: Read> RowReader<R> {
    /// Reads the header of `input`; `path` names the file in messages.
    ///
    /// # Errors
    /// [`Error::Io`] on a read error, [`Error::NoData`] for an empty file,
    /// [`Error::UnknownLayout`] for a header of neither layout.
    pub fn new(input: R, path: &Path) -> Result<Self> {
        let mut reader = RowReader {
            rec: Records::new(input),
            layout: Layout::Raw,
            fields: 0,
            min_fields: 0,
            current_col: None,
            form: None,
            path: path.to_path_buf(),
        };
        if !reader.read()? {
            return Err(Error::NoData {
                path: reader.path,
                why: "the file is empty".into(),
            });
        }
        let names: Vec<String> = reader
            .rec
            .iter()
            .enumerate()
            .map(|(i, f)| {
                // A UTF-8 byte order mark can only precede the first field.
                let f = if i == 0 {
                    f.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(f)
                } else {
                    f
                };
                String::from_utf8_lossy(f.trim_ascii()).to_ascii_lowercase()
            })
            .collect();
        let starts =
            |h: &[&str]| names.len() >= h.len() && names.iter().zip(h).all(|(a, b)| a == b);
        reader.fields = names.len();
        if starts(&RAW_HEADER) {
            reader.layout = Layout::Raw;
        } else if starts(&ALIGNED_HEADER) {
            reader.layout = Layout::Aligned;
            reader.current_col = names
                .iter()
                .skip(7)
                .position(|n| n == "current")
                .map(|i| i + 7);
        } else {
            return Err(Error::UnknownLayout { path: reader.path });
        }
        let named = names.len() - names.iter().rev().take_while(|n| n.is_empty()).count();
        reader.min_fields = named.max(reader.current_col.map_or(0, |c| c + 1));
        Ok(reader)
    }

    /// [`Self::row_fits`], the row counted bad with its reason when it does not (an
    /// over-long line skipped, or the wrong number of fields).
    fn row_fits_or_counted(&self, report: &mut IngestReport, line: u64) -> bool {
        if self.row_fits() {
            return true;
        }
        let (n, want) = (self.rec.len(), self.fields);
        if self.rec.overlong() {
            report.bad(line, false, || {
                format!(
                    "a line longer than {} KiB, skipped",
                    crate::limits::MAX_LINE_BYTES >> 10
                )
            });
        } else {
            report.bad(line, false, || format!("expected {want} fields, found {n}"));
        }
        false
    }

    /// Whether the current row has the header's fields, up to blank ones at the end of
    /// either (`time,signal,value,` above rows without the trailing comma, or the reverse).
    fn row_fits(&self) -> bool {
        let n = self.rec.len();
        if n <= self.fields {
            n >= self.min_fields
        } else {
            (self.fields..n).all(|i| self.rec.field(i).trim_ascii().is_empty())
        }
    }

    /// Layout found from the header.
    pub fn layout(&self) -> Layout {
        self.layout
    }

    /// Aligned layout with a `current` column.
    pub fn has_current_column(&self) -> bool {
        self.current_col.is_some()
    }

    /// The file name used in messages.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Gives the input back, to read it again from the start.
    pub fn into_inner(self) -> R {
        self.rec.into_inner()
    }

    fn read(&mut self) -> Result<bool> {
        self.rec.read().map_err(|e| Error::io(&self.path, e))
    }

    /// Line of the current row (of its end, for a quoted field spanning lines).
    fn line(&self) -> u64 {
        self.rec.line()
    }

    /// A row of only whitespace, such as the `\r` of a blank CRLF line: not a row.
    fn is_blank(&self) -> bool {
        self.rec.len() == 1 && self.rec.field(0).trim_ascii().is_empty()
    }

    /// Reads the time field of the current row, counting it as bad when unreadable.
    fn time(&mut self, report: &mut IngestReport, line: u64) -> Option<f64> {
        let field = self.rec.field(0).trim_ascii();
        match parse_time_field(field, &mut self.form) {
            Ok(t) => Some(t),
            Err(err) => {
                let form = self.form;
                report.bad(line, false, || time_reason(field, err, form));
                None
            }
        }
    }

    /// Streams every usable reading to `f` as `(time, signal, value, line)`, in file
    /// order, counting bad rows, missing values and unknown signals in `report`.
    /// Stops early when `f` breaks.
    ///
    /// `f` may fail with its own error type `E`, as an alignment sink does; a read error of
    /// the file is converted into it.
    ///
    /// # Errors
    /// A read error, or whatever `f` returns.
    pub fn for_each_reading<E: From<Error>>(
        &mut self,
        report: &mut IngestReport,
        mut f: impl FnMut(f64, Signal, f64, u64) -> Result<ControlFlow<()>, E>,
    ) -> Result<(), E> {
        match self.layout {
            Layout::Raw => self.raw_readings(report, &mut f),
            Layout::Aligned => self.for_each_row(report, |s, line| {
                for sig in Signal::ALL {
                    let v = sig.get(s);
                    if v.is_finite() && f(s.time, sig, v, line)?.is_break() {
                        return Ok(ControlFlow::Break(()));
                    }
                }
                Ok(ControlFlow::Continue(()))
            }),
        }
    }

    fn raw_readings<E: From<Error>>(
        &mut self,
        report: &mut IngestReport,
        f: &mut impl FnMut(f64, Signal, f64, u64) -> Result<ControlFlow<()>, E>,
    ) -> Result<(), E> {
        while self.read()? {
            if self.is_blank() {
                continue;
            }
            report.rows_read += 1;
            let line = self.line();
            if !self.row_fits_or_counted(report, line) {
                continue;
            }
            let Some(t) = self.time(report, line) else {
                continue;
            };
            let name = self.rec.field(1).trim_ascii();
            let Some(sig) = Signal::from_name(name) else {
                report.unknown(name);
                continue;
            };
            let field = self.rec.field(2).trim_ascii();
            let v = match parse_value(field) {
                Value::Number(v) => v,
                Value::Missing => {
                    report.missing_values += 1;
                    continue;
                }
                Value::Bad => {
                    report.bad(line, false, || {
                        format!("value `{}` is not a number", shown(field))
                    });
                    continue;
                }
            };
            report.rows_used += 1;
            report.values_used += 1;
            report.time_form = self.form;
            if f(t, sig, v, line)?.is_break() {
                break;
            }
        }
        Ok(())
    }

    /// Streams every row of an aligned file with a good time to `f` as a [`Sample`]
    /// (unreadable or absent values as `NaN`) and its line. Raw files yield nothing.
    ///
    /// `f` may fail with its own error type `E`; a read error is converted into it.
    ///
    /// # Errors
    /// A read error, or whatever `f` returns.
    pub fn for_each_row<E: From<Error>>(
        &mut self,
        report: &mut IngestReport,
        mut f: impl FnMut(&Sample, u64) -> Result<ControlFlow<()>, E>,
    ) -> Result<(), E> {
        if self.layout != Layout::Aligned {
            return Ok(());
        }
        while self.read()? {
            if self.is_blank() {
                continue;
            }
            report.rows_read += 1;
            let line = self.line();
            if !self.row_fits_or_counted(report, line) {
                continue;
            }
            let Some(t) = self.time(report, line) else {
                continue;
            };
            let mut sample = Sample::missing(t);
            for sig in Signal::ALL {
                let col = match sig {
                    Signal::Current => match self.current_col {
                        Some(c) => c,
                        None => continue,
                    },
                    s => s.index() + 1,
                };
                let field = self.rec.field(col).trim_ascii();
                match parse_value(field) {
                    Value::Number(v) => {
                        sig.set(&mut sample, v);
                        report.values_used += 1;
                    }
                    Value::Missing => report.missing_values += 1,
                    Value::Bad => report.bad(line, true, || {
                        format!("{} `{}` is not a number", sig.name(), shown(field))
                    }),
                }
            }
            report.rows_used += 1;
            report.time_form = self.form;
            if f(&sample, line)?.is_break() {
                break;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reader(text: &str) -> Result<RowReader<&[u8]>> {
        RowReader::new(text.as_bytes(), Path::new("t.csv"))
    }

    fn readings(text: &str) -> (Vec<(f64, Signal, f64, u64)>, IngestReport) {
        let mut r = reader(text).unwrap();
        let mut report = IngestReport::new(r.layout());
        let mut out = Vec::new();
        r.for_each_reading(&mut report, |t, s, v, line| {
            out.push((t, s, v, line));
            Ok::<_, Error>(ControlFlow::Continue(()))
        })
        .unwrap();
        (out, report)
    }

    #[test]
    fn header_with_bom_crlf_case_and_spaces_is_raw() {
        let (rows, report) =
            readings("\u{feff} Time , SIGNAL,value\r\n1,speed,0.5\r\n2, Voltage ,3\r\n");
        assert_eq!(report.layout, Layout::Raw);
        assert_eq!(
            rows,
            vec![(1.0, Signal::Speed, 0.5, 2), (2.0, Signal::Voltage, 3.0, 3)]
        );
        assert_eq!(report.bad_rows, 0);
    }

    #[test]
    fn aligned_header_may_carry_extra_columns_and_current() {
        let text = "time,speed,direction,voltage,load,door,floor,note,current\n\
                    10,1.5,1,300,40,0,3,hello,12\n11,,1,nan,40,0,3,x,\n";
        let (rows, report) = readings(text);
        assert_eq!(report.layout, Layout::Aligned);
        let currents: Vec<f64> = rows
            .iter()
            .filter(|r| r.1 == Signal::Current)
            .map(|r| r.2)
            .collect();
        assert_eq!(currents, vec![12.0]);
        assert_eq!(rows.len(), 7 + 4);
        assert_eq!(report.missing_values, 3);
        assert_eq!(report.rows_used, 2);
    }

    #[test]
    fn a_trailing_comma_on_the_header_or_the_rows_alone_loses_no_row() {
        // The header ends in a blank name, the rows do not, and the reverse; a row short of
        // a named column, or with a non-blank field past the header, is still bad.
        let (rows, report) = readings("time,signal,value,\n1,speed,0.5\n2,speed,0.6,\n3,speed\n");
        assert_eq!(
            rows,
            vec![(1.0, Signal::Speed, 0.5, 2), (2.0, Signal::Speed, 0.6, 3)]
        );
        assert_eq!(report.bad_rows, 1);
        let (rows, report) = readings(
            "time,speed,direction,voltage,load,door,floor\n\
             1,0.5,1,300,40,0,3,\n2,0.5,1,300,40,0,3, \n3,0.5,1,300,40,0,3,9\n",
        );
        assert_eq!(
            rows.len(),
            2 * 6,
            "the first two rows, every value but none"
        );
        assert_eq!(report.bad_rows, 1, "a ninth field that holds a value");
    }

    #[test]
    fn unknown_header_and_empty_file_are_errors() {
        assert!(matches!(
            reader("a,b,c\n1,2,3\n"),
            Err(Error::UnknownLayout { .. })
        ));
        assert!(matches!(
            reader("time,speed\n"),
            Err(Error::UnknownLayout { .. })
        ));
        assert!(matches!(reader(""), Err(Error::NoData { .. })));
    }

    #[test]
    fn bad_rows_are_counted_with_lines_and_good_rows_kept() {
        let text = "time,signal,value\n\
                    1,speed,0.5\n\
                    2,speed,abc\n\
                    x,speed,1\n\
                    3,speed\n\
                    4,speed,\n\
                    5,speed,NaN\n\
                    6,temp,20\n\
                    1e300,speed,1\n\
                    inf,door,1\n\
                    7,door,inf\n\
                    2026-03-01T00:00:00Z,door,1\n\
                    8,door,1\n\
                    9,flo";
        let (rows, r) = readings(text);
        assert_eq!(rows.iter().map(|r| r.0).collect::<Vec<_>>(), vec![1.0, 8.0]);
        assert_eq!(r.rows_read, 13);
        assert_eq!(r.bad_rows, 8);
        assert_eq!(r.missing_values, 2);
        assert_eq!(r.unknown_rows(), 1);
        assert_eq!(
            r.rows_used + r.bad_rows + r.missing_values + r.unknown_rows(),
            r.rows_read
        );
        assert_eq!(r.first_bad_lines, vec![3, 4, 5, 9, 10]);
        assert!(r
            .first_bad_reason
            .as_deref()
            .unwrap()
            .contains("line 3: value `abc`"));
    }

    #[test]
    fn rfc3339_file_refuses_numeric_rows() {
        let text = "time,signal,value\n2026-03-01T00:00:01Z,speed,1\n5,speed,2\n";
        let (rows, r) = readings(text);
        assert_eq!(rows.len(), 1);
        assert_eq!(r.bad_rows, 1);
        assert_eq!(r.time_form, Some(TimeForm::Rfc3339));
        assert!(r.first_bad_reason.unwrap().contains("file uses RFC 3339"));
    }

    #[test]
    fn aligned_garbage_value_is_missing_but_row_kept() {
        let text = "time,speed,direction,voltage,load,door,floor\n0,1,1,zz,10,0,2\n";
        let mut r = reader(text).unwrap();
        let mut report = IngestReport::new(r.layout());
        let mut seen = Vec::new();
        r.for_each_row(&mut report, |s, _| {
            seen.push(*s);
            Ok::<_, Error>(ControlFlow::Continue(()))
        })
        .unwrap();
        assert_eq!(seen.len(), 1);
        assert!(seen[0].voltage.is_nan());
        assert_eq!(seen[0].load, 10.0);
        assert_eq!((report.bad_rows, report.bad_values), (0, 1));
    }
}
