//! Host-side preparation of uploads: f64 samples, less a reference, to f32, written on every core
//! straight into the queue's staging memory (no host copy first).
//!
//! On a real GPU the kernels take a small part of a call's time. An H200 (16-core host) ran the
//! Welch kernels of 6 × 2·10⁷ samples (nperseg 4096) in 10 ms of a 540 ms call when one thread
//! converted the samples into a host f32 buffer that `write_buffer` then copied; converting on
//! every core took the call to 264 ms, and converting straight into the queue's staging memory
//! (this module) to 64 ms, against 74 ms for the CPU path on all 16 cores
//! (`examples/gpu_throughput.rs`, `benches/results/`). Work is split into fixed blocks, so every
//! result stays bit-identical from run to run: block sums are added in block order, never in the
//! order threads finish.

use rayon::prelude::*;
use wgpu::WriteOnly;

/// A block of staging memory, sent to a worker thread.
struct Block<'a, T>(WriteOnly<'a, [T]>);

// SAFETY: `WriteOnly<'a, [T]>` is a unique pointer to its elements, as `&'a mut [T]` is, which is
// Send when T is. wgpu-types 30 declares Send only for sized targets (its impl lacks `?Sized`; its
// Sync impl covers slices). Blocks come from `split_at`, so no two overlap.
unsafe impl<T: Send> Send for Block<'_, T> {}

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

/// Pairs `dst` with `src` (of its length) block by block, `block` elements each (the last
/// shorter), appending the pairs to `out`: the units of work spread over the cores.
fn pair_blocks<'a, 's, T, S>(
    mut dst: WriteOnly<'a, [T]>,
    mut src: &'s [S],
    block: usize,
    out: &mut Vec<(Block<'a, T>, &'s [S])>,
) {
    debug_assert_eq!(dst.len(), src.len());
    while !src.is_empty() {
        let take = src.len().min(block);
        let (head, tail) = dst.split_at(take);
        out.push((Block(head), &src[..take]));
        (dst, src) = (tail, &src[take..]);
    }
}

/// Writes `(v − reference) as f32` of every `v` of `a ++ b` into `dst` (device staging memory of
/// 4 bytes per value), block by block on every core.
pub(crate) fn fill_converted(dst: WriteOnly<'_, [u8]>, a: &[f64], b: &[f64], reference: f64) {
    let (words, rest) = dst.into_chunks::<4>();
    debug_assert_eq!(rest.len(), 0);
    let (wa, wb) = words.split_at(a.len());
    let mut blocks = Vec::with_capacity((a.len() + b.len()) / BLOCK + 2);
    pair_blocks(wa, a, BLOCK, &mut blocks);
    pair_blocks(wb, b, BLOCK, &mut blocks);
    blocks.into_par_iter().for_each(|(Block(dst), src)| {
        dst.write_iter(src.iter().map(|&v| ((v - reference) as f32).to_ne_bytes()));
    });
}

/// Copies `src` into `dst` (device staging memory of its size), block by block on every core.
pub(crate) fn fill_copy<T: bytemuck::Pod>(dst: WriteOnly<'_, [u8]>, src: &[T]) {
    let bytes: &[u8] = bytemuck::cast_slice(src);
    let mut blocks = Vec::with_capacity(bytes.len() / (8 * BLOCK) + 1);
    pair_blocks(dst, bytes, 8 * BLOCK, &mut blocks);
    blocks
        .into_par_iter()
        .for_each(|(Block(mut dst), src)| dst.copy_from_slice(src));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_give_the_sequential_conversion_and_copy_and_a_run_independent_sum() {
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
        let expected: Vec<f32> = all.iter().map(|&v| (v - reference) as f32).collect();
        let mut bytes = vec![0u8; 4 * all.len()];
        fill_converted(WriteOnly::from_mut(bytes.as_mut_slice()), &a, &b, reference);
        assert_eq!(bytes, bytemuck::cast_slice::<f32, u8>(&expected));
        let mut copied = vec![0u8; 8 * all.len()];
        fill_copy(WriteOnly::from_mut(copied.as_mut_slice()), &all);
        assert_eq!(copied, bytemuck::cast_slice::<f64, u8>(&all));
        // Either part may be empty.
        let mut only_b = vec![0u8; 4 * b.len()];
        fill_converted(WriteOnly::from_mut(only_b.as_mut_slice()), &[], &b, 1.0);
        let expected: Vec<f32> = b.iter().map(|&v| (v - 1.0) as f32).collect();
        assert_eq!(only_b, bytemuck::cast_slice::<f32, u8>(&expected));
    }
}
