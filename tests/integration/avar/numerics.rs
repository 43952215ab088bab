//! Numerical exactness on long data, agreement with the textbook reference, and independence from
//! the number of threads.

use imunoise::avar::{compute, reference, Confidence, Statistic, TauGrid};
use rayon::prelude::*;

use super::support::{rel, SplitMix};

/// Integer units per unit of rate: y = Y / 2^20, exactly representable in f64.
const SCALE_BITS: u32 = 20;

/// Y_k = offset + white + random walk, in integer units of 2^-20 (σ_white = 1 unit of y = 2^20
/// counts, offset 10⁶ σ, walk steps 0.01 σ). Returned with y = Y / 2^20 (exact: |Y| < 2^41).
fn offset_drift_data(n: usize, seed: u64) -> (Vec<i64>, Vec<f64>) {
    let mut rng = SplitMix(seed);
    let unit = (1i64 << SCALE_BITS) as f64;
    let offset = 1_000_000i64 << SCALE_BITS;
    let mut walk = 0i64;
    let ints: Vec<i64> = (0..n)
        .map(|_| {
            let white = (rng.gauss() * unit).round() as i64;
            walk += (rng.gauss() * 0.01 * unit).round() as i64;
            offset + white + walk
        })
        .collect();
    let y = ints.iter().map(|&v| v as f64 / unit).collect();
    (ints, y)
}

/// Exact overlapping Allan variance of y = Y/2^20: the second differences
/// D_j = Σ_{i=j+m}^{j+2m−1} Y_i − Σ_{i=j}^{j+m−1} Y_i (= S_{j+2m} − 2S_{j+m} + S_j) are carried as
/// exact integers, ΣD² exactly in u128, and only the final division rounds (≤ 3 roundings).
fn exact_oavar(ints: &[i64], m: usize) -> f64 {
    let n = ints.len();
    let terms = n - 2 * m + 1;
    let mut a0: i128 = ints[..m].iter().map(|&v| i128::from(v)).sum();
    let mut a1: i128 = ints[m..2 * m].iter().map(|&v| i128::from(v)).sum();
    let mut sum: u128 = 0;
    for j in 0..terms {
        let d = a1 - a0;
        sum += (d * d) as u128;
        if j + 1 < terms {
            a0 += i128::from(ints[j + m] - ints[j]);
            a1 += i128::from(ints[j + 2 * m] - ints[j + m]);
        }
    }
    let unit2 = 2f64.powi(2 * SCALE_BITS as i32);
    sum as f64 / (2.0 * (m * m) as f64 * terms as f64) / unit2
}

#[test]
fn oadev_of_1e7_samples_with_offset_and_drift_is_exact_to_1e_9() {
    let n = 10_000_000;
    let (ints, y) = offset_drift_data(n, 7);
    let d = compute(
        &y,
        200.0,
        &TauGrid::Octave,
        Statistic::Oadev,
        Confidence::OneSigma,
    )
    .unwrap();
    assert_eq!(d.m.len(), 23); // 1 … 2^22
    let exact: Vec<f64> =
        d.m.par_iter()
            .map(|&m| exact_oavar(&ints, m as usize))
            .collect();
    let mut worst = 0.0f64;
    for ((m, got), want) in d.m.iter().zip(&d.variance).zip(&exact) {
        let r = rel(*got, *want);
        worst = worst.max(r);
        assert!(r < 1e-9, "m = {m}: {got:e} vs exact {want:e} (rel {r:e})");
    }
    eprintln!("1e7 samples, offset 1e6 σ + random walk: worst relative error {worst:.1e}");
}

#[test]
fn fast_paths_match_the_textbook_reference() {
    let mut rng = SplitMix(11);
    let mut walk = 0.0;
    let y: Vec<f64> = (0..5000)
        .map(|_| {
            walk += 0.05 * rng.gauss();
            10.0 + rng.gauss() + walk
        })
        .collect();
    let ms = TauGrid::Explicit(vec![1, 2, 3, 7, 13, 64, 99, 333, 512, 1000, 1249]);
    for stat in Statistic::ALL {
        let d = compute(&y, 1.0, &ms, stat, Confidence::OneSigma).unwrap();
        assert!(d.len() >= 10, "{stat}");
        for (&m, got) in d.m.iter().zip(&d.variance) {
            let want = reference::variance(&y, m, stat);
            assert!(
                rel(*got, want) < 1e-11,
                "{stat} m={m}: {got:e} vs reference {want:e}"
            );
        }
    }
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let mut rng = SplitMix(3);
    let y = rng.gauss_vec(300_000);
    let run = || {
        Statistic::ALL
            .iter()
            .map(|&s| compute(&y, 1.0, &TauGrid::Octave, s, Confidence::OneSigma).unwrap())
            .collect::<Vec<_>>()
    };
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(run);
    let three = rayon::ThreadPoolBuilder::new()
        .num_threads(3)
        .build()
        .unwrap()
        .install(run);
    assert_eq!(one, three); // bit-identical, including EDF and bounds
}
