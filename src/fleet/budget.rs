//! A memory budget for a screen's concurrent analyses (`--memory-budget`).
//!
//! `--threads N` alone bounds the files in flight, not their size: four 24-h recordings at once
//! need four times one. With a budget, a worker starts its next file only while the files in
//! flight plus this one are estimated to fit; a file larger than the whole budget runs alone
//! (never refused: a fleet has the files it has), and the run says so.
//!
//! **The estimate** ([`footprint_bytes`]) is a model of `analyze`'s measured peak resident memory:
//! a base of [`BASE_BYTES`], every channel's samples as f64 (8 bytes each: the Allan statistics
//! hold whole channels), and [`LOOP_BYTES_PER_SAMPLE`] per sample for each channel the model
//! stage works on at once (one per core: the residual loop's detectors and their buffers, a
//! corrected copy of the channel). Measured on this project's 2-core machine (`/usr/bin/time`,
//! peak RSS, f32 Arrow files) against the model: 1 h × 200 Hz × 6 channels 151–155 MB (model
//! 164 MB), 2 h × 200 Hz × 3 channels 162–171 MB (210 MB), 13.5 h × 207 Hz × 3 channels
//! 510–534 MB (970 MB), 24 h × 400 Hz × 7 channels 3.0–3.1 GB (4.23 GB): 6–90 % above; 4 h ×
//! 200 Hz, 6 axes and a temperature 328–334 MiB (429 MB; 478 MiB before the coupling test
//! stopped holding series-long buffers per scale). Rows come from the Parquet footer, from the
//! sampled length of a CSV line, or from the file size over the stored width of a row (Arrow IPC,
//! MCAP: an over-estimate where messages carry overhead).

use std::path::Path;
use std::sync::{Condvar, Mutex};

use crate::io::{self, OpenOptions};

/// Resident memory of an analysis before any sample (binary, allocator, thread stacks), and the
/// small buffers that do not grow with the record (was 48 MiB until the time-domain detectors of a
/// channel ran side by side: a 1-h × 6-channel file then peaked 20 MB above that model).
pub const BASE_BYTES: u64 = 80 << 20;
/// Per sample of each channel the model stage holds at once.
pub const LOOP_BYTES_PER_SAMPLE: u64 = 32;

/// Estimated peak memory of analysing `path`, or `None` when it cannot even be opened (its
/// analysis will fail with the reason; it is admitted as if small).
pub fn footprint_bytes(path: &Path, open: &OpenOptions, cores: usize) -> Option<u64> {
    let rec = io::open(path, open).ok()?;
    let channels = rec.channels.len() as u64;
    let rows = rec.estimated_rows()?;
    let concurrent = channels.min(cores.max(1) as u64);
    Some(BASE_BYTES + 8 * rows * channels + LOOP_BYTES_PER_SAMPLE * rows * concurrent)
}

/// Bytes admitted at once; waits for room.
#[derive(Debug)]
pub struct Budget {
    limit: u64,
    in_flight: Mutex<u64>,
    freed: Condvar,
}

/// Bytes held by one admitted file, released on drop.
#[derive(Debug)]
pub struct Admission<'a> {
    budget: &'a Budget,
    bytes: u64,
    /// The file alone exceeds the budget (it runs with nothing else in flight).
    pub over: bool,
}

impl Budget {
    pub fn new(limit: u64) -> Self {
        Budget {
            limit,
            in_flight: Mutex::new(0),
            freed: Condvar::new(),
        }
    }

    pub fn limit(&self) -> u64 {
        self.limit
    }

    /// Waits until `bytes` fit beside what is in flight (or nothing is in flight), then holds
    /// them.
    pub fn admit(&self, bytes: u64) -> Admission<'_> {
        let mut held = self.in_flight.lock().unwrap_or_else(|e| e.into_inner());
        while *held > 0 && *held + bytes > self.limit {
            held = self.freed.wait(held).unwrap_or_else(|e| e.into_inner());
        }
        *held += bytes;
        Admission {
            budget: self,
            bytes,
            over: bytes > self.limit,
        }
    }
}

impl Drop for Admission<'_> {
    fn drop(&mut self) {
        crate::memory::release_freed_memory();
        let mut held = self
            .budget
            .in_flight
            .lock()
            .unwrap_or_else(|e| e.into_inner());
        *held -= self.bytes;
        self.budget.freed.notify_all();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicU64, Ordering};

    /// Files that fit together run together; never more than the budget in flight, except a
    /// file larger than the whole budget, alone.
    #[test]
    fn admissions_never_exceed_the_budget_and_a_large_file_runs_alone() {
        let budget = Budget::new(100);
        let now = AtomicU64::new(0);
        let peak = AtomicU64::new(0);
        let sizes = [30u64, 40, 50, 20, 150, 10, 60, 30];
        std::thread::scope(|s| {
            for chunk in sizes.chunks(2) {
                let (budget, now, peak) = (&budget, &now, &peak);
                s.spawn(move || {
                    for &b in chunk {
                        let a = budget.admit(b);
                        let v = now.fetch_add(b, Ordering::SeqCst) + b;
                        peak.fetch_max(v, Ordering::SeqCst);
                        assert!(v <= 100 || (a.over && v == b), "{v} with {b}");
                        std::thread::sleep(std::time::Duration::from_millis(5));
                        now.fetch_sub(b, Ordering::SeqCst);
                    }
                });
            }
        });
        assert!(peak.load(Ordering::SeqCst) >= 150);
        assert_eq!(*budget.in_flight.lock().unwrap(), 0);
    }

    /// Rows are read from the Parquet footer, estimated from the row width of an Arrow file and
    /// from the line length of a CSV file (within 5 % on these; the exact count is 30 000).
    #[test]
    fn rows_are_estimated_per_format() {
        use crate::io::{write_recording, ColumnOut, StoredAs};
        use crate::units::{Kind, Unit};
        let dir = tempfile::tempdir().unwrap();
        let samples: Vec<f64> = (0..30_000)
            .map(|i| (i as f64 * 0.37).sin() * 1e-3)
            .collect();
        let cols: Vec<ColumnOut<'_>> = ["gx", "gy"]
            .iter()
            .map(|name| ColumnOut {
                name,
                unit: Unit::RadPerS,
                kind: Kind::Gyro,
                samples: &samples,
            })
            .collect();
        for (ext, stored) in [
            ("arrow", StoredAs::F64),
            ("arrow", StoredAs::F32),
            ("parquet", StoredAs::F64),
            ("csv", StoredAs::F64),
        ] {
            let path = dir.path().join(format!("r{stored:?}.{ext}"));
            write_recording(&path, 100.0, &cols, stored).unwrap();
            let open = OpenOptions {
                rate_hz: Some(100.0),
                ..Default::default()
            };
            let rec = io::open(&path, &open).unwrap();
            let rows = rec.estimated_rows().unwrap() as f64;
            assert!(
                (rows / 30_000.0 - 1.0).abs() < 0.05,
                "{ext} {stored:?}: {rows}"
            );
            let bytes = footprint_bytes(&path, &open, 2).unwrap();
            assert_eq!(
                bytes,
                BASE_BYTES + (8 * 2 + LOOP_BYTES_PER_SAMPLE * 2) * rows as u64
            );
        }
    }
}
