//! Tail probabilities and the χ²-equivalent of a search-corrected p-value.

use std::f64::consts::SQRT_2;

use statrs::distribution::{ChiSquared, ContinuousCDF, StudentsT};
use statrs::function::erf::{erfc, erfc_inv};

/// P(Z > z) for a standard normal Z.
pub fn norm_sf(z: f64) -> f64 {
    0.5 * erfc(z / SQRT_2)
}

/// Standard normal density.
pub fn norm_pdf(z: f64) -> f64 {
    (-0.5 * z * z).exp() / (2.0 * std::f64::consts::PI).sqrt()
}

/// z with P(Z > z) = q, q in (0, 1).
pub fn norm_isf(q: f64) -> f64 {
    SQRT_2 * erfc_inv(2.0 * q)
}

/// P(T > t) for Student's t with `nu` degrees of freedom (normal for huge `nu`).
pub fn t_sf(t: f64, nu: f64) -> f64 {
    if !(nu.is_finite() && nu > 0.0) || nu > 1e7 {
        return norm_sf(t);
    }
    StudentsT::new(0.0, 1.0, nu).map_or(norm_sf(t), |d| d.sf(t))
}

/// Half-width multiplier of a two-sided interval at probability `p` for Student's t.
pub fn t_two_sided(p: f64, nu: f64) -> f64 {
    let q = (1.0 + p.clamp(1e-9, 1.0 - 1e-12)) / 2.0;
    if !(nu.is_finite() && nu > 0.0) || nu > 1e7 {
        return norm_isf(1.0 - q);
    }
    StudentsT::new(0.0, 1.0, nu).map_or(norm_isf(1.0 - q), |d| d.inverse_cdf(q))
}

/// P(X > x) for χ² with `k` degrees of freedom.
pub fn chi2_sf(x: f64, k: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    ChiSquared::new(k).map_or(1.0, |d| d.sf(x))
}

/// The χ²₁ value with two-sided p-value `p`: z² with P(|Z| > z) = p. `fallback` (the raw
/// statistic, itself a χ²) is used where `p` has underflowed.
pub fn chi2_eq(p: f64, fallback: f64) -> f64 {
    if !(p < 1.0) {
        return 0.0;
    }
    if p < 1e-290 {
        let floor = norm_isf(0.5e-290).powi(2);
        return fallback.max(floor);
    }
    norm_isf(p / 2.0).powi(2)
}

/// ΔBIC of an effect with `k` amplitude parameters, `n_eff` effective observations and a
/// search-corrected two-sided p-value `p` (`raw_chi2` where `p` underflows).
pub fn delta_bic(k: f64, n_eff: f64, p: f64, raw_chi2: f64) -> f64 {
    k * n_eff.max(1.0).ln() - chi2_eq(p, raw_chi2)
}

/// Mean and variance (divided by n) of `v`.
pub fn mean_var(v: &[f64]) -> (f64, f64) {
    if v.is_empty() {
        return (0.0, 0.0);
    }
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    (m, v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tails_and_equivalents() {
        assert!((norm_sf(1.96) - 0.025).abs() < 1e-4);
        assert!((norm_isf(0.025) - 1.959964).abs() < 1e-5);
        assert!((t_two_sided(0.95, 10.0) - 2.228139).abs() < 1e-5);
        assert!((chi2_eq(0.05, 0.0) - 3.8415).abs() < 1e-3);
        assert_eq!(chi2_eq(1.0, 5.0), 0.0);
        assert!(chi2_eq(0.0, 5000.0) == 5000.0);
        assert!((chi2_sf(5.991, 2.0) - 0.05).abs() < 1e-4);
    }
}
