//! The result type, `Psd`, and its assembly from averaged raw |X_k|² values.

use super::dof::DofInputs;
use super::scaling::fold_one_sided;
use super::{Average, Detrend, Scaling, WelchPlan, Window};

/// A one-sided Welch spectrum of one channel: bins k = 0..=nfft/2 at f_k = k·fs/nfft, every bin
/// except DC and (for even nfft) Nyquist doubled, as scipy's default `return_onesided=True`.
///
/// Carries the options that made it, so that it can be reported and log-binned (the band EDF
/// depends on the window and overlap) without the plan.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Psd {
    pub freq_hz: Vec<f64>,
    /// unit²/Hz for `Scaling::Density`, unit² for `Scaling::Spectrum`.
    pub value: Vec<f64>,
    pub scaling: Scaling,
    /// Number of segments averaged.
    pub segments: usize,
    pub nperseg: usize,
    pub noverlap: usize,
    pub nfft: usize,
    pub rate_hz: f64,
    /// Equivalent noise bandwidth of one bin, fs·Σw²/(Σw)² (Hz): converts a spectrum reading to a
    /// density and back.
    pub enbw_hz: f64,
    /// Equivalent degrees of freedom of each bin for white Gaussian input, from Welch's formula
    /// extended to DC/Nyquist (see `dof.rs`): value_k·ν_k/E[value_k] ~ χ²(ν_k), so a fit can weight
    /// bin k by ν_k/(2·value_k²).
    pub dof: Vec<f64>,
    pub window: Window,
    pub detrend: Detrend,
    pub average: Average,
}

impl Psd {
    /// Builds the spectrum from `raw[k]`, the mean (or bias-corrected median) over `segments`
    /// segments of |X_k|², k = 0..=nfft/2, and the per-bin EDF from [`Psd::bin_dof`].
    pub(crate) fn from_averaged(
        plan: &WelchPlan,
        rate_hz: f64,
        segments: usize,
        raw: Vec<f64>,
        dof: Vec<f64>,
    ) -> Psd {
        let cfg = plan.config();
        let nfft = plan.nfft();
        let mut value = raw;
        let scale = cfg.scaling.factor(rate_hz, plan.sum_w(), plan.sum_w2());
        for v in &mut value {
            *v *= scale;
        }
        fold_one_sided(&mut value, nfft);
        // numpy's rfftfreq: k · (1/(nfft·d)) with d = 1/fs.
        let df = 1.0 / (nfft as f64 * (1.0 / rate_hz));
        let freq_hz = (0..value.len()).map(|k| k as f64 * df).collect();
        Psd {
            freq_hz,
            value,
            scaling: cfg.scaling,
            segments,
            nperseg: plan.nperseg(),
            noverlap: plan.noverlap(),
            nfft,
            rate_hz,
            enbw_hz: plan.enbw_hz(rate_hz),
            dof,
            window: cfg.window.clone(),
            detrend: cfg.detrend,
            average: cfg.average,
        }
    }

    /// Per-bin EDF of a `segments`-segment estimate with this plan; the same for every channel, so
    /// computed once per accumulator.
    pub(crate) fn bin_dof(plan: &WelchPlan, segments: usize) -> Vec<f64> {
        DofInputs {
            window: plan.window(),
            step: plan.step(),
            nfft: plan.nfft(),
            segments,
            average: plan.config().average,
            fft: Some(plan.shared_fft()),
        }
        .per_bin()
    }

    /// Frequency resolution fs/nfft (Hz).
    pub fn bin_width_hz(&self) -> f64 {
        self.rate_hz / self.nfft as f64
    }
}
