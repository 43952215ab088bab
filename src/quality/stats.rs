//! Per-channel summary statistics gathered in one streaming pass.

use serde::Serialize;

/// Running statistics of one channel's finite samples (Welford's update for mean and variance, so that a
/// large offset does not cancel the variance away).
#[derive(Debug, Clone, Default)]
pub struct ChannelStats {
    count: u64,
    mean: f64,
    m2: f64,
    min: f64,
    max: f64,
    at_min: u64,
    at_max: u64,
    smallest_step: f64,
    previous: Option<f64>,
    /// Length of the current run of identical consecutive samples, and the longest so far with the
    /// index (among finite samples) of its first sample.
    run: u64,
    longest_run: u64,
    longest_run_start: u64,
}

/// The finished summary of a channel, as reported.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct ChannelSummary {
    pub finite_samples: u64,
    pub mean: f64,
    pub std: f64,
    pub min: f64,
    pub max: f64,
    /// Samples equal to the minimum / maximum: many of them mean a clipped (saturated) sensor.
    pub samples_at_min: u64,
    pub samples_at_max: u64,
    /// Many samples at an extreme (see [`ChannelSummary::samples_at_min`]); as reported, judged
    /// on gyro and accelerometer channels only (false on the others).
    pub possibly_saturated: bool,
    /// Smallest non-zero difference between consecutive samples: the quantisation step of an
    /// integer-coded sensor (in SI units), an upper bound of it otherwise.
    pub smallest_step: Option<f64>,
    /// The longest run of identical consecutive samples, and where it starts (index among the finite
    /// samples): a sensor that froze for a while.
    pub longest_repeat: u64,
    pub longest_repeat_start: u64,
}

/// The smallest non-zero difference between consecutive samples of `y` (`None` where every
/// difference is 0 or `y` has fewer than 2 samples): the quantisation step of a digital output,
/// as [`ChannelSummary::smallest_step`] reads it while streaming.
///
/// In eight lanes: one running minimum is a chain of dependent compares (20 ms on 10⁷ samples,
/// and the residual loop asks for it once per channel); the minimum of the lanes' minima is the
/// same number.
pub fn smallest_step(y: &[f64]) -> Option<f64> {
    const LANES: usize = 8;
    if y.len() < 2 {
        return None;
    }
    let nonzero = |d: f64| if d > 0.0 { d } else { f64::INFINITY };
    let mut acc = [f64::INFINITY; LANES];
    let full = (y.len() - 1) / LANES * LANES;
    for (next, prev) in y[1..1 + full]
        .chunks_exact(LANES)
        .zip(y[..full].chunks_exact(LANES))
    {
        for j in 0..LANES {
            acc[j] = acc[j].min(nonzero((next[j] - prev[j]).abs()));
        }
    }
    let step = acc
        .into_iter()
        .chain(y[full..].windows(2).map(|w| nonzero((w[1] - w[0]).abs())))
        .fold(f64::INFINITY, f64::min);
    step.is_finite().then_some(step)
}

/// Share of samples sitting on one extreme above which a channel is flagged as possibly saturated.
const SATURATION_SHARE: f64 = 1e-3;
/// How many times the count a normal distribution of the channel's mean and σ puts on an extreme
/// level that level must hold to count as piled up (see [`ChannelStats::summary`]). Gaussian
/// samples rounded to steps of 0.25σ–2σ hold 0.3–0.9 times that count on their extremes; clipped
/// at 1.5σ–2.5σ before rounding, 2.1–3.1 times on a grid of 0.25σ and 8–13 times on 0.05σ
/// (10⁵ samples each). On grids of half a σ and coarser, clipping (1.3–1.9 times) cannot be told
/// from the grid and is not flagged.
const PILE_UP: f64 = 2.0;
/// ...and the least count, so that short recordings are not flagged by chance.
const SATURATION_MIN_COUNT: u64 = 10;

impl ChannelStats {
    pub fn new() -> Self {
        ChannelStats {
            min: f64::INFINITY,
            max: f64::NEG_INFINITY,
            smallest_step: f64::INFINITY,
            ..Default::default()
        }
    }

    pub fn push(&mut self, x: f64) {
        if !x.is_finite() {
            self.previous = None;
            return;
        }
        self.count += 1;
        let delta = x - self.mean;
        self.mean += delta / self.count as f64;
        self.m2 += delta * (x - self.mean);
        if x < self.min {
            self.min = x;
            self.at_min = 0;
        }
        if x == self.min {
            self.at_min += 1;
        }
        if x > self.max {
            self.max = x;
            self.at_max = 0;
        }
        if x == self.max {
            self.at_max += 1;
        }
        if let Some(p) = self.previous {
            let step = (x - p).abs();
            if step > 0.0 && step < self.smallest_step {
                self.smallest_step = step;
            }
        }
        self.extend_run(self.previous == Some(x));
        self.previous = Some(x);
    }

    /// Counts the sample just added (`count` already includes it) into the runs of repeats.
    fn extend_run(&mut self, repeats: bool) {
        self.run = if repeats { self.run + 1 } else { 1 };
        if self.run > self.longest_run {
            self.longest_run = self.run;
            self.longest_run_start = self.count - self.run;
        }
    }

    /// Adds a slice of samples at once (finite ones; any other sends the slice through
    /// [`push`](Self::push) sample by sample): the block's moments about its first sample and its
    /// extremes in one lane-parallel pass (`BlockScan`), merged with Chan et al.'s pairwise update.
    /// Same result as [`push`](Self::push) per sample up to rounding; this is the screen every sample
    /// of every file goes through, so it is written for the vector units (a fold with `f64::min` or a
    /// single running sum would keep them idle).
    pub fn push_slice(&mut self, xs: &[f64]) {
        match SliceScan::of(xs) {
            Some(scan) => self.push_scanned(xs, scan),
            // A NaN or infinity makes the sums non-finite (so does an overflow, which the
            // per-sample path handles as well).
            None => xs.iter().for_each(|&x| self.push(x)),
        }
    }

    /// Adds the finite slice `xs` that `scan` was made of ([`SliceScan::of`]).
    pub fn push_scanned(&mut self, xs: &[f64], scan: SliceScan) {
        let block = scan.0;
        let n_b = xs.len() as f64;
        let mean_dev = block.sum / n_b;
        let mean_b = block.shift + mean_dev;
        let m2_b = (block.squares - block.sum * mean_dev).max(0.0);
        let n_a = self.count as f64;
        let n = n_a + n_b;
        let delta = mean_b - self.mean;
        self.mean += delta * n_b / n;
        self.m2 += m2_b + delta * delta * n_a * n_b / n;
        let first = self.count;
        self.count += xs.len() as u64;
        merge_extreme(
            &mut self.min,
            &mut self.at_min,
            block.min,
            block.at_min,
            |a, b| a < b,
        );
        merge_extreme(
            &mut self.max,
            &mut self.at_max,
            block.max,
            block.at_max,
            |a, b| a > b,
        );
        let joint = self.previous.map_or(f64::INFINITY, |p| (xs[0] - p).abs());
        for step in [block.smallest_step, joint] {
            if step > 0.0 && step < self.smallest_step {
                self.smallest_step = step;
            }
        }
        self.run = if self.previous == Some(xs[0]) {
            self.run + 1
        } else {
            1
        };
        let mut longest = (self.longest_run, self.longest_run_start);
        if self.run > longest.0 {
            longest = (self.run, first + 1 - self.run);
        }
        let mut run = self.run;
        let windows = xs.len() - 1;
        if !block.repeats {
            // No two neighbours inside the block are equal: the run ends at its first pair.
            if windows > 0 {
                run = 1;
            }
        } else {
            // Repeats are rare in a live sensor: a group of neighbours without one only resets
            // the run.
            for start in (0..windows).step_by(REPEAT_GROUP) {
                let end = (start + REPEAT_GROUP).min(windows);
                let (heads, tails) = (&xs[start..end], &xs[start + 1..=end]);
                if !heads
                    .iter()
                    .zip(tails)
                    .fold(false, |any, (a, b)| any | (a == b))
                {
                    run = 1;
                    continue;
                }
                for (i, (a, b)) in (start..).zip(heads.iter().zip(tails)) {
                    if a == b {
                        run += 1;
                        if run > longest.0 {
                            longest = (run, first + i as u64 + 2 - run);
                        }
                    } else {
                        run = 1;
                    }
                }
            }
        }
        (self.run, self.longest_run, self.longest_run_start) = (run, longest.0, longest.1);
        self.previous = xs.last().copied();
    }

    pub fn summary(&self) -> ChannelSummary {
        let n = self.count;
        let threshold = SATURATION_MIN_COUNT.max((SATURATION_SHARE * n as f64) as u64);
        let constant = self.min == self.max;
        let std = if n > 1 {
            (self.m2 / (n - 1) as f64).sqrt()
        } else {
            f64::NAN
        };
        // A quantised output's extreme level holds every sample within half a step of it: with
        // a step of the noise's size that is a tenth of the samples, and no sign of clipping
        // (an angle-quantised gyro whose output takes four values had 11 % on its maximum). The
        // extremes count as piled up only beyond PILE_UP times what a normal distribution of the
        // channel's mean and σ puts within half a step of them (for unquantised data about
        // nothing, so the share threshold alone decides, as before).
        let half_step = if self.smallest_step.is_finite() {
            self.smallest_step / 2.0
        } else {
            0.0
        };
        let piled = |at: u64, from_mean: f64| {
            let sf = |x: f64| crate::stats::norm_sf(x / std);
            let expected = n as f64 * (sf(from_mean - half_step) - sf(from_mean + half_step));
            at >= threshold && (expected.is_nan() || at as f64 > PILE_UP * expected)
        };
        let saturated = n > 0
            && !constant
            && (piled(self.at_min, self.mean - self.min)
                || piled(self.at_max, self.max - self.mean));
        ChannelSummary {
            finite_samples: n,
            mean: if n > 0 { self.mean } else { f64::NAN },
            std,
            min: self.min,
            max: self.max,
            samples_at_min: self.at_min,
            samples_at_max: self.at_max,
            possibly_saturated: saturated,
            smallest_step: self.smallest_step.is_finite().then_some(self.smallest_step),
            longest_repeat: self.longest_run,
            longest_repeat_start: self.longest_run_start,
        }
    }
}

/// Merges a block's extreme (and how many samples sit on it) into the running one.
fn merge_extreme(
    current: &mut f64,
    count: &mut u64,
    block: f64,
    block_count: u64,
    beyond: impl Fn(f64, f64) -> bool,
) {
    if beyond(block, *current) {
        *current = block;
        *count = 0;
    }
    if block == *current {
        *count += block_count;
    }
}

/// Independent accumulators per lane: enough of them that the compiler keeps several vector
/// registers busy at once.
const LANES: usize = 8;

/// Neighbour pairs checked at once for a repeat before the run is followed pair by pair.
const REPEAT_GROUP: usize = 64;

/// One pass over a block of finite samples, for [`ChannelStats::push_scanned`]: made first, so that
/// a reader learns that every sample of a block is finite (its sums are) without a pass of its own.
#[derive(Debug, Clone, Copy)]
pub struct SliceScan(BlockScan);

impl SliceScan {
    /// The scan of `xs`; `None` where it is empty or its sums are not finite (a NaN or infinity
    /// among the samples, or an overflow), which the per-sample path handles.
    pub fn of(xs: &[f64]) -> Option<SliceScan> {
        if xs.is_empty() {
            return None;
        }
        let block = BlockScan::of(xs);
        // The shift (the first sample) enters the sums only through the others' deviations: a
        // slice of one non-finite sample has sums of 0.
        (block.shift.is_finite() && block.sum.is_finite() && block.squares.is_finite())
            .then_some(SliceScan(block))
    }
}

/// One block's sums of deviations from its first sample (`shift`), extremes with how many samples
/// sit on each, smallest non-zero step between neighbours and whether any two are equal. The shift
/// keeps the sum of squares free of cancellation for a channel far from zero (its deviations are
/// of the size of the noise), so one pass suffices; everything is gathered in that one pass
/// (this screen reads every sample of every file, so each extra pass costs a tenth of a Welch
/// estimate on a long record).
#[derive(Debug, Clone, Copy)]
struct BlockScan {
    shift: f64,
    sum: f64,
    squares: f64,
    min: f64,
    max: f64,
    at_min: u64,
    at_max: u64,
    smallest_step: f64,
    repeats: bool,
}

/// Per-lane accumulators of [`BlockScan::of`].
struct Lanes {
    sum: [f64; LANES],
    squares: [f64; LANES],
    min: [f64; LANES],
    max: [f64; LANES],
    at_min: [u64; LANES],
    at_max: [u64; LANES],
    step: [f64; LANES],
    repeats: [bool; LANES],
}

impl Lanes {
    /// Takes sample `x`, whose predecessor is `previous`, into lane `l`.
    #[inline(always)]
    fn take(&mut self, l: usize, x: f64, previous: f64, shift: f64) {
        let d = x - shift;
        self.sum[l] += d;
        self.squares[l] += d * d;
        let below = x < self.min[l];
        self.at_min[l] = if below {
            1
        } else {
            self.at_min[l] + u64::from(x == self.min[l])
        };
        self.min[l] = if below { x } else { self.min[l] };
        let above = x > self.max[l];
        self.at_max[l] = if above {
            1
        } else {
            self.at_max[l] + u64::from(x == self.max[l])
        };
        self.max[l] = if above { x } else { self.max[l] };
        let s = (x - previous).abs();
        self.repeats[l] |= s == 0.0;
        let s = if s > 0.0 { s } else { f64::INFINITY };
        self.step[l] = if s < self.step[l] { s } else { self.step[l] };
    }
}

impl BlockScan {
    /// `xs` is non-empty; a non-finite sample leaves non-finite sums (see [`SliceScan::of`]).
    fn of(xs: &[f64]) -> Self {
        let shift = xs[0];
        let mut lanes = Lanes {
            sum: [0.0; LANES],
            squares: [0.0; LANES],
            min: [f64::INFINITY; LANES],
            max: [f64::NEG_INFINITY; LANES],
            at_min: [0; LANES],
            at_max: [0; LANES],
            step: [f64::INFINITY; LANES],
            repeats: [false; LANES],
        };
        // The first sample has no predecessor: its deviation is 0 and it only sets the extremes.
        lanes.min[0] = shift;
        lanes.max[0] = shift;
        lanes.at_min[0] = 1;
        lanes.at_max[0] = 1;
        // Every other sample with its predecessor.
        let (heads, tails) = (&xs[..xs.len() - 1], &xs[1..]);
        let pairs = heads.chunks_exact(LANES).zip(tails.chunks_exact(LANES));
        for (a, b) in pairs {
            for l in 0..LANES {
                lanes.take(l, b[l], a[l], shift);
            }
        }
        let done = heads.len() / LANES * LANES;
        for (a, b) in heads[done..].iter().zip(&tails[done..]) {
            lanes.take(0, *b, *a, shift);
        }
        let min = lanes.min.iter().copied().fold(f64::INFINITY, f64::min);
        let max = lanes.max.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let on = |extremes: &[f64; LANES], counts: &[u64; LANES], value: f64| -> u64 {
            (0..LANES)
                .filter(|&l| extremes[l] == value)
                .map(|l| counts[l])
                .sum()
        };
        BlockScan {
            shift,
            sum: lanes.sum.iter().sum(),
            squares: lanes.squares.iter().sum(),
            min,
            max,
            at_min: on(&lanes.min, &lanes.at_min, min),
            at_max: on(&lanes.max, &lanes.at_max, max),
            smallest_step: lanes.step.iter().copied().fold(f64::INFINITY, f64::min),
            repeats: lanes.repeats.iter().any(|&r| r),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lanes find the plain scan's smallest non-zero step: every length up to a few lanes,
    /// repeats, NaN and a step only at the very end.
    #[test]
    fn smallest_step_matches_a_plain_scan() {
        let plain = |y: &[f64]| {
            let d = y
                .windows(2)
                .map(|w| (w[1] - w[0]).abs())
                .filter(|d| *d > 0.0)
                .fold(f64::INFINITY, f64::min);
            d.is_finite().then_some(d)
        };
        let mut rng = crate::sim::rng::Rng::new(4);
        for len in 0..40 {
            let noisy: Vec<f64> = (0..len).map(|_| (rng.gauss() * 8.0).round()).collect();
            let mut late = vec![1.0; len];
            if let Some(last) = late.last_mut() {
                *last = 1.5;
            }
            let mut holed = noisy.clone();
            if len > 3 {
                holed[len / 2] = f64::NAN;
            }
            for y in [&noisy, &late, &holed] {
                assert_eq!(smallest_step(y), plain(y), "{y:?}");
            }
        }
    }

    /// A Gaussian rounded to steps of 2σ has over 0.1 % of its samples on each extreme level
    /// (and an angle quantiser's four values far more): a coarse grid, not clipping. Clipped at
    /// 1.5σ before rounding to steps of σ/4, the samples pile up there.
    #[test]
    fn a_coarse_grid_is_not_saturation_but_clipping_on_it_is() {
        let x = crate::sim::rng::Rng::new(8).gauss_vec(100_000);
        let summary = |clip: f64, step: f64| {
            let mut s = ChannelStats::new();
            for v in &x {
                s.push((v.clamp(-clip, clip) / step).round() * step);
            }
            s.summary()
        };
        let free = summary(f64::INFINITY, 2.0);
        assert!(free.samples_at_max >= 100, "{free:?}");
        assert!(!free.possibly_saturated, "{free:?}");
        let clipped = summary(1.5, 0.25);
        assert!(clipped.possibly_saturated, "{clipped:?}");
    }

    #[test]
    fn welford_survives_a_large_offset() {
        let mut s = ChannelStats::new();
        for i in 0..1000 {
            s.push(1e9 + if i % 2 == 0 { 1.0 } else { -1.0 });
        }
        let sum = s.summary();
        assert!(
            (sum.std - (1000.0f64 / 999.0).sqrt()).abs() < 1e-6,
            "{}",
            sum.std
        );
        assert_eq!(sum.smallest_step, Some(2.0));
        let xs: Vec<f64> = (0..1000)
            .map(|i| 1e9 + if i % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        let mut blocks = ChannelStats::new();
        xs.chunks(61).for_each(|c| blocks.push_slice(c));
        let b = blocks.summary();
        assert!((b.std - sum.std).abs() < 1e-9, "{} vs {}", b.std, sum.std);
        assert_eq!(b.smallest_step, Some(2.0));
        assert_eq!((b.samples_at_min, b.samples_at_max), (500, 500));
    }

    #[test]
    fn slices_and_single_samples_agree() {
        let xs: Vec<f64> = (0..5000)
            .map(|i| 3.0 + ((i * 7919) % 101) as f64 * 0.01)
            .collect();
        let mut one = ChannelStats::new();
        xs.iter().for_each(|&x| one.push(x));
        // A slice of one non-finite sample is not taken for a finite one.
        assert!(SliceScan::of(&[f64::NAN]).is_none());
        assert!(SliceScan::of(&[f64::INFINITY, 1.0]).is_none());
        assert!(SliceScan::of(&[1.0, f64::NAN]).is_none());
        // Slices of one sample (no neighbour pair inside), two, fewer than the lanes, and many.
        for size in [1, 2, 7, 333] {
            let mut blocks = ChannelStats::new();
            xs.chunks(size).for_each(|c| blocks.push_slice(c));
            let (a, b) = (one.summary(), blocks.summary());
            assert_summaries_agree(&a, &b);
        }
    }

    fn assert_summaries_agree(a: &ChannelSummary, b: &ChannelSummary) {
        assert!((a.mean - b.mean).abs() < 1e-12 && (a.std - b.std).abs() < 1e-12);
        assert_eq!(
            (a.min, a.max, a.samples_at_min, a.samples_at_max),
            (b.min, b.max, b.samples_at_min, b.samples_at_max)
        );
        assert!((a.smallest_step.unwrap() - b.smallest_step.unwrap()).abs() < 1e-15);
        assert_eq!(
            (a.longest_repeat, a.longest_repeat_start),
            (b.longest_repeat, b.longest_repeat_start)
        );
    }

    #[test]
    fn longest_repeat_is_found_across_slices() {
        let mut xs: Vec<f64> = (0..3000).map(|i| ((i * 7919) % 101) as f64).collect();
        for x in &mut xs[1000..1250] {
            *x = 7.5;
        }
        let mut one = ChannelStats::new();
        xs.iter().for_each(|&x| one.push(x));
        assert_eq!(
            (
                one.summary().longest_repeat,
                one.summary().longest_repeat_start
            ),
            (250, 1000)
        );
        for size in [1, 5, 97] {
            let mut blocks = ChannelStats::new();
            xs.chunks(size).for_each(|c| blocks.push_slice(c));
            let s = blocks.summary();
            assert_eq!((s.longest_repeat, s.longest_repeat_start), (250, 1000));
        }
    }

    #[test]
    fn clipped_channel_is_flagged() {
        let mut s = ChannelStats::new();
        for i in 0..10_000 {
            let x = ((i as f64) * 0.37).sin() * 2.0;
            s.push(x.clamp(-1.5, 1.5));
        }
        assert!(s.summary().possibly_saturated);
        let mut clean = ChannelStats::new();
        for i in 0..10_000 {
            clean.push(((i as f64) * 0.37).sin());
        }
        assert!(!clean.summary().possibly_saturated);
    }
}
