//! Per-segment trend removal, fused with the window multiplication.
//!
//! Removing the segment mean (or least-squares line) before windowing keeps a large offset or drift
//! from leaking through the window's side lobes into the low-frequency bins, which is what a sensor
//! bias of 1000× the noise level would otherwise do. scipy applies `scipy.signal.detrend` to each
//! segment; the same model is fitted here, in one pass for the statistics and one pass that writes
//! `(x − trend)·w` straight into the FFT input, so the segment is never copied on its own.
//!
//! A segment may straddle two input chunks of a stream, so it arrives as two slices, `head ++ tail`.

use std::fmt;
use std::str::FromStr;

use super::PsdError;

/// What to remove from each segment before windowing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Detrend {
    /// Subtract the segment mean (scipy's default, `detrend='constant'`).
    Constant,
    /// Subtract the least-squares straight line (`detrend='linear'`).
    Linear,
    /// Leave the segment as it is (`detrend=False`).
    None,
}

impl Detrend {
    /// Writes `(x_t − trend_t)·w_t` for the segment `head ++ tail` into `out[..w.len()]`.
    ///
    /// `head.len() + tail.len()` must equal `w.len()` and `out.len() >= w.len()`.
    pub(crate) fn apply_windowed(self, head: &[f64], tail: &[f64], w: &[f64], out: &mut [f64]) {
        debug_assert_eq!(head.len() + tail.len(), w.len());
        let n = w.len();
        let (w_head, w_tail) = w.split_at(head.len());
        let (out_head, rest) = out[..n].split_at_mut(head.len());
        let out_tail = rest;
        match self {
            Detrend::None => {
                window_line(head, w_head, 0.0, 0.0, 0.0, out_head);
                window_line(tail, w_tail, 0.0, 0.0, 0.0, out_tail);
            }
            Detrend::Constant => {
                let mean = (crate::stats::lane_sum(head) + crate::stats::lane_sum(tail)) / n as f64;
                window_line(head, w_head, mean, 0.0, 0.0, out_head);
                window_line(tail, w_tail, mean, 0.0, 0.0, out_tail);
            }
            Detrend::Linear => {
                // Fit x ≈ mean + slope·(t − t̄) with t̄ = (n − 1)/2; centring t keeps the two
                // coefficients uncorrelated, so each is a plain ratio with no cancellation.
                let centre = (n as f64 - 1.0) / 2.0;
                let mean = (crate::stats::lane_sum(head) + crate::stats::lane_sum(tail)) / n as f64;
                let sxt =
                    lane_moment(head, -centre) + lane_moment(tail, head.len() as f64 - centre);
                // Σ (t − t̄)² = n(n² − 1)/12; zero for n = 1, where the line is the point itself.
                let stt = n as f64 * (n as f64 * n as f64 - 1.0) / 12.0;
                let slope = if stt > 0.0 { sxt / stt } else { 0.0 };
                window_line(head, w_head, mean, slope, -centre, out_head);
                window_line(
                    tail,
                    w_tail,
                    mean,
                    slope,
                    head.len() as f64 - centre,
                    out_tail,
                );
            }
        }
    }
}

/// `out_i = (x_i − (mean + slope·(t0 + i)))·w_i`.
#[inline]
fn window_line(x: &[f64], w: &[f64], mean: f64, slope: f64, t0: f64, out: &mut [f64]) {
    if slope == 0.0 {
        for ((o, &xi), &wi) in out.iter_mut().zip(x).zip(w) {
            *o = (xi - mean) * wi;
        }
    } else {
        for (i, ((o, &xi), &wi)) in out.iter_mut().zip(x).zip(w).enumerate() {
            *o = (xi - (mean + slope * (t0 + i as f64))) * wi;
        }
    }
}

/// Number of independent partial sums (as [`crate::stats::lane_sum`]'s).
const LANES: usize = 8;

/// Σ x_i·(t0 + i).
fn lane_moment(x: &[f64], t0: f64) -> f64 {
    let mut acc = [0.0; LANES];
    let chunks = x.chunks_exact(LANES);
    let rest = chunks.remainder();
    let mut t = t0;
    for c in chunks {
        for (j, (a, v)) in acc.iter_mut().zip(c).enumerate() {
            *a += v * (t + j as f64);
        }
        t += LANES as f64;
    }
    let tail: f64 = rest
        .iter()
        .enumerate()
        .map(|(j, v)| v * (t + j as f64))
        .sum();
    acc.iter().sum::<f64>() + tail
}

impl fmt::Display for Detrend {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Detrend::Constant => "constant",
            Detrend::Linear => "linear",
            Detrend::None => "none",
        })
    }
}

impl FromStr for Detrend {
    type Err = PsdError;

    /// `constant`/`c`, `linear`/`l` (scipy's names) and `none`/`false` (scipy's `detrend=False`).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(match s.to_ascii_lowercase().as_str() {
            "constant" | "c" => Detrend::Constant,
            "linear" | "l" => Detrend::Linear,
            "none" | "false" => Detrend::None,
            _ => {
                return Err(PsdError::UnknownName {
                    what: "detrend",
                    name: s.to_owned(),
                    expected: "constant, linear, none",
                })
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn apply(d: Detrend, x: &[f64], split: usize) -> Vec<f64> {
        let w = vec![1.0; x.len()];
        let mut out = vec![f64::NAN; x.len() + 3];
        d.apply_windowed(&x[..split], &x[split..], &w, &mut out);
        out.truncate(x.len());
        out
    }

    #[test]
    fn linear_removes_a_line_exactly_wherever_the_split_is() {
        let x: Vec<f64> = (0..37).map(|t| 3.0 - 0.25 * t as f64).collect();
        for split in [0, 1, 8, 20, 37] {
            for r in apply(Detrend::Linear, &x, split) {
                assert!(r.abs() < 1e-13, "split {split}: residual {r}");
            }
        }
    }

    #[test]
    fn linear_matches_the_normal_equations() {
        // Residuals of a least-squares line are orthogonal to 1 and to t.
        let x: Vec<f64> = (0..29).map(|t| ((t * 7919) % 31) as f64).collect();
        let r = apply(Detrend::Linear, &x, 11);
        let s0: f64 = r.iter().sum();
        let s1: f64 = r.iter().enumerate().map(|(t, v)| t as f64 * v).sum();
        assert!(s0.abs() < 1e-11 && s1.abs() < 1e-10, "{s0} {s1}");
    }

    #[test]
    fn constant_removes_the_mean_and_window_is_applied() {
        let x = [1.0, 2.0, 3.0, 6.0];
        let w = [0.5, 1.0, 2.0, 0.0];
        let mut out = [0.0; 4];
        Detrend::Constant.apply_windowed(&x[..3], &x[3..], &w, &mut out);
        // mean 3: (1 − 3)·0.5, (2 − 3)·1, (3 − 3)·2, (6 − 3)·0.
        assert_eq!(out, [-1.0, -1.0, 0.0, 0.0]);
        Detrend::None.apply_windowed(&x[..1], &x[1..], &w, &mut out);
        assert_eq!(out, [0.5, 2.0, 6.0, 0.0]);
    }

    #[test]
    fn single_sample_segments_detrend_to_zero() {
        assert_eq!(apply(Detrend::Linear, &[5.0], 1), vec![0.0]);
        assert_eq!(apply(Detrend::Constant, &[5.0], 0), vec![0.0]);
    }

    #[test]
    fn names_round_trip() {
        for d in [Detrend::Constant, Detrend::Linear, Detrend::None] {
            assert_eq!(d.to_string().parse::<Detrend>().unwrap(), d);
        }
        assert_eq!("False".parse::<Detrend>().unwrap(), Detrend::None);
        assert!("quadratic".parse::<Detrend>().is_err());
    }
}
