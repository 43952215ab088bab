//! The statistical helpers every stage uses: normal, Student t and χ² tails and quantiles, on
//! `statrs`' distributions. One module, so that a p-value means the same thing in the fit, the
//! loop and the report.

use std::f64::consts::SQRT_2;

use statrs::distribution::{ChiSquared, Continuous, ContinuousCDF, Normal, StudentsT};
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
    if x <= 0.0 || k <= 0.0 {
        return 1.0;
    }
    ChiSquared::new(k).map_or(1.0, |d| d.sf(x))
}

/// The χ²₁ value with two-sided p-value `p`: z² with P(|Z| > z) = p. `fallback` (the raw
/// statistic, itself a χ²) is used where `p` has underflowed.
pub fn chi2_eq(p: f64, fallback: f64) -> f64 {
    if p.is_nan() || p >= 1.0 {
        return 0.0;
    }
    if p < 1e-290 {
        let floor = norm_isf(0.5e-290).powi(2);
        return fallback.max(floor);
    }
    norm_isf(p / 2.0).powi(2)
}

/// Standard normal quantile: z with P(Z ≤ z) = p.
pub fn normal_quantile(p: f64) -> f64 {
    Normal::new(0.0, 1.0).expect("unit normal").inverse_cdf(p)
}

/// Quantile of the chi-square distribution with `nu` degrees of freedom at probability `p` in
/// (0, 1).
///
/// statrs' generic `inverse_cdf` stops after a fixed small number of bisection and Newton steps,
/// which is not accurate enough at the large EDFs of long recordings, so this starts from the
/// Wilson–Hilferty approximation (already within ~1e-4 for ν ≥ 10) and refines it with safeguarded
/// Newton steps on statrs' accurate CDF until the step is below 1e-15 relative.
pub fn chi2_quantile(p: f64, nu: f64) -> f64 {
    let Ok(dist) = ChiSquared::new(nu) else {
        return f64::NAN;
    };
    // Bracket [lo, hi] with cdf(lo) < p < cdf(hi), widened from the approximation.
    let start = wilson_hilferty(p, nu);
    let mut x = if start.is_finite() && start > 0.0 {
        start
    } else {
        nu.max(1e-3)
    };
    let mut lo = 0.0f64;
    let mut hi = f64::INFINITY;
    for _ in 0..200 {
        let f = dist.cdf(x) - p;
        if f == 0.0 {
            return x;
        }
        if f < 0.0 {
            lo = lo.max(x);
        } else {
            hi = hi.min(x);
        }
        let density = dist.pdf(x);
        let mut next = x - f / density;
        // Fall back to bisection (or doubling while no upper bound is known) when Newton leaves
        // the bracket or the density underflows.
        if !(next > lo && next < hi && next.is_finite()) {
            next = if hi.is_finite() {
                0.5 * (lo + hi)
            } else {
                2.0 * x.max(lo)
            };
        }
        if (next - x).abs() <= 1e-15 * x.abs() {
            return next;
        }
        x = next;
    }
    x
}

/// Wilson–Hilferty cube-root normal approximation of the chi-square quantile.
fn wilson_hilferty(p: f64, nu: f64) -> f64 {
    let z = std::f64::consts::SQRT_2 * statrs::function::erf::erf_inv(2.0 * p - 1.0);
    let c = 2.0 / (9.0 * nu);
    nu * (1.0 - c + z * c.sqrt()).powi(3)
}
