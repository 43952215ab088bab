//! The validation study of the model stage on simulated sensors with known truth: sensor
//! low-pass filters, quantisation, heavy-tailed outliers. For every case and seed the residual
//! loop runs as `analyze` runs it (bandwidth detection, fits, effects) and the combined
//! coefficients are checked against the truth. Prints a Markdown table: detection of the filter,
//! false effects, bias (median ratio to the truth) and 1σ interval coverage of N, B, K.
//!
//! `cargo run --release --example validation -- [SEEDS] [SECONDS]` (defaults 50, 1800); seeds
//! start at 900 000, disjoint from every test. `validation/run.sh` writes `validation/results.md`.

use imunoise::avar::{compute, Confidence, Statistic, TauGrid};
use imunoise::effects::{close_loop, AuxSeries, LoopConfig};
use imunoise::model::{combine, rounding_warning, CoefUnit, Coefficients, FitWarning, Term};
use imunoise::quality::smallest_step;
use imunoise::sim::{simulate, SimSpec};
use serde_json::json;

const FS: f64 = 100.0;
const FIRST_SEED: u64 = 900_000;
/// The planted resonance: f₀ (Hz), Q, σ (rad/s).
const RESONANCE: (f64, f64, f64) = (8.0, 20.0, 1.5e-4);
/// The recording's temperature: a 4 °C warm-up with a 600-s time constant, a 0.3-°C wander of
/// 300-s correlation time, 0.01 °C of measurement noise (a coupling of 5e-5 rad/s per °C drifts
/// 2e-4 rad/s over the warm-up, 14× B).
fn temperature_spec() -> serde_json::Value {
    json!({ "start_degc": 20.0, "rise_degc": 4.0, "warmup_s": 600.0,
            "wander": { "sigma": 0.3, "tc_s": 300.0 }, "noise_degc": 0.01 })
}
/// Outliers planted in the outlier case (1 % of a 1800-s record at 100 Hz).
const OUTLIERS: usize = 1800;
/// 10σ of 10-s means of the white noise: 10·N/√10 s.
const EXCURSION: f64 = 10.0 * 4.363_3e-5 / 3.162_277_7;

struct Case {
    name: String,
    filtered: bool,
    extra: serde_json::Value,
    /// The effect planted (`None`: none; any addition is then false).
    expect: Option<&'static str>,
    /// Record length of this case, s (`None`: the run's).
    seconds: Option<f64>,
    /// Sample rate, Hz (`None`: 100 Hz).
    rate: Option<f64>,
}

fn truth() -> Coefficients {
    Coefficients {
        n: CoefUnit::DegPerSqrtH.to_si(0.15),
        b: CoefUnit::DegPerH.to_si(3.0),
        k: CoefUnit::DegPerHPerSqrtH.to_si(20.0),
        ..Default::default()
    }
}

#[derive(Default)]
struct Tally {
    /// Records whose combined result has a rate ramp (none is planted), and how many of those
    /// flag it as indistinguishable from K.
    ramps: usize,
    ramps_ambiguous: usize,
    /// Excursions found: how often each edge's interval covered the planted time, and the
    /// interval widths (s).
    edges_found: usize,
    /// Resonances found: how often the 1σ intervals of f₀, Q and σ covered the planted values, and
    /// the ratios of the estimates to them.
    resonances_found: usize,
    /// Of those, the ones found inside the fit band (a resonance effect, not a peak beyond the
    /// band), and how many of those were read in the band-pass form (no plateau below f₀).
    in_band_resonances: usize,
    band_pass_resonances: usize,
    /// Couplings found: how often the 1σ interval of the coefficient covered the planted one, and
    /// the ratios of the estimates to it.
    couplings_found: usize,
    coupling_covered: usize,
    coupling_ratios: Vec<f64>,
    resonance_covered: [usize; 3],
    resonance_ratios: [Vec<f64>; 3],
    /// Gauss–Markov processes found: how often the 1σ intervals of Tc and σ covered the planted
    /// values, and the ratios of the estimates to them.
    gm_found: usize,
    gm_covered: [usize; 2],
    gm_ratios: [Vec<f64>; 2],
    /// Narrow bands found at a planted (wandering) line: how often the centre's 1σ interval
    /// covered its mean frequency, the centres' distances from it and the intervals' half-widths
    /// (Hz).
    bands_found: usize,
    band_centre_covered: usize,
    band_centre_errors: Vec<f64>,
    band_half_widths: Vec<f64>,
    edge_covered: [usize; 2],
    edge_widths: Vec<f64>,
    /// Excursions found that settle away from where they started (`after`), and how often the
    /// 1σ interval of that level covered the planted one (the sum of the case's steps).
    excursions_found: usize,
    settled_found: usize,
    settled_covered: usize,
    runs: usize,
    detected: usize,
    /// Filters read with a sinc^k decimator, and with how many stages (k).
    decimators: Vec<u32>,
    with_effect: usize,
    effects: Vec<&'static str>,
    ratio: [Vec<f64>; 3],
    covered: [usize; 3],
    kept: [usize; 3],
    warnings: usize,
    warning_kinds: Vec<String>,
    found_expected: usize,
    spikes_found: usize,
    /// Records with an output-resolution warning, how often its interval of the sensor's N
    /// (rounding taken out) covered the planted N, and its ratios to it.
    resolution_found: usize,
    resolution_covered: usize,
    resolution_ratios: Vec<f64>,
    /// Records with a heavy-tail warning, and the ratios of the N it gives with the spikes (and of
    /// the combined N, without them) to the planted N.
    heavy_tail_found: usize,
    heavy_tail_ratios: Vec<f64>,
    heavy_tail_n_ratios: Vec<f64>,
}

impl Tally {
    /// A resonance's f₀, Q and σ, each (estimate, lo, hi, truth): coverage and ratio to the truth.
    fn resonance(&mut self, checks: [(f64, f64, f64, f64); 3]) {
        for (k, (v, lo, hi, t)) in checks.into_iter().enumerate() {
            self.resonance_covered[k] += usize::from(lo <= t && t <= hi);
            self.resonance_ratios[k].push(v / t);
        }
    }
}

/// "(K disagrees 12, lack of fit (Allan) 3)".
fn warning_summary(kinds: &[String]) -> String {
    let mut sorted = kinds.to_vec();
    sorted.sort();
    let mut parts: Vec<String> = Vec::new();
    let mut i = 0;
    while i < sorted.len() {
        let j = sorted[i..].iter().take_while(|k| **k == sorted[i]).count();
        parts.push(format!("{} {j}", sorted[i]));
        i += j;
    }
    if parts.is_empty() {
        String::new()
    } else {
        format!(" ({})", parts.join(", "))
    }
}

fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The study's cases (`results.md`).
fn study_cases() -> Vec<Case> {
    vec![
        Case {
            name: "clean IEEE (N, B, K)".into(),
            filtered: false,
            extra: json!({}),
            expect: None,
            seconds: None,
            rate: None,
        },
        Case {
            name: "clean, 15-min records".into(),
            filtered: false,
            extra: json!({}),
            expect: None,
            seconds: Some(900.0),
            rate: None,
        },
        Case {
            name: "clean, random walk ruling from 20 s (K = 50 °/h/√h hides B), 20-min records at 200 Hz"
                .into(),
            filtered: false,
            extra: json!({ "noise": { "k": CoefUnit::DegPerHPerSqrtH.to_si(50.0) } }),
            expect: None,
            seconds: Some(1200.0),
            rate: Some(200.0),
        },
        Case {
            name: "N and B only (no K), 60-min records".into(),
            filtered: false,
            extra: json!({ "noise": { "k": 0.0 } }),
            expect: None,
            seconds: Some(3600.0),
            rate: None,
        },
        Case {
            name: "clean, 6-h records".into(),
            filtered: false,
            extra: json!({}),
            expect: None,
            seconds: Some(21_600.0),
            rate: None,
        },
        Case {
            name: "clean, 24-h records at 10 Hz".into(),
            filtered: false,
            extra: json!({}),
            expect: None,
            seconds: Some(86_400.0),
            rate: Some(10.0),
        },
        Case {
            name: "digital low-pass, order 2 at 20 Hz".into(),
            filtered: true,
            extra: json!({ "lowpass": { "corner_hz": 20.0, "order": 2 } }),
            expect: None,
            seconds: None,
            rate: None,
        },
        Case {
            name: "digital low-pass, order 4 at 30 Hz + quantisation".into(),
            filtered: true,
            extra: json!({ "lowpass": { "corner_hz": 30.0, "order": 4 },
                           "noise": { "q": CoefUnit::DegPerSqrtH.to_si(0.15) * 0.1 } }),
            expect: None,
            seconds: None,
            rate: None,
        },
        Case {
            name: "digital low-pass, order 1 at 10 Hz".into(),
            filtered: true,
            extra: json!({ "lowpass": { "corner_hz": 10.0, "order": 1 } }),
            expect: None,
            seconds: None,
            rate: None,
        },
        Case {
            name: "sinc³ decimator (↓4), then digital low-pass order 2 at 25 Hz".into(),
            filtered: true,
            extra: json!({ "lowpass": { "corner_hz": 25.0, "order": 2 },
                           "decimator": { "stages": 3, "factor": 4 } }),
            expect: None,
            seconds: None,
            rate: None,
        },
        Case {
            name: "wandering line 12 Hz (±0.05 Hz, ±20 %, 10 s) ≈ 100× floor, low-pass order 2 at 25 Hz".into(),
            filtered: true,
            extra: json!({ "lowpass": { "corner_hz": 25.0, "order": 2 },
                "sinusoids": [{ "amplitude": 3e-4, "freq_hz": 12.0,
                    "wander": { "freq_wander_hz": 0.05, "amplitude_wander": 0.2, "wander_tc_s": 10.0 } }] }),
            expect: Some("narrowband"),
            seconds: None,
            rate: None,
        },
        Case {
            name: "resonance 8 Hz, Q 20, σ 1.5e-4 rad/s (peak ≈ 30× floor)".into(),
            filtered: false,
            extra: json!({ "resonances": [{ "f0_hz": RESONANCE.0, "q": RESONANCE.1, "sigma": RESONANCE.2 }] }),
            expect: Some("resonance"),
            seconds: None,
            rate: None,
        },
        Case {
            name: "strong resonance 8 Hz, Q 20, σ 4.6e-4 rad/s (its plateau 44 % of the floor)".into(),
            filtered: false,
            extra: json!({ "resonances": [{ "f0_hz": RESONANCE.0, "q": RESONANCE.1, "sigma": 4.6e-4 }] }),
            expect: Some("resonance"),
            seconds: None,
            rate: None,
        },
        Case {
            name: "band-pass resonance 8 Hz, Q 20, σ 4.6e-4 rad/s (its rate: no plateau, where the low-pass form's would be 44 % of the floor)".into(),
            filtered: false,
            extra: json!({ "resonances": [{ "f0_hz": RESONANCE.0, "q": RESONANCE.1, "sigma": 4.6e-4, "form": "band_pass" }] }),
            expect: Some("resonance"),
            seconds: None,
            rate: None,
        },
        Case {
            name: "resonance 18 Hz, Q 30, σ 1.5e-4 rad/s beyond the fit band (peak ≈ 5× floor), low-pass order 2 at 25 Hz".into(),
            filtered: true,
            extra: json!({ "lowpass": { "corner_hz": 25.0, "order": 2 },
                "resonances": [{ "f0_hz": 18.0, "q": 30.0, "sigma": 1.5e-4 }] }),
            expect: Some("narrowband"),
            seconds: None,
            rate: None,
        },
        Case {
            name: "Gauss–Markov σ 1e-4 rad/s, Tc 60 s (longer than a 41-s Welch segment)".into(),
            filtered: false,
            extra: json!({ "gauss_markov": [{ "sigma": 1e-4, "tc_s": 60.0 }] }),
            expect: Some("gauss_markov"),
            seconds: None,
            rate: None,
        },
        Case {
            name: "the same Gauss–Markov process in 2-h records (120 Tc instead of 30)".into(),
            filtered: false,
            extra: json!({ "gauss_markov": [{ "sigma": 1e-4, "tc_s": 60.0 }] }),
            expect: Some("gauss_markov"),
            seconds: Some(7200.0),
            rate: None,
        },
        Case {
            name: "temperature coupling 5e-5 rad/s/°C (warm-up 4 °C, Tc 600 s, wander 0.3 °C)".into(),
            filtered: false,
            extra: json!({ "temperature_coefficient": 5e-5, "temperature": temperature_spec() }),
            expect: Some("coupling"),
            seconds: None,
            rate: None,
        },
        Case {
            name: "temperature coupling 1e-4 rad/s/°C (the same temperature)".into(),
            filtered: false,
            extra: json!({ "temperature_coefficient": 1e-4, "temperature": temperature_spec() }),
            expect: Some("coupling"),
            seconds: None,
            rate: None,
        },
        Case {
            name: "independent temperature channel, no coupling (negative control)".into(),
            filtered: false,
            extra: json!({ "temperature": temperature_spec() }),
            expect: None,
            seconds: None,
            rate: None,
        },
        Case {
            name: "outliers: 1 % of samples ±8 white σ".into(),
            filtered: false,
            extra: json!({ "spikes": { "count": OUTLIERS, "size": 8.0 * CoefUnit::DegPerSqrtH.to_si(0.15) * FS.sqrt() } }),
            expect: Some("spikes"),
            seconds: None,
            rate: None,
        },
        Case {
            name: "outliers on a filtered sensor: 1 % of samples ±8 white σ, low-pass order 2 at 20 Hz".into(),
            filtered: true,
            extra: json!({ "lowpass": { "corner_hz": 20.0, "order": 2 },
                "spikes": { "count": OUTLIERS, "size": 8.0 * CoefUnit::DegPerSqrtH.to_si(0.15) * FS.sqrt() } }),
            expect: Some("spikes"),
            seconds: None,
            rate: None,
        },
        Case {
            name: "rate output rounded to steps of one white σ (4.36e-4 rad/s)".into(),
            filtered: false,
            extra: json!({ "lsb": 4.363e-4 }),
            expect: None,
            seconds: None,
            rate: None,
        },
        Case {
            name: "band-limited bias instability: 1/f only above 16 mHz (a bias correlated over ≈ 10 s)".into(),
            filtered: false,
            extra: json!({ "flicker_corner_hz": 1.0 / (2.0 * std::f64::consts::PI * 10.0) }),
            expect: None,
            seconds: None,
            rate: None,
        },
        Case {
            name: "heavy-tailed white noise: Student t, 3 degrees of freedom (same N)".into(),
            filtered: false,
            extra: json!({ "white_tail_dof": 3.0 }),
            expect: None,
            seconds: None,
            rate: None,
        },
        Case {
            name: "heavy-tailed white noise: Student t, 5 degrees of freedom (same N)".into(),
            filtered: false,
            extra: json!({ "white_tail_dof": 5.0 }),
            expect: None,
            seconds: None,
            rate: None,
        },
        Case {
            name: "angle quantiser Q = 0.9 arcsec, no filter: the output takes four values".into(),
            filtered: false,
            extra: json!({ "noise": { "q": 4.363e-6 } }),
            expect: None,
            seconds: None,
            rate: None,
        },
        Case {
            name: "warm-up drift, no temperature channel: bias settling from 30 °/h with Tc 300 s".into(),
            filtered: false,
            extra: json!({ "drift": { "exponential": { "amplitude": CoefUnit::DegPerH.to_si(30.0), "tc_s": 300.0 } } }),
            expect: Some("drift"),
            seconds: None,
            rate: None,
        },
        Case {
            name: "warm-up drift, no temperature channel: bias settling from 100 °/h with Tc 300 s".into(),
            filtered: false,
            extra: json!({ "drift": { "exponential": { "amplitude": CoefUnit::DegPerH.to_si(100.0), "tc_s": 300.0 } } }),
            expect: Some("drift"),
            seconds: None,
            rate: None,
        },
        Case {
            name: "bias step: +10σ (10-s means) at 600 s".into(),
            filtered: false,
            extra: json!({ "steps": [{ "time_s": 600.0, "size": EXCURSION }] }),
            expect: Some("step"),
            seconds: None,
            rate: None,
        },
        Case {
            name: "excursion: +10σ (10-s means) from 600 s to 900 s".into(),
            filtered: false,
            extra: json!({ "steps": [{ "time_s": 600.0, "size": EXCURSION }, { "time_s": 900.0, "size": -EXCURSION }] }),
            expect: Some("excursion"),
            seconds: None,
            rate: None,
        },
        Case {
            name: "excursion that settles elsewhere: +10σ (10-s means) at 600 s, −6σ at 900 s".into(),
            filtered: false,
            extra: json!({ "steps": [{ "time_s": 600.0, "size": EXCURSION }, { "time_s": 900.0, "size": -0.6 * EXCURSION }] }),
            expect: Some("excursion"),
            seconds: None,
            rate: None,
        },
    ]
}

/// One case of a detection-limit sweep: `extra` planted in 30-min records, `expect` the effect.
fn sweep(name: String, extra: serde_json::Value, expect: &'static str) -> Case {
    Case {
        name,
        filtered: false,
        extra,
        expect: Some(expect),
        seconds: None,
        rate: None,
    }
}

/// `VALIDATION_SWEEP=1`: the effects the study plants near their detection limit, each at a
/// ladder of sizes around the study's own, to say from what size on each is found in 90 % of
/// records (`validation/detection.md`). Sizes in the units of the study's cases.
fn sweep_cases() -> Vec<Case> {
    let mut cases = Vec::new();
    for sigma in [1.0e-4, 1.5e-4, 2.0e-4, 3.0e-4] {
        cases.push(sweep(
            format!("Gauss–Markov Tc 60 s, σ {sigma:.1e} rad/s"),
            json!({ "gauss_markov": [{ "sigma": sigma, "tc_s": 60.0 }] }),
            "gauss_markov",
        ));
    }
    // The same process with more correlation times per record (60 instead of 30).
    cases.push(Case {
        seconds: Some(3600.0),
        ..sweep(
            "Gauss–Markov Tc 60 s, σ 1.0e-4 rad/s, 60-min records".into(),
            json!({ "gauss_markov": [{ "sigma": 1.0e-4, "tc_s": 60.0 }] }),
            "gauss_markov",
        )
    });
    for amplitude in [30.0, 50.0, 70.0] {
        cases.push(sweep(
            format!("warm-up drift from {amplitude} °/h, Tc 300 s"),
            json!({ "drift": { "exponential": { "amplitude": CoefUnit::DegPerH.to_si(amplitude), "tc_s": 300.0 } } }),
            "drift",
        ));
    }
    for coefficient in [5.0e-5, 7.0e-5] {
        cases.push(sweep(
            format!("temperature coupling {coefficient:.1e} rad/s/°C (the study's temperature)"),
            json!({ "temperature_coefficient": coefficient, "temperature": temperature_spec() }),
            "coupling",
        ));
    }
    for sigmas in [3.0, 5.0, 7.0] {
        let size = sigmas * EXCURSION / 10.0;
        cases.push(sweep(
            format!("bias step +{sigmas}σ (10-s means) at 600 s"),
            json!({ "steps": [{ "time_s": 600.0, "size": size }] }),
            "step",
        ));
        cases.push(sweep(
            format!("excursion +{sigmas}σ (10-s means) from 600 s to 900 s"),
            json!({ "steps": [{ "time_s": 600.0, "size": size }, { "time_s": 900.0, "size": -size }] }),
            "excursion",
        ));
    }
    // An excursion that settles elsewhere: the rise, and a return of 60 % of it, so that the
    // level after is 40 % of the rise; found as such only where that level stands out of the
    // random walk's wander over the 900 s after the excursion (K·√900 s ≈ 3.5σ of 10-s means).
    for sigmas in [10.0, 20.0, 30.0] {
        let size = sigmas * EXCURSION / 10.0;
        cases.push(sweep(
            format!("excursion +{sigmas}σ (10-s means) at 600 s, −{}σ at 900 s", 0.6 * sigmas),
            json!({ "steps": [{ "time_s": 600.0, "size": size }, { "time_s": 900.0, "size": -0.6 * size }] }),
            "excursion",
        ));
    }
    // The study's wandering line (100× the floor at 3e-4 rad/s) down to the floor, on an
    // unfiltered sensor: a weak line whose power one coherent sinusoid does not hold.
    for amplitude in [1.5e-5, 3.0e-5, 5.0e-5, 8.5e-5] {
        let floor_ratio = 100.0 * (amplitude / 3e-4_f64).powi(2);
        cases.push(sweep(
            format!("wandering line 12 Hz (±0.05 Hz, ±20 %, 10 s), amplitude {amplitude:.1e} rad/s (≈ {floor_ratio:.2}× floor)"),
            json!({ "sinusoids": [{ "amplitude": amplitude, "freq_hz": 12.0,
                "wander": { "freq_wander_hz": 0.05, "amplitude_wander": 0.2, "wander_tc_s": 10.0 } }] }),
            "narrowband",
        ));
    }
    for sigma in [0.5e-4, 1.0e-4] {
        cases.push(sweep(
            format!("resonance 8 Hz, Q 20, σ {sigma:.1e} rad/s"),
            json!({ "resonances": [{ "f0_hz": RESONANCE.0, "q": RESONANCE.1, "sigma": sigma }] }),
            "resonance",
        ));
    }
    // The study's resonance beyond the fit band (σ 1.5e-4 rad/s, peak 7–9× the floor through the
    // 25-Hz filter), down to where it no longer stands out.
    for sigma in [0.3e-4, 0.5e-4, 0.75e-4, 1.0e-4] {
        cases.push(Case {
            filtered: true,
            ..sweep(
                format!("resonance 18 Hz, Q 30, σ {sigma:.2e} rad/s beyond the fit band, low-pass order 2 at 25 Hz"),
                json!({ "lowpass": { "corner_hz": 25.0, "order": 2 },
                    "resonances": [{ "f0_hz": 18.0, "q": 30.0, "sigma": sigma }] }),
                "narrowband",
            )
        });
    }
    cases
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let seeds: u64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(50);
    let seconds: f64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1800.0);
    let cases = if std::env::var_os("VALIDATION_SWEEP").is_some() {
        sweep_cases()
    } else {
        study_cases()
    };
    let cfg = LoopConfig::with_segment(4096);
    let t = truth();
    let truths = [
        (Term::RandomWalk, t.n),
        (Term::BiasInstability, t.b),
        (Term::RateRandomWalk, t.k),
    ];
    println!("Simulated gyro N = 0.15 °/√h, B = 3 °/h, K = 20 °/h/√h at {FS} Hz, {seconds} s per record unless the case says otherwise, {seeds} seeds per case (from {FIRST_SEED}).\n");
    println!("| case | filter found | planted effect found | records with an effect added | warnings | N ratio (median) | N coverage | B ratio | B coverage | B kept | K ratio | K coverage | K kept |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    // `VALIDATION_CASES=outliers,excursion` runs only the cases whose names contain one of those.
    let only: Vec<String> = std::env::var("VALIDATION_CASES")
        .map(|v| v.split(',').map(str::to_owned).collect())
        .unwrap_or_default();
    // `VALIDATION_VERBOSE=1` prints, per seed, the effects added, the candidates rejected in the
    // last round and the final fits' terms (stderr).
    let verbose = std::env::var_os("VALIDATION_VERBOSE").is_some();
    // `VALIDATION_DUMP=path` appends one JSON line per record (fits, intervals, combined terms).
    let dump = std::env::var_os("VALIDATION_DUMP");
    let mut edge_notes = Vec::new();
    for case in cases
        .iter()
        .filter(|c| only.is_empty() || only.iter().any(|o| c.name.contains(o.as_str())))
    {
        let mut tally = Tally::default();
        // The case's own truth: a term its "noise" sets to 0 is absent (the K-less case).
        let truths = truths.map(|(term, v)| {
            let key = term.symbol().to_lowercase();
            let own = case.extra["noise"][key.as_str()].as_f64();
            (term, own.unwrap_or(v))
        });
        for s in 0..seeds {
            let mut ch = json!({ "name": "g", "sensor": "gyro", "noise": t });
            let mut temperature = None;
            for (k, v) in case.extra.as_object().unwrap() {
                if k == "temperature" {
                    // The recording's temperature channel (spec level), given to the loop as
                    // its aux channel.
                    temperature = Some(v.clone());
                } else if k == "noise" {
                    for (nk, nv) in v.as_object().unwrap() {
                        ch["noise"][nk] = nv.clone();
                    }
                } else {
                    ch[k] = v.clone();
                }
            }
            let fs = case.rate.unwrap_or(FS);
            let mut spec = json!({ "rate_hz": fs, "duration_s": case.seconds.unwrap_or(seconds), "seed": FIRST_SEED + s, "channels": [ch] });
            if let Some(t) = &temperature {
                spec["temperature"] = t.clone();
            }
            let spec: SimSpec = serde_json::from_value(spec).unwrap();
            let (mut columns, _) = simulate(&spec).unwrap().into_columns();
            let y = columns.remove(0);
            let aux: Vec<AuxSeries<'_>> = columns
                .iter()
                .map(|c| AuxSeries {
                    name: "temperature",
                    samples: c,
                })
                .collect();
            let Some(o) = close_loop(&y, fs, &aux, &cfg, None) else {
                continue;
            };
            tally.runs += 1;
            if verbose {
                if let Some(b) = &o.report.bandwidth {
                    eprintln!(
                        "  band {:?} corner {:.2} Hz order {} Nyquist {:.1} dB, f ≤ {:.2} Hz, ΔBIC {:.0}, {:?}",
                        b.lowpass.form, b.lowpass.corner_hz, b.lowpass.order,
                        b.nyquist_attenuation_db, b.fit_max_freq_hz, b.delta_bic, b.cause
                    );
                }
                eprintln!(
                    "seed {}: added {:?}",
                    FIRST_SEED + s,
                    o.report
                        .steps
                        .iter()
                        .map(|s| s.effect.kind())
                        .collect::<Vec<_>>()
                );
                for r in &o.report.rejected {
                    eprintln!("  rejected {} {:?}: {}", r.kind, r.delta_bic, r.note);
                }
                for f in [o.allan.as_ref(), o.spectrum.as_ref()]
                    .into_iter()
                    .flatten()
                {
                    eprintln!(
                        "  fit {:?}",
                        f.estimates
                            .iter()
                            .map(|e| (e.term.symbol(), e.value))
                            .collect::<Vec<_>>()
                    );
                    if std::env::var_os("VALIDATION_POINTS").is_some() {
                        for p in &f.points {
                            eprintln!(
                                "    x {:.4e} value {:.3e} model {:.3e} edf {:.1} z {:.2}",
                                p.x,
                                p.value.sqrt(),
                                p.model.sqrt(),
                                p.edf,
                                p.z
                            );
                        }
                    }
                }
            }
            // A filter claimed: an edge the output's coarse angle grid makes is not one.
            tally.detected +=
                usize::from(o.report.bandwidth.as_ref().is_some_and(|b| b.is_filter()));
            if let Some(d) = o
                .report
                .bandwidth
                .as_ref()
                .filter(|b| b.is_filter())
                .and_then(|b| b.lowpass.decimator)
            {
                tally.decimators.push(d.stages);
            }
            if !o.report.steps.is_empty() {
                tally.with_effect += 1;
                // Each kind once per record: the column counts records.
                let mut kinds: Vec<&'static str> =
                    o.report.steps.iter().map(|s| s.effect.kind()).collect();
                kinds.sort_unstable();
                kinds.dedup();
                tally.effects.extend(kinds);
            }
            if let Some(kind) = case.expect {
                tally.found_expected +=
                    usize::from(o.report.steps.iter().any(|s| s.effect.kind() == kind));
            }
            for s in &o.report.steps {
                if let imunoise::effects::Effect::Spikes(sp) = &s.effect {
                    tally.spikes_found += sp.indices.len();
                }
                if let imunoise::effects::Effect::Coupling { fit, .. } = &s.effect {
                    if case.expect == Some("coupling") {
                        let planted = case.extra["temperature_coefficient"].as_f64().unwrap();
                        tally.couplings_found += 1;
                        tally.coupling_covered +=
                            usize::from(fit.lo <= planted && planted <= fit.hi);
                        tally.coupling_ratios.push(fit.coefficient / planted);
                    }
                }
                if let imunoise::effects::Effect::Step(st) = &s.effect {
                    tally.edges_found += 1;
                    if let Some((a, b)) = st.time_interval_s {
                        tally.edge_covered[0] += usize::from(a <= 600.0 && 600.0 <= b);
                        tally.edge_widths.push(b - a);
                    }
                }
                if let imunoise::effects::Effect::GaussMarkov {
                    tc_s,
                    tc_lo_s,
                    tc_hi_s,
                    sigma,
                } = &s.effect
                {
                    if case.expect == Some("gauss_markov") {
                        let planted = &case.extra["gauss_markov"][0];
                        let (tc_t, s_t) = (
                            planted["tc_s"].as_f64().unwrap_or(f64::NAN),
                            planted["sigma"].as_f64().unwrap_or(f64::NAN),
                        );
                        tally.gm_found += 1;
                        for (k, (v, lo, hi, t)) in [
                            (*tc_s, *tc_lo_s, *tc_hi_s, tc_t),
                            (sigma.value, sigma.lo, sigma.hi, s_t),
                        ]
                        .into_iter()
                        .enumerate()
                        {
                            tally.gm_covered[k] += usize::from(lo <= t && t <= hi);
                            tally.gm_ratios[k].push(v / t);
                        }
                    }
                }
                if let imunoise::effects::Effect::Resonance {
                    f0_hz,
                    f0_lo,
                    f0_hi,
                    q,
                    q_lo,
                    q_hi,
                    sigma,
                    form,
                    ..
                } = &s.effect
                {
                    if case.expect == Some("resonance") {
                        tally.resonances_found += 1;
                        tally.in_band_resonances += 1;
                        tally.band_pass_resonances += usize::from(
                            *form == imunoise::effects::shapes::ResonanceForm::BandPass,
                        );
                        // The case's own resonance (the sweep plants other σ than the study's).
                        let planted = &case.extra["resonances"][0];
                        let (f0_t, q_t, s_t) = (
                            planted["f0_hz"].as_f64().unwrap_or(RESONANCE.0),
                            planted["q"].as_f64().unwrap_or(RESONANCE.1),
                            planted["sigma"].as_f64().unwrap_or(RESONANCE.2),
                        );
                        tally.resonance([
                            (*f0_hz, *f0_lo, *f0_hi, f0_t),
                            (*q, *q_lo, *q_hi, q_t),
                            (sigma.value, sigma.lo, sigma.hi, s_t),
                        ]);
                    }
                }
                if let imunoise::effects::Effect::Narrowband(nb) = &s.effect {
                    // A peak beyond the fit band, read as a resonance over the extrapolated floor.
                    let planted = &case.extra["resonances"][0];
                    if let (Some(r), Some(f0_t)) = (&nb.resonance, planted["f0_hz"].as_f64()) {
                        tally.resonances_found += 1;
                        let truth = |key: &str| planted[key].as_f64().unwrap_or(f64::NAN);
                        tally.resonance([
                            (r.f0_hz, r.f0_lo_hz, r.f0_hi_hz, f0_t),
                            (r.q, r.q_lo, r.q_hi, truth("q")),
                            (r.sigma, r.sigma_lo, r.sigma_hi, truth("sigma")),
                        ]);
                    }
                    if let Some(f) = case.extra["sinusoids"][0]["freq_hz"].as_f64() {
                        tally.bands_found += 1;
                        tally.band_centre_covered +=
                            usize::from(nb.freq_lo_hz <= f && f <= nb.freq_hi_hz);
                        tally.band_centre_errors.push((nb.freq_hz - f).abs());
                        tally
                            .band_half_widths
                            .push((nb.freq_hi_hz - nb.freq_lo_hz) / 2.0);
                    }
                }
                if let imunoise::effects::Effect::Excursion(e) = &s.effect {
                    tally.edges_found += 1;
                    tally.excursions_found += 1;
                    if let Some(after) = e.after {
                        let planted: f64 = case.extra["steps"]
                            .as_array()
                            .map_or(0.0, |v| v.iter().filter_map(|s| s["size"].as_f64()).sum());
                        tally.settled_found += 1;
                        tally.settled_covered +=
                            usize::from(after.lo <= planted && planted <= after.hi);
                    }
                    for (k, (i, truth)) in [(e.start_interval_s, 600.0), (e.end_interval_s, 900.0)]
                        .into_iter()
                        .enumerate()
                    {
                        if let Some((a, b)) = i {
                            tally.edge_covered[k] += usize::from(a <= truth && truth <= b);
                            tally.edge_widths.push(b - a);
                        }
                    }
                }
            }
            let dev = compute(
                &y,
                fs,
                &TauGrid::Octave,
                Statistic::Oadev,
                Confidence::OneSigma,
            )
            .ok();
            let mut c = combine(o.allan.as_ref(), o.spectrum.as_ref(), dev.as_ref());
            c.warnings.extend(o.report.warnings());
            // As `analyze` adds it from the quality screen's step.
            let rounding = smallest_step(&y)
                .and_then(|h| rounding_warning(h, fs, &c, o.allan.as_ref(), o.spectrum.as_ref()));
            if let Some(FitWarning::OutputResolution {
                n_without,
                n_lo,
                n_hi,
                ..
            }) = &rounding
            {
                tally.resolution_found += 1;
                tally.resolution_ratios.push(n_without / truths[0].1);
                tally.resolution_covered +=
                    usize::from(*n_lo <= truths[0].1 && n_hi.is_none_or(|hi| truths[0].1 <= hi));
            }
            c.warnings.extend(rounding);
            // As `analyze` adds it after the loop.
            let n_final = c.get(Term::RandomWalk).map(|e| e.value);
            let tail = o.report.heavy_tail_warning(n_final, y.len(), fs);
            if let Some(FitWarning::HeavyTail { n, n_with, .. }) = &tail {
                tally.heavy_tail_found += 1;
                tally.heavy_tail_ratios.push(n_with / truths[0].1);
                tally.heavy_tail_n_ratios.push(n / truths[0].1);
            }
            c.warnings.extend(tail);
            if verbose {
                for w in &c.warnings {
                    eprintln!("  warning {}", w.describe());
                }
            }
            tally.warnings += usize::from(!c.warnings.is_empty());
            for w in &c.warnings {
                tally.warning_kinds.push(match w {
                    FitWarning::LackOfFit { domain, .. } => format!("lack of fit ({domain:?})"),
                    FitWarning::DomainsDisagree { term, .. } => {
                        format!("{} disagrees", term.symbol())
                    }
                    FitWarning::ContradictsReadOff { term, .. } => {
                        format!("{} vs read-off", term.symbol())
                    }
                    FitWarning::BeyondAllanCurve { term, .. } => {
                        format!("{} beyond the Allan curve", term.symbol())
                    }
                    FitWarning::LoopLimitReached { .. } => "loop limit".to_string(),
                    FitWarning::RivalModel { effect, .. } => format!("rival {effect}"),
                    FitWarning::OutputResolution { .. } => "output resolution".to_string(),
                    FitWarning::HeavyTail { .. } => "heavy tail".to_string(),
                    FitWarning::CouplingOrWarmUp { .. } => "coupling or warm-up".to_string(),
                    FitWarning::KOrCoupling { .. } => "K or coupling".to_string(),
                    FitWarning::NotStatic { .. } => "not static".to_string(),
                    FitWarning::LinesAcrossJoins { .. } => "lines across joins".to_string(),
                });
            }
            if let Some(path) = &dump {
                // One line per record: each domain's kept terms with intervals and misfit, and
                // the combined terms (for calibration studies: `validation/calibration.py`).
                let fit_json = |f: Option<&imunoise::model::NoiseFit>| {
                    f.map(|f| {
                        json!({
                            "chi2_per_dof": f.chi2_per_dof(),
                            "inflation": f.lack_of_fit.inflation,
                            "points": f.points.len(),
                            "terms": f.estimates.iter().map(|e| json!({"term": e.term.symbol(), "value": e.value, "lo": e.lo, "hi": e.hi, "edf": e.edf, "ambiguous_with": e.ambiguous_with.map(|a| a.symbol())})).collect::<Vec<_>>(),
                        })
                    })
                };
                let line = json!({
                    "case": case.name,
                    "seed": FIRST_SEED + s,
                    "truth": truths.iter().map(|(t, v)| (t.symbol().to_string(), json!(v))).collect::<serde_json::Map<_, _>>(),
                    "allan": fit_json(o.allan.as_ref()),
                    "spectrum": fit_json(o.spectrum.as_ref()),
                    "combined": c.terms.iter().map(|t| json!({"term": t.term.symbol(), "value": t.value, "lo": t.lo, "hi": t.hi, "source": format!("{:?}", t.source), "hull": t.hull, "ambiguous_with": t.ambiguous_with.map(|a| a.symbol())})).collect::<Vec<_>>(),
                    "effects": o.report.steps.iter().map(|s| &s.effect).collect::<Vec<_>>(),
                });
                use std::io::Write;
                let mut f = std::fs::OpenOptions::new()
                    .create(true)
                    .append(true)
                    .open(path)
                    .unwrap();
                writeln!(f, "{line}").unwrap();
            }
            if let Some(r) = c.get(Term::RateRamp) {
                tally.ramps += 1;
                tally.ramps_ambiguous += usize::from(r.ambiguous_with.is_some());
            }
            for (i, (term, truth)) in truths.iter().enumerate() {
                if let Some(e) = c.get(*term) {
                    tally.kept[i] += 1;
                    if *truth > 0.0 {
                        tally.ratio[i].push(e.value / truth);
                    } else {
                        // None planted: the value against the other cases' K, and whether the
                        // interval reaches 0.
                        tally.ratio[i].push(e.value / t.k);
                    }
                    tally.covered[i] += usize::from(e.lo <= *truth && *truth <= e.hi);
                }
            }
        }
        let runs = tally.runs.max(1) as f64;
        let pct = |k: usize, of: usize| format!("{:.0} %", 100.0 * k as f64 / of.max(1) as f64);
        let effects: Vec<String> = tally.effects.iter().map(|k| k.to_string()).collect();
        let [mut rn, mut rb, mut rk] = tally.ratio;
        let k_absent = truths[2].1 <= 0.0;
        if k_absent {
            edge_notes.push(format!(
                "{}: K (none planted) kept in the combined result of {} of {} records, median value {:.3}× the other cases' K of 20 °/h/√h, its 1σ interval reaching 0 in {} of them.",
                case.name,
                tally.kept[2],
                tally.runs,
                median(&mut rk.clone()),
                tally.covered[2]
            ));
        }
        let k_ratio = if k_absent {
            "– (none planted)".to_string()
        } else {
            format!("{:.3}", median(&mut rk))
        };
        let k_coverage = if k_absent {
            "–".to_string()
        } else {
            pct(tally.covered[2], tally.kept[2])
        };
        println!(
            "| {} | {} | {} | {}{} | {}{} | {:.3} | {} | {:.3} | {} | {} | {} | {} | {} |",
            case.name,
            if case.filtered {
                pct(tally.detected, tally.runs)
            } else {
                format!("{} false", tally.detected)
            },
            match case.expect {
                Some("spikes") => format!(
                    "{} ({:.1} % of the planted count on average)",
                    pct(tally.found_expected, tally.runs),
                    100.0 * tally.spikes_found as f64 / (OUTLIERS * tally.runs.max(1)) as f64
                ),
                Some(_) => pct(tally.found_expected, tally.runs),
                None => "–".into(),
            },
            tally.with_effect,
            warning_summary(&effects),
            tally.warnings,
            warning_summary(&tally.warning_kinds),
            median(&mut rn),
            pct(tally.covered[0], tally.kept[0]),
            median(&mut rb),
            pct(tally.covered[1], tally.kept[1]),
            pct(tally.kept[1], tally.runs),
            k_ratio,
            k_coverage,
            pct(tally.kept[2], tally.runs),
        );
        let _ = runs;
        if tally.couplings_found > 0 {
            edge_notes.push(format!(
                "{}: of {} couplings found, the 1σ interval of the coefficient covers the planted one in {}; median ratio to it {:.3}.",
                case.name,
                tally.couplings_found,
                pct(tally.coupling_covered, tally.couplings_found),
                median(&mut tally.coupling_ratios)
            ));
        }
        if tally.resolution_found > 0 {
            edge_notes.push(format!(
                "{}: an output-resolution warning in {} of {} records; the sensor's N it gives (rounding taken out) has a median ratio {:.4} to the planted N, and its 1σ interval covers it in {}.",
                case.name,
                tally.resolution_found,
                tally.runs,
                median(&mut tally.resolution_ratios),
                pct(tally.resolution_covered, tally.resolution_found)
            ));
        }
        if !tally.decimators.is_empty() {
            let mut stages = tally.decimators.clone();
            stages.sort_unstable();
            let mut counts: Vec<String> = Vec::new();
            for k in 2..=5 {
                let c = stages.iter().filter(|&&s| s == k).count();
                if c > 0 {
                    counts.push(format!("sinc{k} {c}"));
                }
            }
            edge_notes.push(format!(
                "{}: the filter read with a decimator in {} of {} records ({}).",
                case.name,
                tally.decimators.len(),
                tally.runs,
                counts.join(", ")
            ));
        }
        if tally.heavy_tail_found > 0 {
            edge_notes.push(format!(
                "{}: a heavy-tail warning in {} of {} records; the N it gives with the spikes has a median ratio {:.4} to the planted N, the N without them (the combined value) {:.4}.",
                case.name,
                tally.heavy_tail_found,
                tally.runs,
                median(&mut tally.heavy_tail_ratios),
                median(&mut tally.heavy_tail_n_ratios)
            ));
        }
        if tally.ramps > 0 {
            edge_notes.push(format!(
                "{}: a rate ramp (none planted) in the combined result of {} of {} records, {} of them flagged as not distinguishable from K.",
                case.name, tally.ramps, tally.runs, tally.ramps_ambiguous
            ));
        }
        if tally.edges_found > 0 && case.expect == Some("step") {
            edge_notes.push(format!(
                "{}: of {} steps found, the 1σ interval of the time covers the planted 600 s in {}; median interval width {:.1} s.",
                case.name,
                tally.edges_found,
                pct(tally.edge_covered[0], tally.edges_found),
                median(&mut tally.edge_widths)
            ));
        } else if tally.resonances_found > 0 {
            let [rf, rq, rs] = &mut tally.resonance_ratios;
            let (found, inside, bp) = (
                tally.resonances_found,
                tally.in_band_resonances,
                tally.band_pass_resonances,
            );
            let what = if inside == found {
                format!("resonances found ({bp} read in the band-pass form)")
            } else if inside == 0 {
                "peaks beyond the fit band read as resonances".to_string()
            } else {
                format!(
                    "resonances found ({inside} inside the fit band, {bp} of those read in the band-pass form; {} peaks beyond it)",
                    found - inside
                )
            };
            edge_notes.push(format!(
                "{}: of {} {what}, the 1σ interval covers f₀ in {}, Q in {}, σ in {}; median ratios to the truth f₀ {:.4}, Q {:.3}, σ {:.3}.",
                case.name,
                tally.resonances_found,
                pct(tally.resonance_covered[0], tally.resonances_found),
                pct(tally.resonance_covered[1], tally.resonances_found),
                pct(tally.resonance_covered[2], tally.resonances_found),
                median(rf),
                median(rq),
                median(rs)
            ));
        } else if tally.bands_found > 0 {
            edge_notes.push(format!(
                "{}: of {} narrow bands found at the line, the centre's 1σ interval covers its mean frequency in {}; median distance from it {:.4} Hz, median half-width {:.4} Hz.",
                case.name,
                tally.bands_found,
                pct(tally.band_centre_covered, tally.bands_found),
                median(&mut tally.band_centre_errors),
                median(&mut tally.band_half_widths)
            ));
        } else if tally.edges_found > 0 && case.expect == Some("excursion") {
            edge_notes.push(format!(
                "{}: of {} excursions found, the 1σ interval of the start covers the planted 600 s in {}, of the end the planted 900 s in {}; median interval width {:.1} s.",
                case.name,
                tally.edges_found,
                pct(tally.edge_covered[0], tally.edges_found),
                pct(tally.edge_covered[1], tally.edges_found),
                median(&mut tally.edge_widths)
            ));
            if tally.settled_found > 0 {
                edge_notes.push(format!(
                    "{}: {} of the {} excursions settle away from where they started, the 1σ interval of that level covering the planted one in {}.",
                    case.name,
                    tally.settled_found,
                    tally.excursions_found,
                    pct(tally.settled_covered, tally.settled_found)
                ));
            }
        }
        if tally.gm_found > 0 {
            let [rt, rs] = &mut tally.gm_ratios;
            edge_notes.push(format!(
                "{}: of {} Gauss–Markov processes found, the 1σ interval covers Tc in {}, σ in {}; median ratios to the truth Tc {:.3}, σ {:.3}.",
                case.name,
                tally.gm_found,
                pct(tally.gm_covered[0], tally.gm_found),
                pct(tally.gm_covered[1], tally.gm_found),
                median(rt),
                median(rs)
            ));
        }
    }
    for n in edge_notes {
        println!("\n{n}");
    }
}
