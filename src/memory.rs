//! How the process uses memory: the allocator's thresholds, sample buffers of a whole recording on
//! transparent huge pages, and handing freed memory back between files.
//!
//! Reading a file streams it through blocks of 65 536 rows: an Arrow batch buffer, the block's
//! channels, the cleaner's pending rows, each about half a megabyte, allocated and freed ~150 times
//! per 10⁷ samples. glibc's defaults return such freed memory to the system at once (its top-of-heap
//! trim and its mmap threshold both adapt to half a megabyte), so every block paid its page faults
//! again: 36 000 faults and 0.10 s of reading a 10⁷-sample file, against 2 100 faults and 0.06 s
//! with fixed thresholds ([`tune_allocator`]).
//!
//! The first touch of a fresh 4 KiB page costs a page fault, and a recording's channel and its
//! Allan prefix sums are written once, front to back, into fresh memory. For 10⁷ samples (80 MB)
//! that is 20 000 faults, a third of reading the file (measured: `avar` of a 10⁷-sample Arrow file
//! read in 0.080 s with 4 KiB pages, 0.050 s with 2 MiB pages). Most Linux systems ship transparent
//! huge pages in `madvise` mode, so a buffer gets them only when it asks. Elsewhere (other
//! systems, or THP disabled) the advice is a no-op and the buffers are ordinary.

/// glibc: blocks below this size come from the heap, larger ones are mapped (and unmapped when
/// freed), so the per-block buffers are reused while whole-recording buffers still go back at once.
const MMAP_THRESHOLD_BYTES: i32 = 32 << 20;
/// glibc: free memory at the top of the heap is kept up to this size instead of being returned.
const TRIM_THRESHOLD_BYTES: i32 = 128 << 20;

/// Sets the allocator's thresholds (see the module docs); called once at process start, before
/// threads exist. glibc only; elsewhere a no-op. [`release_freed_memory`] still returns everything
/// after each file of a batch.
pub fn tune_allocator() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        const M_TRIM_THRESHOLD: std::ffi::c_int = -1;
        const M_MMAP_THRESHOLD: std::ffi::c_int = -3;
        extern "C" {
            fn mallopt(param: std::ffi::c_int, value: std::ffi::c_int) -> std::ffi::c_int;
        }
        // SAFETY: mallopt takes two integers and changes only the allocator's policy.
        unsafe {
            mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES);
            mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD_BYTES);
        }
    }
}

/// Hands the memory freed by a finished analysis back to the system.
///
/// glibc's allocator keeps an arena per thread that has allocated, and keeps what a thread freed
/// for that thread's next allocation: two workers that analyse one file after the other still
/// held two files' peaks (measured: a budget of one file at a time with two workers peaked at
/// 353 MB, one worker 206 MB), so no budget could bound the batch. `malloc_trim` returns the
/// free pages of every arena. Elsewhere (other C libraries) a no-op.
pub fn release_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        extern "C" {
            fn malloc_trim(pad: usize) -> std::ffi::c_int;
        }
        // SAFETY: malloc_trim takes no pointer, only a padding size, and is thread-safe.
        unsafe {
            malloc_trim(0);
        }
    }
}

/// Buffers below this size stay on ordinary pages: a huge page would be mostly empty.
const ADVISE_FROM_BYTES: usize = 8 << 20;

/// An empty buffer with room for `capacity` samples, advised onto huge pages when large. The
/// capacity is an estimate (a file's size over its row width): where the system refuses it, the
/// buffer starts empty and grows as an ordinary vector.
pub fn with_capacity(capacity: usize) -> Vec<f64> {
    let mut v = Vec::new();
    if v.try_reserve_exact(capacity).is_ok() {
        advise(v.as_ptr(), v.capacity());
    }
    v
}

/// `len` zeros, advised onto huge pages when large (before any page of it is touched: a zeroed
/// allocation of this size is fresh mapped memory that the kernel zeroes on first touch).
pub fn zeroed(len: usize) -> Vec<f64> {
    let v = vec![0.0f64; len];
    advise(v.as_ptr(), v.len());
    v
}

fn advise(start: *const f64, len: usize) {
    let bytes = len * std::mem::size_of::<f64>();
    if bytes < ADVISE_FROM_BYTES {
        return;
    }
    #[cfg(target_os = "linux")]
    {
        const PAGE: usize = 4096;
        const MADV_HUGEPAGE: std::ffi::c_int = 14;
        extern "C" {
            fn madvise(
                addr: *mut std::ffi::c_void,
                len: usize,
                advice: std::ffi::c_int,
            ) -> std::ffi::c_int;
        }
        // madvise wants a page-aligned start: advise the whole pages inside the allocation.
        let first = (start as usize).div_ceil(PAGE) * PAGE;
        let end = (start as usize + bytes) / PAGE * PAGE;
        if end > first {
            // SAFETY: [first, end) lies inside one live allocation of this process; MADV_HUGEPAGE
            // changes only how the kernel backs those pages, not their contents or validity. A
            // failure (THP unsupported) leaves ordinary pages, which is fine.
            unsafe {
                madvise(first as *mut std::ffi::c_void, end - first, MADV_HUGEPAGE);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn large_buffers_behave_as_ordinary_vectors() {
        let n = (ADVISE_FROM_BYTES / 8) * 3 + 5;
        let mut z = zeroed(n);
        assert_eq!(z.len(), n);
        assert!(z.iter().all(|&x| x == 0.0));
        z[n - 1] = 2.5;
        assert_eq!(z.iter().sum::<f64>(), 2.5);
        let mut v = with_capacity(n);
        assert!(v.capacity() >= n && v.is_empty());
        v.extend((0..n + 10).map(|i| i as f64));
        assert_eq!(v[n + 9], (n + 9) as f64);
        assert!(with_capacity(3).capacity() >= 3);
        assert_eq!(with_capacity(usize::MAX / 16).capacity(), 0);
    }
}
