//! The grid of sample instants behind a jittery time column.
//!
//! A sampled sensor ticks on a regular grid; its timestamps are the grid plus jitter (scheduling,
//! transport, rounding). Judging one interval at a time mistakes jitter for gaps: with ±40 % jitter
//! an interval can be 1.8 periods with nothing missing, and one missing sample between an early and
//! a late timestamp can look like 1.2 periods. [`GridTracker`] instead follows the grid itself: each
//! timestamp is placed on the nearest grid instant after the previous one (the number of periods
//! stepped, one when nothing is missing), and pulls the grid's phase toward itself by a small gain,
//! so the grid follows clock drift while a single late timestamp hardly moves it.

/// Gain of the phase update once warmed up: a rate off by 0.1 % lags by 0.064 periods, and one late
/// timestamp moves the grid by under 2 % of its lateness.
pub const GRID_GAIN: f64 = 1.0 / 64.0;

/// Timestamps before the grid's phase is known to a small fraction of the jitter: during these the
/// gain is 1/(k+1) (the running mean of the deviations, the least-squares phase), and the
/// deviations are not counted as jitter.
pub const GRID_WARMUP: u64 = 64;

/// See the module docs.
#[derive(Debug, Clone)]
pub struct GridTracker {
    period: f64,
    grid: Option<f64>,
    updates: u64,
}

/// Timestamps the initial phase is estimated from.
pub const PHASE_WINDOW: usize = 256;

impl GridTracker {
    /// A tracker whose phase is set by the first timestamp it places (then refined by the running
    /// mean of the deviations). Prefer [`anchored`](Self::anchored) when the first timestamps are at
    /// hand: one jittered timestamp is a poor phase.
    pub fn new(period: f64) -> Self {
        GridTracker {
            period,
            grid: None,
            updates: 0,
        }
    }

    /// A tracker whose phase comes from the circular mean of the first [`PHASE_WINDOW`] timestamps
    /// of `head` (their offsets from the first, modulo the period): missing samples shift an offset
    /// by whole periods and so do not matter, and the phase is known to the jitter / 16 before the
    /// first timestamp is judged. `head` must start with the first timestamp to be placed.
    pub fn anchored(period: f64, head: &[f64]) -> Self {
        let first = head.iter().copied().find(|t| t.is_finite());
        let Some(t0) = first else {
            return GridTracker::new(period);
        };
        let (mut s, mut c, mut n) = (0.0, 0.0, 0usize);
        for &t in head.iter().filter(|t| t.is_finite()).take(PHASE_WINDOW) {
            let angle = std::f64::consts::TAU * ((t - t0) / period).rem_euclid(1.0);
            s += angle.sin();
            c += angle.cos();
            n += 1;
        }
        if n < 8 || (s * s + c * c).sqrt() < 0.2 * n as f64 {
            // Too few timestamps, or jitter so wide the phase is undefined.
            return GridTracker::new(period);
        }
        let phase = s.atan2(c) / std::f64::consts::TAU * period;
        GridTracker {
            period,
            // The grid instant before the first timestamp's own.
            grid: Some(t0 + phase - period),
            updates: GRID_WARMUP + 1,
        }
    }

    /// Places timestamp `t`: the periods stepped since the previous timestamp (0 for the first, at
    /// least 1 after) and its deviation from the grid instant it was placed on.
    pub fn place(&mut self, t: f64) -> (u64, f64) {
        let Some(grid) = self.grid else {
            self.grid = Some(t);
            return (0, 0.0);
        };
        // The common case, one period on, is told by a product with the reciprocal (safely inside
        // (0.5, 1.5), where its rounding cannot differ from the quotient's) without a division or a
        // call to `round` (a library call on baseline x86-64): the two were a fifth of reading a
        // timed file. Elsewhere the exact quotient, rounded.
        let near = (t - grid) * (1.0 / self.period);
        let steps = if near > 0.5 + 1e-9 && near < 1.5 - 1e-9 {
            1.0
        } else {
            ((t - grid) / self.period).round().max(1.0)
        };
        let on_grid = grid + steps * self.period;
        let deviation = t - on_grid;
        let gain = (1.0 / (self.updates + 2) as f64).max(GRID_GAIN);
        self.grid = Some(on_grid + gain * deviation);
        self.updates += 1;
        (steps as u64, deviation)
    }

    /// Whether the phase has settled (deviations now measure jitter, not the phase's own error).
    pub fn warm(&self) -> bool {
        self.updates > GRID_WARMUP
    }
}

/// The mean period of `times` (finite, in any unit) from the grid that `rough_period` starts:
/// span / periods stepped, which neither jitter nor gaps bias (a mean of intervals near the median
/// does, by the jittered gap intervals it keeps or drops).
pub fn grid_period(times: &[f64], rough_period: f64) -> f64 {
    // A period off by δ makes the tracker lag by δ/GRID_GAIN periods, which under heavy jitter
    // misplaces timestamps (and each misplaced one adds a step for good); so the period is first made
    // coherent with the timestamps, then counted on the grid.
    let period = coherent_period(times, rough_period);
    grid_pass(times, period)
}

/// The period P that makes the timestamps most coherent: the one maximising |Σ exp(2πi·t/P)| (the
/// Rayleigh statistic of the phases t mod P), searched over windows of growing span so that each
/// search needs only a few dozen trial periods. Missing samples shift a phase by whole periods and do
/// not matter; jitter only lowers the peak (to 0.23 of its height at ±0.4 period, uniform).
fn coherent_period(times: &[f64], rough_period: f64) -> f64 {
    let finite: Vec<f64> = times.iter().copied().filter(|t| t.is_finite()).collect();
    let mut period = rough_period;
    let mut window = 256usize;
    // The first window allows the rough period 2 % of error; each later one the previous window's
    // resolution.
    let mut half_width = 0.02 * rough_period;
    loop {
        let w = window.min(finite.len());
        if w < 16 {
            return period;
        }
        let head = &finite[..w];
        let t0 = head[0];
        let span = head[w - 1] - t0;
        if span.is_nan() || span <= 0.0 {
            return period;
        }
        // The peak's width in P is about P²/span. Trial periods that far apart first (the best of
        // them lies in the main lobe: within half a width of the peak the coherence keeps over
        // half its height, while side lobes stay under a quarter), then a fifth of that apart
        // around the best: the same answer as the fine grid over the whole range, with a third of
        // its evaluations (this search was a sixth of reading a timed file).
        let resolution = period * period / span;
        let search = |from: f64, to: f64, step: f64| {
            let trials = (((to - from) / step).ceil() as usize).clamp(2, 400);
            most_coherent(head, from, to, trials).unwrap_or(period)
        };
        let coarse = search(period - half_width, period + half_width, resolution);
        period = search(coarse - resolution, coarse + resolution, 0.2 * resolution);
        half_width = 0.5 * resolution;
        if w == finite.len() || window >= 1 << 16 {
            return period;
        }
        window *= 16;
    }
}

/// Of `trials + 1` trial periods from `from` to `to` (evenly spaced in frequency), the one whose
/// phases of `head` (relative to its first timestamp) are most coherent; `None` for an empty or
/// non-positive range.
///
/// Each timestamp's phasor at the next trial frequency is its phasor at this one turned by a fixed
/// step, so a timestamp costs two `sin_cos` and one complex product per trial instead of a
/// `sin_cos` per trial (this search was two thirds of `info` on a 15-min timed file). The
/// rotations carry at most 400 roundings: 1e-13 of a phasor, far below what moves the peak.
fn most_coherent(head: &[f64], from: f64, to: f64, trials: usize) -> Option<f64> {
    if !(from > 0.0 && to > from) || head.is_empty() {
        return None;
    }
    let t0 = head[0];
    let (low, high) = (std::f64::consts::TAU / to, std::f64::consts::TAU / from);
    let step = (high - low) / trials as f64;
    let mut sums = vec![(0.0f64, 0.0f64); trials + 1];
    for &t in head {
        // sin and cos are periodic: no reduction modulo the period is needed (the angle reaches
        // 2π·65 536 at most, where f64 keeps it to 1e-10 rad).
        let dt = t - t0;
        let (mut s, mut c) = (dt * low).sin_cos();
        let (rs, rc) = (dt * step).sin_cos();
        for sum in sums.iter_mut() {
            sum.0 += s;
            sum.1 += c;
            (s, c) = (s * rc + c * rs, c * rc - s * rs);
        }
    }
    let (best, _) = sums
        .iter()
        .enumerate()
        .map(|(k, (s, c))| (k, s * s + c * c))
        .fold((0, f64::NEG_INFINITY), |a, b| if b.1 > a.1 { b } else { a });
    Some(std::f64::consts::TAU / (low + step * best as f64))
}

/// One pass of the tracker over `times` at `rough_period`: the least-squares slope of the
/// timestamps against their grid index (every timestamp weighs in, so the endpoints' jitter does
/// not set the answer as it would for span / steps).
fn grid_pass(times: &[f64], rough_period: f64) -> f64 {
    let finite: Vec<f64> = times
        .iter()
        .copied()
        .filter(|t| t.is_finite())
        .take(PHASE_WINDOW)
        .collect();
    let Some(&t0) = finite.first() else {
        return rough_period;
    };
    let mut tracker = GridTracker::anchored(rough_period, &finite);
    let mut index = 0u64;
    let mut points: Vec<(f64, f64)> = Vec::with_capacity(times.len());
    for &t in times.iter().filter(|t| t.is_finite()) {
        let (s, _) = tracker.place(t);
        if !points.is_empty() {
            index += s;
        }
        points.push((index as f64, t - t0));
    }
    // The least-squares slope from compensated sums about the means: the raw sums' n·Σk² − (Σk)²
    // and their rounding put the period 2e-11 off over the probe's 2²⁰ timestamps (exact 10-ms
    // ticks read 99.99999999797 Hz).
    let n = points.len() as f64;
    let mk = crate::stats::neumaier(points.iter().map(|p| p.0)) / n;
    let mt = crate::stats::neumaier(points.iter().map(|p| p.1)) / n;
    let skk = crate::stats::neumaier(points.iter().map(|&(k, _)| (k - mk) * (k - mk)));
    let skt = crate::stats::neumaier(points.iter().map(|&(k, y)| (k - mk) * (y - mt)));
    let slope = skt / skk;
    if skk > 0.0 && slope.is_finite() && slope > 0.0 {
        slope
    } else {
        rough_period
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Exact ticks (10 ms in ns, 2²⁰ of them, as a probe reads them): the period comes back to
    /// the last bit or two, not 2e-11 off.
    #[test]
    fn exact_ticks_give_the_exact_period() {
        let times: Vec<f64> = (0..1u64 << 20).map(|k| (k * 10_000_000) as f64).collect();
        let p = grid_period(&times, 1e7);
        assert!((p / 1e7 - 1.0).abs() < 1e-14, "{p}");
    }

    #[test]
    fn jitter_and_gaps_do_not_bias_the_period() {
        // ±0.4 period of deterministic jitter, a clock 300 ppm slow, and samples 100..103 missing.
        let period = 0.01 * (1.0 + 300e-6);
        let times: Vec<f64> = (0..5000)
            .filter(|i| !(100..103).contains(i))
            .map(|i| i as f64 * period + 0.004 * ((i * 7919 % 101) as f64 / 50.0 - 1.0))
            .collect();
        let p = grid_period(&times, 0.01);
        assert!((p / period - 1.0).abs() < 2e-6, "{p}");
        let mut tracker = GridTracker::anchored(period, &times);
        let steps: Vec<u64> = times.iter().map(|&t| tracker.place(t).0).collect();
        assert_eq!(
            steps[0], 1,
            "the first timestamp steps onto its own instant"
        );
        assert_eq!(steps.iter().filter(|&&s| s == 4).count(), 1);
        assert_eq!(steps.iter().filter(|&&s| s > 1).count(), 1);
    }

    #[test]
    fn the_anchored_phase_ignores_missing_samples_and_wrap() {
        // Grid at 0.3 period past each multiple; the first timestamp 0.45 late, samples 3..9 missing.
        let period = 1.0;
        let mut times = vec![0.75];
        times.extend((10..300).map(|i| i as f64 + 0.3 + 0.2 * ((i * 37 % 11) as f64 / 5.0 - 1.0)));
        let mut tracker = GridTracker::anchored(period, &times);
        let (steps, deviation) = tracker.place(times[0]);
        assert_eq!(steps, 1);
        assert!((deviation - 0.45).abs() < 0.05, "{deviation}");
        assert_eq!(tracker.place(times[1]).0, 10);
    }

    #[test]
    fn the_turned_phasors_pick_the_directly_computed_best() {
        // Trial by trial, the coherence with each phasor from its own sin_cos; the rotations
        // must pick the same trial, over windows up to the longest (2^16 timestamps, 400 trials).
        for (n, jitter, trials) in [(256, 0.4, 12), (4096, 0.1, 40), (65536, 0.3, 400)] {
            let period = 0.0025 * (1.0 - 150e-6);
            let times: Vec<f64> = (0..n)
                .map(|i| {
                    let u = ((i * 7919 + 13) % 1009) as f64 / 504.5 - 1.0;
                    1e5 + i as f64 * period + jitter * period * u
                })
                .collect();
            let (from, to) = (0.0025 * 0.999, 0.0025 * 1.001);
            let (low, high) = (std::f64::consts::TAU / to, std::f64::consts::TAU / from);
            let direct = (0..=trials)
                .map(|k| {
                    let scale = low + (high - low) / trials as f64 * k as f64;
                    let (s, c) = times.iter().fold((0.0, 0.0), |(s, c), &t| {
                        let (a, b) = ((t - times[0]) * scale).sin_cos();
                        (s + a, c + b)
                    });
                    (std::f64::consts::TAU / scale, s * s + c * c)
                })
                .fold(
                    (0.0, f64::NEG_INFINITY),
                    |a, b| if b.1 > a.1 { b } else { a },
                );
            let turned = most_coherent(&times, from, to, trials).unwrap();
            assert!(
                (turned / direct.0 - 1.0).abs() < 1e-14,
                "{n}: {turned} {direct:?}"
            );
        }
        assert_eq!(most_coherent(&[1.0, 2.0], 0.0, 1.0, 4), None);
    }
}
