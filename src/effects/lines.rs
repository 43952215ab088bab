//! Narrow excesses in the raw Welch spectrum over the fitted model: where a sinusoid (a line) or a
//! resonance lives. The log-binned spectrum the base fit uses smears a line over a band; the raw
//! bins do not.
//!
//! Each bin's ratio to the model, times its EDF, is χ²_ν under the model; a bin is in excess when
//! its tail probability times the number of bins searched is below `family_p` (Bonferroni, so a
//! pure-noise spectrum of 10⁵ bins raises a false line with probability ≤ `family_p`). Neighbouring
//! excess bins (a line's window main lobe and sidelobes, a resonance's width) form one group.

use crate::stats::chi2_sf;
use serde::Serialize;

use crate::psd::Psd;

/// One group of contiguous excess bins.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Excess {
    /// Frequency of the strongest bin, refined by a parabola through its neighbours' log power.
    pub freq_hz: f64,
    pub f_lo_hz: f64,
    pub f_hi_hz: f64,
    pub bins: usize,
    /// Peak measured/model ratio.
    pub peak_ratio: f64,
    /// Power above the model integrated over the group (one-sided, unit²).
    pub excess_power: f64,
    /// Half-power width of the excess, Hz (at least one bin).
    pub width_hz: f64,
    /// Bonferroni-corrected p-value of the strongest bin.
    pub p_value: f64,
}

/// Groups of bins of `psd` (one-sided density) above `model_one_sided(f)`, strongest first. Bins
/// outside [`min_freq_hz`, `max_freq_hz`], DC and Nyquist are not searched.
pub fn find_excess(
    psd: &Psd,
    model_one_sided: impl Fn(f64) -> f64,
    min_freq_hz: f64,
    max_freq_hz: f64,
    family_p: f64,
) -> Vec<Excess> {
    let n = psd.freq_hz.len();
    if n < 4 {
        return Vec::new();
    }
    let searched: Vec<usize> = (1..n - 1)
        .filter(|&k| psd.freq_hz[k] >= min_freq_hz && psd.freq_hz[k] <= max_freq_hz)
        .collect();
    let m = searched.len().max(1) as f64;
    let model: Vec<f64> = psd.freq_hz.iter().map(|&f| model_one_sided(f)).collect();
    let ratio = |k: usize| psd.value[k] / model[k];
    let p_of = |k: usize| {
        let nu = psd.dof[k].max(1.0);
        (chi2_sf(ratio(k) * nu, nu) * m).min(1.0)
    };
    let significant: Vec<bool> = (0..n)
        .map(|k| {
            searched.binary_search(&k).is_ok()
                && model[k] > 0.0
                && model[k].is_finite()
                && p_of(k) < family_p
        })
        .collect();
    let df = psd.bin_width_hz();
    let mut groups = Vec::new();
    let mut k = 0;
    while k < n {
        if !significant[k] {
            k += 1;
            continue;
        }
        // Extend over gaps of one bin (a sidelobe null).
        let start = k;
        let mut end = k;
        while end + 1 < n && (significant[end + 1] || (end + 2 < n && significant[end + 2])) {
            end += 1;
        }
        let peak = (start..=end)
            .max_by(|&a, &b| ratio(a).total_cmp(&ratio(b)))
            .unwrap_or(start);
        let excess: Vec<f64> = (start..=end)
            .map(|i| (psd.value[i] - model[i]).max(0.0))
            .collect();
        let top = excess.iter().cloned().fold(0.0, f64::max);
        let half = excess.iter().filter(|&&e| e >= top / 2.0).count().max(1);
        let refined = if peak > 0 && peak + 1 < n {
            let (a, b, c) = (
                psd.value[peak - 1].ln(),
                psd.value[peak].ln(),
                psd.value[peak + 1].ln(),
            );
            let d = a - 2.0 * b + c;
            let shift = if d < 0.0 { 0.5 * (a - c) / d } else { 0.0 };
            psd.freq_hz[peak] + shift.clamp(-0.5, 0.5) * df
        } else {
            psd.freq_hz[peak]
        };
        groups.push(Excess {
            freq_hz: refined,
            f_lo_hz: psd.freq_hz[start],
            f_hi_hz: psd.freq_hz[end],
            bins: end - start + 1,
            peak_ratio: ratio(peak),
            excess_power: excess.iter().sum::<f64>() * df,
            width_hz: half as f64 * df,
            p_value: p_of(peak),
        });
        k = end + 1;
    }
    groups.sort_by(|a, b| b.excess_power.total_cmp(&a.excess_power));
    groups
}
