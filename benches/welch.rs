//! Welch PSD on the CPU: one-shot and streaming, for short and long segments and 1 or 3 channels.
//!
//! `cargo bench --bench welch`. The headline case is 1e7 samples, Hann, nperseg 65536, 50 %
//! overlap; compare with `scipy.signal.welch` on the same input size (see tests/data/psd/
//! PROVENANCE.md for the timing command).

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use imunoise::psd::{welch_with_plan, WelchAccumulator, WelchConfig};

/// Deterministic broadband test signal (a linear congruential generator; the content does not
/// change the cost).
fn signal(n: usize, seed: u64) -> Vec<f64> {
    let mut s = seed;
    (0..n)
        .map(|_| {
            s = s
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        })
        .collect()
}

fn channels(n: usize, count: usize) -> Vec<Vec<f64>> {
    (0..count).map(|c| signal(n, c as u64 + 1)).collect()
}

fn one_shot(c: &mut Criterion) {
    let n = 1_000_000;
    let data = channels(n, 3);
    let mut group = c.benchmark_group("welch_1e6");
    for nperseg in [1024, 65536] {
        let plan = WelchConfig::new(nperseg).validate().unwrap();
        for count in [1, 3] {
            let refs: Vec<&[f64]> = data[..count].iter().map(Vec::as_slice).collect();
            group.throughput(Throughput::Elements((n * count) as u64));
            group.bench_with_input(
                BenchmarkId::new(format!("nperseg{nperseg}"), format!("{count}ch")),
                &refs,
                |b, refs| b.iter(|| welch_with_plan(black_box(refs), 100.0, &plan).unwrap()),
            );
        }
    }
    group.finish();
}

fn streaming(c: &mut Criterion) {
    // Record batches of 65 536 rows, as a file reader delivers them.
    let n = 1_000_000;
    let data = channels(n, 3);
    let mut group = c.benchmark_group("welch_stream_1e6");
    for nperseg in [1024, 65536] {
        let plan = WelchConfig::new(nperseg).validate().unwrap();
        group.throughput(Throughput::Elements((n * 3) as u64));
        group.bench_function(BenchmarkId::new(format!("nperseg{nperseg}"), "3ch"), |b| {
            b.iter(|| {
                let mut acc = WelchAccumulator::new(plan.clone(), 100.0, 3);
                for start in (0..n).step_by(65_536) {
                    let end = (start + 65_536).min(n);
                    acc.push(&[
                        &data[0][start..end],
                        &data[1][start..end],
                        &data[2][start..end],
                    ]);
                }
                acc.finish().unwrap()
            })
        });
    }
    group.finish();
}

fn headline(c: &mut Criterion) {
    // 1e7 samples (about the reference paper's 10.1 M per axis), Hann, nperseg 65536, 50 %.
    let n = 10_000_000;
    let data = channels(n, 3);
    let plan = WelchConfig::new(65536).validate().unwrap();
    let mut group = c.benchmark_group("welch_1e7");
    group.sample_size(10);
    for count in [1, 3] {
        let refs: Vec<&[f64]> = data[..count].iter().map(Vec::as_slice).collect();
        group.throughput(Throughput::Elements((n * count) as u64));
        group.bench_with_input(
            BenchmarkId::new("nperseg65536", format!("{count}ch")),
            &refs,
            |b, refs| b.iter(|| welch_with_plan(black_box(refs), 100.0, &plan).unwrap()),
        );
    }
    group.finish();
}

criterion_group!(benches, one_shot, streaming, headline);
criterion_main!(benches);
