//! Correlation between the bands of a log-binned Welch spectrum.
//!
//! Bands do not share bins, but neighbouring bins are correlated through the window (for Hann
//! without zero padding ρ²(k = 1) = 4/9) and across overlapping segments. At low frequency, where
//! every band is a single bin, neighbouring bands are thus correlated at ≈ 0.45, and treating them
//! as independent makes the intervals of the low-frequency terms (B, K) too narrow.
//!
//! For a locally white Gaussian input (what the band EDF of [`crate::psd::log_bin`] also assumes)
//! the covariance of two band means is proportional to
//! Σ_d w_d·Σ_{i∈b, j∈b′} ρ²(d, i − j), with ρ(d, k) the normalised correlation of the windowed
//! DFT coefficients of segments d apart at bins k apart and w_d the number of segment pairs at lag
//! d (Percival & Walden 1993, §6.17). ρ is computed from the window for |k| up to a few bins per
//! unit of zero padding, beyond which it is negligible for tapered windows. The mirror term
//! ρ²(d, i + j), which matters only next to DC and Nyquist, is left out.

use std::f64::consts::TAU;

use std::sync::Arc;

use crate::memo::Memo;
use crate::psd::{BinnedPsd, Psd, Window};

/// Correlation matrix of the bands `keep` of `binned` (the log-binned form of `psd`); `None` when
/// the window cannot be rebuilt from what `psd` records.
pub(crate) fn band_correlation(
    psd: &Psd,
    binned: &BinnedPsd,
    keep: &[usize],
) -> Option<Vec<Vec<f64>>> {
    if psd.nperseg == 0
        || psd.noverlap >= psd.nperseg
        || psd.nfft < psd.nperseg
        || psd.segments == 0
    {
        return None;
    }
    let kmax = (4 * psd.nfft / psd.nperseg + 4).min(64);
    let rho2 = cached_lag_table(psd, kmax)?;
    let df = psd.bin_width_hz();
    // Inclusive bin ranges of the kept bands.
    let ranges: Vec<(i64, i64)> = keep
        .iter()
        .map(|&b| {
            let first = ((binned.f_lo_hz[b] + df / 2.0) / df).round() as i64;
            (first, first + i64::from(binned.bins[b].max(1)) - 1)
        })
        .collect();
    let cov = |a: (i64, i64), b: (i64, i64)| -> f64 {
        let mut sum = 0.0;
        for (delta, r) in rho2.iter().enumerate() {
            for d in [delta as i64, -(delta as i64)] {
                if delta == 0 && d < 0 {
                    continue;
                }
                // Pairs i ∈ a, j ∈ b with j − i = d: i ∈ [a.0, a.1] ∩ [b.0 − d, b.1 − d].
                let lo = a.0.max(b.0 - d);
                let hi = a.1.min(b.1 - d);
                if hi >= lo {
                    sum += (hi - lo + 1) as f64 * r;
                }
            }
        }
        sum
    };
    let var: Vec<f64> = ranges.iter().map(|&r| cov(r, r)).collect();
    let n = ranges.len();
    let mut out = vec![vec![0.0; n]; n];
    for i in 0..n {
        out[i][i] = 1.0;
        for j in 0..i {
            let gap = ranges[i].0 - ranges[j].1;
            let c = if gap > kmax as i64 {
                0.0
            } else {
                cov(ranges[j], ranges[i]) / (var[i] * var[j]).sqrt()
            };
            out[i][j] = c;
            out[j][i] = c;
        }
    }
    Some(out)
}

/// What a lag table depends on: the window, the segmenting and the transform length.
#[derive(Clone, PartialEq)]
struct LagKey {
    window: Window,
    nperseg: usize,
    noverlap: usize,
    nfft: usize,
    segments: usize,
    kmax: usize,
}

/// [`lag_table`] for `psd`'s plan, computed once per plan. The loop fits one spectrum dozens of
/// times (a profile over a Gauss–Markov correlation time, a resonance's f₀ and Q), and the table
/// is O(segment length) cosines and products per lag: with hour-long segments it was half of the
/// loop's time, all of it recomputing the same numbers.
fn cached_lag_table(psd: &Psd, kmax: usize) -> Option<Arc<Vec<f64>>> {
    static TABLES: Memo<LagKey, Arc<Vec<f64>>> = Memo::new(8);
    let key = LagKey {
        window: psd.window.clone(),
        nperseg: psd.nperseg,
        noverlap: psd.noverlap,
        nfft: psd.nfft,
        segments: psd.segments,
        kmax,
    };
    TABLES.get_or(key, || {
        let window = psd.window.coefficients(psd.nperseg).ok()?;
        let step = psd.nperseg - psd.noverlap;
        Some(Arc::new(lag_table(
            &window,
            step,
            psd.nfft,
            psd.segments,
            kmax,
        )))
    })
}

/// Σ_d w_d·ρ²(d, k) for k = 0..=kmax: the covariance of two single-bin estimates k bins apart, up
/// to a common factor.
fn lag_table(window: &[f64], step: usize, nfft: usize, segments: usize, kmax: usize) -> Vec<f64> {
    let n = window.len();
    let sum_w2: f64 = window.iter().map(|w| w * w).sum();
    let mut table = vec![0.0; kmax + 1];
    let mut d = 0;
    while d < segments && d * step < n {
        let shift = d * step;
        let weight = if d == 0 { segments } else { 2 * (segments - d) } as f64;
        for (k, t) in table.iter_mut().enumerate() {
            let w = TAU * k as f64 / nfft as f64;
            let (mut re, mut im) = (0.0, 0.0);
            // Phase advanced by rotation, renormalised every 1024 steps against drift.
            let (sin_w, cos_w) = w.sin_cos();
            let (mut s, mut c) = (0.0f64, 1.0f64);
            for t_idx in 0..n - shift {
                let p = window[t_idx] * window[t_idx + shift];
                re += p * c;
                im -= p * s;
                let (ns, nc) = (s * cos_w + c * sin_w, c * cos_w - s * sin_w);
                s = ns;
                c = nc;
                if t_idx % 1024 == 1023 {
                    let a = w * (t_idx + 1) as f64;
                    (s, c) = a.sin_cos();
                }
            }
            *t += weight * (re * re + im * im) / (sum_w2 * sum_w2);
        }
        d += 1;
    }
    table
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hann_single_segment_neighbour_correlation() {
        // One periodic Hann segment: ρ(0, 1) = 2/3, ρ(0, 2) = 1/6, ρ(0, 3) = 0, so two single-bin
        // bands one apart correlate at ρ² = 4/9.
        let n = 64;
        let w: Vec<f64> = (0..n)
            .map(|i| (std::f64::consts::PI * i as f64 / n as f64).sin().powi(2))
            .collect();
        let t = lag_table(&w, n, n, 1, 4);
        assert!((t[1] / t[0] - 4.0 / 9.0).abs() < 1e-12, "{t:?}");
        assert!((t[2] / t[0] - 1.0 / 36.0).abs() < 1e-12);
        assert!(t[3] / t[0] < 1e-20);
    }
}
