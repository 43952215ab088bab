//! Calibration of raw periodogram sums |X_k|² into physical units, and the one-sided fold.

use std::fmt;
use std::str::FromStr;

use super::PsdError;

/// Units of the result.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Scaling {
    /// Power spectral density, unit²/Hz: |X|²/(fs·Σw²). Noise floors read directly as a density
    /// (what the IEEE noise model and Kalibr's `*_noise_density` use), independent of `nperseg`.
    Density,
    /// Power spectrum, unit²: |X|²/(Σw)². A sinusoid of amplitude A reads A²/2 at its peak
    /// (exactly so with a flat-top window), independent of `nperseg`.
    Spectrum,
}

impl Scaling {
    /// The factor that turns |X_k|² of one windowed segment into a two-sided value.
    pub(crate) fn factor(self, rate_hz: f64, sum_w: f64, sum_w2: f64) -> f64 {
        match self {
            Scaling::Density => 1.0 / (rate_hz * sum_w2),
            Scaling::Spectrum => 1.0 / (sum_w * sum_w),
        }
    }
}

/// Folds a two-sided spectrum of a real signal onto f ≥ 0: every bin except DC and (for even
/// `nfft`) Nyquist has a mirror image at −f whose power it takes over, so it is doubled.
pub(crate) fn fold_one_sided(values: &mut [f64], nfft: usize) {
    let end = if nfft.is_multiple_of(2) {
        values.len().saturating_sub(1)
    } else {
        values.len()
    };
    for v in values.iter_mut().take(end).skip(1) {
        *v *= 2.0;
    }
}

impl fmt::Display for Scaling {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Scaling::Density => "density",
            Scaling::Spectrum => "spectrum",
        })
    }
}

impl FromStr for Scaling {
    type Err = PsdError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "density" => Ok(Scaling::Density),
            "spectrum" => Ok(Scaling::Spectrum),
            _ => Err(PsdError::UnknownName {
                what: "scaling",
                name: s.to_owned(),
                expected: "density, spectrum",
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fold_doubles_all_but_dc_and_nyquist() {
        let mut even = vec![1.0; 5]; // nfft = 8
        fold_one_sided(&mut even, 8);
        assert_eq!(even, [1.0, 2.0, 2.0, 2.0, 1.0]);
        let mut odd = vec![1.0; 4]; // nfft = 7: no Nyquist bin
        fold_one_sided(&mut odd, 7);
        assert_eq!(odd, [1.0, 2.0, 2.0, 2.0]);
        let mut single = vec![1.0]; // nfft = 1 or 2
        fold_one_sided(&mut single, 1);
        assert_eq!(single, [1.0]);
    }

    #[test]
    fn factors() {
        assert_eq!(Scaling::Density.factor(100.0, 4.0, 2.0), 1.0 / 200.0);
        assert_eq!(Scaling::Spectrum.factor(100.0, 4.0, 2.0), 1.0 / 16.0);
    }

    #[test]
    fn names_round_trip() {
        for s in [Scaling::Density, Scaling::Spectrum] {
            assert_eq!(s.to_string().parse::<Scaling>().unwrap(), s);
        }
        assert!("power".parse::<Scaling>().is_err());
    }
}
