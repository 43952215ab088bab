//! The loop's evidence arithmetic (ΔBIC of an effect from a search-corrected p-value, mean and
//! variance); the distributions themselves come from [`crate::stats`].

pub use crate::stats::{chi2_eq, chi2_sf, norm_isf, norm_pdf, norm_sf, t_sf, t_two_sided};

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
