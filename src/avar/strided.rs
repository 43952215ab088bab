//! Non-overlapping estimators (ADEV, HDEV): differences of S at j = 0, m, 2m, ….
//!
//! The decimated series x_i = S_{i·m} is read once, with the previous two or three values kept in
//! registers, so a term costs one (strided) load. The work is ⌊N/m⌋ terms per τ, small next to the
//! overlapping estimators; long τ lists are split into fixed chunks of terms and run on all cores,
//! and the chunk sums are added in order (same result for any thread count).

use rayon::prelude::*;

use super::sweep::{neumaier, Order};

/// Terms per task.
const CHUNK: usize = 1 << 16;

/// For each m in `ms`: Σ_{i=0}^{terms−1} v_i², v_i the `order` difference of x at i, where
/// x_i = S_{i·m} and terms = ⌊N/m⌋ + 1 − span (at least one).
pub(crate) fn strided_sums(s: &[f64], ms: &[u64], order: Order) -> Vec<f64> {
    let n = s.len() - 1;
    let span = match order {
        Order::Second => 2,
        Order::Third => 3,
    };
    let terms = |m: usize| (n / m + 1).saturating_sub(span);
    let tasks: Vec<(usize, usize, usize)> = ms
        .iter()
        .enumerate()
        .flat_map(|(t, &m)| {
            let count = terms(m as usize);
            (0..count.div_ceil(CHUNK)).map(move |c| (t, c * CHUNK, ((c + 1) * CHUNK).min(count)))
        })
        .collect();
    let partial: Vec<f64> = tasks
        .par_iter()
        .map(|&(t, a, b)| {
            let m = ms[t] as usize;
            let x = |i: usize| s[i * m];
            // Four accumulators (term i goes to i mod 4) so the additions do not wait on each
            // other.
            let mut acc = [0.0f64; 4];
            match order {
                Order::Second => {
                    let (mut x0, mut x1) = (x(a), x(a + 1));
                    for i in a..b {
                        let x2 = x(i + 2);
                        let v = (x2 - x1) - (x1 - x0);
                        acc[i % 4] += v * v;
                        (x0, x1) = (x1, x2);
                    }
                }
                Order::Third => {
                    let (mut x0, mut x1, mut x2) = (x(a), x(a + 1), x(a + 2));
                    for i in a..b {
                        let x3 = x(i + 3);
                        let (f0, f1, f2) = (x1 - x0, x2 - x1, x3 - x2);
                        let v = (f2 - f1) - (f1 - f0);
                        acc[i % 4] += v * v;
                        (x0, x1, x2) = (x1, x2, x3);
                    }
                }
            }
            acc.iter().sum::<f64>()
        })
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equals_direct_sums() {
        let n = 200_000usize;
        let mut acc = 0.0;
        let s: Vec<f64> = (0..=n)
            .map(|i| {
                let v = acc;
                acc += ((i * 7919 % 1013) as f64 - 506.0) / 300.0;
                v
            })
            .collect();
        let ms = [1u64, 2, 3, 10, 999, 50_000];
        for (order, span) in [(Order::Second, 2usize), (Order::Third, 3)] {
            let got = strided_sums(&s, &ms, order);
            for (&m, g) in ms.iter().zip(&got) {
                let m = m as usize;
                let want: f64 = (0..n / m + 1 - span)
                    .map(|i| {
                        let x = |k: usize| s[(i + k) * m];
                        let v = if span == 2 {
                            x(2) - 2.0 * x(1) + x(0)
                        } else {
                            x(3) - 3.0 * x(2) + 3.0 * x(1) - x(0)
                        };
                        v * v
                    })
                    .sum();
                assert!((g - want).abs() <= 1e-11 * want, "m={m} {g} {want}");
            }
        }
    }
}
