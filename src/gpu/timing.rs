//! Device time of the kernels, read from GPU timestamps, for benchmarks: how long the GPU itself
//! was busy, apart from uploads, read-backs and the host work around them, so that a run can say
//! which fraction of the device's memory bandwidth the kernels reach.
//!
//! Off unless the context was opened with [`ContextOptions::kernel_timing`](super::ContextOptions)
//! on an adapter with `TIMESTAMP_QUERY`. When on, every compute pass writes a timestamp at its
//! start and end, and the submission is waited for at once to read them: the work is serialised
//! (no overlap of the next upload with the running kernels), which is what a kernel measurement
//! wants and what a production run must not pay. A pass holds all the dispatches of one
//! submission (a Welch batch, a group of Allan levels), so the figure is the pass's span,
//! including the device's gaps between its dispatches.

use std::sync::{mpsc, Mutex, PoisonError};
use std::time::Duration;

use super::GpuError;

/// Which estimator a pass belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    Welch,
    Allan,
}

/// Accumulated device time per estimator since the context was opened (or last reset).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct KernelTimes {
    pub welch: Duration,
    pub welch_passes: u32,
    pub allan: Duration,
    pub allan_passes: u32,
}

/// The totals and the tick length of the queue's timestamps.
#[derive(Debug)]
pub(crate) struct KernelTimer {
    period_ns: f64,
    totals: Mutex<KernelTimes>,
}

/// One pass's pair of timestamps, from its recording to its read-back.
pub(crate) struct Stamp {
    stage: Stage,
    queries: wgpu::QuerySet,
    resolved: wgpu::Buffer,
    staging: wgpu::Buffer,
}

const STAMP_BYTES: u64 = 2 * std::mem::size_of::<u64>() as u64;

impl KernelTimer {
    pub(crate) fn new(queue: &wgpu::Queue) -> KernelTimer {
        KernelTimer {
            period_ns: f64::from(queue.get_timestamp_period()),
            totals: Mutex::new(KernelTimes::default()),
        }
    }

    /// A fresh pair of queries for one pass of `stage`.
    pub(crate) fn stamp(&self, device: &wgpu::Device, stage: Stage) -> Stamp {
        let queries = device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("kernel time"),
            ty: wgpu::QueryType::Timestamp,
            count: 2,
        });
        let resolved = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("kernel time (resolved)"),
            size: STAMP_BYTES,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let staging = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("kernel time (read back)"),
            size: STAMP_BYTES,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Stamp {
            stage,
            queries,
            resolved,
            staging,
        }
    }

    /// Waits for the submission that holds `stamp` and adds its span to the totals.
    pub(crate) fn collect(&self, device: &wgpu::Device, stamp: Stamp) -> Result<(), GpuError> {
        let (tx, rx) = mpsc::channel();
        stamp
            .staging
            .map_async(wgpu::MapMode::Read, 0..STAMP_BYTES, move |r| {
                let _ = tx.send(r);
            });
        device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::DeviceLost(e.to_string()))?;
        rx.recv()
            .map_err(|_| GpuError::Readback("map callback never ran".into()))?
            .map_err(|e| GpuError::Readback(e.to_string()))?;
        let ticks: Vec<u64> = {
            let view = stamp
                .staging
                .get_mapped_range(0..STAMP_BYTES)
                .map_err(|e| GpuError::Readback(e.to_string()))?;
            bytemuck::pod_collect_to_vec(&view)
        };
        stamp.staging.unmap();
        let span = Duration::from_nanos(
            (ticks[1].saturating_sub(ticks[0]) as f64 * self.period_ns).round() as u64,
        );
        let mut totals = self.totals.lock().unwrap_or_else(PoisonError::into_inner);
        match stamp.stage {
            Stage::Welch => {
                totals.welch += span;
                totals.welch_passes += 1;
            }
            Stage::Allan => {
                totals.allan += span;
                totals.allan_passes += 1;
            }
        }
        Ok(())
    }

    pub(crate) fn totals(&self) -> KernelTimes {
        *self.totals.lock().unwrap_or_else(PoisonError::into_inner)
    }

    pub(crate) fn reset(&self) {
        *self.totals.lock().unwrap_or_else(PoisonError::into_inner) = KernelTimes::default();
    }
}

impl Stamp {
    /// The pass descriptor's timestamp writes: the first query at the start, the second at the end.
    pub(crate) fn writes(&self) -> wgpu::ComputePassTimestampWrites<'_> {
        wgpu::ComputePassTimestampWrites {
            query_set: &self.queries,
            beginning_of_pass_write_index: Some(0),
            end_of_pass_write_index: Some(1),
        }
    }

    /// Records, after the pass, the copy of both timestamps to where they can be read.
    pub(crate) fn resolve(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.resolve_query_set(&self.queries, 0..2, &self.resolved, 0);
        encoder.copy_buffer_to_buffer(&self.resolved, 0, &self.staging, 0, STAMP_BYTES);
    }
}
