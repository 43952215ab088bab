//! The device side of one Welch job: its buffers and bind groups, made once, and the encoding of one
//! batch (every segment of every channel in one submission).

use std::sync::Arc;

use super::params::{AccumulateParams, WelchParams};
use crate::gpu::buffers::{bind_group, dispatch, Buf};
use crate::gpu::fft::{per_group, twiddles, FftAlgorithm};
use crate::gpu::readback::read_buffer;
use crate::gpu::shaders::{Kernel, WORKGROUP};
use crate::gpu::timing::{Stage, Stamp};
use crate::gpu::{GpuContext, GpuError};

/// Capacities of a job's buffers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Capacity {
    pub channels: usize,
    /// Segments per channel in one batch.
    pub segments: usize,
    /// Samples per channel in one batch.
    pub stride: usize,
}

/// Buffers, pipelines and bind groups of one Welch job.
pub(crate) struct WelchDevice {
    ctx: Arc<GpuContext>,
    cap: Capacity,
    template: WelchParams,
    algorithm: FftAlgorithm,
    params: Buf,
    acc_params: Buf,
    input: Buf,
    refs: Buf,
    power: Buf,
    acc: Buf,
    work: Option<Buf>,
    spectrum: Option<Buf>,
    /// The kernels of one batch, in order, with their bind groups.
    stages: Vec<(Kernel, wgpu::ComputePipeline, wgpu::BindGroup)>,
    /// The twiddle table and window: written once and only reached through the bind groups, but
    /// held (like every buffer here) for the job's lifetime, since a buffer back in the pool can be
    /// handed to another job and overwritten while this one's batches still read it.
    _resident: [Buf; 2],
}

impl WelchDevice {
    /// Allocates everything for batches of up to `cap`, with the plan's window and nfft (in
    /// `template`), and builds the bind groups of `algorithm`'s kernels.
    pub(crate) fn new(
        ctx: Arc<GpuContext>,
        template: WelchParams,
        window: &[f32],
        algorithm: FftAlgorithm,
        cap: Capacity,
    ) -> Result<WelchDevice, GpuError> {
        let slots = (cap.channels * cap.segments) as u64;
        let (half, bins) = (u64::from(template.half), u64::from(template.bins));
        let c = &*ctx;
        let tw = Buf::with_data(c, &twiddles(template.nfft as usize))?;
        let window = Buf::with_data(c, window)?;
        let params = Buf::uniform::<WelchParams>(c)?;
        let acc_params = Buf::uniform::<AccumulateParams>(c)?;
        let input = Buf::storage(c, (cap.channels * cap.stride) as u64 * 4)?;
        let refs = Buf::storage(c, cap.channels as u64 * 4)?;
        let power = Buf::storage(c, slots * bins * 4)?;
        let acc = Buf::storage(c, cap.channels as u64 * bins * 4)?;
        let (work, spectrum) = match algorithm {
            FftAlgorithm::Local => (None, None),
            FftAlgorithm::FourStep { .. } => (
                Some(Buf::storage(c, slots * half * 8)?),
                Some(Buf::storage(c, slots * half * 8)?),
            ),
        };

        let kernels: &[Kernel] = match algorithm {
            FftAlgorithm::Local => &[Kernel::WelchLocal, Kernel::WelchAccumulate],
            FftAlgorithm::FourStep { .. } => &[
                Kernel::WelchPrepare,
                Kernel::FftColumns,
                Kernel::FftRows,
                Kernel::WelchPower,
                Kernel::WelchAccumulate,
            ],
        };
        let mut stages = Vec::with_capacity(kernels.len());
        for &kernel in kernels {
            let pipeline = c.pipeline(kernel)?;
            let entries: Vec<(u32, wgpu::BindingResource<'_>)> = match kernel {
                Kernel::WelchLocal => vec![
                    (0, params.binding()),
                    (1, tw.binding()),
                    (2, input.binding()),
                    (3, window.binding()),
                    (4, refs.binding()),
                    (5, power.binding()),
                ],
                Kernel::WelchPrepare => vec![
                    (0, params.binding()),
                    (2, input.binding()),
                    (3, window.binding()),
                    (4, refs.binding()),
                    (5, work.as_ref().expect("four-step").binding()),
                ],
                Kernel::FftColumns => vec![
                    (0, params.binding()),
                    (1, tw.binding()),
                    (5, work.as_ref().expect("four-step").binding()),
                ],
                Kernel::FftRows => vec![
                    (0, params.binding()),
                    (1, tw.binding()),
                    (5, work.as_ref().expect("four-step").binding()),
                    (6, spectrum.as_ref().expect("four-step").binding()),
                ],
                Kernel::WelchPower => vec![
                    (0, params.binding()),
                    (1, tw.binding()),
                    (6, spectrum.as_ref().expect("four-step").binding()),
                    (7, power.binding()),
                ],
                Kernel::WelchAccumulate => vec![
                    (0, acc_params.binding()),
                    (1, power.binding()),
                    (2, acc.binding()),
                ],
                _ => unreachable!("not a Welch kernel"),
            };
            let group = bind_group(c, &pipeline, &entries);
            stages.push((kernel, pipeline, group));
        }
        ctx.check()?;
        Ok(WelchDevice {
            ctx,
            cap,
            template,
            algorithm,
            params,
            acc_params,
            input,
            refs,
            power,
            acc,
            work,
            spectrum,
            stages,
            _resident: [tw, window],
        })
    }

    pub(crate) fn capacity(&self) -> Capacity {
        self.cap
    }

    /// Runs one batch: `segments` segments of each channel, whose samples (relative to `refs`,
    /// channel-major, `stride` per channel, as f32) `fill` writes into the upload's staging
    /// memory. With `reset` the running sums start again from this batch. Only queues the work;
    /// results come with [`read_sums`](Self::read_sums).
    pub(crate) fn run_batch(
        &self,
        fill: impl FnOnce(wgpu::WriteOnly<'_, [u8]>),
        refs: &[f32],
        segments: usize,
        stride: usize,
        reset: bool,
    ) -> Result<(), GpuError> {
        debug_assert!(segments <= self.cap.segments && stride <= self.cap.stride);
        let params = WelchParams {
            segments: segments as u32,
            input_stride: stride as u32,
            ..self.template
        };
        self.params.write(&self.ctx, 0, &[params]);
        self.acc_params.write(
            &self.ctx,
            0,
            &[AccumulateParams {
                bins: self.template.bins,
                segments: segments as u32,
                reset: u32::from(reset),
                _pad: 0,
            }],
        );
        self.input
            .write_with(&self.ctx, 0, (self.cap.channels * stride * 4) as u64, fill);
        self.refs.write(&self.ctx, 0, refs);
        self.submit(&self.kernels(), segments)?;
        self.ctx.check()
    }

    /// The running sums Σ|X_k|² since the last reset, channel-major (channels × bins).
    pub(crate) fn read_sums(&self) -> Result<Vec<f32>, GpuError> {
        read_buffer(
            &self.ctx,
            self.acc.buffer(),
            0,
            self.cap.channels * self.template.bins as usize,
        )
    }

    /// The kernels of a batch, in order.
    fn kernels(&self) -> Vec<Kernel> {
        self.stages.iter().map(|s| s.0).collect()
    }

    /// Encodes and submits `kernels` for a batch of `segments` per channel.
    fn submit(&self, kernels: &[Kernel], segments: usize) -> Result<(), GpuError> {
        let mut encoder =
            self.ctx
                .device()
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("welch batch"),
                });
        let stamp = self.ctx.stamp(Stage::Welch);
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("welch"),
                timestamp_writes: stamp.as_ref().map(Stamp::writes),
            });
            for (kernel, pipeline, group) in &self.stages {
                if kernels.contains(kernel) {
                    dispatch(&mut pass, pipeline, group, self.groups(*kernel, segments));
                }
            }
        }
        self.ctx.submit_timed(encoder, stamp)
    }

    /// Workgroups of each kernel for `segments` segments per channel.
    fn groups(&self, kernel: Kernel, segments: usize) -> (u32, u32) {
        let channels = self.cap.channels as u32;
        let slots = channels * segments as u32;
        let bins_groups = self.template.bins.div_ceil(WORKGROUP);
        let (m1, m2) = match self.algorithm {
            FftAlgorithm::FourStep { m1, m2 } => (m1 as u32, m2 as u32),
            FftAlgorithm::Local => (0, 0),
        };
        match kernel {
            Kernel::WelchLocal | Kernel::WelchPrepare => (segments as u32, channels),
            Kernel::FftColumns => (m1 / self.per_group(m1, m2), slots),
            Kernel::FftRows => (m2 / self.per_group(m2, m1), slots),
            Kernel::WelchPower => (bins_groups, slots),
            Kernel::WelchAccumulate => (bins_groups, channels),
            _ => (0, 0),
        }
    }

    /// Transforms of length `len` per workgroup in a four-step pass (see [`per_group`]).
    fn per_group(&self, available: u32, len: u32) -> u32 {
        per_group(
            available as usize,
            len as usize,
            self.ctx.local_fft_size() as usize,
        ) as u32
    }

    // Single-kernel access, for checking each kernel against its CPU mirror (`gpu::kernels`).

    /// Writes the per-batch parameters and inputs without running anything.
    pub(crate) fn load(&self, params: &WelchParams, input: &[f32], refs: &[f32]) {
        self.params.write(&self.ctx, 0, &[*params]);
        self.input.write(&self.ctx, 0, input);
        self.refs.write(&self.ctx, 0, refs);
    }

    /// Writes the accumulation parameters and, when given, the running sums.
    pub(crate) fn load_accumulate(&self, params: &AccumulateParams, power: &[f32], acc: &[f32]) {
        self.acc_params.write(&self.ctx, 0, &[*params]);
        self.power.write(&self.ctx, 0, power);
        self.acc.write(&self.ctx, 0, acc);
    }

    /// Writes the complex work array (input of `fft_columns`/`fft_rows`) or spectrum (input of
    /// `welch_power`).
    pub(crate) fn load_complex(&self, work: &[[f32; 2]], spectrum: &[[f32; 2]]) {
        if let Some(w) = &self.work {
            w.write(&self.ctx, 0, work);
        }
        if let Some(s) = &self.spectrum {
            s.write(&self.ctx, 0, spectrum);
        }
    }

    /// Runs one kernel on what was loaded.
    pub(crate) fn run_kernel(&self, kernel: Kernel, segments: usize) -> Result<(), GpuError> {
        self.submit(&[kernel], segments)?;
        self.ctx.wait()
    }

    /// Reads back one of the job's arrays: `power`, `acc`, `work` or `spectrum`.
    pub(crate) fn read_f32(&self, which: &str) -> Result<Vec<f32>, GpuError> {
        let buf = match which {
            "power" => &self.power,
            "acc" => &self.acc,
            "work" => self.work.as_ref().expect("four-step"),
            "spectrum" => self.spectrum.as_ref().expect("four-step"),
            other => panic!("no array {other}"),
        };
        read_buffer(&self.ctx, buf.buffer(), 0, (buf.size() / 4) as usize)
    }
}
