//! Streaming Welch on the GPU: the same contract as the CPU's `WelchAccumulator` (chunks of any
//! size, memory bounded by the segment length), and the same result.
//!
//! Per channel the host keeps the samples after the start of the next incomplete segment (fewer than
//! nperseg, in f64, exactly as the CPU accumulator does). Each push uploads `held ++ chunk` batch by
//! batch (a batch re-uploads the overlap it shares with the previous one, so overlapping segments
//! are exact) and queues the kernels; at the end of the push the device's running sums are read once
//! and added, in f64, to the host's. That read is also the push's check that the device is healthy.
//!
//! Failure: if anything fails during a push (device lost, out of memory, a validation error), the
//! push's partial GPU sums are discarded and a CPU `WelchAccumulator` takes over from the state
//! before the push (the held samples plus the chunk), and keeps every later push. `finish` adds
//! the CPU's sums to the GPU's from the pushes that completed, so every segment is counted once, by
//! one path or the other, and nothing computed after the failure is used. Reading the sums once
//! per push is what makes this possible without keeping past samples; it costs one
//! synchronisation per push, which is small next to a push's worth of segments.
//!
//! Host memory: the held samples (fewer than nperseg per channel, as on the CPU) and the queue's
//! staging memory for one batch in flight (the samples are converted straight into it), whose
//! size the device limits and the memory budget bound.

use std::sync::Arc;

use super::device::{Capacity, WelchDevice};
use super::params::WelchParams;
use super::{layout, WelchLayout};
use crate::estimate::WelchSink;
use crate::gpu::fallback::{FallbackLog, Task};
use crate::gpu::fft::FftAlgorithm;
use crate::gpu::staging;
use crate::gpu::{FallbackReason, GpuContext, GpuError};
use crate::psd::{Detrend, Psd, PsdError, WelchAccumulator, WelchPlan};

/// Batches between read-backs of the device sums within one push: bounds how many batch sums are
/// added in f32 on the device before the f64 host sum takes over.
const FLUSH_BATCHES: usize = 16;

/// A Welch estimate in progress on the GPU, for all channels of one recording.
pub struct GpuWelch {
    plan: WelchPlan,
    rate_hz: f64,
    channels: usize,
    engine: Engine,
    /// Per channel: samples from the start of the next segment (GPU mode only).
    held: Vec<Vec<f64>>,
    received: usize,
    /// Segments per channel whose sums are in `sums`.
    gpu_segments: usize,
    /// Per channel, per bin: Σ|X_k|² of the GPU segments, in f64.
    sums: Vec<Vec<f64>>,
    peak_buffered: usize,
    error: Option<PsdError>,
    log: Option<Arc<FallbackLog>>,
    spec: DeviceSpec,
}

/// What the device side is built from. Its buffers are sized for the largest push seen so far (at
/// most `max_batch` segments per channel, the most the device's limits allow), not for the limits:
/// a short recording should not allocate hundreds of megabytes.
struct DeviceSpec {
    ctx: Arc<GpuContext>,
    template: WelchParams,
    window: Vec<f32>,
    algorithm: FftAlgorithm,
    max_batch: usize,
    channels: usize,
}

impl DeviceSpec {
    fn build(&self, segments: usize) -> Result<WelchDevice, GpuError> {
        let cap = Capacity {
            channels: self.channels,
            segments,
            stride: (segments - 1) * self.template.step as usize + self.template.nperseg as usize,
        };
        WelchDevice::new(
            Arc::clone(&self.ctx),
            self.template,
            &self.window,
            self.algorithm,
            cap,
        )
    }
}

enum Engine {
    Gpu(Box<WelchDevice>),
    Cpu(Box<WelchAccumulator>),
}

impl GpuWelch {
    /// A GPU Welch estimate of `channels` channels at `rate_hz`, or the reason the plan cannot run
    /// on this device (see [`layout`](super::layout)) or the device failed to allocate.
    ///
    /// An invalid rate is reported by `finish`, as the CPU accumulator does.
    pub fn new(
        ctx: Arc<GpuContext>,
        plan: WelchPlan,
        rate_hz: f64,
        channels: usize,
    ) -> Result<GpuWelch, FallbackReason> {
        let WelchLayout { algorithm, batch } = layout(&ctx, &plan, channels)?;
        let split = match algorithm {
            FftAlgorithm::FourStep { m1, .. } => m1,
            FftAlgorithm::Local => 0,
        };
        let spec = DeviceSpec {
            ctx,
            template: WelchParams::for_plan(&plan, split),
            window: plan.window().iter().map(|&w| w as f32).collect(),
            algorithm,
            max_batch: batch,
            channels: channels.max(1),
        };
        // A one-segment device now, so that a device that cannot even do that fails here (and the
        // backend uses the CPU from the start); pushes grow it as needed.
        let device = spec.build(1).map_err(FallbackReason::Failed)?;
        let error = (!(rate_hz.is_finite() && rate_hz > 0.0)).then(|| {
            PsdError::InvalidConfig(format!(
                "sample rate must be finite and positive, got {rate_hz}"
            ))
        });
        Ok(GpuWelch {
            held: (0..channels)
                .map(|_| Vec::with_capacity(plan.nperseg()))
                .collect(),
            sums: vec![vec![0.0; plan.bins()]; channels],
            plan,
            rate_hz,
            channels,
            engine: Engine::Gpu(Box::new(device)),
            received: 0,
            gpu_segments: 0,
            peak_buffered: 0,
            error,
            log: None,
            spec,
        })
    }

    /// Records mid-stream fallbacks in `log` (the backend's).
    pub fn with_log(mut self, log: Arc<FallbackLog>) -> GpuWelch {
        self.log = Some(log);
        self
    }

    /// Whether the estimate is still on the GPU (false after a mid-stream fallback).
    pub fn on_gpu(&self) -> bool {
        matches!(self.engine, Engine::Gpu(_))
    }

    /// Samples received per channel.
    pub fn samples(&self) -> usize {
        self.received
    }

    /// Feeds the next samples of every channel (one slice per channel, equal lengths); misuse is
    /// reported by `finish`, as with the CPU accumulator.
    pub fn push(&mut self, chunk: &[&[f64]]) {
        if self.error.is_some() {
            return;
        }
        if let Err(e) = self.check(chunk) {
            self.error = Some(e);
            return;
        }
        let len = chunk.first().map_or(0, |c| c.len());
        if let Engine::Cpu(acc) = &mut self.engine {
            acc.push(chunk);
            self.received += len;
            self.peak_buffered = self.peak_buffered.max(acc.peak_buffered_samples());
            return;
        }
        if len == 0 {
            return;
        }
        let held = self.held.first().map_or(0, Vec::len);
        let nseg = self.plan.segments_for(held + len);
        if nseg > 0 {
            match self.process(chunk, nseg) {
                Ok(sums) => {
                    for (total, add) in self.sums.iter_mut().zip(sums.chunks(self.plan.bins())) {
                        for (t, a) in total.iter_mut().zip(add) {
                            *t += a;
                        }
                    }
                    self.gpu_segments += nseg;
                }
                Err(e) => {
                    self.fall_back(e, chunk);
                    self.received += len;
                    return;
                }
            }
        }
        self.received += len;
        let consumed = nseg * self.plan.step();
        for (h, x) in self.held.iter_mut().zip(chunk) {
            if consumed >= h.len() {
                let skip = consumed - h.len();
                h.clear();
                h.extend_from_slice(&x[skip..]);
            } else {
                h.drain(..consumed);
                h.extend_from_slice(x);
            }
        }
        self.peak_buffered = self
            .peak_buffered
            .max(self.held.first().map_or(0, Vec::len));
    }

    /// The CPU accumulator's checks, so that misuse gives the same error on either backend.
    fn check(&self, chunk: &[&[f64]]) -> Result<(), PsdError> {
        crate::psd::check_chunk(chunk, self.channels)
    }

    /// Runs the `nseg` segments complete in `held ++ chunk` on the device and returns their
    /// Σ|X_k|², channel-major: the device's f32 sums (each over at most FLUSH_BATCHES batches)
    /// added in f64.
    fn process(&mut self, chunk: &[&[f64]], nseg: usize) -> Result<Vec<f64>, GpuError> {
        let Engine::Gpu(device) = &mut self.engine else {
            unreachable!("only called on the GPU path")
        };
        let have = device.capacity().segments;
        let want = nseg.min(self.spec.max_batch);
        if have < want {
            // Grow geometrically, so that a stream of slowly growing pushes rebuilds rarely.
            let grown = want.max(2 * have).min(self.spec.max_batch);
            **device = self.spec.build(grown)?;
        }
        let batch = device.capacity().segments;
        let (step, n) = (self.plan.step(), self.plan.nperseg());
        let bins = self.plan.bins();
        let subtract_mean = self.plan.config().detrend != Detrend::None;
        let mut out = vec![0.0f64; self.channels * bins];
        let mut refs = vec![0.0f32; self.channels];
        let mut pending = 0;
        let mut s0 = 0;
        while s0 < nseg {
            let count = batch.min(nseg - s0);
            let start = s0 * step;
            let stride = (count - 1) * step + n;
            // Each channel's part of the batch, and its reference: the batch mean, in f64, so
            // that what is left fits f32 with the noise's own digits. Detrending removes it
            // again; without detrending the kernel adds it back, so it is not used there.
            let parts: Vec<(&[f64], &[f64], f64)> = self
                .held
                .iter()
                .zip(chunk)
                .map(|(held, x)| {
                    let (a, b) = split_range(held, x, start, stride);
                    let reference = if subtract_mean {
                        staging::sum(a, b) / stride as f64
                    } else {
                        0.0
                    };
                    (a, b, reference)
                })
                .collect();
            for (r, part) in refs.iter_mut().zip(&parts) {
                *r = part.2 as f32;
            }
            let fill = |mut dst: wgpu::WriteOnly<'_, [u8]>| {
                for &(a, b, reference) in &parts {
                    let (row, rest) = dst.split_at(4 * stride);
                    staging::fill_converted(row, a, b, reference);
                    dst = rest;
                }
            };
            device.run_batch(fill, &refs, count, stride, pending == 0)?;
            pending += 1;
            if pending == FLUSH_BATCHES {
                add_into(&mut out, &device.read_sums()?);
                pending = 0;
            }
            s0 += count;
        }
        if pending > 0 {
            add_into(&mut out, &device.read_sums()?);
        }
        Ok(out)
    }

    /// Switches to the CPU after a failure during the push of `chunk`: the CPU accumulator starts
    /// from the samples held before the push, then takes the chunk.
    fn fall_back(&mut self, e: GpuError, chunk: &[&[f64]]) {
        if let Some(log) = &self.log {
            log.record(Task::Welch, FallbackReason::Failed(e));
        }
        let mut acc = WelchAccumulator::new(self.plan.clone(), self.rate_hz, self.channels);
        let held: Vec<&[f64]> = self.held.iter().map(Vec::as_slice).collect();
        acc.push(&held);
        acc.push(chunk);
        self.peak_buffered = self.peak_buffered.max(acc.peak_buffered_samples());
        self.held = Vec::new();
        self.engine = Engine::Cpu(Box::new(acc));
    }

    /// The PSD of every channel.
    ///
    /// Errors: `TooShort` when no segment was formed, and any misuse recorded by `new` or `push`.
    pub fn finish(self) -> Result<Vec<Psd>, PsdError> {
        if let Some(e) = self.error {
            return Err(e);
        }
        if self.channels == 0 {
            return Ok(Vec::new());
        }
        let plan = self.plan;
        let gpu_m = self.gpu_segments;
        let mut sums = self.sums;
        let mut m = gpu_m;
        if let Engine::Cpu(acc) = self.engine {
            let cpu_m = acc.segments();
            if gpu_m == 0 {
                return acc.finish();
            }
            if cpu_m > 0 {
                let cpu = acc.finish()?;
                for (total, psd) in sums.iter_mut().zip(&cpu) {
                    for (k, (t, v)) in total.iter_mut().zip(&psd.value).enumerate() {
                        *t += raw_mean(&plan, self.rate_hz, k, *v) * cpu_m as f64;
                    }
                }
                m += cpu_m;
            }
        }
        if m == 0 {
            return Err(PsdError::TooShort {
                n: self.received,
                nperseg: plan.nperseg(),
            });
        }
        let dof = Psd::bin_dof(&plan, m);
        Ok(sums
            .into_iter()
            .map(|s| {
                let raw = s.iter().map(|v| v / m as f64).collect();
                Psd::from_averaged(&plan, self.rate_hz, m, raw, dof.clone())
            })
            .collect())
    }
}

/// The mean |X_k|² behind bin k of a finished PSD: its value without the scaling and the
/// one-sided doubling (every bin but DC and, for even nfft, Nyquist).
fn raw_mean(plan: &WelchPlan, rate_hz: f64, k: usize, value: f64) -> f64 {
    let scale = plan
        .config()
        .scaling
        .factor(rate_hz, plan.sum_w(), plan.sum_w2());
    let bins = plan.bins();
    let doubled_end = if plan.nfft().is_multiple_of(2) {
        bins - 1
    } else {
        bins
    };
    let fold = if k >= 1 && k < doubled_end { 2.0 } else { 1.0 };
    value / (scale * fold)
}

fn add_into(out: &mut [f64], sums: &[f32]) {
    for (o, s) in out.iter_mut().zip(sums) {
        *o += f64::from(*s);
    }
}

/// Samples [start, start + len) of `held ++ chunk`, as (part in `held`, part in `chunk`).
fn split_range<'a>(
    held: &'a [f64],
    chunk: &'a [f64],
    start: usize,
    len: usize,
) -> (&'a [f64], &'a [f64]) {
    if start >= held.len() {
        let s = start - held.len();
        (&[], &chunk[s..s + len])
    } else {
        let in_held = (held.len() - start).min(len);
        (&held[start..start + in_held], &chunk[..len - in_held])
    }
}

impl WelchSink for GpuWelch {
    fn push(&mut self, chunk: &[&[f64]]) {
        GpuWelch::push(self, chunk)
    }
    fn finish(self: Box<Self>) -> Result<Vec<Psd>, PsdError> {
        GpuWelch::finish(*self)
    }
    fn peak_buffered_samples(&self) -> usize {
        self.peak_buffered
    }
}
