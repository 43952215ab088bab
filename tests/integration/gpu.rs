//! GPU backend: the shaders validate (on any machine), every kernel agrees with its CPU mirror, the
//! mirrors agree with textbook references, and GPU Welch PSDs and Allan variances agree with the CPU
//! path — on plain and chunked devices, for streams and batches of recordings, and through device
//! failures.
//!
//! Tolerances (relative): PSD 1e-4 on every bin above 1e-6 of the spectrum's maximum; Allan
//! variance 1e-5 at every τ; kernel vs mirror 1e-5 of the largest output value (f32, same order of
//! operations; only fused multiply-adds and reduction order differ); mirror FFT vs f64 DFT 1e-5 of
//! the largest coefficient.
//!
//! Without an adapter the GPU tests print why and pass, unless `IMUNOISE_REQUIRE_GPU=1` (set by CI),
//! which makes a missing adapter a failure. Inputs are small: lavapipe, the software Vulkan driver
//! CI uses, is single-threaded.

use std::sync::{Arc, OnceLock};

use imunoise::avar::{compute, AvarError, Confidence, Deviations, Statistic, TauGrid};
use imunoise::estimate::{Backend, CpuBackend};
use imunoise::gpu::{ContextOptions, GpuContext, GpuError};
use imunoise::psd::{Psd, WelchConfig, WelchPlan};

/// PSD tolerance: relative error on bins above `PSD_FLOOR` of the maximum.
const PSD_TOL: f64 = 1e-4;
const PSD_FLOOR: f64 = 1e-6;
/// Allan-variance tolerance: relative error at every τ.
const AV_TOL: f64 = 1e-5;
/// Kernel vs mirror: absolute error over the largest |value|.
const MIRROR_TOL: f32 = 1e-5;

// ---------------------------------------------------------------------------------------------
// Devices and data

fn require_gpu() -> bool {
    std::env::var("IMUNOISE_REQUIRE_GPU").is_ok_and(|v| v == "1")
}

/// What to do about a device that could not be opened: skip (print why) or, in CI, fail.
fn skip_or_fail(e: &GpuError) {
    assert!(
        !require_gpu(),
        "IMUNOISE_REQUIRE_GPU=1 but no GPU device could be opened: {e}"
    );
    eprintln!("skipping GPU test: {e}");
}

/// The device shared by most GPU tests (adapter limits, f64 when available).
fn shared() -> Option<Arc<GpuContext>> {
    static CTX: OnceLock<Result<Arc<GpuContext>, GpuError>> = OnceLock::new();
    match CTX.get_or_init(|| GpuContext::new().map(Arc::new)) {
        Ok(ctx) => Some(Arc::clone(ctx)),
        Err(e) => {
            skip_or_fail(e);
            None
        }
    }
}

/// A device of its own, opened with `options` (limits start from the adapter's).
fn fresh(shrink: impl FnOnce(&mut wgpu::Limits), allow_f64: bool) -> Option<Arc<GpuContext>> {
    let result = (|| {
        let base = ContextOptions::default();
        let adapter = imunoise::gpu::request_adapter(&base)?;
        let mut limits = adapter.limits();
        shrink(&mut limits);
        let options = ContextOptions {
            limits: Some(limits),
            allow_f64,
            ..base
        };
        GpuContext::on_adapter(&adapter, &options)
    })();
    match result {
        Ok(ctx) => Some(Arc::new(ctx)),
        Err(e) => {
            skip_or_fail(&e);
            None
        }
    }
}

macro_rules! gpu {
    () => {
        match shared() {
            Some(ctx) => ctx,
            None => return,
        }
    };
    ($shrink:expr, $f64:expr) => {
        match fresh($shrink, $f64) {
            Some(ctx) => ctx,
            None => return,
        }
    };
}

use crate::support::noise;

/// A gyro-like record: white noise (σ = 1) on a bias of 1e4 σ, plus a random-walk drift (steps of
/// 0.02 σ, a few σ over the record).
fn imu(n: usize, seed: u64) -> Vec<f64> {
    let steps = noise(n, seed ^ 0xABCD);
    let mut walk = 0.0;
    noise(n, seed)
        .into_iter()
        .zip(steps)
        .map(|(w, s)| {
            walk += 0.02 * s;
            1e4 + w + walk
        })
        .collect()
}

/// Random values in [−1, 1) as f32 (for kernel inputs).
fn uniform_f32(n: usize, seed: u64) -> Vec<f32> {
    noise(n, seed)
        .iter()
        .map(|v| (v / 4.0).clamp(-1.0, 1.0) as f32)
        .collect()
}

fn complex_f32(n: usize, seed: u64) -> Vec<[f32; 2]> {
    uniform_f32(2 * n, seed)
        .chunks_exact(2)
        .map(|c| [c[0], c[1]])
        .collect()
}

// ---------------------------------------------------------------------------------------------
// Comparisons

/// Worst relative error of `gpu` against `cpu` over bins above PSD_FLOOR of the maximum, after
/// checking that everything but the values is identical.
fn psd_error(gpu: &Psd, cpu: &Psd) -> f64 {
    assert_eq!(gpu.freq_hz, cpu.freq_hz);
    assert_eq!(gpu.dof, cpu.dof);
    assert_eq!(
        (
            gpu.segments,
            gpu.nperseg,
            gpu.noverlap,
            gpu.nfft,
            gpu.scaling
        ),
        (
            cpu.segments,
            cpu.nperseg,
            cpu.noverlap,
            cpu.nfft,
            cpu.scaling
        )
    );
    let max = cpu.value.iter().cloned().fold(0.0, f64::max);
    gpu.value
        .iter()
        .zip(&cpu.value)
        .filter(|(_, &c)| c > PSD_FLOOR * max)
        .map(|(g, c)| ((g - c) / c).abs())
        // A NaN is the worst error there is, not one to skip.
        .fold(0.0, |worst, e| {
            if e.is_nan() {
                f64::INFINITY
            } else {
                worst.max(e)
            }
        })
}

fn assert_psds(gpu: &[Psd], cpu: &[Psd], what: &str) {
    assert_eq!(gpu.len(), cpu.len(), "{what}");
    for (ch, (g, c)) in gpu.iter().zip(cpu).enumerate() {
        let e = psd_error(g, c);
        assert!(e <= PSD_TOL, "{what}, channel {ch}: relative error {e:e}");
    }
}

/// The CPU reference: the one-shot CPU Welch of each channel.
fn cpu_welch(channels: &[Vec<f64>], rate: f64, plan: &WelchPlan) -> Vec<Psd> {
    let refs: Vec<&[f64]> = channels.iter().map(Vec::as_slice).collect();
    imunoise::psd::welch_with_plan(&refs, rate, plan).unwrap()
}

/// GPU Welch through the backend, the whole record in one push.
fn gpu_welch(
    ctx: &Arc<GpuContext>,
    channels: &[Vec<f64>],
    rate: f64,
    plan: &WelchPlan,
) -> Vec<Psd> {
    let backend = imunoise::gpu::GpuBackend::with_context(Arc::clone(ctx));
    let mut sink = backend.welch(plan, rate, channels.len());
    let refs: Vec<&[f64]> = channels.iter().map(Vec::as_slice).collect();
    sink.push(&refs);
    let out = sink.finish().unwrap();
    assert!(backend.fallbacks().is_empty(), "{:?}", backend.fallbacks());
    out
}

/// Everything equal but the variances and their bounds, which agree to AV_TOL.
fn assert_deviations(gpu: &Deviations, cpu: &Deviations, what: &str) {
    assert_eq!(
        (&gpu.m, &gpu.tau_s, &gpu.n_terms, &gpu.alpha, &gpu.edf),
        (&cpu.m, &cpu.tau_s, &cpu.n_terms, &cpu.alpha, &cpu.edf),
        "{what}"
    );
    assert_eq!(
        (gpu.statistic, gpu.rate_hz, gpu.confidence),
        (cpu.statistic, cpu.rate_hz, cpu.confidence)
    );
    for (name, g, c) in [
        ("variance", &gpu.variance, &cpu.variance),
        ("variance_lo", &gpu.variance_lo, &cpu.variance_lo),
        ("variance_hi", &gpu.variance_hi, &cpu.variance_hi),
    ] {
        for (i, (a, b)) in g.iter().zip(c).enumerate() {
            let e = ((a - b) / b).abs();
            assert!(
                e <= AV_TOL,
                "{what}: {name} at m = {}: {a} vs {b} ({e:e})",
                cpu.m[i]
            );
        }
    }
}

/// |a − b| ≤ MIRROR_TOL · max|b| elementwise.
fn assert_mirror(gpu: &[f32], mirror: &[f32], what: &str) {
    assert_eq!(gpu.len(), mirror.len(), "{what}");
    let max = mirror.iter().fold(0.0f32, |m, v| m.max(v.abs()));
    for (i, (g, m)) in gpu.iter().zip(mirror).enumerate() {
        assert!(
            (g - m).abs() <= MIRROR_TOL * max,
            "{what}[{i}]: {g} vs {m} (max {max})"
        );
    }
}

fn flat(v: &[[f32; 2]]) -> Vec<f32> {
    v.iter().flat_map(|c| *c).collect()
}

// ---------------------------------------------------------------------------------------------

/// No device needed: every kernel compiles with naga, every file belongs to a kernel, and the
/// host's parameter structs have the shaders' layout.
mod shaders {
    use imunoise::gpu::avar::{OctaveParams, PrefixParams};
    use imunoise::gpu::shaders::Kernel;
    use imunoise::gpu::welch::{AccumulateParams, WelchParams};

    fn module(kernel: Kernel) -> naga::Module {
        let src = kernel.source();
        naga::front::wgsl::parse_str(&src)
            .unwrap_or_else(|e| panic!("{}: {}", kernel.entry_point(), e.emit_to_string(&src)))
    }

    #[test]
    fn every_kernel_parses_and_validates() {
        for kernel in Kernel::ALL {
            let m = module(kernel);
            let mut caps = naga::valid::Capabilities::default();
            if kernel.needs_f64() {
                caps |= naga::valid::Capabilities::FLOAT64;
            }
            naga::valid::Validator::new(naga::valid::ValidationFlags::all(), caps)
                .validate(&m)
                .unwrap_or_else(|e| {
                    panic!(
                        "{}: {}",
                        kernel.entry_point(),
                        e.emit_to_string(&kernel.source())
                    )
                });
            assert!(
                m.entry_points
                    .iter()
                    .any(|e| e.name == kernel.entry_point()),
                "{} has no entry point of its name",
                kernel.entry_point()
            );
        }
    }

    #[test]
    fn every_shader_file_belongs_to_a_kernel() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
        let mut files = 0;
        for entry in std::fs::read_dir(dir).unwrap() {
            let name = entry.unwrap().file_name().into_string().unwrap();
            if !name.ends_with(".wgsl") {
                continue;
            }
            files += 1;
            assert!(
                Kernel::ALL
                    .iter()
                    .any(|k| k.files().contains(&name.as_str())),
                "shaders/{name} is not part of any kernel, so nothing validates it"
            );
        }
        assert_eq!(files, 11);
    }

    /// (struct, size, [(member, offset)]) as naga lays the WGSL struct out.
    fn layout(m: &naga::Module, name: &str) -> (u32, Vec<(String, u32)>) {
        for (_, ty) in m.types.iter() {
            if ty.name.as_deref() == Some(name) {
                if let naga::TypeInner::Struct { members, span } = &ty.inner {
                    let members = members
                        .iter()
                        .map(|mb| (mb.name.clone().unwrap_or_default(), mb.offset))
                        .collect();
                    return (*span, members);
                }
            }
        }
        panic!("no struct {name}");
    }

    macro_rules! check_layout {
        ($kernel:expr, $ty:ident, [$($field:ident),* $(,)?]) => {{
            let (span, members) = layout(&module($kernel), stringify!($ty));
            assert_eq!(span as usize, std::mem::size_of::<$ty>(), "size of {}", stringify!($ty));
            let expected: Vec<(String, u32)> = vec![
                $((stringify!($field).to_string(), std::mem::offset_of!($ty, $field) as u32)),*
            ];
            assert_eq!(members, expected, "{}", stringify!($ty));
        }};
    }

    #[test]
    fn parameter_structs_match_the_shaders() {
        for kernel in [
            Kernel::WelchLocal,
            Kernel::WelchPrepare,
            Kernel::FftColumns,
            Kernel::FftRows,
            Kernel::WelchPower,
        ] {
            check_layout!(
                kernel,
                WelchParams,
                [
                    nperseg,
                    nfft,
                    half,
                    step,
                    segments,
                    input_stride,
                    bins,
                    detrend,
                    centre,
                    inv_n,
                    inv_stt,
                    split
                ]
            );
        }
        check_layout!(
            Kernel::WelchAccumulate,
            AccumulateParams,
            [bins, segments, reset, _pad]
        );
        check_layout!(
            Kernel::AvarOctave,
            OctaveParams,
            [
                count,
                lo_off,
                hi_off,
                next_off,
                partial_base,
                write_next,
                _pad0,
                _pad1
            ]
        );
        for kernel in [Kernel::AvarPrefixF64, Kernel::AvarPrefixFixed] {
            check_layout!(
                kernel,
                PrefixParams,
                [count, off0, off1, off2, partial_base, scale, _pad0, _pad1]
            );
        }
    }
}

/// No device needed: the CPU mirrors against textbook references.
mod mirrors {
    use super::*;
    use imunoise::gpu::kernels::twiddle_table;
    use imunoise::gpu::mirror::fft::{
        fft_columns, fft_rows, local_result, stockham_local, Workgroup,
    };
    use imunoise::gpu::welch::WelchParams;

    /// Direct complex DFT in f64.
    fn dft(x: &[[f32; 2]]) -> Vec<[f64; 2]> {
        let n = x.len();
        (0..n)
            .map(|k| {
                let mut acc = [0.0f64; 2];
                for (t, v) in x.iter().enumerate() {
                    let a = -2.0 * std::f64::consts::PI * ((k * t) % n) as f64 / n as f64;
                    let (s, c) = a.sin_cos();
                    acc[0] += f64::from(v[0]) * c - f64::from(v[1]) * s;
                    acc[1] += f64::from(v[0]) * s + f64::from(v[1]) * c;
                }
                acc
            })
            .collect()
    }

    fn assert_spectrum(got: &[[f32; 2]], want: &[[f64; 2]], what: &str) {
        let max = want.iter().fold(0.0f64, |m, v| m.max(v[0].hypot(v[1])));
        for (k, (g, w)) in got.iter().zip(want).enumerate() {
            let e = (f64::from(g[0]) - w[0]).hypot(f64::from(g[1]) - w[1]);
            assert!(
                e <= 1e-5 * max,
                "{what}: bin {k} off by {e:e} (max {max:e})"
            );
        }
    }

    #[test]
    fn workgroup_fft_matches_a_direct_dft() {
        for log in 0..=12 {
            let len = 1u32 << log;
            // The table of nfft = 4·len, as in a four-step column pass of a larger transform.
            let nfft = 4 * len;
            let tw = twiddle_table(nfft as usize);
            let x = complex_f32(len as usize, u64::from(len));
            let mut wg = Workgroup::new(4096);
            wg.fa[..len as usize].copy_from_slice(&x);
            let in_b = stockham_local(&mut wg, &tw, len, nfft);
            let got: Vec<[f32; 2]> = (0..len).map(|i| local_result(&wg, in_b, i)).collect();
            assert_spectrum(&got, &dft(&x), &format!("len {len}"));
        }
    }

    #[test]
    fn four_step_fft_matches_a_direct_dft() {
        // half = 8192 = 128 × 64, on a "device" whose workgroup FFT holds 128 values.
        let p = WelchParams {
            nperseg: 16384,
            nfft: 16384,
            half: 8192,
            step: 1,
            segments: 1,
            input_stride: 0,
            bins: 8193,
            detrend: 0,
            centre: 0.0,
            inv_n: 0.0,
            inv_stt: 0.0,
            split: 128,
        };
        let tw = twiddle_table(16384);
        let x = complex_f32(8192, 7);
        let mut work = x.clone();
        fft_columns(&p, &tw, &mut work, 1, 4096);
        let mut spectrum = vec![[0.0f32; 2]; 8192];
        fft_rows(&p, &tw, &work, &mut spectrum, 1, 4096);
        assert_spectrum(&spectrum, &dft(&x), "four-step 128 × 64");
    }

    #[test]
    fn welch_mirror_matches_the_cpu_welch() {
        use imunoise::gpu::mirror::welch::welch_local;
        use imunoise::psd::Detrend;
        let x = imu(3000, 11);
        for detrend in [Detrend::Constant, Detrend::Linear] {
            let cfg = WelchConfig {
                detrend,
                nfft: Some(512),
                ..WelchConfig::new(400)
            };
            let plan = cfg.validate().unwrap();
            let segs = plan.segments_for(x.len());
            let reference = x.iter().sum::<f64>() / x.len() as f64;
            let input: Vec<f32> = x.iter().map(|v| (v - reference) as f32).collect();
            let window: Vec<f32> = plan.window().iter().map(|&w| w as f32).collect();
            let mut p = WelchParams::for_plan(&plan, 0);
            p.segments = segs as u32;
            p.input_stride = x.len() as u32;
            let power = welch_local(&p, &twiddle_table(512), &input, &window, &[0.0], 1, 4096);
            let cpu = imunoise::psd::welch(&x, 100.0, &cfg).unwrap();
            let scale = 1.0 / (100.0 * plan.sum_w2());
            for k in 0..plan.bins() {
                let mean: f64 = (0..segs)
                    .map(|s| f64::from(power[s * plan.bins() + k]))
                    .sum::<f64>()
                    / segs as f64;
                let fold = if k == 0 || k == plan.bins() - 1 {
                    1.0
                } else {
                    2.0
                };
                let want = cpu.value[k];
                let got = mean * scale * fold;
                assert!(
                    ((got - want) / want).abs() <= PSD_TOL,
                    "{detrend} bin {k}: {got} vs {want}"
                );
            }
        }
    }

    #[test]
    fn allan_mirrors_match_the_reference() {
        use imunoise::avar::reference::oadev;
        use imunoise::gpu::avar::{OctaveParams, PrefixParams};
        use imunoise::gpu::mirror::avar::{avar_octave, avar_prefix_f64, avar_prefix_fixed};
        let y = imu(5001, 5);
        let n = y.len();
        let mean = y.iter().sum::<f64>() / n as f64;
        // Pyramid.
        let mut level: Vec<f32> = y.iter().map(|v| (v - mean) as f32).collect();
        for k in 0..11 {
            let m = 1usize << k;
            let count = n + 1 - 2 * m;
            let groups = count.div_ceil(4096) as u32;
            let mut next = vec![0.0f32; count];
            let mut partials = vec![0.0f32; groups as usize];
            let p = OctaveParams {
                count: count as u32,
                lo_off: 0,
                hi_off: m as u32,
                next_off: 0,
                partial_base: 0,
                write_next: 1,
                _pad0: 0,
                _pad1: 0,
            };
            avar_octave(&p, &level, &level, &mut next, &mut partials, groups);
            let var = partials.iter().map(|&v| f64::from(v)).sum::<f64>() / (2.0 * count as f64);
            let want = oadev(&y, m);
            assert!(
                ((var - want) / want).abs() <= AV_TOL,
                "octave m {m}: {var} vs {want}"
            );
            level = next;
        }
        // Prefix sums, f64 and fixed point, at a few m.
        let mut s = vec![0.0f64];
        let mut fixed = vec![[0u32; 2]];
        let unit = 2f64.powi(-30);
        let mut acc = 0i64;
        for v in &y {
            s.push(s.last().unwrap() + (v - mean));
            acc = acc.wrapping_add(((v - mean) / unit).round() as i64);
            fixed.push([acc as u64 as u32, ((acc as u64) >> 32) as u32]);
        }
        for m in [1usize, 3, 10, 77, 2500] {
            let count = n + 1 - 2 * m;
            let groups = count.div_ceil(4096) as u32;
            let p = PrefixParams {
                count: count as u32,
                off0: 0,
                off1: m as u32,
                off2: 2 * m as u32,
                partial_base: 0,
                scale: 2f32.powi(-30),
                _pad0: 0,
                _pad1: 0,
            };
            let mf = m as f64;
            let want = oadev(&y, m);
            let mut wide = vec![0.0f64; groups as usize];
            avar_prefix_f64(&p, &s, &s, &s, &mut wide, groups);
            let var = wide.iter().sum::<f64>() / (2.0 * mf * mf * count as f64);
            assert!(
                ((var - want) / want).abs() <= AV_TOL,
                "f64 m {m}: {var} vs {want}"
            );
            let mut narrow = vec![0.0f32; groups as usize];
            avar_prefix_fixed(&p, &fixed, &fixed, &fixed, &mut narrow, groups);
            let var =
                narrow.iter().map(|&v| f64::from(v)).sum::<f64>() / (2.0 * mf * mf * count as f64);
            assert!(
                ((var - want) / want).abs() <= AV_TOL,
                "fixed m {m}: {var} vs {want}"
            );
        }
    }
}

/// Each kernel on the device against its CPU mirror.
mod kernels {
    use super::*;
    use imunoise::gpu::avar::{OctaveParams, PrefixParams};
    use imunoise::gpu::kernels::{self, twiddle_table};
    use imunoise::gpu::mirror;
    use imunoise::gpu::welch::{AccumulateParams, WelchParams};
    use imunoise::psd::Detrend;

    fn params(nperseg: usize, nfft: usize, detrend: Detrend, split: usize) -> WelchParams {
        let cfg = WelchConfig {
            detrend,
            nfft: Some(nfft),
            noverlap: Some(nperseg / 3),
            window: imunoise::psd::Window::Blackman,
            ..WelchConfig::new(nperseg)
        };
        WelchParams::for_plan(&cfg.validate().unwrap(), split)
    }

    #[test]
    fn welch_local() {
        let ctx = gpu!();
        let local = ctx.local_fft_size();
        for (nperseg, nfft, detrend) in [
            (7usize, 8usize, Detrend::Linear),
            (200, 512, Detrend::Linear),
            (256, 256, Detrend::Constant),
            (2 * local as usize, 2 * local as usize, Detrend::None),
        ] {
            let mut p = params(nperseg, nfft, detrend, 0);
            p.segments = 3;
            p.input_stride = 2 * p.step + p.nperseg + 5;
            let channels = 2;
            let input = uniform_f32(channels * p.input_stride as usize, nfft as u64);
            let window = uniform_f32(nperseg, 3);
            let refs = [0.25f32, -3.0];
            let tw = twiddle_table(nfft);
            let gpu = kernels::welch_local(&ctx, &p, &input, &window, &refs).unwrap();
            let cpu = mirror::welch::welch_local(&p, &tw, &input, &window, &refs, channels, local);
            assert_mirror(&gpu, &cpu, &format!("welch_local nfft {nfft}"));
        }
    }

    #[test]
    fn welch_prepare() {
        let ctx = gpu!();
        let local = ctx.local_fft_size();
        for detrend in [Detrend::Linear, Detrend::None] {
            let mut p = params(3000, 8192, detrend, 64);
            p.segments = 2;
            p.input_stride = p.step + p.nperseg;
            let input = uniform_f32(2 * p.input_stride as usize, 9);
            let window = uniform_f32(3000, 10);
            let refs = [1.5f32, 0.0];
            let gpu = kernels::welch_prepare(&ctx, &p, &input, &window, &refs).unwrap();
            let cpu = mirror::welch::welch_prepare(&p, &input, &window, &refs, 2, local);
            assert_mirror(
                &flat(&gpu),
                &flat(&cpu),
                &format!("welch_prepare {detrend}"),
            );
        }
    }

    #[test]
    fn four_step_passes_and_power() {
        let ctx = gpu!();
        let local = ctx.local_fft_size();
        // half = 4096 = 64 × 64 (a split any device can hold).
        let p = params(8192, 8192, Detrend::Constant, 64);
        let slots = 3;
        let tw = twiddle_table(8192);
        let work = complex_f32(slots * 4096, 21);

        let gpu_cols = kernels::fft_columns(&ctx, &p, &work, slots).unwrap();
        let mut cpu_cols = work.clone();
        mirror::fft::fft_columns(&p, &tw, &mut cpu_cols, slots, local);
        assert_mirror(&flat(&gpu_cols), &flat(&cpu_cols), "fft_columns");

        let gpu_rows = kernels::fft_rows(&ctx, &p, &cpu_cols, slots).unwrap();
        let mut cpu_rows = vec![[0.0f32; 2]; work.len()];
        mirror::fft::fft_rows(&p, &tw, &cpu_cols, &mut cpu_rows, slots, local);
        assert_mirror(&flat(&gpu_rows), &flat(&cpu_rows), "fft_rows");

        let gpu_power = kernels::welch_power(&ctx, &p, &cpu_rows, slots).unwrap();
        let cpu_power = mirror::welch::welch_power(&p, &tw, &cpu_rows, slots);
        assert_mirror(&gpu_power, &cpu_power, "welch_power");
    }

    #[test]
    fn welch_accumulate() {
        let ctx = gpu!();
        let channels = 3;
        for (segments, reset) in [(1u32, 1u32), (70, 0), (33, 1)] {
            let q = AccumulateParams {
                bins: 300,
                segments,
                reset,
                _pad: 0,
            };
            let power: Vec<f32> = uniform_f32(channels * (segments * 300) as usize, 4)
                .iter()
                .map(|v| v.abs())
                .collect();
            let acc: Vec<f32> = uniform_f32(channels * 300, 5)
                .iter()
                .map(|v| v.abs())
                .collect();
            let gpu = kernels::welch_accumulate(&ctx, &q, &power, &acc, channels).unwrap();
            let mut cpu = acc.clone();
            mirror::welch::welch_accumulate(&q, &power, &mut cpu, channels);
            assert_mirror(&gpu, &cpu, &format!("welch_accumulate {segments} {reset}"));
        }
    }

    #[test]
    fn avar_octave() {
        let ctx = gpu!();
        let (count, m) = (10_000usize, 37usize);
        let data = uniform_f32(count + m + 8, 6);
        let p = OctaveParams {
            count: count as u32,
            lo_off: 3,
            hi_off: 3 + m as u32,
            next_off: 5,
            partial_base: 0,
            write_next: 1,
            _pad0: 0,
            _pad1: 0,
        };
        let (gpu_partials, gpu_next) = kernels::avar_octave(&ctx, &p, &data, &data).unwrap();
        let groups = gpu_partials.len() as u32;
        assert_eq!(groups, 3);
        let mut partials = vec![0.0f32; 3];
        let mut next = vec![0.0f32; count + 5];
        mirror::avar::avar_octave(&p, &data, &data, &mut next, &mut partials, groups);
        assert_mirror(&gpu_partials, &partials, "avar_octave partial sums");
        assert_mirror(&gpu_next[5..], &next[5..], "avar_octave next level");
    }

    fn prefix_params(count: usize, scale: f32) -> PrefixParams {
        PrefixParams {
            count: count as u32,
            off0: 1,
            off1: 2,
            off2: 3,
            partial_base: 0,
            scale,
            _pad0: 0,
            _pad1: 0,
        }
    }

    #[test]
    fn avar_prefix_f64() {
        let ctx = gpu!();
        if !ctx.has_f64() {
            eprintln!("skipping: the device has no f64 (avar_prefix_fixed covers it)");
            return;
        }
        let count = 9000;
        let s: Vec<f64> = noise(count + 10, 8).iter().map(|v| v * 1e3).collect();
        let p = prefix_params(count, 1.0);
        let gpu = kernels::avar_prefix_f64(&ctx, &p, &s, &s[5..], &s[2..]).unwrap();
        let mut cpu = vec![0.0f64; gpu.len()];
        mirror::avar::avar_prefix_f64(&p, &s, &s[5..], &s[2..], &mut cpu, gpu.len() as u32);
        for (g, c) in gpu.iter().zip(&cpu) {
            assert!(((g - c) / c).abs() <= 1e-12, "{g} vs {c}");
        }
    }

    #[test]
    fn avar_prefix_fixed() {
        let ctx = gpu!();
        let count = 9000;
        // Wrapping sums of large steps, so that both words and the borrows are exercised.
        let mut acc = 0i64;
        let words: Vec<[u32; 2]> = noise(count + 10, 12)
            .iter()
            .map(|v| {
                acc = acc.wrapping_add((v * 1e15) as i64);
                [acc as u64 as u32, ((acc as u64) >> 32) as u32]
            })
            .collect();
        let p = prefix_params(count, 2f32.powi(-40));
        let gpu = kernels::avar_prefix_fixed(&ctx, &p, &words, &words[4..], &words[1..]).unwrap();
        let mut cpu = vec![0.0f32; gpu.len()];
        mirror::avar::avar_prefix_fixed(
            &p,
            &words,
            &words[4..],
            &words[1..],
            &mut cpu,
            gpu.len() as u32,
        );
        assert_mirror(&gpu, &cpu, "avar_prefix_fixed");
    }
}

/// GPU Welch against the CPU Welch.
mod welch {
    use super::*;
    use imunoise::gpu::GpuBackend;
    use imunoise::psd::{Detrend, Scaling, Window};

    #[test]
    fn windows_detrends_and_overlaps() {
        let ctx = gpu!();
        let with_offset = vec![imu(6_001, 1), imu(6_001, 2)];
        // Without detrending, a 1e4 σ bias leaks into the low bins and hides the noise bins below
        // the comparison floor; those are checked on data without a bias.
        let no_offset: Vec<Vec<f64>> = with_offset
            .iter()
            .map(|c| c.iter().map(|v| v - 1e4).collect())
            .collect();
        let custom: Vec<f64> = (0..256)
            .map(|i| 1.0 + 0.5 * ((i * 37 % 101) as f64 / 101.0))
            .collect();
        for window in [
            Window::Hann,
            Window::Hamming,
            Window::Blackman,
            Window::BlackmanHarris,
            Window::Flattop,
            Window::Boxcar,
            Window::Custom(custom),
        ] {
            for detrend in [Detrend::Constant, Detrend::Linear, Detrend::None] {
                for noverlap in [None, Some(0), Some(192), Some(37)] {
                    let cfg = WelchConfig {
                        window: window.clone(),
                        detrend,
                        noverlap,
                        ..WelchConfig::new(256)
                    };
                    let plan = cfg.validate().unwrap();
                    let data = if detrend == Detrend::None {
                        &no_offset
                    } else {
                        &with_offset
                    };
                    let gpu = gpu_welch(&ctx, data, 100.0, &plan);
                    assert_psds(&gpu, &cpu_welch(data, 100.0, &plan), &format!("{cfg:?}"));
                }
            }
        }
    }

    #[test]
    fn segment_lengths_from_2_8_to_2_20() {
        let ctx = gpu!();
        for (nperseg, n) in [
            (256usize, 10_000usize),
            (1024, 10_000),
            (4096, 20_000),
            (8192, 20_000),
            (1 << 16, 1 << 17),
            (1 << 20, 3 << 19),
        ] {
            let plan = WelchConfig {
                detrend: Detrend::Linear,
                ..WelchConfig::new(nperseg)
            }
            .validate()
            .unwrap();
            let data = vec![imu(n, nperseg as u64)];
            let gpu = gpu_welch(&ctx, &data, 200.0, &plan);
            assert_psds(
                &gpu,
                &cpu_welch(&data, 200.0, &plan),
                &format!("nperseg {nperseg}"),
            );
        }
    }

    #[test]
    fn zero_padding_spectrum_scaling_and_odd_lengths() {
        let ctx = gpu!();
        let data = vec![imu(12_345, 3), imu(12_345, 4), imu(12_345, 5)];
        for (nperseg, nfft, scaling) in [
            (1000usize, 4096usize, Scaling::Spectrum),
            (300, 512, Scaling::Density),
            (5000, 16384, Scaling::Density),
        ] {
            let plan = WelchConfig {
                nfft: Some(nfft),
                scaling,
                ..WelchConfig::new(nperseg)
            }
            .validate()
            .unwrap();
            let gpu = gpu_welch(&ctx, &data, 50.0, &plan);
            assert_psds(
                &gpu,
                &cpu_welch(&data, 50.0, &plan),
                &format!("{nperseg}/{nfft}"),
            );
        }
    }

    #[test]
    fn agrees_with_the_direct_sum_reference() {
        let ctx = gpu!();
        let x = imu(2_000, 9);
        let cfg = WelchConfig {
            detrend: Detrend::Linear,
            window: Window::Hamming,
            ..WelchConfig::new(128)
        };
        let reference = imunoise::psd::reference::welch(&x, 10.0, &cfg).unwrap();
        let gpu = gpu_welch(&ctx, &[x], 10.0, &cfg.validate().unwrap());
        let max = reference.iter().cloned().fold(0.0, f64::max);
        for (k, (g, r)) in gpu[0].value.iter().zip(&reference).enumerate() {
            if *r > PSD_FLOOR * max {
                assert!(((g - r) / r).abs() <= PSD_TOL, "bin {k}: {g} vs {r}");
            }
        }
    }

    #[test]
    fn streaming_in_uneven_chunks_equals_one_shot() {
        let ctx = gpu!();
        let data = vec![imu(40_000, 6), imu(40_000, 7)];
        let plan = WelchConfig::new(2048).validate().unwrap();
        let mut sink =
            imunoise::gpu::GpuWelch::new(Arc::clone(&ctx), plan.clone(), 100.0, 2).unwrap();
        let mut at = 0;
        for size in [1usize, 999, 4097, 3, 2048, 0, 20_000].iter().cycle() {
            if at >= data[0].len() {
                break;
            }
            let end = (at + size).min(data[0].len());
            sink.push(&[&data[0][at..end], &data[1][at..end]]);
            at = end;
        }
        assert!(sink.on_gpu());
        let peak = imunoise::estimate::WelchSink::peak_buffered_samples(&sink);
        assert!(peak < 2048, "held {peak} samples");
        assert_psds(
            &sink.finish().unwrap(),
            &cpu_welch(&data, 100.0, &plan),
            "streamed",
        );
    }

    #[test]
    fn several_recordings_through_one_context() {
        let ctx = gpu!();
        let backend = GpuBackend::with_context(Arc::clone(&ctx));
        let files = [
            (vec![imu(30_000, 20)], WelchConfig::new(512)),
            (
                vec![imu(25_001, 21), imu(25_001, 22), imu(25_001, 23)],
                WelchConfig::new(4096),
            ),
            (
                vec![imu(50_000, 24)],
                WelchConfig {
                    nfft: Some(16384),
                    ..WelchConfig::new(10_000)
                },
            ),
        ];
        let plans: Vec<WelchPlan> = files.iter().map(|f| f.1.validate().unwrap()).collect();
        // Open all sinks, then feed them interleaved, as a batch run reading files in parallel.
        let mut sinks: Vec<_> = files
            .iter()
            .zip(&plans)
            .map(|(f, plan)| backend.welch(plan, 100.0, f.0.len()))
            .collect();
        for part in 0..5 {
            for ((data, _), sink) in files.iter().zip(&mut sinks) {
                let n = data[0].len();
                let (a, b) = (part * n / 5, (part + 1) * n / 5);
                let chunk: Vec<&[f64]> = data.iter().map(|c| &c[a..b]).collect();
                sink.push(&chunk);
            }
        }
        for (((data, _), plan), sink) in files.iter().zip(&plans).zip(sinks) {
            assert_psds(
                &sink.finish().unwrap(),
                &cpu_welch(data, 100.0, plan),
                &format!("{plan:?}"),
            );
        }
        assert!(backend.fallbacks().is_empty());
        // A second pass reuses the pooled buffers and gives the same numbers.
        let again = gpu_welch(&ctx, &files[1].0, 100.0, &plans[1]);
        assert_psds(&again, &cpu_welch(&files[1].0, 100.0, &plans[1]), "again");
    }

    #[test]
    fn concurrent_jobs_share_one_context() {
        let ctx = gpu!();
        let plans: Vec<WelchPlan> = [512usize, 2048, 8192]
            .iter()
            .map(|&n| WelchConfig::new(n).validate().unwrap())
            .collect();
        let data = vec![imu(30_000, 80), imu(30_000, 81)];
        let expected: Vec<Vec<Psd>> = plans.iter().map(|p| cpu_welch(&data, 100.0, p)).collect();
        std::thread::scope(|s| {
            for t in 0..3 {
                let (ctx, plans, data, expected) = (&ctx, &plans, &data, &expected);
                s.spawn(move || {
                    for round in 0..3 {
                        let i = (t + round) % plans.len();
                        let gpu = gpu_welch(ctx, data, 100.0, &plans[i]);
                        assert_psds(&gpu, &expected[i], &format!("thread {t} round {round}"));
                    }
                });
            }
        });
    }

    #[test]
    fn misuse_is_reported_like_the_cpu() {
        let ctx = gpu!();
        let plan = WelchConfig::new(256).validate().unwrap();
        let x = vec![0.5; 100];
        for (rate, chunk, channels) in [
            (100.0, vec![&x[..], &x[..]], 1usize),
            (100.0, vec![&x[..], &x[..50]], 2),
            (f64::NAN, vec![&x[..]], 1),
            (100.0, vec![&x[..]], 1),
        ] {
            let mut gpu =
                imunoise::gpu::GpuWelch::new(Arc::clone(&ctx), plan.clone(), rate, channels)
                    .unwrap();
            let mut cpu = imunoise::psd::WelchAccumulator::new(plan.clone(), rate, channels);
            gpu.push(&chunk);
            cpu.push(&chunk);
            assert_eq!(gpu.finish().unwrap_err(), cpu.finish().unwrap_err());
        }
    }
}

/// GPU Allan variances against the CPU's.
mod allan {
    use super::*;
    use imunoise::gpu::GpuBackend;

    fn check(ctx: &Arc<GpuContext>, channels: &[Vec<f64>], grid: &TauGrid, what: &str) {
        let backend = GpuBackend::with_context(Arc::clone(ctx));
        let gpu = backend.deviations(
            channels,
            100.0,
            grid,
            Statistic::Oadev,
            Confidence::OneSigma,
        );
        assert!(backend.fallbacks().is_empty(), "{:?}", backend.fallbacks());
        for (c, (g, y)) in gpu.iter().zip(channels).enumerate() {
            let cpu = compute(y, 100.0, grid, Statistic::Oadev, Confidence::OneSigma).unwrap();
            assert_deviations(
                g.as_ref().unwrap(),
                &cpu,
                &format!("{what}, {grid}, channel {c}"),
            );
        }
    }

    fn grids(n: usize) -> Vec<TauGrid> {
        vec![
            TauGrid::Octave,
            TauGrid::Decade125,
            TauGrid::PerDecade(7),
            TauGrid::Explicit(vec![1, 3, 6, 64, 1000, 12_345, (n as u64 - 1) / 2]),
        ]
    }

    #[test]
    fn grids_channels_offset_and_drift_with_f64() {
        let ctx = gpu!();
        let n = 100_003;
        let walk: Vec<f64> = noise(n, 31)
            .iter()
            .scan(0.0, |s, v| {
                *s += v;
                Some(*s)
            })
            .collect();
        let channels = vec![imu(n, 30), noise(n, 32), walk];
        for grid in grids(n) {
            check(&ctx, &channels, &grid, "adapter's own device");
        }
        check(&ctx, &[imu(1_001, 33)], &TauGrid::All, "all taus");
    }

    #[test]
    fn grids_with_the_fixed_point_scheme() {
        let ctx = gpu!(|_| {}, false);
        assert!(!ctx.has_f64());
        let n = 100_003;
        let channels = vec![imu(n, 40), noise(n, 41)];
        for grid in grids(n) {
            check(&ctx, &channels, &grid, "no f64");
        }
        check(&ctx, &[imu(1_001, 42)], &TauGrid::All, "all taus, no f64");
    }

    #[test]
    fn errors_are_the_cpus() {
        let ctx = gpu!();
        let backend = GpuBackend::with_context(ctx);
        let good = noise(100, 1);
        let mut nan = noise(100, 2);
        nan[17] = f64::NAN;
        let cases: Vec<(Vec<f64>, f64, TauGrid, Confidence)> = vec![
            (vec![1.0, 2.0], 1.0, TauGrid::Octave, Confidence::OneSigma),
            (nan, 1.0, TauGrid::Octave, Confidence::OneSigma),
            (
                good.clone(),
                1.0,
                TauGrid::Explicit(vec![0, 2]),
                Confidence::OneSigma,
            ),
            (
                good.clone(),
                1.0,
                TauGrid::Explicit(vec![2, 60]),
                Confidence::OneSigma,
            ),
            (
                good.clone(),
                1.0,
                TauGrid::PerDecade(0),
                Confidence::OneSigma,
            ),
            (good.clone(), 0.0, TauGrid::Octave, Confidence::OneSigma),
            (good.clone(), 1.0, TauGrid::Octave, Confidence::Level(1.5)),
        ];
        for (y, rate, grid, conf) in cases {
            let gpu = backend.deviations(
                &[y.clone(), good.clone()],
                rate,
                &grid,
                Statistic::Oadev,
                conf,
            );
            let cpu =
                CpuBackend.deviations(&[y, good.clone()], rate, &grid, Statistic::Oadev, conf);
            let gpu_err: Result<(), AvarError> = gpu[0].clone().map(|_| ());
            let cpu_err: Result<(), AvarError> = cpu[0].clone().map(|_| ());
            assert!(cpu_err.is_err());
            assert_eq!(gpu_err, cpu_err);
            // The valid channel next to it still gets its result (or the same shared error).
            assert_eq!(gpu[1].is_ok(), cpu[1].is_ok());
        }
    }
}

/// Devices with deliberately small limits: every job must chunk, and still agree.
mod chunked {
    use super::*;
    use imunoise::gpu::chunking::{spans, Caps, Paging};
    use imunoise::gpu::welch::layout;

    /// 1 MiB bindings in 2 MiB buffers: Allan-variance arrays of 600k samples need pages and
    /// windows.
    fn small(l: &mut wgpu::Limits) {
        l.max_storage_buffer_binding_size = 1 << 20;
        l.max_buffer_size = 2 << 20;
    }

    /// 128 KiB bindings: Welch batches of a few segments, more batches than the device sums are
    /// kept between read-backs.
    fn tiny(l: &mut wgpu::Limits) {
        l.max_storage_buffer_binding_size = 128 << 10;
        l.max_buffer_size = 2 << 20;
    }

    #[test]
    fn welch_in_many_batches() {
        let ctx = gpu!(tiny, true);
        let n = 300_001;
        let data = vec![imu(n, 50), imu(n, 51), imu(n, 52)];
        for cfg in [
            WelchConfig::new(256),
            WelchConfig {
                noverlap: Some(1000),
                ..WelchConfig::new(8192)
            },
        ] {
            let plan = cfg.validate().unwrap();
            let batch = layout(&ctx, &plan, 3).unwrap().batch;
            let batches = plan.segments_for(n).div_ceil(batch);
            assert!(batches > 16, "{batches} batches of {batch}");
            let gpu = gpu_welch(&ctx, &data, 100.0, &plan);
            assert_psds(
                &gpu,
                &cpu_welch(&data, 100.0, &plan),
                &format!("chunked {cfg:?}"),
            );
        }
    }

    #[test]
    fn allan_across_pages_and_windows() {
        for allow_f64 in [true, false] {
            let ctx = gpu!(small, allow_f64);
            let n = 600_001;
            let caps = Caps::of(&ctx);
            // The pyramid's arrays span two pages and several windows; the prefix sums three pages.
            assert!(Paging::new(4, &caps).pages(n) >= 2);
            assert!(Paging::new(8, &caps).pages(n + 1) >= 3);
            assert!(spans(n - 1, &[0, 1], &Paging::new(4, &caps)).len() >= 3);
            let y = imu(n, 60);
            let grid =
                TauGrid::Explicit(vec![1, 2, 5, 64, 1000, 65_536, 123_457, 262_144, 300_000]);
            let backend = imunoise::gpu::GpuBackend::with_context(Arc::clone(&ctx));
            let gpu = backend.deviations(
                std::slice::from_ref(&y),
                10.0,
                &grid,
                Statistic::Oadev,
                Confidence::OneSigma,
            );
            assert!(backend.fallbacks().is_empty(), "{:?}", backend.fallbacks());
            let cpu = compute(&y, 10.0, &grid, Statistic::Oadev, Confidence::OneSigma).unwrap();
            assert_deviations(
                gpu[0].as_ref().unwrap(),
                &cpu,
                &format!("chunked, f64 {allow_f64}"),
            );
        }
    }
}

/// What runs on the CPU instead, and that it says so.
mod fallback {
    use super::*;
    use imunoise::gpu::{FallbackReason, GpuBackend, GpuWelch, Task};
    use imunoise::psd::Average;

    #[test]
    fn unsupported_welch_options_run_on_the_cpu() {
        let ctx = gpu!();
        let data = vec![imu(20_000, 70)];
        for cfg in [
            WelchConfig {
                average: Average::Median,
                ..WelchConfig::new(1024)
            },
            WelchConfig::new(1000),
        ] {
            let backend = GpuBackend::with_context(Arc::clone(&ctx));
            let plan = cfg.validate().unwrap();
            let mut sink = backend.welch(&plan, 100.0, 1);
            sink.push(&[&data[0]]);
            // The CPU path itself: identical numbers.
            assert_eq!(sink.finish().unwrap(), cpu_welch(&data, 100.0, &plan));
            let reason = backend.last_fallback_reason().expect("fallback recorded");
            assert!(matches!(reason, FallbackReason::Unsupported(_)), "{reason}");
            assert!(!reason.is_warning());
            // The note for the run's output, once.
            let notes = backend.take_notes();
            assert_eq!(notes.len(), 1, "{notes:?}");
            assert!(
                notes[0].starts_with("welch: not on the GPU path"),
                "{notes:?}"
            );
            assert!(backend.take_notes().is_empty());
        }
    }

    #[test]
    fn too_large_for_a_small_device_runs_on_the_cpu() {
        let ctx = gpu!(|l| l.max_storage_buffer_binding_size = 1 << 18, true);
        let backend = GpuBackend::with_context(ctx);
        let plan = WelchConfig::new(1 << 17).validate().unwrap();
        let _ = backend.welch(&plan, 100.0, 1);
        let reason = backend.last_fallback_reason().expect("fallback recorded");
        assert!(reason.to_string().contains("bytes"), "{reason}");
    }

    #[test]
    fn other_statistics_run_on_the_cpu() {
        let ctx = gpu!();
        let backend = GpuBackend::with_context(ctx);
        let y = vec![noise(3000, 71)];
        let gpu = backend.deviations(
            &y,
            1.0,
            &TauGrid::Octave,
            Statistic::Mdev,
            Confidence::OneSigma,
        );
        let cpu = CpuBackend.deviations(
            &y,
            1.0,
            &TauGrid::Octave,
            Statistic::Mdev,
            Confidence::OneSigma,
        );
        assert_eq!(gpu, cpu);
        let f = backend.fallbacks();
        assert_eq!(f.len(), 1);
        assert_eq!(f[0].task, Task::Deviations);
    }

    #[test]
    fn device_lost_mid_stream_finishes_on_the_cpu() {
        // A device of its own: this test destroys it.
        let ctx = gpu!(|_| {}, true);
        let backend = GpuBackend::with_context(Arc::clone(&ctx));
        let data = vec![imu(60_000, 72), imu(60_000, 73)];
        let plan = WelchConfig::new(2048).validate().unwrap();
        let log = Arc::new(imunoise::gpu::FallbackLog::default());
        let mut sink = GpuWelch::new(Arc::clone(&ctx), plan.clone(), 100.0, 2)
            .unwrap()
            .with_log(Arc::clone(&log));
        let half = 25_555;
        sink.push(&[&data[0][..half], &data[1][..half]]);
        assert!(sink.on_gpu());
        ctx.device().destroy();
        sink.push(&[&data[0][half..], &data[1][half..]]);
        assert!(!sink.on_gpu());
        assert_psds(
            &sink.finish().unwrap(),
            &cpu_welch(&data, 100.0, &plan),
            "after device loss",
        );
        let reason = log.last().expect("fallback recorded").reason;
        assert!(reason.is_warning(), "{reason}");

        // Later jobs on the dead device go to the CPU from the start, with the same numbers.
        let mut sink = backend.welch(&plan, 100.0, 2);
        sink.push(&[&data[0], &data[1]]);
        assert_eq!(sink.finish().unwrap(), cpu_welch(&data, 100.0, &plan));
        let y = vec![imu(5_000, 74)];
        let gpu = backend.deviations(
            &y,
            1.0,
            &TauGrid::Octave,
            Statistic::Oadev,
            Confidence::OneSigma,
        );
        let cpu = CpuBackend.deviations(
            &y,
            1.0,
            &TauGrid::Octave,
            Statistic::Oadev,
            Confidence::OneSigma,
        );
        assert_eq!(gpu, cpu);
        assert!(backend.fallbacks().iter().all(|f| f.reason.is_warning()));
        assert_eq!(backend.fallbacks().len(), 2);
    }

    #[test]
    fn no_adapter_is_a_clean_error() {
        let options = ContextOptions {
            backends: Some(wgpu::Backends::empty()),
            ..ContextOptions::default()
        };
        match GpuContext::with_options(&options) {
            Err(GpuError::NoAdapter(msg)) => assert!(!msg.is_empty()),
            other => panic!("expected NoAdapter, got {other:?}"),
        }
    }

    /// With kernel timing asked for, every pass of both estimators is timed (when the adapter has
    /// timestamps) and the numbers are the untimed context's; without it there are no times.
    #[test]
    fn kernel_timing_counts_every_pass_and_changes_no_number() {
        let untimed = gpu!();
        assert!(untimed.kernel_times().is_none(), "timing is off by default");
        let options = ContextOptions {
            kernel_timing: true,
            ..ContextOptions::default()
        };
        let timed = match GpuContext::with_options(&options) {
            Ok(ctx) => Arc::new(ctx),
            Err(e) => return skip_or_fail(&e),
        };
        let Some(zero) = timed.kernel_times() else {
            let adapter = imunoise::gpu::request_adapter(&options).unwrap();
            assert!(
                !adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY),
                "the adapter has timestamps but the context does not time"
            );
            return;
        };
        assert_eq!(zero, imunoise::gpu::KernelTimes::default());
        let channels = vec![imu(20_000, 3), imu(20_000, 4)];
        let plan = WelchConfig::new(1024).validate().unwrap();
        let psd_timed = gpu_welch(&timed, &channels, 100.0, &plan);
        let psd_untimed = gpu_welch(&untimed, &channels, 100.0, &plan);
        assert_eq!(psd_timed, psd_untimed);
        let grid = TauGrid::Explicit(vec![1, 2, 4, 7, 100]);
        let run = |ctx: &Arc<GpuContext>| {
            GpuBackend::with_context(Arc::clone(ctx))
                .deviations(
                    &channels,
                    100.0,
                    &grid,
                    Statistic::Oadev,
                    Confidence::OneSigma,
                )
                .into_iter()
                .map(Result::unwrap)
                .collect::<Vec<_>>()
        };
        assert_eq!(run(&timed), run(&untimed));
        let t = timed.kernel_times().unwrap();
        assert!(t.welch_passes >= 1 && t.allan_passes >= 1, "{t:?}");
        assert!(t.welch > std::time::Duration::ZERO, "{t:?}");
        assert!(t.allan > std::time::Duration::ZERO, "{t:?}");
        timed.reset_kernel_times();
        assert_eq!(
            timed.kernel_times(),
            Some(imunoise::gpu::KernelTimes::default())
        );
    }

    /// Every pipeline a run may use builds up front (as `--backend auto` does beside the
    /// reading), on a device with f64 and on one without, and leaves the context healthy.
    #[test]
    fn every_pipeline_prepares_up_front() {
        for allow_f64 in [true, false] {
            let Some(ctx) = fresh(|_| {}, allow_f64) else {
                return;
            };
            ctx.prepare_pipelines()
                .unwrap_or_else(|e| panic!("f64 {allow_f64}: {e}"));
            assert!(ctx.failure().is_none());
        }
    }

    #[test]
    fn describe_names_the_adapter() {
        let ctx = gpu!();
        let backend = GpuBackend::with_context(Arc::clone(&ctx));
        let info = ctx.adapter_info();
        let text = backend.describe();
        assert!(text.contains(&info.name), "{text}");
        assert!(text.contains(&format!("{:?}", info.backend)), "{text}");
    }
}
