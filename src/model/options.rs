//! Options of the noise-model fits.

use crate::avar::Confidence;

use super::{Criterion, LowPass, Term};

/// How to fit. [`FitOptions::default`] allows all five terms, uses BIC, 1σ intervals, the default
/// spectrum band and correlated Allan points.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FitOptions {
    /// Terms that may enter the model.
    pub terms: Vec<Term>,
    pub criterion: Criterion,
    /// Two-sided probability of the coefficient intervals.
    pub confidence: Confidence,
    /// Spectrum fit: lowest band centre used, Hz. `None`: 4·fs/nperseg, above the bins that the
    /// per-segment detrend and the window's leakage bias (with Hann and constant detrend bin 1
    /// reads 1/6 low for white noise; steep spectra leak into bins 2–3).
    pub min_freq_hz: Option<f64>,
    /// Spectrum fit: highest band centre used, Hz. `None`: up to Nyquist (the Nyquist bin itself
    /// is never used: one-sided spectra do not double it).
    pub max_freq_hz: Option<f64>,
    /// Allan fit: model the correlation between the variances at neighbouring τ (see
    /// [`fit_avar`](super::fit_avar)). Off treats them as independent, which makes the intervals
    /// too narrow.
    pub correlated_points: bool,
    /// Allan fit: shortest τ used, s. `None`: every τ. Set per channel from the detected sensor
    /// bandwidth ([`crate::model::detect_bandwidth`]) where a low-pass filter distorts the
    /// shortest τ.
    pub min_tau_s: Option<f64>,
    /// Look for the sensor's low-pass roll-off before fitting and fit only inside the band where
    /// the recording follows the IEEE model ([`crate::model::detect_bandwidth`]).
    pub detect_bandwidth: bool,
    /// The sensor's low-pass response, when one was detected (set with the band by
    /// [`crate::model::Bandwidth::restrict`]): the spectrum fit's terms (quantisation's
    /// excepted) are multiplied by it, the Allan fit's N column by the share of white noise it
    /// leaves, and the residual loop's line search runs up to its corner with the model
    /// multiplied by it, for narrow lines only.
    pub lowpass: Option<LowPass>,
    /// Count the choice of terms as uncertain: each kept term's value averaged over the competing
    /// subsets with their BIC weights and its interval widened by their spread (see
    /// [`select`](super::select)). Off only for the many fits of a profile over an effect's shape
    /// parameters, which use scores and not the estimates.
    pub selection_uncertainty: bool,
    /// Allowed terms every candidate subset must contain: the rate ramp where the time series
    /// determines one that the Allan curve alone cannot tell from a random walk (the residual
    /// loop's last check, [`crate::effects::ramp`]). Empty: the criterion chooses every term.
    pub required: Vec<Term>,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            terms: Term::ALL.to_vec(),
            criterion: Criterion::Bic,
            confidence: Confidence::OneSigma,
            min_freq_hz: None,
            max_freq_hz: None,
            correlated_points: true,
            min_tau_s: None,
            detect_bandwidth: true,
            lowpass: None,
            selection_uncertainty: true,
            required: Vec::new(),
        }
    }
}

impl FitOptions {
    /// Bit mask of the allowed terms.
    pub(crate) fn mask(&self) -> u8 {
        self.terms.iter().fold(0, |m, t| m | (1 << t.index()))
    }

    /// Bit mask of the required terms that are allowed.
    pub(crate) fn required_mask(&self) -> u8 {
        self.required.iter().fold(0, |m, t| m | (1 << t.index())) & self.mask()
    }
}
