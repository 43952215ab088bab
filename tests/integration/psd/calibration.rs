//! Calibration on signals whose spectrum is known in closed form.

use std::f64::consts::PI;

use imunoise::psd::{welch, Detrend, Scaling, WelchConfig, Window};

use super::common::Rng;

#[test]
fn white_noise_density_is_two_sigma_squared_over_fs() {
    // σ = 2, fs = 200 Hz: one-sided density 2σ²/fs = 0.04 unit²/Hz at every frequency.
    // 409 600 samples, nperseg 1024 (799 segments): the mean over the 510 bins between DC and
    // Nyquist (the two lowest bins are dented by the per-segment mean removal) has a relative
    // standard error of about 0.3 % (≈ 0.25 % from the estimate's EDF, 0.2 % from the realised
    // sample variance); the tolerance is 1.5 %, about five standard errors.
    let (sigma, fs) = (2.0, 200.0);
    let x = Rng::new(1).white(409_600, sigma);
    let psd = welch(&x, fs, &WelchConfig::new(1024)).unwrap();
    let expected = 2.0 * sigma * sigma / fs;
    let inner = &psd.value[2..psd.value.len() - 1];
    let mean = inner.iter().sum::<f64>() / inner.len() as f64;
    assert!(
        (mean / expected - 1.0).abs() < 0.015,
        "mean density {mean} vs {expected}"
    );
    // The same data in Spectrum scaling reads density × ENBW, bin by bin.
    let cfg = WelchConfig {
        scaling: Scaling::Spectrum,
        ..WelchConfig::new(1024)
    };
    let spectrum = welch(&x, fs, &cfg).unwrap();
    for (s, d) in spectrum.value.iter().zip(&psd.value) {
        assert!(
            (s - d * psd.enbw_hz).abs() <= 1e-12 * s.abs(),
            "{s} vs {d}·ENBW"
        );
    }
    assert!(
        (psd.enbw_hz - 1.5 * fs / 1024.0).abs() < 1e-12,
        "Hann ENBW is 1.5 bins"
    );
}

#[test]
fn parseval_holds_exactly_for_boxcar_without_overlap() {
    // With a boxcar window, no overlap, no detrend and nfft = nperseg, the one-sided density
    // integrates (Σ_k P_k·Δf) to the mean square of the samples used, to rounding.
    let x: Vec<f64> = Rng::new(2)
        .white(10_000, 0.7)
        .iter()
        .map(|v| v + 0.1)
        .collect();
    for nperseg in [256usize, 255] {
        let cfg = WelchConfig {
            window: Window::Boxcar,
            noverlap: Some(0),
            detrend: Detrend::None,
            ..WelchConfig::new(nperseg)
        };
        let psd = welch(&x, 50.0, &cfg).unwrap();
        let used = psd.segments * nperseg;
        let mean_square = x[..used].iter().map(|v| v * v).sum::<f64>() / used as f64;
        let power: f64 = psd.value.iter().sum::<f64>() * psd.bin_width_hz();
        assert!(
            (power / mean_square - 1.0).abs() < 1e-12,
            "nperseg {nperseg}: {power} vs {mean_square}"
        );
    }
}

#[test]
fn flattop_spectrum_reads_a_sinusoids_power() {
    // A·sin(2πf0t + φ), Scaling::Spectrum, flattop: the peak reads A²/2 within 0.1 % wherever f0
    // falls between bins up to 0.45 bin off centre. At exactly half a bin the window's own scallop
    // loss is 0.22 % (scipy gives the same); that case is checked against its known value.
    let (a, fs, n) = (1.7, 1000.0, 4096usize);
    let cfg = WelchConfig {
        window: Window::Flattop,
        scaling: Scaling::Spectrum,
        ..WelchConfig::new(n)
    };
    for (offset, tol) in [
        (0.0, 1e-3),
        (0.1, 1e-3),
        (0.25, 1e-3),
        (0.37, 1e-3),
        (0.45, 1e-3),
        (0.5, 2.5e-3),
    ] {
        let f0 = (300.0 + offset) * fs / n as f64;
        let x: Vec<f64> = (0..40_000)
            .map(|i| a * (2.0 * PI * f0 * i as f64 / fs + 0.3).sin())
            .collect();
        let psd = welch(&x, fs, &cfg).unwrap();
        let (k, peak) = psd
            .value
            .iter()
            .copied()
            .enumerate()
            .fold(
                (0, 0.0),
                |best, (k, v)| if v > best.1 { (k, v) } else { best },
            );
        assert!(
            (peak / (a * a / 2.0) - 1.0).abs() < tol,
            "offset {offset}: peak {peak} vs {}",
            a * a / 2.0
        );
        assert!(
            (psd.freq_hz[k] - f0).abs() <= psd.bin_width_hz(),
            "peak at {} Hz, f0 {f0}",
            psd.freq_hz[k]
        );
    }
}
