//! Why a job ran on the CPU instead, kept where the caller can see it.
//!
//! Two kinds, kept apart because they mean different things to a user: an option the GPU path does
//! not implement (median averaging, say) is a plan, reported as information; a device that failed
//! in the middle of a run is a fault, reported as a warning. Either way the numbers are the CPU's,
//! never a GPU result computed after a failure.

use std::fmt;
use std::sync::{Mutex, PoisonError};

use super::GpuError;

/// Why a job (or part of it) was computed on the CPU.
#[non_exhaustive]
#[derive(Debug, Clone, PartialEq)]
pub enum FallbackReason {
    /// An option or size the GPU path does not handle; the whole job ran on the CPU.
    Unsupported(String),
    /// The device failed during the job; the work not yet finished on the GPU was redone on the CPU.
    Failed(GpuError),
}

impl FallbackReason {
    /// Whether this deserves a warning (a fault) rather than a note (a plan).
    pub fn is_warning(&self) -> bool {
        matches!(self, FallbackReason::Failed(_))
    }
}

impl fmt::Display for FallbackReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FallbackReason::Unsupported(why) => write!(f, "not on the GPU path: {why}"),
            FallbackReason::Failed(e) => write!(f, "GPU failed, recomputed on the CPU: {e}"),
        }
    }
}

/// Which job fell back.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Task {
    Welch,
    Deviations,
}

impl fmt::Display for Task {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Task::Welch => "welch",
            Task::Deviations => "deviations",
        })
    }
}

/// One fallback.
#[derive(Debug, Clone, PartialEq)]
pub struct Fallback {
    pub task: Task,
    pub reason: FallbackReason,
}

impl fmt::Display for Fallback {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.task, self.reason)
    }
}

/// Every fallback of a backend, in order; shared with the jobs it hands out, which may fall back
/// long after they were made (a device lost in the middle of a stream).
#[derive(Debug, Default)]
pub struct FallbackLog {
    entries: Mutex<Log>,
}

#[derive(Debug, Default)]
struct Log {
    all: Vec<Fallback>,
    /// How many of `all` [`FallbackLog::take_new`] has handed out.
    taken: usize,
}

impl FallbackLog {
    fn lock(&self) -> std::sync::MutexGuard<'_, Log> {
        self.entries.lock().unwrap_or_else(PoisonError::into_inner)
    }

    pub fn record(&self, task: Task, reason: FallbackReason) {
        self.lock().all.push(Fallback { task, reason });
    }

    /// All fallbacks so far.
    pub fn entries(&self) -> Vec<Fallback> {
        self.lock().all.clone()
    }

    /// The most recent fallback.
    pub fn last(&self) -> Option<Fallback> {
        self.lock().all.last().cloned()
    }

    /// The fallbacks recorded since the previous call (for per-recording notes).
    pub fn take_new(&self) -> Vec<Fallback> {
        let mut log = self.lock();
        let new = log.all[log.taken..].to_vec();
        log.taken = log.all.len();
        new
    }
}
