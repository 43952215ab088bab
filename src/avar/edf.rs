//! Equivalent degrees of freedom (EDF) of Allan-family variance estimates.
//!
//! [`greenhall_edf`] is the combined algorithm of C. Greenhall and W. Riley, "Uncertainty of
//! stability variances based on finite differences", 35th PTTI meeting (2003). It models the phase
//! as a continuous-time power-law process, and covers every estimator here (d = 2 Allan, d = 3
//! Hadamard; overlapping or not; modified or not) and every noise exponent α the estimator
//! converges for. Stable32 uses it for its confidence intervals: the 1σ bounds of its PHASE.DAT
//! octave run are reproduced to better than 4e-4 (the simple approximations of [`simple_edf`] are
//! off by up to 2.4e-3 there), see `tests/integration/avar`.
//!
//! The exact form (a sum of squared autocovariances, the paper's eq. 10) is used while it has at most 100
//! terms; beyond that the paper's fitted asymptotic forms (tables 1–3) take over, which makes the
//! EDF cost O(1) per τ however long the recording.

use super::Statistic;

/// Maximum number of autocovariance terms summed exactly (the paper's J_max).
const J_MAX: f64 = 100.0;

/// EDF of `stat` at averaging factor `m` on `n_samples` rate samples, for power-law noise
/// S_y(f) ∝ f^α. α is clamped to the range the statistic converges for
/// ([`Statistic::alpha_min`] to 2).
pub fn edf(stat: Statistic, alpha: i8, m: u64, n_samples: usize) -> f64 {
    greenhall_edf(
        alpha,
        stat.difference_order(),
        m,
        n_samples as u64 + 1,
        stat.overlapping(),
        stat.modified(),
    )
}

/// Greenhall–Riley combined EDF.
///
/// `d`: order of the phase difference (2 Allan, 3 Hadamard; 1 is also accepted); `m`: averaging
/// factor; `n_phase`: number of phase points (rate samples + 1); `overlapping`: stride 1 rather than
/// m; `modified`: the modified (phase-averaging) estimator. α is clamped to [2 − 2d, 2], the range
/// where the estimator converges (α + 2d > 1). Returns NaN when the data are too short for one
/// estimator term.
pub fn greenhall_edf(
    alpha: i8,
    d: u8,
    m: u64,
    n_phase: u64,
    overlapping: bool,
    modified: bool,
) -> f64 {
    let d = d.clamp(1, 3);
    let alpha = alpha.clamp(2 - 2 * d as i8, 2);
    let di = u64::from(d);
    let df = f64::from(d);
    let m = m.max(1);
    // Filter factor F (1 for modified, m otherwise) and stride factor S (m overlapping, 1 not).
    let stride = if overlapping { m } else { 1 };
    let filter_len = if modified { m } else { 1 } + m * di; // L
    if n_phase < filter_len {
        return f64::NAN;
    }
    // M: number of estimator terms.
    let big_m = 1 + stride * (n_phase - filter_len) / m;
    let j = big_m.min((di + 1) * stride) as f64;
    let (mf, sf, mm) = (m as f64, stride as f64, big_m as f64);
    let r = mm / sf;
    let sz0 = |f: Filter| sz(0.0, f, alpha, d);
    let inv = if modified {
        // Case 1: modified variances, all α.
        let f = Filter::Finite(1.0);
        if j <= J_MAX {
            basic_sum(j, mm, sf, f, alpha, d) / (mm * sz0(f).powi(2))
        } else if r > df + 1.0 {
            let (a0, a1) = TABLE1[row(alpha)][d as usize - 1];
            (a0 - a1 / r) / r
        } else {
            let mp = J_MAX / r;
            basic_sum(J_MAX, J_MAX, mp, f, alpha, d) / (J_MAX * sz0(f).powi(2))
        }
    } else if alpha <= 0 {
        // Case 2: unmodified, white FM and redder.
        if j <= J_MAX {
            let f = if mf * (df + 1.0) <= J_MAX {
                Filter::Finite(mf)
            } else {
                Filter::Infinite
            };
            basic_sum(j, mm, sf, f, alpha, d) / (mm * sz0(f).powi(2))
        } else if r > df + 1.0 {
            let (a0, a1) = TABLE2[row(alpha)][d as usize - 1];
            (a0 - a1 / r) / r
        } else {
            let mp = J_MAX / r;
            let f = Filter::Infinite;
            basic_sum(J_MAX, J_MAX, mp, f, alpha, d) / (J_MAX * sz0(f).powi(2))
        }
    } else if alpha == 1 {
        // Case 3: unmodified, flicker PM (the EDF depends on ln m).
        let (b0, b1) = TABLE3[d as usize - 1];
        if j <= J_MAX {
            let f = Filter::Finite(mf);
            basic_sum(j, mm, sf, f, alpha, d) / (mm * sz0(f).powi(2))
        } else if r > df + 1.0 {
            let (a0, a1) = TABLE2[row(alpha)][d as usize - 1];
            (a0 - a1 / r) / ((b0 + b1 * mf.ln()).powi(2) * r)
        } else {
            let mp = J_MAX / r;
            basic_sum(J_MAX, J_MAX, mp, Filter::Finite(mp), alpha, d)
                / ((b0 + b1 * mf.ln()).powi(2) * J_MAX)
        }
    } else {
        // Case 4: unmodified, white PM: closed forms.
        let k = r.ceil();
        if k <= df {
            let c = binomial(2 * di, di);
            let mut s = 0.0;
            let mut kk = 1u64;
            while (kk as f64) < k {
                s += (1.0 - kk as f64 / r) * binomial(2 * di, di - kk).powi(2);
                kk += 1;
            }
            (1.0 + 2.0 * s / (c * c)) / mm
        } else {
            let a0 = binomial(4 * di, 2 * di) / binomial(2 * di, di).powi(2);
            let a1 = df / 2.0;
            (a0 - a1 / r) / mm
        }
    };
    1.0 / inv
}

/// The simple EDF approximations of NIST SP 1065 table 5 (Stein, Howe, Allan and Barnes) for the
/// overlapping Allan variance, with `n_phase` phase points. For α outside −2..=2 they have no
/// entry, and N − 1 (independent samples) is returned.
pub fn simple_edf(alpha: i8, m: u64, n_phase: u64) -> f64 {
    let n = n_phase as f64;
    let m = m as f64;
    match alpha {
        2 => (n + 1.0) * (n - 2.0 * m) / (2.0 * (n - m)),
        1 => {
            let a = (n - 1.0) / (2.0 * m);
            let b = (2.0 * m + 1.0) * (n - 1.0) / 4.0;
            (a.ln() * b.ln()).sqrt().exp()
        }
        0 => {
            (3.0 * (n - 1.0) / (2.0 * m) - 2.0 * (n - 2.0) / n) * (4.0 * m * m)
                / (4.0 * m * m + 5.0)
        }
        -1 => {
            if m == 1.0 {
                2.0 * (n - 2.0) / (2.3 * n - 4.9)
            } else {
                5.0 * n * n / (4.0 * m * (n + 3.0 * m))
            }
        }
        -2 => {
            (n - 2.0) / (m * (n - 3.0).powi(2))
                * ((n - 1.0).powi(2) - 3.0 * m * (n - 1.0) + 4.0 * m * m)
        }
        _ => n - 1.0,
    }
}

/// The phase filter of the estimator: F = m averages over m samples, F = ∞ is its continuous
/// limit (used where m is large).
#[derive(Debug, Clone, Copy)]
enum Filter {
    Finite(f64),
    Infinite,
}

/// Σ of squared autocovariances of the estimator's terms (the paper's eq. 10).
fn basic_sum(j: f64, big_m: f64, stride: f64, f: Filter, alpha: i8, d: u8) -> f64 {
    let term = |k: f64| sz(k / stride, f, alpha, d).powi(2);
    let mut sum = term(0.0) + (1.0 - j / big_m) * term(j);
    let mut k = 1.0;
    while k < j {
        sum += 2.0 * (1.0 - k / big_m) * term(k);
        k += 1.0;
    }
    sum
}

/// Autocovariance of the d-th difference (eq. 9): Σ_k (−1)^k C(2d, d+k) sx(t + k).
fn sz(t: f64, f: Filter, alpha: i8, d: u8) -> f64 {
    let d = i64::from(d);
    (-d..=d)
        .map(|k| {
            let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
            sign * binomial((2 * d) as u64, (d + k) as u64) * sx(t + k as f64, f, alpha)
        })
        .sum()
}

/// Autocovariance of the filtered phase (eq. 8): F²·(2sw(t) − sw(t − 1/F) − sw(t + 1/F)).
///
/// For large F·|t| this second difference cancels catastrophically (the paper warns of round-off
/// for m > 10⁶), so there it is replaced by its Taylor expansion −sw''(t) − sw''''(t)/(12F²),
/// whose truncation error is below 1e-12 once F·|t| ≥ 1000.
fn sx(t: f64, f: Filter, alpha: i8) -> f64 {
    match f {
        Filter::Infinite => sw(t, alpha + 2),
        Filter::Finite(f) => {
            let h = 1.0 / f;
            if t == 0.0 {
                -2.0 * f * f * sw(h, alpha)
            } else if t.abs() * f >= 1000.0 {
                let (d2, d4) = sw_derivatives(t.abs(), alpha);
                -d2 - h * h * d4 / 12.0
            } else {
                f * f * (2.0 * sw(t, alpha) - sw(t - h, alpha) - sw(t + h, alpha))
            }
        }
    }
}

/// Generalised autocovariance of the continuous-time power-law process (eq. 7), up to sign and
/// scale (both cancel in the EDF).
fn sw(t: f64, alpha: i8) -> f64 {
    let t = t.abs();
    let log_term = |p: i32| if t == 0.0 { 0.0 } else { t.powi(p) * t.ln() };
    match alpha {
        2 => -t,
        1 => log_term(2),
        0 => t.powi(3),
        -1 => log_term(4),
        -2 => t.powi(5),
        -3 => log_term(6),
        -4 => t.powi(7),
        // Only reached through Filter::Infinite with α + 2 ∈ {…}, which stays in range.
        _ => f64::NAN,
    }
}

/// Second and fourth derivatives of `sw` at t > 0.
fn sw_derivatives(t: f64, alpha: i8) -> (f64, f64) {
    let l = t.ln();
    match alpha {
        2 => (0.0, 0.0),
        1 => (2.0 * l + 3.0, -2.0 / (t * t)),
        0 => (6.0 * t, 0.0),
        -1 => (t * t * (12.0 * l + 7.0), 24.0 * l + 50.0),
        -2 => (20.0 * t.powi(3), 120.0 * t),
        -3 => (t.powi(4) * (30.0 * l + 11.0), t * t * (360.0 * l + 342.0)),
        -4 => (42.0 * t.powi(5), 840.0 * t.powi(3)),
        _ => (f64::NAN, f64::NAN),
    }
}

fn binomial(n: u64, k: u64) -> f64 {
    if k > n {
        return 0.0;
    }
    let k = k.min(n - k);
    (0..k).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64)
}

/// Row of tables 1 and 2 for α (α = 2 is row 0, α = −4 row 6).
fn row(alpha: i8) -> usize {
    (2 - alpha) as usize
}

/// Not defined (the estimator does not converge for that α and d).
const NA: (f64, f64) = (f64::NAN, f64::NAN);

/// Table 1 (modified variances): (a0, a1) by α row and d = 1, 2, 3.
const TABLE1: [[(f64, f64); 3]; 7] = [
    [
        (2.0 / 3.0, 1.0 / 3.0),
        (7.0 / 9.0, 0.5),
        (22.0 / 25.0, 2.0 / 3.0),
    ],
    [(0.840, 0.345), (0.997, 0.616), (1.141, 0.843)],
    [(1.079, 0.368), (1.033, 0.607), (1.184, 0.848)],
    [NA, (1.048, 0.534), (1.180, 0.816)],
    [NA, (1.302, 0.535), (1.175, 0.777)],
    [NA, NA, (1.194, 0.703)],
    [NA, NA, (1.489, 0.702)],
];

/// Table 2 (unmodified variances): (a0, a1) by α row and d = 1, 2, 3.
const TABLE2: [[(f64, f64); 3]; 7] = [
    [(1.5, 0.5), (35.0 / 18.0, 1.0), (231.0 / 100.0, 1.5)],
    [(78.6, 25.2), (790.0, 410.0), (9950.0, 6520.0)],
    [
        (2.0 / 3.0, 1.0 / 6.0),
        (2.0 / 3.0, 1.0 / 3.0),
        (7.0 / 9.0, 0.5),
    ],
    [NA, (0.852, 0.375), (0.997, 0.617)],
    [NA, (1.079, 0.368), (1.033, 0.607)],
    [NA, NA, (1.053, 0.553)],
    [NA, NA, (1.302, 0.535)],
];

/// Table 3 (unmodified, flicker PM): (b0, b1) by d = 1, 2, 3.
const TABLE3: [(f64, f64); 3] = [(6.0, 4.0), (15.23, 12.0), (47.8, 40.0)];

#[cfg(test)]
mod tests {
    use super::*;

    /// allantools 2024.06 `ci.edf_greenhall(alpha, d, m, N, overlapping, modified)`.
    const ALLANTOOLS: [(i8, u8, u64, u64, bool, bool, f64); 16] = [
        (0, 2, 1, 1001, true, false, 782.0302990727438),
        (0, 2, 64, 1001, true, false, 21.239474955410227),
        (0, 2, 128, 1001, true, false, 9.5509533314978),
        (-2, 2, 10, 100000, true, false, 9246.447464767803),
        (-1, 2, 1000, 100000, true, false, 115.54240204039894),
        (1, 2, 7, 5000, true, false, 1497.4970204893239),
        (1, 2, 300, 100000, false, false, 176.5181025707808),
        (2, 2, 40, 10000, true, false, 5112.31586238744),
        (2, 2, 30, 10000, false, false, 171.00775728322702),
        (0, 2, 20, 10000, true, true, 481.5847864346314),
        (-2, 2, 1000, 10000, true, true, 5.712386463786474),
        (0, 3, 16, 5000, false, false, 160.60977541250608),
        (-4, 3, 8, 5000, true, false, 476.8795922657021),
        (-3, 3, 100, 50000, true, false, 472.48406619891813),
        (1, 2, 200, 100000, true, false, 3919.3642581589297),
        (-1, 3, 5000, 100000, true, true, 14.172002626626444),
    ];

    #[test]
    fn matches_allantools_greenhall() {
        for (alpha, d, m, n, ov, md, want) in ALLANTOOLS {
            let got = greenhall_edf(alpha, d, m, n, ov, md);
            let rel = (got - want).abs() / want;
            assert!(rel < 1e-9, "α={alpha} d={d} m={m} N={n}: {got} vs {want}");
        }
    }

    #[test]
    fn taylor_form_of_sx_agrees_with_the_difference() {
        for alpha in -4..=2i8 {
            for t in [1.5f64, 3.0, 7.0] {
                let f = 50.0; // small enough for the direct difference to be accurate
                let h = 1.0 / f;
                let direct = f * f * (2.0 * sw(t, alpha) - sw(t - h, alpha) - sw(t + h, alpha));
                let (d2, d4) = sw_derivatives(t, alpha);
                let taylor = -d2 - h * h * d4 / 12.0;
                let scale = direct.abs().max(1e-3);
                assert!((direct - taylor).abs() < 1e-6 * scale, "α={alpha} t={t}");
            }
        }
    }

    #[test]
    fn white_pm_with_few_terms_uses_the_closed_form() {
        // Overlapping ADEV, α = 2, m = 4000 on 10001 phase points: M = 2001 terms, r = M/m ≈ 0.5,
        // K = ⌈r⌉ = 1 ≤ d, so 1/EDF = 1/M (allantools raises NotImplementedError here).
        assert!((greenhall_edf(2, 2, 4000, 10_001, true, false) - 2001.0).abs() < 1e-9);
        // r = 1.5, K = 2: 1/EDF = (1 + 2(1 − 1/r)·C(4,1)²/C(4,2)²)/M.
        let m = 2000;
        let big_m = 3000.0;
        let want = big_m / (1.0 + 2.0 * (1.0 - 1.0 / 1.5) * 16.0 / 36.0);
        assert!((greenhall_edf(2, 2, m, 1 + 2 * m + 2999, true, false) - want).abs() < 1e-9);
    }

    #[test]
    fn flicker_pm_at_huge_m_is_finite_and_positive() {
        // Non-overlapping ADEV, α = 1 at m = 10⁷: the case the paper warns about.
        let e = greenhall_edf(1, 2, 10_000_000, 100_000_001, false, false);
        assert!(e.is_finite() && e > 1.0, "{e}");
    }
}
