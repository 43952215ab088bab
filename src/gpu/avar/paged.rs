//! A long array on the device, in pages of at most `max_buffer_size`, read through windows no
//! larger than the binding limit (see [`chunking`](crate::gpu::chunking)).

use super::passes::View;
use crate::gpu::buffers::Buf;
use crate::gpu::chunking::Paging;
use crate::gpu::staging;
use crate::gpu::{GpuContext, GpuError};

pub(crate) struct Paged {
    pages: Vec<Buf>,
    paging: Paging,
    len: usize,
}

impl Paged {
    /// Room for `len` values laid out by `paging`.
    pub(crate) fn new(ctx: &GpuContext, paging: Paging, len: usize) -> Result<Paged, GpuError> {
        let pages = (0..paging.pages(len))
            .map(|p| Buf::storage(ctx, paging.page_len_of(p, len).max(1) as u64 * paging.elem))
            .collect::<Result<_, _>>()?;
        Ok(Paged { pages, paging, len })
    }

    /// Queues the upload of `data` (`len` values of `paging.elem` bytes), copied on every core
    /// straight into the queue's staging memory.
    pub(crate) fn upload<T: bytemuck::Pod>(&self, ctx: &GpuContext, data: &[T]) {
        debug_assert_eq!(data.len(), self.len);
        debug_assert_eq!(std::mem::size_of::<T>() as u64, self.paging.elem);
        for (p, page) in self.pages.iter().enumerate() {
            let start = p * self.paging.page_len;
            let end = start + self.paging.page_len_of(p, self.len);
            let src = &data[start..end];
            page.write_with(ctx, 0, std::mem::size_of_val(src) as u64, |dst| {
                staging::fill_copy(dst, src)
            });
        }
    }

    /// Queues the upload of `(v − reference) as f32` of every `v` of `y` (`len` values of 4
    /// bytes), converted on every core straight into the queue's staging memory.
    pub(crate) fn upload_converted(&self, ctx: &GpuContext, y: &[f64], reference: f64) {
        debug_assert_eq!(y.len(), self.len);
        debug_assert_eq!(self.paging.elem, 4);
        for (p, page) in self.pages.iter().enumerate() {
            let start = p * self.paging.page_len;
            let src = &y[start..start + self.paging.page_len_of(p, self.len)];
            page.write_with(ctx, 0, 4 * src.len() as u64, |dst| {
                staging::fill_converted(dst, src, &[], reference)
            });
        }
    }

    /// The window through which a dispatch reads values [start, start + count), and the index of
    /// `start` inside it.
    pub(crate) fn view(&self, start: usize, count: usize) -> (View<'_>, u32) {
        let w = self.paging.window(start, count, self.len);
        (
            View {
                buf: &self.pages[w.page],
                offset: w.byte_offset,
                size: w.byte_size,
            },
            w.skip,
        )
    }
}
