//! Spectra of sampled averages: what a sensor that outputs the mean rate over each sample interval
//! (delta angle or delta velocity over τ₀, as most IMUs do) has at frequency f < fs/2.
//!
//! Averaging over τ₀ multiplies the continuous spectrum by sinc²(πfτ₀), and sampling folds every
//! alias f + k·fs onto f:
//!
//! S_d(f) = Σ_k S(f + k·fs)·sinc²(π(f + k·fs)τ₀).
//!
//! For a power law S(f) = |2πf|^(−p) this is (2π·fs)^(−p)·sin²(πx)/π²·Σ_k |x + k|^(−(p+2)) with
//! x = f/fs, a sum of two Hurwitz zeta values. The sampled process has exactly the continuous
//! Allan variance at every τ = mτ₀ (averaging m averages is the continuous average over τ), which
//! is why the fits use the IEEE AV forms as they are and this form for the spectrum. For white
//! noise (p = 0) the sum is π²/sin²(πx) and S_d = S: white stays white.

use std::f64::consts::PI;

/// Σ_{k∈ℤ} |x + k|^(−s) for 0 < x < 1 and integer s ≥ 2: ζ(s, x) + ζ(s, 1 − x).
#[inline]
pub(crate) fn alias_sum(x: f64, s: i32) -> f64 {
    hurwitz_zeta(s, x) + hurwitz_zeta(s, 1.0 - x)
}

/// `x^n` by the square-and-multiply that `f64::powi` runs for an exponent unknown at compile
/// time (compiler-rt's `__powidf2`, the reciprocal taken last for n < 0), the same operations in
/// the same order, so the same result to the bit; inlined, where `powi` is a call that was a
/// thirtieth of the model stage's time.
#[inline(always)]
fn powi(mut x: f64, n: i32) -> f64 {
    let mut b = n;
    let mut r = 1.0;
    loop {
        if b & 1 != 0 {
            r *= x;
        }
        b /= 2;
        if b == 0 {
            break;
        }
        x *= x;
    }
    if n < 0 {
        1.0 / r
    } else {
        r
    }
}

/// Hurwitz zeta ζ(s, a) = Σ_{k≥0} (a + k)^(−s), s > 1, 0 < a ≤ 1: sixteen terms summed, the
/// rest by Euler–Maclaurin with three Bernoulli corrections (the next one is below 1e-12
/// relative for s ≤ 5).
/// Integer s only: `powi` keeps it fast enough to shape tens of millions of bins.
#[inline]
fn hurwitz_zeta(si: i32, a: f64) -> f64 {
    const N: usize = 16;
    let mut sum = 0.0;
    for k in 0..N {
        sum += powi(a + k as f64, -si);
    }
    let b = a + N as f64;
    let s = f64::from(si);
    // ∫_b^∞ x^−s dx + f(b)/2 − Σ_j B_2j/(2j)!·f^(2j−1)(b), f(x) = x^−s; B₂ = 1/6, B₄ = −1/30,
    // B₆ = 1/42.
    let t = powi(b, -si);
    let b2 = b * b;
    let (s1, s2, s3, s4) = (s + 1.0, s + 2.0, s + 3.0, s + 4.0);
    sum += b * t / (s - 1.0) + t / 2.0;
    sum += s * t / b / 12.0;
    sum -= s * s1 * s2 * t / (b * b2) / 720.0;
    sum += s * s1 * s2 * s3 * s4 * t / (b * b2 * b2) / 30240.0;
    sum
}

/// The sampled-average spectrum of a two-sided power law |2πf|^(−p) (integer p ≥ 0) at
/// 0 < f < fs/2.
#[inline]
pub(crate) fn sampled_power_law(f: f64, rate_hz: f64, p: i32) -> f64 {
    let x = f / rate_hz;
    if p == 0 {
        return 1.0;
    }
    let s = (PI * x).sin();
    (2.0 * PI * rate_hz).powi(-p) * s * s / (PI * PI) * alias_sum(x, p + 2)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn powi_is_the_library_powi_to_the_bit() {
        for x in [0.37, 1.0 + 1e-9, 3.5, 16.25, 1234.5] {
            for n in -7..=7 {
                // The exponent hidden from the optimiser, as at the call sites.
                let m = std::hint::black_box(n);
                assert_eq!(powi(x, m).to_bits(), x.powi(m).to_bits(), "{x}^{n}");
            }
        }
    }

    #[test]
    fn hurwitz_zeta_known_values() {
        // ζ(2, 1) = π²/6, ζ(3, 1) = Apéry's constant, ζ(4, ½) = 15·ζ(4) = π⁴/6.
        assert!((hurwitz_zeta(2, 1.0) - PI * PI / 6.0).abs() < 1e-12);
        assert!((hurwitz_zeta(3, 1.0) - 1.202_056_903_159_594_3).abs() < 1e-13);
        assert!((hurwitz_zeta(4, 0.5) - PI.powi(4) / 6.0).abs() < 1e-12);
    }

    #[test]
    fn white_stays_white_and_low_frequencies_are_unchanged() {
        // Σ 1/(x+k)² = π²/sin²(πx): the p = 0 identity, checked through the general path.
        for x in [0.01, 0.2, 0.37, 0.5] {
            let s = (PI * x).sin();
            assert!(
                (s * s / (PI * PI) * alias_sum(x, 2) - 1.0).abs() < 1e-12,
                "{x}"
            );
        }
        // Far below Nyquist the k = 0 term dominates: S_d/S = sinc² + O(x^(p+2)).
        let fs = 100.0;
        for p in [1, 2, 3] {
            let f = 0.01;
            let ratio = sampled_power_law(f, fs, p) * (2.0 * PI * f).powi(p);
            assert!((ratio - 1.0).abs() < 1e-6, "p = {p}: {ratio}");
        }
    }
}
