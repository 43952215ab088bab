//! Which engine computes each statistic, and its normalisation.
//!
//! With S in units of rate × samples and τ = m·τ₀, every estimator below is dimensionless in τ₀:
//! τ₀ cancels between the differences of phase (τ₀·S) and the 1/τ² in front.

use super::mdev::modified_sums;
use super::prefix::PrefixSums;
use super::strided::strided_sums;
use super::sweep::{overlapping_sums, Order};
use super::Statistic;

/// Variance of `stat` at each averaging factor of `ms` (all valid for the data length).
pub(crate) fn variances(ps: &PrefixSums, ms: &[u64], stat: Statistic) -> Vec<f64> {
    let s = ps.s();
    let n = ps.len();
    let sums = match stat {
        Statistic::Oadev => overlapping_sums(s, ms, Order::Second),
        Statistic::Ohdev => overlapping_sums(s, ms, Order::Third),
        Statistic::Adev => strided_sums(s, ms, Order::Second),
        Statistic::Hdev => strided_sums(s, ms, Order::Third),
        Statistic::Mdev => modified_sums(s, ms),
    };
    ms.iter()
        .zip(sums)
        .map(|(&m, sum)| {
            let terms = stat.n_terms(n, m) as f64;
            let m = m as f64;
            match stat {
                // Allan: ½⟨(ȳ_{k+1} − ȳ_k)²⟩ with ȳ = ΔS/m.
                Statistic::Oadev | Statistic::Adev => sum / (2.0 * m * m * terms),
                // Modified Allan: the m-average of the phase second differences, 1/(2m⁴).
                Statistic::Mdev => sum / (2.0 * m * m * m * m * terms),
                // Hadamard: ⅙⟨(ȳ_{k+2} − 2ȳ_{k+1} + ȳ_k)²⟩.
                Statistic::Hdev | Statistic::Ohdev => sum / (6.0 * m * m * terms),
            }
        })
        .collect()
}
