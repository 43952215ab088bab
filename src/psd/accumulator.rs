//! Streaming Welch estimation: segments are transformed as soon as their samples have arrived.
//!
//! Recordings are hours long and read in record batches, so the estimator must not need the whole
//! signal. Per channel the accumulator holds only the samples after the start of the next
//! incomplete segment (fewer than nperseg) and, for mean averaging, one running sum of |X_k|².
//! Each push transforms every segment that is complete in `held ++ chunk`, reading it straight from
//! the two slices (nothing is copied except the new tail), in parallel over channels × blocks of
//! segments. Blocks are fixed by the chunk and thread count and their sums are added in block order,
//! so a run is reproducible bit for bit on a given machine.
//!
//! Memory per channel: < nperseg held samples, nfft/2 + 1 sums, and for the parallel step up to
//! one partial sum per thread; plus one FFT work area (about 2.5·nfft values) per thread.
//! Median averaging keeps every segment's periodogram instead: segments × (nfft/2 + 1) values.

use std::ops::Range;

use rayon::prelude::*;

use super::median::column_medians;
use super::segment::SegmentWorker;
use super::{Average, Psd, PsdError, WelchPlan};

/// Welch estimator fed in chunks, for several channels of the same recording at once.
pub struct WelchAccumulator {
    plan: WelchPlan,
    rate_hz: f64,
    channels: Vec<Channel>,
    /// Samples received per channel.
    received: usize,
    /// Segments completed per channel.
    segments: usize,
    peak_buffered: usize,
    /// First misuse seen (wrong channel count, ragged chunk, bad rate); reported by `finish`.
    error: Option<PsdError>,
    /// One FFT work area per thread, made on first use and kept.
    workers: Vec<SegmentWorker>,
    /// Per-task partial sums for mean averaging, kept between pushes.
    partials: Vec<Vec<f64>>,
}

struct Channel {
    /// Samples from the start of the next segment onwards (always fewer than nperseg).
    held: Vec<f64>,
    /// Mean: Σ_segments |X_k|². Median: |X_k|² of every segment, one row of nfft/2 + 1 per segment.
    power: Vec<f64>,
}

/// Where a task puts its segments' |X_k|².
enum Sink<'a> {
    Sum(&'a mut [f64]),
    Rows(&'a mut [f64]),
}

/// Segments `range` (indices relative to the start of `held`) of one channel.
struct Task<'a> {
    held: &'a [f64],
    chunk: &'a [f64],
    range: Range<usize>,
    sink: Sink<'a>,
}

impl WelchAccumulator {
    /// An accumulator for `channels` channels sampled at `rate_hz`. An invalid rate (not finite
    /// and positive) is reported by [`finish`](Self::finish).
    pub fn new(plan: WelchPlan, rate_hz: f64, channels: usize) -> Self {
        let sums = match plan.config().average {
            Average::Mean => plan.bins(),
            Average::Median => 0,
        };
        let error = (!(rate_hz.is_finite() && rate_hz > 0.0)).then(|| {
            PsdError::InvalidConfig(format!(
                "sample rate must be finite and positive, got {rate_hz}"
            ))
        });
        let channels = (0..channels)
            .map(|_| Channel {
                held: Vec::with_capacity(plan.nperseg()),
                power: vec![0.0; sums],
            })
            .collect();
        WelchAccumulator {
            plan,
            rate_hz,
            channels,
            received: 0,
            segments: 0,
            peak_buffered: 0,
            error,
            workers: Vec::new(),
            partials: Vec::new(),
        }
    }

    /// Feeds the next `chunk[c].len()` samples of every channel c. All slices must have the same
    /// length and there must be one per channel; otherwise the data is ignored and `finish`
    /// reports the mismatch (a stream reader should not have to handle an error per batch).
    /// Non-finite samples are not checked (that is the quality stage's job); they make the
    /// affected bins NaN or infinite, never a panic.
    pub fn push(&mut self, chunk: &[&[f64]]) {
        if self.error.is_some() {
            return;
        }
        if let Err(e) = self.check(chunk) {
            self.error = Some(e);
            return;
        }
        let len = chunk.first().map_or(0, |c| c.len());
        if len == 0 {
            return;
        }
        let held = self.channels[0].held.len();
        let nseg = self.plan.segments_for(held + len);
        if nseg > 0 {
            self.process(chunk, nseg);
        }
        self.received += len;
        self.segments += nseg;
        // Keep what follows the start of the first segment not yet complete.
        let consumed = nseg * self.plan.step();
        for (ch, x) in self.channels.iter_mut().zip(chunk) {
            if consumed >= held {
                ch.held.clear();
                ch.held.extend_from_slice(&x[consumed - held..]);
            } else {
                ch.held.drain(..consumed);
                ch.held.extend_from_slice(x);
            }
        }
        self.peak_buffered = self.peak_buffered.max(self.channels[0].held.len());
    }

    fn check(&self, chunk: &[&[f64]]) -> Result<(), PsdError> {
        check_chunk(chunk, self.channels.len())
    }

    /// Transforms the `nseg` segments complete in `held ++ chunk`, for every channel.
    fn process(&mut self, chunk: &[&[f64]], nseg: usize) {
        let plan = &self.plan;
        let bins = plan.bins();
        let threads = rayon::current_num_threads().max(1);
        // Blocks of segments per channel: enough for every thread to have work even with one
        // channel, and channels × threads tasks keep threads evenly loaded with several.
        let blocks = nseg.min(threads);
        let block = |b: usize| b * nseg / blocks..(b + 1) * nseg / blocks;

        let mut tasks = Vec::with_capacity(self.channels.len() * blocks);
        match plan.config().average {
            Average::Mean if blocks == 1 => {
                for (ch, x) in self.channels.iter_mut().zip(chunk) {
                    let Channel { held, power } = ch;
                    tasks.push(Task {
                        held,
                        chunk: x,
                        range: 0..nseg,
                        sink: Sink::Sum(power),
                    });
                }
            }
            Average::Mean => {
                let needed = self.channels.len() * blocks;
                if self.partials.len() < needed {
                    self.partials.resize_with(needed, || vec![0.0; bins]);
                }
                let mut partials = self.partials.iter_mut();
                for (ch, x) in self.channels.iter().zip(chunk) {
                    for b in 0..blocks {
                        let partial = partials.next().expect("sized above");
                        partial.fill(0.0);
                        tasks.push(Task {
                            held: &ch.held,
                            chunk: x,
                            range: block(b),
                            sink: Sink::Sum(partial),
                        });
                    }
                }
            }
            Average::Median => {
                for (ch, x) in self.channels.iter_mut().zip(chunk) {
                    let Channel { held, power } = ch;
                    let start = power.len();
                    power.resize(start + nseg * bins, 0.0);
                    let mut rows = &mut power[start..];
                    for b in 0..blocks {
                        let range = block(b);
                        let (mine, rest) = rows.split_at_mut(range.len() * bins);
                        rows = rest;
                        tasks.push(Task {
                            held,
                            chunk: x,
                            range,
                            sink: Sink::Rows(mine),
                        });
                    }
                }
            }
        }

        let used = threads.min(tasks.len());
        while self.workers.len() < used {
            self.workers.push(SegmentWorker::new(plan));
        }
        if used == 1 {
            for task in tasks {
                run(plan, &mut self.workers[0], task);
            }
        } else {
            // Round-robin: worker w takes tasks w, w + used, … (equal-sized, so evenly loaded).
            let mut groups: Vec<Vec<Task>> = (0..used).map(|_| Vec::new()).collect();
            for (i, task) in tasks.into_iter().enumerate() {
                groups[i % used].push(task);
            }
            self.workers[..used]
                .par_iter_mut()
                .zip(groups)
                .for_each(|(worker, group)| {
                    for task in group {
                        run(plan, worker, task);
                    }
                });
        }

        if plan.config().average == Average::Mean && blocks > 1 {
            let mut partials = self.partials.iter();
            for ch in &mut self.channels {
                for _ in 0..blocks {
                    let partial = partials.next().expect("sized above");
                    for (s, p) in ch.power.iter_mut().zip(partial) {
                        *s += p;
                    }
                }
            }
        }
    }

    /// Averages, scales and folds the accumulated periodograms into one `Psd` per channel.
    ///
    /// Errors: `TooShort` if fewer than nperseg samples arrived (no segment), and any misuse
    /// recorded by `new` or `push`.
    pub fn finish(self) -> Result<Vec<Psd>, PsdError> {
        if let Some(e) = self.error {
            return Err(e);
        }
        if self.channels.is_empty() {
            return Ok(Vec::new());
        }
        let m = self.segments;
        if m == 0 {
            return Err(PsdError::TooShort {
                n: self.received,
                nperseg: self.plan.nperseg(),
            });
        }
        let plan = &self.plan;
        let dof = Psd::bin_dof(plan, m);
        Ok(self
            .channels
            .into_iter()
            .map(|ch| {
                let raw = match plan.config().average {
                    Average::Mean => ch.power.iter().map(|s| s / m as f64).collect(),
                    Average::Median => column_medians(&ch.power, m, plan.bins()),
                };
                Psd::from_averaged(plan, self.rate_hz, m, raw, dof.clone())
            })
            .collect())
    }

    /// Most samples per channel held between pushes so far: always fewer than nperseg, however
    /// long the stream (the chunk being pushed is read in place, not copied).
    pub fn peak_buffered_samples(&self) -> usize {
        self.peak_buffered
    }

    /// Samples received per channel so far.
    pub fn samples(&self) -> usize {
        self.received
    }

    /// Segments completed per channel so far.
    pub fn segments(&self) -> usize {
        self.segments
    }

    pub fn plan(&self) -> &WelchPlan {
        &self.plan
    }
}

/// Runs one task on one worker.
fn run(plan: &WelchPlan, worker: &mut SegmentWorker, task: Task<'_>) {
    let Task {
        held,
        chunk,
        range,
        sink,
    } = task;
    let (step, n) = (plan.step(), plan.nperseg());
    match sink {
        Sink::Sum(acc) => {
            for s in range {
                let (head, tail) = segment(held, chunk, s * step, n);
                worker.accumulate(plan, head, tail, acc);
            }
        }
        Sink::Rows(rows) => {
            for (row, s) in rows.chunks_exact_mut(plan.bins()).zip(range) {
                let (head, tail) = segment(held, chunk, s * step, n);
                worker.power_into(plan, head, tail, row);
            }
        }
    }
}

/// Segment starting at `offset` in `held ++ chunk`, as (part in `held`, part in `chunk`).
fn segment<'a>(
    held: &'a [f64],
    chunk: &'a [f64],
    offset: usize,
    n: usize,
) -> (&'a [f64], &'a [f64]) {
    match offset.checked_sub(held.len()) {
        Some(start) => (&chunk[start..start + n], &[]),
        None => (&held[offset..], &chunk[..n - (held.len() - offset)]),
    }
}

/// A pushed chunk must have one slice per channel, all of one length. Shared by every Welch sink
/// (CPU and GPU) so that misuse gives the same error whichever backend runs.
pub(crate) fn check_chunk(chunk: &[&[f64]], channels: usize) -> Result<(), PsdError> {
    if chunk.len() != channels {
        return Err(PsdError::ChannelMismatch {
            expected: channels,
            got: chunk.len(),
        });
    }
    let expected = chunk.first().map_or(0, |c| c.len());
    match chunk.iter().position(|c| c.len() != expected) {
        Some(channel) => Err(PsdError::LengthMismatch {
            channel,
            len: chunk[channel].len(),
            expected,
        }),
        None => Ok(()),
    }
}
