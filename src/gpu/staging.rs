//! Host-side preparation of uploads: f64 samples, less a reference, to f32, on every core.
//!
//! On a real GPU the kernels take a small part of a call's time (an H200 ran the Welch kernels of
//! 6 × 2·10⁷ samples in 10 ms of a 540 ms call); the rest was this conversion and the sums before
//! it, done by one thread while the CPU path used all of them. Both are split into fixed blocks,
//! so the work spreads over rayon's threads while every result stays bit-identical from run to
//! run: block sums are added in block order, never in the order threads finish.

use rayon::prelude::*;

/// Samples per block: large enough to amortise a task, small enough to spread a batch.
const BLOCK: usize = 1 << 16;

/// Σ of `a ++ b`, in f64: each block's sum sequentially, then the block sums in order.
pub(crate) fn sum(a: &[f64], b: &[f64]) -> f64 {
    let blocks: Vec<f64> = a
        .par_chunks(BLOCK)
        .chain(b.par_chunks(BLOCK))
        .map(|c| c.iter().sum::<f64>())
        .collect();
    blocks.iter().sum()
}

/// Writes `(v − reference) as f32` of every `v` of `a ++ b` into `out` (of their total length).
pub(crate) fn convert_into(out: &mut [f32], a: &[f64], b: &[f64], reference: f64) {
    debug_assert_eq!(out.len(), a.len() + b.len());
    let (head, tail) = out.split_at_mut(a.len());
    let convert = |dst: &mut [f32], src: &[f64]| {
        for (d, &v) in dst.iter_mut().zip(src) {
            *d = (v - reference) as f32;
        }
    };
    head.par_chunks_mut(BLOCK)
        .zip(a.par_chunks(BLOCK))
        .chain(tail.par_chunks_mut(BLOCK).zip(b.par_chunks(BLOCK)))
        .for_each(|(dst, src)| convert(dst, src));
}

/// `(v − reference) as f32` of every `v` of `y`.
pub(crate) fn converted(y: &[f64], reference: f64) -> Vec<f32> {
    let mut out = vec![0.0f32; y.len()];
    convert_into(&mut out, y, &[], reference);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_give_the_sequential_conversion_and_a_run_independent_sum() {
        let a: Vec<f64> = (0..150_001)
            .map(|i| 1e4 + (i as f64 * 0.37).sin())
            .collect();
        let b: Vec<f64> = (0..70_003).map(|i| 1e4 + (i as f64 * 0.11).cos()).collect();
        let all: Vec<f64> = a.iter().chain(&b).copied().collect();
        let total = sum(&a, &b);
        let naive: f64 = all.iter().sum();
        assert!(
            (total - naive).abs() <= 1e-12 * naive.abs(),
            "{total} vs {naive}"
        );
        for _ in 0..5 {
            assert_eq!(
                sum(&a, &b).to_bits(),
                total.to_bits(),
                "same bits every run"
            );
        }
        let reference = total / all.len() as f64;
        let mut out = vec![0.0f32; all.len()];
        convert_into(&mut out, &a, &b, reference);
        let expected: Vec<f32> = all.iter().map(|&v| (v - reference) as f32).collect();
        assert_eq!(out, expected);
        assert_eq!(converted(&all, reference), expected);
        // Either part may be empty.
        let mut only_b = vec![0.0f32; b.len()];
        convert_into(&mut only_b, &[], &b, 1.0);
        assert_eq!(
            only_b,
            b.iter().map(|&v| (v - 1.0) as f32).collect::<Vec<_>>()
        );
    }
}
