//! How often the Allan fit keeps a rate ramp R where none was planted (N, B, K records), and how
//! often it finds one that was: the ramp's false-alarm rate and detection rate, with the BIC gap
//! between the chosen subset and the same subset with K in R's place.
//!
//! `cargo run --release --example ramp_check -- [SEEDS] [SECONDS] [R in °/h/h ...]`; with
//! `RAMP_TEST=1` the fits are the base fits' flow with the time series' test of the ramp
//! (`effects::band::fit_in_band`, `effects::ramp`), with `RAMP_TEST=loop` the final Allan fit
//! of the residual loop (`effects::close_loop`, which asks the corrected series again at its end),
//! without either the Allan fit alone. Results: `validation/ramp.md`.
use imunoise::avar::{compute, Confidence, Statistic, TauGrid};
use imunoise::effects::band::{fit_in_band, Series};
use imunoise::effects::{close_loop, LoopConfig};
use imunoise::model::{fit_avar, CoefUnit, Coefficients, FitOptions, NoiseFit, Term};
use imunoise::psd::{log_bin, welch, WelchConfig};
use imunoise::sim::{simulate, SimSpec};
use rayon::prelude::*;

const FS: f64 = 100.0;
const FIRST_SEED: u64 = 11_000_000;

/// Which fit is judged.
#[derive(Clone, Copy, PartialEq)]
enum Mode {
    /// The Allan fit alone.
    Alone,
    /// The base fits' flow with the ramp's test.
    Base,
    /// The residual loop's final Allan fit.
    Loop,
}

fn fit(seed: u64, seconds: f64, truth: &Coefficients, mode: Mode) -> NoiseFit {
    let spec = serde_json::json!({ "rate_hz": FS, "duration_s": seconds, "seed": seed,
        "channels": [{ "name": "g", "sensor": "gyro", "noise": truth }] });
    let spec: SimSpec = serde_json::from_value(spec).expect("a valid spec");
    let y = simulate(&spec)
        .expect("simulated")
        .into_columns()
        .0
        .remove(0);
    let d = compute(
        &y,
        FS,
        &TauGrid::Octave,
        Statistic::Oadev,
        Confidence::OneSigma,
    )
    .expect("OADEV");
    match mode {
        Mode::Alone => return fit_avar(&d, &FitOptions::default()).expect("Allan fit"),
        Mode::Loop => {
            let out = close_loop(&y, FS, &[], &LoopConfig::with_segment(4096), None);
            return out.and_then(|o| o.allan).expect("the loop's Allan fit");
        }
        Mode::Base => {}
    }
    let psd = welch(&y, FS, &WelchConfig::new(4096)).expect("Welch");
    let binned = log_bin(&psd, 20);
    let s = Series {
        samples: &y,
        output_step: None,
    };
    let b = fit_in_band(Some(&d), &psd, Some(&binned), &FitOptions::default(), s);
    b.allan.expect("Allan fit")
}

/// Score of the chosen subset with R swapped for K, minus the best score (∞ if not ranked).
fn swap_gap(f: &NoiseFit) -> f64 {
    let chosen: Vec<Term> = f.estimates.iter().map(|t| t.term).collect();
    let swapped: Vec<Term> = {
        let mut s: Vec<Term> = chosen
            .iter()
            .copied()
            .filter(|&t| t != Term::RateRamp)
            .collect();
        if !s.contains(&Term::RateRandomWalk) {
            s.push(Term::RateRandomWalk);
        }
        s
    };
    let best = f
        .candidates
        .iter()
        .filter(|c| c.proper)
        .map(|c| c.score)
        .fold(f64::INFINITY, f64::min);
    f.candidates
        .iter()
        .filter(|c| {
            c.proper
                && c.terms.len() == swapped.len()
                && swapped.iter().all(|t| c.terms.contains(t))
        })
        .map(|c| c.score - best)
        .fold(f64::INFINITY, f64::min)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let seeds: u64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(500);
    let seconds: f64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1800.0);
    let mut ramps: Vec<f64> = args.iter().skip(3).filter_map(|s| s.parse().ok()).collect();
    if ramps.is_empty() {
        ramps = vec![0.0];
    }
    let mode = match std::env::var("RAMP_TEST").as_deref() {
        Ok("1") => Mode::Base,
        Ok("loop") => Mode::Loop,
        _ => Mode::Alone,
    };
    for r in ramps {
        let truth = Coefficients {
            n: CoefUnit::DegPerSqrtH.to_si(0.15),
            b: CoefUnit::DegPerH.to_si(3.0),
            k: CoefUnit::DegPerHPerSqrtH.to_si(20.0),
            r: r * std::f64::consts::PI / 180.0 / 3600.0 / 3600.0,
            ..Default::default()
        };
        let out: Vec<(bool, bool, f64, bool, f64)> = (0..seeds)
            .into_par_iter()
            .map(|s| {
                let f = fit(FIRST_SEED + s, seconds, &truth, mode);
                let e = f.get(Term::RateRamp);
                let kept = e.is_some();
                if kept && std::env::var("RAMP_SEEDS").is_ok() {
                    eprintln!("kept R: seed {}", FIRST_SEED + s);
                }
                let zero = e.is_some_and(|e| e.lo <= 0.0);
                let covers = e.map_or(truth.r == 0.0, |e| e.covers(truth.r));
                if let (Some(e), true) = (e, std::env::var("RAMP_SEEDS").is_ok()) {
                    eprintln!("half-width {:.3}", (e.hi - e.lo) / 2.0 / e.value);
                }
                (
                    kept,
                    zero,
                    if kept { swap_gap(&f) } else { f64::NAN },
                    covers,
                    e.map_or(f64::NAN, |e| e.value / truth.r),
                )
            })
            .collect();
        let kept: Vec<f64> = out.iter().filter(|o| o.0).map(|o| o.2).collect();
        let zero = out.iter().filter(|o| o.0 && o.1).count();
        let covered = out.iter().filter(|o| o.3).count();
        let mut ratios: Vec<f64> = out.iter().filter(|o| o.0).map(|o| o.4).collect();
        ratios.sort_by(f64::total_cmp);
        println!(
            "ratios {:?}",
            ratios
                .iter()
                .map(|g| (g * 100.0).round() / 100.0)
                .collect::<Vec<_>>()
        );
        let mut gaps = kept.clone();
        gaps.sort_by(f64::total_cmp);
        println!(
            "R {r} °/h/h, {seconds} s: kept {} of {seeds} ({} reaching 0), covered {covered}; swap gaps {:?}",
            kept.len(),
            zero,
            gaps.iter().map(|g| (g * 10.0).round() / 10.0).collect::<Vec<_>>()
        );
    }
}
