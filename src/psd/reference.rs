//! Reference Welch estimate by direct summation, written from the textbook definitions with no
//! attention to speed (O(segments · nperseg · nfft)).
//!
//! It shares nothing with the fast path but the window coefficients (checked against scipy on their
//! own): its own segmentation, least-squares detrend, DFT and averaging. Tests check the fast CPU
//! path against it, and a GPU backend can be checked against it the same way. Keep inputs small.

use std::f64::consts::PI;

use realfft::num_complex::Complex;

use super::median::median_bias;
use super::{Average, Detrend, PsdError, Scaling, WelchConfig};

/// DFT of `x` zero-padded to `nfft` points: X_k = Σ_t x_t·e^{−2πi·k·t/nfft}, k = 0..nfft.
///
/// The phase is reduced exactly, ((k·t) mod nfft), before the sine and cosine, so large k·t lose
/// no accuracy. `nfft` must be at least `x.len()`.
pub fn dft(x: &[f64], nfft: usize) -> Vec<Complex<f64>> {
    (0..nfft)
        .map(|k| {
            x.iter()
                .enumerate()
                .map(|(t, &xt)| {
                    let phase = -2.0 * PI * ((k * t) % nfft) as f64 / nfft as f64;
                    Complex::new(xt * phase.cos(), xt * phase.sin())
                })
                .sum()
        })
        .collect()
}

/// Removes the trend from a segment by solving the 2×2 normal equations for x ≈ a + b·t.
pub fn detrend(x: &[f64], detrend: Detrend) -> Vec<f64> {
    let n = x.len() as f64;
    match detrend {
        Detrend::None => x.to_vec(),
        Detrend::Constant => {
            let mean = x.iter().sum::<f64>() / n;
            x.iter().map(|v| v - mean).collect()
        }
        Detrend::Linear => {
            let st: f64 = (0..x.len()).map(|t| t as f64).sum();
            let stt: f64 = (0..x.len()).map(|t| (t * t) as f64).sum();
            let sx: f64 = x.iter().sum();
            let stx: f64 = x.iter().enumerate().map(|(t, v)| t as f64 * v).sum();
            let det = n * stt - st * st;
            let (a, b) = if det == 0.0 {
                (sx / n, 0.0)
            } else {
                ((stt * sx - st * stx) / det, (n * stx - st * sx) / det)
            };
            x.iter()
                .enumerate()
                .map(|(t, v)| v - (a + b * t as f64))
                .collect()
        }
    }
}

/// One-sided periodogram of one segment: detrend, window, DFT, |X_k|² times the scaling factor,
/// bins 0..=nfft/2, doubled except DC and (even nfft) Nyquist.
pub fn periodogram(segment: &[f64], rate_hz: f64, cfg: &WelchConfig) -> Result<Vec<f64>, PsdError> {
    let n = segment.len();
    let w = cfg.window.coefficients(n)?;
    let nfft = cfg.nfft.unwrap_or(n);
    let y: Vec<f64> = detrend(segment, cfg.detrend)
        .iter()
        .zip(&w)
        .map(|(x, w)| x * w)
        .collect();
    let scale = match cfg.scaling {
        Scaling::Density => 1.0 / (rate_hz * w.iter().map(|v| v * v).sum::<f64>()),
        Scaling::Spectrum => 1.0 / w.iter().sum::<f64>().powi(2),
    };
    Ok(dft(&y, nfft)
        .iter()
        .take(nfft / 2 + 1)
        .enumerate()
        .map(|(k, x)| {
            let mirrored = k != 0 && 2 * k != nfft;
            let p = x.norm_sqr() * scale;
            if mirrored {
                2.0 * p
            } else {
                p
            }
        })
        .collect())
}

/// Welch estimate (one-sided values only; frequencies are k·rate/nfft): segments start every
/// nperseg − noverlap samples and trailing samples are dropped, as in scipy; the segment
/// periodograms are averaged by the mean, or by the median divided by scipy's bias factor.
pub fn welch(x: &[f64], rate_hz: f64, cfg: &WelchConfig) -> Result<Vec<f64>, PsdError> {
    let plan = cfg.validate()?; // the same validation, so both paths accept the same configs
    let (n, step) = (plan.nperseg(), plan.step());
    let cfg = WelchConfig {
        nfft: Some(plan.nfft()),
        ..cfg.clone()
    };
    let mut starts = Vec::new();
    let mut start = 0;
    while start + n <= x.len() {
        starts.push(start);
        start += step;
    }
    if starts.is_empty() {
        return Err(PsdError::TooShort {
            n: x.len(),
            nperseg: n,
        });
    }
    let periodograms = starts
        .iter()
        .map(|&s| periodogram(&x[s..s + n], rate_hz, &cfg))
        .collect::<Result<Vec<_>, _>>()?;
    let m = periodograms.len();
    Ok((0..plan.bins())
        .map(|k| {
            let mut column: Vec<f64> = periodograms.iter().map(|p| p[k]).collect();
            match cfg.average {
                Average::Mean => column.iter().sum::<f64>() / m as f64,
                Average::Median => {
                    column.sort_by(f64::total_cmp);
                    let median = if m % 2 == 1 {
                        column[m / 2]
                    } else {
                        (column[m / 2 - 1] + column[m / 2]) / 2.0
                    };
                    median / median_bias(m)
                }
            }
        })
        .collect())
}

/// Worst relative deviation of `value` from `reference`, the comparison every implementation
/// (fast CPU path, GPU backend) is checked with: |v − r|/|r| over bins with |r| above
/// `floor`·max|r|, and |v − r|/(`floor`·max|r|) below it, where rounding noise of a near-zero bin
/// (DC after detrending) is no error. A length mismatch or a NaN gives infinity.
pub fn relative_error(value: &[f64], reference: &[f64], floor: f64) -> f64 {
    if value.len() != reference.len() {
        return f64::INFINITY;
    }
    let max = reference.iter().fold(0.0_f64, |m, r| m.max(r.abs()));
    let small = floor * max;
    value
        .iter()
        .zip(reference)
        .map(|(v, r)| {
            let d = (v - r).abs();
            if d == 0.0 {
                0.0
            } else if d.is_nan() {
                f64::INFINITY
            } else {
                d / r.abs().max(small)
            }
        })
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::psd::Window;

    #[test]
    fn dft_of_four_points_by_hand() {
        // X = [1+2+3+4, (1−3) + i(4−2), 1−2+3−4, (1−3) − i(4−2)].
        let x = dft(&[1.0, 2.0, 3.0, 4.0], 4);
        let expected = [(10.0, 0.0), (-2.0, 2.0), (-2.0, 0.0), (-2.0, -2.0)];
        for (got, (re, im)) in x.iter().zip(expected) {
            assert!(
                (got.re - re).abs() < 1e-14 && (got.im - im).abs() < 1e-14,
                "{got}"
            );
        }
    }

    #[test]
    fn parseval_holds() {
        // Σ_k |X_k|² = nfft·Σ_t x_t², zero padding included.
        let x: Vec<f64> = (0..13).map(|t| ((t * 37) % 11) as f64 - 5.0).collect();
        let energy: f64 = x.iter().map(|v| v * v).sum();
        for nfft in [13, 16, 21] {
            let spectral: f64 = dft(&x, nfft).iter().map(|c| c.norm_sqr()).sum();
            assert!(
                (spectral - nfft as f64 * energy).abs() < 1e-9 * spectral,
                "nfft {nfft}"
            );
        }
    }

    #[test]
    fn sinusoid_on_a_bin_has_the_textbook_power() {
        // A·cos(2π·k0·t/n) over n samples, boxcar: X_k0 = A·n/2, so the one-sided spectrum reads
        // A²/2 at k0 and the density (A²/2)/Δf, with Δf = fs/n; every other bin is zero.
        let (n, k0, a, fs) = (32usize, 5usize, 3.0, 64.0);
        let x: Vec<f64> = (0..n)
            .map(|t| a * (2.0 * PI * (k0 * t) as f64 / n as f64).cos())
            .collect();
        let mut cfg = WelchConfig {
            window: Window::Boxcar,
            detrend: Detrend::None,
            scaling: Scaling::Spectrum,
            ..WelchConfig::new(n)
        };
        let p = periodogram(&x, fs, &cfg).unwrap();
        assert!((p[k0] - a * a / 2.0).abs() < 1e-12, "{}", p[k0]);
        for (k, v) in p.iter().enumerate().filter(|&(k, _)| k != k0) {
            assert!(v.abs() < 1e-24, "bin {k}: {v}");
        }
        cfg.scaling = Scaling::Density;
        let d = periodogram(&x, fs, &cfg).unwrap();
        let df = fs / n as f64;
        assert!((d[k0] - a * a / 2.0 / df).abs() < 1e-11, "{}", d[k0]);
    }

    #[test]
    fn constant_signal_is_all_dc() {
        let cfg = WelchConfig {
            window: Window::Boxcar,
            detrend: Detrend::None,
            scaling: Scaling::Spectrum,
            ..WelchConfig::new(8)
        };
        let p = periodogram(&[2.0; 8], 1.0, &cfg).unwrap();
        assert!((p[0] - 4.0).abs() < 1e-14);
        assert!(p[1..].iter().all(|v| v.abs() < 1e-28));
    }

    #[test]
    fn linear_detrend_solves_least_squares() {
        let x: Vec<f64> = (0..10).map(|t| 1.5 + 0.5 * t as f64).collect();
        assert!(detrend(&x, Detrend::Linear).iter().all(|r| r.abs() < 1e-13));
    }

    #[test]
    fn relative_error_floors_tiny_bins() {
        let r = [1.0, 1e-20, 2.0];
        assert_eq!(relative_error(&[1.0, 0.0, 2.0], &r, 1e-12), 1e-20 / 2e-12);
        assert!((relative_error(&[1.1, 1e-20, 2.0], &r, 1e-12) - 0.1).abs() < 1e-12);
        assert_eq!(relative_error(&[1.0], &r, 1e-12), f64::INFINITY);
        assert_eq!(
            relative_error(&[f64::NAN, 0.0, 2.0], &r, 1e-12),
            f64::INFINITY
        );
    }

    #[test]
    fn median_of_two_segments_is_their_mean() {
        // scipy: bias(2) = 1, so median averaging of 2 segments equals mean averaging.
        let x: Vec<f64> = (0..48).map(|t| ((t * 7) % 5) as f64).collect();
        let mean = welch(&x, 1.0, &WelchConfig::new(32)).unwrap();
        let cfg = WelchConfig {
            average: Average::Median,
            ..WelchConfig::new(32)
        };
        let median = welch(&x, 1.0, &cfg).unwrap();
        for (a, b) in mean.iter().zip(&median) {
            assert!((a - b).abs() <= 1e-12 * a.abs().max(1e-300), "{a} {b}");
        }
    }
}
