//! Robust location and scale, shared by the fit and the evaluation.
//!
//! ```text
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

/// 1/Φ⁻¹(¾): the factor that turns a MAD into a standard deviation for Gaussian data.
pub const MAD_TO_SIGMA: f64 = 1.4826;

/// The median of `xs`: the middle value, or the mean of the two middle values for an even
/// count; NaN for an empty slice. Values are ordered by [`f64::total_cmp`].
pub fn median(xs: &[f64]) -> f64 {
    let mut v = xs.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        return f64::NAN;
    }
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_of_an_even_count_is_the_mean_of_the_middle_pair() {
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median(&[5.0, 1.0, 3.0]), 3.0);
        assert!(median(&[]).is_nan());
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
