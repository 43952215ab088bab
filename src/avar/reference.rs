//! Brute-force reference estimators, written straight from the textbook formulas (NIST SP 1065,
//! section 5.2) for clarity, not speed: one plain loop per τ, plain f64 sums, no blocking, no
//! threads, no tricks. The fast paths and the GPU backend are tested against these.
//!
//! Each takes rate samples `y` (τ₀ = 1; the variances do not depend on τ₀) and an averaging factor
//! `m`, and returns the variance, or NaN when the data do not hold a single term. Where the
//! textbook has two forms, the one least like the fast path is used, so that a shared mistake is
//! unlikely: ADEV and HDEV from block averages of y, the overlapping ones from phase x = Σ (y − ȳ).
//! Costs: O(N) per τ, except MDEV's double sum, O(N·m).

use super::Statistic;

/// The variance of `stat` at averaging factor `m` (see the module docs).
pub fn variance(y: &[f64], m: u64, stat: Statistic) -> f64 {
    let m = m as usize;
    if m == 0 {
        return f64::NAN;
    }
    match stat {
        Statistic::Oadev => oadev(y, m),
        Statistic::Adev => adev(y, m),
        Statistic::Mdev => mdev(y, m),
        Statistic::Hdev => hdev(y, m),
        Statistic::Ohdev => ohdev(y, m),
    }
}

/// Phase x_0 = 0, x_{k+1} = x_k + (y_k − ȳ): the time integral of the mean-removed rate (τ₀ = 1).
pub fn phase(y: &[f64]) -> Vec<f64> {
    let mean = y.iter().sum::<f64>() / y.len() as f64;
    let mut x = Vec::with_capacity(y.len() + 1);
    let mut acc = 0.0;
    x.push(acc);
    for v in y {
        acc += v - mean;
        x.push(acc);
    }
    x
}

/// Averages of y over consecutive, non-overlapping blocks of m samples (a partial last block is
/// dropped).
pub fn block_averages(y: &[f64], m: usize) -> Vec<f64> {
    y.chunks_exact(m)
        .map(|block| block.iter().sum::<f64>() / m as f64)
        .collect()
}

/// Overlapping Allan variance: 1/(2m²(N − 2m + 1)) Σ_{j=0}^{N−2m} (x_{j+2m} − 2x_{j+m} + x_j)².
pub fn oadev(y: &[f64], m: usize) -> f64 {
    let x = phase(y);
    let n = y.len();
    if n < 2 * m {
        return f64::NAN;
    }
    let terms = n - 2 * m + 1;
    let mut sum = 0.0;
    for j in 0..terms {
        let v = x[j + 2 * m] - 2.0 * x[j + m] + x[j];
        sum += v * v;
    }
    sum / (2.0 * (m * m) as f64 * terms as f64)
}

/// Allan variance from non-overlapping τ-averages ȳ_k: 1/(2(K − 1)) Σ (ȳ_{k+1} − ȳ_k)².
pub fn adev(y: &[f64], m: usize) -> f64 {
    let avg = block_averages(y, m);
    if avg.len() < 2 {
        return f64::NAN;
    }
    let mut sum = 0.0;
    for k in 0..avg.len() - 1 {
        let v = avg[k + 1] - avg[k];
        sum += v * v;
    }
    sum / (2.0 * (avg.len() - 1) as f64)
}

/// Modified Allan variance: 1/(2m⁴(N − 3m + 2)) Σ_j [Σ_{i=j}^{j+m−1} (x_{i+2m} − 2x_{i+m} + x_i)]².
pub fn mdev(y: &[f64], m: usize) -> f64 {
    let x = phase(y);
    let n = y.len();
    if n + 2 < 3 * m + 1 {
        return f64::NAN;
    }
    let terms = n + 2 - 3 * m;
    let mut sum = 0.0;
    for j in 0..terms {
        let mut inner = 0.0;
        for i in j..j + m {
            inner += x[i + 2 * m] - 2.0 * x[i + m] + x[i];
        }
        sum += inner * inner;
    }
    sum / (2.0 * (m as f64).powi(4) * terms as f64)
}

/// Hadamard variance from non-overlapping τ-averages: 1/(6(K − 2)) Σ (ȳ_{k+2} − 2ȳ_{k+1} + ȳ_k)².
pub fn hdev(y: &[f64], m: usize) -> f64 {
    let avg = block_averages(y, m);
    if avg.len() < 3 {
        return f64::NAN;
    }
    let mut sum = 0.0;
    for k in 0..avg.len() - 2 {
        let v = avg[k + 2] - 2.0 * avg[k + 1] + avg[k];
        sum += v * v;
    }
    sum / (6.0 * (avg.len() - 2) as f64)
}

/// Overlapping Hadamard variance:
/// 1/(6m²(N − 3m + 1)) Σ_{j=0}^{N−3m} (x_{j+3m} − 3x_{j+2m} + 3x_{j+m} − x_j)².
pub fn ohdev(y: &[f64], m: usize) -> f64 {
    let x = phase(y);
    let n = y.len();
    if n < 3 * m {
        return f64::NAN;
    }
    let terms = n - 3 * m + 1;
    let mut sum = 0.0;
    for j in 0..terms {
        let v = x[j + 3 * m] - 3.0 * x[j + 2 * m] + 3.0 * x[j + m] - x[j];
        sum += v * v;
    }
    sum / (6.0 * (m * m) as f64 * terms as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn textbook_identities() {
        // At m = 1 every Allan estimator is the same number, and so are the Hadamard ones.
        let y: Vec<f64> = (0..50).map(|i| ((i * 17 % 23) as f64).sin()).collect();
        let a = adev(&y, 1);
        assert!((oadev(&y, 1) - a).abs() < 1e-14 * a);
        assert!((mdev(&y, 1) - a).abs() < 1e-14 * a);
        let h = hdev(&y, 1);
        assert!((ohdev(&y, 1) - h).abs() < 1e-14 * h);
        // A linear rate ramp has zero Hadamard variance.
        let ramp: Vec<f64> = (0..60).map(|i| 3.0 + 0.25 * i as f64).collect();
        assert!(hdev(&ramp, 4).abs() < 1e-20 && ohdev(&ramp, 4).abs() < 1e-20);
        assert!(oadev(&y, 30).is_nan() && adev(&y, 30).is_nan());
    }
}
