//! Where a GPU run's fixed cost goes: the time to find the adapter (loading the Vulkan driver),
//! open a device, build each estimator's pipelines on first use, run a small job again with them
//! built, and close the device. A command on a small file pays all of it once, so this is what
//! `--backend gpu` adds to the CPU path's time end to end, whatever the data.
//!
//! `cargo run --release --example gpu_startup [ROUNDS=2]`: each round is a fresh context in the
//! same process (the driver stays loaded after the first), so round 1 is what a command pays and
//! later rounds show which part is the driver's one-time load. Run it twice in a row to see the
//! effect of the driver's own on-disk shader cache.

use std::sync::Arc;
use std::time::Instant;

use imunoise::avar::{Confidence, Statistic, TauGrid};
use imunoise::estimate::Backend;
use imunoise::gpu::{request_adapter, ContextOptions, GpuBackend, GpuContext};
use imunoise::psd::WelchConfig;

fn ms(t: Instant) -> String {
    format!("{:8.1} ms", t.elapsed().as_secs_f64() * 1e3)
}

fn welch(backend: &dyn Backend, x: &[f64], nperseg: usize) {
    let plan = WelchConfig::new(nperseg).validate().expect("plan");
    let mut sink = backend.welch(&plan, 100.0, 1);
    sink.push(&[x]);
    sink.finish().expect("welch");
}

fn oadev(backend: &dyn Backend, x: &[f64]) {
    for d in backend.deviations(
        &[x.to_vec()],
        100.0,
        &TauGrid::Octave,
        Statistic::Oadev,
        Confidence::OneSigma,
    ) {
        d.expect("oadev");
    }
}

fn main() {
    let start = Instant::now();
    let rounds: usize = std::env::args()
        .nth(1)
        .map_or(2, |a| a.parse().expect("ROUNDS"));
    let x: Vec<f64> = (0..1 << 18).map(|i| ((i * 7919) % 1013) as f64).collect();
    println!("process start to main: data ready {}", ms(start));
    for round in 1..=rounds {
        println!("round {round}");
        let t = Instant::now();
        let options = ContextOptions::default();
        let adapter = request_adapter(&options).expect("adapter");
        println!("  instance and adapter      {}", ms(t));
        let t = Instant::now();
        let context = GpuContext::on_adapter(&adapter, &options).expect("device");
        println!("  device                    {}", ms(t));
        let backend = GpuBackend::with_context(Arc::new(context));
        for (label, nperseg) in [
            ("Welch 4096 (one-step FFT)", 4096),
            ("Welch 65536 (four-step)", 65536),
        ] {
            let t = Instant::now();
            welch(&backend, &x, nperseg);
            println!("  {label:<25} {} first, ", ms(t));
            let t = Instant::now();
            welch(&backend, &x, nperseg);
            println!("  {:<25} {} again", "", ms(t));
        }
        let t = Instant::now();
        oadev(&backend, &x);
        println!("  {:<25} {} first", "OADEV octave", ms(t));
        let t = Instant::now();
        oadev(&backend, &x);
        println!("  {:<25} {} again", "", ms(t));
        let t = Instant::now();
        drop(backend);
        drop(adapter);
        println!("  close                     {}", ms(t));
    }
    println!("total {}", ms(start));
}
