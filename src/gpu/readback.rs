//! Reading results back: the one place where the host waits for the device.
//!
//! copy → map_async → poll → get_mapped_range → unmap, with every failure on the way (device lost,
//! map refused, an error reported earlier by the device) returned as a [`GpuError`]: a caller either
//! gets the numbers the kernels wrote or an error, never a buffer of stale or zeroed memory.

use std::sync::mpsc;

use super::{GpuContext, GpuError};

/// Copies `count` values of `T` starting at byte `offset` of `src` (which needs COPY_SRC usage)
/// back to the host, after all work submitted so far.
pub(crate) fn read_buffer<T: bytemuck::Pod>(
    ctx: &GpuContext,
    src: &wgpu::Buffer,
    offset: u64,
    count: usize,
) -> Result<Vec<T>, GpuError> {
    let size = (count * std::mem::size_of::<T>()) as u64;
    if size == 0 {
        return Ok(Vec::new());
    }
    // Copies must be a multiple of 4 bytes; T is f32, f64 or u32 here, so they are. The staging
    // buffer is not pooled: after a failed map it could be left mapped.
    let staging = ctx.device().create_buffer(&wgpu::BufferDescriptor {
        label: Some("read back"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    ctx.check()?;
    let mut encoder = ctx
        .device()
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("read back"),
        });
    encoder.copy_buffer_to_buffer(src, offset, &staging, 0, size);
    ctx.queue().submit([encoder.finish()]);

    let (tx, rx) = mpsc::channel();
    staging.map_async(wgpu::MapMode::Read, 0..size, move |r| {
        // The receiver outlives the poll below; a send error cannot happen.
        let _ = tx.send(r);
    });
    ctx.wait()?;
    rx.recv()
        .map_err(|_| GpuError::Readback("map callback never ran".into()))?
        .map_err(|e| GpuError::Readback(e.to_string()))?;
    let out = {
        let view = staging
            .get_mapped_range(0..size)
            .map_err(|e| GpuError::Readback(e.to_string()))?;
        bytemuck::pod_collect_to_vec(&view)
    };
    staging.unmap();
    ctx.check()?;
    Ok(out)
}
