//! Parameter blocks of the Welch kernels, laid out byte for byte as the WGSL structs.

use bytemuck::{Pod, Zeroable};

use crate::psd::{Detrend, WelchPlan};

/// Keep in sync with `WelchParams` in shaders/welch_common.wgsl.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct WelchParams {
    pub nperseg: u32,
    pub nfft: u32,
    /// nfft/2, the complex FFT length.
    pub half: u32,
    pub step: u32,
    /// Segments per channel in this batch.
    pub segments: u32,
    /// Samples per channel in the input buffer.
    pub input_stride: u32,
    /// nfft/2 + 1.
    pub bins: u32,
    /// 0 none, 1 constant, 2 linear.
    pub detrend: u32,
    /// (nperseg − 1)/2.
    pub centre: f32,
    pub inv_n: f32,
    /// 1/Σ(t − centre)², 0 when nperseg = 1.
    pub inv_stt: f32,
    /// Four-step row length M1 (0 on the local path).
    pub split: u32,
}

impl WelchParams {
    /// The per-plan fields; `segments` and `input_stride` are set per batch.
    pub fn for_plan(plan: &WelchPlan, split: usize) -> WelchParams {
        let n = plan.nperseg();
        let nf = n as f64;
        let stt = nf * (nf * nf - 1.0) / 12.0;
        WelchParams {
            nperseg: n as u32,
            nfft: plan.nfft() as u32,
            half: (plan.nfft() / 2) as u32,
            step: plan.step() as u32,
            segments: 0,
            input_stride: 0,
            bins: plan.bins() as u32,
            detrend: detrend_code(plan.config().detrend),
            centre: ((nf - 1.0) / 2.0) as f32,
            inv_n: (1.0 / nf) as f32,
            inv_stt: if stt > 0.0 { (1.0 / stt) as f32 } else { 0.0 },
            split: split as u32,
        }
    }
}

/// The `detrend` code of the kernels.
pub fn detrend_code(d: Detrend) -> u32 {
    match d {
        Detrend::None => 0,
        Detrend::Constant => 1,
        Detrend::Linear => 2,
    }
}

/// Keep in sync with `AccumulateParams` in shaders/welch_accumulate.wgsl.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Pod, Zeroable)]
pub struct AccumulateParams {
    pub bins: u32,
    /// Segments per channel in this batch.
    pub segments: u32,
    /// 1: overwrite the running sums, 0: add to them.
    pub reset: u32,
    pub _pad: u32,
}
