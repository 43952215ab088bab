//! Temporary: correlation of octave OAVAR estimates.
use imunoise::avar::{compute, Confidence, Statistic, TauGrid};
use imunoise::sim::rng::Rng;
use imunoise::sim::shaped_noise;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let which = args.get(1).map(String::as_str).unwrap_or("n");
    let n = 1 << 14;
    let trials = 2000;
    let mut rows: Vec<Vec<f64>> = Vec::new();
    for t in 0..trials {
        let mut rng = Rng::new(t);
        let y: Vec<f64> = match which {
            "n" => rng.gauss_vec(n),
            "b" => shaped_noise(n, 1.0, |f| 1.0 / f, &mut rng),
            "k" => {
                let mut l = 0.0;
                (0..n)
                    .map(|_| {
                        l += rng.gauss();
                        l
                    })
                    .collect()
            }
            _ => {
                let e = rng.gauss_vec(n + 1);
                (0..n).map(|i| e[i + 1] - e[i]).collect()
            }
        };
        let d = compute(
            &y,
            1.0,
            &TauGrid::Octave,
            Statistic::Oadev,
            Confidence::OneSigma,
        )
        .unwrap();
        rows.push(d.variance.clone());
    }
    let p = rows[0].len();
    let mean: Vec<f64> = (0..p)
        .map(|j| rows.iter().map(|r| r[j]).sum::<f64>() / trials as f64)
        .collect();
    let cov = |a: usize, b: usize| {
        rows.iter()
            .map(|r| (r[a] - mean[a]) * (r[b] - mean[b]))
            .sum::<f64>()
            / (trials - 1) as f64
    };
    println!(
        "{which}: edf(mc) 2/var: {:?}",
        (0..p)
            .map(|j| format!("{:.1}", 2.0 * mean[j] * mean[j] / cov(j, j)))
            .collect::<Vec<_>>()
    );
    for lag in 1..5 {
        let r: Vec<f64> = (0..p - lag)
            .map(|j| cov(j, j + lag) / (cov(j, j) * cov(j + lag, j + lag)).sqrt())
            .collect();
        let mid: Vec<f64> = r
            .iter()
            .copied()
            .skip(1)
            .take(p.saturating_sub(lag + 5))
            .collect();
        let avg = mid.iter().sum::<f64>() / mid.len() as f64;
        println!(
            "corr lag {lag}: mid-avg {avg:.3} all {:?}",
            r.iter().map(|v| format!("{v:.2}")).collect::<Vec<_>>()
        );
    }
}
