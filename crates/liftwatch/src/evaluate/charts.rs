//! Evaluation, the classical control charts: two-sided CUSUM and EWMA on standardised
//! trip means, and the calibration of their limits on a healthy training run.
//!
//! ```text
//! standardise:  z_k = (x_k − μ0)/σ0          μ0 median, σ0 = 1.4826·MAD of healthy x_k
//! CUSUM:        S⁺ = max(0, S⁺ + z − k),  S⁻ = max(0, S⁻ − z − k),  signal when S± > h, k = 0.5
//! EWMA:         w = λ·z + (1 − λ)·w,  signal when |w| > L·sqrt(λ/(2 − λ)),          λ = 0.1
//! Siegmund:     ARL = (e^{−2Δb} + 2Δb − 1)/(2Δ²),  Δ = δ − k,  b = h + 1.166
//! ```
//!
//! The limits are the smallest ones (bisection) that signal at most once per simulated year
//! on a moving-block bootstrap of the healthy trips ([`crate::rng::moving_blocks`], blocks of
//! [`BLOCK_TRIPS`] trips), floored by the same search on independent N(0, 1) trips.

use serde::Serialize;

use crate::error::{Error, Result};
use crate::rng::{moving_blocks, BlockStart, Rng};
use crate::sample::YEAR_DAYS;
use crate::stats::{median, MAD_TO_SIGMA};

/// CUSUM reference value k (units of the healthy trip-mean spread): tuned to a 1σ shift.
pub const CUSUM_K: f64 = 0.5;
/// EWMA smoothing λ.
pub const EWMA_LAMBDA: f64 = 0.1;
/// Target of false signals per elevator-year every chart is calibrated to.
pub const TARGET_FALSE_PER_YEAR: f64 = 1.0;
/// Bootstrap block length (trips).
pub const BLOCK_TRIPS: usize = 40;
/// Years of healthy trips the chart calibration simulates.
pub const CALIBRATION_YEARS: f64 = 5.0;

/// A two-sided tabular CUSUM on standardised observations.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Cusum {
    /// Reference value k.
    pub k: f64,
    /// Decision limit h.
    pub h: f64,
    /// S⁺, the upper sum.
    pub upper: f64,
    /// S⁻, the lower sum.
    pub lower: f64,
}

impl Cusum {
    /// A chart at rest with reference `k` and limit `h`.
    pub fn new(k: f64, h: f64) -> Self {
        Cusum {
            k,
            h,
            upper: 0.0,
            lower: 0.0,
        }
    }

    /// Adds one observation; true when the chart signals (it then restarts from zero).
    /// A non-finite observation is skipped.
    pub fn push(&mut self, z: f64) -> bool {
        if !z.is_finite() {
            return false;
        }
        self.upper = (self.upper + z - self.k).max(0.0);
        self.lower = (self.lower - z - self.k).max(0.0);
        if self.upper > self.h || self.lower > self.h {
            self.upper = 0.0;
            self.lower = 0.0;
            return true;
        }
        false
    }
}

/// A two-sided EWMA chart on standardised observations with asymptotic limits.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Ewma {
    /// Smoothing λ.
    pub lambda: f64,
    /// Limit width L in units of the EWMA's asymptotic standard deviation.
    pub l: f64,
    /// The smoothed value w.
    pub w: f64,
}

impl Ewma {
    /// A chart at zero with smoothing `lambda` and width `l`.
    pub fn new(lambda: f64, l: f64) -> Self {
        Ewma { lambda, l, w: 0.0 }
    }

    /// The control limit L·sqrt(λ/(2 − λ)).
    pub fn limit(&self) -> f64 {
        self.l * (self.lambda / (2.0 - self.lambda)).sqrt()
    }

    /// Adds one observation; true when the chart signals (it then restarts from zero).
    /// A non-finite observation is skipped.
    pub fn push(&mut self, z: f64) -> bool {
        if !z.is_finite() {
            return false;
        }
        self.w = self.lambda * z + (1.0 - self.lambda) * self.w;
        if self.w.abs() > self.limit() {
            self.w = 0.0;
            return true;
        }
        false
    }
}

/// Siegmund's approximation of a one-sided CUSUM's average run length for a mean shift
/// `delta` (standardised): ARL = (e^{−2Δb} + 2Δb − 1)/(2Δ²), Δ = δ − k, b = h + 1.166.
pub fn cusum_arl(k: f64, h: f64, delta: f64) -> f64 {
    let d = delta - k;
    let b = h + 1.166;
    if d.abs() < 1e-9 {
        return b * b;
    }
    ((-2.0 * d * b).exp() + 2.0 * d * b - 1.0) / (2.0 * d * d)
}

/// The two-sided CUSUM limit h whose in-control ARL (Siegmund, both sides) is `arl`.
pub fn cusum_h_for_arl(k: f64, arl: f64) -> f64 {
    // Two one-sided charts of equal ARL signal together at half its rate.
    let target = 2.0 * arl.max(1.0);
    let (mut lo, mut hi) = (0.0, 60.0);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if cusum_arl(k, mid, 0.0) < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    hi
}

/// Number of signals of a chart with limit `limit` over `stream` (restart after each signal).
fn count_signals(stream: &[f64], limit: f64, chart: ChartKind) -> usize {
    match chart {
        ChartKind::Cusum => {
            let mut c = Cusum::new(CUSUM_K, limit);
            stream.iter().filter(|&&z| c.push(z)).count()
        }
        ChartKind::Ewma => {
            let mut c = Ewma::new(EWMA_LAMBDA, limit);
            stream.iter().filter(|&&z| c.push(z)).count()
        }
    }
}

/// Which chart a limit belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ChartKind {
    /// Two-sided CUSUM ([`Cusum`]); the limit is h.
    Cusum,
    /// Two-sided EWMA ([`Ewma`]); the limit is L.
    Ewma,
}

/// The smallest limit (bisection) with at most `max_signals` signals over `stream`.
pub fn calibrate_limit(stream: &[f64], chart: ChartKind, max_signals: usize) -> f64 {
    let (mut lo, mut hi) = (0.0, 8.0);
    // Strongly drifting healthy data can need a limit far above the textbook one.
    while count_signals(stream, hi, chart) > max_signals && hi < 1e6 {
        lo = hi;
        hi *= 2.0;
    }
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        if count_signals(stream, mid, chart) > max_signals {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    hi
}

/// A moving-block bootstrap of `xs` to length `n`: blocks of `block` consecutive values
/// starting anywhere a whole block fits, concatenated ([`moving_blocks`]).
pub fn block_bootstrap(xs: &[f64], n: usize, block: usize, rng: &mut Rng) -> Vec<f64> {
    let mut out = Vec::with_capacity(n);
    let whole = BlockStart::Whole { block };
    let block = block.max(1);
    moving_blocks(
        rng,
        xs.len(),
        whole,
        n,
        |first, i| i - first >= block,
        |i| {
            out.push(xs[i]);
        },
    );
    out
}

/// Standardisation and limits of the two charts, from one healthy training run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ChartCalibration {
    /// μ0: median of the healthy trip means of r_U/σ_U (1).
    pub mu0: f64,
    /// σ0: 1.4826·MAD of the healthy trip means (1).
    pub sigma0: f64,
    /// Healthy trips the calibration used.
    pub healthy_trips: usize,
    /// Trips per day of the training run (the rate an elevator-year is made of).
    pub trips_per_day: f64,
    /// CUSUM h from the block bootstrap.
    pub cusum_h_bootstrap: f64,
    /// CUSUM h from independent N(0, 1) trips (the floor).
    pub cusum_h_iid: f64,
    /// CUSUM h in use: the larger of the two.
    pub cusum_h: f64,
    /// Siegmund's h for the same ARL, as a check of the iid value.
    pub cusum_h_siegmund: f64,
    /// EWMA L from the block bootstrap.
    pub ewma_l_bootstrap: f64,
    /// EWMA L from independent N(0, 1) trips (the floor).
    pub ewma_l_iid: f64,
    /// EWMA L in use: the larger of the two.
    pub ewma_l: f64,
}

impl ChartCalibration {
    /// Calibrates both charts on the healthy trip means `xs` (in trip order) of a run of
    /// `days` days, to [`TARGET_FALSE_PER_YEAR`] over [`CALIBRATION_YEARS`] simulated years.
    ///
    /// # Errors
    /// [`Error::Unidentifiable`] with fewer than 30 trips or no spread.
    pub fn calibrate(xs: &[f64], days: f64, seed: u64) -> Result<ChartCalibration> {
        Self::calibrate_years(xs, days, seed, CALIBRATION_YEARS)
    }

    /// As [`ChartCalibration::calibrate`] over `years` simulated years.
    ///
    /// # Errors
    /// [`Error::Unidentifiable`] with fewer than 30 trips or no spread;
    /// [`Error::InvalidConfig`] for a span or a number of years that is not positive.
    pub fn calibrate_years(
        xs: &[f64],
        days: f64,
        seed: u64,
        years: f64,
    ) -> Result<ChartCalibration> {
        if !(days > 0.0 && years > 0.0) {
            return Err(Error::InvalidConfig {
                field: "evaluate.calibration",
                why: format!("span {days} days and {years} years must be positive"),
            });
        }
        let xs: Vec<f64> = xs.iter().copied().filter(|x| x.is_finite()).collect();
        if xs.len() < 30 {
            return Err(Error::Unidentifiable(format!(
                "chart calibration needs at least 30 healthy trips, found {}",
                xs.len()
            )));
        }
        let mu0 = median(&xs);
        let dev: Vec<f64> = xs.iter().map(|x| (x - mu0).abs()).collect();
        let sigma0 = MAD_TO_SIGMA * median(&dev);
        if sigma0.is_nan() || sigma0 <= 0.0 {
            return Err(Error::Unidentifiable(
                "healthy trip means have no spread".into(),
            ));
        }
        let z: Vec<f64> = xs.iter().map(|x| (x - mu0) / sigma0).collect();
        let trips_per_day = xs.len() as f64 / days;
        let n = (trips_per_day * YEAR_DAYS * years).round() as usize;
        let max_signals = (TARGET_FALSE_PER_YEAR * years).floor() as usize;
        let mut rng = Rng::new(seed);
        let boot = block_bootstrap(&z, n, BLOCK_TRIPS, &mut rng);
        let iid: Vec<f64> = (0..n).map(|_| rng.normal()).collect();
        let cusum_h_bootstrap = calibrate_limit(&boot, ChartKind::Cusum, max_signals);
        let cusum_h_iid = calibrate_limit(&iid, ChartKind::Cusum, max_signals);
        let ewma_l_bootstrap = calibrate_limit(&boot, ChartKind::Ewma, max_signals);
        let ewma_l_iid = calibrate_limit(&iid, ChartKind::Ewma, max_signals);
        let arl = trips_per_day * YEAR_DAYS / TARGET_FALSE_PER_YEAR;
        Ok(ChartCalibration {
            mu0,
            sigma0,
            healthy_trips: xs.len(),
            trips_per_day,
            cusum_h_bootstrap,
            cusum_h_iid,
            cusum_h: cusum_h_bootstrap.max(cusum_h_iid),
            cusum_h_siegmund: cusum_h_for_arl(CUSUM_K, arl),
            ewma_l_bootstrap,
            ewma_l_iid,
            ewma_l: ewma_l_bootstrap.max(ewma_l_iid),
        })
    }

    /// z = (x − μ0)/σ0.
    pub fn standardise(&self, x: f64) -> f64 {
        (x - self.mu0) / self.sigma0
    }
}
/// Something that signals on standardised trip means.
pub(super) trait Chart {
    /// Adds one observation; true when the chart signals.
    fn signal(&mut self, z: f64) -> bool;
}

impl Chart for Cusum {
    fn signal(&mut self, z: f64) -> bool {
        self.push(z)
    }
}

impl Chart for Ewma {
    fn signal(&mut self, z: f64) -> bool {
        self.push(z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cusum_signals_a_one_sigma_shift_quickly() {
        let mut rng = Rng::new(7);
        let h = cusum_h_for_arl(CUSUM_K, 10_000.0);
        let mut c = Cusum::new(CUSUM_K, h);
        // Siegmund: the ARL at a 1σ shift with this h is about 20 observations.
        let expect = cusum_arl(CUSUM_K, h, 1.0);
        let first = (0..1000)
            .find(|_| c.push(1.0 + rng.normal()))
            .expect("a 1σ shift must be signalled");
        assert!(
            (first as f64) < 4.0 * expect,
            "signalled after {first}, ARL {expect:.1}"
        );
        let mut down = Cusum::new(CUSUM_K, h);
        assert!(
            (0..1000).any(|_| down.push(-1.0 + rng.normal())),
            "a downward shift too"
        );
    }

    #[test]
    fn noise_signals_about_as_rarely_as_the_arl_says() {
        let arl = 2_000.0;
        let h = cusum_h_for_arl(CUSUM_K, arl);
        let mut rng = Rng::new(11);
        let xs: Vec<f64> = (0..100_000).map(|_| rng.normal()).collect();
        let n = count_signals(&xs, h, ChartKind::Cusum);
        // 50 expected; Siegmund is accurate to ~10 %, the count's own spread is ~7.
        assert!((25..=90).contains(&n), "{n} signals in 50 ARLs");
        // And the bisection finds the limit for a given count back.
        let hc = calibrate_limit(&xs, ChartKind::Cusum, 50);
        assert!(
            (hc - h).abs() < 0.6,
            "calibrated {hc:.2} vs Siegmund {h:.2}"
        );
    }

    #[test]
    fn ewma_signals_a_shift_and_not_noise_within_its_arl() {
        let mut rng = Rng::new(3);
        let noise: Vec<f64> = (0..200_000).map(|_| rng.normal()).collect();
        let l = calibrate_limit(&noise, ChartKind::Ewma, 20);
        // Textbook: λ = 0.1, L ≈ 3.0 gives an ARL of ~850; ARL 10 000 needs L ≈ 3.5.
        assert!((3.0..4.2).contains(&l), "L = {l}");
        // Fresh noise of 10 ARLs: about 10 signals, none of the clustering a wrong limit gives.
        let fresh: Vec<f64> = (0..100_000).map(|_| rng.normal()).collect();
        let n = count_signals(&fresh, l, ChartKind::Ewma);
        assert!((3..=25).contains(&n), "{n} signals in 10 ARLs");
        let mut c = Ewma::new(EWMA_LAMBDA, l);
        let first = (0..1000)
            .find(|_| c.push(1.0 + rng.normal()))
            .expect("a 1σ shift must be signalled");
        assert!(first < 100, "signalled after {first}");
    }

    #[test]
    fn calibration_standardises_and_is_floored_by_the_iid_limit() {
        let mut rng = Rng::new(5);
        // Strongly autocorrelated healthy trip means: an AR(1) with φ = 0.9.
        let mut x = 0.0;
        let xs: Vec<f64> = (0..500)
            .map(|_| {
                x = 0.9 * x + 0.3 * rng.normal();
                2.0 + x
            })
            .collect();
        let c = ChartCalibration::calibrate_years(&xs, 1.0, 9, 1.0).unwrap();
        assert!((c.mu0 - 2.0).abs() < 0.5, "{c:?}");
        assert!(c.cusum_h >= c.cusum_h_iid && c.ewma_l >= c.ewma_l_iid);
        // Correlation makes the bootstrap limit wider than the iid one.
        assert!(c.cusum_h_bootstrap > c.cusum_h_iid, "{c:?}");
        assert!((c.cusum_h_iid - c.cusum_h_siegmund).abs() < 2.0, "{c:?}");
        assert!(ChartCalibration::calibrate(&xs[..10], 1.0, 1).is_err());
    }

    #[test]
    fn block_bootstrap_takes_whole_blocks_of_consecutive_values() {
        let xs: Vec<f64> = (0..10).map(f64::from).collect();
        let boot = block_bootstrap(&xs, 25, 4, &mut Rng::new(1));
        assert_eq!(boot.len(), 25);
        for b in boot.chunks(4) {
            assert!(b.windows(2).all(|w| w[1] == w[0] + 1.0), "{boot:?}");
        }
        assert!(block_bootstrap(&[], 5, 4, &mut Rng::new(1)).is_empty());
    }
}
