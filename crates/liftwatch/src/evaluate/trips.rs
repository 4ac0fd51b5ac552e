//! Evaluation, trips as the charts see them: the monitor rows grouped by the features stage's
//! trip index ([`MonitorRow::trip`], the one segmenter), summarised per trip.
//!
//! ```text
//! x_k = mean over the rows i of trip k with r_U and r_F of r_U,i/σ_U     (≥ MIN_TRIP_ROWS rows)
//! ```

use serde::Serialize;

use super::MIN_TRIP_ROWS;
use crate::alarm::Level;
use crate::fit::FittedModel;
use crate::monitor::{Method, Monitor, MonitorRow};
use crate::sample::AlignedSeries;

/// One trip as the evaluation sees it in monitor rows: the rows of one trip of the features
/// stage that carry a force and a voltage residual.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct TripSummary {
    /// Time of the trip's last row with both residuals (s).
    pub end: f64,
    /// Mean of r_U/σ_U over those rows (1).
    pub mean_e_u: f64,
    /// Rows with both residuals.
    pub n: usize,
    /// Time of the first of those rows at the alarm level (NaN if none).
    pub first_alarm: f64,
    /// Those rows on which the voltage (motor) limit was exceeded.
    pub motor_hits: usize,
    /// Those rows on which the friction limit was exceeded.
    pub friction_hits: usize,
}

/// Groups a stream of monitor rows into [`TripSummary`]s by their trip index.
#[derive(Clone, Debug)]
pub struct TripGrouper {
    sigma_u: f64,
    open: Option<(u32, TripSummary)>,
    sum: f64,
}

impl TripGrouper {
    /// A grouper scaling r_U by the model's healthy σ_U (V).
    pub fn new(sigma_u: f64) -> Self {
        TripGrouper {
            sigma_u,
            open: None,
            sum: 0.0,
        }
    }

    /// Feeds one row; returns the trip it closed, if any (only trips of [`MIN_TRIP_ROWS`]
    /// rows with both residuals or more).
    pub fn push(&mut self, r: &MonitorRow) -> Option<TripSummary> {
        let closed = if r.trip == self.open.map(|(k, _)| k) {
            None
        } else {
            self.close()
        };
        let Some(index) = r.trip else {
            return closed;
        };
        let (_, t) = self.open.get_or_insert((
            index,
            TripSummary {
                end: r.time,
                mean_e_u: 0.0,
                n: 0,
                first_alarm: f64::NAN,
                motor_hits: 0,
                friction_hits: 0,
            },
        ));
        if t.n == 0 {
            self.sum = 0.0;
        }
        if r.r_force.is_finite() && r.r_voltage.is_finite() {
            t.end = r.time;
            t.n += 1;
            self.sum += r.r_voltage / self.sigma_u;
            if r.level == Level::Alarm && t.first_alarm.is_nan() {
                t.first_alarm = r.time;
            }
            t.motor_hits += usize::from(r.risk_motor > 0.5);
            t.friction_hits += usize::from(r.risk_friction > 0.5);
        }
        closed
    }

    /// Closes the trip in progress (end of data).
    pub fn close(&mut self) -> Option<TripSummary> {
        let (_, mut t) = self.open.take()?;
        if t.n < MIN_TRIP_ROWS {
            return None;
        }
        t.mean_e_u = self.sum / t.n as f64;
        Some(t)
    }
}

/// Mean trip residuals r_U/σ_U of a healthy series monitored with `model`.
pub fn healthy_trip_means(model: &FittedModel, series: &AlignedSeries) -> Vec<f64> {
    let mut m = Monitor::new(model, Method::Pinn);
    let mut trips = TripGrouper::new(model.hybrid.scales.sigma_u_v);
    let mut out = Vec::new();
    for x in &series.samples {
        if let Some(r) = m.push(x) {
            out.extend(trips.push(&r).map(|t| t.mean_e_u));
        }
    }
    for r in m.finish() {
        out.extend(trips.push(&r).map(|t| t.mean_e_u));
    }
    out.extend(trips.close().map(|t| t.mean_e_u));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trips_average_their_rows_with_residuals_and_short_ones_are_dropped() {
        let row = |t: f64, trip: Option<u32>, ru: f64, rf: f64| MonitorRow {
            time: t,
            r_voltage: ru,
            r_force: rf,
            risk: 0.0,
            risk_motor: 0.0,
            risk_brake: 0.0,
            risk_friction: 0.0,
            trip,
            ..MonitorRow::EMPTY
        };
        let mut g = TripGrouper::new(2.0);
        let mut trips = Vec::new();
        for (t, k, ru, rf) in [
            (0.0, None, 1.0, f64::NAN),
            (1.0, Some(0), 2.0, 5.0),
            (2.0, Some(0), 4.0, f64::NAN),
            (3.0, Some(0), 4.0, 5.0),
            (4.0, Some(0), 6.0, 5.0),
            (4.5, None, 0.0, f64::NAN),
            (5.0, Some(1), 9.0, 1.0),
            (6.0, Some(2), 9.0, 1.0),
            (7.0, None, 0.0, f64::NAN),
        ] {
            trips.extend(g.push(&row(t, k, ru, rf)));
        }
        assert_eq!(trips.len(), 1, "a standstill row closes the trip");
        trips.extend(g.close());
        // Trip 0 keeps its three rows with residuals across the hole; trips 1 and 2 are short.
        assert_eq!(trips.len(), 1, "{trips:?}");
        assert_eq!((trips[0].n, trips[0].end, trips[0].mean_e_u), (3, 4.0, 2.0));
    }
}
