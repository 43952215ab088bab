//! Interval coverage of the base fits (no residual loop) on many seeds of clean simulated gyros:
//! the calibration the validation study's 50 seeds per case cannot resolve. Every case of the
//! validation draws its white noise, flicker and random walk from the same 50 seeds (independent
//! streams per component, so that a case differs from the clean one only by its impairment): its
//! coverage columns are one draw of 50, shared by every row, and their binomial error (±6.6
//! points at 68 %) is common to all of them. This study draws 1000 seeds per record length, from
//! 7 000 000 (disjoint from the validation's and the tests').
//!
//! Per record length, domain and term: how often the term was kept, the share of kept estimates
//! whose 1σ interval covers the truth, the median normalised error (|ln(truth/value)| over the
//! interval's log half-width on the truth's side; 0.674 for a calibrated 1σ interval), the median
//! ratio to the truth, and the same coverage among the estimates flagged as not told from a
//! neighbouring term.
//!
//! `cargo run --release --example coverage -- [SEEDS] [SECONDS...]` (defaults 1000; 900 1800
//! 7200). Simulated gyro as the validation's: N = 0.15 °/√h, B = 3 °/h, K = 20 °/h/√h at 100 Hz;
//! the fits as `analyze` makes them (octave OADEV, Welch of 4096 samples in 20 bands a decade,
//! default fit options, 1σ).

use imunoise::avar::{compute, Confidence, Statistic, TauGrid};
use imunoise::model::{fit_avar, fit_psd, CoefUnit, Coefficients, FitOptions, NoiseFit, Term};
use imunoise::psd::{log_bin, welch, WelchConfig};
use imunoise::sim::{simulate, SimSpec};
use rayon::prelude::*;

const FS: f64 = 100.0;
const FIRST_SEED: u64 = 7_000_000;

#[derive(Default, Clone)]
struct Cell {
    kept: usize,
    covered: usize,
    errors: Vec<f64>,
    ratios: Vec<f64>,
    ambiguous: usize,
    ambiguous_covered: usize,
}

fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn fits(seed: u64, seconds: f64, truth: &Coefficients) -> [NoiseFit; 2] {
    let spec = serde_json::json!({ "rate_hz": FS, "duration_s": seconds, "seed": seed,
        "channels": [{ "name": "g", "sensor": "gyro", "noise": truth }] });
    let spec: SimSpec = serde_json::from_value(spec).expect("a valid spec");
    let y = simulate(&spec)
        .expect("simulated")
        .into_columns()
        .0
        .remove(0);
    let opts = FitOptions::default();
    let d = compute(
        &y,
        FS,
        &TauGrid::Octave,
        Statistic::Oadev,
        Confidence::OneSigma,
    )
    .expect("OADEV");
    let psd = welch(&y, FS, &WelchConfig::new(4096)).expect("Welch");
    [
        fit_avar(&d, &opts).expect("Allan fit"),
        fit_psd(&psd, &log_bin(&psd, 20), &opts).expect("spectrum fit"),
    ]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let seeds: u64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(1000);
    // `COVERAGE_FIRST_SEED=900000` draws the validation's own seeds instead.
    let first: u64 = std::env::var("COVERAGE_FIRST_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(FIRST_SEED);
    let mut lengths: Vec<f64> = args.iter().skip(2).filter_map(|s| s.parse().ok()).collect();
    if lengths.is_empty() {
        lengths = vec![900.0, 1800.0, 7200.0];
    }
    let truth = Coefficients {
        n: CoefUnit::DegPerSqrtH.to_si(0.15),
        b: CoefUnit::DegPerH.to_si(3.0),
        k: CoefUnit::DegPerHPerSqrtH.to_si(20.0),
        ..Default::default()
    };
    let terms = [
        (Term::RandomWalk, truth.n),
        (Term::BiasInstability, truth.b),
        (Term::RateRandomWalk, truth.k),
    ];
    println!("| record | domain | term | kept | coverage (1σ, nominal 68.3 %) | median abs. normalised error (0.674) | median ratio | flagged not told apart | their coverage |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for seconds in lengths {
        let all: Vec<[NoiseFit; 2]> = (0..seeds)
            .into_par_iter()
            .map(|s| fits(first + s, seconds, &truth))
            .collect();
        for (k, domain) in ["Allan", "spectrum"].iter().enumerate() {
            for (term, v) in terms {
                let mut cell = Cell::default();
                for f in &all {
                    let Some(e) = f[k].get(term) else { continue };
                    let covered = e.covers(v);
                    cell.kept += 1;
                    cell.covered += usize::from(covered);
                    cell.ratios.push(e.value / v);
                    let half = if v > e.value {
                        e.hi / e.value
                    } else {
                        e.value / e.lo
                    };
                    cell.errors.push(((v / e.value).ln() / half.ln()).abs());
                    if e.ambiguous_with.is_some() {
                        cell.ambiguous += 1;
                        cell.ambiguous_covered += usize::from(covered);
                    }
                }
                let pct = |a: usize, b: usize| {
                    if b == 0 {
                        "–".to_owned()
                    } else {
                        format!("{:.1} %", 100.0 * a as f64 / b as f64)
                    }
                };
                println!(
                    "| {:.0} min | {domain} | {} | {} of {seeds} | {} | {:.2} | {:.3} | {} | {} |",
                    seconds / 60.0,
                    term.symbol(),
                    cell.kept,
                    pct(cell.covered, cell.kept),
                    median(&mut cell.errors),
                    median(&mut cell.ratios),
                    cell.ambiguous,
                    pct(cell.ambiguous_covered, cell.ambiguous),
                );
            }
        }
    }
}
