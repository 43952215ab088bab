//! Log-frequency binning: structure, values, and degrees of freedom (checked by Monte Carlo).

use imunoise::psd::{log_bin, welch, Detrend, Psd, WelchConfig, Window};

use super::common::Rng;

fn white_psd(seed: u64, cfg: &WelchConfig, n: usize) -> Psd {
    welch(&Rng::new(seed).white(n, 1.0), 100.0, cfg).unwrap()
}

#[test]
fn bands_are_ordered_tile_the_axis_and_hold_bin_averages() {
    let psd = white_psd(1, &WelchConfig::new(1000), 50_000);
    for bpd in [1, 5, 10, 20] {
        let b = log_bin(&psd, bpd);
        let all_but_dc_and_nyquist = psd.value.len() - 2;
        assert_eq!(
            b.bins.iter().map(|&k| k as usize).sum::<usize>(),
            all_but_dc_and_nyquist
        );
        let df = psd.bin_width_hz();
        for i in 0..b.value.len() {
            assert!(b.f_lo_hz[i] < b.freq_hz[i] && b.freq_hz[i] < b.f_hi_hz[i]);
            if i > 0 {
                assert!(b.freq_hz[i - 1] < b.freq_hz[i], "frequencies increase");
                assert!(
                    (b.f_lo_hz[i] - b.f_hi_hz[i - 1]).abs() < 1e-9 * df,
                    "bands tile"
                );
            }
            // Naive check: the input bins whose centres lie inside the band's edges.
            let inside: Vec<usize> = (0..psd.value.len() - 1)
                .filter(|&k| psd.freq_hz[k] > b.f_lo_hz[i] && psd.freq_hz[k] < b.f_hi_hz[i])
                .collect();
            assert_eq!(inside.len(), b.bins[i] as usize);
            let mean = inside.iter().map(|&k| psd.value[k]).sum::<f64>() / inside.len() as f64;
            let fmean = inside.iter().map(|&k| psd.freq_hz[k]).sum::<f64>() / inside.len() as f64;
            assert!(
                (b.value[i] - mean).abs() <= 1e-14 * mean,
                "band {i}: {} vs {mean}",
                b.value[i]
            );
            assert!((b.freq_hz[i] - fmean).abs() <= 1e-12 * fmean);
            // A multi-bin band lies inside one 1/bpd-decade band.
            if inside.len() > 1 {
                let band = |f: f64| (f64::from(bpd) * f.log10()).floor();
                assert_eq!(
                    band(psd.freq_hz[inside[0]]),
                    band(psd.freq_hz[*inside.last().unwrap()])
                );
            }
        }
        // Where bands are narrower than Δf (0.1 Hz here) the first bins stay single.
        if bpd >= 5 {
            assert_eq!(&b.bins[..2], &[1, 1]);
        }
        assert!((b.freq_hz[0] - df).abs() < 1e-12 || b.bins[0] > 1);
    }
}

#[test]
fn dof_adds_up_when_bins_are_independent() {
    // Boxcar, no overlap, nfft = nperseg: bins and segments are uncorrelated, so a band of K bins
    // over M segments has exactly 2·K·M degrees of freedom, the sum of its bins' (2·M each).
    let cfg = WelchConfig {
        window: Window::Boxcar,
        noverlap: Some(0),
        detrend: Detrend::None,
        ..WelchConfig::new(256)
    };
    let psd = white_psd(2, &cfg, 256 * 40);
    let m = psd.segments as f64;
    assert_eq!(psd.segments, 40);
    let b = log_bin(&psd, 10);
    let mut first_bin = 1;
    for i in 0..b.value.len() {
        let k = f64::from(b.bins[i]);
        let summed: f64 = psd.dof[first_bin..first_bin + b.bins[i] as usize]
            .iter()
            .sum();
        first_bin += b.bins[i] as usize;
        assert!(
            (b.dof[i] - 2.0 * k * m).abs() < 1e-9 * b.dof[i],
            "band {i}: {}",
            b.dof[i]
        );
        assert!((b.dof[i] - summed).abs() < 1e-9 * b.dof[i]);
    }
    assert_eq!(
        first_bin, 128,
        "bins 1..=127 binned (DC and Nyquist dropped)"
    );
    // The dropped Nyquist bin is a χ²₁ bin: M degrees of freedom.
    assert!((psd.dof[128] - m).abs() < 1e-9 && (psd.dof[0] - m).abs() < 1e-9);
}

#[test]
fn hann_band_dof_and_unbiasedness_hold_in_monte_carlo() {
    // White noise, Hann, 50 % overlap, 300 independent recordings. For every band:
    // - the mean of the binned value over recordings is the true density 2σ²/fs (σ = 1, fs = 100)
    //   within 5 standard errors, the standard error being E·√(2/(dof·R));
    // - the variance over recordings matches 2·E²/dof: pooled over bands within 10 %, each band
    //   within 40 % (a sample variance of 300 χ²-like values scatters by about ±10 %).
    // The naive 2·K·M would overstate the EDF of wide Hann bands almost twofold and fail this.
    const R: usize = 300;
    let cfg = WelchConfig::new(256);
    let truth = 2.0 / 100.0;
    let runs: Vec<_> = (0..R)
        .map(|r| log_bin(&white_psd(100 + r as u64, &cfg, 256 * 16), 8))
        .collect();
    let first = &runs[0];
    let mut ratio_sum = 0.0;
    let mut used = 0;
    for i in 0..first.value.len() {
        // Skip the bands holding the two lowest bins: the per-segment mean removal dents them.
        if first.f_lo_hz[i] < 2.5 * 100.0 / 256.0 {
            continue;
        }
        let values: Vec<f64> = runs.iter().map(|b| b.value[i]).collect();
        let mean = values.iter().sum::<f64>() / R as f64;
        let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (R - 1) as f64;
        let dof = first.dof[i];
        let se = truth * (2.0 / (dof * R as f64)).sqrt();
        assert!(
            (mean - truth).abs() < 5.0 * se,
            "band {i}: mean {mean} vs {truth} (se {se})"
        );
        let ratio = var / (2.0 * truth * truth / dof);
        assert!(
            (0.6..1.4).contains(&ratio),
            "band {i} ({} bins): variance ratio {ratio}",
            first.bins[i]
        );
        let naive = 2.0 * f64::from(first.bins[i]) * 31.0;
        assert!(
            dof <= naive * 1.0001,
            "EDF {dof} above the independent-bin count {naive}"
        );
        ratio_sum += ratio;
        used += 1;
    }
    let pooled = ratio_sum / used as f64;
    assert!(
        used > 10 && (pooled - 1.0).abs() < 0.1,
        "pooled variance ratio {pooled} over {used} bands"
    );
}
