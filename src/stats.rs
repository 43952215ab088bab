//! The statistical helpers every stage uses: normal, Student t and χ² tails and quantiles, on
//! `statrs`' distributions. One module, so that a p-value means the same thing in the fit, the
//! loop and the report.

use std::f64::consts::SQRT_2;

use statrs::distribution::{ChiSquared, Continuous, ContinuousCDF, Normal, StudentsT};
use statrs::function::erf::{erfc, erfc_inv};

/// Σ x_i in eight independent partial sums: a plain fold is one chain of dependent adds (one add
/// per 4 cycles; on a 10⁷-sample record 11 ms a pass, and the loop's detectors pass over it
/// several times), the lanes run in vector registers; and, as a side effect, the sum is more
/// accurate.
pub fn lane_sum(x: &[f64]) -> f64 {
    const LANES: usize = 8;
    let mut acc = [0.0; LANES];
    let chunks = x.chunks_exact(LANES);
    let rest = chunks.remainder();
    for c in chunks {
        for (a, v) in acc.iter_mut().zip(c) {
            *a += v;
        }
    }
    acc.iter().sum::<f64>() + rest.iter().sum::<f64>()
}

/// Compensated (Neumaier) sum, in iteration order: the rounding of every addition carried along.
pub fn neumaier(values: impl Iterator<Item = f64>) -> f64 {
    let (mut sum, mut comp) = (0.0f64, 0.0f64);
    for v in values {
        let t = sum + v;
        comp += if sum.abs() >= v.abs() {
            (sum - t) + v
        } else {
            (v - t) + sum
        };
        sum = t;
    }
    sum + comp
}

/// The distance from |x| to the next larger 64-bit float: the resolution of a value that size.
pub fn float_spacing(x: f64) -> f64 {
    let a = x.abs();
    f64::from_bits(a.to_bits() + 1) - a
}

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
    if k >= TEMME_MIN_NU && k.is_finite() {
        return chi2_tails_large(x, k).1;
    }
    ChiSquared::new(k).map_or(1.0, |d| d.sf(x))
}

/// Degrees of freedom from which the χ² tails come from [`chi2_tails_large`] instead of statrs.
///
/// **Why.** statrs' regularised incomplete gamma sums a series whose length grows with √ν: at the
/// EDFs of a white-noise coefficient on a long record (ν of 10⁶–10⁷) each evaluation cost tens of
/// microseconds, and the fits' intervals and model averages ask for thousands of them (a fifth of
/// the model stage's time on 812 min at 207 Hz). From ν = 10⁵ the uniform expansion below, cut
/// after its third term, gives both tails to 10⁻¹² of the smaller one or better out to 9σ (the
/// tests hold it to 40-digit arithmetic; statrs' own series is off by 10⁻¹¹ there).
const TEMME_MIN_NU: f64 = 1e5;

/// (P(X ≤ x), P(X > x)) for X ~ χ² with `nu` degrees of freedom, large `nu`
/// (≥ [`TEMME_MIN_NU`]): Temme's uniform asymptotic expansion of the regularised incomplete gamma
/// functions at a = ν/2, with λ = x/ν and η = sign(λ − 1)·√(2(λ − 1 − ln λ)):
///
/// Q = ½ erfc(η√(a/2)) + R, P = ½ erfc(−η√(a/2)) − R,
/// R = e^{−aη²/2}/√(2πa) · (C₀(η) + C₁(η)/a + C₂(η)/a²),
///
/// C₀ = 1/(λ−1) − 1/η, C₁ = 1/η³ − 1/(λ−1)³ − 1/(λ−1)² − 1/(12(λ−1)), both from their Taylor
/// series in η where |η| < 0.01 (the closed forms cancel there), C₂ from its first two (it is
/// weighed by 1/a² < 10⁻⁹). Temme (1979), "The asymptotic expansion of the incomplete gamma
/// functions", SIAM J. Math. Anal. 10; coefficients as tabulated by DiDonato & Morris (1986).
fn chi2_tails_large(x: f64, nu: f64) -> (f64, f64) {
    use std::f64::consts::PI;
    if x <= 0.0 {
        return (0.0, 1.0);
    }
    if x == f64::INFINITY {
        return (1.0, 0.0);
    }
    let a = 0.5 * nu;
    let e = x / nu - 1.0;
    // λ − 1 − ln λ = e − ln(1 + e), by its series where the difference cancels.
    let half_eta2 = if e.abs() < 0.1 {
        let mut sum = 0.0;
        let mut power = e * e;
        for k in 2..=24 {
            let term = power / k as f64;
            sum += if k % 2 == 0 { term } else { -term };
            power *= e;
        }
        sum
    } else {
        e - e.ln_1p()
    };
    let eta = (2.0 * half_eta2).sqrt().copysign(e);
    let (c0, c1) = if eta.abs() < 0.01 {
        const D0: [f64; 6] = [
            -1.0 / 3.0,
            1.0 / 12.0,
            -2.0 / 135.0,
            1.0 / 864.0,
            1.0 / 2835.0,
            -139.0 / 777_600.0,
        ];
        const D1: [f64; 5] = [
            -1.0 / 540.0,
            -1.0 / 288.0,
            1.0 / 378.0,
            -77.0 / 77_760.0,
            1.0 / 4860.0,
        ];
        let horner = |d: &[f64]| d.iter().rev().fold(0.0, |acc, c| acc * eta + c);
        (horner(&D0), horner(&D1))
    } else {
        (
            1.0 / e - 1.0 / eta,
            1.0 / eta.powi(3) - 1.0 / e.powi(3) - 1.0 / (e * e) - 1.0 / (12.0 * e),
        )
    };
    let c2 = 25.0 / 6048.0 - 139.0 / 51_840.0 * eta;
    let r = (-a * half_eta2).exp() / (2.0 * PI * a).sqrt() * (c0 + c1 / a + c2 / (a * a));
    // libm's erfc: statrs' is off by ~1e-10 relative, which the expansion would pass on.
    let arg = eta * (0.5 * a).sqrt();
    (0.5 * libm::erfc(-arg) - r, 0.5 * libm::erfc(arg) + r)
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
/// Newton steps on statrs' CDF (from ν = 10⁵ on, Temme's expansion: `chi2_tails_large`)
/// until the step is below 1e-15 relative.
pub fn chi2_quantile(p: f64, nu: f64) -> f64 {
    let Ok(dist) = ChiSquared::new(nu) else {
        return f64::NAN;
    };
    let large = nu >= TEMME_MIN_NU && nu.is_finite();
    let cdf = |x: f64| {
        if large {
            chi2_tails_large(x, nu).0
        } else {
            dist.cdf(x)
        }
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
        let f = cdf(x) - p;
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

/// Golden-section minimum of `g` on [a, b] (`iters` steps): (x, g(x)). For the one-dimensional
/// searches over an effect's shape parameter (a resonance's Q or f₀, a Gauss–Markov Tc), whose
/// scores are single-welled over the range searched.
pub fn golden(g: &mut dyn FnMut(f64) -> f64, mut a: f64, mut b: f64, iters: usize) -> (f64, f64) {
    let r = (5f64.sqrt() - 1.0) / 2.0;
    let (mut c, mut d) = (b - r * (b - a), a + r * (b - a));
    let (mut gc, mut gd) = (g(c), g(d));
    for _ in 0..iters {
        if gc <= gd {
            (b, d, gd) = (d, c, gc);
            c = b - r * (b - a);
            gc = g(c);
        } else {
            (a, c, gc) = (c, d, gd);
            d = a + r * (b - a);
            gd = g(d);
        }
    }
    if gc <= gd {
        (c, gc)
    } else {
        (d, gd)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn neumaier_keeps_small_terms() {
        let v = [1e16, 1.0, -1e16, 1.0];
        assert_eq!(neumaier(v.into_iter()), 2.0);
    }

    #[test]
    fn float_spacing_is_one_unit_in_the_last_place() {
        assert_eq!(float_spacing(1.0), f64::EPSILON);
        assert_eq!(float_spacing(-1.7e9), 2f64.powi(-22));
        assert_eq!(float_spacing(0.0), f64::from_bits(1));
    }

    /// (ν, z, P, Q) at x = ν + z·√(2ν), in 40-digit arithmetic (`scripts/make_chi2_fixtures.py`).
    const TAILS: [(f64, f64, f64, f64); 14] = [
        (
            1.000000e+05,
            -6.0,
            7.107427070584388e-10,
            0.9999999992892573,
        ),
        (1.000000e+05, -1.0, 0.15865444478879534, 0.8413455552112047),
        (1.000000e+05, -0.001, 0.5001957656637223, 0.4998042343362777),
        (1.000000e+05, 0.0, 0.5005947081047933, 0.4994052918952067),
        (1.000000e+05, 0.5, 0.6918560455548445, 0.30814395444515547),
        (1.000000e+05, 3.0, 0.9985967636561871, 0.0014032363438129228),
        (1.000000e+05, 9.0, 1.0, 3.239561953864801e-19),
        (
            4.000000e+06,
            -6.0,
            9.375636962777569e-10,
            0.9999999990624363,
        ),
        (4.000000e+06, -1.0, 0.15865523375708943, 0.8413447662429105),
        (
            4.000000e+06,
            -0.001,
            0.49969508925918016,
            0.5003049107408198,
        ),
        (4.000000e+06, 0.0, 0.5000940315975192, 0.49990596840248086),
        (4.000000e+06, 0.5, 0.6915246973019786, 0.30847530269802137),
        (4.000000e+06, 3.0, 0.9986417330154115, 0.0013582669845885267),
        (4.000000e+06, 9.0, 1.0, 1.3389739436873068e-19),
    ];

    /// (ν, p, x) with P(X ≤ x) = p, in 40-digit arithmetic (the same script).
    const QUANTILES: [(f64, f64, f64); 8] = [
        (1.000000e+05, 1e-09, 97340.97157279658),
        (1.000000e+05, 0.025, 99125.37330064735),
        (1.000000e+05, 0.5, 99999.33333412347),
        (1.000000e+05, 0.975, 100878.41530566558),
        (4.000000e+06, 1e-09, 3983058.9489106643),
        (4.000000e+06, 0.025, 3994458.2792516043),
        (4.000000e+06, 0.5, 3999999.333333353),
        (4.000000e+06, 0.975, 4005545.5093600205),
    ];

    /// The large-ν expansion gives both tails to 1e-12 of the smaller one, out to 9σ (where
    /// statrs' series is off by 1e-11, and scipy's cdf by 6e-5 at 6σ below the mean of ν = 4e6).
    #[test]
    fn large_nu_tails_match_high_precision() {
        for (nu, z, p, q) in TAILS {
            let x = nu + z * (2.0 * nu).sqrt();
            let (got_p, got_q) = chi2_tails_large(x, nu);
            let scale = p.min(q);
            assert!(
                (got_p - p).abs() <= 1e-12 * scale,
                "ν {nu} z {z}: P {got_p:e} vs {p:e}"
            );
            assert!(
                (got_q - q).abs() <= 1e-12 * scale,
                "ν {nu} z {z}: Q {got_q:e} vs {q:e}"
            );
            assert_eq!(chi2_sf(x, nu), got_q);
        }
    }

    /// The quantile from the expansion to the Newton tolerance; below the threshold statrs' series
    /// serves, and its quantile agrees to 1e-9 (its own accuracy there).
    #[test]
    fn large_nu_quantiles_match_high_precision() {
        for (nu, p, x) in QUANTILES {
            let got = chi2_quantile(p, nu);
            assert!((got - x).abs() <= 1e-14 * x, "ν {nu} p {p}: {got} vs {x}");
            let below = chi2_quantile(p, nu * (1.0 - 1e-15));
            if nu * (1.0 - 1e-15) < TEMME_MIN_NU {
                assert!(
                    (below - x).abs() <= 1e-9 * x,
                    "ν {nu} p {p}: {below} vs {x}"
                );
            }
        }
    }
}
