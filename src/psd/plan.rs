//! Welch options (`WelchConfig`, plain values a CLI can fill in) and the validated, built plan
//! (`WelchPlan`: window coefficients, FFT plan, step), made once before any data is read so that a
//! bad option fails in milliseconds rather than after an hour of input.

use std::fmt;
use std::sync::Arc;

use realfft::{RealFftPlanner, RealToComplex};

use super::{Average, Detrend, PsdError, Scaling, Window};

/// Largest FFT length accepted: 2²⁸ points (2 GiB per f64 buffer). Beyond that the allocation, not
/// the configuration, would fail, and an error is better than an abort.
pub const MAX_NFFT: usize = 1 << 28;

/// Welch options, with scipy.signal.welch's meaning and defaults (boundary=None, padded=False,
/// return_onesided=True).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct WelchConfig {
    pub window: Window,
    /// Samples per segment (≥ 1).
    pub nperseg: usize,
    /// Samples shared by consecutive segments (< nperseg); `None` means nperseg/2.
    pub noverlap: Option<usize>,
    /// FFT length (≥ nperseg; the segment is zero-padded); `None` means nperseg.
    pub nfft: Option<usize>,
    pub detrend: Detrend,
    pub scaling: Scaling,
    pub average: Average,
}

impl WelchConfig {
    /// scipy's defaults for the given segment length: Hann, 50 % overlap, constant detrend,
    /// density, mean.
    pub fn new(nperseg: usize) -> Self {
        WelchConfig {
            window: Window::Hann,
            nperseg,
            noverlap: None,
            nfft: None,
            detrend: Detrend::Constant,
            scaling: Scaling::Density,
            average: Average::Mean,
        }
    }

    /// Checks the options as scipy does (nperseg ≥ 1, noverlap < nperseg, nfft ≥ nperseg, custom
    /// window of length nperseg), plus what scipy leaves to chance (finite window coefficients that
    /// do not sum to zero, nfft ≤ [`MAX_NFFT`]), and builds the plan.
    pub fn validate(&self) -> Result<WelchPlan, PsdError> {
        let invalid = |msg: String| Err(PsdError::InvalidConfig(msg));
        let nperseg = self.nperseg;
        if nperseg == 0 {
            return invalid("nperseg must be at least 1".into());
        }
        let noverlap = self.noverlap.unwrap_or(nperseg / 2);
        if noverlap >= nperseg {
            return invalid(format!(
                "noverlap ({noverlap}) must be less than nperseg ({nperseg})"
            ));
        }
        let nfft = self.nfft.unwrap_or(nperseg);
        if nfft < nperseg {
            return invalid(format!(
                "nfft ({nfft}) must be greater than or equal to nperseg ({nperseg})"
            ));
        }
        if nfft > MAX_NFFT {
            return invalid(format!("nfft ({nfft}) exceeds the limit of {MAX_NFFT}"));
        }
        let window = self.window.coefficients(nperseg)?;
        if window.iter().any(|w| !w.is_finite()) {
            return invalid("window coefficients must be finite".into());
        }
        let sum_w: f64 = window.iter().sum();
        let sum_w2: f64 = window.iter().map(|w| w * w).sum();
        if sum_w2 == 0.0 || (self.scaling == Scaling::Spectrum && sum_w == 0.0) {
            return invalid(format!(
                "window coefficients sum to zero, which {} scaling divides by",
                self.scaling
            ));
        }
        let fft = RealFftPlanner::<f64>::new().plan_fft_forward(nfft);
        Ok(WelchPlan(Arc::new(PlanInner {
            config: self.clone(),
            window: window.into(),
            noverlap,
            nfft,
            sum_w,
            sum_w2,
            fft,
        })))
    }
}

impl Default for WelchConfig {
    /// scipy's defaults, including nperseg = 256.
    fn default() -> Self {
        WelchConfig::new(256)
    }
}

/// A validated Welch configuration with everything built that every segment reuses. Cloning is
/// cheap (shared), so one plan can serve many channels, files and threads.
#[derive(Clone)]
pub struct WelchPlan(Arc<PlanInner>);

struct PlanInner {
    config: WelchConfig,
    window: Arc<[f64]>,
    noverlap: usize,
    nfft: usize,
    sum_w: f64,
    sum_w2: f64,
    fft: Arc<dyn RealToComplex<f64>>,
}

impl WelchPlan {
    /// The options this plan was built from.
    pub fn config(&self) -> &WelchConfig {
        &self.0.config
    }
    /// Window coefficients (length nperseg).
    pub fn window(&self) -> &[f64] {
        &self.0.window
    }
    pub fn nperseg(&self) -> usize {
        self.0.window.len()
    }
    /// Resolved overlap (the default filled in).
    pub fn noverlap(&self) -> usize {
        self.0.noverlap
    }
    /// Distance between segment starts, nperseg − noverlap (≥ 1).
    pub fn step(&self) -> usize {
        self.nperseg() - self.0.noverlap
    }
    /// Resolved FFT length (the default filled in).
    pub fn nfft(&self) -> usize {
        self.0.nfft
    }
    /// Number of one-sided frequency bins, nfft/2 + 1.
    pub fn bins(&self) -> usize {
        self.0.nfft / 2 + 1
    }
    /// Σw: the coherent gain, which `Scaling::Spectrum` divides by (squared).
    pub fn sum_w(&self) -> f64 {
        self.0.sum_w
    }
    /// Σw²: the incoherent power gain, which `Scaling::Density` divides by.
    pub fn sum_w2(&self) -> f64 {
        self.0.sum_w2
    }
    /// Equivalent noise bandwidth at `rate_hz`: fs·Σw²/(Σw)², the width of the ideal rectangular
    /// filter that passes as much white-noise power as one bin of this window.
    pub fn enbw_hz(&self, rate_hz: f64) -> f64 {
        rate_hz * self.0.sum_w2 / (self.0.sum_w * self.0.sum_w)
    }
    /// Segments that scipy forms from `n` samples: ⌊(n − noverlap)/step⌋, trailing samples dropped.
    pub fn segments_for(&self, n: usize) -> usize {
        if n < self.nperseg() {
            0
        } else {
            (n - self.0.noverlap) / self.step()
        }
    }
    pub(crate) fn fft(&self) -> &dyn RealToComplex<f64> {
        &*self.0.fft
    }
    pub(crate) fn shared_fft(&self) -> Arc<dyn RealToComplex<f64>> {
        Arc::clone(&self.0.fft)
    }
}

impl fmt::Debug for WelchPlan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("WelchPlan")
            .field("window", &self.0.config.window.to_string())
            .field("nperseg", &self.nperseg())
            .field("noverlap", &self.0.noverlap)
            .field("nfft", &self.0.nfft)
            .field("detrend", &self.0.config.detrend)
            .field("scaling", &self.0.config.scaling)
            .field("average", &self.0.config.average)
            .finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(cfg: WelchConfig) -> String {
        cfg.validate().unwrap_err().to_string()
    }

    #[test]
    fn defaults_are_scipys() {
        let plan = WelchConfig::new(100).validate().unwrap();
        assert_eq!(
            (plan.noverlap(), plan.step(), plan.nfft(), plan.bins()),
            (50, 50, 100, 51)
        );
        assert_eq!(plan.segments_for(99), 0);
        assert_eq!(plan.segments_for(100), 1);
        assert_eq!(plan.segments_for(149), 1);
        assert_eq!(plan.segments_for(150), 2);
    }

    #[test]
    fn rejects_what_scipy_rejects() {
        assert!(err(WelchConfig::new(0)).contains("nperseg"));
        let cfg = WelchConfig {
            noverlap: Some(8),
            ..WelchConfig::new(8)
        };
        assert!(err(cfg).contains("noverlap (8)"));
        let cfg = WelchConfig {
            nfft: Some(7),
            ..WelchConfig::new(8)
        };
        assert!(err(cfg).contains("nfft (7)"));
        let cfg = WelchConfig {
            window: Window::Custom(vec![1.0; 7]),
            ..WelchConfig::new(8)
        };
        assert!(err(cfg).contains("7 coefficients"));
    }

    #[test]
    fn rejects_degenerate_windows() {
        let cfg = WelchConfig {
            window: Window::Custom(vec![0.0; 4]),
            ..WelchConfig::new(4)
        };
        assert!(err(cfg).contains("sum to zero"));
        let cfg = WelchConfig {
            window: Window::Custom(vec![1.0, -1.0]),
            scaling: Scaling::Spectrum,
            ..WelchConfig::new(2)
        };
        assert!(err(cfg).contains("spectrum"));
        let cfg = WelchConfig {
            window: Window::Custom(vec![1.0, f64::NAN]),
            ..WelchConfig::new(2)
        };
        assert!(err(cfg).contains("finite"));
    }

    #[test]
    fn enbw_of_hann_is_one_and_a_half_bins() {
        let plan = WelchConfig::new(1024).validate().unwrap();
        assert!((plan.enbw_hz(1024.0) - 1.5).abs() < 1e-12);
    }
}
