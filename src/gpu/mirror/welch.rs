//! CPU mirror of `shaders/welch_local.wgsl`, `welch_prepare.wgsl`, `welch_power.wgsl` and
//! `welch_accumulate.wgsl`, line for line, in f32. Per-thread partial sums are formed thread by
//! thread in the kernels' order so that the reductions round the same way.

use super::fft::{
    add, local_result, norm_sqr, stockham_local, twist, workgroup_sum, Workgroup, C32, WG,
};
use crate::gpu::welch::{AccumulateParams, WelchParams};

const DETREND_NONE: u32 = 0;
const DETREND_LINEAR: u32 = 2;
/// `BLOCK` of welch_prepare.wgsl.
const PREPARE_BLOCK: u32 = 64;
/// `BLOCK` of welch_accumulate.wgsl.
const ACCUMULATE_BLOCK: u32 = 32;

/// `welch_local` for every slot: rows of `bins` values of |X_k|², channel-major.
pub fn welch_local(
    p: &WelchParams,
    twiddles: &[C32],
    input: &[f32],
    window: &[f32],
    refs: &[f32],
    channels: usize,
    local_max: u32,
) -> Vec<f32> {
    let mut power = vec![0.0f32; channels * p.segments as usize * p.bins as usize];
    let mut wg = Workgroup::new(local_max);
    let wgs = WG as usize;
    for ch in 0..channels as u32 {
        for s in 0..p.segments {
            let slot = ch * p.segments + s;
            let base = (ch * p.input_stride + s * p.step) as usize;
            let half = p.half;

            let mut s1 = vec![0.0f32; wgs];
            for (tid, s1) in s1.iter_mut().enumerate() {
                let mut j = tid as u32;
                while j < half {
                    let t = 2 * j;
                    let mut v = [0.0f32; 2];
                    if t < p.nperseg {
                        v[0] = input[base + t as usize];
                    }
                    if t + 1 < p.nperseg {
                        v[1] = input[base + t as usize + 1];
                    }
                    wg.fa[j as usize] = v;
                    *s1 += v[0] + v[1];
                    j += WG;
                }
            }

            let mut mean = -refs[ch as usize];
            let mut slope = 0.0f32;
            if p.detrend != DETREND_NONE {
                let v1: Vec<C32> = s1.iter().map(|&s| [s, 0.0]).collect();
                let mean1 = workgroup_sum(&mut wg, &v1)[0] * p.inv_n;
                let mut s2 = vec![[0.0f32; 2]; wgs];
                for (tid, s2) in s2.iter_mut().enumerate() {
                    let mut j = tid as u32;
                    while j < half {
                        let t = 2 * j;
                        let v = wg.fa[j as usize];
                        if t < p.nperseg {
                            let d = v[0] - mean1;
                            *s2 = add(*s2, [d, d * (t as f32 - p.centre)]);
                        }
                        if t + 1 < p.nperseg {
                            let d = v[1] - mean1;
                            *s2 = add(*s2, [d, d * ((t + 1) as f32 - p.centre)]);
                        }
                        j += WG;
                    }
                }
                let sums = workgroup_sum(&mut wg, &s2);
                mean = mean1 + sums[0] * p.inv_n;
                if p.detrend == DETREND_LINEAR {
                    slope = sums[1] * p.inv_stt;
                }
            }

            for j in 0..half {
                let t = 2 * j;
                let mut v = wg.fa[j as usize];
                if t < p.nperseg {
                    v[0] = (v[0] - (mean + slope * (t as f32 - p.centre))) * window[t as usize];
                }
                if t + 1 < p.nperseg {
                    v[1] = (v[1] - (mean + slope * ((t + 1) as f32 - p.centre)))
                        * window[t as usize + 1];
                }
                wg.fa[j as usize] = v;
            }

            let in_b = stockham_local(&mut wg, twiddles, half, p.nfft);

            let row = (slot * p.bins) as usize;
            for k in 0..=half {
                let zk = local_result(&wg, in_b, k % half);
                let zmk = local_result(&wg, in_b, (half - k) % half);
                let x = twist(twiddles, zk, zmk, k);
                power[row + k as usize] = norm_sqr(x);
            }
        }
    }
    power
}

/// `welch_prepare` for every slot: the packed, detrended, windowed FFT input, rows of `half`.
pub fn welch_prepare(
    p: &WelchParams,
    input: &[f32],
    window: &[f32],
    refs: &[f32],
    channels: usize,
    local_max: u32,
) -> Vec<C32> {
    let mut work = vec![[0.0f32; 2]; channels * p.segments as usize * p.half as usize];
    let mut wg = Workgroup::new(local_max);
    let wgs = WG as usize;
    for ch in 0..channels as u32 {
        for s in 0..p.segments {
            let slot = ch * p.segments + s;
            let base = (ch * p.input_stride + s * p.step) as usize;

            let mut mean = -refs[ch as usize];
            let mut slope = 0.0f32;
            if p.detrend != DETREND_NONE {
                let mut v1 = vec![[0.0f32; 2]; wgs];
                for (tid, v1) in v1.iter_mut().enumerate() {
                    let mut outer = 0.0f32;
                    let mut inner = 0.0f32;
                    let mut count = 0u32;
                    let mut t = tid as u32;
                    while t < p.nperseg {
                        inner += input[base + t as usize];
                        count += 1;
                        if count == PREPARE_BLOCK {
                            outer += inner;
                            inner = 0.0;
                            count = 0;
                        }
                        t += WG;
                    }
                    *v1 = [outer + inner, 0.0];
                }
                let mean1 = workgroup_sum(&mut wg, &v1)[0] * p.inv_n;

                let mut v2 = vec![[0.0f32; 2]; wgs];
                for (tid, v2) in v2.iter_mut().enumerate() {
                    let mut outer2 = [0.0f32; 2];
                    let mut inner2 = [0.0f32; 2];
                    let mut count = 0u32;
                    let mut t = tid as u32;
                    while t < p.nperseg {
                        let d = input[base + t as usize] - mean1;
                        inner2 = add(inner2, [d, d * (t as f32 - p.centre)]);
                        count += 1;
                        if count == PREPARE_BLOCK {
                            outer2 = add(outer2, inner2);
                            inner2 = [0.0; 2];
                            count = 0;
                        }
                        t += WG;
                    }
                    *v2 = add(outer2, inner2);
                }
                let sums = workgroup_sum(&mut wg, &v2);
                mean = mean1 + sums[0] * p.inv_n;
                if p.detrend == DETREND_LINEAR {
                    slope = sums[1] * p.inv_stt;
                }
            }

            let row = (slot * p.half) as usize;
            for j in 0..p.half {
                let t = 2 * j;
                let mut v = [0.0f32; 2];
                if t < p.nperseg {
                    v[0] = (input[base + t as usize] - (mean + slope * (t as f32 - p.centre)))
                        * window[t as usize];
                }
                if t + 1 < p.nperseg {
                    v[1] = (input[base + t as usize + 1]
                        - (mean + slope * ((t + 1) as f32 - p.centre)))
                        * window[t as usize + 1];
                }
                work[row + j as usize] = v;
            }
        }
    }
    work
}

/// `welch_power` for every slot: |X_k|² from the complex spectra, rows of `bins`.
pub fn welch_power(p: &WelchParams, twiddles: &[C32], spectrum: &[C32], slots: usize) -> Vec<f32> {
    let mut power = vec![0.0f32; slots * p.bins as usize];
    let half = p.half;
    for slot in 0..slots as u32 {
        let row = (slot * half) as usize;
        for k in 0..p.bins {
            let x = twist(
                twiddles,
                spectrum[row + (k % half) as usize],
                spectrum[row + ((half - k) % half) as usize],
                k,
            );
            power[(slot * p.bins + k) as usize] = norm_sqr(x);
        }
    }
    power
}

/// `welch_accumulate`: adds (or, with `q.reset`, writes) each channel's column sums of `power`
/// into `acc` (channels × bins).
pub fn welch_accumulate(q: &AccumulateParams, power: &[f32], acc: &mut [f32], channels: usize) {
    let (bins, segments) = (q.bins, q.segments);
    for ch in 0..channels as u32 {
        for k in 0..bins {
            let mut outer = 0.0f32;
            let mut inner = 0.0f32;
            for s in 0..segments {
                inner += power[((ch * segments + s) * bins + k) as usize];
                if s % ACCUMULATE_BLOCK == ACCUMULATE_BLOCK - 1 {
                    outer += inner;
                    inner = 0.0;
                }
            }
            let i = (ch * bins + k) as usize;
            let prior = if q.reset == 0 { acc[i] } else { 0.0 };
            acc[i] = prior + (outer + inner);
        }
    }
}
