//! Fuzz target, stage 1-2: arbitrary bytes through the streaming CSV reader (both layouts,
//! `for_each_reading` and `for_each_row`) and through in-memory alignment
//! (`align_reader` over a `Cursor`). Errors are fine; a panic is a finding.
//!
//! ```text
//! raw layout   rows_read = rows_used + bad_rows + missing values + unknown-signal rows
//! aligned      sample times finite and strictly increasing after every start()
//! ```
#![no_main]

use std::cell::RefCell;
use std::io::Cursor;
use std::ops::ControlFlow;
use std::path::Path;

use libfuzzer_sys::fuzz_target;
use liftwatch::align::{align_reader, sink_fn, AlignConfig};
use liftwatch::ingest::csv::RowReader;
use liftwatch::ingest::{IngestReport, Layout};
use liftwatch::{Error, Result, Sample};

/// Samples one input may send to the sink before the sink stops alignment with an error:
/// a few readings may still span a week of grid points (`align::FREE_SPAN_S`); holding them
/// all would measure memory, not find bugs.
const SINK_CAP: usize = 1 << 12;

fuzz_target!(|data: &[u8]| {
    let path = Path::new("fuzz.csv");
    if let Ok(mut rows) = RowReader::new(data, path) {
        let mut report = IngestReport::new(rows.layout());
        let done = rows.for_each_reading(&mut report, |t, _, _, _| {
            assert!(t.is_finite());
            Ok::<_, Error>(ControlFlow::Continue(()))
        });
        if done.is_ok() && report.layout == Layout::Raw {
            let counted =
                report.rows_used + report.bad_rows + report.missing_values + report.unknown_rows();
            assert_eq!(report.rows_read, counted, "{report:?}");
        }
        let _ = report.warning();
    }
    if let Ok(mut rows) = RowReader::new(data, path) {
        let mut report = IngestReport::new(rows.layout());
        let _ = rows.for_each_row(&mut report, |s, _| {
            assert!(s.time.is_finite());
            Ok::<_, Error>(ControlFlow::Continue(()))
        });
    }
    let samples = RefCell::new(Vec::<Sample>::new());
    let mut sink = sink_fn(
        |_| -> Result<()> {
            samples.borrow_mut().clear();
            Ok(())
        },
        |s| -> Result<()> {
            let mut v = samples.borrow_mut();
            assert!(s.time.is_finite());
            assert!(v.last().map_or(true, |p| p.time < s.time));
            if v.len() == SINK_CAP {
                return Err(Error::io(path, std::io::Error::other("fuzz sink full")));
            }
            v.push(*s);
            Ok(())
        },
    );
    if let Ok(report) = align_reader(Cursor::new(data), path, &AlignConfig::default(), &mut sink) {
        let _ = report.warning();
    }
});
