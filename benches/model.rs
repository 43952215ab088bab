//! Noise-model fits and the simulator: `fit_avar` on an octave OADEV curve (31 subsets, each
//! iterated to convergence with the working correlation), `fit_psd` on a log-binned Welch
//! spectrum, `simulate` of one channel with every IEEE term (flicker dominates: one real FFT of
//! ≥ 4n points), and the model stage against the estimation it follows (`loop_vs_estimation`: the
//! OADEV, Welch spectrum and log bins of one channel, then the whole residual loop on them, as
//! `analyze` runs it per channel), and both on the reference paper's workload as `analyze` runs
//! it, reading included (`analyze_paper_workload`).
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
        // Each repetition starts cold, as a new process would: the model stage's memos forgotten
        // (the same channel's covariances would otherwise all be remembered from the first) and
        // the pooled record-length buffers released.
        let cold = || {
            imunoise::memo::forget_all();
            imunoise::memory::release_cached_memory();
        };
        group.bench_with_input(BenchmarkId::new("estimate", n), &y, |b, y| {
            b.iter(|| {
                cold();
                estimate(black_box(y))
            })
        });
        let initial = estimate(&y);
        group.bench_with_input(BenchmarkId::new("fit_and_loop", n), &y, |b, y| {
            b.iter(|| {
                cold();
                close_loop(black_box(y), FS, &[], &cfg, Some(initial.clone())).unwrap()
            })
        });
    }
    group.finish();
}

/// The reference paper's workload (3 gyro axes, 812 min at 207 Hz: N and B of its Table 4 and 5,
/// as `examples/paper_workload.rs`), written once as an f32 Arrow file and analysed as `analyze`
/// does with its default options: `estimation` reads the file with the streamed Welch spectrum
/// and computes the Allan deviations; `estimation_fit_loop` does the same, then the fits and the
/// residual loop of every channel. The model stage's time is the difference of the two: what
/// "fit and loop no longer than the estimation" compares, reading included, which the in-memory
/// `loop_vs_estimation` leaves out.
fn analyze_paper_workload(c: &mut Criterion) {
    use imunoise::avar::Confidence;
    use imunoise::estimate::CpuBackend;
    use imunoise::io::StoredAs;
    use imunoise::model::CoefUnit;
    use imunoise::pipeline::{run, AvarWork, Inputs, Silent, TauSpec, WelchWork, Work};

    const RATE_HZ: f64 = 207.0;
    let (arw, bi) = ([0.024, 0.029, 0.030], [0.0013, 0.0015, 0.0015]);
    let spec = SimSpec {
        rate_hz: RATE_HZ,
        duration_s: 812.0 * 60.0,
        seed: 2014,
        channels: (0..3)
            .map(|i| {
                ChannelSpec::new(
                    format!("gyro_{i}"),
                    Sensor::Gyro,
                    Coefficients {
                        n: CoefUnit::DegPerSPerSqrtHz.to_si(arw[i]),
                        b: CoefUnit::DegPerS.to_si(bi[i]),
                        ..Default::default()
                    },
                )
            })
            .collect(),
        temperature: None,
    };
    let dir = std::env::temp_dir().join(format!("imunoise-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("paper.arrow");
    simulate(&spec)
        .unwrap()
        .write(&path, StoredAs::F32)
        .unwrap();
    // `analyze`'s defaults (its report.json `options`).
    let estimation = Work {
        welch: Some(WelchWork {
            plan: WelchConfig::new(4096).validate().unwrap(),
            bins_per_decade: Some(20),
        }),
        avar: Some(AvarWork {
            statistics: vec![Statistic::Oadev],
            taus: TauSpec::Grid(TauGrid::Octave),
            confidence: Confidence::OneSigma,
        }),
        fit: None,
        residual_loop: false,
    };
    let whole = Work {
        fit: Some(FitOptions::default()),
        residual_loop: true,
        ..estimation.clone()
    };
    let inputs = Inputs::default();
    let mut group = c.benchmark_group("analyze_paper_workload");
    group.sample_size(10);
    for (name, work) in [("estimation", &estimation), ("estimation_fit_loop", &whole)] {
        // Each repetition as a fresh process starts: nothing remembered from the one before
        // (the model stage's memos, the pooled record-length buffers).
        group.bench_function(name, |b| {
            b.iter(|| {
                imunoise::memo::forget_all();
                imunoise::memory::release_cached_memory();
                run(&path, &inputs, work, &CpuBackend, &Silent).unwrap()
            })
        });
    }
    group.finish();
    let _ = std::fs::remove_dir_all(&dir);
}

criterion_group!(
    benches,
    fits,
    simulator,
    loop_vs_estimation,
    analyze_paper_workload
);
criterion_main!(benches);
