//! Reusable device buffers.
//!
//! A run over a batch of recordings opens the same-sized buffers again and again (segments, spectra,
//! pyramid levels); allocating them once and handing them out again saves the allocation and the
//! driver's zeroing. Sizes are rounded up to a power of two so that slightly different recordings
//! share buffers, which is why every binding names its size explicitly instead of binding the whole
//! buffer. Idle buffers beyond the budget are dropped, largest first.
//!
//! A buffer must stay leased for as long as any submitted or future work of its job reads it;
//! handing it back early lets the next job overwrite data still in use. Debug builds therefore
//! fill every returned buffer with NaN, so that such a slip shows up in the tests as NaN results
//! instead of as a rare wrong number under concurrency.

use std::ops::Deref;
use std::sync::{Arc, Mutex, PoisonError};

use super::GpuError;

/// Idle buffers, shared by every job on one context.
pub(crate) struct BufferPool {
    inner: Arc<Mutex<Idle>>,
}

struct Idle {
    buffers: Vec<wgpu::Buffer>,
    bytes: u64,
    budget: u64,
}

/// A buffer on loan from the pool; returned when dropped.
pub(crate) struct Lease {
    buffer: Option<wgpu::Buffer>,
    pool: Arc<Mutex<Idle>>,
    #[cfg(debug_assertions)]
    queue: wgpu::Queue,
}

impl BufferPool {
    /// A pool that keeps at most `budget` bytes of idle buffers.
    pub(crate) fn new(budget: u64) -> BufferPool {
        BufferPool {
            inner: Arc::new(Mutex::new(Idle {
                buffers: Vec::new(),
                bytes: 0,
                budget,
            })),
        }
    }

    /// An idle buffer with exactly `usage` and room for `size` bytes (at most twice that), or a new
    /// one of `size` rounded up to a power of two (capped at `max_size`).
    pub(crate) fn acquire(
        &self,
        device: &wgpu::Device,
        #[cfg_attr(not(debug_assertions), allow(unused_variables))] queue: &wgpu::Queue,
        usage: wgpu::BufferUsages,
        size: u64,
        max_size: u64,
    ) -> Result<Lease, GpuError> {
        let size = size.max(16).next_multiple_of(4);
        if size > max_size {
            return Err(GpuError::TooLarge {
                what: "a device buffer",
                needed: size,
                limit: max_size,
            });
        }
        let mut idle = self.inner.lock().unwrap_or_else(PoisonError::into_inner);
        let found = idle
            .buffers
            .iter()
            .enumerate()
            .filter(|(_, b)| b.usage() == usage && b.size() >= size && b.size() <= 2 * size)
            .min_by_key(|(_, b)| b.size())
            .map(|(i, _)| i);
        let buffer = match found {
            Some(i) => {
                let b = idle.buffers.swap_remove(i);
                idle.bytes -= b.size();
                b
            }
            None => {
                drop(idle);
                let rounded = size
                    .checked_next_power_of_two()
                    .unwrap_or(size)
                    .min(max_size);
                device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("imunoise pooled"),
                    size: rounded.max(size),
                    usage,
                    mapped_at_creation: false,
                })
            }
        };
        Ok(Lease {
            buffer: Some(buffer),
            pool: Arc::clone(&self.inner),
            #[cfg(debug_assertions)]
            queue: queue.clone(),
        })
    }
}

impl Deref for Lease {
    type Target = wgpu::Buffer;

    fn deref(&self) -> &wgpu::Buffer {
        self.buffer.as_ref().expect("present until dropped")
    }
}

impl Drop for Lease {
    fn drop(&mut self) {
        let Some(buffer) = self.buffer.take() else {
            return;
        };
        #[cfg(debug_assertions)]
        if buffer.usage().contains(wgpu::BufferUsages::COPY_DST) {
            let nan = vec![0xFF_u8; buffer.size() as usize];
            self.queue.write_buffer(&buffer, 0, &nan);
        }
        let mut idle = self.pool.lock().unwrap_or_else(PoisonError::into_inner);
        idle.bytes += buffer.size();
        idle.buffers.push(buffer);
        while idle.bytes > idle.budget {
            let largest = idle
                .buffers
                .iter()
                .enumerate()
                .max_by_key(|(_, b)| b.size())
                .map(|(i, _)| i)
                .expect("bytes > 0 means a buffer");
            let b = idle.buffers.swap_remove(largest);
            idle.bytes -= b.size();
        }
    }
}
