//! Noise model, simulator and fits: the AV–PSD link of every term, the simulator against the
//! model, recovery of known coefficients from simulated records, agreement of the spectrum and
//! Allan fits, false inclusions, and Monte-Carlo coverage of the intervals.
//!
//! Every tolerance is stated next to its assertion with where it comes from. Sizes are chosen to
//! run in a few seconds at the test profile's opt-level 2.

use imunoise::avar::{compute, Confidence, Deviations, Statistic, TauGrid, ONE_SIGMA};
use imunoise::model::{
    compare, fit_avar, fit_psd, CoefUnit, Coefficients, FitError, FitOptions, GaussMarkov,
    NoiseFit, Sensor, Sinusoid, Term, FLICKER_PLATEAU,
};
use imunoise::psd::{log_bin, welch, Psd, Scaling, WelchConfig};
use imunoise::sim::{simulate, ChannelSpec, SimSpec};

/// One gyro channel with coefficients `c` (SI), `n` samples at `fs`.
fn record(c: Coefficients, fs: f64, n: usize, seed: u64) -> Vec<f64> {
    let spec = SimSpec {
        rate_hz: fs,
        duration_s: n as f64 / fs,
        seed,
        channels: vec![ChannelSpec::new("g", Sensor::Gyro, c)],
        temperature: None,
    };
    simulate(&spec).unwrap().channels.remove(0).samples
}

fn oadev(y: &[f64], fs: f64) -> Deviations {
    compute(
        y,
        fs,
        &TauGrid::Octave,
        Statistic::Oadev,
        Confidence::OneSigma,
    )
    .unwrap()
}

fn spectrum(y: &[f64], fs: f64, nperseg: usize) -> Psd {
    welch(y, fs, &WelchConfig::new(nperseg)).unwrap()
}

fn fit_both(y: &[f64], fs: f64, nperseg: usize, opts: &FitOptions) -> (NoiseFit, NoiseFit) {
    let av = fit_avar(&oadev(y, fs), opts).unwrap();
    let psd = spectrum(y, fs, nperseg);
    let sp = fit_psd(&psd, &log_bin(&psd, 10), opts).unwrap();
    (av, sp)
}

/// Relative error of the fitted `term` against `truth`; panics with the fit if the term is absent.
fn rel_err(fit: &NoiseFit, term: Term, truth: f64) -> f64 {
    let e = fit
        .get(term)
        .unwrap_or_else(|| panic!("{:?} fit lacks {term}: {fit:#?}", fit.domain));
    (e.value - truth).abs() / truth
}

fn kept(fit: &NoiseFit) -> Vec<Term> {
    fit.estimates.iter().map(|e| e.term).collect()
}

/// The Allan variance – PSD link σ²(τ) = 4∫₀^∞ S(f)·sin⁴(πfτ)/(πfτ)² df, evaluated numerically.
mod link {
    use super::*;
    use std::f64::consts::PI;

    /// 8-point Gauss–Legendre nodes and weights on [−1, 1].
    const GL: [(f64, f64); 8] = [
        (-0.960_289_856_497_536_3, 0.101_228_536_290_376_3),
        (-0.796_666_477_413_626_7, 0.222_381_034_453_374_5),
        (-0.525_532_409_916_329, 0.313_706_645_877_887),
        (-0.183_434_642_495_649_8, 0.362_683_783_378_362),
        (0.183_434_642_495_649_8, 0.362_683_783_378_362),
        (0.525_532_409_916_329, 0.313_706_645_877_887),
        (0.796_666_477_413_626_7, 0.222_381_034_453_374_5),
        (0.960_289_856_497_536_3, 0.101_228_536_290_376_3),
    ];

    /// ∫_a^b g by 8-point Gauss–Legendre on `pieces` equal pieces.
    fn integrate(g: &dyn Fn(f64) -> f64, a: f64, b: f64, pieces: usize) -> f64 {
        let h = (b - a) / pieces as f64;
        (0..pieces)
            .map(|p| {
                let mid = a + (p as f64 + 0.5) * h;
                GL.iter()
                    .map(|(x, w)| w * g(mid + x * h / 2.0))
                    .sum::<f64>()
                    * h
                    / 2.0
            })
            .sum()
    }

    /// The continuous link for two-sided PSD `s`, from f = `f_lo` (0 for the whole axis).
    ///
    /// Method: substitute x = πfτ; Gauss–Legendre (8 points) on 400 log-spaced pieces from
    /// 10⁻⁹ (or the lower limit) to π/4, which resolve spectral features far below 1/τ (a
    /// Gauss–Markov knee, the ramp's 1/x), then on each quarter period of sin⁴ up to X = 1000π;
    /// beyond X, sin⁴x is replaced by its mean 3/8 and the rest integrated in u = X/x on (0, 1].
    /// The oscillating remainder is O(1/X²) ≈ 1e-7 relative; below 10⁻⁹ the integrand of every
    /// convergent term is < 10⁻⁹ of its peak.
    fn continuous(s: &dyn Fn(f64) -> f64, tau: f64, f_lo: f64) -> f64 {
        let x_max = 1000.0 * PI;
        let g = |x: f64| 4.0 * s(x / (PI * tau)) * x.sin().powi(4) / (x * x) / (PI * tau);
        let x_lo = (PI * f_lo * tau).max(1e-9);
        let x_mid = PI / 4.0;
        let ratio = (x_mid / x_lo).powf(1.0 / 400.0);
        let near: f64 = (0..400)
            .map(|k| {
                let a = x_lo * ratio.powi(k);
                integrate(&g, a, a * ratio, 1)
            })
            .sum();
        let body = near + integrate(&g, x_mid, x_max, 3999);
        let tail = integrate(
            &|u: f64| 1.5 / (x_max * PI * tau) * s(x_max / (u * PI * tau)),
            0.0,
            1.0,
            64,
        );
        body + tail
    }

    /// The sampled-data link 4∫₀^{fs/2} S_d(f)·sin⁴(πfmτ₀)/(m² sin²(πfτ₀)) df for the spectrum of
    /// the samples, S_d; Gauss–Legendre on 64·m pieces (the integrand is smooth).
    fn sampled(s: &dyn Fn(f64) -> f64, m: u32, fs: f64) -> f64 {
        let tau0 = 1.0 / fs;
        let mf = f64::from(m);
        let g = |f: f64| {
            let k = (PI * f * tau0).sin();
            4.0 * s(f) * (PI * f * mf * tau0).sin().powi(4) / (mf * mf * k * k)
        };
        integrate(&g, 0.0, fs / 2.0, 64 * m as usize)
    }

    fn close(got: f64, want: f64, tol: f64, what: &str) {
        let r = got / want - 1.0;
        assert!(
            r.abs() < tol,
            "{what}: link {got:e}, AV form {want:e}, relative {r:e}"
        );
    }

    #[test]
    fn continuous_terms_have_their_allan_variance() {
        // White, flicker, random walk and Gauss–Markov over the whole frequency axis: the
        // integrals converge at both ends. Tolerance 1e-5: the quadrature is good to ~1e-7.
        let tau0 = 0.01;
        for tau in [0.05, 1.0, 30.0] {
            for term in [
                Term::RandomWalk,
                Term::BiasInstability,
                Term::RateRandomWalk,
            ] {
                let got = continuous(&|f| term.psd_unit(f, tau0), tau, 0.0);
                close(
                    got,
                    term.avar_unit(tau),
                    1e-5,
                    &format!("{term} at τ = {tau}"),
                );
            }
            for tc in [0.1, 3.0, 100.0] {
                let gm = GaussMarkov {
                    sigma: 0.7,
                    tc_s: tc,
                };
                let got = continuous(&|f| gm.psd(f), tau, 0.0);
                close(
                    got,
                    gm.avar(tau),
                    1e-5,
                    &format!("GM Tc = {tc} at τ = {tau}"),
                );
            }
        }
        // Flicker plateau: (2 ln 2/π)·B², σ ≈ 0.664·B.
        assert!((FLICKER_PLATEAU - 2.0 * std::f64::consts::LN_2 / PI).abs() < 1e-16);
        // Sinusoid: lines of power Ω₀²/4 at ±f₀ put 4·Ω₀²/4·sin⁴(πf₀τ)/(πf₀τ)² into the integral
        // from 0 to ∞ (one line); exact.
        let s = Sinusoid {
            amplitude: 1.5,
            freq_hz: 0.3,
        };
        let x = PI * 0.3 * 2.0;
        let want = 4.0 * s.line_power() * x.sin().powi(4) / (x * x);
        assert!((s.avar(2.0) - want).abs() < 1e-15);
    }

    #[test]
    fn sampled_terms_have_the_continuous_allan_variance_at_every_m() {
        // The spectra of sampled interval means (Term::psd_sampled_unit) through the sampled-data
        // kernel give the continuous AV exactly, m = 1 included; quantisation, a sampled angle
        // error, gives 3Q²/τ² exactly. Tolerance 1e-9 (smooth integrands, Hurwitz sums to 1e-12).
        let fs = 50.0;
        for m in [1u32, 2, 5, 16] {
            let tau = f64::from(m) / fs;
            for term in Term::ALL.into_iter().filter(|&t| t != Term::RateRamp) {
                let got = sampled(&|f| term.psd_sampled_unit(f, fs), m, fs);
                close(
                    got,
                    term.avar_unit(tau),
                    1e-9,
                    &format!("sampled {term} at m = {m}"),
                );
            }
        }
    }

    #[test]
    fn rate_ramp_spectrum_has_no_finite_allan_variance() {
        // IEEE 952's R²/(2πf)³ is not the transform of R²τ²/2: near f = 0 the integrand is
        // (R²τ²/2π)/x, so every halving of the lower limit adds (R²τ²/2π)·ln 2 (to O(x²): 1e-6
        // relative at πf_loτ = 1e-3). The ramp's AV is checked in the time domain instead (sim).
        let tau = 2.0;
        let f_lo = 1e-3 / (PI * tau);
        let s = |f: f64| Term::RateRamp.psd_unit(f, 0.01);
        let a = continuous(&s, tau, f_lo);
        let b = continuous(&s, tau, f_lo / 2.0);
        let step = tau * tau / (2.0 * PI) * std::f64::consts::LN_2;
        assert!(((b - a) / step - 1.0).abs() < 1e-5, "{} vs {step}", b - a);
    }
}

/// The simulator against the model it claims to follow.
mod simulator {
    use super::*;

    #[test]
    fn flicker_is_one_over_f_up_to_nyquist_and_flat_in_allan_variance() {
        let fs = 100.0;
        let b = 1e-3;
        let y = record(
            Coefficients {
                b,
                ..Default::default()
            },
            fs,
            1 << 18,
            21,
        );
        // Spectrum: every band from 4 bins up to Nyquist within 4σ (σ = √(2/ν) of the band) of
        // B² times the sampled 1/f form averaged over the band.
        let psd = spectrum(&y, fs, 4096);
        let binned = log_bin(&psd, 10);
        let df = psd.bin_width_hz();
        let mut top = 0.0;
        for i in 0..binned.freq_hz.len() {
            if binned.freq_hz[i] < 4.0 * df {
                continue;
            }
            let bins = binned.bins[i];
            let model = (0..bins)
                .map(|k| {
                    let f = binned.f_lo_hz[i] + df * (0.5 + f64::from(k));
                    b * b * Term::BiasInstability.psd_sampled_unit(f, fs)
                })
                .sum::<f64>()
                / f64::from(bins);
            let ratio = binned.value[i] / 2.0 / model;
            let sigma = (2.0 / binned.dof[i]).sqrt();
            assert!(
                (ratio - 1.0).abs() < 4.0 * sigma,
                "f = {} Hz: measured/model {ratio}, σ {sigma}",
                binned.freq_hz[i]
            );
            top = binned.freq_hz[i];
        }
        assert!(top > 40.0, "bands reach Nyquist: {top}");
        // Allan variance: the plateau from m = 1 (a point-sampled 1/f would read 19 % high
        // there). EDF ≈ 10⁵ at m = 1 falling to ≈ 10³ at m = 64: 3 % and 10 % are > 4σ.
        let d = oadev(&y, fs);
        for (i, &m) in d.m.iter().enumerate().take(7) {
            let ratio = d.variance[i] / (FLICKER_PLATEAU * b * b);
            let tol = if m <= 8 { 0.03 } else { 0.10 };
            assert!((ratio - 1.0).abs() < tol, "m = {m}: {ratio}");
        }
    }

    #[test]
    fn random_walk_and_ramp_have_their_allan_variance() {
        // K: EDF at m = 1..16 above 10⁴ on 2²⁰ samples (3 % is > 3σ); interval means make m = 1
        // exact (point samples would read 50 % high). R: deterministic, exact to rounding with
        // N = 0 (the rate is a pure ramp).
        let fs = 10.0;
        let k = 1e-3;
        let y = record(
            Coefficients {
                k,
                ..Default::default()
            },
            fs,
            1 << 20,
            5,
        );
        let d = oadev(&y, fs);
        for i in 0..5 {
            let ratio = d.variance[i] / (k * k * d.tau_s[i] / 3.0);
            assert!((ratio - 1.0).abs() < 0.03, "m = {}: {ratio}", d.m[i]);
        }
        let r = 2e-4;
        let y = record(
            Coefficients {
                r,
                ..Default::default()
            },
            fs,
            10_000,
            5,
        );
        let d = oadev(&y, fs);
        for i in 0..d.len() {
            let ratio = d.variance[i] / (r * r * d.tau_s[i].powi(2) / 2.0);
            assert!((ratio - 1.0).abs() < 1e-6, "m = {}: {ratio}", d.m[i]);
        }
    }
}

/// Coefficient units, checked against the reference paper's own conversions.
#[test]
fn units_reproduce_the_papers_table_3_conversions() {
    // Paszek & Kaniewski (2014), Table 3: ARW 0.016 °/√s = 0.96 °/√h and 0.020 °/√s = 1.20 °/√h;
    // BI 0.0031 = 11.16 and 0.0028 = 10.08. The BI rows are labelled °/√s and °/√h there, but
    // the factor 3600 is that of °/s → °/h: bias instability is a rate.
    use CoefUnit::*;
    let cases = [
        (DegPerSPerSqrtHz, 0.016, DegPerSqrtH, 0.96),
        (DegPerSPerSqrtHz, 0.020, DegPerSqrtH, 1.20),
        (DegPerS, 0.0031, DegPerH, 11.16),
        (DegPerS, 0.0028, DegPerH, 10.08),
    ];
    for (from, v, to, want) in cases {
        let got = from.convert(v, to).unwrap();
        assert!(
            (got - want).abs() < 1e-12,
            "{v} {from} = {got} {to}, paper {want}"
        );
    }
    // Kalibr's densities are the SI units: 0.5 °/√h = 1.454e-4 rad/s/√Hz.
    let n = DegPerSqrtH.convert(0.5, RadPerSPerSqrtHz).unwrap();
    assert!((n - 0.5 * std::f64::consts::PI / 180.0 / 60.0).abs() < 1e-18);
}

/// Recovery of known coefficients from single simulated records.
mod recovery {
    use super::*;

    #[test]
    fn white_and_rate_random_walk() {
        // N = 1e-3 rad/√s, K = 2e-4 rad/s/√s at 100 Hz for 2621 s: AV crossover at τ = √3·N/K =
        // 8.7 s, PSD crossover at K/(2πN) = 0.032 Hz, above the fit's 4·fs/nperseg = 0.012 Hz.
        // Over 200 seeds of this record the fitted N scatters by 0.16 % (AV) and 0.14 % (PSD), K
        // by 6.4 % (AV) and 8.6 % (PSD): the ±5 % and ±25 % bounds are > 3σ.
        //
        // Absent terms: BIC admits each with probability ≈ ½·P(χ²₁ > ln n) ≈ 4 % per fit (over
        // those 200 seeds: Q 3.5 %, B 5 %, R 4 % in the AV fit), so about one record in eight shows
        // some spurious term. This one, seed 1, shows a B in both fits: it is in the realisation,
        // not an artefact of one estimator. Absence is therefore asserted as a rate, over 150
        // records, in `coverage_and_spurious_terms`; here the fits must keep both true terms and
        // explain the data (χ²/dof).
        let truth = Coefficients {
            n: 1e-3,
            k: 2e-4,
            ..Default::default()
        };
        let y = record(truth, 100.0, 1 << 18, 1);
        let (av, sp) = fit_both(&y, 100.0, 1 << 15, &FitOptions::default());
        for fit in [&av, &sp] {
            assert!(rel_err(fit, Term::RandomWalk, truth.n) < 0.05);
            assert!(rel_err(fit, Term::RateRandomWalk, truth.k) < 0.25);
            eprintln!("{:?} fit keeps {:?}", fit.domain, kept(fit));
            assert!(fit.chi2_per_dof() < 2.0, "χ²/dof {}", fit.chi2_per_dof());
        }
    }

    #[test]
    fn quantisation_and_ramp() {
        // Q = 4e-5 rad with N = 1e-3 rad/√s at 100 Hz: the angle moves by 2.9 quantisation steps
        // per sample (σ), enough for the rounding error to be white (IEEE's model), and Q adds 48 %
        // to σ² at τ₀. R = 1.6e-6 rad/s² overtakes white noise at τ ≈ 90 s of 2621 s. Over 50
        // seeds: Q scatters 0.8 % (both fits), R 2.0 % (AV): bounds ±5 % and ±25 %. The ramp lives in
        // the lowest Welch bins, which the spectrum fit excludes, so only the AV fit may see it.
        let truth = Coefficients {
            n: 1e-3,
            q: 4e-5,
            r: 1.6e-6,
            ..Default::default()
        };
        let y = record(truth, 100.0, 1 << 18, 2);
        let (av, sp) = fit_both(&y, 100.0, 4096, &FitOptions::default());
        assert_eq!(
            kept(&av),
            [Term::Quantization, Term::RandomWalk, Term::RateRamp],
            "{av:#?}"
        );
        assert_eq!(kept(&sp), [Term::Quantization, Term::RandomWalk], "{sp:#?}");
        for fit in [&av, &sp] {
            assert!(rel_err(fit, Term::Quantization, truth.q) < 0.05);
            assert!(rel_err(fit, Term::RandomWalk, truth.n) < 0.05);
        }
        assert!(rel_err(&av, Term::RateRamp, truth.r) < 0.25);
    }

    #[test]
    fn white_and_flicker_agree_between_spectrum_and_allan_variance() {
        // N = 1e-3 rad/√s, B = 2e-3 rad/s at 100 Hz, 2¹⁸ samples, nperseg 4096: the spectrum sees
        // flicker below B²/(2πN²) = 0.64 Hz from 0.098 Hz on, the AV from τ = 0.6 s. Over 400 seeds
        // N scatters 0.2 % in both fits, B 1.4 % (AV) and 1.5 % (PSD), and the two fits' 1σ
        // intervals overlapped in 393 (N) and 398 (B) of the 400 records (same data: the estimates
        // are strongly correlated). PSD/AV within ±10 %: > 4σ of their difference.
        let truth = Coefficients {
            n: 1e-3,
            b: 2e-3,
            ..Default::default()
        };
        let y = record(truth, 100.0, 1 << 18, 3);
        let (av, sp) = fit_both(&y, 100.0, 4096, &FitOptions::default());
        for fit in [&av, &sp] {
            assert!(rel_err(fit, Term::RandomWalk, truth.n) < 0.05);
            assert!(rel_err(fit, Term::BiasInstability, truth.b) < 0.25);
            assert_eq!(
                kept(fit),
                [Term::RandomWalk, Term::BiasInstability],
                "{fit:#?}"
            );
        }
        let table = compare(&av, &sp);
        assert_eq!(table.len(), 2);
        for row in &table {
            assert_eq!(row.overlap, Some(true), "{row:#?}");
            let ratio = row.ratio.unwrap();
            assert!((ratio - 1.0).abs() < 0.1, "{}: PSD/AV {ratio}", row.term);
        }
    }
}

/// Monte-Carlo: interval coverage and the rate of spurious terms.
///
/// 150 seeded records of N = 1e-3 rad/√s and K = 2e-4 rad/s/√s at 100 Hz, 2¹⁶ samples each (AV
/// crossover at 8.7 s of 655 s), fitted in the AV domain with 1σ intervals. The count of covering
/// records is binomial: σ = 3.8 % at p = 0.683. Measured (this test's seeds): see the printed
/// line; over 200 seeds of 2¹⁷ samples the coverage was 0.635 (N) and 0.76 (K), with the
/// intervals about 10 % narrower than the scatter for N (Greenhall's EDF at m = 1 overstates
/// the exact one by 17 %, see `avar/coverage.rs`) and 10 % wider for K. The band [0.55, 0.85]
/// is ±3σ around 0.683 widened by that model allowance; intervals off by a factor 2 in width give
/// ≈ 0.38 or ≈ 0.95 and fail. Without the correlation between τ points the same run gives
/// 0.50 (N) and 0.44 (K) — that is what the working correlation is for.
///
/// Spurious terms: BIC lets an absent term in when it lowers −2 ln L by more than ln n ≈ 2.8
/// (n = 16 points), which for a term that can only be positive happens ≈ ½·P(χ²₁ > 2.8) = 5 % of the
/// time; over 200 seeds the rates were Q 6 %, B 5 %, R 3 %. Bound: ≤ 15 % per term (3σ above
/// 6 % for 150 trials).
#[test]
fn coverage_and_spurious_terms() {
    const TRIALS: u64 = 150;
    let truth = Coefficients {
        n: 1e-3,
        k: 2e-4,
        ..Default::default()
    };
    let opts = FitOptions::default();
    let (mut cover_n, mut cover_k, mut spurious) = (0u32, 0u32, [0u32; 5]);
    for seed in 0..TRIALS {
        let y = record(truth, 100.0, 1 << 16, 1000 + seed);
        let fit = fit_avar(&oadev(&y, 100.0), &opts).unwrap();
        cover_n += u32::from(fit.get(Term::RandomWalk).is_some_and(|e| e.covers(truth.n)));
        cover_k += u32::from(
            fit.get(Term::RateRandomWalk)
                .is_some_and(|e| e.covers(truth.k)),
        );
        for e in &fit.estimates {
            if truth.get(e.term) == 0.0 {
                spurious[e.term.index()] += 1;
            }
        }
    }
    let rate = |c: u32| f64::from(c) / TRIALS as f64;
    eprintln!(
        "1σ coverage over {TRIALS} records: N {:.3}, K {:.3} (nominal {ONE_SIGMA:.3}); spurious Q {:.3} B {:.3} R {:.3}",
        rate(cover_n),
        rate(cover_k),
        rate(spurious[0]),
        rate(spurious[2]),
        rate(spurious[4])
    );
    for (name, c) in [("N", cover_n), ("K", cover_k)] {
        assert!(
            (0.55..=0.85).contains(&rate(c)),
            "{name} coverage {}",
            rate(c)
        );
    }
    for t in [Term::Quantization, Term::BiasInstability, Term::RateRamp] {
        assert!(
            rate(spurious[t.index()]) <= 0.15,
            "{t} in {} records",
            spurious[t.index()]
        );
    }
}

/// Non-overlapping Allan variance is fitted with the same forms (its EDF differs).
#[test]
fn non_overlapping_allan_variance_is_fitted_too() {
    // White noise, 2¹⁶ samples: N from ADEV scatters ≈ 0.3 % (EDF ≈ N at m = 1); bound ±2 %.
    let y = record(
        Coefficients {
            n: 1e-3,
            ..Default::default()
        },
        100.0,
        1 << 16,
        4,
    );
    let d = compute(
        &y,
        100.0,
        &TauGrid::Octave,
        Statistic::Adev,
        Confidence::OneSigma,
    )
    .unwrap();
    let fit = fit_avar(&d, &FitOptions::default()).unwrap();
    assert!(rel_err(&fit, Term::RandomWalk, 1e-3) < 0.02, "{fit:#?}");
}

/// What the fits refuse.
#[test]
fn bad_inputs_are_errors() {
    let y = record(
        Coefficients {
            n: 1e-3,
            ..Default::default()
        },
        100.0,
        4096,
        9,
    );
    let mdev = compute(
        &y,
        100.0,
        &TauGrid::Octave,
        Statistic::Mdev,
        Confidence::OneSigma,
    )
    .unwrap();
    assert_eq!(
        fit_avar(&mdev, &FitOptions::default()).unwrap_err(),
        FitError::UnsupportedStatistic(Statistic::Mdev)
    );
    let cfg = WelchConfig {
        scaling: Scaling::Spectrum,
        ..WelchConfig::new(256)
    };
    let power = welch(&y, 100.0, &cfg).unwrap();
    assert_eq!(
        fit_psd(&power, &log_bin(&power, 10), &FitOptions::default()).unwrap_err(),
        FitError::NotDensity
    );
    let psd = spectrum(&y, 100.0, 256);
    let opts = FitOptions {
        min_freq_hz: Some(49.9),
        ..Default::default()
    };
    assert!(matches!(
        fit_psd(&psd, &log_bin(&psd, 10), &opts),
        Err(FitError::TooFewPoints { .. })
    ));
}

/// Defect: an effect column forced into a fit that does not see it (a Gauss–Markov knee below the
/// band of a white spectrum) made every subset with N improper (the effect at 0 counted as a term
/// zeroed), so the fit fell back to Q and the effect standing in for white noise: χ²/dof ≈ 400 on
/// the sample's accelerometers, a ΔBIC of +18 000 in the loop's account. Now the effect may come
/// out 0: the fit is the white noise's, N within 2 % (its 1σ error here ≈ 0.3 %).
#[test]
fn an_effect_a_spectrum_does_not_see_comes_out_zero_beside_the_base_terms() {
    use imunoise::effects::shapes::GaussMarkov1;
    use imunoise::model::fit_psd_with;
    let fs = 100.0;
    let truth = Coefficients {
        n: 1e-3,
        ..Default::default()
    };
    let y = record(truth, fs, 60_000, 808);
    let psd = welch(&y, fs, &WelchConfig::new(4096)).unwrap();
    let binned = log_bin(&psd, 20);
    let opts = FitOptions::default();
    let fit = fit_psd_with(&psd, &binned, &opts, Some(&GaussMarkov1 { tc_s: 30.0 })).unwrap();
    let n = fit.get(Term::RandomWalk).expect("N kept");
    assert!((n.value / 1e-3 - 1.0).abs() < 0.02, "{n:?}");
    assert!(
        fit.effect.is_none_or(|e| e.value < 0.1 * 1e-3),
        "{:?}",
        fit.effect
    );
    assert!(fit.chi2_per_dof() < 2.0, "χ²/dof {}", fit.chi2_per_dof());
}

/// An absent term's upper limit is a bound the truth lies under at its stated level: 30-min
/// records of N, B and K (K = 20 °/h/√h, often not admitted over 30 minutes), the Allan fit's
/// 1σ (84 % one-sided) bound on K wherever the fit left K out. With the chosen model's variances
/// it covered the truth in 1 of 24 such records (seeds 5 000 001–5 000 060, `imunoise analyze
/// --no-loop`); at the fixed point in 21 of 24. Here 40 seeds of the default Allan fit alone: K
/// absent in 19, the old bound covering it in 0 of them, the fixed point's in 12 (63 %, still
/// below the nominal 84 %: the bound is no longer wrong by a factor but not yet calibrated). The
/// test holds 60 %, the binomial 1 % lower tail of 84 % over 10–20 such records.
#[test]
fn an_absent_random_walks_upper_limit_covers_the_truth() {
    let fs = 100.0;
    let truth = Coefficients {
        n: CoefUnit::DegPerSqrtH.to_si(0.15),
        b: CoefUnit::DegPerH.to_si(3.0),
        k: CoefUnit::DegPerHPerSqrtH.to_si(20.0),
        ..Default::default()
    };
    let (mut absent, mut covered) = (0, 0);
    for seed in 0..40 {
        let y = record(truth, fs, 180_000, 6_100_000 + seed);
        let fit = fit_avar(&oadev(&y, fs), &FitOptions::default()).unwrap();
        if fit.get(Term::RateRandomWalk).is_some() {
            continue;
        }
        let upper = fit
            .upper_limits
            .iter()
            .find(|u| u.term == Term::RateRandomWalk)
            .expect("an absent K has an upper limit")
            .upper;
        absent += 1;
        covered += usize::from(truth.k <= upper);
    }
    println!("K absent in {absent} of 40; its upper limit covers the truth in {covered}");
    assert!(absent >= 8, "K absent in only {absent} of 40");
    assert!(
        covered as f64 >= 0.6 * absent as f64,
        "{covered} of {absent}"
    );
}

/// The spectrum's upper limit on an absent B covers the truth at its level: 30-min 100-Hz records
/// of N = 60 µg/√Hz, B = 20 µg and a small K (1e-5 m/s²/√s), where B shows only as an 18 % rise
/// of the lowest bands, which a spectrum reads as B or as K alike. Where it kept K in B's place,
/// the bound on B had been taken beside that K (the rise all K's) and lay below the truth in most
/// such records (0.61–0.99× the truth); now it is the larger of that and the bound in the model
/// with B in K's place. Seeds 7 300 000–039: B absent in 18, the bound covering the truth in 9
/// before, 13 now (72 %; nominal 84 % one-sided at 1σ, so still somewhat low). The test holds
/// 60 % of them.
#[test]
fn a_spectrums_bound_on_an_absent_bias_instability_covers_the_truth() {
    let fs = 100.0;
    let g = 9.80665;
    let truth = Coefficients {
        n: 60e-6 * g,
        b: 20e-6 * g,
        k: 1e-5,
        ..Default::default()
    };
    let (mut absent, mut covered) = (0, 0);
    for seed in 0..40 {
        let y = record(truth, fs, 180_000, 7_300_000 + seed);
        let psd = welch(&y, fs, &WelchConfig::new(4096)).unwrap();
        let fit = fit_psd(&psd, &log_bin(&psd, 20), &FitOptions::default()).unwrap();
        if fit.get(Term::BiasInstability).is_some() {
            continue;
        }
        let upper = fit
            .upper_limits
            .iter()
            .find(|u| u.term == Term::BiasInstability)
            .expect("an absent B has an upper limit")
            .upper;
        absent += 1;
        covered += usize::from(truth.b <= upper);
    }
    println!("B absent in {absent} of 40; its upper limit covers the truth in {covered}");
    assert!(absent >= 8, "B absent in only {absent} of 40");
    assert!(
        covered as f64 >= 0.6 * absent as f64,
        "{covered} of {absent}"
    );
}
