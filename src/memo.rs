//! A small process-wide memo for values that are expensive to compute, cheap to clone, and asked
//! for again and again with the same key (a Welch plan's window statistics: the model stage fits
//! one spectrum dozens of times per channel, and each fit needs the same O(segment length)
//! numbers).

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, PoisonError};

/// The current generation of every memo: an entry remembered in an earlier one is not found.
static GENERATION: AtomicU64 = AtomicU64::new(0);

/// Forgets what every memo of the process remembers (O(1): the entries are left to be replaced).
/// For measuring a cold start in a process that has run the same analysis before (a benchmark's
/// repetitions would otherwise find every value of the first run remembered).
pub fn forget_all() {
    GENERATION.fetch_add(1, Ordering::Relaxed);
}

/// The most recent `cap` (key, value) pairs; older ones are forgotten.
pub struct Memo<K, V> {
    /// (generation, key, value).
    slots: Mutex<Vec<(u64, K, V)>>,
    cap: usize,
}

impl<K: PartialEq, V: Clone> Memo<K, V> {
    /// An empty memo of `cap` entries (usable in a `static`).
    pub const fn new(cap: usize) -> Self {
        Self {
            slots: Mutex::new(Vec::new()),
            cap,
        }
    }

    /// The value of `key`: the remembered one, or `make()` (computed without holding the lock,
    /// remembered when `Some`).
    pub fn get_or(&self, key: K, make: impl FnOnce() -> Option<V>) -> Option<V> {
        let find = |slots: &mut Vec<(u64, K, V)>| {
            let now = GENERATION.load(Ordering::Relaxed);
            slots.retain(|(g, _, _)| *g == now);
            slots
                .iter()
                .find(|(_, k, _)| *k == key)
                .map(|(_, _, v)| v.clone())
        };
        if let Some(v) = find(&mut self.slots.lock().unwrap_or_else(PoisonError::into_inner)) {
            return Some(v);
        }
        let value = make()?;
        let mut slots = self.slots.lock().unwrap_or_else(PoisonError::into_inner);
        if find(&mut slots).is_none() {
            if slots.len() >= self.cap.max(1) {
                slots.remove(0);
            }
            slots.push((GENERATION.load(Ordering::Relaxed), key, value.clone()));
        }
        Some(value)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn remembers_the_latest_and_forgets_the_oldest() {
        let memo: Memo<u32, u64> = Memo::new(2);
        let calls = std::cell::Cell::new(0);
        let get = |k: u32| {
            memo.get_or(k, || {
                calls.set(calls.get() + 1);
                Some(u64::from(k) * 10)
            })
        };
        assert_eq!(get(1), Some(10));
        assert_eq!(get(1), Some(10));
        assert_eq!(get(2), Some(20));
        assert_eq!(get(3), Some(30)); // forgets 1
        assert_eq!(get(1), Some(10));
        assert_eq!(calls.get(), 4);
        assert_eq!(memo.get_or(9, || None), None);
        // Forgotten by a new generation: computed again, then remembered again.
        forget_all();
        assert_eq!(get(1), Some(10));
        assert_eq!(get(1), Some(10));
        assert_eq!(calls.get(), 5);
    }
}
