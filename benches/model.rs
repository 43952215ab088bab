//! Noise-model fits and the simulator: `fit_avar` on an octave OADEV curve (31 subsets, each
//! iterated to convergence with the working correlation), `fit_psd` on a log-binned Welch
//! spectrum, `simulate` of one channel with every IEEE term (flicker dominates: one real FFT of
//! ≥ 4n points), and the model stage against the estimation it follows (`loop_vs_estimation`: the
//! OADEV, Welch spectrum and log bins of one channel, then the whole residual loop on them, as
//! `analyze` runs it per channel).
//!
//! `cargo bench --bench model`.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use imunoise::avar::{compute, Confidence, Statistic, TauGrid};
use imunoise::effects::{close_loop, LoopConfig};
use imunoise::model::{fit_avar, fit_psd, Coefficients, FitOptions, Sensor};
use imunoise::psd::{log_bin, welch, WelchConfig};
use imunoise::sim::{simulate, ChannelSpec, SimSpec};

const FS: f64 = 100.0;

fn spec(n: usize) -> SimSpec {
    SimSpec {
        rate_hz: FS,
        duration_s: n as f64 / FS,
        seed: 1,
        channels: vec![ChannelSpec::new(
            "g",
            Sensor::Gyro,
            Coefficients {
                q: 2e-5,
                n: 1e-3,
                b: 1e-4,
                k: 1e-5,
                r: 1e-8,
            },
        )],
        temperature: None,
    }
}

fn fits(c: &mut Criterion) {
    let mut group = c.benchmark_group("model_fit");
    for n in [1usize << 16, 1 << 20] {
        let y = simulate(&spec(n)).unwrap().channels.remove(0).samples;
        let d = compute(
            &y,
            FS,
            &TauGrid::Octave,
            Statistic::Oadev,
            Confidence::OneSigma,
        )
        .unwrap();
        let psd = welch(&y, FS, &WelchConfig::new(4096)).unwrap();
        let binned = log_bin(&psd, 10);
        let opts = FitOptions::default();
        group.bench_with_input(BenchmarkId::new("fit_avar", n), &d, |b, d| {
            b.iter(|| fit_avar(black_box(d), &opts).unwrap())
        });
        group.bench_with_input(BenchmarkId::new("fit_psd", n), &binned, |b, binned| {
            b.iter(|| fit_psd(&psd, black_box(binned), &opts).unwrap())
        });
    }
    group.finish();
}

fn simulator(c: &mut Criterion) {
    let mut group = c.benchmark_group("simulate");
    group.sample_size(10);
    for n in [1usize << 16, 1 << 20] {
        let s = spec(n);
        group.throughput(Throughput::Elements(n as u64));
        group.bench_with_input(BenchmarkId::new("all_terms", n), &s, |b, s| {
            b.iter(|| simulate(black_box(s)).unwrap())
        });
    }
    group.finish();
}

fn loop_vs_estimation(c: &mut Criterion) {
    let mut group = c.benchmark_group("loop_vs_estimation");
    group.sample_size(10);
    let cfg = LoopConfig::with_segment(4096);
    let estimate = |y: &[f64]| {
        let d = compute(y, FS, &cfg.taus, Statistic::Oadev, cfg.confidence).unwrap();
        let psd = welch(y, FS, &cfg.welch).unwrap();
        let binned = log_bin(&psd, cfg.bins_per_decade);
        (d, psd, binned)
    };
    for n in [1usize << 20, 1 << 22] {
        let y = simulate(&spec(n)).unwrap().channels.remove(0).samples;
        group.throughput(Throughput::Elements(n as u64));
        group.bench_with_input(BenchmarkId::new("estimate", n), &y, |b, y| {
            b.iter(|| estimate(black_box(y)))
        });
        let initial = estimate(&y);
        group.bench_with_input(BenchmarkId::new("fit_and_loop", n), &y, |b, y| {
            b.iter(|| close_loop(black_box(y), FS, &[], &cfg, Some(initial.clone())).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, fits, simulator, loop_vs_estimation);
criterion_main!(benches);
