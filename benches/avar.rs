//! Allan-family estimators on the CPU, full `compute` (prefix sums, estimator, noise
//! identification, EDF and bounds): OADEV at octave taus and at 100 log-spaced taus, and ADEV,
//! MDEV, HDEV, OHDEV at octave taus, for 1e5 and 1e6 samples.
//!
//! `cargo bench --bench avar`. The headline comparison (1e7 samples against
//! `allantools.oadev(data_type="freq")`) is the `avar_1e7` group, run only when
//! `IMUNOISE_BENCH_1E7=1` is set because it needs ~1 GB of memory traffic per iteration; the
//! allantools side is timed with the same sizes and taus in Python (see the numbers in the module
//! docs of `imunoise::avar`).

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use imunoise::avar::{compute, Confidence, Statistic, TauGrid};

/// White noise plus a random walk (a linear congruential generator: the content barely changes
/// the cost, but a realistic mix exercises both noise-identification paths).
fn signal(n: usize, seed: u64) -> Vec<f64> {
    let mut s = seed;
    let mut walk = 0.0;
    (0..n)
        .map(|_| {
            s = s
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            let u = (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            walk += 1e-3 * u;
            u + walk
        })
        .collect()
}

/// `count` distinct averaging factors, log-spaced from 1 to the largest valid OADEV factor.
fn log_factors(n: usize, count: usize) -> Vec<u64> {
    let max = Statistic::Oadev.max_factor(n) as f64;
    let mut points = count;
    loop {
        let mut ms: Vec<u64> = (0..points)
            .map(|i| max.powf(i as f64 / (points - 1) as f64).round() as u64)
            .collect();
        ms.dedup();
        if ms.len() >= count {
            ms.truncate(count - 1);
            ms.push(max as u64);
            return ms;
        }
        points += 1;
    }
}

fn run(c: &mut Criterion, group_name: &str, sizes: &[usize], samples: usize) {
    let mut group = c.benchmark_group(group_name);
    group.sample_size(samples);
    for &n in sizes {
        let y = signal(n, 1);
        group.throughput(Throughput::Elements(n as u64));
        let cases = [
            ("oadev_octave", Statistic::Oadev, TauGrid::Octave),
            (
                "oadev_log100",
                Statistic::Oadev,
                TauGrid::Explicit(log_factors(n, 100)),
            ),
            ("adev_octave", Statistic::Adev, TauGrid::Octave),
            ("mdev_octave", Statistic::Mdev, TauGrid::Octave),
            ("hdev_octave", Statistic::Hdev, TauGrid::Octave),
            ("ohdev_octave", Statistic::Ohdev, TauGrid::Octave),
        ];
        for (name, stat, grid) in cases {
            if n > 1_000_000 && !name.starts_with("oadev") {
                continue;
            }
            group.bench_with_input(BenchmarkId::new(name, n), &y, |b, y| {
                b.iter(|| compute(black_box(y), 100.0, &grid, stat, Confidence::OneSigma).unwrap())
            });
        }
    }
    group.finish();
}

fn sizes(c: &mut Criterion) {
    run(c, "avar", &[100_000, 1_000_000], 20);
}

fn headline(c: &mut Criterion) {
    if std::env::var_os("IMUNOISE_BENCH_1E7").is_some() {
        run(c, "avar_1e7", &[10_000_000], 10);
    }
}

criterion_group!(benches, sizes, headline);
criterion_main!(benches);
