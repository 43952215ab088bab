//! Averaging of segment periodograms: the mean, or scipy's bias-corrected median.
//!
//! The median is robust to a few segments spoiled by a transient (a bump on the test table, a door
//! slam), at the cost of keeping every segment's periodogram until the end: memory is
//! segments × (nfft/2 + 1) values per channel, unlike the mean, which needs one running sum.

use std::fmt;
use std::str::FromStr;

use rayon::prelude::*;

use super::PsdError;

/// How segment periodograms are combined.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Average {
    /// Arithmetic mean (scipy's default). Memory: one spectrum per channel.
    Mean,
    /// Median divided by scipy's `_median_bias(segments)`. Memory: segments × bins per channel.
    Median,
}

/// scipy's `_median_bias(n)`: the ratio of the expected median to the expected mean of n
/// periodogram values (χ²₂-distributed), 1 + Σ_{i=1}^{⌊(n−1)/2⌋} (1/(2i+1) − 1/(2i)), from
/// Allen et al., FINDCHIRP (arXiv gr-qc/0509116), appendix B. It tends to ln 2.
pub fn median_bias(n: usize) -> f64 {
    let terms = n.saturating_sub(1) / 2;
    1.0 + (1..=terms)
        .map(|i| {
            let ii = 2.0 * i as f64;
            1.0 / (ii + 1.0) - 1.0 / ii
        })
        .sum::<f64>()
}

/// Median of `values` (reordered in place) as numpy computes it: the middle value, or the mean of
/// the two middle values for an even count. NaN if any value is NaN (numpy's rule too), so a bad
/// sample shows up instead of being hidden. `values` must not be empty.
pub(crate) fn median_in_place(values: &mut [f64]) -> f64 {
    let n = values.len();
    debug_assert!(n > 0);
    if values.iter().any(|v| v.is_nan()) {
        return f64::NAN;
    }
    let mid = n / 2;
    let (below, upper, _) = values.select_nth_unstable_by(mid, f64::total_cmp);
    let upper = *upper;
    if n % 2 == 1 {
        upper
    } else {
        let lower = below.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        (lower + upper) / 2.0
    }
}

/// Bias-corrected median over segments of each bin, from `rows` (segments × bins, one row per
/// segment). Bins are independent, so they are spread over threads.
pub(crate) fn column_medians(rows: &[f64], segments: usize, bins: usize) -> Vec<f64> {
    let bias = median_bias(segments);
    (0..bins)
        .into_par_iter()
        .map_init(
            || Vec::with_capacity(segments),
            |column, k| {
                column.clear();
                column.extend(rows.iter().skip(k).step_by(bins).take(segments));
                median_in_place(column) / bias
            },
        )
        .collect()
}

/// Relative efficiency of the bias-corrected median against the mean, for `n` independent
/// χ²₂ values: Var(mean)/Var(median/bias) in units of the squared expectation. Exact, from the
/// order statistics of exponentials (the r-th smallest of n is Σ_{j<r} E_j/(n − j)); it falls
/// from 1 (n ≤ 2, where the median *is* the mean) towards (ln 2)² ≈ 0.48.
pub fn median_efficiency(n: usize) -> f64 {
    if n <= 2 {
        return 1.0;
    }
    // Mean and variance of the k-th order statistic (1-based) of n unit exponentials.
    let moments = |k: usize| -> (f64, f64) {
        (0..k).fold((0.0, 0.0), |(m, v), j| {
            let d = 1.0 / (n - j) as f64;
            (m + d, v + d * d)
        })
    };
    let (mean, var) = if n % 2 == 1 {
        moments(n.div_ceil(2))
    } else {
        // (X_(r) + X_(r+1))/2 with X_(r+1) = X_(r) + E_r/(n − r), r = n/2.
        let r = n / 2;
        let (m, v) = moments(r);
        let d = 1.0 / (n - r) as f64;
        (m + d / 2.0, v + d * d / 4.0)
    };
    (1.0 / n as f64) / (var / (mean * mean))
}

impl fmt::Display for Average {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Average::Mean => "mean",
            Average::Median => "median",
        })
    }
}

impl FromStr for Average {
    type Err = PsdError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "mean" => Ok(Average::Mean),
            "median" => Ok(Average::Median),
            _ => Err(PsdError::UnknownName {
                what: "average",
                name: s.to_owned(),
                expected: "mean, median",
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bias_matches_scipy_values() {
        // scipy.signal._spectral_py._median_bias(n) for n = 1, 2, 3, 4, 5, 100.
        assert_eq!(median_bias(1), 1.0);
        assert_eq!(median_bias(2), 1.0);
        assert!((median_bias(3) - (1.0 + 1.0 / 3.0 - 0.5)).abs() < 1e-15);
        assert!((median_bias(4) - median_bias(3)).abs() < 1e-15);
        assert!((median_bias(5) - (1.0 + 1.0 / 3.0 - 0.5 + 0.2 - 0.25)).abs() < 1e-15);
        assert!((median_bias(100_001) - std::f64::consts::LN_2).abs() < 1e-5);
    }

    #[test]
    fn median_odd_even_and_nan() {
        assert_eq!(median_in_place(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median_in_place(&mut [4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median_in_place(&mut [7.0]), 7.0);
        assert!(median_in_place(&mut [1.0, f64::NAN, 2.0]).is_nan());
    }

    #[test]
    fn efficiency_limits() {
        assert_eq!(median_efficiency(2), 1.0);
        // n = 3: the median is E1/3 + E2/2: mean 5/6, variance 13/36 → (1/3)/(13/25).
        assert!((median_efficiency(3) - 25.0 / 39.0).abs() < 1e-15);
        let ln2sq = std::f64::consts::LN_2.powi(2);
        assert!((median_efficiency(20_001) - ln2sq).abs() < 1e-3);
    }

    #[test]
    fn names_round_trip() {
        for a in [Average::Mean, Average::Median] {
            assert_eq!(a.to_string().parse::<Average>().unwrap(), a);
        }
        assert!("mode".parse::<Average>().is_err());
    }
}
