//! How the process reuses and hands back memory: a small pool of record-length scratch buffers,
//! and handing freed memory back between the files of a batch.
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
        release_cached_memory();
        // SAFETY: malloc_trim takes no pointer, only a padding size, and is thread-safe.
        unsafe {
            malloc_trim(0);
        }
    }
}

/// Buffers of at least this many values are pooled when given back.
const POOLED_MIN: usize = 1 << 20;

/// Record-length scratch buffers given back for reuse ([`scratch`], [`recycle`]): the first touch
/// of a fresh buffer costs a page fault per 4 KiB, and the Allan prefix sums and the step scan each
/// need one buffer of the whole record per channel (on 24 h × 400 Hz × 7 channels the step scan's
/// page faults alone were 9 % of the run). At most [`pool_size`] buffers are kept (the largest);
/// [`release_freed_memory`] empties the pool.
static POOL: std::sync::Mutex<Vec<Vec<f64>>> = std::sync::Mutex::new(Vec::new());

/// Buffers the pool keeps: one per worker thread, and two more. A thread waiting in a join runs
/// other tasks meanwhile (another channel's detector), so more buffers than threads are in use at
/// times. With one per thread, the loop over 24 h × 400 Hz × 7 channels made a 276-MB buffer
/// afresh on some runs (190 000 page faults in the fit instead of 123 000, and on this project's
/// virtual machine up to a second more of system time); with two more, and a refit's prefix sums
/// built in its own copy ([`crate::avar::compute_owned`]), 7 runs of 7 made none beyond the first
/// two. Idle pooled buffers stay resident, but the peak was lower, not higher (2.61–2.68 GB
/// against 2.86–3.11 GB, measured on that file): fewer buffers were freed and made again.
fn pool_size() -> usize {
    rayon::current_num_threads().max(1) + 2
}

/// A buffer of `len` values with unspecified contents: the smallest pooled one that is large
/// enough, else a fresh zeroed one (`vec!` of zeros maps fresh pages, so their first touch
/// happens where the caller writes).
pub fn scratch(len: usize) -> Vec<f64> {
    let taken = {
        let mut pool = POOL.lock().unwrap_or_else(|e| e.into_inner());
        let fit = (0..pool.len())
            .filter(|&i| pool[i].capacity() >= len)
            .min_by_key(|&i| pool[i].capacity());
        fit.map(|i| pool.swap_remove(i))
    };
    match taken {
        Some(mut buf) => {
            if buf.len() >= len {
                buf.truncate(len);
            } else {
                buf.resize(len, 0.0);
            }
            buf
        }
        None => {
            // A little more than asked: the callers ask for n (a series' copy) and n + 1 (its
            // prefix sums), and a buffer made for one must serve the other.
            let mut fresh = vec![0.0f64; len + SLACK];
            fresh.truncate(len);
            fresh
        }
    }
}

/// Spare values allocated beyond a fresh scratch buffer's length (see [`scratch`]).
const SLACK: usize = 64;

/// Gives a buffer back to the pool (small ones are simply freed; a full pool keeps its largest).
pub fn recycle(buf: Vec<f64>) {
    if buf.capacity() < POOLED_MIN {
        return;
    }
    let mut pool = POOL.lock().unwrap_or_else(|e| e.into_inner());
    pool.push(buf);
    if pool.len() > pool_size() {
        let smallest = (0..pool.len()).min_by_key(|&i| pool[i].capacity());
        if let Some(i) = smallest {
            drop(pool.swap_remove(i));
        }
    }
}

/// Frees the pooled scratch buffers.
pub fn release_cached_memory() {
    let pooled = std::mem::take(&mut *POOL.lock().unwrap_or_else(|e| e.into_inner()));
    drop(pooled);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scratch_buffers_are_reused_and_released() {
        release_cached_memory();
        let n = POOLED_MIN + 10;
        let mut a = scratch(n);
        assert_eq!(a.len(), n);
        a[n - 1] = 7.0;
        let ptr = a.as_ptr();
        recycle(a);
        // The same allocation comes back, at the length asked for.
        let b = scratch(n - 5);
        assert_eq!((b.as_ptr(), b.len()), (ptr, n - 5));
        recycle(b);
        let c = scratch(n + 100);
        assert_eq!(c.len(), n + 100);
        recycle(c);
        // A buffer made for n values serves n + 1 (a series' prefix sums after its copy).
        let d = scratch(n + 1000);
        let ptr = d.as_ptr();
        recycle(d);
        let e = scratch(n + 1001);
        assert_eq!(e.as_ptr(), ptr);
        recycle(e);
        recycle(vec![1.0; 10]);
        assert!(POOL.lock().unwrap().len() <= pool_size());
        release_cached_memory();
        assert!(POOL.lock().unwrap().is_empty());
    }
}
