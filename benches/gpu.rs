//! CPU against GPU: Welch PSD (1e6 samples × 3 channels, nperseg 4096 and 65536) and the
//! overlapping Allan deviation at octave taus (1e6 samples), each through its backend, so the
//! numbers include everything a run pays (upload, read-back, EDF and confidence on the CPU).
//!
//! `cargo bench --bench gpu`. Without a GPU adapter the GPU cases are skipped with a message and
//! only the CPU cases run. On a software rasteriser (lavapipe) the GPU numbers show that the path
//! works, not how fast it is.

use std::hint::black_box;
use std::sync::Arc;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use imunoise::avar::{Confidence, Statistic, TauGrid};
use imunoise::estimate::{Backend, CpuBackend};
use imunoise::gpu::{GpuBackend, GpuContext};
use imunoise::psd::WelchConfig;

const SAMPLES: usize = 1_000_000;

/// Deterministic broadband test signal on a large bias (the content does not change the cost).
fn signal(n: usize, seed: u64) -> Vec<f64> {
    let mut s = seed;
    (0..n)
        .map(|_| {
            s = s
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            1e3 + (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        })
        .collect()
}

/// The backends to compare: the CPU always, the GPU when an adapter exists.
fn backends() -> Vec<(&'static str, Box<dyn Backend>)> {
    let mut out: Vec<(&'static str, Box<dyn Backend>)> = vec![("cpu", Box::new(CpuBackend))];
    match GpuContext::new() {
        Ok(ctx) => {
            let gpu = GpuBackend::with_context(Arc::new(ctx));
            eprintln!("{}", gpu.describe());
            out.push(("gpu", Box::new(gpu)));
        }
        Err(e) => eprintln!("skipping the GPU cases: {e}"),
    }
    out
}

fn welch(c: &mut Criterion) {
    let data: Vec<Vec<f64>> = (0..3).map(|ch| signal(SAMPLES, ch + 1)).collect();
    let refs: Vec<&[f64]> = data.iter().map(Vec::as_slice).collect();
    let mut group = c.benchmark_group("gpu_welch_1e6x3");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(5))
        .throughput(Throughput::Elements((SAMPLES * 3) as u64));
    for (name, backend) in backends() {
        for nperseg in [4096, 65536] {
            let plan = WelchConfig::new(nperseg).validate().unwrap();
            group.bench_function(BenchmarkId::new(name, format!("nperseg{nperseg}")), |b| {
                b.iter(|| {
                    let mut sink = backend.welch(&plan, 100.0, 3);
                    sink.push(black_box(&refs));
                    sink.finish().unwrap()
                })
            });
            assert!(backend.take_notes().is_empty(), "{name} fell back");
        }
    }
    group.finish();
}

fn avar_octave(c: &mut Criterion) {
    let data = vec![signal(SAMPLES, 7)];
    let mut group = c.benchmark_group("gpu_oadev_octave_1e6");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(5))
        .throughput(Throughput::Elements(SAMPLES as u64));
    for (name, backend) in backends() {
        group.bench_function(name, |b| {
            b.iter(|| {
                backend.deviations(
                    black_box(&data),
                    100.0,
                    &TauGrid::Octave,
                    Statistic::Oadev,
                    Confidence::OneSigma,
                )
            })
        });
        assert!(backend.take_notes().is_empty(), "{name} fell back");
    }
    group.finish();
}

criterion_group!(benches, welch, avar_octave);
criterion_main!(benches);
