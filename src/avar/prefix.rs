//! The cumulative sum S of the mean-removed rate samples, the one array every estimator reads.
//!
//! Why care: an Allan-family term is a second (or third) difference of S, a small number formed
//! from large ones. S must therefore be accurate to about one rounding of its own magnitude at every
//! index, not carry an error that grows along the recording. Three things make it so:
//!
//! - the mean is removed first (a gyro bias of 1e6 times the noise would otherwise make S grow
//!   like j·bias and leave no digits for the noise), and the mean itself comes from an exact
//!   double-double sum;
//! - S is built as Y_j − j·ȳ, where Y_j = Σ_{k<j} y_k is carried in double-double at every 4096-sample
//!   boundary and j·ȳ is formed exactly (two-product), so boundary values are correct to one
//!   rounding however long the recording;
//! - between boundaries a plain f64 running sum of y_k − ȳ adds at most ~4096 roundings of the
//!   local partial sum, far below one rounding of S for any realistic recording.
//!
//! Never f32: its 24 bits are gone after a few thousand samples of cumulative sum.
//!
//! Both passes run on all cores. The boundary grid is fixed (it does not depend on the number of
//! threads), so S is bit-for-bit the same on any machine with IEEE f64.
//!
//! The fill also records coarse cumulative sums of S (every 256 values), which give any window sum
//! of S in O(1): the modified Allan variance at a few sampled start indices needs them (noise
//! identification).

use rayon::prelude::*;

use super::AvarError;

/// Samples between exact (double-double) anchors of S.
const ANCHOR: usize = 4096;
/// Anchored blocks filled together by one task: four independent running sums interleave, so the
/// fill is not bound by the latency of one long chain of additions.
const LANES: usize = 4;
/// Samples between the sub-anchors of T (the cumulative sum of S), used for window sums of S.
const SUB: usize = 256;
/// Sub-anchors per anchored block.
const SUBS: usize = ANCHOR / SUB;
/// S_j = Σ_{k<j} (y_k − ȳ) for j = 0..=N, with the mean ȳ that was removed, and coarse cumulative
/// sums of S itself (for window sums of S).
///
/// The S buffer of a large recording is recycled when this is dropped (see
/// [`crate::memory::release_cached_memory`]).
#[derive(Debug, Clone)]
pub struct PrefixSums {
    s: Vec<f64>,
    mean: f64,
    /// T at the start of each anchored block of S (T_j = Σ_{i<j} S_i), double-double; one more
    /// entry than there are blocks (the total).
    block_t: Vec<(f64, f64)>,
    /// Σ of S from the start of its block to each sub-anchor (every 256 values), per block.
    sub_t: Vec<f64>,
}

impl PrefixSums {
    /// Builds S from rate samples `y`. Fails on the first non-finite sample (with its index), or if
    /// the samples' sum overflows f64.
    pub fn new(y: &[f64]) -> Result<PrefixSums, AvarError> {
        let n = y.len();
        if n == 0 {
            return Ok(PrefixSums::empty());
        }
        let (mean, bases) = anchors(y)?;
        // Pass 2: fill S between anchors, and the sums of S towards each sub-anchor.
        let mut s = crate::memory::scratch(n + 1);
        s[0] = 0.0;
        let mut sub_t = vec![0.0f64; bases.len() * SUBS];
        let mut totals = vec![0.0f64; bases.len()];
        s[1..]
            .par_chunks_mut(ANCHOR * LANES)
            .zip(y.par_chunks(ANCHOR * LANES))
            .zip(bases.par_chunks(LANES))
            .zip(sub_t.par_chunks_mut(SUBS * LANES))
            .zip(totals.par_chunks_mut(LANES))
            .for_each(|((((out, ys), bs), subs), tot)| fill_group(out, ys, bs, mean, subs, tot));
        Ok(PrefixSums::assembled(s, mean, sub_t, &totals))
    }

    /// [`PrefixSums::new`] of the samples in `y`, built in `y`'s own buffer, to the bit the same.
    ///
    /// **Why.** A corrected copy of a series whose Allan deviation is wanted (the residual loop's
    /// refits under a slow effect removed) would otherwise need a second record-length buffer for
    /// S beside it: two per refit, which with the step scan running beside it in the same channel
    /// made three at once, more than the pooled buffers, and the one made afresh cost its page
    /// faults (on 24 h × 400 Hz, 67 000 of them and up to 0.7 s of system time a run).
    ///
    /// **How.** S_{j+1} is written where y_{j+1} was, so each block reads its next sample before
    /// writing over it, and the last value of each group of blocks (S at the next group's first
    /// index, whose sample that group reads first) is stored once every group is done.
    pub fn from_samples(mut y: Vec<f64>) -> Result<PrefixSums, AvarError> {
        let n = y.len();
        if n == 0 {
            crate::memory::recycle(y);
            return Ok(PrefixSums::empty());
        }
        let (mean, bases) = anchors(&y)?;
        let mut sub_t = vec![0.0f64; bases.len() * SUBS];
        let mut totals = vec![0.0f64; bases.len()];
        let group = ANCHOR * LANES;
        let mut lasts = vec![0.0f64; n.div_ceil(group)];
        y[..n]
            .par_chunks_mut(group)
            .zip(bases.par_chunks(LANES))
            .zip(sub_t.par_chunks_mut(SUBS * LANES))
            .zip(totals.par_chunks_mut(LANES))
            .zip(lasts.par_iter_mut())
            .for_each(|((((buf, bs), subs), tot), last)| {
                *last = fill_group_in_place(buf, bs, mean, subs, tot);
            });
        y.push(0.0);
        for (g, last) in lasts.into_iter().enumerate() {
            y[((g + 1) * group).min(n)] = last;
        }
        y[0] = 0.0;
        Ok(PrefixSums::assembled(y, mean, sub_t, &totals))
    }

    /// The prefix sums of no samples.
    fn empty() -> PrefixSums {
        PrefixSums {
            s: vec![0.0],
            mean: 0.0,
            block_t: vec![(0.0, 0.0), (0.0, 0.0)],
            sub_t: vec![0.0; SUBS],
        }
    }

    /// S with the cumulative sums of S at each anchored block's start, from the blocks' totals.
    fn assembled(s: Vec<f64>, mean: f64, sub_t: Vec<f64>, totals: &[f64]) -> PrefixSums {
        let mut block_t = Vec::with_capacity(totals.len() + 1);
        let (mut th, mut tl) = (0.0f64, 0.0f64);
        block_t.push((th, tl));
        for &t in totals {
            let (sum, err) = two_sum(th, t);
            th = sum;
            tl += err;
            block_t.push((th, tl));
        }
        PrefixSums {
            s,
            mean,
            block_t,
            sub_t,
        }
    }

    /// S_0..=S_N (length N + 1).
    pub fn s(&self) -> &[f64] {
        &self.s
    }

    /// Number of rate samples N.
    pub fn len(&self) -> usize {
        self.s.len() - 1
    }

    /// Whether there are no samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The mean that was removed.
    pub fn mean(&self) -> f64 {
        self.mean
    }

    /// T_p = Σ_{i<p} S_i for p ≤ N + 1, as double-double (hi, lo), from the stored anchors plus at
    /// most 255 values of S: O(1) in N.
    pub fn cumulative_s(&self, p: usize) -> (f64, f64) {
        let b = p / ANCHOR;
        let (base, start) = if b + 1 >= self.block_t.len() {
            let b = self.block_t.len() - 1;
            (self.block_t[b], b * ANCHOR)
        } else {
            // Sub-anchors exist up to the end of the samples the block covers.
            let covered = (self.len() - b * ANCHOR).min(ANCHOR);
            let sub = ((p % ANCHOR) / SUB).min(covered / SUB).min(SUBS - 1);
            let (h, l) = self.block_t[b];
            let (h, e) = two_sum(h, self.sub_t[b * SUBS + sub]);
            ((h, l + e), b * ANCHOR + sub * SUB)
        };
        let rest: f64 = self.s[start..p].iter().sum();
        let (h, e) = two_sum(base.0, rest);
        (h, base.1 + e)
    }
}

impl Drop for PrefixSums {
    fn drop(&mut self) {
        crate::memory::recycle(std::mem::take(&mut self.s));
    }
}

/// Error-free sum: a + b = s + e exactly (Knuth's TwoSum).
#[inline(always)]
pub(crate) fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let z = s - a;
    (s, (a - (s - z)) + (b - z))
}

/// Pass 1 of the prefix sums: the mean of `y` (from an exact sum) and S at each anchor
/// (Y_j − j·ȳ in double-double, rounded once). Fails on the first non-finite sample (with its
/// index), or if the samples' sum overflows f64. `y` is not empty.
fn anchors(y: &[f64]) -> Result<(f64, Vec<f64>), AvarError> {
    let n = y.len();
    // Exact sum of every anchored block (also detects NaN/Inf: they poison the sum).
    let block_sums: Vec<(f64, f64)> = y.par_chunks(ANCHOR).map(dd_sum).collect();
    let mut anchors: Vec<(f64, f64)> = Vec::with_capacity(block_sums.len());
    let (mut hi, mut lo) = (0.0f64, 0.0f64);
    for &(s, e) in &block_sums {
        anchors.push((hi, lo));
        let (t, err) = two_sum(hi, s);
        hi = t;
        lo += err + e;
    }
    if !(hi.is_finite() && lo.is_finite()) {
        return Err(match y.iter().position(|v| !v.is_finite()) {
            Some(index) => AvarError::NonFinite { index },
            None => AvarError::Overflow,
        });
    }
    let mean = (hi + lo) / n as f64;
    let bases = anchors
        .iter()
        .enumerate()
        .map(|(b, &(yh, yl))| {
            let j = (b * ANCHOR) as f64;
            let p = j * mean;
            let pe = j.mul_add(mean, -p);
            let (dh, dl) = two_sum(yh, -p);
            dh + (dl + (yl - pe))
        })
        .collect();
    Ok((mean, bases))
}

/// Double-double sum of a block, four interleaved accumulators for throughput.
fn dd_sum(x: &[f64]) -> (f64, f64) {
    let mut s = [0.0f64; 4];
    let mut c = [0.0f64; 4];
    let chunks = x.chunks_exact(4);
    let rest = chunks.remainder();
    for ch in chunks {
        for l in 0..4 {
            let (t, e) = two_sum(s[l], ch[l]);
            s[l] = t;
            c[l] += e;
        }
    }
    for &v in rest {
        let (t, e) = two_sum(s[0], v);
        s[0] = t;
        c[0] += e;
    }
    let (mut hi, mut lo) = (0.0f64, c.iter().sum::<f64>());
    for v in s {
        let (t, e) = two_sum(hi, v);
        hi = t;
        lo += e;
    }
    (hi, lo)
}

/// Fills S_{j+1} for the samples of up to `LANES` consecutive anchored blocks, starting each block
/// from its anchor value S_{j₀}, and records, per block, Σ S_i from the block start j₀ to each
/// sub-anchor j₀ + k·256 (`subs`) and over the whole block (`totals`).
fn fill_group(
    out: &mut [f64],
    y: &[f64],
    bases: &[f64],
    mean: f64,
    subs: &mut [f64],
    totals: &mut [f64],
) {
    if bases.len() == LANES && y.len() == LANES * ANCHOR {
        let (y0, rest) = y.split_at(ANCHOR);
        let (y1, rest) = rest.split_at(ANCHOR);
        let (y2, y3) = rest.split_at(ANCHOR);
        let (o0, rest) = out.split_at_mut(ANCHOR);
        let (o1, rest) = rest.split_at_mut(ANCHOR);
        let (o2, o3) = rest.split_at_mut(ANCHOR);
        let mut a = [bases[0], bases[1], bases[2], bases[3]];
        let mut t = [0.0f64; LANES];
        for k in 0..ANCHOR {
            advance_t(subs, &mut t, &a, k);
            a[0] += y0[k] - mean;
            a[1] += y1[k] - mean;
            a[2] += y2[k] - mean;
            a[3] += y3[k] - mean;
            o0[k] = a[0];
            o1[k] = a[1];
            o2[k] = a[2];
            o3[k] = a[3];
        }
        totals.copy_from_slice(&t);
    } else {
        for (l, ((o, ys), &base)) in out
            .chunks_mut(ANCHOR)
            .zip(y.chunks(ANCHOR))
            .zip(bases.iter())
            .enumerate()
        {
            let mut a = base;
            let mut t = 0.0f64;
            for (k, (dst, &v)) in o.iter_mut().zip(ys).enumerate() {
                if k % SUB == 0 {
                    subs[l * SUBS + k / SUB] = t;
                }
                t += a;
                a += v - mean;
                *dst = a;
            }
            close_block(subs, totals, l, o.len(), t);
        }
    }
}

/// One step of the four lanes' T in [`fill_group`] and [`fill_group_in_place`]: at a
/// sub-anchor (k a multiple of `SUB`) each lane's running Σ S is recorded, then each lane's
/// current S (`a`) added.
#[inline(always)]
fn advance_t(subs: &mut [f64], t: &mut [f64; LANES], a: &[f64; LANES], k: usize) {
    if k.is_multiple_of(SUB) {
        for l in 0..LANES {
            subs[l * SUBS + k / SUB] = t[l];
        }
    }
    for l in 0..LANES {
        t[l] += a[l];
    }
}

/// The end of block `l` (of `len` values) in the one-lane fills: its T total, and a partial last
/// block ending on a sub-anchor records that anchor too (it is still inside S).
#[inline(always)]
fn close_block(subs: &mut [f64], totals: &mut [f64], l: usize, len: usize, t: f64) {
    if len.is_multiple_of(SUB) && len / SUB < SUBS {
        subs[l * SUBS + len / SUB] = t;
    }
    totals[l] = t;
}

/// [`fill_group`] in the samples' own buffer: `buf` holds the samples of up to `LANES`
/// consecutive anchored blocks and receives S_{j} at index j (relative to the group's start) for
/// every index but the first; S at the index after the group is returned. Each block reads its
/// next sample before it writes over it, and a block's last value goes where the next block's
/// first sample was, read before any write. The same operations in the same order as
/// [`fill_group`], so the same values.
fn fill_group_in_place(
    buf: &mut [f64],
    bases: &[f64],
    mean: f64,
    subs: &mut [f64],
    totals: &mut [f64],
) -> f64 {
    if bases.len() == LANES && buf.len() == LANES * ANCHOR {
        let mut a = [bases[0], bases[1], bases[2], bases[3]];
        let mut t = [0.0f64; LANES];
        let mut next = [buf[0], buf[ANCHOR], buf[2 * ANCHOR], buf[3 * ANCHOR]];
        for k in 0..ANCHOR {
            advance_t(subs, &mut t, &a, k);
            let v = next;
            if k + 1 < ANCHOR {
                for l in 0..LANES {
                    next[l] = buf[l * ANCHOR + k + 1];
                }
            }
            for l in 0..LANES {
                a[l] += v[l] - mean;
            }
            if k + 1 < ANCHOR {
                for l in 0..LANES {
                    buf[l * ANCHOR + k + 1] = a[l];
                }
            }
        }
        totals.copy_from_slice(&t);
        for l in 1..LANES {
            buf[l * ANCHOR] = a[l - 1];
        }
        a[LANES - 1]
    } else {
        let blocks = buf.len().div_ceil(ANCHOR);
        let mut carry = 0.0;
        for (l, &base) in bases.iter().enumerate().take(blocks) {
            let start = l * ANCHOR;
            let len = (buf.len() - start).min(ANCHOR);
            let mut a = base;
            let mut t = 0.0f64;
            let mut next = buf[start];
            for k in 0..len {
                if k % SUB == 0 {
                    subs[l * SUBS + k / SUB] = t;
                }
                t += a;
                let v = next;
                if k + 1 < len {
                    next = buf[start + k + 1];
                }
                a += v - mean;
                if k + 1 < len {
                    buf[start + k + 1] = a;
                }
            }
            close_block(subs, totals, l, len, t);
            // This block's last value is S at the next block's first index (read above).
            if l > 0 {
                buf[start] = carry;
            }
            carry = a;
        }
        carry
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_exact_integer_sums() {
        // Integers/2^10 with a big offset: every S_j is exactly representable, so the result must be
        // exact (the mean is chosen to be exactly representable too).
        let n = 3 * ANCHOR * LANES + 123;
        let raw: Vec<i64> = (0..n as i64).map(|i| (i * 7919 % 2003) - 1001).collect();
        let offset = 1i64 << 40;
        let total: i64 = raw.iter().sum();
        let shift = total / n as i64; // make the exact mean an integer
        let ints: Vec<i64> = raw.iter().map(|r| r - shift).collect();
        let fix = ints.iter().sum::<i64>();
        let mut ints = ints;
        ints[0] -= fix; // sum is now exactly 0
        let y: Vec<f64> = ints.iter().map(|&v| (v + offset) as f64 / 1024.0).collect();
        let ps = PrefixSums::new(&y).unwrap();
        assert_eq!(ps.mean(), offset as f64 / 1024.0);
        let mut acc = 0i64;
        for (j, &s) in ps.s().iter().enumerate() {
            assert_eq!(s, acc as f64 / 1024.0, "j = {j}");
            acc += ints.get(j).copied().unwrap_or(0);
        }
    }

    #[test]
    fn cumulative_sums_of_s() {
        for n in [
            1usize,
            255,
            4096,
            4097,
            3 * ANCHOR * LANES + 123,
            4 * ANCHOR * LANES,
        ] {
            let y: Vec<f64> = (0..n)
                .map(|i| ((i * 7919 % 2003) as f64 - 1001.0) / 64.0)
                .collect();
            let ps = PrefixSums::new(&y).unwrap();
            let mut t = 0.0f64;
            for p in 0..=n + 1 {
                let (h, l) = ps.cumulative_s(p);
                assert!((h + l - t).abs() <= 1e-9 * (1.0 + t.abs()), "n={n} p={p}");
                if p <= n {
                    t += ps.s()[p];
                }
            }
        }
    }

    #[test]
    fn reports_first_non_finite_and_overflow() {
        let mut y = vec![1.0; 10_000];
        y[7000] = f64::NAN;
        y[9000] = f64::INFINITY;
        assert_eq!(
            PrefixSums::new(&y).unwrap_err(),
            AvarError::NonFinite { index: 7000 }
        );
        let big = vec![f64::MAX; 4];
        assert_eq!(PrefixSums::new(&big).unwrap_err(), AvarError::Overflow);
        assert_eq!(PrefixSums::new(&[]).unwrap().len(), 0);
    }
    #[test]
    fn built_in_place_to_the_bit() {
        let mut rng = crate::sim::rng::Rng::new(3);
        let group = ANCHOR * LANES;
        for n in [
            1usize,
            2,
            255,
            ANCHOR - 1,
            ANCHOR,
            ANCHOR + 1,
            group - 1,
            group,
            group + 1,
            3 * group + 123,
            5 * group + 7 * ANCHOR,
        ] {
            let y: Vec<f64> = rng.gauss_vec(n).iter().map(|v| 1e3 + v).collect();
            let a = PrefixSums::new(&y).unwrap();
            let b = PrefixSums::from_samples(y.clone()).unwrap();
            assert_eq!(a.mean().to_bits(), b.mean().to_bits(), "n = {n}");
            assert_eq!(a.s().len(), b.s().len());
            for (j, (p, q)) in a.s().iter().zip(b.s()).enumerate() {
                assert_eq!(p.to_bits(), q.to_bits(), "n = {n}, S_{j}");
            }
            for p in [0, 1, n / 3, n / 2, n, n + 1] {
                assert_eq!(a.cumulative_s(p), b.cumulative_s(p), "n = {n}, T_{p}");
            }
        }
        let mut y = vec![1.0; 3 * ANCHOR];
        y[5000] = f64::NAN;
        assert_eq!(
            PrefixSums::from_samples(y).unwrap_err(),
            AvarError::NonFinite { index: 5000 }
        );
        assert_eq!(PrefixSums::from_samples(Vec::new()).unwrap().len(), 0);
    }
}
