//! Evaluation, the oracle floor of a detection delay: how soon the CUSUM that knows the fault
//! (its mode, and its size at every trip) would detect it, with the model's own trip noise and
//! at the model's own false-advisory budget. A delay is read against it: how near the
//! decision is to the statistical optimum, which no threshold can show.
//!
//! ```text
//! β(t)   the true drift as the signature's coefficient: Kd factor − 1 (motor), the friction
//!        force's change over the model's reference friction, the drag over its reference F_c
//! δ_k    = β(t_k)·√(info_m/s²_m)          trip k's drift in trip-statistic units (s²_m, info_m:
//!                                          the model's healthy noise and mean information a trip)
//! Λ_n    = Σ_{onset ≤ t_k ≤ t_n} δ_k²/2    the expected log-likelihood ratio of the oracle
//! h      = ln(ARL0),  ARL0 = trips per year / false advisories per year
//! floor  = t_n − onset at the first n with Λ_n ≥ h
//! ```
//!
//! For a step of size δ this is Lorden's ln(ARL0)/(δ²/2) trips, the delay no test held to
//! that false-alarm rate beats on average (asymptotically); for a ramp, the same bound on the
//! information gathered so far. The oracle counts only a trip's noise: not the healthy wander
//! between hours and days that a real decision must allow for, not the multiplicity of three
//! modes and several sizes, not an unknown size. A delay near the floor is as early as the
//! data allow; one far above it says where the decision waits.

/// The floor's delay (s after `onset`): the end of the first trip after the onset at which
/// the expected log-likelihood ratio of the trips since, Σ δ_k²/2, reaches `h`; `None` when
/// the trips never gather it. `size(t)` is δ of a trip ending at `t` (trip-statistic units).
pub fn floor_delay_s(
    trip_ends: impl IntoIterator<Item = f64>,
    onset: f64,
    h: f64,
    size: impl Fn(f64) -> f64,
) -> Option<f64> {
    let mut llr = 0.0;
    for t in trip_ends.into_iter().filter(|&t| t >= onset) {
        let d = size(t);
        if d.is_finite() {
            llr += 0.5 * d * d;
        }
        // Some evidence must have gathered: with h at 0 (a budget of a false advisory per
        // trip or more) no change is still no detection.
        if llr >= h && llr > 0.0 {
            return Some(t - onset);
        }
    }
    None
}

/// h = ln(ARL0) of a budget of `per_year` false advisories at `trips_per_year` trips (0 for
/// a budget of one a trip or more); `None` when either is not a positive number.
pub fn oracle_threshold(trips_per_year: f64, per_year: f64) -> Option<f64> {
    (trips_per_year > 0.0 && per_year > 0.0 && (trips_per_year / per_year).is_finite())
        .then(|| (trips_per_year / per_year).ln().max(0.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A step of δ = 0.5 at 1 trip a minute with h = ln(10⁵): Lorden's ln(ARL0)/(δ²/2) trips.
    #[test]
    fn a_step_waits_lordens_number_of_trips() {
        let h = oracle_threshold(1e5, 1.0).unwrap();
        assert!((h - 1e5_f64.ln()).abs() < 1e-12);
        let trips = (0..10_000).map(|k| 1000.0 + 60.0 * k as f64);
        let onset = 1000.0 + 60.0 * 100.0 - 30.0;
        let step = |t: f64| if t >= onset { 0.5 } else { 0.0 };
        let n = (h / (0.5 * 0.25)).ceil();
        let got = floor_delay_s(trips, onset, h, step).unwrap();
        // The first trip after the onset ends 30 s after it: trip n ends (n − 1) minutes later.
        assert_eq!(got, 30.0 + 60.0 * (n - 1.0));
        // Twice the size, a quarter of the trips.
        let trips = (0..10_000).map(|k| 1000.0 + 60.0 * k as f64);
        let big = floor_delay_s(trips, onset, h, |t| 2.0 * step(t)).unwrap();
        let n_big = (h / 0.5).ceil();
        assert_eq!(big, 30.0 + 60.0 * (n_big - 1.0));
        assert!((n / n_big - 4.0).abs() < 0.2, "{n} {n_big}");
    }

    /// A linear ramp δ_k = a·k gathers a²·n(n+1)(2n+1)/12 after n trips: the floor is the first
    /// n past h, about (6h/a²)^(1/3), far later than a step of the ramp's final size.
    #[test]
    fn a_ramp_waits_for_its_information_and_no_fault_is_never_found() {
        let h = 10.0;
        let a = 0.01;
        let onset = 0.0;
        let trips = || (1..100_000).map(f64::from);
        let got = floor_delay_s(trips(), onset, h, |t| a * t).unwrap();
        let n = (1..)
            .map(f64::from)
            .find(|&n| a * a * n * (n + 1.0) * (2.0 * n + 1.0) / 12.0 >= h)
            .unwrap();
        assert_eq!(got, n);
        assert!((n - (6.0 * h / (a * a)).cbrt()).abs() < 2.0, "{n}");
        assert_eq!(floor_delay_s(trips(), onset, h, |_| 0.0), None);
        assert_eq!(floor_delay_s(trips(), onset, h, |_| f64::NAN), None);
        let none = oracle_threshold(1.0, 2.0).unwrap();
        assert_eq!(none, 0.0);
        assert_eq!(floor_delay_s(trips(), onset, none, |_| 0.0), None);
        assert_eq!(floor_delay_s(trips(), onset, none, |_| 0.1), Some(1.0));
        assert_eq!(oracle_threshold(0.0, 1.0), None);
        assert_eq!(oracle_threshold(1e5, 0.0), None);
    }
}
