//! Confidence intervals of fitted coefficients.
//!
//! A fitted squared coefficient ĉ is a weighted sum of χ²-like point estimates, so, like each of
//! them, it is modelled as c·χ²_ν/ν with the Satterthwaite degrees of freedom ν = 2ĉ²/Var(ĉ), where
//! Var(ĉ) is the diagonal of the inverse Fisher information of the selected terms. The interval is
//! then [νĉ/χ²_ν(1 − q), νĉ/χ²_ν(q)], q = (1 − p)/2, and the coefficient's is its square root.
//! Compared with ĉ ± z·σ this is skewed the way the estimate is (long upper tail when ν is small),
//! never negative, and reduces to the symmetric form when ν is large. The same construction as the
//! Allan-deviation intervals of [`crate::avar`].

use crate::stats::{chi2_quantile, normal_quantile};

/// (lo, hi, ν) of the coefficient √c for squared estimate `c` with variance `var`, at two-sided
/// probability `p`.
pub(crate) fn coefficient_interval(c: f64, var: f64, p: f64) -> (f64, f64, f64) {
    if c.is_nan() || c <= 0.0 {
        return (0.0, 0.0, 0.0);
    }
    if !(var.is_finite() && var > 0.0) {
        return (c.sqrt(), c.sqrt(), f64::INFINITY);
    }
    let nu = 2.0 * c * c / var;
    let q = (1.0 - p) / 2.0;
    if nu > 1e7 {
        // χ² quantiles lose precision there; the interval is symmetric to 1e-4 anyway.
        let z = normal_quantile(1.0 - q);
        let sd = var.sqrt();
        return ((c - z * sd).max(0.0).sqrt(), (c + z * sd).sqrt(), nu);
    }
    // Below ν ≈ 0.3 the χ²_ν mass crowds at 0 so that even its upper quantile lies below the
    // mean: the scaled interval then excludes the estimate itself (a K of 5.0e-7 was printed with
    // [6.7e-7, 0.84]). An interval always holds its estimate.
    let lo = (nu * c / chi2_quantile(1.0 - q, nu)).min(c);
    let hi = (nu * c / chi2_quantile(q, nu)).max(c);
    (lo.sqrt(), hi.sqrt(), nu)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn large_nu_is_the_symmetric_interval() {
        // ν = 2e6: χ² interval ≈ c ± σ to O(1/√ν).
        let (c, sd) = (4.0, 4.0 * 1e-3);
        let (lo, hi, nu) = coefficient_interval(c, sd * sd, crate::avar::ONE_SIGMA);
        assert!((nu - 2e6).abs() < 1.0);
        assert!((lo * lo - (c - sd)).abs() < 1e-5 && (hi * hi - (c + sd)).abs() < 1e-5);
    }

    /// A term the data hardly determine (ν = 0.005): the interval still holds the estimate.
    #[test]
    fn a_vanishing_nu_keeps_the_estimate_inside() {
        let c = 1.0;
        let nu = 0.005;
        let (lo, hi, got) = coefficient_interval(c, 2.0 * c * c / nu, crate::avar::ONE_SIGMA);
        assert!((got - nu).abs() < 1e-12);
        assert!(lo <= 1.0 && 1.0 <= hi, "[{lo}, {hi}]");
        assert!(hi > 1.0);
    }

    #[test]
    fn small_nu_is_skewed_and_positive() {
        // ν = 2: the 90 % interval of c·χ²₂/2 is [c·2/5.991, c·2/0.1026].
        let (lo, hi, nu) = coefficient_interval(1.0, 1.0, 0.9);
        assert!((nu - 2.0).abs() < 1e-12);
        assert!((lo * lo - 2.0 / 5.991_464_547).abs() < 1e-6, "{lo}");
        assert!((hi * hi - 2.0 / 0.102_586_589).abs() < 1e-4, "{hi}");
    }
}
