//! Overlapping estimators (OADEV, OHDEV): Σ_j v_j² for every start index j and many taus at once.
//!
//! The naive loop (for each τ, stream the whole of S three times) reads 24 bytes per sample per τ
//! from memory; on a ten-million-sample recording and a hundred taus that is 24 GB, seconds of pure
//! memory traffic. This sweep reads S once per block of start indices instead:
//!
//! - j runs in blocks of up to 32768; for each block every τ is evaluated while the block is hot.
//!   For small m, S_{j+m} and S_{j+2m} fall in the same few hundred kilobytes as S_j and come from
//!   L1/L2; for large m they come from their own windows.
//! - Octave taus are evaluated in chains (m, 2m, 4m, 8m) by one kernel that loads each window once
//!   (S_{j+2m} for m is S_{j+m'} for m' = 2m), see [`kernel`](super::kernel).
//! - Both cores work on neighbouring blocks (a round of eight at a time), so the windows one core
//!   pulls into the shared L3 are still there when the other needs them.
//! - Each block's partial sums are stored, then added in block order: the result does not depend
//!   on the number of threads or on scheduling.

use rayon::prelude::*;

use super::kernel::{chain_second, third, MAX_CHAIN};

/// Taus evaluated per sweep (bounds the partial-sum table at blocks × taus).
const TAU_GROUP: usize = 256;
/// Blocks handed to the thread pool at a time.
const ROUND: usize = 8;

/// Finite-difference order of an overlapping estimator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Order {
    /// (S_{j+2m} − S_{j+m}) − (S_{j+m} − S_j): Allan.
    Second,
    /// Third difference S_{j+3m} − 3S_{j+2m} + 3S_{j+m} − S_j: Hadamard.
    Third,
}

impl Order {
    fn span(self) -> usize {
        match self {
            Order::Second => 2,
            Order::Third => 3,
        }
    }
}

/// Block length of the sweep for N samples: long enough to amortise per-block work, short enough
/// to give both cores several blocks. Depends on N only, so results do not depend on the thread
/// count.
fn block_len(n: usize) -> usize {
    (n / 16).next_power_of_two().clamp(1024, 32768)
}

/// Splits sorted factors into doubling chains (m, 2m, 4m, … up to `MAX_CHAIN` long) for the
/// second-difference kernel; indices into `ms`. Third differences are not chained.
fn chains(ms: &[u64], order: Order) -> Vec<Vec<usize>> {
    let mut out: Vec<Vec<usize>> = Vec::new();
    for (i, &m) in ms.iter().enumerate() {
        match out.last_mut() {
            Some(chain)
                if order == Order::Second
                    && chain.len() < MAX_CHAIN
                    && ms[*chain.last().unwrap()] * 2 == m =>
            {
                chain.push(i)
            }
            _ => out.push(vec![i]),
        }
    }
    out
}

/// For each m in `ms` (sorted ascending): Σ_{j=0}^{N − span·m} v_j², v_j the `order` difference
/// of S at lag m. Every m must leave at least one term (span·m ≤ N).
pub(crate) fn overlapping_sums(s: &[f64], ms: &[u64], order: Order) -> Vec<f64> {
    let n = s.len() - 1;
    let span = order.span();
    let terms = |m: u64| (n + 1).saturating_sub(span * m as usize);
    let b = block_len(n);
    let mut out = Vec::with_capacity(ms.len());
    for group in ms.chunks(TAU_GROUP) {
        let most = group.iter().map(|&m| terms(m)).max().unwrap_or(0);
        let blocks = most.div_ceil(b);
        let g = group.len();
        let plan = chains(group, order);
        let mut partial = vec![0.0f64; blocks * g];
        for (r, table) in partial.chunks_mut(ROUND * g).enumerate() {
            table.par_chunks_mut(g).enumerate().for_each(|(k, row)| {
                let j0 = (r * ROUND + k) * b;
                for chain in &plan {
                    block_chain(s, j0, b, group, chain, order, &terms, row);
                }
            });
        }
        for t in 0..g {
            out.push(neumaier((0..blocks).map(|k| partial[k * g + t])));
        }
    }
    out
}

/// The terms of one chain of taus for start indices j0..j0 + b. Taus whose terms cover the whole
/// block go through the chain kernel together; a τ whose last terms end inside the block is done
/// alone (once per τ), so every τ sees the same lane layout and gives the same bits however the
/// factors are grouped.
#[allow(clippy::too_many_arguments)]
fn block_chain(
    s: &[f64],
    j0: usize,
    b: usize,
    ms: &[u64],
    chain: &[usize],
    order: Order,
    terms: &impl Fn(u64) -> usize,
    row: &mut [f64],
) {
    let full = chain
        .iter()
        .take_while(|&&t| terms(ms[t]) >= j0 + b)
        .count();
    if full > 0 {
        let m = ms[chain[0]] as usize;
        let mut streams: [&[f64]; MAX_CHAIN + 2] = [&[]; MAX_CHAIN + 2];
        streams[0] = &s[j0..];
        for (c, slot) in streams[1..full + 2].iter_mut().enumerate() {
            *slot = &s[j0 + (m << c)..];
        }
        match order {
            Order::Second => {
                let mut sums = [0.0f64; MAX_CHAIN];
                chain_second(b, &streams[..full + 2], &mut sums);
                for (c, &t) in chain[..full].iter().enumerate() {
                    row[t] = sums[c];
                }
            }
            Order::Third => row[chain[0]] = third_block(s, j0, b, m),
        }
    }
    for &t in &chain[full..] {
        let end = terms(ms[t]);
        if end <= j0 {
            continue;
        }
        let m = ms[t] as usize;
        let len = end - j0;
        row[t] = match order {
            Order::Second => {
                let mut one = [0.0f64; 1];
                chain_second(len, &[&s[j0..], &s[j0 + m..], &s[j0 + 2 * m..]], &mut one);
                one[0]
            }
            Order::Third => third_block(s, j0, len, m),
        };
    }
}

fn third_block(s: &[f64], j0: usize, len: usize, m: usize) -> f64 {
    third(
        len,
        &[&s[j0..], &s[j0 + m..], &s[j0 + 2 * m..], &s[j0 + 3 * m..]],
    )
}

/// Compensated (Neumaier) sum, in iteration order.
pub(crate) fn neumaier(values: impl Iterator<Item = f64>) -> f64 {
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

#[cfg(test)]
mod tests {
    use super::*;

    fn direct(s: &[f64], m: usize, order: Order) -> f64 {
        let n = s.len() - 1;
        let span = order.span();
        (0..=n - span * m)
            .map(|j| {
                let v = match order {
                    Order::Second => s[j + 2 * m] - 2.0 * s[j + m] + s[j],
                    Order::Third => s[j + 3 * m] - 3.0 * s[j + 2 * m] + 3.0 * s[j + m] - s[j],
                };
                v * v
            })
            .sum()
    }

    #[test]
    fn equals_direct_sums_across_blocks_and_groups() {
        let n = 50_000;
        let mut acc = 0.0;
        let s: Vec<f64> = (0..=n)
            .map(|i| {
                let v = acc;
                acc += ((i * 7919 % 1013) as f64 - 506.0) / 300.0;
                v
            })
            .collect();
        // More taus than one group, several blocks, taus longer than a block.
        let ms: Vec<u64> = (1..=300u64)
            .map(|k| k * 55)
            .filter(|&m| 3 * m <= n as u64)
            .collect();
        for order in [Order::Second, Order::Third] {
            let got = overlapping_sums(&s, &ms, order);
            for (&m, g) in ms.iter().zip(&got) {
                let want = direct(&s, m as usize, order);
                assert!((g - want).abs() <= 1e-11 * want, "m={m} {g} {want}");
            }
        }
    }

    #[test]
    fn neumaier_keeps_small_terms() {
        let v = [1e16, 1.0, -1e16, 1.0];
        assert_eq!(neumaier(v.into_iter()), 2.0);
    }
}

#[cfg(test)]
mod scratch {
    use super::*;
    use std::time::Instant;
    #[test]
    #[ignore]
    fn sweep_speed() {
        let n = 10_000_000usize;
        let s: Vec<f64> = (0..=n).map(|i| (i as f64).sqrt()).collect();
        let max = ((n - 1) / 2) as f64;
        let mut pts = 100;
        let ms = loop {
            let mut v: Vec<u64> = (0..pts)
                .map(|i| max.powf(i as f64 / (pts - 1) as f64).round() as u64)
                .collect();
            v.dedup();
            if v.len() >= 100 {
                v.truncate(99);
                v.push(max as u64);
                break v;
            }
            pts += 1;
        };
        for _ in 0..2 {
            let t = Instant::now();
            let r = overlapping_sums(&s, &ms, Order::Second);
            eprintln!("log100 sweep {:?}", t.elapsed());
            for (lo, hi) in [(0u32, 12u32), (12, 16), (16, 19), (19, 21), (21, 23)] {
                let set: Vec<u64> = ms
                    .iter()
                    .cloned()
                    .filter(|&m| m >= 1 << lo && m < 1 << hi)
                    .collect();
                let t = Instant::now();
                let r2 = overlapping_sums(&s, &set, Order::Second);
                let terms: usize = set.iter().map(|&m| n + 1 - 2 * m as usize).sum();
                eprintln!(
                    "  [{lo},{hi}) {} taus {:?} {:.2} Gt/s",
                    set.len(),
                    t.elapsed(),
                    terms as f64 / t.elapsed().as_secs_f64() / 1e9
                );
                std::hint::black_box(r2);
            }
            std::hint::black_box(r);
        }
    }
}
