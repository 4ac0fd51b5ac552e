//! Robust location and scale, shared by the fit and the evaluation, and the one CUSUM
//! increment.
//!
//! ```text
//! llr(ν, u)       ν·u − ν²/2: a CUSUM's step for a shift ν of a unit-variance score u
//! median(x)       middle value of the sorted x
//! MAD(x)          median(|x_i − median(x)|)
//! σ̂ = 1.4826·MAD  a standard deviation that a few outliers do not inflate
//! ```
//!
//! 1.4826 = 1/Φ⁻¹(¾) makes σ̂ an unbiased estimate of σ for Gaussian data.
//!
//! Two medians live here, and they differ only for an even count: [`median`] is the textbook
//! one (the mean of the two middle values), [`upper_median`] takes the upper of the two by an
//! O(n) selection. [`robust_sigma`] is built on [`upper_median`], as every fitted model so far
//! was; switching it would move σ_U, σ_F and with them every fitted number in the last bits.

/// The CUSUM's increment for a score `u` of unit variance and a change of size `nu` (in its
/// standard deviations): the log-likelihood ratio ν·u − ν²/2 of a mean ν against 0. The one
/// increment of every CUSUM of the crate (the risk stage's bank, the rest voltage of
/// [`crate::sensor`], the doors of [`crate::operation`]): G ← max(0, G + gaussian_llr(ν, u)).
pub fn gaussian_llr(nu: f64, u: f64) -> f64 {
    nu * u - 0.5 * nu * nu
}

/// 1/Φ⁻¹(¾): the factor that turns a MAD into a standard deviation for Gaussian data.
pub const MAD_TO_SIGMA: f64 = 1.4826;

/// The median of `xs`: the middle value, or the mean of the two middle values for an even
/// count; NaN for an empty slice. Values are ordered by [`f64::total_cmp`].
pub fn median(xs: &[f64]) -> f64 {
    median_in_place(&mut xs.to_vec())
}

/// [`median`] without a copy: reorders `v` (an O(n) selection instead of a sort). The same
/// bits as the sort gives: the upper middle value is the element of rank n/2, the lower the
/// largest of the ones selected below it, and values that [`f64::total_cmp`] calls equal have
/// equal bits.
pub fn median_in_place(v: &mut [f64]) -> f64 {
    let n = v.len();
    if n == 0 {
        return f64::NAN;
    }
    let upper = upper_median(v);
    if n % 2 == 1 {
        return upper;
    }
    let lower = v[..n / 2]
        .iter()
        .copied()
        .max_by(f64::total_cmp)
        .expect("an even count of two or more has a lower half");
    0.5 * (lower + upper)
}

/// The `p`-quantile of `sorted` (ascending) by nearest rank: the element of rank
/// round(p·(n − 1)); NaN for an empty slice.
pub fn sorted_quantile(sorted: &[f64], p: f64) -> f64 {
    match sorted.len() {
        0 => f64::NAN,
        n => sorted[((p * (n - 1) as f64).round() as usize).min(n - 1)],
    }
}

/// The upper median of `v`: the element of rank ⌊n/2⌋ (the middle value, or the upper of the
/// two middle values for an even count); NaN for an empty slice. Reorders `v` (an O(n)
/// selection instead of a sort); values are ordered by [`f64::total_cmp`].
pub fn upper_median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mid = v.len() / 2;
    v.select_nth_unstable_by(mid, f64::total_cmp);
    v[mid]
}

/// σ̂ = 1.4826·MAD of the finite `values`, with upper medians ([`upper_median`]): a standard
/// deviation that a few outliers do not inflate. NaN when no value is finite.
pub fn robust_sigma(values: impl Iterator<Item = f64>) -> f64 {
    let mut v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    let med = upper_median(&mut v);
    let mut dev: Vec<f64> = v.iter().map(|x| (x - med).abs()).collect();
    MAD_TO_SIGMA * upper_median(&mut dev)
}

/// Φ⁻¹(p): the standard normal quantile, for 0 < p < 1 (NaN outside), by Acklam's rational
/// approximation (relative error below 1.2e-9 over the whole range: ample for a threshold).
pub fn normal_quantile(p: f64) -> f64 {
    // Coefficients of Acklam's approximation (central region |p − ½| ≤ 0.475, and tails).
    const A: [f64; 6] = [
        -3.969683028665376e1,
        2.209460984245205e2,
        -2.759285104469687e2,
        1.383_577_518_672_69e2,
        -3.066479806614716e1,
        2.506628277459239,
    ];
    const B: [f64; 5] = [
        -5.447609879822406e1,
        1.615858368580409e2,
        -1.556989798598866e2,
        6.680131188771972e1,
        -1.328068155288572e1,
    ];
    const C: [f64; 6] = [
        -7.784894002430293e-3,
        -3.223964580411365e-1,
        -2.400758277161838,
        -2.549732539343734,
        4.374664141464968,
        2.938163982698783,
    ];
    const D: [f64; 4] = [
        7.784695709041462e-3,
        3.224671290700398e-1,
        2.445134137142996,
        3.754408661907416,
    ];
    /// Below this p (and above 1 − it) the tail formula applies.
    const P_LOW: f64 = 0.02425;
    if !(p > 0.0 && p < 1.0) {
        return f64::NAN;
    }
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    if p < P_LOW {
        tail((-2.0 * p.ln()).sqrt())
    } else if p > 1.0 - P_LOW {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    }
}

/// The Student-t quantile of `p` with `dof` degrees of freedom (at least 1), by the
/// Cornish-Fisher expansion about Φ⁻¹(p) (Abramowitz & Stegun 26.7.5): within 0.5 % for
/// dof ≥ 3 at p = 0.975, within 4 % at dof = 2 (4.17 for 4.30), conservative enough for an
/// interval whose degrees of freedom are an estimate themselves.
pub fn t_quantile(p: f64, dof: f64) -> f64 {
    let z = normal_quantile(p);
    let v = dof.max(1.0);
    let (z3, z5, z7) = (z.powi(3), z.powi(5), z.powi(7));
    z + (z3 + z) / (4.0 * v)
        + (5.0 * z5 + 16.0 * z3 + 3.0 * z) / (96.0 * v * v)
        + (3.0 * z7 + 19.0 * z5 + 17.0 * z3 - 15.0 * z) / (384.0 * v * v * v)
}

/// The χ² quantile of `p` with `dof` degrees of freedom (any positive real), by the
/// Wilson-Hilferty cube-root approximation: χ²_p ≈ ν·(1 − 2/(9ν) + z_p·√(2/(9ν)))³, z_p =
/// Φ⁻¹(p); within 1.6 % of the tables for ν ≥ 5 at p = 0.05 and 0.95 (0.5 % for ν ≥ 10),
/// never negative, and low below that at p = 0.05 (7 % at ν = 3, 23 % at ν = 2), so that an
/// upper bound made with it errs wide.
pub fn chi_square_quantile(p: f64, dof: f64) -> f64 {
    let v = dof.max(1e-9);
    let k = 2.0 / (9.0 * v);
    v * (1.0 - k + normal_quantile(p) * k.sqrt()).max(0.0).powi(3)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sorted_quantiles_take_the_nearest_rank() {
        let v: Vec<f64> = (0..101).map(f64::from).collect();
        assert_eq!(sorted_quantile(&v, 0.99), 99.0);
        assert_eq!(sorted_quantile(&v, 0.5), 50.0);
        assert_eq!(sorted_quantile(&v[..10], 0.99), 9.0); // rank round(8.91) = 9
        assert_eq!(sorted_quantile(&v[..10], 0.04), 0.0);
        assert!(sorted_quantile(&[], 0.5).is_nan());
    }

    #[test]
    fn t_quantiles_match_the_tables() {
        // Tables: t(0.975; 3) = 3.182, t(0.975; 10) = 2.228, t(0.975; 30) = 2.042.
        for (dof, table) in [(3.0, 3.182), (10.0, 2.228), (30.0, 2.042)] {
            let t = t_quantile(0.975, dof);
            assert!((t - table).abs() < 0.02 * table, "dof {dof}: {t}");
        }
        assert!((t_quantile(0.975, 1e9) - 1.96).abs() < 1e-3);
    }

    #[test]
    fn chi_square_quantiles_match_the_tables() {
        // Tables: χ²(0.05; 5) = 1.1455, (0.05; 10) = 3.940, (0.05; 30) = 18.493,
        // (0.05; 100) = 77.929, (0.95; 10) = 18.307, (0.95; 30) = 43.773.
        for (p, dof, table) in [
            (0.05, 5.0, 1.1455),
            (0.05, 10.0, 3.940),
            (0.05, 30.0, 18.493),
            (0.05, 100.0, 77.929),
            (0.95, 10.0, 18.307),
            (0.95, 30.0, 43.773),
        ] {
            let q = chi_square_quantile(p, dof);
            let tolerance = if dof < 10.0 { 0.016 } else { 0.005 };
            assert!((q / table - 1.0).abs() < tolerance, "p {p}, dof {dof}: {q}");
        }
        // Below five degrees of freedom it is low, never high: χ²(0.05; 3) = 0.3518,
        // (0.05; 2) = 0.1026.
        for (dof, table) in [(3.0, 0.3518), (2.0, 0.1026)] {
            let q = chi_square_quantile(0.05, dof);
            assert!((0.75 * table..table).contains(&q), "dof {dof}: {q}");
        }
    }

    #[test]
    fn normal_quantile_matches_tabulated_values() {
        // Φ⁻¹ from standard tables (15 digits).
        for (p, z) in [
            (0.5, 0.0),
            (0.75, 0.674489750196082),
            (0.975, 1.959963984540054),
            (0.99, 2.326347874040841),
            (0.999, 3.090232306167814),
            (1e-6, -4.753424308822899),
        ] {
            let got = normal_quantile(p);
            assert!(
                (got - z).abs() <= 2e-9 * z.abs().max(1.0),
                "Φ⁻¹({p}) = {got}, want {z}"
            );
        }
        assert!(normal_quantile(0.0).is_nan() && normal_quantile(1.0).is_nan());
        assert!(normal_quantile(f64::NAN).is_nan());
    }

    #[test]
    fn median_of_an_even_count_is_the_mean_of_the_middle_pair() {
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median(&[5.0, 1.0, 3.0]), 3.0);
        assert!(median(&[]).is_nan());
    }

    #[test]
    fn median_in_place_gives_the_bits_of_the_sorted_median() {
        let sorted_median = |xs: &[f64]| {
            let mut v = xs.to_vec();
            v.sort_by(f64::total_cmp);
            let n = v.len();
            if n % 2 == 1 {
                v[n / 2]
            } else {
                0.5 * (v[n / 2 - 1] + v[n / 2])
            }
        };
        let mut rng = crate::rng::Rng::new(9);
        for n in 1..60 {
            // Few distinct values, so that ties (and -0 beside +0) straddle the middle.
            let xs: Vec<f64> = (0..n)
                .map(|_| (rng.uniform(-3.0, 3.0).round() * 0.1).max(-0.1))
                .chain([-0.0, 0.0].into_iter().take(n % 3))
                .collect();
            let got = median_in_place(&mut xs.clone());
            assert_eq!(got.to_bits(), sorted_median(&xs).to_bits(), "{xs:?}");
        }
    }

    #[test]
    fn upper_median_of_an_even_count_is_the_upper_middle_value() {
        assert_eq!(upper_median(&mut [4.0, 1.0, 3.0, 2.0]), 3.0);
        assert_eq!(upper_median(&mut [5.0, 1.0, 3.0]), 3.0);
        assert!(upper_median(&mut []).is_nan());
    }

    #[test]
    fn robust_sigma_ignores_outliers_and_non_finite_values() {
        // Upper median 4, deviations {3, 2, 1, 0, 1, 996}: upper median 2.
        let xs = [1.0, 2.0, 3.0, 4.0, 5.0, 1000.0, f64::NAN, f64::INFINITY];
        assert_eq!(robust_sigma(xs.into_iter()), MAD_TO_SIGMA * 2.0);
        assert!(robust_sigma([f64::NAN].into_iter()).is_nan());
        assert!(robust_sigma(std::iter::empty()).is_nan());
    }

    #[test]
    fn robust_sigma_of_gaussian_data_is_near_its_standard_deviation() {
        let mut rng = crate::rng::Rng::new(4);
        let sigma = robust_sigma((0..20_000).map(|_| 3.0 * rng.normal() + 7.0));
        assert!((sigma - 3.0).abs() < 0.1, "σ̂ {sigma}");
    }
}
