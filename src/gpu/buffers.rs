//! Small helpers shared by the jobs: a pooled buffer with its logical size (pooled buffers are
//! rounded up, so bindings must name the size), bind groups from a kernel's own layout, and one
//! compute dispatch.

use std::num::NonZeroU64;

use super::pool::Lease;
use super::{GpuContext, GpuError};

/// A pooled buffer and the number of bytes in use.
pub(crate) struct Buf {
    lease: Lease,
    size: u64,
}

impl Buf {
    /// A storage buffer of `size` bytes that can be written from and read back to the host.
    pub(crate) fn storage(ctx: &GpuContext, size: u64) -> Result<Buf, GpuError> {
        let size = size.max(4);
        let usage = wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_DST
            | wgpu::BufferUsages::COPY_SRC;
        Ok(Buf {
            lease: ctx.buffer(usage, size)?,
            size,
        })
    }

    /// A storage buffer holding `data`.
    pub(crate) fn with_data<T: bytemuck::Pod>(
        ctx: &GpuContext,
        data: &[T],
    ) -> Result<Buf, GpuError> {
        let buf = Buf::storage(ctx, std::mem::size_of_val(data) as u64)?;
        buf.write(ctx, 0, data);
        Ok(buf)
    }

    /// A pooled buffer used whole.
    pub(crate) fn from_lease(lease: Lease) -> Buf {
        let size = lease.size();
        Buf { lease, size }
    }

    /// A uniform buffer for one `T`.
    pub(crate) fn uniform<T: bytemuck::Pod>(ctx: &GpuContext) -> Result<Buf, GpuError> {
        let size = std::mem::size_of::<T>() as u64;
        let usage = wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST;
        Ok(Buf {
            lease: ctx.buffer(usage, size)?,
            size,
        })
    }

    /// Queues a write of `bytes` bytes at byte `offset` (done before the next submission runs),
    /// which `fill` writes straight into the queue's staging memory: no host copy of the data is
    /// made first. A write the device refuses is reported through the context's error callback,
    /// as a refused `write` is.
    pub(crate) fn write_with(
        &self,
        ctx: &GpuContext,
        offset: u64,
        bytes: u64,
        fill: impl FnOnce(wgpu::WriteOnly<'_, [u8]>),
    ) {
        let Some(size) = NonZeroU64::new(bytes) else {
            return;
        };
        if let Some(mut view) = ctx.queue().write_buffer_with(&self.lease, offset, size) {
            fill(view.slice(..));
        }
    }

    /// Queues a write of `data` at byte `offset` (done before the next submission runs).
    pub(crate) fn write<T: bytemuck::Pod>(&self, ctx: &GpuContext, offset: u64, data: &[T]) {
        if !data.is_empty() {
            ctx.queue()
                .write_buffer(&self.lease, offset, bytemuck::cast_slice(data));
        }
    }

    /// The whole logical range as a binding.
    pub(crate) fn binding(&self) -> wgpu::BindingResource<'_> {
        self.range(0, self.size)
    }

    /// `size` bytes from `offset` as a binding.
    pub(crate) fn range(&self, offset: u64, size: u64) -> wgpu::BindingResource<'_> {
        wgpu::BindingResource::Buffer(wgpu::BufferBinding {
            buffer: &self.lease,
            offset,
            size: NonZeroU64::new(size),
        })
    }

    pub(crate) fn buffer(&self) -> &wgpu::Buffer {
        &self.lease
    }

    pub(crate) fn size(&self) -> u64 {
        self.size
    }
}

/// A bind group for group 0 of `pipeline` (its layout derived from the kernel, so `entries` must
/// list exactly the bindings the kernel uses).
pub(crate) fn bind_group(
    ctx: &GpuContext,
    pipeline: &wgpu::ComputePipeline,
    entries: &[(u32, wgpu::BindingResource<'_>)],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry<'_>> = entries
        .iter()
        .map(|(binding, resource)| wgpu::BindGroupEntry {
            binding: *binding,
            resource: resource.clone(),
        })
        .collect();
    ctx.device().create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
    })
}

/// Records one dispatch of `groups` workgroups.
pub(crate) fn dispatch(
    pass: &mut wgpu::ComputePass<'_>,
    pipeline: &wgpu::ComputePipeline,
    bind_group: &wgpu::BindGroup,
    groups: (u32, u32),
) {
    if groups.0 == 0 || groups.1 == 0 {
        return;
    }
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, bind_group, &[]);
    pass.dispatch_workgroups(groups.0, groups.1, 1);
}
