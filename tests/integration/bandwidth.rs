//! The sensor's low-pass filter: found in the spectrum, the fits kept inside the band where the
//! recording follows the IEEE model, no effect claimed from the filter's edge; nothing found where
//! there is no filter. The simulator's filter (digital Butterworth sections, `sim/lowpass.rs`) is
//! an implementation independent of the detector's response family.

use crate::support::{repo_root, term_value};
use imunoise::avar::{compute, Confidence, Statistic, TauGrid};
use imunoise::effects::{close_loop, LoopConfig, LoopOutcome};
use imunoise::model::{BandEdge, CoefUnit, Coefficients, Decimator, FilterForm, LowPass, Term};
use imunoise::sim::{lowpass_power_gain, simulate, LowPassSpec, SimSpec};
use serde_json::json;

const FS: f64 = 100.0;

fn config() -> LoopConfig {
    crate::support::loop_config()
}

fn truth() -> Coefficients {
    crate::support::loop_gyro()
}

/// N from both of the loop's final fits within `tolerance` (relative) of the truth.
fn assert_n_within(o: &LoopOutcome, tolerance: f64) {
    for fit in [o.allan.as_ref(), o.spectrum.as_ref()] {
        let fit = fit.expect("fit");
        let n = fit.get(Term::RandomWalk).expect("N kept").value;
        assert!(
            (n / truth().n - 1.0).abs() < tolerance,
            "{:?}: N {n}",
            fit.domain
        );
    }
}

fn record(lowpass: Option<LowPassSpec>, seconds: f64, seed: u64) -> Vec<f64> {
    let spec = json!({ "rate_hz": FS, "duration_s": seconds, "seed": seed,
        "channels": [{ "name": "g", "sensor": "gyro", "noise": truth(), "lowpass": lowpass }] });
    let spec: SimSpec = serde_json::from_value(spec).unwrap();
    simulate(&spec).unwrap().channels.remove(0).samples
}

#[test]
fn a_sensor_low_pass_is_found_and_the_fits_stay_inside_it() {
    for (seed, order, corner_hz) in [(61, 2, 20.0), (62, 4, 30.0), (63, 1, 10.0)] {
        let lp = LowPassSpec { corner_hz, order };
        let y = record(Some(lp), 3000.0, seed);
        let o = close_loop(&y, FS, &[], &config(), None).expect("loop ran");
        let b = o.report.bandwidth.expect("roll-off found");
        println!(
            "order {order} at {corner_hz} Hz: fitted {:?} order {} at {:.2} Hz, band f ≤ {:.2} Hz, τ ≥ {:?} s",
            b.lowpass.form, b.lowpass.order, b.lowpass.corner_hz, b.fit_max_freq_hz, b.fit_min_tau_s
        );
        assert!(
            (b.lowpass.corner_hz / corner_hz - 1.0).abs() < 0.25,
            "{b:?}"
        );
        // The band kept: the true filter has lost at most 3 % of the power there.
        let loss = 1.0 - lowpass_power_gain(&lp, FS, b.fit_max_freq_hz);
        assert!(loss <= 0.03, "loss {loss} at {}", b.fit_max_freq_hz);
        assert!(b.fit_min_tau_s.is_some_and(|t| t <= 2.0), "{b:?}");
        // No effect from the filter's edge.
        for s in &o.report.steps {
            assert!(
                !matches!(s.effect.kind(), "resonance" | "gauss_markov" | "sinusoid"),
                "order {order}: {} added",
                s.effect.kind()
            );
        }
        // N from both fits within 4 % of the truth.
        assert_n_within(&o, 0.04);
    }
}

/// A user's band limit far below the filter (`--fit-max-freq`): the filter is still found over
/// the whole spectrum; the spectrum fit keeps the user's band, and the Allan fit starts where
/// that band's edge allows (τ ≥ 7.6/4 Hz: 2.56 s on the octave grid), above the filter's droop.
/// Searched inside the user's band, the filter went unseen and N came out "not significant"
/// with an upper limit of 0.46× the truth.
#[test]
fn a_user_band_limit_keeps_the_filter_found() {
    let lp = LowPassSpec {
        corner_hz: 20.0,
        order: 2,
    };
    let y = record(Some(lp), 3000.0, 64);
    let mut cfg = config();
    cfg.fit.max_freq_hz = Some(4.0);
    let o = close_loop(&y, FS, &[], &cfg, None).expect("loop ran");
    let b = o
        .report
        .bandwidth
        .expect("roll-off found beyond the user's band");
    assert!((b.lowpass.corner_hz / 20.0 - 1.0).abs() < 0.25, "{b:?}");
    assert!(b.fit_max_freq_hz <= 4.0, "the user's band: {b:?}");
    assert!(
        b.fit_min_tau_s.is_some_and(|t| (t - 2.56).abs() < 1e-9),
        "{b:?}"
    );
    let allan = o.allan.as_ref().expect("Allan fit");
    assert!(allan.points.iter().all(|p| p.x >= 2.56 * (1.0 - 1e-9)));
    assert_n_within(&o, 0.04);
}

#[test]
fn no_roll_off_is_claimed_without_a_filter() {
    for seed in 70..74 {
        let y = record(None, 3000.0, seed);
        let o = close_loop(&y, FS, &[], &config(), None).expect("loop ran");
        assert!(
            o.report.bandwidth.is_none(),
            "seed {seed}: {:?}",
            o.report.bandwidth
        );
    }
}

/// An unfiltered gyro whose integrated angle is rounded to Q = 0.9 arcsec (a step of 3.5
/// per-sample angle σ: the output on four or five levels): its rounding error is correlated from
/// sample to sample and the spectrum falls 12–15 % below IEEE 952's quantisation form over the
/// top fifth of the band, which the detector reads as a roll-off. The edge is attributed to the
/// grid, not to a filter (the band is kept: the IEEE model does not hold above it), and N comes
/// out within 5 %. The control, a real filter whose output is rounded as a rate (white rounding, no Q),
/// keeps its filter.
#[test]
fn a_coarse_angle_quantiser_is_not_taken_for_a_filter() {
    let q = 4.363e-6;
    for seed in 80..83 {
        let mut noise = serde_json::to_value(truth()).unwrap();
        noise["q"] = json!(q);
        let spec = json!({ "rate_hz": FS, "duration_s": 1800.0, "seed": seed,
            "channels": [{ "name": "g", "sensor": "gyro", "noise": noise }] });
        let spec: SimSpec = serde_json::from_value(spec).unwrap();
        let y = simulate(&spec).unwrap().channels.remove(0).samples;
        let o = close_loop(&y, FS, &[], &config(), None).expect("loop ran");
        let b = o.report.bandwidth.expect("the edge is found");
        let BandEdge::AngleQuantiser {
            step,
            steps_per_sigma,
        } = b.cause
        else {
            panic!("seed {seed}: a filter claimed: {b:?}");
        };
        assert!(!b.is_filter());
        // The grid: √12·Q·fs; white σ of the output: N·√fs.
        assert!(
            (step / (12f64.sqrt() * q * FS) - 1.0).abs() < 1e-6,
            "{step}"
        );
        let r = step / (truth().n * FS.sqrt());
        assert!(
            (steps_per_sigma / r - 1.0).abs() < 0.05,
            "{steps_per_sigma} vs {r}"
        );
        assert_n_within(&o, 0.05);
        // Q within ×/÷ 1.25 in both fits, not closer: the correlated error is not IEEE 952's
        // white one (the spectrum's Q read 1.07–1.08× on these seeds, from its +5 % excess at
        // 10–20 Hz; the Allan Q 0.82–1.11×, its shortest τ cut at the band's edge).
        for fit in [o.allan.as_ref(), o.spectrum.as_ref()] {
            let fit = fit.unwrap();
            let ratio = fit.get(Term::Quantization).expect("Q kept").value / q;
            assert!(
                (0.8..1.25).contains(&ratio),
                "seed {seed} {:?}: Q {ratio}× the truth",
                fit.domain
            );
        }
    }
    // The control: order 2 at 20 Hz, the rate rounded to one white σ.
    let lsb = truth().n * FS.sqrt();
    let spec = json!({ "rate_hz": FS, "duration_s": 1800.0, "seed": 84,
        "channels": [{ "name": "g", "sensor": "gyro", "noise": truth(),
            "lowpass": { "corner_hz": 20.0, "order": 2 }, "lsb": lsb }] });
    let spec: SimSpec = serde_json::from_value(spec).unwrap();
    let y = simulate(&spec).unwrap().channels.remove(0).samples;
    let o = close_loop(&y, FS, &[], &config(), None).expect("loop ran");
    let b = o.report.bandwidth.expect("roll-off found");
    assert!(b.is_filter(), "{b:?}");
    assert!((b.lowpass.corner_hz / 20.0 - 1.0).abs() < 0.25, "{b:?}");
}

/// The Allan bias of filtered white noise that sets the band's shortest τ, against Allan
/// variances measured on white noise through the simulator's filter.
#[test]
fn white_noise_allan_bias_matches_the_measured_one() {
    let lp = LowPassSpec {
        corner_hz: 15.0,
        order: 4,
    };
    let model = LowPass {
        corner_hz: 15.0,
        order: 4,
        form: FilterForm::Digital { rate_hz: FS },
        decimator: None,
    };
    let n = CoefUnit::DegPerSqrtH.to_si(0.15);
    let spec = json!({ "rate_hz": FS, "duration_s": 10_000.0, "seed": 5,
        "channels": [{ "name": "g", "sensor": "gyro", "noise": { "n": n }, "lowpass": lp }] });
    let spec: SimSpec = serde_json::from_value(spec).unwrap();
    let y = simulate(&spec).unwrap().channels.remove(0).samples;
    let d = compute(
        &y,
        FS,
        &TauGrid::Explicit(vec![1, 2, 4, 8, 16, 32]),
        Statistic::Oadev,
        Confidence::OneSigma,
    )
    .unwrap();
    for i in 0..d.len() {
        let measured = 1.0 - d.variance[i] * d.tau_s[i] / (n * n);
        let predicted = model.white_avar_bias(FS, d.m[i]);
        let sd = (2.0 / d.edf[i]).sqrt();
        println!(
            "m = {}: measured loss {measured:.4}, predicted {predicted:.4} (±{sd:.4})",
            d.m[i]
        );
        assert!(
            (measured - predicted).abs() < 4.0 * sd + 1e-3,
            "m = {}",
            d.m[i]
        );
    }
}

/// An accelerometer behind a digital low-pass (order 2 at 25 Hz) with two lines that wander in
/// frequency and amplitude, one strong (12 Hz, beyond the fit band's 2 % edge, inside the filter's
/// corner) and one weak (5.3 Hz, ≈ 8× the floor): both are found as lines with a width, and
/// nothing else is added (no steps, no Gauss–Markov hump from the lines' Allan signature, no
/// resonance from the filter). Each power is checked against the power the lines really have in
/// this record (the same simulation without noise, integrated over ±1 Hz of its Welch spectrum:
/// as recorded, as the detector reports it): a wandering amplitude makes
/// the realised power differ from A²(1 + δa²)/2 by 3.3 % (1σ) over 3000 s.
#[test]
fn wandering_lines_are_found_as_lines_with_a_width() {
    let lp = json!({ "corner_hz": 25.0, "order": 2 });
    let wander = |f: f64, a: f64, tc: f64| json!({ "freq_wander_hz": f, "amplitude_wander": a, "wander_tc_s": tc });
    let spec = json!({ "rate_hz": FS, "duration_s": 3000.0, "seed": 4243,
        "channels": [{ "name": "a", "sensor": "accel", "noise": { "n": 1e-3, "b": 2e-4 }, "lowpass": lp,
            "sinusoids": [
                { "amplitude": 6e-3, "freq_hz": 12.0, "wander": wander(0.05, 0.2, 10.0) },
                { "amplitude": 1.8e-3, "freq_hz": 5.3, "wander": wander(0.02, 0.1, 30.0) }] }] });
    let mut spec: SimSpec = serde_json::from_value(spec).unwrap();
    let y = simulate(&spec).unwrap().channels.remove(0).samples;
    let o = close_loop(&y, FS, &[], &config(), None).expect("loop ran");
    let kinds: Vec<&str> = o.report.steps.iter().map(|s| s.effect.kind()).collect();
    assert_eq!(kinds, ["narrowband", "narrowband"], "{:?}", o.report.steps);
    // The lines alone (their wander has its own random streams: the same realisation).
    spec.channels[0].noise = Coefficients::default();
    let lines = simulate(&spec).unwrap().channels.remove(0).samples;
    let lines_psd =
        imunoise::psd::welch(&lines, FS, &imunoise::psd::WelchConfig::new(4096)).unwrap();
    // The lines' power as recorded (the narrow band's convention, as a line's amplitude is
    // point-sampled): their own spectrum's excess within 1 Hz.
    let realised = |f0: f64| {
        (0..lines_psd.freq_hz.len())
            .filter(|&k| (lines_psd.freq_hz[k] - f0).abs() <= 1.0)
            .map(|k| lines_psd.value[k])
            .sum::<f64>()
            * lines_psd.bin_width_hz()
    };
    let filt = LowPassSpec {
        corner_hz: 25.0,
        order: 2,
    };
    for (f0, amp, rel) in [(12.0, 6e-3, 0.2), (5.3, 1.8e-3, 0.1)] {
        let nb = o
            .report
            .steps
            .iter()
            .find_map(|s| match &s.effect {
                imunoise::effects::Effect::Narrowband(nb) if (nb.freq_hz - f0).abs() < 0.1 => {
                    Some(nb.clone())
                }
                _ => None,
            })
            .unwrap_or_else(|| panic!("no line at {f0} Hz"));
        // Expected power of the continuous line after the sensor's filter: A²(1 + δa²)/2·|H|².
        let expected: f64 = amp * amp * (1.0 + rel * rel) / 2.0 * lowpass_power_gain(&filt, FS, f0);
        let truth = realised(f0);
        println!(
            "{f0} Hz: power {:.4e} [{:.4e}, {:.4e}], realised {truth:.4e}, expected {expected:.4e}, width {:.3} Hz",
            nb.power, nb.power_lo, nb.power_hi, nb.width_hz
        );
        assert!(
            (truth / expected - 1.0).abs() < 0.15,
            "realised {truth} vs {expected}"
        );
        assert!((nb.power / truth - 1.0).abs() < 0.05, "{nb:?}");
        assert!(nb.coherent_share < 0.5);
    }
}

/// A resonance between the fit band's edge and the filter's corner is a peak, not the filter's
/// transition: found and measured as a band at its frequency with its power (the resonance's
/// variance through the filter), where it was once dismissed as the filter's edge. Nothing else
/// is added, and the same filter without the resonance gets nothing beyond the band.
#[test]
fn a_resonance_beyond_the_fit_band_is_measured_not_dismissed() {
    let filt = LowPassSpec {
        corner_hz: 25.0,
        order: 2,
    };
    let (f0, q, sigma) = (18.0, 30.0, 1.5e-4);
    let spec = |resonances: serde_json::Value| {
        let spec = json!({ "rate_hz": FS, "duration_s": 1800.0, "seed": 31_337,
            "channels": [{ "name": "g", "sensor": "gyro", "noise": truth(), "lowpass": filt,
                "resonances": resonances }] });
        serde_json::from_value::<SimSpec>(spec).unwrap()
    };
    let y = simulate(&spec(json!([{ "f0_hz": f0, "q": q, "sigma": sigma }])))
        .unwrap()
        .channels
        .remove(0)
        .samples;
    let o = close_loop(&y, FS, &[], &config(), None).expect("loop ran");
    let band = o.report.bandwidth.as_ref().expect("roll-off found");
    assert!(band.fit_max_freq_hz < f0, "{band:?}");
    let kinds: Vec<&str> = o.report.steps.iter().map(|s| s.effect.kind()).collect();
    assert_eq!(kinds, ["narrowband"], "{:?}", o.report.steps);
    let imunoise::effects::Effect::Narrowband(nb) = &o.report.steps[0].effect else {
        unreachable!()
    };
    // The resonance's variance through the filter (its band is a few tenths of a Hz wide, where
    // the filter's gain barely changes), against the measured power with its interval.
    let expected = sigma * sigma * lowpass_power_gain(&filt, FS, f0);
    println!(
        "peak at {:.3} Hz, width {:.3} Hz, power {:.3e} [{:.3e}, {:.3e}], expected {expected:.3e}",
        nb.freq_hz, nb.width_hz, nb.power, nb.power_lo, nb.power_hi
    );
    assert!((nb.freq_hz - f0).abs() < 0.1, "{nb:?}");
    assert!((nb.power / expected - 1.0).abs() < 0.2, "{nb:?}");
    assert!(
        nb.width_hz > 2.0 * f0 / q / 3.0 && nb.width_hz < 4.0 * f0 / q,
        "{nb:?}"
    );
    // The same sensor without the resonance: nothing claimed beyond the band.
    let clean = simulate(&spec(json!([])))
        .unwrap()
        .channels
        .remove(0)
        .samples;
    let o = close_loop(&clean, FS, &[], &config(), None).expect("loop ran");
    for s in &o.report.steps {
        assert!(
            !matches!(s.effect.kind(), "narrowband" | "resonance" | "sinusoid"),
            "{} added to a clean filtered record",
            s.effect.kind()
        );
    }
}

/// A strong resonance inside the filter's band (Q 20 at 7 Hz, σ 3e-4 rad/s, about 15× the floor
/// at its peak; a 2nd-order 30-Hz filter at 100 Hz): the band edge's check on the data must not
/// read the bands beside the peak as the filter's deficit. It had walked the edge down below the
/// peak; the resonance's skirt left in the band then passed for a Gauss–Markov process and
/// excursions, steps and drifts followed. Now the edge stays above the peak and the loop adds the
/// resonance and nothing else.
#[test]
fn a_strong_resonance_does_not_pull_the_band_edge_below_itself() {
    let filt = LowPassSpec {
        corner_hz: 26.0,
        order: 4,
    };
    let (f0, q, sigma) = (7.0, 20.0, 3e-4);
    for seed in [41_001, 41_002, 41_003] {
        let spec = json!({ "rate_hz": FS, "duration_s": 1800.0, "seed": seed,
            "channels": [{ "name": "g", "sensor": "gyro", "noise": truth(), "lowpass": filt,
                "resonances": [{ "f0_hz": f0, "q": q, "sigma": sigma }] }] });
        let spec: SimSpec = serde_json::from_value(spec).unwrap();
        let y = simulate(&spec).unwrap().channels.remove(0).samples;
        let o = close_loop(&y, FS, &[], &config(), None).expect("loop ran");
        let band = o.report.bandwidth.as_ref().expect("roll-off found");
        let kinds: Vec<&str> = o.report.steps.iter().map(|s| s.effect.kind()).collect();
        println!(
            "seed {seed}: band f ≤ {:.2} Hz; added {kinds:?}",
            band.fit_max_freq_hz
        );
        assert!(
            band.fit_max_freq_hz > f0 * (1.0 + 1.0 / q),
            "seed {seed}: {band:?}"
        );
        assert_eq!(kinds.len(), 1, "seed {seed}: {kinds:?}");
        assert!(
            matches!(kinds[0], "resonance" | "narrowband"),
            "seed {seed}: {kinds:?}"
        );
    }
}

/// White noise through the simulator's CIC decimator (k moving averages at 4× and 16× the rate,
/// every D-th sample kept, in the time domain) has the folded response the detector's
/// [`Decimator`] computes from the filter's autocorrelation: Welch's band averages within 2.5 %
/// (each band averages about 2 000 bins of 67 segments: 1σ ≈ 0.3 %).
#[test]
fn the_simulated_decimator_has_the_folded_response() {
    let n = truth().n;
    for (stages, factor) in [(3, 4), (2, 16)] {
        let spec = json!({ "rate_hz": FS, "duration_s": 2800.0, "seed": 95,
            "channels": [{ "name": "g", "sensor": "gyro", "noise": { "n": n },
                "decimator": { "stages": stages, "factor": factor } }] });
        let spec: SimSpec = serde_json::from_value(spec).unwrap();
        let y = simulate(&spec).unwrap().channels.remove(0).samples;
        let psd = imunoise::psd::welch(&y, FS, &imunoise::psd::WelchConfig::new(4096)).unwrap();
        let dec = Decimator::new(stages, Some(factor)).unwrap();
        for (lo, hi) in [(1.0, 5.0), (15.0, 20.0), (30.0, 35.0), (44.0, 49.0)] {
            let bins: Vec<usize> = (0..psd.freq_hz.len())
                .filter(|&k| (lo..hi).contains(&psd.freq_hz[k]))
                .collect();
            let measured = bins.iter().map(|&k| psd.value[k]).sum::<f64>();
            let model = bins
                .iter()
                .map(|&k| 2.0 * n * n * dec.power_gain(psd.freq_hz[k], FS))
                .sum::<f64>();
            assert!(
                (measured / model - 1.0).abs() < 0.025,
                "sinc^{stages} ↓{factor} {lo}–{hi} Hz: {measured:e} vs {model:e}"
            );
        }
    }
}

/// A sinc³ decimator (↓4, 400 Hz inside) and then a 2nd-order digital low-pass at 25 Hz, as a
/// sigma-delta MEMS part filters its output; and a sinc³ decimator alone (↓16). No Butterworth
/// shape follows the decimator's droop (one was read 30–40 % too high in frequency and left N
/// about 1 % low with a ±0.25 % interval). Both chains are read as what they are: the stages
/// exact, the low-pass's corner within 5 %, nothing added, and N within 3 % in both fits: the
/// sinc³ droop is 2 % at 4.6 Hz, so the spectrum fit keeps 0.02–4.6 Hz, where N's 1σ is 0.7 %
/// (four seeds of the first chain read 0.980, 0.995, 1.009, 0.998 × the truth).
#[test]
fn a_sinc_decimator_is_read_as_one() {
    for (seed, lowpass, factor) in [
        (
            96,
            Some(LowPassSpec {
                corner_hz: 25.0,
                order: 2,
            }),
            4,
        ),
        (97, None, 16),
    ] {
        let spec = json!({ "rate_hz": FS, "duration_s": 3000.0, "seed": seed,
            "channels": [{ "name": "g", "sensor": "gyro", "noise": truth(), "lowpass": lowpass,
                "decimator": { "stages": 3, "factor": factor } }] });
        let spec: SimSpec = serde_json::from_value(spec).unwrap();
        let y = simulate(&spec).unwrap().channels.remove(0).samples;
        let o = close_loop(&y, FS, &[], &config(), None).expect("loop ran");
        let b = o.report.bandwidth.expect("roll-off found");
        println!("seed {seed}: {:?}", b.lowpass);
        let d = b.lowpass.decimator.expect("a decimator read");
        assert_eq!(d.stages, 3, "{b:?}");
        match lowpass {
            Some(lp) => {
                assert_eq!(b.lowpass.order, lp.order, "{b:?}");
                assert!(
                    (b.lowpass.corner_hz / lp.corner_hz - 1.0).abs() < 0.05,
                    "{b:?}"
                );
            }
            None => assert_eq!(b.lowpass.order, 0, "{b:?}"),
        }
        assert!(o.report.steps.is_empty(), "{:?}", o.report.steps);
        assert_n_within(&o, 0.03);
    }
}

/// An independent generator's sigma-delta gyro (`tests/data/cic/PROVENANCE.md`): a sinc³
/// decimator and a 2nd-order 50-Hz low-pass (200 Hz) is read as that chain, and a sinc²
/// decimator alone (a first-order low-pass at fs/4 over a third-level floor, the same shape)
/// gets a band that loses at most 2.5 % of its true response. N within 3 % on both (10 min: the
/// spectrum fit's 1σ is about 0.8 %).
#[test]
fn an_independent_sigma_delta_gyro_is_read_as_its_chain() {
    let dir = repo_root().join("tests/data/cic");
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("truth.json")).unwrap()).unwrap();
    let out = tempfile::tempdir().unwrap();
    crate::support::run_ok(
        &[
            "analyze",
            dir.join("cic_gyro_10min.parquet").to_str().unwrap(),
            "-o",
            "out",
            "--backend",
            "cpu",
            "--quiet",
        ],
        out.path(),
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.path().join("out/report.json")).unwrap())
            .unwrap();
    let fs = truth["rate_hz"].as_f64().unwrap();
    for a in report["files"][0]["analysis"].as_array().unwrap() {
        let name = a["channel"].as_str().unwrap();
        let t = &truth["channels"][name];
        let band = &a["bandwidth"];
        let lp = &band["lowpass"];
        if name == "gyro_a" {
            assert_eq!(lp["decimator"]["stages"], 3, "{band}");
            assert_eq!(lp["order"], 2, "{band}");
            let corner = lp["corner_hz"].as_f64().unwrap();
            assert!((corner / 50.0 - 1.0).abs() < 0.05, "{band}");
        } else {
            let d = &t["decimator"];
            let dec = Decimator::new(
                d["stages"].as_u64().unwrap() as u32,
                Some(d["factor"].as_u64().unwrap() as u32),
            )
            .unwrap();
            let edge = band["fit_max_freq_hz"].as_f64().unwrap();
            let loss = 1.0 - dec.power_gain(edge, fs);
            assert!(loss <= 0.025, "{name}: loss {loss} at {edge} Hz ({band})");
        }
        let n = term_value(a, "random_walk").expect("N");
        let want = t["N_with_rounding"].as_f64().unwrap();
        assert!((n / want - 1.0).abs() < 0.03, "{name}: N {n:e} vs {want:e}");
    }
}

/// An analog filter sampled with nothing more to stop its tail (a part that filters at 800 Hz and
/// keeps every 8th sample): the tail above Nyquist folds back and the spectrum rises towards
/// Nyquist from the analog form's. Read in the sampled form at its corner; N the output's white
/// level, aliased noise included, as the Allan deviation reads it. In the analog form the corner
/// had come out 5 % low and the folded noise at the Allan fit's shortest τ had been taken for
/// angle quantisation.
#[test]
fn an_analog_filter_sampled_without_anti_aliasing_is_read_folded() {
    let fast = FS * 8.0;
    for (seed, corner_hz) in [(71, 30.0), (72, 25.0)] {
        let spec = json!({ "rate_hz": fast, "duration_s": 1800.0, "seed": seed,
            "channels": [{ "name": "g", "sensor": "gyro", "noise": truth(),
                "lowpass": { "corner_hz": corner_hz, "order": 2 } }] });
        let spec: SimSpec = serde_json::from_value(spec).unwrap();
        let y: Vec<f64> = simulate(&spec).unwrap().channels.remove(0).samples;
        let y: Vec<f64> = y.iter().step_by(8).copied().collect();
        let o = close_loop(&y, FS, &[], &config(), None).expect("loop ran");
        let b = o.report.bandwidth.expect("roll-off found");
        println!(
            "{corner_hz} Hz: {:?} order {} at {:.2} Hz, band f ≤ {:.2} Hz, τ ≥ {:?} s",
            b.lowpass.form,
            b.lowpass.order,
            b.lowpass.corner_hz,
            b.fit_max_freq_hz,
            b.fit_min_tau_s
        );
        assert_eq!(b.lowpass.form, FilterForm::Sampled { rate_hz: FS }, "{b:?}");
        assert_eq!(b.lowpass.order, 2, "{b:?}");
        assert!(
            (b.lowpass.corner_hz / corner_hz - 1.0).abs() < 0.03,
            "{b:?}"
        );
        // The output's white level: the sensor's N times the folded gain at 0 Hz.
        let images: f64 = (-2..=2)
            .map(|k: i32| 1.0 / (1.0 + (f64::from(k) * FS / corner_hz).powi(4)))
            .sum();
        let n_out = truth().n * images.sqrt();
        for fit in [o.allan.as_ref(), o.spectrum.as_ref()] {
            let fit = fit.expect("fit");
            let n = fit.get(Term::RandomWalk).expect("N kept");
            assert!(
                (n.value / n_out - 1.0).abs() < 0.01,
                "{:?}: {n:?} vs {n_out}",
                fit.domain
            );
            // No angle quantisation made of the folded noise.
            assert!(
                fit.get(Term::Quantization)
                    .is_none_or(|q| q.one_sigma.0 <= 0.0),
                "{:?}: {:?}",
                fit.domain,
                fit.get(Term::Quantization)
            );
        }
    }
}
