//! How work is cut to fit the device: batches of Welch segments, and windows onto long arrays for the
//! Allan variances. Pure arithmetic on sizes and limits, so it is tested without a device.
//!
//! Two limits matter. `max_storage_buffer_binding_size` bounds what one kernel invocation can see;
//! `max_buffer_size` bounds one allocation. A recording can exceed both.
//!
//! - Welch segments are independent once their samples are on the device, so a batch is simply as
//!   many segments per channel as fit every binding; consecutive batches upload overlapping sample
//!   ranges (segment s needs samples [s·step, s·step + nperseg)), so overlaps are exact by
//!   construction.
//! - An Allan-variance term reads the same array at two or three places m samples apart, where m
//!   can be half the recording. Arrays are therefore stored in pages (one buffer each, at most
//!   `max_buffer_size`), and each dispatch binds one window per place, at an offset aligned to
//!   `min_storage_buffer_offset_alignment`, no larger than the binding limit. [`spans`] cuts the term
//!   range so that every window of a span lies inside one page; a span boundary only changes which
//!   workgroup sums a term, never which samples it reads.

use super::shaders::{AVAR_ITEMS, WORKGROUP};
use super::{GpuContext, GpuError};

/// Device limits and the job budget, in bytes (and workgroups).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Caps {
    /// Largest storage binding.
    pub binding: u64,
    /// Largest buffer.
    pub buffer: u64,
    /// Alignment of storage binding offsets.
    pub align: u64,
    /// Most bytes one job holds in device buffers at once (a soft limit: a single segment batch
    /// may exceed it when one segment alone does).
    pub budget: u64,
    /// Most workgroups per dispatch dimension.
    pub max_groups: u32,
}

impl Caps {
    pub fn of(ctx: &GpuContext) -> Caps {
        let l = ctx.limits();
        Caps {
            binding: l.max_storage_buffer_binding_size.min(l.max_buffer_size),
            buffer: l.max_buffer_size,
            align: u64::from(l.min_storage_buffer_offset_alignment).max(4),
            budget: ctx.memory_budget(),
            max_groups: l.max_compute_workgroups_per_dimension,
        }
    }
}

/// The sizes of a Welch job that the batch depends on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WelchShape {
    pub nperseg: usize,
    pub step: usize,
    /// nfft/2, the complex FFT length.
    pub half: usize,
    /// nfft/2 + 1.
    pub bins: usize,
    pub channels: usize,
    /// Whether the multi-pass path (two complex work arrays per segment) is used.
    pub multipass: bool,
}

/// Most segments per channel in one batch: every binding within the device limit, the dispatch
/// within the workgroup-count limit, and the whole batch within the budget (but at least one
/// segment per channel when that alone fits the limits).
///
/// # Errors
/// [`GpuError::TooLarge`] naming the first buffer that cannot hold even one segment per channel.
pub fn welch_batch(shape: &WelchShape, caps: &Caps) -> Result<usize, GpuError> {
    let WelchShape {
        nperseg,
        step,
        half,
        bins,
        channels,
        multipass,
    } = *shape;
    let (ch, n, step, half, bins) = (
        channels as u64,
        nperseg as u64,
        step as u64,
        half as u64,
        bins as u64,
    );
    let too_large = |what: &'static str, needed: u64| GpuError::TooLarge {
        what,
        needed,
        limit: caps.binding,
    };
    // Buffers that do not grow with the batch.
    for (what, bytes) in [
        ("the window", n * 4),
        ("the twiddle table", half * 8),
        ("the per-channel sums", ch * bins * 4),
    ] {
        if bytes > caps.binding {
            return Err(too_large(what, bytes));
        }
    }
    if ch > u64::from(caps.max_groups) {
        return Err(GpuError::TooLarge {
            what: "one workgroup row per channel",
            needed: ch,
            limit: u64::from(caps.max_groups),
        });
    }
    // Bytes per segment slot of each growing buffer: input (after the first segment), power,
    // and the two complex work arrays of the multi-pass path.
    let input_first = ch * n * 4;
    let input_per = ch * step * 4;
    let power_per = ch * bins * 4;
    let work_per = if multipass { ch * half * 8 } else { 0 };

    if input_first > caps.binding {
        return Err(too_large("one segment of every channel", input_first));
    }
    if power_per > caps.binding {
        return Err(too_large("one spectrum of every channel", power_per));
    }
    if work_per > caps.binding {
        return Err(too_large("one FFT work array of every channel", work_per));
    }
    // How many `per` fit in `budget` after `first` (unbounded when nothing grows).
    let fit = |budget: u64, first: u64, per: u64| {
        budget
            .saturating_sub(first)
            .checked_div(per)
            .unwrap_or(u64::MAX)
    };
    let mut b = u64::from(caps.max_groups);
    if multipass {
        // Slots (channels × segments) are the y dimension of the multi-pass dispatches.
        b = b.min(u64::from(caps.max_groups) / ch);
    }
    b = b.min(1 + fit(caps.binding, input_first, input_per));
    b = b.min(fit(caps.binding, 0, power_per));
    b = b.min(fit(caps.binding, 0, work_per));
    let per_batch = power_per + 2 * work_per + input_per;
    b = b.min(
        1 + fit(
            caps.budget,
            input_first + power_per + 2 * work_per,
            per_batch,
        ),
    );
    Ok(b.max(1) as usize)
}

/// How a long array of `elem`-byte values is split into pages and seen through windows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Paging {
    /// Bytes per value.
    pub elem: u64,
    /// Values per page (one buffer); a multiple of `align`.
    pub page_len: usize,
    /// Most values one dispatch reads through one window.
    pub window_len: usize,
    /// Values per binding-offset alignment.
    pub align: usize,
}

impl Paging {
    /// Pages and windows for `elem`-byte values on a device with `caps`.
    pub fn new(elem: u64, caps: &Caps) -> Paging {
        let align = (caps.align / elem).max(1) as usize;
        let page_len = ((caps.buffer / elem) as usize / align) * align;
        let per_dispatch = caps.max_groups as usize * (WORKGROUP * AVAR_ITEMS) as usize;
        let window_len = ((caps.binding / elem) as usize)
            .saturating_sub(align)
            .min(per_dispatch)
            .max(1);
        Paging {
            elem,
            page_len: page_len.max(align),
            window_len,
            align,
        }
    }

    /// Number of pages for an array of `len` values.
    pub fn pages(&self, len: usize) -> usize {
        len.div_ceil(self.page_len).max(1)
    }

    /// Values in page `page` of an array of `len` values.
    pub fn page_len_of(&self, page: usize, len: usize) -> usize {
        (len - page * self.page_len).min(self.page_len)
    }

    /// The window through which one dispatch reads values [start, start + len) of an array of
    /// `total` values (a range that lies within one page, as [`spans`] guarantees).
    pub fn window(&self, start: usize, len: usize, total: usize) -> Window {
        let page = start / self.page_len;
        let within = start - page * self.page_len;
        let offset = within / self.align * self.align;
        let skip = within - offset;
        let size = (self.page_len_of(page, total) - offset).min(self.window_len + self.align);
        debug_assert!(
            skip + len <= size,
            "window [{start}, +{len}) crosses a page"
        );
        Window {
            page,
            byte_offset: offset as u64 * self.elem,
            byte_size: size as u64 * self.elem,
            skip: skip as u32,
        }
    }
}

/// A binding of part of one page.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Window {
    pub page: usize,
    pub byte_offset: u64,
    pub byte_size: u64,
    /// Values between the (aligned) start of the binding and the first value wanted.
    pub skip: u32,
}

/// A range of term indices handled by one dispatch.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Span {
    pub start: usize,
    pub len: usize,
}

/// Cuts terms [0, count) into spans such that, for every shift s, the values [start + s,
/// start + s + len) lie in one page and len ≤ the window length.
pub fn spans(count: usize, shifts: &[usize], paging: &Paging) -> Vec<Span> {
    let mut out = Vec::new();
    let mut start = 0;
    while start < count {
        let mut end = count.min(start + paging.window_len);
        for &s in shifts {
            let page_end = ((start + s) / paging.page_len + 1) * paging.page_len;
            end = end.min(page_end - s);
        }
        out.push(Span {
            start,
            len: end - start,
        });
        start = end;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn caps(binding: u64, buffer: u64) -> Caps {
        Caps {
            binding,
            buffer,
            align: 32,
            budget: 1 << 30,
            max_groups: 65535,
        }
    }

    #[test]
    fn spans_cover_everything_once_and_stay_in_pages() {
        let paging = Paging::new(4, &caps(1 << 10, 1 << 12)); // 256-value windows, 1024-value pages
        assert_eq!((paging.align, paging.page_len), (8, 1024));
        for (count, shifts) in [
            (5000usize, vec![0usize, 700]),
            (3000, vec![0, 1, 2]),
            (10, vec![0]),
        ] {
            let spans = spans(count, &shifts, &paging);
            let mut next = 0;
            for sp in &spans {
                assert_eq!(sp.start, next);
                assert!(sp.len >= 1 && sp.len <= paging.window_len);
                for &s in &shifts {
                    let a = sp.start + s;
                    assert_eq!(a / 1024, (a + sp.len - 1) / 1024, "{sp:?} shift {s}");
                    let w = paging.window(a, sp.len, count + 1024);
                    assert_eq!(w.byte_offset % 32, 0);
                    assert!(u64::from(w.skip) + sp.len as u64 <= w.byte_size / 4);
                    assert!(w.byte_size <= 1 << 10);
                }
                next += sp.len;
            }
            assert_eq!(next, count);
        }
    }

    #[test]
    fn welch_batches_respect_every_limit() {
        let shape = WelchShape {
            nperseg: 4096,
            step: 2048,
            half: 2048,
            bins: 2049,
            channels: 3,
            multipass: false,
        };
        let b = welch_batch(&shape, &caps(1 << 20, 1 << 30)).unwrap();
        // Input: 3·((b − 1)·2048 + 4096)·4 ≤ 1 MiB → b ≤ 41; power: 3·b·2049·4 ≤ 1 MiB → b ≤ 42.
        assert_eq!(b, 41);
        let multi = WelchShape {
            multipass: true,
            ..shape
        };
        // Work: 3·b·2048·8 ≤ 1 MiB → b ≤ 21.
        assert_eq!(welch_batch(&multi, &caps(1 << 20, 1 << 30)).unwrap(), 21);
        let err = welch_batch(&shape, &caps(40_000, 1 << 30)).unwrap_err();
        assert!(matches!(
            err,
            GpuError::TooLarge {
                what: "one segment of every channel",
                ..
            }
        ));
    }
}
