//! The monitor's outputs as CSV (DATA.md §4): one row per sample ([`RowWriter`]) or one row per
//! trip ([`TripRowWriter`]), each column at a fixed precision.
//!
//! ```text
//! column                                   precision            why
//! time, start, end (epoch)                 shortest exact       grid times are short already
//! time, start, end (RFC 3339)              1 ms                 at the elevator's UTC offset
//! r_voltage (V), e, risk*, kd_drift_pct    3 decimals           voltage noise is about 1 V
//! r_force (N), brake_drag_n (N), load_pct  1 decimal            force noise is tens of N
//! friction_drift_pct                       2 decimals
//! direction, floors, samples               whole numbers
//! ```
//!
//! A value that rounds to zero is written `0.000`, never `-0.000`; `NaN` is an empty field. The
//! digits come from the one fixed-precision writer, [`crate::text::push_fixed`]; a row is
//! formatted into one reused line and written with one call. The per-second rows keep each
//! column's last text ([`crate::text::FixedColumn`]): between trips the risks and drifts hold
//! still, and a value with the digits of the second before is copied, not formatted again.
//! Fixed decimals instead of the shortest round-trip form halve the per-second rows (30
//! simulated days: 434 MB before, 214 MB now) in about the same time.

use std::io::Write;

use serde::{Deserialize, Serialize};

use super::MonitorRow;
use crate::exact;
use crate::features::Trip;
use crate::ingest::time::format_rfc3339;
use crate::mode::FaultMode;
use crate::text::{push_fixed, push_shortest, push_u64, FixedColumn};

/// The DATA.md §4 columns, in order, then the extra columns of this build.
pub const CSV_HEADER: &str =
    "time,r_voltage,r_force,risk,risk_motor,risk_brake,risk_friction,level,e,kd_drift_pct,friction_drift_pct,brake_drag_n";

/// The columns of one row per trip.
pub const TRIP_CSV_HEADER: &str =
    "start,end,direction,from_floor,to_floor,load_pct,samples,r_voltage,r_force,e,risk,risk_motor,risk_brake,risk_friction,level,mode,kd_drift_pct,friction_drift_pct,brake_drag_n";

/// How the time columns are written.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TimeFormat {
    /// Seconds as a number, as they came in (DATA.md §2).
    #[default]
    Epoch,
    /// An RFC 3339 instant at this UTC offset (s).
    Rfc3339 {
        /// Seconds east of UTC.
        offset_s: i32,
    },
}

impl TimeFormat {
    fn push(self, line: &mut Vec<u8>, t: f64) {
        match self {
            _ if !t.is_finite() => {}
            TimeFormat::Epoch => push_shortest(line, t),
            TimeFormat::Rfc3339 { offset_s } => {
                line.extend_from_slice(format_rfc3339(t, offset_s).as_bytes());
            }
        }
    }
}

/// A finished trip as the monitor saw it: the features stage's trip and the means of its
/// residuals over its moving samples. Carried by the row at which the trip is reported.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TripSummary {
    /// The trip: times, direction, floors, load.
    pub trip: Trip,
    /// Mean r_U over the trip's samples with a residual (V).
    pub mean_r_voltage: f64,
    /// Mean r_F (N).
    pub mean_r_force: f64,
    /// Mean combined scaled residual e.
    pub mean_e: f64,
    /// The fault mode of the open episode; `None` while the level is normal.
    pub mode: Option<FaultMode>,
}

/// Running sums of a trip's residuals, part of the monitor's state so that a trip crossing
/// the end of one run and the start of the next is summed whole.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub(super) struct TripSums {
    /// The features stage's index of the trip being summed.
    index: Option<u32>,
    #[serde(with = "exact")]
    r_u: f64,
    #[serde(with = "exact")]
    r_f: f64,
    #[serde(with = "exact")]
    e: f64,
    n: u32,
}

impl TripSums {
    /// Adds one sample of trip `index` (a new index starts new sums).
    pub(super) fn push(&mut self, index: u32, r_u: f64, r_f: f64, e: f64) {
        if self.index != Some(index) {
            *self = TripSums {
                index: Some(index),
                ..TripSums::default()
            };
        }
        if r_u.is_finite() && r_f.is_finite() && e.is_finite() {
            self.r_u += r_u;
            self.r_f += r_f;
            self.e += e;
            self.n += 1;
        }
    }

    /// The summary of `trip` when these sums are its own (NaN means without a residual).
    pub(super) fn finish(&mut self, trip: &Trip) -> Option<TripSummary> {
        if self.index != Some(trip.index) {
            return None;
        }
        let n = f64::from(self.n);
        let mean = |x: f64| if self.n == 0 { f64::NAN } else { x / n };
        let s = TripSummary {
            trip: *trip,
            mean_r_voltage: mean(self.r_u),
            mean_r_force: mean(self.r_f),
            mean_e: mean(self.e),
            mode: None,
        };
        *self = TripSums::default();
        Some(s)
    }
}

/// Decimals of r_voltage (V) and e, of r_force (N), of each risk and of the drifts (Kd %,
/// friction %, brake drag N): the precisions of the module's table, for both layouts.
const R_VOLTAGE_DECIMALS: usize = 3;
const R_FORCE_DECIMALS: usize = 1;
const E_DECIMALS: usize = 3;
const RISK_DECIMALS: usize = 3;
const DRIFT_DECIMALS: [usize; 3] = [3, 2, 1];

/// Appends each value at its precision, each after a comma.
fn fields(line: &mut Vec<u8>, values: &[(f64, usize)]) {
    for &(x, decimals) in values {
        line.push(b',');
        push_fixed(line, x, decimals);
    }
}

/// The columns both layouts end with, each keeping its last text ([`FixedColumn`]): the four
/// risks, the level, then the three drifts.
struct RiskColumns {
    risks: [FixedColumn; 4],
    drifts: [FixedColumn; 3],
}

impl RiskColumns {
    fn new() -> Self {
        RiskColumns {
            risks: [RISK_DECIMALS; 4].map(FixedColumn::new),
            drifts: DRIFT_DECIMALS.map(FixedColumn::new),
        }
    }

    /// Appends the per-mode risk columns and the level.
    fn risks_and_level(&mut self, line: &mut Vec<u8>, r: &MonitorRow) {
        let values = [r.risk, r.risk_motor, r.risk_brake, r.risk_friction];
        for (c, x) in self.risks.iter_mut().zip(values) {
            c.push(line, x);
            line.push(b',');
        }
        line.extend_from_slice(r.level.as_str().as_bytes());
    }

    /// Appends the three drift columns, each after a comma, and ends the line.
    fn drifts(&mut self, line: &mut Vec<u8>, r: &MonitorRow) {
        let values = [r.kd_drift_pct, r.friction_drift_pct, r.brake_drag_n];
        for (c, x) in self.drifts.iter_mut().zip(values) {
            line.push(b',');
            c.push(line, x);
        }
        line.push(b'\n');
    }
}

/// Writes monitor rows as CSV with [`CSV_HEADER`]; empty fields for `NaN`.
///
/// Each row is formatted into one reused line and handed to the writer whole: one call into
/// the output's stack (atomic file, compressor, buffer) per row, not one per field.
pub struct RowWriter<W: Write> {
    out: W,
    time: TimeFormat,
    line: Vec<u8>,
    /// r_voltage, r_force and e, each with its last text.
    residuals: [FixedColumn; 3],
    risks: RiskColumns,
}

impl<W: Write> RowWriter<W> {
    /// Writes the header; times as epoch seconds.
    ///
    /// # Errors
    /// The writer's I/O error.
    pub fn new(out: W) -> std::io::Result<Self> {
        RowWriter::with_time(out, TimeFormat::Epoch)
    }

    /// Writes the header; times as `time` says.
    ///
    /// # Errors
    /// The writer's I/O error.
    pub fn with_time(mut out: W, time: TimeFormat) -> std::io::Result<Self> {
        writeln!(out, "{CSV_HEADER}")?;
        Ok(RowWriter {
            out,
            time,
            line: Vec::with_capacity(256),
            residuals: [R_VOLTAGE_DECIMALS, R_FORCE_DECIMALS, E_DECIMALS].map(FixedColumn::new),
            risks: RiskColumns::new(),
        })
    }

    /// Writes one row.
    ///
    /// # Errors
    /// The writer's I/O error.
    pub fn write(&mut self, r: &MonitorRow) -> std::io::Result<()> {
        let line = &mut self.line;
        line.clear();
        self.time.push(line, r.time);
        let [r_u, r_f, e] = &mut self.residuals;
        for (c, x) in [(r_u, r.r_voltage), (r_f, r.r_force)] {
            line.push(b',');
            c.push(line, x);
        }
        line.push(b',');
        self.risks.risks_and_level(line, r);
        line.push(b',');
        e.push(line, r.e);
        self.risks.drifts(line, r);
        self.out.write_all(line)
    }

    /// Flushes and returns the writer.
    ///
    /// # Errors
    /// The writer's I/O error.
    pub fn into_inner(mut self) -> std::io::Result<W> {
        self.out.flush()?;
        Ok(self.out)
    }
}

/// Writes one row per finished trip with [`TRIP_CSV_HEADER`]: the rows that carry a
/// [`TripSummary`], the others skipped.
pub struct TripRowWriter<W: Write> {
    out: W,
    time: TimeFormat,
    line: Vec<u8>,
    risks: RiskColumns,
}

impl<W: Write> TripRowWriter<W> {
    /// Writes the header.
    ///
    /// # Errors
    /// The writer's I/O error.
    pub fn new(mut out: W, time: TimeFormat) -> std::io::Result<Self> {
        writeln!(out, "{TRIP_CSV_HEADER}")?;
        Ok(TripRowWriter {
            out,
            time,
            line: Vec::with_capacity(256),
            risks: RiskColumns::new(),
        })
    }

    /// Writes the trip `r` reports, if it reports one.
    ///
    /// # Errors
    /// The writer's I/O error.
    pub fn write(&mut self, r: &MonitorRow) -> std::io::Result<()> {
        let Some(s) = &r.trip_end else {
            return Ok(());
        };
        let line = &mut self.line;
        line.clear();
        let t = &s.trip;
        self.time.push(line, t.start_time);
        line.push(b',');
        self.time.push(line, t.end_time);
        let _ = write!(line, ",{}", t.direction);
        fields(
            line,
            &[
                (t.from_floor, 0),
                (t.to_floor, 0),
                (100.0 * t.load_ratio, 1),
            ],
        );
        line.push(b',');
        push_u64(line, u64::from(t.samples));
        let means = [
            (s.mean_r_voltage, R_VOLTAGE_DECIMALS),
            (s.mean_r_force, R_FORCE_DECIMALS),
            (s.mean_e, E_DECIMALS),
        ];
        fields(line, &means);
        line.push(b',');
        self.risks.risks_and_level(line, r);
        line.push(b',');
        if let Some(m) = s.mode {
            line.extend_from_slice(m.as_str().as_bytes());
        }
        self.risks.drifts(line, r);
        self.out.write_all(line)
    }

    /// Flushes and returns the writer.
    ///
    /// # Errors
    /// The writer's I/O error.
    pub fn into_inner(mut self) -> std::io::Result<W> {
        self.out.flush()?;
        Ok(self.out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trip_sums_of_another_trip_give_no_summary() {
        let mut sums = TripSums::default();
        sums.push(4, 1.0, 10.0, 0.5);
        sums.push(4, 3.0, f64::NAN, 0.5);
        sums.push(4, 3.0, 30.0, 1.5);
        let trip = |index| Trip {
            index,
            start_time: 0.0,
            end_time: 9.0,
            direction: 1,
            from_floor: 1.0,
            to_floor: 3.0,
            load_ratio: 0.1,
            peak_speed: 1.0,
            distance_m: 6.0,
            samples: 9,
        };
        assert_eq!(sums.finish(&trip(5)), None);
        let s = sums.finish(&trip(4)).unwrap();
        assert_eq!(
            (s.mean_r_voltage, s.mean_r_force, s.mean_e),
            (2.0, 20.0, 1.0)
        );
        assert_eq!(sums, TripSums::default(), "the sums start afresh");
    }
}
