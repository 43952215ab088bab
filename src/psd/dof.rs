//! Equivalent degrees of freedom (EDF) of Welch estimates, per bin and per band of bins.
//!
//! A fit that weights spectrum points needs each point's variance. For a locally white, Gaussian
//! input the variance of any average of periodogram values follows from the correlation between the
//! windowed DFT coefficients involved (Percival & Walden, *Spectral Analysis for Physical
//! Applications*, 1993, §6.17; Welch 1967). For segments `d` apart (start offsets differing by
//! d·step) and bins `k` apart,
//!
//! ```text
//! ρ(d, k) = |Σ_t w_t·w_{t+d·step}·e^{−2πikt/nfft}| / Σ_t w_t²,
//! ```
//!
//! and for real Gaussian data Cov(|X_{s,i}|², |X_{s+d,j}|²) = E²·(ρ²(d, i−j) + ρ²(d, i+j)): the first
//! term is the usual overlap/leakage correlation, the second the mirror-image term that makes DC
//! and Nyquist χ²₁ instead of χ²₂. The mean over M segments and a band B of K bins then has
//!
//! ```text
//! ν = 2·E²/Var = 2·(M·K)² / Σ_{d=−(M−1)}^{M−1} (M−|d|) · Σ_{i,j∈B} [ρ²(|d|, i−j) + ρ²(|d|, i+j)].
//! ```
//!
//! With K = 1 and an interior bin this is Welch's / Percival & Walden's (eq. 292b) formula
//! ν = 2M / (1 + 2 Σ_{d=1}^{M−1} (1 − d/M) ρ²(d, 0)); with no overlap and no window correlation it
//! is the textbook 2·K·M. It accounts for overlap, window shape and zero padding exactly (for white
//! noise) instead of by a rule of thumb, which matters because zero padding and tapering make
//! adjacent bins strongly correlated: averaging K bins of a Hann spectrum gains K/1.94, not K.
//!
//! Median averaging: ν is multiplied by the exact efficiency of the bias-corrected median of M
//! independent χ²₂ values ([`median_efficiency`]), which is exact without overlap and an
//! approximation with it. Detrending, which suppresses the lowest one or two bins, is not modelled.
//!
//! Cost: one FFT of length nfft per overlapping lag, at most min(M, ⌈nperseg/step⌉) of them, so
//! never more than the Welch estimate itself; memory O(nfft).

use std::sync::Arc;

use realfft::{RealFftPlanner, RealToComplex};

use super::median::median_efficiency;
use super::Average;

/// Window, layout and averaging of a Welch estimate: all the EDF depends on.
pub(crate) struct DofInputs<'a> {
    pub window: &'a [f64],
    pub step: usize,
    pub nfft: usize,
    pub segments: usize,
    pub average: Average,
    /// A forward FFT of length nfft if one is at hand (planning one costs about as much as a few
    /// transforms); otherwise one is planned.
    pub fft: Option<Arc<dyn RealToComplex<f64>>>,
}

impl DofInputs<'_> {
    /// Calls `f(weight, rho2)` for every lag d ≥ 0 whose segments overlap, with weight the number
    /// of ordered segment pairs at that lag (M for d = 0, 2(M − d) otherwise) and `rho2[k]` =
    /// ρ²(d, k) for k = 0..=nfft/2 (ρ² is even and nfft-periodic in k; see [`fold`]).
    fn for_each_lag(&self, mut f: impl FnMut(f64, &[f64])) {
        let n = self.window.len();
        let m = self.segments;
        if m == 0 || n == 0 {
            return;
        }
        let sum_w2: f64 = self.window.iter().map(|w| w * w).sum();
        let fft = match &self.fft {
            Some(fft) if fft.len() == self.nfft => Arc::clone(fft),
            _ => RealFftPlanner::<f64>::new().plan_fft_forward(self.nfft),
        };
        let mut input = fft.make_input_vec();
        let mut spectrum = fft.make_output_vec();
        let mut scratch = fft.make_scratch_vec();
        let mut rho2 = vec![0.0; spectrum.len()];
        let mut d = 0;
        while d < m && d * self.step < n {
            let shift = d * self.step;
            input.fill(0.0);
            for (t, v) in input.iter_mut().take(n - shift).enumerate() {
                *v = self.window[t] * self.window[t + shift];
            }
            // Lengths come from the same plan, so this cannot fail.
            fft.process_with_scratch(&mut input, &mut spectrum, &mut scratch)
                .expect("buffers sized by the FFT plan");
            for (r, x) in rho2.iter_mut().zip(&spectrum) {
                *r = (x.re * x.re + x.im * x.im) / (sum_w2 * sum_w2);
            }
            let weight = if d == 0 { m } else { 2 * (m - d) } as f64;
            f(weight, &rho2);
            d += 1;
        }
    }

    /// Multiplier for median averaging (1 for the mean).
    fn average_efficiency(&self) -> f64 {
        match self.average {
            Average::Mean => 1.0,
            Average::Median => median_efficiency(self.segments),
        }
    }

    /// EDF of each one-sided bin k = 0..=nfft/2.
    pub(crate) fn per_bin(&self) -> Vec<f64> {
        let bins = self.nfft / 2 + 1;
        let mut den = vec![0.0; bins];
        self.for_each_lag(|weight, rho2| {
            for (i, d) in den.iter_mut().enumerate() {
                *d += weight * (rho2[0] + rho2[fold(2 * i, self.nfft)]);
            }
        });
        let m = self.segments as f64;
        let eff = self.average_efficiency();
        den.iter().map(|d| eff * 2.0 * m * m / d).collect()
    }

    /// EDF of the mean of each band of consecutive bins `bands[b] = (first, last)` (inclusive).
    pub(crate) fn per_band(&self, bands: &[(usize, usize)]) -> Vec<f64> {
        let mut den = vec![0.0; bands.len()];
        self.for_each_lag(|weight, rho2| {
            for (d, &(i0, i1)) in den.iter_mut().zip(bands) {
                *d += weight * band_pair_sum(rho2, self.nfft, i0, i1);
            }
        });
        let m = self.segments as f64;
        let eff = self.average_efficiency();
        den.iter()
            .zip(bands)
            .map(|(d, &(i0, i1))| {
                let mk = m * (i1 - i0 + 1) as f64;
                eff * 2.0 * mk * mk / d
            })
            .collect()
    }
}

/// Σ_{i,j ∈ [i0, i1]} ρ²(i − j) + ρ²(i + j), grouping the pairs by difference and by sum.
fn band_pair_sum(rho2: &[f64], nfft: usize, i0: usize, i1: usize) -> f64 {
    let k = i1 - i0 + 1;
    let diff: f64 = rho2[0] * k as f64
        + 2.0
            * (1..k)
                .map(|j| (k - j) as f64 * rho2[fold(j, nfft)])
                .sum::<f64>();
    let centre = i0 + i1;
    let sum: f64 = (2 * i0..=2 * i1)
        .map(|s| (k - s.abs_diff(centre)) as f64 * rho2[fold(s, nfft)])
        .sum();
    diff + sum
}

/// Index into a one-sided table of a quantity that is even and nfft-periodic in k.
fn fold(k: usize, nfft: usize) -> usize {
    let k = k % nfft;
    k.min(nfft - k)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn inputs(window: &[f64], step: usize, nfft: usize, segments: usize) -> DofInputs<'_> {
        DofInputs {
            window,
            step,
            nfft,
            segments,
            average: Average::Mean,
            fft: None,
        }
    }

    #[test]
    fn boxcar_without_overlap_is_2km() {
        let w = vec![1.0; 16];
        let dof = inputs(&w, 16, 16, 5);
        let per_bin = dof.per_bin();
        assert!((per_bin[0] - 5.0).abs() < 1e-12, "DC is chi2_1 per segment");
        assert!(
            (per_bin[8] - 5.0).abs() < 1e-12,
            "Nyquist is chi2_1 per segment"
        );
        for v in &per_bin[1..8] {
            assert!((v - 10.0).abs() < 1e-12, "{v}");
        }
        let bands = dof.per_band(&[(1, 3), (4, 7)]);
        assert!(
            (bands[0] - 30.0).abs() < 1e-11 && (bands[1] - 40.0).abs() < 1e-11,
            "{bands:?}"
        );
    }

    #[test]
    fn hann_half_overlap_matches_welchs_formula() {
        // Periodic Hann, 50 % overlap: ρ(1, 0) = 1/6 exactly, so ν = 2M/(1 + 2(1 − 1/M)/36).
        let n = 64;
        let w: Vec<f64> = (0..n)
            .map(|i| (std::f64::consts::PI * i as f64 / n as f64).sin().powi(2))
            .collect();
        let m = 9.0;
        let expected = 2.0 * m / (1.0 + 2.0 * (1.0 - 1.0 / m) / 36.0);
        let per_bin = inputs(&w, 32, 64, 9).per_bin();
        assert!(
            (per_bin[10] - expected).abs() < 1e-10,
            "{} vs {expected}",
            per_bin[10]
        );
    }

    #[test]
    fn hann_band_gains_less_than_k() {
        // One Hann segment: bins k apart correlate with ρ(0,1) = 2/3, ρ(0,2) = 1/6, so a wide band
        // of K bins has ν → 2K/(1 + 2·(4/9 + 1/36)) = 2K/1.944.
        let n = 256;
        let w: Vec<f64> = (0..n)
            .map(|i| (std::f64::consts::PI * i as f64 / n as f64).sin().powi(2))
            .collect();
        let k = 100;
        let nu = inputs(&w, n, n, 1).per_band(&[(10, 10 + k - 1)])[0];
        let k = k as f64;
        let exact = 2.0 * k * k / (k + 2.0 * ((k - 1.0) * 4.0 / 9.0 + (k - 2.0) / 36.0));
        assert!((nu - exact).abs() < 1e-9, "{nu} vs {exact}");
    }
}
