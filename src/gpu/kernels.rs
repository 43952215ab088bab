//! Each kernel run on its own, on host data, for checking it against its CPU mirror
//! ([`mirror`](super::mirror)) and for timing single stages. These go through the same buffers,
//! bind groups and dispatch code as the real jobs (`WelchDevice`, the Allan-variance passes); only
//! the inputs come from the caller instead of the previous stage.

use std::sync::Arc;

use super::avar::{run_octave_level, run_prefix, OctaveParams, PrefixData, PrefixParams};
use super::fft::{twiddles, FftAlgorithm};
use super::shaders::Kernel;
use super::welch::{AccumulateParams, Capacity, WelchDevice, WelchParams};
use super::{GpuContext, GpuError};

/// A complex value (re, im).
pub type C32 = [f32; 2];

fn welch_device(
    ctx: &Arc<GpuContext>,
    p: &WelchParams,
    window: &[f32],
    channels: usize,
    input_len: usize,
) -> Result<WelchDevice, GpuError> {
    let algorithm = if p.split == 0 {
        FftAlgorithm::Local
    } else {
        FftAlgorithm::FourStep {
            m1: p.split as usize,
            m2: (p.half / p.split) as usize,
        }
    };
    let cap = Capacity {
        channels,
        segments: p.segments as usize,
        stride: input_len / channels.max(1),
    };
    WelchDevice::new(Arc::clone(ctx), *p, window, algorithm, cap)
}

/// `welch_local` on `input` (channel-major, `p.input_stride` samples per channel): |X_k|² rows,
/// `p.bins` per segment slot.
pub fn welch_local(
    ctx: &Arc<GpuContext>,
    p: &WelchParams,
    input: &[f32],
    window: &[f32],
    refs: &[f32],
) -> Result<Vec<f32>, GpuError> {
    let dev = welch_device(
        ctx,
        &WelchParams { split: 0, ..*p },
        window,
        refs.len(),
        input.len(),
    )?;
    dev.load(p, input, refs);
    dev.run_kernel(Kernel::WelchLocal, p.segments as usize)?;
    let mut power = dev.read_f32("power")?;
    power.truncate(refs.len() * (p.segments * p.bins) as usize);
    Ok(power)
}

/// `welch_prepare`: the packed, detrended, windowed FFT input, `p.half` values per slot.
/// `p.split` must be a valid four-step split of `p.half`.
pub fn welch_prepare(
    ctx: &Arc<GpuContext>,
    p: &WelchParams,
    input: &[f32],
    window: &[f32],
    refs: &[f32],
) -> Result<Vec<C32>, GpuError> {
    let dev = welch_device(ctx, p, window, refs.len(), input.len())?;
    dev.load(p, input, refs);
    dev.run_kernel(Kernel::WelchPrepare, p.segments as usize)?;
    read_complex(&dev, "work", refs.len() * (p.segments * p.half) as usize)
}

/// Runs `kernel` alone over `slots` rows of `p.half` complex values, with `work` and `spectrum`
/// loaded as given: the shared set-up of the single-kernel FFT and power tests.
fn run_on_rows(
    ctx: &Arc<GpuContext>,
    p: &WelchParams,
    kernel: Kernel,
    work: &[C32],
    spectrum: &[C32],
    slots: usize,
) -> Result<(WelchDevice, WelchParams), GpuError> {
    let p = WelchParams {
        segments: slots as u32,
        ..*p
    };
    let dev = welch_device(ctx, &p, &[0.0], 1, 1)?;
    dev.load(&p, &[0.0], &[0.0]);
    dev.load_complex(work, spectrum);
    dev.run_kernel(kernel, slots)?;
    Ok((dev, p))
}

/// `fft_columns` on `work` (`slots` rows of `p.half`), in place.
pub fn fft_columns(
    ctx: &Arc<GpuContext>,
    p: &WelchParams,
    work: &[C32],
    slots: usize,
) -> Result<Vec<C32>, GpuError> {
    let (dev, _) = run_on_rows(ctx, p, Kernel::FftColumns, work, &[], slots)?;
    read_complex(&dev, "work", work.len())
}

/// `fft_rows` from `work` (after `fft_columns`): the spectra in natural order.
pub fn fft_rows(
    ctx: &Arc<GpuContext>,
    p: &WelchParams,
    work: &[C32],
    slots: usize,
) -> Result<Vec<C32>, GpuError> {
    let (dev, _) = run_on_rows(ctx, p, Kernel::FftRows, work, &[], slots)?;
    read_complex(&dev, "spectrum", work.len())
}

/// `welch_power` from complex spectra (`slots` rows of `p.half`): |X_k|² rows of `p.bins`.
pub fn welch_power(
    ctx: &Arc<GpuContext>,
    p: &WelchParams,
    spectrum: &[C32],
    slots: usize,
) -> Result<Vec<f32>, GpuError> {
    let (dev, p) = run_on_rows(ctx, p, Kernel::WelchPower, &[], spectrum, slots)?;
    let mut power = dev.read_f32("power")?;
    power.truncate(slots * p.bins as usize);
    Ok(power)
}

/// `welch_accumulate`: `acc` (channels × bins) plus (or, with `reset`, replaced by) each
/// channel's column sums of `power` (channels × segments rows of bins).
pub fn welch_accumulate(
    ctx: &Arc<GpuContext>,
    params: &AccumulateParams,
    power: &[f32],
    acc: &[f32],
    channels: usize,
) -> Result<Vec<f32>, GpuError> {
    let p = WelchParams {
        nperseg: 1,
        nfft: 2 * (params.bins - 1),
        half: params.bins - 1,
        step: 1,
        segments: params.segments,
        input_stride: 1,
        bins: params.bins,
        detrend: 0,
        centre: 0.0,
        inv_n: 1.0,
        inv_stt: 0.0,
        split: 0,
    };
    let dev = welch_device(ctx, &p, &[1.0], channels, channels)?;
    dev.load_accumulate(params, power, acc);
    dev.run_kernel(Kernel::WelchAccumulate, params.segments as usize)?;
    let mut out = dev.read_f32("acc")?;
    out.truncate(acc.len());
    Ok(out)
}

fn read_complex(dev: &WelchDevice, which: &str, len: usize) -> Result<Vec<C32>, GpuError> {
    let flat = dev.read_f32(which)?;
    Ok(flat
        .chunks_exact(2)
        .take(len)
        .map(|c| [c[0], c[1]])
        .collect())
}

/// `avar_octave` on one level: terms `(hi[i] − lo[i])²` summed per workgroup (returned), and the
/// next level `(lo[i] + hi[i])/2` (returned when `write_next`).
pub fn avar_octave(
    ctx: &Arc<GpuContext>,
    p: &OctaveParams,
    lo: &[f32],
    hi: &[f32],
) -> Result<(Vec<f32>, Vec<f32>), GpuError> {
    run_octave_level(ctx, p, lo, hi)
}

/// `avar_prefix_f64` (needs SHADER_F64): partial sums of (s2 − 2·s1 + s0)² per workgroup.
pub fn avar_prefix_f64(
    ctx: &Arc<GpuContext>,
    p: &PrefixParams,
    s0: &[f64],
    s1: &[f64],
    s2: &[f64],
) -> Result<Vec<f64>, GpuError> {
    let out = run_prefix(ctx, p, PrefixData::F64([s0, s1, s2]))?;
    Ok(bytemuck::pod_collect_to_vec(&out))
}

/// `avar_prefix_fixed`: partial sums of (scale·(s2 − 2·s1 + s0))² per workgroup, the s as 64-bit
/// two's-complement (low, high) words.
pub fn avar_prefix_fixed(
    ctx: &Arc<GpuContext>,
    p: &PrefixParams,
    s0: &[[u32; 2]],
    s1: &[[u32; 2]],
    s2: &[[u32; 2]],
) -> Result<Vec<f32>, GpuError> {
    let out = run_prefix(ctx, p, PrefixData::Fixed([s0, s1, s2]))?;
    Ok(bytemuck::pod_collect_to_vec(&out))
}

/// (Internal) the twiddle table of `nfft`, as the kernels get it.
pub fn twiddle_table(nfft: usize) -> Vec<C32> {
    twiddles(nfft)
}
