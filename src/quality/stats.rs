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
    pub possibly_saturated: bool,
    /// Smallest non-zero difference between consecutive samples: the quantisation step of an
    /// integer-coded sensor (in SI units), an upper bound of it otherwise.
    pub smallest_step: Option<f64>,
    /// The longest run of identical consecutive samples, and where it starts (index among the finite
    /// samples): a sensor that froze for a while.
    pub longest_repeat: u64,
    pub longest_repeat_start: u64,
}

/// Share of samples sitting on one extreme above which a channel is flagged as possibly saturated.
const SATURATION_SHARE: f64 = 1e-3;
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

    /// Adds a slice of finite samples at once: block mean and sum of squares by two passes, merged with
    /// Chan et al.'s pairwise update. Same result as [`push`](Self::push) per sample up to rounding, several
    /// times faster on long recordings.
    pub fn push_slice(&mut self, xs: &[f64]) {
        if xs.is_empty() {
            return;
        }
        if xs.iter().any(|x| !x.is_finite()) {
            xs.iter().for_each(|&x| self.push(x));
            return;
        }
        let n_b = xs.len() as f64;
        let mean_b = xs.iter().sum::<f64>() / n_b;
        let m2_b: f64 = xs.iter().map(|x| (x - mean_b) * (x - mean_b)).sum();
        let min_b = xs.iter().copied().fold(f64::INFINITY, f64::min);
        let max_b = xs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let n_a = self.count as f64;
        let n = n_a + n_b;
        let delta = mean_b - self.mean;
        self.mean += delta * n_b / n;
        self.m2 += m2_b + delta * delta * n_a * n_b / n;
        self.count += xs.len() as u64;
        merge_extreme(&mut self.min, &mut self.at_min, min_b, xs, |a, b| a < b);
        merge_extreme(&mut self.max, &mut self.at_max, max_b, xs, |a, b| a > b);
        let inner = xs
            .windows(2)
            .map(|w| (w[1] - w[0]).abs())
            .filter(|&d| d > 0.0)
            .fold(f64::INFINITY, f64::min);
        let joint = self.previous.map_or(f64::INFINITY, |p| (xs[0] - p).abs());
        let first = self.count - xs.len() as u64;
        let mut previous = self.previous;
        for (i, &x) in xs.iter().enumerate() {
            self.run = if previous == Some(x) { self.run + 1 } else { 1 };
            if self.run > self.longest_run {
                self.longest_run = self.run;
                self.longest_run_start = first + i as u64 + 1 - self.run;
            }
            previous = Some(x);
        }
        for step in [inner, joint] {
            if step > 0.0 && step < self.smallest_step {
                self.smallest_step = step;
            }
        }
        self.previous = xs.last().copied();
    }

    pub fn summary(&self) -> ChannelSummary {
        let n = self.count;
        let threshold = SATURATION_MIN_COUNT.max((SATURATION_SHARE * n as f64) as u64);
        let constant = self.min == self.max;
        ChannelSummary {
            finite_samples: n,
            mean: if n > 0 { self.mean } else { f64::NAN },
            std: if n > 1 {
                (self.m2 / (n - 1) as f64).sqrt()
            } else {
                f64::NAN
            },
            min: self.min,
            max: self.max,
            samples_at_min: self.at_min,
            samples_at_max: self.at_max,
            possibly_saturated: n > 0
                && !constant
                && (self.at_min >= threshold || self.at_max >= threshold),
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
    xs: &[f64],
    beyond: impl Fn(f64, f64) -> bool,
) {
    if beyond(block, *current) {
        *current = block;
        *count = 0;
    }
    if block == *current {
        *count += xs.iter().filter(|&&x| x == block).count() as u64;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
    }

    #[test]
    fn slices_and_single_samples_agree() {
        let xs: Vec<f64> = (0..5000)
            .map(|i| 3.0 + ((i * 7919) % 101) as f64 * 0.01)
            .collect();
        let mut one = ChannelStats::new();
        xs.iter().for_each(|&x| one.push(x));
        let mut blocks = ChannelStats::new();
        xs.chunks(333).for_each(|c| blocks.push_slice(c));
        let (a, b) = (one.summary(), blocks.summary());
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
        let mut blocks = ChannelStats::new();
        xs.chunks(97).for_each(|c| blocks.push_slice(c));
        for s in [one.summary(), blocks.summary()] {
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
