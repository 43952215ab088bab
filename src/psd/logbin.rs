//! Log-frequency binning: a low-variance spectrum for plotting and for fitting noise models.
//!
//! A Welch spectrum has constant resolution Δf, so on a log axis the top decade holds 90 % of the
//! points and each is as noisy as the lowest one. Averaging the bins that fall into bands of
//! 1/`bins_per_decade` decade gives roughly even spacing on the log axis and a variance that falls
//! with frequency, as a fit in the log domain wants.
//!
//! Bands are aligned to decades (edges at 10^(j/bins_per_decade) Hz), so spectra of different
//! recordings are binned alike. At low frequency the bands are narrower than Δf and most hold no
//! bin; there each bin is kept on its own. DC is dropped (it holds the removed trend, not noise), and
//! so is the Nyquist bin of an even nfft: one-sided spectra (scipy's convention) do not double it,
//! so for broadband noise it reads half the density and would bias the top band low.
//!
//! Not corrected: the per-segment detrend also removes part of the power of the lowest bins (with
//! Hann and constant detrend, bin 1 reads 1/6 low for white noise; linear detrend reaches further).
//! Those bins are kept, single, as scipy reports them; a fit may skip them.
//!
//! Degrees of freedom: the exact EDF of the band mean for white Gaussian input (see `dof.rs`),
//! 2·K·M / (correction for the correlation between overlapping segments and between neighbouring
//! bins that the window and zero padding create). Assuming independent bins (2·K·M) would overstate
//! a Hann-window band's EDF almost twofold and make a fit overconfident.

use super::dof::DofInputs;
use super::Psd;

/// A log-binned spectrum. Output bin b averages `bins[b]` consecutive input bins.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct BinnedPsd {
    /// Arithmetic mean of the averaged bins' frequencies.
    pub freq_hz: Vec<f64>,
    /// Lower edge of the span the averaged bins cover: first bin's frequency − Δf/2. Consecutive
    /// output bins tile the axis, so value·(f_hi − f_lo) sums to the power in the band.
    pub f_lo_hz: Vec<f64>,
    /// Upper edge: last bin's frequency + Δf/2.
    pub f_hi_hz: Vec<f64>,
    /// Arithmetic mean of the averaged bins' values (same unit as the `Psd`).
    pub value: Vec<f64>,
    /// Number of input bins averaged.
    pub bins: Vec<u32>,
    /// Equivalent degrees of freedom of `value` (value·dof/E[value] ~ χ²(dof)).
    pub dof: Vec<f64>,
}

/// Averages the bins of `psd` (DC and Nyquist excluded) in bands of 1/`bins_per_decade` decade.
/// `bins_per_decade = 0` keeps every bin on its own (DC and Nyquist still dropped).
pub fn log_bin(psd: &Psd, bins_per_decade: u32) -> BinnedPsd {
    log_bin_resolving(psd, bins_per_decade, f64::NAN, f64::NAN)
}

/// [`log_bin`], except that the bins from `fine_lo_hz` to `fine_hi_hz` are kept on their own: a
/// feature narrower than a band (a resonance of a few bins' width) keeps its shape there, where
/// averaged into two or three bands its centre and width could trade against each other.
pub fn log_bin_resolving(
    psd: &Psd,
    bins_per_decade: u32,
    fine_lo_hz: f64,
    fine_hi_hz: f64,
) -> BinnedPsd {
    let mut n = psd.freq_hz.len().min(psd.value.len());
    if psd.nfft.is_multiple_of(2) && n == psd.nfft / 2 + 1 {
        n -= 1; // the Nyquist bin
    }
    let bands = group(&psd.freq_hz[..n], bins_per_decade, (fine_lo_hz, fine_hi_hz));
    let half = psd.bin_width_hz() / 2.0;
    let mut out = BinnedPsd {
        freq_hz: Vec::with_capacity(bands.len()),
        f_lo_hz: Vec::with_capacity(bands.len()),
        f_hi_hz: Vec::with_capacity(bands.len()),
        value: Vec::with_capacity(bands.len()),
        bins: Vec::with_capacity(bands.len()),
        dof: band_dof(psd, &bands),
    };
    for &(i0, i1) in &bands {
        let k = (i1 - i0 + 1) as f64;
        out.freq_hz
            .push(psd.freq_hz[i0..=i1].iter().sum::<f64>() / k);
        out.value.push(psd.value[i0..=i1].iter().sum::<f64>() / k);
        out.f_lo_hz.push(psd.freq_hz[i0] - half);
        out.f_hi_hz.push(psd.freq_hz[i1] + half);
        out.bins
            .push(u32::try_from(i1 - i0 + 1).unwrap_or(u32::MAX));
    }
    out
}

/// How many times a likelihood that takes single neighbouring bins of `psd` as independent
/// overstates their information: a run of M bins in the middle of the spectrum holds
/// M·EDF(one bin)/EDF(run) times fewer independent values than it has bins (1.94 for a periodic
/// Hann window without zero padding: neighbouring bins' powers correlate by 4/9). A parameter
/// whose effect spreads over many such bins (a resonance's centre and width, over a half-power
/// width of ~16 bins) has its profile likelihood's curvature overstated by about this factor; a
/// band mean ([`BinnedPsd::dof`]) already accounts for it. 1 where the layout is not known.
pub fn neighbour_redundancy(psd: &Psd) -> f64 {
    const RUN: usize = 64;
    let n = psd.freq_hz.len().min(psd.value.len());
    let mid = n / 4;
    if mid == 0 || mid + RUN >= n {
        return 1.0;
    }
    let dof = band_dof(psd, &[(mid, mid), (mid, mid + RUN - 1)]);
    let factor = RUN as f64 * dof[0] / dof[1];
    if factor.is_finite() {
        factor.max(1.0)
    } else {
        1.0
    }
}

/// Runs of consecutive bins k ≥ 1 that share the band ⌊bins_per_decade·log10 f_k⌋, as inclusive
/// index ranges; bins inside `fine` (lo, hi in Hz; NaN: none) each on their own. Bins at f ≤ 0
/// (DC) are skipped.
fn group(freq_hz: &[f64], bins_per_decade: u32, fine: (f64, f64)) -> Vec<(usize, usize)> {
    let band = |k: usize| -> (bool, i64) {
        if bins_per_decade == 0 || (fine.0 <= freq_hz[k] && freq_hz[k] <= fine.1) {
            (true, k as i64)
        } else {
            (
                false,
                (f64::from(bins_per_decade) * freq_hz[k].log10()).floor() as i64,
            )
        }
    };
    let mut bands: Vec<(usize, usize)> = Vec::new();
    let mut current = None;
    for (k, &f) in freq_hz.iter().enumerate() {
        // Written so that NaN is skipped too.
        if f.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            continue;
        }
        let j = band(k);
        match bands.last_mut() {
            Some(last) if current == Some(j) && last.1 + 1 == k => last.1 = k,
            _ => bands.push((k, k)),
        }
        current = Some(j);
    }
    bands
}

/// Band EDF from the window and layout recorded in `psd`. Should those fields have been edited
/// into something inconsistent, falls back to the sum of the per-bin EDF (an upper bound) rather
/// than failing.
fn band_dof(psd: &Psd, bands: &[(usize, usize)]) -> Vec<f64> {
    let window = psd.window.coefficients(psd.nperseg).ok();
    let consistent = psd.nperseg > 0 && psd.noverlap < psd.nperseg && psd.nfft >= psd.nperseg;
    match window {
        Some(window) if consistent && psd.segments > 0 => DofInputs {
            window: &window,
            step: psd.nperseg - psd.noverlap,
            nfft: psd.nfft,
            segments: psd.segments,
            average: psd.average,
            fft: None,
        }
        .per_band(bands),
        _ => bands
            .iter()
            .map(|&(i0, i1)| psd.dof.get(i0..=i1).map_or(f64::NAN, |d| d.iter().sum()))
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn low_bins_stay_single_and_high_bins_group() {
        // Δf = 1 Hz, 10 bands per decade: up to ~10 Hz each bin is alone (bands narrower than
        // Δf), from there bands of 10^0.1 ≈ 1.26× collect several bins.
        let f: Vec<f64> = (0..=100).map(f64::from).collect();
        let bands = group(&f, 10, (f64::NAN, f64::NAN));
        // Band edges 10^(j/10): [3.98, 5.01) holds 4 and 5; [79.4, 100) holds 80..=99.
        assert_eq!(&bands[..4], &[(1, 1), (2, 2), (3, 3), (4, 5)]);
        assert_eq!(&bands[bands.len() - 2..], &[(80, 99), (100, 100)]);
        let covered: usize = bands.iter().map(|(a, b)| b - a + 1).sum();
        assert_eq!(covered, 100, "every bin but DC in exactly one band");
        for w in bands.windows(2) {
            assert_eq!(w[0].1 + 1, w[1].0);
        }
    }

    #[test]
    fn bins_inside_the_fine_window_stay_single() {
        let f: Vec<f64> = (0..=100).map(f64::from).collect();
        let bands = group(&f, 10, (82.0, 84.0));
        // [79.4, 100) is split: 80–81 grouped, 82, 83, 84 alone, 85–99 grouped.
        assert_eq!(
            &bands[bands.len() - 6..],
            &[(80, 81), (82, 82), (83, 83), (84, 84), (85, 99), (100, 100)]
        );
        let covered: usize = bands.iter().map(|(a, b)| b - a + 1).sum();
        assert_eq!(covered, 100);
    }

    /// The redundancy against the one measured on white noise: the variance of the sum of 64
    /// neighbouring bins of a Welch spectrum over many records, divided by the sum of their
    /// variances. Hann, 50 % overlap: 1.94 from the window alone; the overlap adds little.
    #[test]
    fn neighbour_redundancy_matches_white_noise() {
        use crate::psd::{welch, WelchConfig};
        use crate::sim::rng::Rng;
        let cfg = WelchConfig::new(512);
        let (records, len) = (400, 512 * 16);
        let mut rng = Rng::new(20261126);
        let (lo, hi) = (80, 144);
        let mut sums = Vec::with_capacity(records);
        let mut per_bin = vec![(0.0, 0.0); hi - lo];
        let mut factor = 0.0;
        for _ in 0..records {
            let x = rng.gauss_vec(len);
            let psd = welch(&x, 1.0, &cfg).unwrap();
            factor = neighbour_redundancy(&psd);
            sums.push(psd.value[lo..hi].iter().sum::<f64>());
            for (acc, v) in per_bin.iter_mut().zip(&psd.value[lo..hi]) {
                *acc = (acc.0 + v, acc.1 + v * v);
            }
        }
        let r = records as f64;
        let var = |s: f64, s2: f64| s2 / r - (s / r).powi(2);
        let sum_mean = sums.iter().sum::<f64>() / r;
        let var_sum = sums.iter().map(|s| (s - sum_mean).powi(2)).sum::<f64>() / r;
        let sum_var: f64 = per_bin.iter().map(|&(s, s2)| var(s, s2)).sum();
        let measured = var_sum / sum_var;
        // 400 records: the ratio of two variance estimates scatters by about √(2/400) = 7 %.
        assert!((1.8..2.1).contains(&factor), "computed {factor}");
        assert!(
            (measured / factor - 1.0).abs() < 0.2,
            "measured {measured}, computed {factor}"
        );
    }

    #[test]
    fn zero_bins_per_decade_keeps_every_bin() {
        let f = [0.0, 0.5, 1.0, 1.5];
        assert_eq!(
            group(&f, 0, (f64::NAN, f64::NAN)),
            vec![(1, 1), (2, 2), (3, 3)]
        );
    }
}
