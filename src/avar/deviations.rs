//! The result of one statistic on one channel: a table with one row per τ.

use super::Statistic;

/// Allan-family variances with their confidence intervals, one entry per averaging factor.
///
/// All vectors have the same length and are in increasing τ. Variances are in the squared units
/// of the input rate samples.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Deviations {
    /// The statistic estimated.
    pub statistic: Statistic,
    /// Sample rate of the input, Hz (τ₀ = 1/rate).
    pub rate_hz: f64,
    /// Averaging factors m (samples).
    pub m: Vec<u64>,
    /// Averaging times τ = m / rate, seconds.
    pub tau_s: Vec<f64>,
    /// Variance estimates σ²(τ).
    pub variance: Vec<f64>,
    /// Number of squared differences averaged by the estimator at each τ.
    pub n_terms: Vec<u64>,
    /// Identified power-law noise exponent α (S_y ∝ f^α) used for the EDF.
    pub alpha: Vec<i8>,
    /// Equivalent degrees of freedom of each estimate (Greenhall–Riley).
    pub edf: Vec<f64>,
    /// Lower bound of the variance at the confidence level.
    pub variance_lo: Vec<f64>,
    /// Upper bound of the variance at the confidence level.
    pub variance_hi: Vec<f64>,
    /// Two-sided probability of the interval [variance_lo, variance_hi].
    pub confidence: f64,
}

impl Deviations {
    /// Deviations σ(τ): square roots of the variances, in the units of the input.
    pub fn deviation(&self) -> Vec<f64> {
        self.variance.iter().map(|v| v.sqrt()).collect()
    }

    /// Lower confidence bounds of the deviation.
    pub fn deviation_lo(&self) -> Vec<f64> {
        self.variance_lo.iter().map(|v| v.sqrt()).collect()
    }

    /// Upper confidence bounds of the deviation.
    pub fn deviation_hi(&self) -> Vec<f64> {
        self.variance_hi.iter().map(|v| v.sqrt()).collect()
    }

    /// Number of τ values.
    pub fn len(&self) -> usize {
        self.m.len()
    }

    /// Whether there are no τ values.
    pub fn is_empty(&self) -> bool {
        self.m.is_empty()
    }

    /// The rows at `keep` (increasing indices).
    pub fn subset(&self, keep: &[usize]) -> Deviations {
        fn pick<T: Copy>(v: &[T], keep: &[usize]) -> Vec<T> {
            keep.iter().map(|&i| v[i]).collect()
        }
        Deviations {
            statistic: self.statistic,
            rate_hz: self.rate_hz,
            m: pick(&self.m, keep),
            tau_s: pick(&self.tau_s, keep),
            variance: pick(&self.variance, keep),
            n_terms: pick(&self.n_terms, keep),
            alpha: pick(&self.alpha, keep),
            edf: pick(&self.edf, keep),
            variance_lo: pick(&self.variance_lo, keep),
            variance_hi: pick(&self.variance_hi, keep),
            confidence: self.confidence,
        }
    }
}
