//! Modified Allan variance: Σ_j V_j² with V_j = Σ_{i=j}^{j+m−1} D_i, D_i the second difference of S
//! at lag m (an m-average of phase second differences).
//!
//! The inner sum is a moving sum, updated as V_{j+1} = V_j + D_{j+m} − D_j: O(N) per τ instead of
//! O(N·m). A moving sum drifts by one rounding per update, so it is restarted from a direct sum at
//! the start of every chunk of max(65536, 16m) indices (bounding the drift to a few hundred
//! roundings of V, and giving the cores independent tasks), and within a chunk four moving sums
//! over its quarters run interleaved (one alone would wait on the latency of each addition).
//! Chunk boundaries depend on N and m only, and chunk sums are added in order, so the result does
//! not depend on the thread count.

use rayon::prelude::*;

use super::sweep::neumaier;

/// For each m: Σ_{j=0}^{N+1−3m} V_j² (N + 2 − 3m terms, at least one).
pub(crate) fn modified_sums(s: &[f64], ms: &[u64]) -> Vec<f64> {
    let n = s.len() - 1;
    let tasks: Vec<(usize, usize, usize)> = ms
        .iter()
        .enumerate()
        .flat_map(|(t, &m)| {
            let m = m as usize;
            let count = (n + 2).saturating_sub(3 * m);
            let chunk = (16 * m).max(1 << 16);
            (0..count.div_ceil(chunk)).map(move |c| (t, c * chunk, ((c + 1) * chunk).min(count)))
        })
        .collect();
    let partial: Vec<f64> = tasks
        .par_iter()
        .map(|&(t, a, b)| chunk_sum(s, ms[t] as usize, a, b))
        .collect();
    let mut out = vec![0.0f64; ms.len()];
    let mut k = 0;
    for (t, slot) in out.iter_mut().enumerate() {
        let start = k;
        while k < tasks.len() && tasks[k].0 == t {
            k += 1;
        }
        *slot = neumaier(partial[start..k].iter().copied());
    }
    out
}

/// Σ_{j=a}^{b−1} V_j² for lag m, as `PARTS` interleaved moving sums over consecutive parts of the
/// range (each restarted from a direct sum), so that the additions of one do not wait on another.
fn chunk_sum(s: &[f64], m: usize, a: usize, b: usize) -> f64 {
    const PARTS: usize = 4;
    let d = |i: usize| (s[i + 2 * m] - s[i + m]) - (s[i + m] - s[i]);
    let len = b - a;
    let part = len / PARTS;
    if part == 0 {
        return chunk_sum_serial(s, m, a, b);
    }
    let starts: [usize; PARTS] = std::array::from_fn(|k| a + k * part);
    let mut v: [f64; PARTS] = std::array::from_fn(|k| neumaier((starts[k]..starts[k] + m).map(d)));
    let mut acc = [0.0f64; PARTS];
    for t in 0..part {
        for k in 0..PARTS {
            acc[k] += v[k] * v[k];
            if t + 1 < part {
                let j = starts[k] + t;
                v[k] += d(j + m) - d(j);
            }
        }
    }
    let rest = chunk_sum_serial(s, m, a + PARTS * part, b);
    acc.iter().sum::<f64>() + rest
}

/// Σ_{j=a}^{b−1} V_j² for lag m with one moving sum.
fn chunk_sum_serial(s: &[f64], m: usize, a: usize, b: usize) -> f64 {
    if a >= b {
        return 0.0;
    }
    let d = |i: usize| (s[i + 2 * m] - s[i + m]) - (s[i + m] - s[i]);
    let mut v = neumaier((a..a + m).map(d));
    let mut acc = 0.0f64;
    for j in a..b {
        acc += v * v;
        if j + 1 < b {
            v += d(j + m) - d(j);
        }
    }
    acc
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equals_double_sum() {
        let n = 3000usize;
        let mut acc = 0.0;
        let s: Vec<f64> = (0..=n)
            .map(|i| {
                let v = acc;
                acc += ((i * 7919 % 1013) as f64 - 506.0) / 300.0;
                v
            })
            .collect();
        let ms = [1u64, 2, 7, 100, 999, 1000];
        let got = modified_sums(&s, &ms);
        for (&m, g) in ms.iter().zip(&got) {
            let m = m as usize;
            let want: f64 = (0..n + 2 - 3 * m)
                .map(|j| {
                    let v: f64 = (j..j + m)
                        .map(|i| s[i + 2 * m] - 2.0 * s[i + m] + s[i])
                        .sum();
                    v * v
                })
                .sum();
            assert!((g - want).abs() <= 1e-11 * want, "m={m} {g} {want}");
        }
    }
}
