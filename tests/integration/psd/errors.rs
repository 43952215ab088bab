//! Bad input: clear errors, never a panic.

use imunoise::psd::{
    log_bin, welch, Average, Detrend, PsdError, Scaling, WelchAccumulator, WelchConfig, Window,
};
use proptest::prelude::*;

#[test]
fn too_short_names_both_lengths() {
    let err = welch(&[0.0; 100], 10.0, &WelchConfig::new(256)).unwrap_err();
    assert_eq!(
        err,
        PsdError::TooShort {
            n: 100,
            nperseg: 256
        }
    );
    let msg = err.to_string();
    assert!(msg.contains("100") && msg.contains("256"), "{msg}");
    // Streaming: the total pushed counts, not the last chunk.
    let mut acc = WelchAccumulator::new(WelchConfig::new(256).validate().unwrap(), 10.0, 2);
    acc.push(&[&[1.0; 200], &[2.0; 200]]);
    acc.push(&[&[1.0; 55], &[2.0; 55]]);
    assert_eq!(
        acc.finish().unwrap_err(),
        PsdError::TooShort {
            n: 255,
            nperseg: 256
        }
    );
}

#[test]
fn invalid_combinations_are_rejected_with_the_numbers() {
    let cases = [
        (
            WelchConfig {
                noverlap: Some(64),
                ..WelchConfig::new(64)
            },
            "noverlap (64)",
        ),
        (
            WelchConfig {
                nfft: Some(63),
                ..WelchConfig::new(64)
            },
            "nfft (63)",
        ),
        (WelchConfig::new(0), "nperseg"),
        (
            WelchConfig {
                window: Window::Custom(vec![1.0; 10]),
                ..WelchConfig::new(64)
            },
            "10 coefficients",
        ),
        (
            WelchConfig {
                nfft: Some(usize::MAX),
                ..WelchConfig::new(64)
            },
            "limit",
        ),
    ];
    for (cfg, needle) in cases {
        let err = welch(&[0.0; 1000], 1.0, &cfg).unwrap_err();
        assert!(matches!(err, PsdError::InvalidConfig(_)), "{err:?}");
        assert!(err.to_string().contains(needle), "{err} lacks {needle:?}");
    }
    for rate in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let err = welch(&[0.0; 1000], rate, &WelchConfig::new(64)).unwrap_err();
        assert!(err.to_string().contains("sample rate"), "{err}");
    }
}

#[test]
fn misused_accumulator_reports_at_finish() {
    let plan = WelchConfig::new(8).validate().unwrap();
    let mut acc = WelchAccumulator::new(plan.clone(), 1.0, 2);
    acc.push(&[&[0.0; 16]]);
    acc.push(&[&[0.0; 16], &[0.0; 16]]); // ignored after the first error
    assert_eq!(
        acc.finish().unwrap_err(),
        PsdError::ChannelMismatch {
            expected: 2,
            got: 1
        }
    );
    let mut acc = WelchAccumulator::new(plan, 1.0, 2);
    acc.push(&[&[0.0; 16], &[0.0; 15]]);
    assert_eq!(
        acc.finish().unwrap_err(),
        PsdError::LengthMismatch {
            channel: 1,
            len: 15,
            expected: 16
        }
    );
}

#[test]
fn non_finite_samples_propagate_without_panicking() {
    let mut x = vec![0.5; 1000];
    x[300] = f64::NAN;
    x[700] = f64::INFINITY;
    for average in [Average::Mean, Average::Median] {
        let cfg = WelchConfig {
            average,
            ..WelchConfig::new(128)
        };
        let psd = welch(&x, 1.0, &cfg).unwrap();
        assert!(
            psd.value.iter().any(|v| !v.is_finite()),
            "{average}: a bad sample must show"
        );
        let _ = log_bin(&psd, 10);
    }
}

#[test]
fn option_names_parse_and_print_like_scipy() {
    for name in [
        "hann",
        "hamming",
        "blackman",
        "blackmanharris",
        "flattop",
        "boxcar",
    ] {
        assert_eq!(name.parse::<Window>().unwrap().to_string(), name);
    }
    for name in ["constant", "linear", "none"] {
        assert_eq!(name.parse::<Detrend>().unwrap().to_string(), name);
    }
    for name in ["density", "spectrum"] {
        assert_eq!(name.parse::<Scaling>().unwrap().to_string(), name);
    }
    for name in ["mean", "median"] {
        assert_eq!(name.parse::<Average>().unwrap().to_string(), name);
    }
    let err = "welch".parse::<Average>().unwrap_err().to_string();
    assert!(
        err.contains("welch") && err.contains("mean, median"),
        "{err}"
    );
    assert_eq!(
        serde_json::to_string(&Scaling::Density).unwrap(),
        "\"density\""
    );
    assert_eq!(
        serde_json::to_string(&Window::BlackmanHarris).unwrap(),
        "\"blackmanharris\""
    );
}

fn any_window() -> impl Strategy<Value = Window> {
    prop_oneof![
        Just(Window::Hann),
        Just(Window::Hamming),
        Just(Window::Blackman),
        Just(Window::BlackmanHarris),
        Just(Window::Flattop),
        Just(Window::Boxcar),
        prop::collection::vec(prop_oneof![Just(0.0), -2.0..2.0f64, Just(f64::NAN)], 0..80)
            .prop_map(Window::Custom),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn no_config_or_length_panics(
        window in any_window(),
        nperseg in 0usize..80,
        noverlap in prop::option::of(0usize..100),
        nfft in prop::option::of(0usize..200),
        detrend in prop_oneof![Just(Detrend::Constant), Just(Detrend::Linear), Just(Detrend::None)],
        scaling in prop_oneof![Just(Scaling::Density), Just(Scaling::Spectrum)],
        average in prop_oneof![Just(Average::Mean), Just(Average::Median)],
        n in 0usize..600,
        rate in prop_oneof![Just(0.0), Just(f64::NAN), -5.0..1e4f64],
        bpd in 0u32..40,
        fit_custom in any::<bool>(),
    ) {
        // Half the custom windows are made the right length, so that they get past validation.
        let window = match window {
            Window::Custom(mut v) if fit_custom => {
                v.resize(nperseg, 0.5);
                Window::Custom(v)
            }
            w => w,
        };
        let cfg = WelchConfig { window, nperseg, noverlap, nfft, detrend, scaling, average };
        let x: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
        match welch(&x, rate, &cfg) {
            Ok(psd) => {
                let plan = cfg.validate().unwrap();
                prop_assert_eq!(psd.value.len(), plan.nfft() / 2 + 1);
                prop_assert_eq!(psd.segments, (n - plan.noverlap()) / plan.step());
                prop_assert_eq!(psd.dof.len(), psd.value.len());
                let binned = log_bin(&psd, bpd);
                let nyquist = usize::from(plan.nfft().is_multiple_of(2));
                let binned_bins = binned.bins.iter().map(|&b| b as usize).sum::<usize>();
                prop_assert_eq!(binned_bins, psd.value.len() - 1 - nyquist);
            }
            Err(PsdError::TooShort { n: short, nperseg: need }) => {
                prop_assert_eq!(short, n);
                prop_assert!(n < need);
            }
            Err(PsdError::InvalidConfig(_)) => {}
            Err(e) => prop_assert!(false, "unexpected error {e:?}"),
        }
    }
}
