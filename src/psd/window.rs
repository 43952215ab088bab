//! Window functions, with the coefficients of `scipy.signal.get_window(name, n, fftbins=True)`.
//!
//! Welch segments are windowed with the *periodic* (DFT-even) form: the symmetric window of length
//! n + 1 with its last point dropped. That is scipy's default for spectral analysis, and parity with
//! scipy is what lets a user check this tool against the numbers they already trust. The cosine sums
//! below are evaluated in the same order and on the same grid as scipy's `_general_cosine_impl`
//! (`linspace(-π, π, n + 1)`), so coefficients agree to the last bit or two.

use std::f64::consts::PI;
use std::fmt;
use std::str::FromStr;

use super::PsdError;

/// A segment window.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Window {
    /// Raised cosine, a = [0.5, 0.5]: the usual default (scipy's too).
    Hann,
    /// a = [0.54, 0.46].
    Hamming,
    /// a = [0.42, 0.50, 0.08].
    Blackman,
    /// 4-term Blackman–Harris, −92 dB side lobes: for spectra with a large dynamic range.
    BlackmanHarris,
    /// 5-term flat top: amplitude-accurate peaks (scallop loss < 0.01 dB) with `Scaling::Spectrum`.
    Flattop,
    /// Rectangular window (no taper).
    Boxcar,
    /// Coefficients given by the caller; the length must equal `nperseg`.
    Custom(Vec<f64>),
}

/// Cosine-sum coefficients, copied from scipy.signal.windows (hamming's second coefficient is
/// computed as `1 - 0.54`, as scipy's `general_hamming` does).
const HANN: [f64; 2] = [0.5, 1.0 - 0.5];
const HAMMING: [f64; 2] = [0.54, 1.0 - 0.54];
const BLACKMAN: [f64; 3] = [0.42, 0.50, 0.08];
const BLACKMAN_HARRIS: [f64; 4] = [0.35875, 0.48829, 0.14128, 0.01168];
const FLATTOP: [f64; 5] = [
    0.21557895,
    0.41663158,
    0.277263158,
    0.083578947,
    0.006947368,
];

const NAMES: &str = "hann, hamming, blackman, blackmanharris, flattop, boxcar";

impl Window {
    /// The `n` periodic window coefficients.
    ///
    /// For `Custom`, the given values; their length must be `n` or the result is `InvalidConfig`.
    pub fn coefficients(&self, n: usize) -> Result<Vec<f64>, PsdError> {
        let a: &[f64] = match self {
            Window::Hann => &HANN,
            Window::Hamming => &HAMMING,
            Window::Blackman => &BLACKMAN,
            Window::BlackmanHarris => &BLACKMAN_HARRIS,
            Window::Flattop => &FLATTOP,
            Window::Boxcar => return Ok(vec![1.0; n]),
            Window::Custom(values) => {
                if values.len() != n {
                    return Err(PsdError::InvalidConfig(format!(
                        "custom window has {} coefficients, nperseg is {n}",
                        values.len()
                    )));
                }
                return Ok(values.clone());
            }
        };
        Ok(periodic_cosine_sum(n, a))
    }
}

/// Σ_k a_k cos(k·φ_i) with φ on scipy's grid `linspace(-π, π, n + 1)`, last point dropped.
/// Lengths 0 and 1 give all ones, as scipy's `_len_guards` does.
fn periodic_cosine_sum(n: usize, a: &[f64]) -> Vec<f64> {
    if n <= 1 {
        return vec![1.0; n];
    }
    // numpy's linspace: step = (stop - start) / (num - 1), y_i = i·step + start.
    let step = (PI - (-PI)) / n as f64;
    (0..n)
        .map(|i| {
            let phi = i as f64 * step + (-PI);
            a.iter()
                .enumerate()
                .fold(0.0, |w, (k, &ak)| w + ak * (k as f64 * phi).cos())
        })
        .collect()
}

impl fmt::Display for Window {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Window::Hann => "hann",
            Window::Hamming => "hamming",
            Window::Blackman => "blackman",
            Window::BlackmanHarris => "blackmanharris",
            Window::Flattop => "flattop",
            Window::Boxcar => "boxcar",
            Window::Custom(_) => "custom",
        })
    }
}

impl FromStr for Window {
    type Err = PsdError;

    /// Accepts scipy's names and aliases (`get_window`), ASCII case-insensitively. `custom` cannot
    /// be parsed: its coefficients have to come from somewhere else.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(match s.to_ascii_lowercase().as_str() {
            "hann" | "han" | "hanning" => Window::Hann,
            "hamming" | "hamm" | "ham" => Window::Hamming,
            "blackman" | "black" | "blk" => Window::Blackman,
            "blackmanharris" | "blkh" => Window::BlackmanHarris,
            "flattop" | "flat" | "flt" => Window::Flattop,
            "boxcar" | "box" | "ones" | "rect" | "rectangular" => Window::Boxcar,
            _ => {
                return Err(PsdError::UnknownName {
                    what: "window",
                    name: s.to_owned(),
                    expected: NAMES,
                })
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hann_periodic_matches_closed_form() {
        // Periodic Hann: w_i = 0.5 − 0.5·cos(2πi/n) = sin²(πi/n).
        let n = 8;
        let w = Window::Hann.coefficients(n).unwrap();
        for (i, wi) in w.iter().enumerate() {
            let expected = (PI * i as f64 / n as f64).sin().powi(2);
            assert!((wi - expected).abs() < 1e-15, "{i}: {wi} vs {expected}");
        }
    }

    #[test]
    fn windows_are_periodic_and_peak_at_the_centre() {
        for win in [
            Window::Hann,
            Window::Hamming,
            Window::Blackman,
            Window::BlackmanHarris,
            Window::Flattop,
        ] {
            let w = win.coefficients(64).unwrap();
            // A DFT-even window is symmetric about index n/2: w[i] == w[n − i].
            for i in 1..32 {
                assert!((w[i] - w[64 - i]).abs() < 1e-15, "{win} at {i}");
            }
            assert!((w[32] - 1.0).abs() < 1e-8, "{win} centre {}", w[32]);
        }
    }

    #[test]
    fn short_lengths_are_ones_like_scipy() {
        assert_eq!(Window::Hann.coefficients(1).unwrap(), vec![1.0]);
        assert!(Window::Flattop.coefficients(0).unwrap().is_empty());
    }

    #[test]
    fn names_round_trip() {
        for win in [
            Window::Hann,
            Window::Hamming,
            Window::Blackman,
            Window::BlackmanHarris,
            Window::Flattop,
            Window::Boxcar,
        ] {
            assert_eq!(win.to_string().parse::<Window>().unwrap(), win);
            assert_eq!(serde_json::to_string(&win).unwrap(), format!("\"{win}\""));
        }
        assert_eq!("Hanning".parse::<Window>().unwrap(), Window::Hann);
        let err = "kaiser".parse::<Window>().unwrap_err();
        assert!(err.to_string().contains("kaiser"), "{err}");
    }

    #[test]
    fn custom_length_must_match() {
        let w = Window::Custom(vec![1.0, 2.0, 3.0]);
        assert_eq!(w.coefficients(3).unwrap(), vec![1.0, 2.0, 3.0]);
        assert!(matches!(w.coefficients(4), Err(PsdError::InvalidConfig(_))));
    }
}
