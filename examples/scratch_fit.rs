//! Temporary: fit behaviour over many seeds.
use imunoise::avar::{compute, Confidence, Statistic, TauGrid};
use imunoise::model::{fit_avar, fit_psd, Coefficients, FitOptions, NoiseFit, Sensor, Term};
use imunoise::psd::{log_bin, welch, WelchConfig};
use imunoise::sim::{simulate, ChannelSpec, SimSpec};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let trials: u64 = args.get(1).map_or(100, |s| s.parse().unwrap());
    let n_samples: f64 = args.get(2).map_or(200_000.0, |s| s.parse().unwrap());
    let model = args.get(3).map_or("nk", |s| s.as_str());
    let corr = args.get(4).map_or(true, |s| s == "1");
    let nperseg: usize = args.get(5).map_or(4096, |s| s.parse().unwrap());
    let fs: f64 = 100.0;
    let mut c = Coefficients::default();
    for kv in model.split(',') {
        let (k, v) = kv.split_once('=').unwrap();
        let v: f64 = v.parse().unwrap();
        match k {
            "q" => c.q = v,
            "n" => c.n = v,
            "b" => c.b = v,
            "k" => c.k = v,
            "r" => c.r = v,
            _ => panic!(),
        }
    }
    let opts = FitOptions {
        correlated_points: corr,
        confidence: if std::env::var("P95").is_ok() {
            Confidence::Level(0.95)
        } else {
            Confidence::OneSigma
        },
        ..Default::default()
    };
    let mut overlaps = [0u32; 5];
    let mut stats: Vec<(&str, [u32; 5], [u32; 5], [f64; 5], [f64; 5], f64)> = vec![
        ("avar", [0; 5], [0; 5], [0.0; 5], [0.0; 5], 0.0),
        ("psd", [0; 5], [0; 5], [0.0; 5], [0.0; 5], 0.0),
    ];
    let t0 = std::time::Instant::now();
    for t in 0..trials {
        let spec = SimSpec {
            rate_hz: fs,
            duration_s: n_samples / fs,
            seed: t,
            channels: vec![ChannelSpec {
                name: "x".into(),
                sensor: Sensor::Gyro,
                bias: 0.0,
                noise: c,
                gauss_markov: vec![],
                sinusoids: vec![],
                temperature_coefficient: 0.0,
            }],
            temperature: None,
        };
        let y = simulate(&spec).unwrap().channels.remove(0).samples;
        let d = compute(
            &y,
            fs,
            &TauGrid::Octave,
            Statistic::Oadev,
            Confidence::OneSigma,
        )
        .unwrap();
        let tf = std::time::Instant::now();
        let fa = fit_avar(&d, &opts).unwrap();
        if t == 0 {
            println!("fit_avar {:?}", tf.elapsed());
        }
        if t == std::env::var("SHOW").map_or(0, |s| s.parse().unwrap()) {
            print_fit(&fa);
            for (i, p) in fa.points.iter().enumerate() {
                println!(
                    "tau {:9.2} v {:.4e} truth {:.4e} model {:.4e} nu {:.1} z {:6.2} edf {:.1}",
                    p.x,
                    p.value,
                    c.avar(p.x),
                    p.model,
                    p.edf,
                    p.z,
                    d.edf[i]
                );
            }
        }
        let psd = welch(&y, fs, &WelchConfig::new(nperseg)).unwrap();
        let tf = std::time::Instant::now();
        let fp = fit_psd(&psd, &log_bin(&psd, 10), &opts).unwrap();
        if t == 0 {
            println!("fit_psd {:?}", tf.elapsed());
        }
        if std::env::var("TRACE").is_ok() {
            println!(
                "trial {t}: av chi2/dof {:.2} terms {:?} | psd chi2/dof {:.2} terms {:?}",
                fa.chi2_per_dof(),
                fa.estimates
                    .iter()
                    .map(|e| e.term.symbol())
                    .collect::<Vec<_>>(),
                fp.chi2_per_dof(),
                fp.estimates
                    .iter()
                    .map(|e| e.term.symbol())
                    .collect::<Vec<_>>()
            );
        }
        for row in imunoise::model::compare(&fa, &fp) {
            if row.overlap == Some(true) {
                overlaps[row.term.index()] += 1;
            }
        }
        for (k, f) in [fa, fp].iter().enumerate() {
            let s = &mut stats[k];
            s.5 += f.chi2_per_dof();
            for term in Term::ALL {
                let j = term.index();
                if let Some(e) = f.get(term) {
                    s.1[j] += 1;
                    if e.covers(c.get(term)) {
                        s.2[j] += 1;
                    }
                    s.3[j] += e.value / c.get(term).max(1e-300);
                    HW.with(|h| h.borrow_mut()[k][j] += (e.hi - e.lo) / 2.0 / e.value);
                    s.4[j] += (e.value / c.get(term).max(1e-300)).powi(2);
                }
            }
            if t == 0 {
                print_fit(f);
            }
        }
    }
    for s in &stats {
        println!("{}: mean chi2/dof {:.3}", s.0, s.5 / trials as f64);
        for term in Term::ALL {
            let j = term.index();
            let k = s.1[j].max(1) as f64;
            let mean = s.3[j] / k;
            let sd = (s.4[j] / k - mean * mean).max(0.0).sqrt();
            let hw = HW.with(|h| h.borrow()[if s.0 == "avar" { 0 } else { 1 }][j]) / k;
            print!("  halfwidth {hw:.4}");
            println!("  {term}: selected {:4} / {trials}, covered {:4} ({:.3}), mean ratio {:.4} sd {:.4}", s.1[j], s.2[j], s.2[j] as f64 / k, mean, sd);
        }
    }
    println!("overlaps {overlaps:?}");
    println!("{:.2} s", t0.elapsed().as_secs_f64());
}

thread_local! { static HW: std::cell::RefCell<[[f64; 5]; 2]> = const { std::cell::RefCell::new([[0.0; 5]; 2]) }; }

fn print_fit(f: &NoiseFit) {
    println!(
        "{:?} chi2/dof {:.2} ({} pts)",
        f.domain,
        f.chi2_per_dof(),
        f.points.len()
    );
    for e in &f.estimates {
        println!(
            "   {} {:.4e} [{:.4e}, {:.4e}] edf {:.1}",
            e.term, e.value, e.lo, e.hi, e.edf
        );
    }
    for u in &f.upper_limits {
        println!("   {} < {:.3e}", u.term, u.upper);
    }
    for c in f.candidates.iter().take(4) {
        println!(
            "   cand {:?} chi2 {:.2} score {:.2} {}",
            c.terms, c.chi2, c.score, c.proper
        );
    }
}
