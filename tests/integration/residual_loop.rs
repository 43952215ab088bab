//! The residual loop on simulated recordings whose effects are not declared to it: each is found,
//! named and fitted, and the error falls; pure IEEE-model data get nothing added.

use imunoise::effects::{close_loop, AuxSeries, Effect, LoopConfig, LoopOutcome};
use imunoise::model::{FitWarning, GaussMarkov, Term};
use imunoise::sim::{simulate, SimSpec};
use serde_json::json;

const FS: f64 = 100.0;

fn config() -> LoopConfig {
    crate::support::loop_config()
}

/// A gyro with N = 0.15 °/√h, B = 3 °/h, K = 20 °/h/√h plus `extra` (JSON fields of the channel
/// spec), `seconds` long at 100 Hz; returns the gyro and, with a temperature, that channel.
fn record(extra: serde_json::Value, temperature: bool, seconds: f64, seed: u64) -> Vec<Vec<f64>> {
    let noise = crate::support::loop_gyro();
    let mut ch = json!({ "name": "g", "sensor": "gyro", "noise": noise });
    for (k, v) in extra.as_object().unwrap() {
        ch[k] = v.clone();
    }
    let mut spec = json!({ "rate_hz": FS, "duration_s": seconds, "seed": seed, "channels": [ch] });
    if temperature {
        spec["temperature"] = json!({ "start_degc": 20.0, "rise_degc": 4.0, "warmup_s": 600.0,
            "wander": { "sigma": 0.3, "tc_s": 300.0 }, "noise_degc": 0.01 });
    }
    let spec: SimSpec = serde_json::from_value(spec).unwrap();
    let (columns, _) = simulate(&spec).unwrap().into_columns();
    columns
}

fn run(columns: &[Vec<f64>]) -> LoopOutcome {
    let aux: Vec<AuxSeries<'_>> = columns[1..]
        .iter()
        .map(|s| AuxSeries {
            name: "temperature",
            samples: s,
        })
        .collect();
    close_loop(&columns[0], FS, &aux, &config(), None).expect("loop ran")
}

fn kinds(o: &LoopOutcome) -> Vec<&'static str> {
    o.report.steps.iter().map(|s| s.effect.kind()).collect()
}

/// The error figures fall with each step, in the domain where the effect lives.
fn assert_error_falls(o: &LoopOutcome, spectrum: bool) {
    for s in &o.report.steps {
        let (b, a) = if spectrum {
            (&s.before.spectrum, &s.after.spectrum)
        } else {
            (&s.before.allan, &s.after.allan)
        };
        let (b, a) = (b.as_ref().unwrap(), a.as_ref().unwrap());
        assert!(
            a.chi2_per_dof < b.chi2_per_dof,
            "{} → {}",
            b.chi2_per_dof,
            a.chi2_per_dof
        );
    }
}

#[test]
fn an_undeclared_line_is_found_fitted_and_removed() {
    // 3e-4 rad/s at 7.3 Hz against white noise of 4.4e-4 rad/s per sample.
    let cols = record(
        json!({ "sinusoids": [{ "amplitude": 3e-4, "freq_hz": 7.3 }] }),
        false,
        1200.0,
        1,
    );
    let o = run(&cols);
    assert_eq!(kinds(&o), ["sinusoid"]);
    let Effect::Sinusoid(s) = &o.report.steps[0].effect else {
        unreachable!()
    };
    // Within a tenth of the spectrum's resolution 1/T. Measured: 7.2999945 Hz
    // [7.2999914, 7.2999975] (1σ), 1.8σ from the truth; the half-width 3.0e-6 Hz is the
    // Cramér–Rao bound for this amplitude, noise and length.
    println!("line: {s:?}");
    assert!((s.freq_hz - 7.3).abs() < 0.1 / 1200.0, "{s:?}");
    assert!((s.amplitude / 3e-4 - 1.0).abs() < 0.05, "{s:?}");
    assert_error_falls(&o, true);
}

#[test]
fn an_undeclared_gauss_markov_process_is_found() {
    // σ = 2e-4 rad/s, Tc = 5 s: a hump over the white noise near τ ≈ 5 s.
    let cols = record(
        json!({ "gauss_markov": [GaussMarkov { sigma: 2e-4, tc_s: 5.0 }] }),
        false,
        1800.0,
        2,
    );
    let o = run(&cols);
    assert_eq!(kinds(&o), ["gauss_markov"], "{:?}", o.report.rejected);
    let Effect::GaussMarkov {
        tc_s,
        tc_lo_s,
        tc_hi_s,
        sigma,
    } = &o.report.steps[0].effect
    else {
        unreachable!()
    };
    assert!(*tc_s > 2.5 && *tc_s < 10.0, "Tc = {tc_s}");
    // Its profile interval holds the estimate and is a real range (the grid's steps are 1/8
    // decade: a Tc the data pin down to a step still gets the interpolated ends).
    assert!(
        tc_lo_s < tc_s && tc_s < tc_hi_s,
        "{tc_lo_s} {tc_s} {tc_hi_s}"
    );
    assert!(
        *tc_lo_s <= 5.0 * 1.5 && *tc_hi_s >= 5.0 / 1.5,
        "{tc_lo_s} {tc_hi_s}"
    );
    assert!((sigma.value / 2e-4 - 1.0).abs() < 0.3, "{sigma:?}");
    assert_error_falls(&o, true);
}

#[test]
fn an_undeclared_temperature_coupling_is_found_with_its_coefficient() {
    // 1e-4 rad/s per °C: 4e-4 rad/s over the 4 °C warm-up, 28× B. The noise of this seed pulls
    // the estimate up by ≈ 1.7e-5 (measured at 5e-5: 6.67e-5, z = 6.5, 1σ error 1.0e-5); at 1e-4
    // the estimate is 1.17e-4 [1.06e-4, 1.27e-4] (1σ). Tolerance: the truth within two
    // half-widths of the 1σ interval, and the estimate within 25 % (≈ 2.5σ).
    let c = 1e-4;
    let cols = record(json!({ "temperature_coefficient": c }), true, 3600.0, 3);
    let o = run(&cols);
    assert_eq!(kinds(&o), ["coupling"], "{:?}", o.report.rejected);
    let Effect::Coupling { fit, .. } = &o.report.steps[0].effect else {
        unreachable!()
    };
    println!("coupling: {fit:?}");
    let half = (fit.hi - fit.lo) / 2.0;
    assert!((fit.coefficient - c).abs() < 2.0 * half, "{fit:?}");
    assert!((fit.coefficient / c - 1.0).abs() < 0.25, "{fit:?}");
    assert_error_falls(&o, false);
}

#[test]
fn a_line_and_a_coupling_together_are_both_found() {
    let cols = record(
        json!({ "temperature_coefficient": 5e-5,
                "sinusoids": [{ "amplitude": 3e-4, "freq_hz": 11.0 }] }),
        true,
        3600.0,
        4,
    );
    let o = run(&cols);
    let mut k = kinds(&o);
    k.sort_unstable();
    assert_eq!(k, ["coupling", "sinusoid"], "{:?}", o.report.rejected);
}

/// (coefficient, lo, hi) from a coupling note's "coefficient C [LO, HI]".
fn coefficient_in(note: &str) -> Option<(f64, f64, f64)> {
    let rest = note.split("coefficient ").nth(1)?;
    let (c, rest) = rest.split_once(" [")?;
    let (lo, rest) = rest.split_once(", ")?;
    let (hi, _) = rest.split_once(']')?;
    Some((c.parse().ok()?, lo.parse().ok()?, hi.parse().ok()?))
}

/// Negative control: the IEEE model alone (white, flicker, random walk) with an independent
/// warming temperature channel; over 12 seeds at most one addition in all (measured: see the
/// printed count).
#[test]
fn pure_ieee_noise_gets_nothing_added() {
    let mut added = Vec::new();
    let mut covers_zero = 0;
    for seed in 100..112 {
        let cols = record(json!({}), true, 1200.0, seed);
        let o = run(&cols);
        if !o.report.steps.is_empty() {
            added.push((seed, kinds(&o)));
        }
        // The rejected coupling still states its coefficient and interval (a bound on the
        // sensitivity), which covers 0 about as often as its probability says.
        let note = &o
            .report
            .rejected
            .iter()
            .find(|r| r.kind == "coupling")
            .expect("the coupling to the temperature channel is listed")
            .note;
        let (c, lo, hi) = coefficient_in(note).unwrap_or_else(|| panic!("{note}"));
        assert!(lo <= c && c <= hi, "{note}");
        covers_zero += usize::from(lo <= 0.0 && 0.0 <= hi);
    }
    println!(
        "false additions: {added:?} in 12 records; coupling interval covers 0 in {covers_zero}"
    );
    assert!(added.len() <= 1, "{added:?}");
    assert!(covers_zero >= 5, "{covers_zero} of 12");
}

/// A Gauss–Markov process of Tc 60 s in 30 min (30 Tc): its short-τ rise reads as a rate random
/// walk 11× the planted K, and the turn-over that tells them apart lies in the Allan variance's
/// last, scarcely averaged points, so the loop does not admit it (in 44 of 50 validation
/// records). It is not simply left out: the model with it is the loop's rival, the final
/// coefficients average both models by their BIC weights, K's interval reaches down towards the
/// rival's reading, and a warning names it. Seed 5 (measured): ΔBIC −2.9, the rival at 81 %;
/// Allan K 1.64e-5 [1.50e-5, 1.85e-5] → 7.1e-6 [0, 1.49e-5] rad/s/√s.
#[test]
fn a_gauss_markov_process_too_long_to_admit_is_averaged_in_as_a_rival() {
    let cols = record(
        json!({ "gauss_markov": [GaussMarkov { sigma: 1e-4, tc_s: 60.0 }] }),
        false,
        1800.0,
        5,
    );
    let o = run(&cols);
    assert!(!kinds(&o).contains(&"gauss_markov"), "{:?}", kinds(&o));
    let rival = o.report.rival.as_ref().expect("a rival model");
    println!("rival: {rival:?}");
    assert_eq!(rival.effect.kind(), "gauss_markov");
    assert!(
        rival.delta_bic >= -6.0 && rival.delta_bic < 10.0,
        "{rival:?}"
    );
    assert!((rival.weight - (-rival.delta_bic / 2.0).exp()).abs() < 1e-12);
    let base = o.report.base_allan.as_ref().unwrap();
    let (k0, k1) = (
        base.get(Term::RateRandomWalk).unwrap(),
        o.allan.as_ref().unwrap().get(Term::RateRandomWalk).unwrap(),
    );
    println!("K base {k0:?}\nK averaged {k1:?}");
    // The base reading: the process's rise, ≈ √(2σ²/Tc) = 1.8e-5 rad/s/√s, its interval far
    // above the planted 1.6e-6. Averaged: lower, and the interval reaches several times lower.
    let planted = crate::support::loop_gyro().k;
    assert!(k0.lo > 5.0 * planted, "{k0:?}");
    assert!(
        k1.value < k0.value && k1.lo < 0.5 * k0.lo,
        "{k1:?} vs {k0:?}"
    );
    let named = o.report.warnings().iter().any(|w| {
        matches!(w, imunoise::model::FitWarning::RivalModel { effect, .. } if effect == "gauss_markov")
    });
    assert_eq!(named, rival.share >= imunoise::effects::RIVAL_WARNING_SHARE);
}

/// A warm-up of 100 °/h settling with Tc 300 s, no temperature channel, 30 min: the base fit's K
/// takes the drift in (2–3×), which weakens the drift's own regression, and under that noise
/// model the parabola can beat the exponential by a hair; removing the parabola left the
/// warm-up, and K, in place (missed in 8 of 50 validation records, K 2–3× there). The drift is
/// now refined in each family of shapes apart. Over 16 seeds: found in all but at most one, and
/// the final Allan K within a factor of 2 of the truth in all but at most two (measured: see the
/// printed lines).
#[test]
fn a_large_warm_up_is_found_and_leaves_the_random_walk_alone() {
    let amplitude = imunoise::model::CoefUnit::DegPerH.to_si(100.0);
    let truth = crate::support::loop_gyro().k;
    let (mut found, mut k_off) = (0, Vec::new());
    for seed in 40..56 {
        let cols = record(
            json!({ "drift": { "exponential": { "amplitude": amplitude, "tc_s": 300.0 } } }),
            false,
            1800.0,
            seed,
        );
        let o = run(&cols);
        found += usize::from(kinds(&o).contains(&"drift"));
        let k = o
            .allan
            .as_ref()
            .and_then(|f| f.get(Term::RateRandomWalk))
            .map_or(0.0, |k| k.value);
        println!(
            "seed {seed}: {:?}, K {:.2}× the truth",
            kinds(&o),
            k / truth
        );
        // A K the fit left out is no inflation.
        if k > 2.0 * truth {
            k_off.push((seed, k / truth));
        }
    }
    assert!(found >= 15, "{found} of 16");
    assert!(k_off.len() <= 2, "{k_off:?}");
}

/// A temperature coupling of 5e-5 rad/s/°C (the 4 °C warm-up moves the rate by 2e-4 rad/s, 14×
/// B) in 30 min is admitted in about half the records. Where it is not, but its regression found
/// some evidence (p below `RIVAL_SLOW_P`), it is the loop's rival: the coefficients average the
/// model without it and the series with it removed, its weight is e^(−ΔBIC/2), and a warning
/// names it from 10 % of the weight on. Over 12 seeds (measured: see the printed lines).
#[test]
fn a_coupling_short_of_admission_is_averaged_in_as_a_rival() {
    use imunoise::effects::{RIVAL_SLOW_P, RIVAL_WARNING_SHARE};
    let (mut admitted, mut rivals, mut neither) = (0, 0, Vec::new());
    for seed in 60..72 {
        let cols = record(
            json!({ "temperature_coefficient": 5e-5 }),
            true,
            1800.0,
            seed,
        );
        let o = run(&cols);
        if kinds(&o).contains(&"coupling") {
            admitted += 1;
            continue;
        }
        let coupling = o.report.rejected.iter().find(|r| r.kind == "coupling");
        match o.report.rival.as_ref() {
            Some(r) if r.effect.kind() == "coupling" => {
                let Effect::Coupling { fit, .. } = &r.effect else {
                    unreachable!()
                };
                assert!(fit.p_value < RIVAL_SLOW_P, "{r:?}");
                assert!((r.weight - (-r.delta_bic / 2.0).exp()).abs() < 1e-12);
                let named = o.report.warnings().iter().any(|w| {
                    matches!(w, imunoise::model::FitWarning::RivalModel { effect, evidence, .. }
                        if effect == "coupling" && evidence.contains("temperature"))
                });
                assert_eq!(named, r.share >= RIVAL_WARNING_SHARE, "{r:?}");
                // The model with the coupling reads the slow terms lower: the average lies
                // between, below the final model's own reading.
                let base = o.report.base_allan.as_ref().unwrap();
                for term in [Term::BiasInstability, Term::RateRandomWalk] {
                    let (b, a) = (base.get(term), o.allan.as_ref().unwrap().get(term));
                    println!("seed {seed}: {term:?} base {b:?}\n  averaged {a:?}");
                }
                rivals += 1;
            }
            other => {
                // Not the rival: no evidence, or another rival that scored better.
                let c = coupling.expect("the coupling is listed");
                let p: f64 = c
                    .note
                    .split("family-wise p = ")
                    .nth(1)
                    .and_then(|t| t.split([',', ' ', ';']).next())
                    .and_then(|t| t.parse().ok())
                    .unwrap_or_else(|| panic!("{}", c.note));
                let beaten = other.is_some_and(|r| Some(r.delta_bic) <= c.delta_bic);
                assert!(p >= RIVAL_SLOW_P || beaten, "seed {seed}: {other:?}; {c:?}");
                neither.push((seed, other.map(|r| r.effect.kind()), p));
            }
        }
    }
    // Measured: admitted 6, rivals 3, neither 3 (p 0.06–0.08, one of them with a Gauss–Markov
    // rival).
    println!("admitted {admitted}, rivals {rivals}, neither {neither:?}");
    assert!(rivals >= 2, "{rivals}");
}

/// The loop tests' gyro with a rate ramp of `r_deg_h_h` °/h per hour, 30 min.
fn ramp_record(seed: u64, r_deg_h_h: f64) -> Vec<f64> {
    let mut noise = crate::support::loop_gyro();
    noise.r = r_deg_h_h.to_radians() / 3600.0 / 3600.0;
    let spec = json!({ "rate_hz": FS, "duration_s": 1800.0, "seed": seed,
        "channels": [{ "name": "g", "sensor": "gyro", "noise": noise }] });
    let spec: SimSpec = serde_json::from_value(spec).unwrap();
    simulate(&spec).unwrap().into_columns().0.remove(0)
}

/// A ramp of 200 °/h/h over 30 min (R·T ≈ 7 K·√T) whose base Allan fit put K in its place (the
/// curve's few longest-τ averages cannot tell them apart): the loop's last check finds it in the
/// series' block means and requires R in the Allan fit, whose interval then holds the series'
/// estimate ± its error; the value within 35 % of the truth (the base fits kept such a ramp in 27
/// of 60 records, with the check 39 of 60: `validation/ramp.md`).
#[test]
fn a_ramp_the_allan_fit_missed_is_added_from_the_series() {
    use imunoise::effects::ramp::RampAction;
    let truth = 200f64.to_radians() / 3600.0 / 3600.0;
    for seed in [13_000_004, 13_000_006, 13_000_010] {
        let o = run(&[ramp_record(seed, 200.0)]);
        let base = o.report.base_allan.as_ref().expect("base fit");
        assert!(
            base.get(Term::RateRamp).is_none(),
            "seed {seed}: base kept R"
        );
        let d = o.report.ramp.expect("the loop decided on a ramp");
        assert_eq!(d.action, RampAction::Added, "seed {seed}");
        assert!(d.test.determined(), "seed {seed}: {d:?}");
        let est = d.estimate.expect("sized under the model with R");
        let r = o
            .allan
            .as_ref()
            .unwrap()
            .get(Term::RateRamp)
            .expect("R required");
        assert!(
            r.lo <= (est.ramp.abs() - est.se).max(0.0) && r.hi >= est.ramp.abs() + est.se,
            "seed {seed}: {r:?} vs {est:?}"
        );
        assert!((r.value / truth - 1.0).abs() < 0.35, "seed {seed}: {r:?}");
    }
}

/// Clean records (no ramp) whose Allan fit read K at 0.54 and 0.47× the truth: weighed against K
/// at its estimate, their wander passed for a ramp (t 5.4 and −5.7); against K at the upper end of
/// its interval ([`imunoise::effects::ramp::ramp_null_coefficients`]) it does not, and nothing is
/// added (0 of 300 such records, `validation/ramp.md`).
#[test]
fn a_random_walk_read_low_is_not_taken_for_a_ramp() {
    for seed in [11_000_153, 11_000_193] {
        let o = run(&[ramp_record(seed, 0.0)]);
        // Reported (the wander shows, p < 0.01) but not added.
        let not_added = o
            .report
            .ramp
            .is_none_or(|d| d.action == imunoise::effects::ramp::RampAction::NotAdded);
        assert!(not_added, "seed {seed}: {:?}", o.report.ramp);
        let allan = o.allan.as_ref().expect("final fit");
        assert!(allan.get(Term::RateRamp).is_none(), "seed {seed}");
    }
}

/// The same ramp beside a temperature channel: where the temperature rises through the record
/// (a straight 4 °C climb, as a coupling's slope would follow it) the ramp cannot be told from a
/// coupling and is not added; where it only oscillates (±0.5 °C, 300-s period) the ramp stands
/// out beside it and is added as without it, and a temperature that never changes takes nothing
/// from it.
#[test]
fn a_ramp_that_a_temperature_rise_explains_as_well_is_not_added() {
    use imunoise::effects::ramp::RampAction;
    let y = ramp_record(13_000_004, 200.0);
    let n = y.len();
    let rising: Vec<f64> = (0..n).map(|i| 20.0 + 4.0 * i as f64 / n as f64).collect();
    let o = run(&[y.clone(), rising]);
    // The series shows the rise, which the temperature's explains as well: reported, not added.
    let d = o.report.ramp.expect("the rise reported");
    assert!(
        d.action == RampAction::NotAdded && d.test.determined() && d.estimate.is_none(),
        "{d:?}"
    );
    assert!(kinds(&o).is_empty(), "{:?}", kinds(&o));
    let allan = o.allan.as_ref().expect("final fit");
    assert!(allan.get(Term::RateRamp).is_none());
    let period = 300.0 * FS;
    let oscillating: Vec<f64> = (0..n)
        .map(|i| 20.0 + 0.5 * (std::f64::consts::TAU * i as f64 / period).sin())
        .collect();
    let o = run(&[y.clone(), oscillating]);
    let d = o
        .report
        .ramp
        .expect("decided beside an oscillating temperature");
    assert_eq!(d.action, RampAction::Added);
    let o = run(&[y, vec![21.0; n]]);
    let d = o
        .report
        .ramp
        .expect("decided beside a constant temperature");
    assert_eq!(d.action, RampAction::Added);
}

/// A coupling the base fit hides: an accelerometer (N = 1 mg/√Hz, B = 20 µg, K = 1e-5 m/s²/√s)
/// whose temperature is a smooth 6 °C warm-up (Tc 600 s, no wander), the coupling of 1.5e-3
/// (m/s²)/°C moving it by about 30σ of 10-s means, 30 min. The base fit takes the drift into its
/// random walk and ramp, under which the regression on the temperature's increments read t ≈ 1.8
/// while the model-free test gave p ≈ 1e-6 (found in 6 of 10 such records of an independent
/// simulator, a false ramp kept in its place); the coupling is now refined and iterated whenever
/// the model-free test is strong (p < 1e-3), and found with its coefficient. Here behind a
/// 4th-order 30-Hz filter and 0.06-mg output steps, seeds 90–119: found in 27 of 30 before, a
/// ramp kept in its place in 2 (seeds 95 and 111); now 29 of 30, no ramp.
#[test]
fn a_coupling_hidden_by_the_base_fits_random_walk_is_found() {
    let c = 1.5e-3;
    let (mut found, mut ramp_instead) = (0, Vec::new());
    let seeds = 90..120;
    for seed in seeds.clone() {
        let noise = imunoise::model::Coefficients {
            n: 1e-3,
            b: 20e-6 * 9.80665,
            k: 1e-5,
            ..Default::default()
        };
        let spec = json!({ "rate_hz": FS, "duration_s": 1800.0, "seed": seed,
            "channels": [{ "name": "a", "sensor": "accel", "noise": noise,
                           "temperature_coefficient": c,
                           "lowpass": { "corner_hz": 30.0, "order": 4 },
                           "lsb": 5.985e-4 }],
            "temperature": { "start_degc": 25.0, "rise_degc": 6.0, "warmup_s": 600.0,
                             "noise_degc": 0.004 } });
        let spec: SimSpec = serde_json::from_value(spec).unwrap();
        let (cols, _) = simulate(&spec).unwrap().into_columns();
        let o = run(&cols);
        println!("seed {seed}: {:?}; {:?}", kinds(&o), o.report.rejected);
        if let Some(Effect::Coupling { fit, .. }) = o
            .report
            .steps
            .iter()
            .map(|s| &s.effect)
            .find(|e| e.kind() == "coupling")
        {
            found += 1;
            assert!(
                (fit.coefficient / c - 1.0).abs() < 0.3,
                "seed {seed}: {fit:?}"
            );
        }
        let allan = o.allan.as_ref().unwrap();
        if allan.get(Term::RateRamp).is_some() && !kinds(&o).contains(&"coupling") {
            ramp_instead.push(seed);
        }
    }
    println!(
        "found in {found} of {}; a ramp in its place in {ramp_instead:?}",
        seeds.len()
    );
    assert!(found >= 27, "found in {found} of {}", seeds.len());
    assert!(ramp_instead.is_empty(), "{ramp_instead:?}");
}

/// A line whose frequency wanders ±0.3 Hz around 9 Hz (wider than a line's 5 % of its
/// frequency, inside the fit band): measured as one narrow band, not fitted as a resonance (its σ
/// the line's rms) with fragments split off as further bands, which an independent simulator's
/// records got in 7 of 10. The band's amplitude is nearly constant (`band_kurtosis` ≈ 1.6),
/// which a resonance's is not.
#[test]
fn a_widely_wandering_line_is_a_narrow_band_not_a_resonance() {
    for seed in [51, 52, 53] {
        let cols = record(
            json!({ "sinusoids": [{ "amplitude": 5e-4, "freq_hz": 9.0,
                "wander": { "freq_wander_hz": 0.3, "amplitude_wander": 0.0, "wander_tc_s": 300.0 } }] }),
            false,
            1800.0,
            seed,
        );
        let o = run(&cols);
        println!("seed {seed}: {:?}", kinds(&o));
        for s in &o.report.steps {
            match &s.effect {
                Effect::Narrowband(nb) => println!(
                    "  band {:.3} Hz [{:.3}, {:.3}], width {:.3}, ΔBIC {:.0}",
                    nb.freq_hz, nb.f_lo_hz, nb.f_hi_hz, nb.width_hz, s.delta_bic
                ),
                Effect::Resonance {
                    f0_hz, q, sigma, ..
                } => println!(
                    "  resonance {f0_hz:.3} Hz, Q {q:.1}, σ {:.2e}, ΔBIC {:.0}: {}",
                    sigma.value, s.delta_bic, s.evidence
                ),
                _ => {}
            }
        }
        assert!(
            !kinds(&o).contains(&"resonance"),
            "seed {seed}: {:?}",
            kinds(&o)
        );
        assert_eq!(
            kinds(&o).iter().filter(|k| **k == "narrowband").count(),
            1,
            "seed {seed}: {:?}",
            kinds(&o)
        );
    }
}

/// A warm-up of the bias itself (100 °/h, Tc 300 s) beside a temperature channel that warms up
/// too (6 °C, Tc 600 s) but does not drive it: the loop takes the coupling (a warm-up seen on a
/// temperature channel is taken for its coupling), and its evidence now says that a drift of the
/// bias is significant on its own too and that the two are not told apart.
#[test]
fn a_coupling_that_stands_for_an_unrelated_warm_up_says_so() {
    let mut said = 0;
    for seed in [71, 72, 73] {
        let noise = crate::support::loop_gyro();
        let drift = imunoise::model::CoefUnit::DegPerH.to_si(100.0);
        let spec = json!({ "rate_hz": FS, "duration_s": 1800.0, "seed": seed,
            "channels": [{ "name": "g", "sensor": "gyro", "noise": noise,
                "drift": { "exponential": { "amplitude": drift, "tc_s": 300.0 } } }],
            "temperature": { "start_degc": 25.0, "rise_degc": 6.0, "warmup_s": 600.0,
                             "noise_degc": 0.004 } });
        let spec: SimSpec = serde_json::from_value(spec).unwrap();
        let (cols, _) = simulate(&spec).unwrap().into_columns();
        let o = run(&cols);
        println!("seed {seed}: {:?}", kinds(&o));
        if let Some(s) = o
            .report
            .steps
            .iter()
            .find(|s| s.effect.kind() == "coupling")
        {
            println!("  {}", s.evidence);
            assert!(
                s.evidence.contains("not told apart"),
                "seed {seed}: {}",
                s.evidence
            );
            // And the channel's warnings say it, where stderr and the fleet table show them.
            let warned = o.report.warnings().into_iter().find_map(|w| match w {
                FitWarning::CouplingOrWarmUp {
                    aux,
                    drift_delta_bic,
                    ..
                } => Some((aux, drift_delta_bic)),
                _ => None,
            });
            let (aux, drift_delta_bic) = warned.expect("a coupling_or_warm_up warning");
            assert_eq!(aux, "temperature");
            assert!(drift_delta_bic < -6.0, "{drift_delta_bic}");
            said += 1;
        }
    }
    assert!(said >= 2, "{said}");
}
