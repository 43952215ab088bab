//! Confidence intervals from equivalent degrees of freedom (EDF).
//!
//! An Allan-family variance estimate σ̂² with ν EDF is modelled as σ²·χ²_ν/ν, so the two-sided
//! interval at probability p is [ν·σ̂²/χ²_ν(1 − q), ν·σ̂²/χ²_ν(q)] with q = (1 − p)/2 (NIST SP 1065
//! eq. 45, the form Stable32 and allantools use).

pub use crate::stats::chi2_quantile;

use super::AvarError;

/// The two-sided probability of the confidence interval.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Confidence {
    /// The "1σ" interval of a normal variable: p = erf(1/√2) ≈ 0.682689. Stable32 prints its
    /// confidence factor for this as 0.683.
    OneSigma,
    /// Any probability strictly between 0 and 1 (e.g. 0.95).
    Level(f64),
}

/// erf(1/√2): the probability of a normal variable within one standard deviation of its mean.
pub const ONE_SIGMA: f64 = 0.682_689_492_137_085_9;

impl Confidence {
    /// The two-sided probability, checked to lie strictly between 0 and 1.
    pub fn probability(self) -> Result<f64, AvarError> {
        match self {
            Confidence::OneSigma => Ok(ONE_SIGMA),
            Confidence::Level(p) if p > 0.0 && p < 1.0 => Ok(p),
            Confidence::Level(p) => Err(AvarError::InvalidConfidence(p)),
        }
    }
}

/// Lower and upper bounds of the variance for estimate `variance` with `edf` degrees of freedom
/// at two-sided probability `p` (already validated). A variance of 0 gives (0, 0); a non-positive
/// or non-finite EDF gives (0, ∞): no information.
pub fn variance_bounds(variance: f64, edf: f64, p: f64) -> (f64, f64) {
    if !edf.is_finite() || edf <= 0.0 {
        return (0.0, f64::INFINITY);
    }
    let q = (1.0 - p) / 2.0;
    let lo = edf * variance / chi2_quantile(1.0 - q, edf);
    let hi = edf * variance / chi2_quantile(q, edf);
    (lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// scipy.stats.chi2.ppf(p, nu) (scipy 1.17) at p = (1 − erf(1/√2))/2, its complement, 0.025
    /// and 0.975.
    const SCIPY: [(f64, [f64; 4]); 7] = [
        (
            0.5,
            [
                0.0008556197281856074,
                0.9642659623670375,
                5.273202591259991e-07,
                3.433235299960771,
            ],
        ),
        (
            1.0,
            [
                0.04006950463364094,
                1.986996713315955,
                0.0009820691171752555,
                5.023886187314888,
            ],
        ),
        (
            2.5,
            [
                0.5742581034948289,
                4.449238615943069,
                0.11862294210006345,
                8.392295266912964,
            ],
        ),
        (
            10.0,
            [
                5.680617711186441,
                14.325506344521887,
                3.2469727802368413,
                20.483177350807388,
            ],
        ),
        (
            1000.0,
            [
                955.2935779834957,
                1044.7064813006473,
                914.257153799259,
                1089.5309127749135,
            ],
        ),
        (
            1e5,
            [
                99552.7878955091,
                100447.2121050835,
                99125.37330064735,
                100878.41530566558,
            ],
        ),
        (
            1e7,
            [
                9995527.864194075,
                10004472.135805931,
                9991236.669053895,
                10008767.119557811,
            ],
        ),
    ];

    #[test]
    fn quantiles_match_scipy() {
        let ps = [0.15865525393145707, 0.8413447460685429, 0.025, 0.975];
        for (nu, expected) in SCIPY {
            for (p, want) in ps.iter().zip(expected) {
                let got = chi2_quantile(*p, nu);
                let rel = (got - want).abs() / want;
                assert!(rel < 1e-9, "nu={nu} p={p}: {got} vs {want} (rel {rel:e})");
            }
        }
    }

    #[test]
    fn bounds_bracket_the_estimate() {
        let (lo, hi) = variance_bounds(2.0, 50.0, ONE_SIGMA);
        assert!(lo < 2.0 && hi > 2.0);
        assert_eq!(variance_bounds(0.0, 10.0, 0.9), (0.0, 0.0));
        assert_eq!(variance_bounds(1.0, 0.0, 0.9), (0.0, f64::INFINITY));
    }

    #[test]
    fn probability_is_validated() {
        assert_eq!(Confidence::OneSigma.probability().unwrap(), ONE_SIGMA);
        assert_eq!(Confidence::Level(0.95).probability().unwrap(), 0.95);
        for p in [0.0, 1.0, -0.2, 1.5, f64::NAN] {
            assert!(Confidence::Level(p).probability().is_err(), "{p}");
        }
    }
}
