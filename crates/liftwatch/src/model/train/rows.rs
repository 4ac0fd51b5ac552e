//! What the fit keeps of a training's feature rows: the moving rows whole, and of the rows at
//! rest only what the passes over them read.
//!
//! ```text
//! moving rows (s ≠ 0)      every field: the observations, the evidence, the baseline
//! rows at rest (s = 0)     time and whether v is known: the winding's lag cools or holds
//!                          (risk::Heating), a trip's evidence closes; in runs of times
//!                          t₀ + k·Δt, each time checked to come back bit for bit
//! rows at rest, observable λ and U summed per load bin, U's median: U0 of the observations
//! ```
//!
//! A week at 1 Hz is 605,000 rows of 96 bytes, and an eighth of them move; the fit held them
//! all, beside the series they came from. [`TrainingRows::from_rows`] takes them one by one
//! from [`crate::features::rows`] and keeps about an eighth of that.

use std::collections::BTreeMap;

use crate::features::FeatureRow;

use super::{observable, LOAD_BINS};

/// A training's feature rows as the fit keeps them (the module's table): the moving rows,
/// runs of the times of the rows at rest between them, and the standstill observations'
/// sums. Rows at rest belong to no trip, as [`crate::features::FeatureTracker`] makes them:
/// their trip is not kept.
#[derive(Clone, Debug, PartialEq)]
pub struct TrainingRows {
    /// The moving rows (s ≠ 0), in order.
    pub moving: Vec<FeatureRow>,
    /// The rows at rest (s = 0), in order, in runs.
    still: Vec<StillRun>,
    /// Observable rows at rest per load bin (λ·[`LOAD_BINS`] rounded): their count, Σλ and
    /// ΣU, summed in order.
    pub(super) bins: BTreeMap<i64, (f64, f64, f64)>,
    /// Observable rows at rest.
    pub(super) n_rest: usize,
    /// The median of their voltages (V), NaN without any.
    pub(super) rest_voltage_v: f64,
}

/// Consecutive rows at rest whose times are `time(k)` and whose velocity is known alike.
#[derive(Clone, Copy, Debug, PartialEq)]
struct StillRun {
    /// Moving rows before the run.
    after_moving: usize,
    /// Rows in the run.
    len: usize,
    /// Time of its first row (s).
    time0: f64,
    /// Step of its times (s); unused in a run of one row.
    step_s: f64,
    /// Whether the rows' velocity v is known (finite).
    known: bool,
}

impl StillRun {
    /// Time of row `k` of the run: t₀ + k·Δt, t₀ itself for the first.
    fn time(&self, k: usize) -> f64 {
        if k == 0 {
            self.time0
        } else {
            self.time0 + k as f64 * self.step_s
        }
    }
}

/// One row as a pass over [`TrainingRows`] sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TrainingRow<'a> {
    /// A moving row, whole.
    Moving(&'a FeatureRow),
    /// A row at rest.
    Still {
        /// Its time (s).
        time: f64,
        /// Whether its velocity v is known (finite).
        known: bool,
    },
}

impl TrainingRows {
    /// What the fit keeps of `rows` (in order).
    ///
    /// The moving rows and the voltages at rest are gathered with room for every row `rows`
    /// may hold (its upper size hint): the pages of the room a vector never writes are never
    /// resident, and one that grows by doubling would hold up to twice its rows' memory, and
    /// the old and the new buffer at once while it moves.
    pub fn from_rows(rows: impl IntoIterator<Item = FeatureRow>) -> TrainingRows {
        let rows = rows.into_iter();
        let room = rows.size_hint().1.unwrap_or(0);
        let mut out = TrainingRows {
            moving: Vec::with_capacity(room),
            still: Vec::new(),
            bins: BTreeMap::new(),
            n_rest: 0,
            rest_voltage_v: f64::NAN,
        };
        let mut rest_voltages = Vec::with_capacity(room);
        for r in rows {
            if r.s != 0 {
                out.moving.push(r);
                continue;
            }
            out.push_still(r.time, r.v.is_finite());
            if observable(&r) {
                let b = out
                    .bins
                    .entry((r.lambda * LOAD_BINS).round() as i64)
                    .or_insert((0.0, 0.0, 0.0));
                b.0 += 1.0;
                b.1 += r.lambda;
                b.2 += r.voltage;
                rest_voltages.push(r.voltage);
            }
        }
        out.moving.shrink_to_fit();
        out.still.shrink_to_fit();
        out.n_rest = rest_voltages.len();
        out.rest_voltage_v = crate::stats::median_in_place(&mut rest_voltages);
        out
    }

    /// Adds a row at rest at `time`: to the last run when it follows it and its time is the
    /// run's next to the bit, else as a new run.
    fn push_still(&mut self, time: f64, known: bool) {
        let after_moving = self.moving.len();
        if let Some(run) = self.still.last_mut() {
            if run.after_moving == after_moving && run.known == known {
                let mut next = *run;
                if next.len == 1 {
                    next.step_s = time - next.time0;
                }
                if next.time(next.len).to_bits() == time.to_bits() {
                    next.len += 1;
                    *run = next;
                    return;
                }
            }
        }
        self.still.push(StillRun {
            after_moving,
            len: 1,
            time0: time,
            step_s: f64::NAN,
            known,
        });
    }

    /// Every row, in order.
    pub fn iter(&self) -> impl Iterator<Item = TrainingRow<'_>> {
        let last = self.still.last().map_or(0, |r| r.after_moving);
        self.still
            .iter()
            .scan(0, |from, run| {
                let moving = &self.moving[*from..run.after_moving];
                *from = run.after_moving;
                Some((moving, run))
            })
            .flat_map(|(moving, run)| {
                moving
                    .iter()
                    .map(TrainingRow::Moving)
                    .chain((0..run.len).map(|k| TrainingRow::Still {
                        time: run.time(k),
                        known: run.known,
                    }))
            })
            .chain(self.moving[last..].iter().map(TrainingRow::Moving))
    }

    /// The stretches of moving rows that no row at rest interrupts, in order.
    pub fn moving_stretches(&self) -> impl Iterator<Item = &[FeatureRow]> {
        let ends = self
            .still
            .iter()
            .map(|r| r.after_moving)
            .chain(std::iter::once(self.moving.len()));
        ends.scan(0, |from, end| {
            let stretch = &self.moving[*from..end];
            *from = end;
            Some(stretch)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A row of sign `s` at `time`, its velocity known or not.
    fn row(time: f64, s: i8, known: bool) -> FeatureRow {
        FeatureRow {
            time,
            v: if known { f64::from(s) } else { f64::NAN },
            s,
            trip: (s != 0).then_some(0),
            ..FeatureRow::MISSING
        }
    }

    #[test]
    fn every_row_comes_back_in_order_with_the_bits_of_its_time() {
        // Whole seconds, a step of 0.1 s that t₀ + k·Δt does not always give back, a time
        // that jumps back, a NaN and a negative zero; moving rows between.
        let mut rows: Vec<FeatureRow> = (0..5).map(|k| row(f64::from(k), 0, true)).collect();
        rows.extend((0..3).map(|k| row(5.0 + f64::from(k), 1, true)));
        rows.extend((0..30).map(|k| row(8.0 + 0.1 * f64::from(k), 0, k % 7 != 3)));
        rows.extend([
            row(2.0, 0, true),
            row(f64::NAN, 0, true),
            row(-0.0, 0, true),
        ]);
        rows.extend([row(20.0, -1, true), row(21.0, 0, true)]);
        let kept = TrainingRows::from_rows(rows.iter().copied());
        let back: Vec<TrainingRow<'_>> = kept.iter().collect();
        assert_eq!(back.len(), rows.len());
        for (r, b) in rows.iter().zip(&back) {
            match *b {
                TrainingRow::Moving(m) => assert!(r.s != 0 && m.time.to_bits() == r.time.to_bits()),
                TrainingRow::Still { time, known } => {
                    assert_eq!(r.s, 0);
                    assert_eq!(time.to_bits(), r.time.to_bits(), "{r:?}");
                    assert_eq!(known, r.v.is_finite());
                }
            }
        }
        // Runs, not a time per row, where the times allow it.
        assert!(kept.still.len() < 30, "{} runs", kept.still.len());
        let stretches: Vec<usize> = kept
            .moving_stretches()
            .map(<[FeatureRow]>::len)
            .filter(|n| *n > 0)
            .collect();
        assert_eq!(stretches, [3, 1]);
    }
}
