//! The reference paper's workload, simulated: three gyro axes of an IMU 300CC at 207 Hz for
//! 812 minutes (10.1 M samples per axis), with the angle random walk and bias instability that
//! Paszek & Kaniewski (2014) report from the Allan variance in their Tables 4 and 5:
//! N = 0.024, 0.029, 0.030 °/√s and B = 0.0013, 0.0015, 0.0015 °/s.
//!
//! (The paper prints the Table 4 values with the unit °/s, but its Table 3 gives the same
//! quantity as °/√s together with the °/√h value, 0.016 °/√s = 0.96 °/√h, so °/√s it is. Its
//! Table 3 also labels the bias instability °/√s and °/√h while converting it by 3600: °/s and
//! °/h.)
//!
//! For each axis: overlapping Allan variance at octave τ and a Welch spectrum, both fitted with the
//! IEEE model, printed like the paper's Tables 3–5 in both unit systems, with intervals, the PSD/AV
//! ratio and whether the intervals overlap, and the time each stage took.
//!
//! ```text
//! cargo run --release --example paper_workload [nperseg] [seed]
//! ```
//! nperseg defaults to 2²¹ samples (2.8 h): the spectrum sees flicker only below
//! B²/(2πN²) ≈ 0.5 mHz, so its segments must be hours long, and the fit starts at 4·fs/nperseg.

use std::time::Instant;

use imunoise::avar::{compute, Confidence, Statistic, TauGrid};
use imunoise::model::{
    compare, fit_avar, fit_psd, CoefUnit, Coefficients, FitOptions, NoiseFit, Sensor, Term,
    TermEstimate,
};
use imunoise::psd::{log_bin, welch, WelchConfig};
use imunoise::sim::{simulate, ChannelSpec, SimSpec};

const RATE_HZ: f64 = 207.0;
const MINUTES: f64 = 812.0;
const AXES: [&str; 3] = ["x (roll)", "y (pitch)", "z (yaw)"];
/// Paper, Table 4 (AV): angle random walk, °/√s.
const ARW: [f64; 3] = [0.024, 0.029, 0.030];
/// Paper, Table 5 (AV): bias instability, °/s.
const BI: [f64; 3] = [0.0013, 0.0015, 0.0015];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let nperseg: usize = args.get(1).map_or(Ok(1 << 21), |s| s.parse())?;
    let seed: u64 = args.get(2).map_or(Ok(2014), |s| s.parse())?;
    let (arw_unit, bi_unit) = (CoefUnit::DegPerSPerSqrtHz, CoefUnit::DegPerS);
    let spec = SimSpec {
        rate_hz: RATE_HZ,
        duration_s: MINUTES * 60.0,
        seed,
        channels: (0..3)
            .map(|i| {
                ChannelSpec::new(
                    format!("gyro_{}", &AXES[i][..1]),
                    Sensor::Gyro,
                    Coefficients {
                        n: arw_unit.to_si(ARW[i]),
                        b: bi_unit.to_si(BI[i]),
                        ..Default::default()
                    },
                )
            })
            .collect(),
        temperature: None,
    };

    let total = Instant::now();
    let t = Instant::now();
    let sim = simulate(&spec)?;
    let t_sim = t.elapsed();
    let n = sim.channels[0].samples.len();
    println!(
        "Simulated 3 axes × {n} samples ({:.1} M) at {RATE_HZ} Hz ({MINUTES} min) in {:.2} s",
        n as f64 / 1e6,
        t_sim.as_secs_f64()
    );

    let opts = FitOptions::default();
    let welch_cfg = WelchConfig::new(nperseg);
    let mut fits = Vec::new();
    let (mut t_av, mut t_psd, mut t_fit) = (0.0, 0.0, 0.0);
    for ch in &sim.channels {
        let y = &ch.samples;
        let t = Instant::now();
        let d = compute(
            y,
            RATE_HZ,
            &TauGrid::Octave,
            Statistic::Oadev,
            Confidence::OneSigma,
        )?;
        t_av += t.elapsed().as_secs_f64();
        let t = Instant::now();
        let psd = welch(y, RATE_HZ, &welch_cfg)?;
        let binned = log_bin(&psd, 10);
        t_psd += t.elapsed().as_secs_f64();
        let t = Instant::now();
        let av = fit_avar(&d, &opts)?;
        let sp = fit_psd(&psd, &binned, &opts)?;
        t_fit += t.elapsed().as_secs_f64();
        fits.push((av, sp, psd.segments));
    }
    println!(
        "Allan variance (octave τ, {} points) {t_av:.2} s; Welch (nperseg {nperseg}, {} segments, \
         fit from {:.2e} Hz) {t_psd:.2} s; fits {t_fit:.3} s; total {:.2} s",
        fits[0].0.points.len(),
        fits[0].2,
        4.0 * RATE_HZ / nperseg as f64,
        total.elapsed().as_secs_f64()
    );

    println!("\nTerms kept (BIC) and goodness of fit:");
    for (i, (av, sp, _)) in fits.iter().enumerate() {
        println!(
            "  {:9}  AV {:<28} χ²/dof {:5.2}   PSD {:<28} χ²/dof {:5.2}",
            AXES[i],
            terms(av),
            av.chi2_per_dof(),
            terms(sp),
            sp.chi2_per_dof()
        );
    }

    table(
        "ARW (N)",
        Term::RandomWalk,
        &[(arw_unit, 4), (CoefUnit::DegPerSqrtH, 3)],
        &ARW,
        &fits,
    );
    table(
        "BI (B)",
        Term::BiasInstability,
        &[(bi_unit, 4), (CoefUnit::DegPerH, 2)],
        &BI,
        &fits,
    );

    println!("\nPSD vs AV per term (1σ intervals):");
    for (i, (av, sp, _)) in fits.iter().enumerate() {
        for row in compare(av, sp) {
            let ratio = row.ratio.map_or("-".into(), |r| format!("{r:.3}"));
            let overlap = row.overlap.map_or("-", |o| if o { "yes" } else { "no" });
            println!(
                "  {:9}  {}  PSD/AV {ratio:>6}  intervals overlap: {overlap}",
                AXES[i], row.term
            );
        }
    }
    Ok(())
}

fn terms(fit: &NoiseFit) -> String {
    let t: Vec<&str> = fit.estimates.iter().map(|e| e.term.symbol()).collect();
    t.join(" ")
}

/// One table like the paper's Tables 3–5: the truth, then the PSD and AV estimates per axis, each
/// in every unit of `units`.
fn table(
    title: &str,
    term: Term,
    units: &[(CoefUnit, usize)],
    truth: &[f64; 3],
    fits: &[(NoiseFit, NoiseFit, usize)],
) {
    println!(
        "\n{title}            {:>30} {:>30} {:>30}",
        AXES[0], AXES[1], AXES[2]
    );
    for &(unit, digits) in units {
        let cell = |e: Option<&TermEstimate>| match e {
            Some(e) => format!(
                "{:.d$} [{:.d$}, {:.d$}]",
                unit.from_si(e.value),
                unit.from_si(e.lo),
                unit.from_si(e.hi),
                d = digits + 1
            ),
            None => "not kept".into(),
        };
        let simulated: Vec<String> = truth
            .iter()
            .map(|&v| {
                let si = units[0].0.to_si(v);
                format!("{:.d$}", unit.from_si(si), d = digits + 1)
            })
            .collect();
        println!(
            "  simulated [{unit}] {:>30} {:>30} {:>30}",
            simulated[0], simulated[1], simulated[2]
        );
        for (label, pick) in [("PSD", 1), ("AV ", 0)] {
            let cells: Vec<String> = fits
                .iter()
                .map(|(av, sp, _)| {
                    cell(if pick == 0 {
                        av.get(term)
                    } else {
                        sp.get(term)
                    })
                })
                .collect();
            println!(
                "  {label} [{unit}]       {:>30} {:>30} {:>30}",
                cells[0], cells[1], cells[2]
            );
        }
    }
}
