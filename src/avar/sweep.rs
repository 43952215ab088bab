//! Overlapping estimators (OADEV, OHDEV): Σ_j v_j² for every start index j and many taus at once.
//!
//! The naive loop (for each τ, stream the whole of S three times) reads 24 bytes per sample per τ
//! from memory; on a ten-million-sample recording and a hundred taus that is 24 GB, seconds of pure
//! memory traffic. This sweep reads S once per block of start indices instead:
//!
//! - j runs in blocks of up to 32768; for each block every τ is evaluated while the block is hot.
//!   For small m, S_{j+m} and S_{j+2m} fall in the same few hundred kilobytes as S_j and come from
//!   L1/L2; for large m they come from their own windows (the base window is shared by every τ).
//! - Taus are evaluated four at a time by one kernel that loads S_j once for all of them; octave
//!   taus in chains (m, 2m, 4m, 8m) that also load each window once (S_{j+2m} for m is S_{j+m'}
//!   for m' = 2m), see `kernel.rs`.
//! - Both cores work on neighbouring blocks (a round of eight at a time), so the windows one core
//!   pulls into the shared L3 are still there when the other needs them.
//! - Each block's partial sums are stored, then added in block order: the result does not depend
//!   on the number of threads or on scheduling.

use rayon::prelude::*;

use super::kernel::{group_second, third, Layout, MAX_GROUP};

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

/// Block length of the sweep for N samples: long enough to amortise per-block work and give the
/// hardware prefetcher long streams, short enough to give both cores many blocks. Depends on N
/// only, so results do not depend on the thread count.
fn block_len(n: usize) -> usize {
    (n / 16).next_power_of_two().clamp(1024, 32768)
}

/// Taus evaluated by one kernel call: indices into the factor list, and how their streams are
/// laid out.
struct Group {
    taus: Vec<usize>,
    layout: Layout,
}

/// Groups sorted factors for the second-difference kernel: doubling chains (m, 2m, 4m, … up to
/// `MAX_GROUP` long) first, then runs of the remaining consecutive factors (up to `MAX_GROUP`),
/// which share only S_j. Third differences are done one τ at a time.
fn groups(ms: &[u64], order: Order) -> Vec<Group> {
    if order == Order::Third {
        return (0..ms.len())
            .map(|t| Group {
                taus: vec![t],
                layout: Layout::Chain,
            })
            .collect();
    }
    let mut chains: Vec<Vec<usize>> = Vec::new();
    for (i, &m) in ms.iter().enumerate() {
        match chains.last_mut() {
            Some(chain) if chain.len() < MAX_GROUP && ms[*chain.last().unwrap()] * 2 == m => {
                chain.push(i)
            }
            _ => chains.push(vec![i]),
        }
    }
    let mut out: Vec<Group> = Vec::new();
    let mut singles: Vec<usize> = Vec::new();
    for chain in chains {
        if chain.len() > 1 {
            out.push(Group {
                taus: chain,
                layout: Layout::Chain,
            });
        } else {
            singles.extend(chain);
        }
    }
    for run in singles.chunks(MAX_GROUP) {
        out.push(Group {
            taus: run.to_vec(),
            layout: Layout::Pairs,
        });
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
        let plan = groups(group, order);
        let mut partial = vec![0.0f64; blocks * g];
        for (r, table) in partial.chunks_mut(ROUND * g).enumerate() {
            table.par_chunks_mut(g).enumerate().for_each(|(k, row)| {
                let j0 = (r * ROUND + k) * b;
                for grp in &plan {
                    range_group(s, j0, b, group, grp, order, &terms, row);
                }
            });
        }
        for t in 0..g {
            out.push(neumaier((0..blocks).map(|k| partial[k * g + t])));
        }
    }
    out
}

/// Adds the terms of one group of taus for start indices a..a + len (cut at each τ's last term)
/// to `row`. Taus whose terms cover the whole range go through the kernel together (they are a
/// prefix of the group: later factors are longer and end earlier); a τ whose last terms end
/// inside the range is done alone.
#[allow(clippy::too_many_arguments)]
fn range_group(
    s: &[f64],
    a: usize,
    len: usize,
    ms: &[u64],
    group: &Group,
    order: Order,
    terms: &impl Fn(u64) -> usize,
    row: &mut [f64],
) {
    let taus = &group.taus;
    let full = taus
        .iter()
        .take_while(|&&t| terms(ms[t]) >= a + len)
        .count();
    if full > 0 {
        match order {
            Order::Second => {
                let mut streams: [&[f64]; 2 * MAX_GROUP + 1] = [&[]; 2 * MAX_GROUP + 1];
                streams[0] = &s[a..];
                let count = group.layout.streams(full);
                match group.layout {
                    Layout::Chain => {
                        let m = ms[taus[0]] as usize;
                        for (c, slot) in streams[1..count].iter_mut().enumerate() {
                            *slot = &s[a + (m << c)..];
                        }
                    }
                    Layout::Pairs => {
                        for (c, &t) in taus[..full].iter().enumerate() {
                            let m = ms[t] as usize;
                            streams[2 * c + 1] = &s[a + m..];
                            streams[2 * c + 2] = &s[a + 2 * m..];
                        }
                    }
                }
                let mut sums = [0.0f64; MAX_GROUP];
                group_second(len, full, group.layout, &streams[..count], &mut sums);
                for (c, &t) in taus[..full].iter().enumerate() {
                    row[t] += sums[c];
                }
            }
            Order::Third => {
                for &t in &taus[..full] {
                    row[t] += third_block(s, a, len, ms[t] as usize);
                }
            }
        }
    }
    for &t in &taus[full..] {
        let end = terms(ms[t]);
        if end <= a {
            continue;
        }
        let m = ms[t] as usize;
        let part = end - a;
        row[t] += match order {
            Order::Second => {
                let mut one = [0.0f64; 1];
                let streams = [&s[a..], &s[a + m..], &s[a + 2 * m..]];
                group_second(part, 1, Layout::Chain, &streams, &mut one);
                one[0]
            }
            Order::Third => third_block(s, a, part, m),
        };
    }
}

fn third_block(s: &[f64], j0: usize, len: usize, m: usize) -> f64 {
    third(
        len,
        &[&s[j0..], &s[j0 + m..], &s[j0 + 2 * m..], &s[j0 + 3 * m..]],
    )
}

pub(crate) use crate::stats::neumaier;

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
}
