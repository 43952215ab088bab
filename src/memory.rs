//! How the process hands memory back between the files of a batch.
//!
//! Tried and not kept (measured on a 10⁷-sample channel and on the paper workload, 3 × 10⁷
//! samples): fixed glibc thresholds (`mallopt` of the mmap and trim thresholds, so that the
//! per-block buffers of reading are not returned and faulted in again): 40 000 instead of 44 000
//! page faults and no change in time; whole-recording buffers on transparent huge pages
//! (`madvise`): one channel's `avar` 0.16 → 0.10 s, but the Allan prefix sums of three channels at
//! once 0.11 → 0.20 s (the kernel compacts memory synchronously for advised regions), with a cost
//! that depends on how fragmented the machine's memory is.

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
