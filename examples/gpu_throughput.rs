//! GPU against CPU on one large in-memory recording: wall time of each backend, the device time of
//! the kernels (GPU timestamps), the effective memory bandwidth that time implies, and the largest
//! difference between the two backends' results.
//!
//! ```text
//! cargo run --release --example gpu_throughput -- [SAMPLES_PER_CHANNEL=2e7] [CHANNELS=6] [PEAK_GB_S]
//! ```
//! PEAK_GB_S is the device's memory bandwidth from its datasheet (e.g. 4800 for an H200, 3350 for
//! an H100 SXM); with it each kernel line also says which fraction of it the kernels reach.
//!
//! What is timed:
//! - `wall`: one backend call as the pipeline makes it (Welch: one push of every channel and the
//!   finish; Allan: `deviations` of every channel), fastest of three after a warm-up. For the GPU
//!   this includes converting to f32, the uploads, the read-backs and the CPU work the GPU path
//!   keeps (prefix sums, EDF and intervals for the Allan variance; scaling and folding for Welch).
//! - `kernels`: the device time of the compute passes alone, from a second context opened with
//!   kernel timing (which waits for each pass, so its wall time is not used).
//! - `GB/s`: the bytes the estimator cannot avoid moving, over the kernel time. Welch: every
//!   sample read as f32 once per segment that holds it (twice at 50 % overlap); the FFT's own passes
//!   over its work buffers are not counted, so the true traffic is higher. Octave Allan: each
//!   level reads and writes the series once in f32 (8 bytes per sample and level). Allan at other
//!   taus: each tau reads the prefix sums once (8 bytes per sample with f64, 12 with the
//!   fixed-point scheme), the other two taps coming from cache.
//!
//! Without a GPU adapter only the CPU lines are printed.

use std::sync::Arc;
use std::time::{Duration, Instant};

use imunoise::avar::{Confidence, Deviations, Statistic, TauGrid};
use imunoise::estimate::{Backend, CpuBackend};
use imunoise::gpu::{ContextOptions, GpuBackend, GpuContext, KernelTimes};
use imunoise::psd::{Psd, WelchConfig};
use imunoise::sim::rng::Rng;

/// Gyro-like samples: white noise on a bias, plus a slow random walk (the content does not change
/// the cost; the bias and walk make precision matter).
fn signal(n: usize, seed: u64) -> Vec<f64> {
    let mut rng = Rng::new(seed);
    let mut walk = 0.0;
    (0..n)
        .map(|_| {
            let u = rng.gauss();
            walk += 1e-3 * u;
            1e3 + u + walk
        })
        .collect()
}

/// One estimator job, run the same way on either backend.
enum Job {
    Welch { nperseg: usize },
    Allan { grid: TauGrid, label: &'static str },
}

/// What a job returns, for comparing the backends.
enum Output {
    Psds(Vec<Psd>),
    Devs(Vec<Deviations>),
}

impl Job {
    fn label(&self) -> String {
        match self {
            Job::Welch { nperseg } => format!("Welch hann nperseg {nperseg}"),
            Job::Allan { label, .. } => format!("OADEV {label}"),
        }
    }

    fn run(&self, backend: &dyn Backend, channels: &[Vec<f64>], rate: f64) -> Output {
        match self {
            Job::Welch { nperseg } => {
                let plan = WelchConfig::new(*nperseg).validate().expect("plan");
                let mut sink = backend.welch(&plan, rate, channels.len());
                let refs: Vec<&[f64]> = channels.iter().map(Vec::as_slice).collect();
                sink.push(&refs);
                Output::Psds(sink.finish().expect("welch"))
            }
            Job::Allan { grid, .. } => Output::Devs(
                backend
                    .deviations(channels, rate, grid, Statistic::Oadev, Confidence::OneSigma)
                    .into_iter()
                    .map(|d| d.expect("oadev"))
                    .collect(),
            ),
        }
    }

    /// Bytes the kernels cannot avoid moving (see the module doc).
    fn essential_bytes(&self, n: usize, channels: usize, f64_prefix: bool) -> f64 {
        let per_channel = match self {
            Job::Welch { .. } => 2.0 * 4.0 * n as f64,
            Job::Allan { grid, .. } => {
                let taus = grid.factors(n, Statistic::Oadev).len() as f64;
                match grid {
                    TauGrid::Octave => 8.0 * n as f64 * taus,
                    _ => (if f64_prefix { 8.0 } else { 12.0 }) * n as f64 * taus,
                }
            }
        };
        per_channel * channels as f64
    }
}

/// Largest relative difference: PSD bins above 1e-6 of each spectrum's maximum; every variance.
fn max_rel_diff(a: &Output, b: &Output) -> f64 {
    let rel = |x: f64, y: f64| (x - y).abs() / y.abs().max(f64::MIN_POSITIVE);
    match (a, b) {
        (Output::Psds(a), Output::Psds(b)) => a
            .iter()
            .zip(b)
            .flat_map(|(p, q)| {
                let floor = 1e-6 * q.value.iter().cloned().fold(0.0, f64::max);
                p.value
                    .iter()
                    .zip(&q.value)
                    .filter(move |(_, y)| **y > floor)
                    .map(|(x, y)| rel(*x, *y))
            })
            .fold(0.0, f64::max),
        (Output::Devs(a), Output::Devs(b)) => a
            .iter()
            .zip(b)
            .flat_map(|(p, q)| p.variance.iter().zip(&q.variance).map(|(x, y)| rel(*x, *y)))
            .fold(0.0, f64::max),
        _ => f64::NAN,
    }
}

/// Fastest of three calls after one warm-up, and the last output.
fn timed(backend: &dyn Backend, job: &Job, channels: &[Vec<f64>]) -> (Duration, Output) {
    let mut out = job.run(backend, channels, 200.0);
    let mut best = Duration::MAX;
    for _ in 0..3 {
        let t = Instant::now();
        out = job.run(backend, channels, 200.0);
        best = best.min(t.elapsed());
    }
    (best, out)
}

/// Kernel time of one call on the timing context: fastest of three.
fn kernel_time(ctx: &Arc<GpuContext>, job: &Job, channels: &[Vec<f64>]) -> Option<Duration> {
    let backend = GpuBackend::with_context(Arc::clone(ctx));
    job.run(&backend, channels, 200.0);
    let mut best: Option<Duration> = None;
    for _ in 0..3 {
        ctx.reset_kernel_times();
        job.run(&backend, channels, 200.0);
        let KernelTimes { welch, allan, .. } = ctx.kernel_times()?;
        let t = welch + allan;
        best = Some(best.map_or(t, |b| b.min(t)));
    }
    best
}

fn arg(i: usize) -> Option<f64> {
    std::env::args()
        .nth(i)
        .map(|a| a.parse().expect("a number"))
}

fn main() {
    let n = arg(1).unwrap_or(2e7) as usize;
    let channel_count = arg(2).unwrap_or(6.0) as usize;
    let peak_gb_s = arg(3);
    let t = Instant::now();
    let channels: Vec<Vec<f64>> = (0..channel_count)
        .map(|c| signal(n, c as u64 + 1))
        .collect();
    println!(
        "{channel_count} channels × {n} samples (f64, {:.0} MiB), generated in {:.1} s; {} CPU threads",
        (channel_count * n * 8) as f64 / 1048576.0,
        t.elapsed().as_secs_f64(),
        std::thread::available_parallelism().map_or(1, |p| p.get())
    );
    let gpu = GpuContext::new().map(|c| GpuBackend::with_context(Arc::new(c)));
    let timing = GpuContext::with_options(&ContextOptions {
        kernel_timing: true,
        ..ContextOptions::default()
    })
    .map(Arc::new);
    match &gpu {
        Ok(g) => println!("GPU: {}", g.describe()),
        Err(e) => println!("no GPU ({e}): CPU lines only"),
    }
    let f64_prefix = gpu.as_ref().is_ok_and(|g| g.context().has_f64());
    let m_max = ((n - 1) / 2) as f64;
    let log_taus: Vec<u64> = (0..100)
        .map(|i| 10f64.powf(i as f64 * m_max.log10() / 99.0).round() as u64)
        .collect();
    let jobs = [
        Job::Welch { nperseg: 4096 },
        Job::Welch { nperseg: 65536 },
        Job::Allan {
            grid: TauGrid::Octave,
            label: "octave taus",
        },
        Job::Allan {
            grid: TauGrid::Explicit(log_taus),
            label: "100 log-spaced taus",
        },
    ];
    println!(
        "{:30} {:>9} {:>9} {:>7} {:>11} {:>9} {:>7} {:>10}",
        "job", "cpu s", "gpu s", "ratio", "kernels s", "GB/s", "of peak", "max rel"
    );
    for job in &jobs {
        let (cpu_wall, cpu_out) = timed(&CpuBackend, job, &channels);
        let Ok(gpu) = &gpu else {
            println!("{:30} {:9.3}", job.label(), cpu_wall.as_secs_f64());
            continue;
        };
        let (gpu_wall, gpu_out) = timed(gpu, job, &channels);
        let notes = gpu.take_notes();
        let kernels = timing
            .as_ref()
            .ok()
            .and_then(|ctx| kernel_time(ctx, job, &channels));
        let bytes = job.essential_bytes(n, channel_count, f64_prefix);
        let (k, gbs, frac) = match kernels {
            Some(k) => {
                let gbs = bytes / k.as_secs_f64() / 1e9;
                let frac =
                    peak_gb_s.map_or("-".to_string(), |p| format!("{:.0} %", 100.0 * gbs / p));
                (format!("{:.4}", k.as_secs_f64()), format!("{gbs:.1}"), frac)
            }
            None => ("-".into(), "-".into(), "-".into()),
        };
        println!(
            "{:30} {:9.3} {:9.3} {:6.2}x {:>11} {:>9} {:>7} {:10.2e}",
            job.label(),
            cpu_wall.as_secs_f64(),
            gpu_wall.as_secs_f64(),
            cpu_wall.as_secs_f64() / gpu_wall.as_secs_f64(),
            k,
            gbs,
            frac,
            max_rel_diff(&gpu_out, &cpu_out)
        );
        for note in notes {
            println!("    note: {note}");
        }
    }
}
