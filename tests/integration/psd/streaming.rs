//! Streaming equals one-shot, and the accumulator's memory stays bounded.

use imunoise::psd::{
    welch, welch_with_plan, Average, Detrend, WelchAccumulator, WelchConfig, Window,
};
use proptest::prelude::*;

use super::common::{assert_psd_close, Rng};

/// Same PSD to 1e-12 relative (the only difference is the order of floating-point sums).
const STREAM_TOL: f64 = 1e-12;

/// Pushes `x` (one channel) in chunks whose lengths cycle through `sizes`; returns the PSD and the
/// largest chunk pushed.
fn stream(
    x: &[f64],
    rate: f64,
    cfg: &WelchConfig,
    sizes: &[usize],
) -> (imunoise::psd::Psd, usize, usize) {
    let mut acc = WelchAccumulator::new(cfg.validate().unwrap(), rate, 1);
    let (mut at, mut i, mut largest) = (0, 0, 0);
    while at < x.len() {
        let len = sizes[i % sizes.len()].min(x.len() - at);
        acc.push(&[&x[at..at + len]]);
        largest = largest.max(len);
        at += len;
        i += 1;
    }
    let peak = acc.peak_buffered_samples();
    (acc.finish().unwrap().remove(0), largest, peak)
}

fn config(
    window: usize,
    nperseg: usize,
    noverlap: usize,
    pad: usize,
    detrend: usize,
    median: bool,
) -> WelchConfig {
    WelchConfig {
        window: [
            Window::Hann,
            Window::Boxcar,
            Window::Flattop,
            Window::BlackmanHarris,
        ][window]
            .clone(),
        nperseg,
        noverlap: Some(noverlap % nperseg),
        nfft: Some(nperseg + pad),
        detrend: [Detrend::Constant, Detrend::Linear, Detrend::None][detrend],
        average: if median {
            Average::Median
        } else {
            Average::Mean
        },
        ..WelchConfig::new(nperseg)
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn random_chunking_gives_the_one_shot_result(
        seed in any::<u64>(),
        n in 1usize..3000,
        nperseg in 1usize..200,
        noverlap in 0usize..200,
        pad in 0usize..40,
        window in 0usize..4,
        detrend in 0usize..3,
        median in any::<bool>(),
        sizes in prop::collection::vec(1usize..700, 1..8),
    ) {
        let x: Vec<f64> = Rng::new(seed).white(n, 1.0).iter().map(|v| v + 3.0).collect();
        let cfg = config(window, nperseg, noverlap, pad, detrend, median);
        match welch(&x, 10.0, &cfg) {
            Ok(one_shot) => {
                let (streamed, largest, peak) = stream(&x, 10.0, &cfg, &sizes);
                assert_psd_close(&streamed.value, &one_shot.value, STREAM_TOL, "streamed vs one-shot");
                prop_assert_eq!(streamed.segments, one_shot.segments);
                prop_assert!(peak < nperseg.max(1) + largest);
            }
            Err(e) => prop_assert!(n < nperseg, "unexpected error {e}"),
        }
    }
}

#[test]
fn long_stream_holds_less_than_one_segment() {
    // 200 × nperseg samples in chunks of 1 to 5000: never more than nperseg + chunk held, in fact
    // fewer than nperseg, because chunks are read in place.
    let nperseg = 512;
    let x = Rng::new(7).white(200 * nperseg, 1.0);
    let mut rng = Rng::new(8);
    let sizes: Vec<usize> = (0..64).map(|_| rng.range(1, 5000)).collect();
    for average in [Average::Mean, Average::Median] {
        let cfg = WelchConfig {
            average,
            ..WelchConfig::new(nperseg)
        };
        let (streamed, largest, peak) = stream(&x, 100.0, &cfg, &sizes);
        assert!(
            peak < nperseg,
            "held {peak} samples (chunks up to {largest})"
        );
        let one_shot = welch(&x, 100.0, &cfg).unwrap();
        assert_psd_close(&streamed.value, &one_shot.value, STREAM_TOL, "long stream");
        assert_eq!(streamed.segments, 399);
    }
}

#[test]
fn sample_by_sample_pushes_work() {
    let x = Rng::new(9).white(777, 1.0);
    let cfg = WelchConfig {
        noverlap: Some(40),
        nfft: Some(101),
        ..WelchConfig::new(64)
    };
    let (streamed, _, peak) = stream(&x, 1.0, &cfg, &[1]);
    assert!(peak < 64);
    assert_psd_close(
        &streamed.value,
        &welch(&x, 1.0, &cfg).unwrap().value,
        STREAM_TOL,
        "one by one",
    );
}

#[test]
fn channels_are_independent() {
    // Three channels pushed together equal three single-channel estimates.
    let mut rng = Rng::new(10);
    let xs: Vec<Vec<f64>> = (0..3).map(|c| rng.white(20_000, 1.0 + c as f64)).collect();
    for average in [Average::Mean, Average::Median] {
        let cfg = WelchConfig {
            average,
            ..WelchConfig::new(256)
        };
        let plan = cfg.validate().unwrap();
        let mut acc = WelchAccumulator::new(plan.clone(), 50.0, 3);
        for start in (0..20_000).step_by(3001) {
            let end = (start + 3001).min(20_000);
            acc.push(&[&xs[0][start..end], &xs[1][start..end], &xs[2][start..end]]);
        }
        let together = acc.finish().unwrap();
        let refs: Vec<&[f64]> = xs.iter().map(|x| x.as_slice()).collect();
        let one_shot = welch_with_plan(&refs, 50.0, &plan).unwrap();
        for (c, x) in xs.iter().enumerate() {
            let alone = welch(x, 50.0, &cfg).unwrap();
            assert_psd_close(
                &together[c].value,
                &alone.value,
                STREAM_TOL,
                "streamed channel",
            );
            assert_psd_close(
                &one_shot[c].value,
                &alone.value,
                STREAM_TOL,
                "one-shot channel",
            );
        }
    }
}
