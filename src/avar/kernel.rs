//! Inner loops: sums of squared second and third differences of S over contiguous ranges.
//!
//! These two loops are where the time goes, so they are written for the vectoriser: 16 independent
//! accumulators (four AVX2 registers, enough to hide the add latency) over `chunks_exact`, which
//! lets the compiler drop bounds checks. On x86-64 the same source is also compiled with AVX2
//! enabled and chosen at run time; both versions perform the same operations in the same order, so
//! their results are bit-identical and the output does not depend on the CPU.
//!
//! The differences are formed as (S₂ − S₁) − (S₁ − S₀): neighbouring values of S are close, so each
//! inner difference is exact (Sterbenz) and the only rounding is that of the small final result,
//! whereas S₂ − 2S₁ + S₀ would round at the magnitude of S.

const LANES: usize = 16;

macro_rules! second_diff_body {
    ($s0:expr, $s1:expr, $s2:expr) => {{
        let (s0, s1, s2): (&[f64], &[f64], &[f64]) = ($s0, $s1, $s2);
        let len = s0.len();
        let (s1, s2) = (&s1[..len], &s2[..len]);
        let mut acc = [0.0f64; LANES];
        for ((a, b), c) in s0
            .chunks_exact(LANES)
            .zip(s1.chunks_exact(LANES))
            .zip(s2.chunks_exact(LANES))
        {
            for l in 0..LANES {
                let v = (c[l] - b[l]) - (b[l] - a[l]);
                acc[l] += v * v;
            }
        }
        let done = len - len % LANES;
        let mut tail = 0.0f64;
        for k in done..len {
            let v = (s2[k] - s1[k]) - (s1[k] - s0[k]);
            tail += v * v;
        }
        reduce(&acc) + tail
    }};
}

macro_rules! third_diff_body {
    ($s0:expr, $s1:expr, $s2:expr, $s3:expr) => {{
        let (s0, s1, s2, s3): (&[f64], &[f64], &[f64], &[f64]) = ($s0, $s1, $s2, $s3);
        let len = s0.len();
        let (s1, s2, s3) = (&s1[..len], &s2[..len], &s3[..len]);
        let mut acc = [0.0f64; LANES];
        for (((a, b), c), d) in s0
            .chunks_exact(LANES)
            .zip(s1.chunks_exact(LANES))
            .zip(s2.chunks_exact(LANES))
            .zip(s3.chunks_exact(LANES))
        {
            for l in 0..LANES {
                let (f0, f1, f2) = (b[l] - a[l], c[l] - b[l], d[l] - c[l]);
                let v = (f2 - f1) - (f1 - f0);
                acc[l] += v * v;
            }
        }
        let done = len - len % LANES;
        let mut tail = 0.0f64;
        for k in done..len {
            let (f0, f1, f2) = (s1[k] - s0[k], s2[k] - s1[k], s3[k] - s2[k]);
            let v = (f2 - f1) - (f1 - f0);
            tail += v * v;
        }
        reduce(&acc) + tail
    }};
}

/// Pairwise reduction of the lanes, in a fixed order.
#[inline(always)]
fn reduce(acc: &[f64; LANES]) -> f64 {
    let mut v = *acc;
    let mut width = LANES;
    while width > 1 {
        width /= 2;
        for l in 0..width {
            v[l] += v[l + width];
        }
    }
    v[0]
}

fn second_portable(s0: &[f64], s1: &[f64], s2: &[f64]) -> f64 {
    second_diff_body!(s0, s1, s2)
}

fn third_portable(s0: &[f64], s1: &[f64], s2: &[f64], s3: &[f64]) -> f64 {
    third_diff_body!(s0, s1, s2, s3)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn second_avx2(s0: &[f64], s1: &[f64], s2: &[f64]) -> f64 {
    second_diff_body!(s0, s1, s2)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn third_avx2(s0: &[f64], s1: &[f64], s2: &[f64], s3: &[f64]) -> f64 {
    third_diff_body!(s0, s1, s2, s3)
}

#[cfg(target_arch = "x86_64")]
fn has_avx2() -> bool {
    std::arch::is_x86_feature_detected!("avx2")
}

/// Σ_k ((s2[k] − s1[k]) − (s1[k] − s0[k]))² over k < s0.len().
///
/// # Panics
/// If `s1` or `s2` is shorter than `s0`.
pub(crate) fn sum_sq_second(s0: &[f64], s1: &[f64], s2: &[f64]) -> f64 {
    assert!(s1.len() >= s0.len() && s2.len() >= s0.len());
    #[cfg(target_arch = "x86_64")]
    if has_avx2() {
        // SAFETY: the CPU supports AVX2 (checked above); the function is otherwise safe Rust.
        return unsafe { second_avx2(s0, s1, s2) };
    }
    second_portable(s0, s1, s2)
}

/// Σ_k (third difference of s0[k], s1[k], s2[k], s3[k])² over k < s0.len().
///
/// # Panics
/// If `s1`, `s2` or `s3` is shorter than `s0`.
pub(crate) fn sum_sq_third(s0: &[f64], s1: &[f64], s2: &[f64], s3: &[f64]) -> f64 {
    assert!(s1.len() >= s0.len() && s2.len() >= s0.len() && s3.len() >= s0.len());
    #[cfg(target_arch = "x86_64")]
    if has_avx2() {
        // SAFETY: the CPU supports AVX2 (checked above); the function is otherwise safe Rust.
        return unsafe { third_avx2(s0, s1, s2, s3) };
    }
    third_portable(s0, s1, s2, s3)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn data(n: usize) -> Vec<f64> {
        (0..n)
            .map(|i| ((i * 37 % 101) as f64).sqrt() + i as f64)
            .collect()
    }

    #[test]
    fn matches_plain_loops() {
        let s = data(1000);
        for len in [0, 1, 15, 16, 17, 100, 333] {
            let (a, b, c, d) = (&s[..len], &s[7..], &s[14..], &s[21..]);
            let want2: f64 = (0..len).map(|k| (c[k] - 2.0 * b[k] + a[k]).powi(2)).sum();
            let want3: f64 = (0..len)
                .map(|k| (d[k] - 3.0 * c[k] + 3.0 * b[k] - a[k]).powi(2))
                .sum();
            let got2 = sum_sq_second(a, b, c);
            let got3 = sum_sq_third(a, b, c, d);
            assert!((got2 - want2).abs() <= 1e-12 * want2.max(1.0), "{len}");
            assert!((got3 - want3).abs() <= 1e-12 * want3.max(1.0), "{len}");
        }
    }

    #[test]
    fn dispatch_is_bit_identical_to_portable() {
        let s = data(5000);
        for len in [3, 64, 999, 4000] {
            let (a, b, c, d) = (&s[..len], &s[5..], &s[300..], &s[900..]);
            assert_eq!(
                sum_sq_second(a, b, c).to_bits(),
                second_portable(a, b, c).to_bits()
            );
            assert_eq!(
                sum_sq_third(a, b, c, d).to_bits(),
                third_portable(a, b, c, d).to_bits()
            );
        }
    }
}
