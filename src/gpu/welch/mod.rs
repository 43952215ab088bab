//! Welch PSD on the GPU, with the CPU path's definitions (scipy.signal.welch): the same segments,
//! detrending, window, scaling and one-sided fold, agreeing to f32 accuracy.
//!
//! Per batch, one submission runs every segment of every channel: gather the segment from the
//! uploaded samples, detrend (constant or linear) and window, real FFT (complex FFT of nfft/2 and
//! the twist; see [`fft`](super::fft)), |X_k|², and the sum over the batch's segments into per-channel
//! running sums that stay on the device. Only the sums come back (once per push, see
//! [`GpuWelch`]); scaling, folding, frequencies and EDF are then done by the CPU code
//! (`Psd::from_averaged`), so the two paths cannot disagree on conventions.
//!
//! Precision: samples are uploaded in f32 after subtracting a per-batch reference in f64 (the batch
//! mean), so a sensor bias of 10⁴σ costs no digits of the noise; segment means use two passes (a
//! first estimate, then the mean of the residuals); sums over segments are blocked so that no f32
//! sum holds more than a few dozen terms; and the per-push sums are added in f64 on the host.
//!
//! Not on the GPU (the backend runs the CPU path and records why): median averaging (needs every
//! segment's periodogram), nfft that is not a power of two, nfft beyond 2·L² (L the workgroup FFT
//! size: 2^23 with 32 KiB of workgroup memory), and jobs whose single segment does not fit the
//! device's binding limit.

mod device;
mod params;
mod sink;

pub(crate) use device::{Capacity, WelchDevice};
pub use params::{detrend_code, AccumulateParams, WelchParams};
pub use sink::GpuWelch;

use super::chunking::{welch_batch, Caps, WelchShape};
use super::fft::{algorithm, max_nfft, FftAlgorithm};
use super::{FallbackReason, GpuContext};
use crate::psd::{Average, WelchPlan};

/// How the GPU runs a plan: the FFT algorithm and the segments per channel in one batch.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WelchLayout {
    pub algorithm: FftAlgorithm,
    pub batch: usize,
}

/// Whether (and how) `ctx` can run `plan` for `channels` channels; the reason when it cannot.
pub fn layout(
    ctx: &GpuContext,
    plan: &WelchPlan,
    channels: usize,
) -> Result<WelchLayout, FallbackReason> {
    let unsupported = |why: String| Err(FallbackReason::Unsupported(why));
    let nfft = plan.nfft();
    if plan.config().average == Average::Median {
        return unsupported("median averaging keeps every segment's periodogram".into());
    }
    if !nfft.is_power_of_two() {
        return unsupported(format!("nfft = {nfft} is not a power of two"));
    }
    let local = ctx.local_fft_size() as usize;
    let Some(algorithm) = algorithm(nfft, local) else {
        return unsupported(format!(
            "nfft = {nfft} exceeds {} on this device",
            max_nfft(local)
        ));
    };
    if channels == 0 {
        return Ok(WelchLayout {
            algorithm,
            batch: 1,
        });
    }
    let shape = WelchShape {
        nperseg: plan.nperseg(),
        step: plan.step(),
        half: nfft / 2,
        bins: plan.bins(),
        channels,
        multipass: algorithm != FftAlgorithm::Local,
    };
    match welch_batch(&shape, &Caps::of(ctx)) {
        Ok(batch) => Ok(WelchLayout { algorithm, batch }),
        Err(e) => unsupported(e.to_string()),
    }
}
