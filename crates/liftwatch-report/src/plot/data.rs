//! The data side of plotting: series thinned to what a pixel column can show, and ranges
//! from quantiles so that one outlier cannot squash a panel.
//!
//! ```text
//! decimate: per pixel column, (t, y) of min y and of max y, in time order
//! robust_range: [q_lo, q_hi] ∪ extra, padded by 6 % each side
//! ```

/// A pixel column in [`decimate`]: index, (t, y) of the minimum, (t, y) of the maximum.
type Column = (i64, (f64, f64), (f64, f64));

/// Thins `(t, y)` to at most about two points per pixel column of `columns` over `[x0, x1]`:
/// the minimum and the maximum of each column, in their time order, so a one-sample spike
/// survives. A non-finite `y` or a time step longer than `max_step` breaks the line (a NaN
/// point is emitted). Points outside `[x0, x1]` are dropped.
pub fn decimate(
    t: &[f64],
    y: &[f64],
    x0: f64,
    x1: f64,
    columns: usize,
    max_step: f64,
) -> Vec<(f64, f64)> {
    let columns = columns.max(1);
    let width = (x1 - x0) / columns as f64;
    let mut out: Vec<(f64, f64)> = Vec::new();
    // Current column: its index, (t, y) of its minimum and of its maximum.
    let mut col: Option<Column> = None;
    let mut last_t = f64::NAN;
    let brk = |out: &mut Vec<(f64, f64)>| {
        if out.last().is_some_and(|p| p.1.is_finite()) {
            out.push((f64::NAN, f64::NAN));
        }
    };
    let flush = |out: &mut Vec<(f64, f64)>, c: &mut Option<Column>| {
        if let Some((_, lo, hi)) = c.take() {
            if lo.0 <= hi.0 {
                out.push(lo);
                if hi != lo {
                    out.push(hi);
                }
            } else {
                out.push(hi);
                out.push(lo);
            }
        }
    };
    for (&ti, &yi) in t.iter().zip(y) {
        if !(ti >= x0 && ti <= x1) {
            continue;
        }
        let gap = last_t.is_finite() && ti - last_t > max_step;
        if !yi.is_finite() || gap {
            flush(&mut out, &mut col);
            brk(&mut out);
            if !yi.is_finite() {
                last_t = f64::NAN;
                continue;
            }
        }
        last_t = ti;
        let k = if width > 0.0 {
            ((ti - x0) / width).floor() as i64
        } else {
            0
        };
        match &mut col {
            Some((idx, lo, hi)) if *idx == k => {
                if yi < lo.1 {
                    *lo = (ti, yi);
                }
                if yi > hi.1 {
                    *hi = (ti, yi);
                }
            }
            _ => {
                flush(&mut out, &mut col);
                col = Some((k, (ti, yi), (ti, yi)));
            }
        }
    }
    flush(&mut out, &mut col);
    out
}

/// Quantile `q` (0..1) of the finite values, NaN when there is none.
pub fn quantile(values: impl IntoIterator<Item = f64>, q: f64) -> f64 {
    let mut v: Vec<f64> = values.into_iter().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let i = (q.clamp(0.0, 1.0) * (v.len() - 1) as f64).round() as usize;
    v[i.min(v.len() - 1)]
}

/// A range holding the `lo..hi` quantiles of the finite values and the `extra` values, padded
/// by 6 % each side; one outlier cannot blow it up. `(0, 1)` without data.
pub fn robust_range(values: &[f64], lo: f64, hi: f64, extra: &[f64]) -> (f64, f64) {
    let mut a = quantile(values.iter().copied(), lo);
    let mut b = quantile(values.iter().copied(), hi);
    for &x in extra.iter().filter(|x| x.is_finite()) {
        a = if a.is_finite() { a.min(x) } else { x };
        b = if b.is_finite() { b.max(x) } else { x };
    }
    if !(a.is_finite() && b.is_finite()) {
        return (0.0, 1.0);
    }
    if b - a < 1e-12 * a.abs().max(1.0) {
        let d = a.abs().max(1.0) * 0.05;
        return (a - d, b + d);
    }
    let pad = 0.06 * (b - a);
    (a - pad, b + pad)
}
