//! The fast path against the direct-sum reference, over random configurations.

use imunoise::psd::{reference, welch, Average, Detrend, Scaling, WelchConfig, Window};
use proptest::prelude::*;

use super::common::{assert_psd_close, Rng};

proptest! {
    #![proptest_config(ProptestConfig::with_cases(std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(48)))]

    #[test]
    fn fast_path_matches_direct_sums(
        seed in any::<u64>(),
        nperseg in 1usize..90,
        overlap_frac in 0.0..0.95f64,
        pad in 0usize..30,
        extra in 0usize..400,
        window in 0usize..7,
        detrend in 0usize..3,
        spectrum in any::<bool>(),
        median in any::<bool>(),
    ) {
        // A detrended segment that is identically zero (a line through ≤ 2 points, the mean of one
        // point) leaves only rounding noise in both paths: nothing to compare relatively.
        let degenerate = (detrend == 1 && nperseg <= 2) || (detrend == 0 && nperseg == 1);
        prop_assume!(!degenerate);
        let n = nperseg + extra;
        let mut rng = Rng::new(seed);
        let x: Vec<f64> = (0..n).map(|i| 0.5 + 1e-3 * i as f64 + rng.normal()).collect();
        let custom: Vec<f64> = (0..nperseg).map(|i| 1.0 + (i % 3) as f64).collect();
        let cfg = WelchConfig {
            window: [
                Window::Hann, Window::Hamming, Window::Blackman, Window::BlackmanHarris,
                Window::Flattop, Window::Boxcar, Window::Custom(custom),
            ][window].clone(),
            nperseg,
            noverlap: Some(((nperseg as f64) * overlap_frac) as usize),
            nfft: Some(nperseg + pad),
            detrend: [Detrend::Constant, Detrend::Linear, Detrend::None][detrend],
            scaling: if spectrum { Scaling::Spectrum } else { Scaling::Density },
            average: if median { Average::Median } else { Average::Mean },
        };
        let fast = welch(&x, 3.0, &cfg).unwrap();
        let slow = reference::welch(&x, 3.0, &cfg).unwrap();
        assert_psd_close(&fast.value, &slow, 1e-9, "fast vs direct sums");
    }
}

#[test]
fn reference_periodogram_of_an_on_bin_sinusoid() {
    // Textbook: A·cos(2πk0t/n) has |X_k0| = A·n/2, so density (A²/2)/Δf at k0, zero elsewhere;
    // the fast path must give the same.
    let (n, k0, a, fs) = (64usize, 9usize, 0.8, 128.0);
    let x: Vec<f64> = (0..n)
        .map(|t| a * (2.0 * std::f64::consts::PI * (k0 * t) as f64 / n as f64).cos())
        .collect();
    let cfg = WelchConfig {
        window: Window::Boxcar,
        detrend: Detrend::None,
        ..WelchConfig::new(n)
    };
    let df = fs / n as f64;
    let slow = reference::welch(&x, fs, &cfg).unwrap();
    assert!((slow[k0] - a * a / 2.0 / df).abs() < 1e-12);
    let fast = welch(&x, fs, &cfg).unwrap();
    assert!((fast.value[k0] - a * a / 2.0 / df).abs() < 1e-12);
    for k in (0..fast.value.len()).filter(|&k| k != k0) {
        assert!(fast.value[k] < 1e-25 && slow[k] < 1e-25, "bin {k}");
    }
}
