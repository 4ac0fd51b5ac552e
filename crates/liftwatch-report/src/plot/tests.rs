//! Tests of the drawing layer: thinning, ranges and tick labels.

use super::draw::segments;
use super::*;

#[test]
fn decimation_keeps_a_one_sample_spike() {
    let t: Vec<f64> = (0..100_000).map(f64::from).collect();
    let mut y = vec![0.0; t.len()];
    y[54_321] = 7.0;
    let pts = decimate(&t, &y, 0.0, 99_999.0, 1000, 1.5);
    assert!(pts.len() <= 2 * 1000 + 2, "{} points", pts.len());
    assert!(pts.iter().any(|p| p.1 == 7.0));
}

#[test]
fn missing_values_and_time_gaps_break_the_line() {
    let t = [0.0, 1.0, 2.0, 3.0, 10.0, 11.0];
    let y = [1.0, 2.0, f64::NAN, 3.0, 4.0, 5.0];
    let pts = decimate(&t, &y, 0.0, 11.0, 10_000, 1.5);
    let segs = segments(&pts);
    assert_eq!(segs.len(), 3, "{pts:?}");
    assert_eq!(segs[0], vec![(0.0, 1.0), (1.0, 2.0)]);
    assert_eq!(segs[1], vec![(3.0, 3.0)]);
}

#[test]
fn robust_range_ignores_one_outlier() {
    let mut v: Vec<f64> = (0..10_000).map(|i| f64::from(i % 100)).collect();
    v[17] = 1e9;
    let (lo, hi) = robust_range(&v, 0.001, 0.999, &[]);
    assert!(lo < 1.0 && hi > 98.0 && hi < 120.0, "{lo} {hi}");
}

#[test]
fn tick_labels_have_the_decimals_the_spacing_needs() {
    assert_eq!(fmt_tick(0.25, 1.0), "0.25");
    assert_eq!(fmt_tick(1500.0, 3000.0), "1500");
    assert_eq!(fmt_tick(-0.0001, 1.0), "0");
    assert_eq!(fmt_tick(-436.5, 3.0), "-436.5");
    assert_eq!(fmt_tick(0.00415, 0.0001), "0.00415");
}
