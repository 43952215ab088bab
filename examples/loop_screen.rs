//! A measurement of the residual loop (`imunoise::effects::close_loop`) on simulated records:
//!
//! 1. false additions: pure IEEE-model noise (four profiles) with an independent warming
//!    temperature channel (warm-up and wander as in `tests/integration/residual_loop.rs`), over
//!    `--seeds` records each: how many records got any addition, per effect kind, and the ΔBIC of
//!    every (false) addition;
//! 2. recovery: each effect of the catalogue planted, undeclared, in the gyro of
//!    `residual_loop.rs` (with the temperature channel), over `--recovery-seeds` records: how often
//!    its kind is found, the median relative error of its main parameter, and how often the
//!    reported 1σ interval covers the truth.
//!
//! Records are 1200 s at 100 Hz. Run with
//! `cargo run --release --example loop_screen -- [--seeds N] [--recovery-seeds M]`
//! (defaults 200 and 50). Prints markdown tables.

use std::collections::BTreeMap;
use std::time::Instant;

use imunoise::effects::slow::DriftShape;
use imunoise::effects::{close_loop, AuxSeries, Effect, LoopConfig, LoopOutcome};
use imunoise::model::{CoefUnit, Coefficients};
use imunoise::sim::{simulate, ChannelTruth, SimSpec};
use rayon::prelude::*;
use serde_json::{json, Value};

const FS: f64 = 100.0;
const SECONDS: f64 = 1200.0;
/// Every kind the loop can add, in table order.
const KINDS: [&str; 7] = [
    "sinusoid",
    "resonance",
    "gauss_markov",
    "coupling",
    "drift",
    "spikes",
    "step",
];

fn config() -> LoopConfig {
    LoopConfig::with_segment(4096)
}

struct Args {
    seeds: u64,
    recovery_seeds: u64,
}

fn args() -> Args {
    let mut a = Args {
        seeds: 200,
        recovery_seeds: 50,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let mut value = || -> u64 {
            it.next()
                .and_then(|v| v.parse().ok())
                .unwrap_or_else(|| panic!("{flag} needs a count"))
        };
        match flag.as_str() {
            "--seeds" => a.seeds = value(),
            "--recovery-seeds" => a.recovery_seeds = value(),
            other => panic!("unknown argument {other}; use --seeds N, --recovery-seeds M"),
        }
    }
    a
}

/// The gyro of `residual_loop.rs`: N = 0.15 °/√h, B = 3 °/h, K = 20 °/h/√h.
fn gyro_noise() -> Coefficients {
    Coefficients {
        n: CoefUnit::DegPerSqrtH.to_si(0.15),
        b: CoefUnit::DegPerH.to_si(3.0),
        k: CoefUnit::DegPerHPerSqrtH.to_si(20.0),
        ..Default::default()
    }
}

/// One channel `ch` (a JSON channel spec) with the warming temperature channel; returns the
/// channel (rounded to multiples of `round_to` when given), the temperature and the truth.
fn record(ch: Value, seed: u64, round_to: Option<f64>) -> (Vec<f64>, Vec<f64>, ChannelTruth) {
    let spec = json!({
        "rate_hz": FS, "duration_s": SECONDS, "seed": seed, "channels": [ch],
        "temperature": { "start_degc": 20.0, "rise_degc": 4.0, "warmup_s": 600.0,
            "wander": { "sigma": 0.3, "tc_s": 300.0 }, "noise_degc": 0.01 }
    });
    let spec: SimSpec = serde_json::from_value(spec).expect("a valid spec");
    let (mut columns, meta) = simulate(&spec).expect("simulated").into_columns();
    let temperature = columns.pop().expect("temperature column");
    let mut y = columns.pop().expect("the channel");
    if let Some(step) = round_to {
        for v in &mut y {
            *v = (*v / step).round() * step;
        }
    }
    (y, temperature, meta[0].truth.clone().expect("truth"))
}

fn run(y: &[f64], temperature: &[f64]) -> LoopOutcome {
    let aux = [AuxSeries {
        name: "temperature",
        samples: temperature,
    }];
    close_loop(y, FS, &aux, &config(), None).expect("loop ran")
}

fn gyro(extra: Value) -> Value {
    let mut ch = json!({ "name": "g", "sensor": "gyro", "noise": gyro_noise() });
    for (k, v) in extra.as_object().expect("an object") {
        ch[k] = v.clone();
    }
    ch
}

struct Profile {
    name: &'static str,
    channel: Value,
    round_to: Option<f64>,
}

fn profiles() -> Vec<Profile> {
    // Accelerometer: N = 1e-3 m/s/√s (white σ 0.01 m/s² per sample), B = 2e-4 m/s², rounded to
    // 0.01 m/s² (one per-sample σ).
    let accel_n = 1e-3;
    let accel = Coefficients {
        n: accel_n,
        b: 2e-4,
        ..Default::default()
    };
    let rw = Coefficients {
        k: CoefUnit::DegPerHPerSqrtH.to_si(200.0),
        ..gyro_noise()
    };
    let ramp = Coefficients {
        r: CoefUnit::DegPerH2.to_si(100.0),
        ..gyro_noise()
    };
    vec![
        Profile {
            name: "gyro N 0.15°/√h, B 3°/h, K 20°/h/√h",
            channel: gyro(json!({})),
            round_to: None,
        },
        Profile {
            name: "accel N 1e-3 m/s/√s, B 2e-4 m/s², rounded to 0.01 m/s² (1σ/sample)",
            channel: json!({ "name": "a", "sensor": "accel", "noise": accel }),
            round_to: Some(accel_n * FS.sqrt()),
        },
        Profile {
            name: "gyro, random walk K 200°/h/√h",
            channel: json!({ "name": "g", "sensor": "gyro", "noise": rw }),
            round_to: None,
        },
        Profile {
            name: "gyro + rate ramp R 100°/h²",
            channel: json!({ "name": "g", "sensor": "gyro", "noise": ramp }),
            round_to: None,
        },
    ]
}

fn screen(seeds: u64) {
    println!("## False additions on pure IEEE noise ({seeds} records per profile, 1200 s at 100 Hz, independent temperature)\n");
    let mut header = "| profile | records with any addition |".to_string();
    let mut rule = "|---|---|".to_string();
    for k in KINDS {
        header += &format!(" {k} |");
        rule += "---|";
    }
    println!("{header}\n{rule}");
    let mut details = Vec::new();
    for p in profiles() {
        let t0 = Instant::now();
        let added: Vec<(u64, Vec<(&'static str, f64)>)> = (0..seeds)
            .into_par_iter()
            .map(|i| {
                let seed = 10_000 + i;
                let (y, t, _) = record(p.channel.clone(), seed, p.round_to);
                let o = run(&y, &t);
                let steps = o
                    .report
                    .steps
                    .iter()
                    .map(|s| (s.effect.kind(), s.delta_bic))
                    .collect();
                (seed, steps)
            })
            .collect();
        let any = added.iter().filter(|(_, s)| !s.is_empty()).count();
        let mut per_kind: BTreeMap<&str, usize> = BTreeMap::new();
        let mut dbic: Vec<String> = Vec::new();
        for (seed, steps) in &added {
            for (k, d) in steps {
                *per_kind.entry(k).or_default() += 1;
                dbic.push(format!("{k} {d:.1} (seed {seed})"));
            }
        }
        let mut row = format!("| {} | {any}/{seeds} |", p.name);
        for k in KINDS {
            row += &format!(" {} |", per_kind.get(k).copied().unwrap_or(0));
        }
        println!("{row}");
        details.push(format!(
            "- {} ({:.0} s): {}",
            p.name,
            t0.elapsed().as_secs_f64(),
            if dbic.is_empty() {
                "none".to_string()
            } else {
                format!("ΔBIC {}", dbic.join(", "))
            }
        ));
    }
    println!("\nΔBIC of each false addition:\n");
    for d in details {
        println!("{d}");
    }
    println!();
}

/// One parameter of a found effect against its truth, with the reported 1σ interval if any.
struct Param {
    name: &'static str,
    est: f64,
    truth: f64,
    interval: Option<(f64, f64)>,
}

impl Param {
    fn new(name: &'static str, est: f64, truth: f64, interval: Option<(f64, f64)>) -> Param {
        Param {
            name,
            est,
            truth,
            interval,
        }
    }
}

type Extract = fn(&Effect, &ChannelTruth) -> Option<Vec<Param>>;

struct Case {
    planted: String,
    kind: &'static str,
    extra: Value,
    extract: Extract,
}

fn cases() -> Vec<Case> {
    let white = CoefUnit::DegPerSqrtH.to_si(0.15) * FS.sqrt();
    let n10 = CoefUnit::DegPerSqrtH.to_si(0.15) / 10f64.sqrt();
    let sine: Extract = |e, t| match e {
        Effect::Sinusoid(s) => Some(vec![
            Param::new(
                "amplitude",
                s.amplitude,
                t.sinusoids[0].amplitude,
                Some((s.amplitude_lo, s.amplitude_hi)),
            ),
            Param::new(
                "f",
                s.freq_hz,
                t.sinusoids[0].freq_hz,
                Some((s.freq_lo, s.freq_hi)),
            ),
        ]),
        _ => None,
    };
    let resonance: Extract = |e, t| match e {
        Effect::Resonance {
            f0_hz,
            q,
            sigma,
            f0_lo,
            f0_hi,
            q_lo,
            q_hi,
            ..
        } => {
            let r = &t.resonances[0];
            Some(vec![
                Param::new("σ", sigma.value, r.sigma, Some((sigma.lo, sigma.hi))),
                Param::new("f0", *f0_hz, r.f0_hz, Some((*f0_lo, *f0_hi))),
                Param::new("q", *q, r.q, Some((*q_lo, *q_hi))),
            ])
        }
        _ => None,
    };
    let gm: Extract = |e, t| match e {
        Effect::GaussMarkov { tc_s, sigma, .. } => {
            let g = &t.gauss_markov[0];
            Some(vec![
                Param::new("σ", sigma.value, g.sigma, Some((sigma.lo, sigma.hi))),
                Param::new("Tc", *tc_s, g.tc_s, None),
            ])
        }
        _ => None,
    };
    let coupling: Extract = |e, t| match e {
        Effect::Coupling { fit, .. } => Some(vec![Param::new(
            "coefficient",
            fit.coefficient,
            t.temperature_coefficient,
            Some((fit.lo, fit.hi)),
        )]),
        _ => None,
    };
    let spikes: Extract = |e, t| match e {
        Effect::Spikes(s) => {
            let matched = t
                .spike_indices
                .iter()
                .filter(|i| s.indices.iter().any(|j| j.abs_diff(**i) <= 1))
                .count();
            let n = t.spike_indices.len() as f64;
            Some(vec![
                Param::new("count", s.indices.len() as f64, n, None),
                Param::new("matched ±1 sample", matched as f64, n, None),
            ])
        }
        _ => None,
    };
    let step: Extract = |e, t| match e {
        Effect::Step(s) => Some(vec![
            Param::new("size", s.size, t.steps[0].size, Some((s.lo, s.hi))),
            Param::new("time", s.time_s, t.steps[0].time_s, None),
        ]),
        _ => None,
    };
    let settling: Extract = |e, t| match e {
        Effect::Drift(d) => {
            let ex = t.drift?.exponential?;
            let DriftShape::Exponential { tc_s } = d.shape else {
                return None;
            };
            Some(vec![
                Param::new("amplitude", d.amplitude, ex.amplitude, Some((d.lo, d.hi))),
                Param::new("τ", tc_s, ex.tc_s, d.tc_interval_s),
            ])
        }
        _ => None,
    };
    let curvature: Extract = |e, t| match e {
        Effect::Drift(d) if d.shape == DriftShape::Quadratic => Some(vec![Param::new(
            "curvature",
            d.amplitude,
            t.drift?.quadratic,
            Some((d.lo, d.hi)),
        )]),
        _ => None,
    };
    let case = |planted: &str, kind, extra, extract| Case {
        planted: planted.to_string(),
        kind,
        extra,
        extract,
    };
    vec![
        case(
            "line 3e-4 rad/s at 7.3 Hz",
            "sinusoid",
            json!({ "sinusoids": [{ "amplitude": 3e-4, "freq_hz": 7.3 }] }),
            sine,
        ),
        case(
            "resonance 8 Hz, q 20, σ 1.5e-4 rad/s",
            "resonance",
            json!({ "resonances": [{ "f0_hz": 8.0, "q": 20.0, "sigma": 1.5e-4 }] }),
            resonance,
        ),
        case(
            "Gauss–Markov σ 2e-4 rad/s, Tc 5 s",
            "gauss_markov",
            json!({ "gauss_markov": [{ "sigma": 2e-4, "tc_s": 5.0 }] }),
            gm,
        ),
        case(
            "coupling 5e-5 rad/s/°C",
            "coupling",
            json!({ "temperature_coefficient": 5e-5 }),
            coupling,
        ),
        case(
            "coupling 2e-4 rad/s/°C",
            "coupling",
            json!({ "temperature_coefficient": 2e-4 }),
            coupling,
        ),
        case(
            "20 spikes of 30σ",
            "spikes",
            json!({ "spikes": { "count": 20, "size": 30.0 * white } }),
            spikes,
        ),
        case(
            "step 10σ(10 s) = 1.4e-4 rad/s at 480 s",
            "step",
            json!({ "steps": [{ "time_s": 480.0, "size": 10.0 * n10 }] }),
            step,
        ),
        case(
            "step 20σ(10 s) = 2.8e-4 rad/s at 480 s",
            "step",
            json!({ "steps": [{ "time_s": 480.0, "size": 20.0 * n10 }] }),
            step,
        ),
        case(
            "settling 1e-3 rad/s, τ 120 s",
            "drift",
            json!({ "drift": { "exponential": { "amplitude": 1e-3, "tc_s": 120.0 } } }),
            settling,
        ),
        case(
            "settling 3e-4 rad/s, τ 120 s",
            "drift",
            json!({ "drift": { "exponential": { "amplitude": 3e-4, "tc_s": 120.0 } } }),
            settling,
        ),
        case(
            "curvature 1e-9 rad/s³",
            "drift",
            json!({ "drift": { "quadratic": 1e-9 } }),
            curvature,
        ),
    ]
}

/// One recovery record: whether the planted kind was added, its parameters when in the planted
/// form, and the other kinds added.
struct Outcome {
    added: bool,
    params: Option<Vec<Param>>,
    others: Vec<&'static str>,
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 {
        v[m]
    } else {
        (v[m - 1] + v[m]) / 2.0
    }
}

/// "median signed / median |·|" relative error and the coverage of the parameters at `index`.
fn summarise(found: &[Vec<Param>], index: usize) -> (String, String) {
    let rel: Vec<f64> = found
        .iter()
        .filter_map(|p| p.get(index))
        .map(|p| p.est / p.truth - 1.0)
        .collect();
    let err = if rel.is_empty() {
        "—".to_string()
    } else {
        format!(
            "{:+.1} % / {:.1} %",
            100.0 * median(rel.clone()),
            100.0 * median(rel.iter().map(|r| r.abs()).collect())
        )
    };
    let with: Vec<bool> = found
        .iter()
        .filter_map(|p| p.get(index))
        .filter_map(|p| p.interval.map(|(lo, hi)| lo <= p.truth && p.truth <= hi))
        .collect();
    let cover = if with.is_empty() {
        "—".to_string()
    } else {
        format!(
            "{}/{} ({:.0} %)",
            with.iter().filter(|c| **c).count(),
            with.len(),
            100.0 * with.iter().filter(|c| **c).count() as f64 / with.len() as f64
        )
    };
    (err, cover)
}

fn recovery(seeds: u64) {
    println!("## Recovery of undeclared effects ({seeds} records each, the gyro of residual_loop.rs + temperature, 1200 s)\n");
    println!("Found: the kind added in the planted form (a drift of the other shape is counted apart). Relative error: median signed / median absolute of estimate/truth − 1. Coverage: share of found records whose 1σ interval holds the truth.\n");
    println!("| planted | found | other kinds added (records) | main parameter | rel. error | 1σ coverage | other parameters: rel. error, coverage |");
    println!("|---|---|---|---|---|---|---|");
    for c in cases() {
        let t0 = Instant::now();
        let outcomes: Vec<Outcome> = (0..seeds)
            .into_par_iter()
            .map(|i| {
                let (y, t, truth) = record(gyro(c.extra.clone()), 20_000 + i, None);
                let o = run(&y, &t);
                let step = o.report.steps.iter().find(|s| s.effect.kind() == c.kind);
                let params = step.and_then(|s| (c.extract)(&s.effect, &truth));
                let others = o
                    .report
                    .steps
                    .iter()
                    .map(|s| s.effect.kind())
                    .filter(|k| *k != c.kind)
                    .collect();
                Outcome {
                    added: step.is_some(),
                    params,
                    others,
                }
            })
            .collect();
        let wrong_form = outcomes
            .iter()
            .filter(|o| o.added && o.params.is_none())
            .count();
        let mut other: BTreeMap<&str, usize> = BTreeMap::new();
        for o in &outcomes {
            let mut seen: Vec<&str> = o.others.clone();
            seen.sort_unstable();
            seen.dedup();
            for k in seen {
                *other.entry(k).or_default() += 1;
            }
        }
        let found: Vec<Vec<Param>> = outcomes.into_iter().filter_map(|o| o.params).collect();
        let other = if other.is_empty() {
            "—".to_string()
        } else {
            other
                .iter()
                .map(|(k, n)| format!("{k} {n}"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let names: Vec<&str> = found
            .first()
            .map(|p| p.iter().map(|q| q.name).collect())
            .unwrap_or_default();
        let (err, cover) = summarise(&found, 0);
        let rest: Vec<String> = (1..names.len())
            .map(|i| {
                let (e, c) = summarise(&found, i);
                if c == "—" {
                    format!("{}: {e}", names[i])
                } else {
                    format!("{}: {e}, {c}", names[i])
                }
            })
            .collect();
        let found_col = if wrong_form > 0 {
            format!("{}/{seeds} (+{wrong_form} in another form)", found.len())
        } else {
            format!("{}/{seeds}", found.len())
        };
        println!(
            "| {} | {found_col} | {other} | {} | {err} | {cover} | {} |",
            c.planted,
            names.first().copied().unwrap_or("—"),
            if rest.is_empty() {
                "—".to_string()
            } else {
                rest.join("; ")
            }
        );
        eprintln!("{}: {:.0} s", c.planted, t0.elapsed().as_secs_f64());
    }
    println!();
}

fn main() {
    let a = args();
    let t0 = Instant::now();
    screen(a.seeds);
    recovery(a.recovery_seeds);
    eprintln!("total {:.0} s", t0.elapsed().as_secs_f64());
}
