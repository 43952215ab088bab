//! The streaming cleaner: checks the time base, applies the gap and non-finite policies and gathers
//! statistics, block by block, holding back only the samples an unfinished interpolation still needs.
//!
//! Clean blocks (the usual case) take a vectorisable fast path; only a block with a problem is walked
//! row by row, so screening a ten-million-row file costs a fraction of the estimate that follows.

use std::path::PathBuf;

use super::stats::SliceScan;
use super::{
    verdicts, ChannelQuality, ChannelStats, DuplicatePolicy, Gap, GapPolicy, NonFinitePolicy,
    QualityOptions, QualityReport, TimeJitter, MAX_LISTED_GAPS,
};
use crate::io::time_grid::GridTracker;
use crate::io::ChannelSpec;
use crate::io::{Block, InputError, Recording};

/// Jitter (largest deviation from the grid, in periods) beyond which a missing sample can no longer
/// be told from a late one: the report says so.
pub const JITTER_AMBIGUOUS_PERIODS: f64 = 0.4;

/// Clean samples ready for the estimators: one `Vec` per channel, all of the same length.
#[derive(Debug, Clone, Default)]
pub struct SampleChunk {
    pub channels: Vec<Vec<f64>>,
}

impl SampleChunk {
    pub fn len(&self) -> usize {
        self.channels.first().map_or(0, Vec::len)
    }
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// An empty chunk of `channels` channels with room for `rows` samples each.
    pub fn with_capacity(channels: usize, rows: usize) -> SampleChunk {
        SampleChunk {
            channels: (0..channels).map(|_| Vec::with_capacity(rows)).collect(),
        }
    }

    /// Appends `later`'s samples (the same channels, in the same order) after this chunk's; an
    /// empty chunk without room for them takes `later`'s buffers as they are.
    pub fn append(&mut self, later: SampleChunk) {
        let room = self.channels.len() == later.channels.len()
            && self.channels.iter().all(|c| c.capacity() >= later.len());
        if self.is_empty() && !room {
            *self = later;
            return;
        }
        for (dst, src) in self.channels.iter_mut().zip(later.channels) {
            dst.extend_from_slice(&src);
        }
    }
}

/// Interpolation state of one channel.
#[derive(Debug, Clone, Default)]
struct Run {
    /// Index in the pending buffer where the current run of bad samples starts.
    start: Option<usize>,
    last_finite: Option<f64>,
}

/// See the module docs.
pub struct Cleaner {
    path: PathBuf,
    names: Vec<String>,
    specs: Vec<ChannelSpec>,
    time_name: String,
    period_s: f64,
    options: QualityOptions,
    previous_time: Option<f64>,
    /// The time column's resolution as stored ([`crate::io::Block::time_resolution_s`]).
    stored_time_resolution_s: f64,
    /// The grid of sample instants the timestamps jitter around, at the period the time column
    /// shows (a clock off its nominal rate by 0.4 % would otherwise make the grid lag by a quarter
    /// period).
    grid: GridTracker,
    grid_period_s: f64,
    jitter_sq: f64,
    jitter_max: f64,
    jitter_count: u64,
    /// The last row handed on (for filling gaps), raw values.
    previous_row: Option<Vec<f64>>,
    pending: Vec<Vec<f64>>,
    runs: Vec<Run>,
    stats: Vec<ChannelStats>,
    nonfinite: Vec<u64>,
    first_nonfinite: Vec<Option<u64>>,
    interpolated: Vec<u64>,
    rows_read: u64,
    samples_out: u64,
    gaps: Vec<Gap>,
    /// The longest gaps (at most [`MAX_LISTED_GAPS`]), wherever they are in the record.
    longest_gaps: Vec<Gap>,
    gap_count: u64,
    missing: u64,
    filled: u64,
    dropped: u64,
    /// Rows dropped because their timestamp repeated the previous row's.
    duplicates: u64,
    last_time: f64,
}

/// Adds `gap` to `longest` (at most [`MAX_LISTED_GAPS`], kept in the order of the record) when
/// it is longer than the shortest there: the gaps whose joins the residual loop must not read as
/// bias steps are the long ones, wherever they fall (a record with hundreds of one-sample drops
/// before a 5-s gap listed only the drops).
fn keep_longest(longest: &mut Vec<Gap>, gap: &Gap) {
    if longest.len() < MAX_LISTED_GAPS {
        longest.push(gap.clone());
        return;
    }
    let (shortest, s) = longest
        .iter()
        .enumerate()
        .min_by_key(|(_, g)| g.missing_samples)
        .map(|(i, g)| (i, g.missing_samples))
        .unwrap_or((0, u64::MAX));
    if gap.missing_samples > s {
        longest.remove(shortest);
        longest.push(gap.clone());
    }
}

impl Cleaner {
    pub fn new(recording: &Recording, options: QualityOptions) -> Self {
        let n = recording.channels.len();
        let grid_period_s = 1.0 / recording.rate_from_time_hz.unwrap_or(recording.rate_hz);
        Cleaner {
            path: recording.path.clone(),
            names: recording.channel_names(),
            specs: recording.channels.clone(),
            time_name: recording
                .time
                .as_ref()
                .map(|t| t.name.clone())
                .unwrap_or_default(),
            period_s: 1.0 / recording.rate_hz,
            options,
            previous_time: None,
            stored_time_resolution_s: 0.0,
            grid: GridTracker::new(grid_period_s),
            grid_period_s,
            jitter_sq: 0.0,
            jitter_max: 0.0,
            jitter_count: 0,
            previous_row: None,
            pending: vec![Vec::new(); n],
            runs: vec![Run::default(); n],
            stats: vec![ChannelStats::new(); n],
            nonfinite: vec![0; n],
            first_nonfinite: vec![None; n],
            interpolated: vec![0; n],
            rows_read: 0,
            samples_out: 0,
            gaps: Vec::new(),
            longest_gaps: Vec::new(),
            gap_count: 0,
            missing: 0,
            filled: 0,
            dropped: 0,
            duplicates: 0,
            last_time: 0.0,
        }
    }

    /// Screens one block; returns the samples that are final (possibly fewer or more rows than the
    /// block: dropped rows, filled gaps, and an interpolation waiting for its right-hand neighbour).
    pub fn push(&mut self, mut block: Block) -> Result<SampleChunk, InputError> {
        let rows = block.rows();
        let mut start = 0;
        self.stored_time_resolution_s = self.stored_time_resolution_s.max(block.time_resolution_s);
        if let (Some(times), None) = (&block.time_s, self.previous_time) {
            self.grid = GridTracker::anchored(self.grid_period_s, times);
        }
        if let Some(times) = block.time_s.take() {
            for (i, &t) in times.iter().enumerate() {
                let row = block.first_row + i as u64;
                match self.check_time(row, t)? {
                    TimeStep::Next => {}
                    TimeStep::Gap(missing) => {
                        self.emit_rows(&mut block, start, i)?;
                        start = i;
                        if self.options.gaps == GapPolicy::Fill {
                            let next: Vec<f64> = block.channels.iter().map(|c| c[i]).collect();
                            self.fill_gap(missing, &next);
                        }
                    }
                    // The rows before it go out; this one does not.
                    TimeStep::Repeat => {
                        self.emit_rows(&mut block, start, i)?;
                        start = i + 1;
                        self.duplicates += 1;
                    }
                }
            }
            if let Some(&t) = times.last() {
                self.last_time = t;
            }
        }
        self.emit_rows(&mut block, start, rows)?;
        self.rows_read += rows as u64;
        Ok(self.take_ready())
    }

    /// Flushes what is held back and returns the report.
    pub fn finish(mut self) -> Result<(SampleChunk, QualityReport), InputError> {
        for c in 0..self.pending.len() {
            if let Some(start) = self.runs[c].start.take() {
                let Some(hold) = self.runs[c].last_finite else {
                    return Err(InputError::NonFinite {
                        path: self.path.clone(),
                        column: self.names[c].clone(),
                        row: self.first_nonfinite[c].unwrap_or(0),
                        value: "every sample of the channel is non-finite".into(),
                    });
                };
                self.pending[c][start..].fill(hold);
            }
        }
        let chunk = self.take_ready();
        let mut report = QualityReport {
            rows_read: self.rows_read,
            samples_out: self.samples_out,
            duration_s: self.samples_out as f64 * self.period_s,
            nonfinite_policy: self.options.nonfinite,
            gap_policy: self.options.gaps,
            gaps: self.gaps,
            longest_gaps: self.longest_gaps,
            gap_count: self.gap_count,
            missing_samples: self.missing,
            filled_samples: self.filled,
            dropped_rows: self.dropped,
            duplicate_policy: self.options.duplicates,
            duplicate_rows: self.duplicates,
            time_jitter: (self.jitter_count > 0).then(|| {
                let rms_s = (self.jitter_sq / self.jitter_count as f64).sqrt();
                // The times count from the first sample, so the last is the largest.
                let last = self.previous_time.unwrap_or(0.0);
                TimeJitter {
                    rms_s,
                    max_s: self.jitter_max,
                    gaps_ambiguous: self.jitter_max > JITTER_AMBIGUOUS_PERIODS * self.grid_period_s,
                    resolution_s: crate::stats::float_spacing(last)
                        .max(self.stored_time_resolution_s),
                }
            }),
            channels: self
                .names
                .iter()
                .enumerate()
                .map(|(c, name)| {
                    let mut summary = self.stats[c].summary();
                    // Saturation is judged on gyros and accelerometers only ([`verdicts`]): a
                    // temperature in 0.125 °C steps that warms up to its last level holds it for
                    // many samples, and was listed as "possibly" saturated.
                    summary.possibly_saturated &= matches!(
                        self.specs[c].kind,
                        crate::units::Kind::Gyro | crate::units::Kind::Accel
                    );
                    ChannelQuality {
                        name: name.clone(),
                        nonfinite_samples: self.nonfinite[c],
                        first_nonfinite_row: self.first_nonfinite[c],
                        interpolated_samples: self.interpolated[c],
                        verdicts: verdicts(&self.specs[c], &summary),
                        summary,
                    }
                })
                .collect(),
        };
        let accel: Vec<usize> = (0..self.specs.len())
            .filter(|&c| self.specs[c].kind == crate::units::Kind::Accel)
            .collect();
        let means: Vec<f64> = accel
            .iter()
            .map(|&c| report.channels[c].summary.mean)
            .collect();
        if let Some(v) = super::gravity_scale(&means) {
            for &c in &accel {
                report.channels[c].verdicts.push(v.clone());
            }
        }
        Ok((chunk, report))
    }

    /// Checks one timestamp against the previous: the next sample, the first after a gap of
    /// missing samples, or a repeat of the previous timestamp to drop, where the policies let the
    /// run go on.
    fn check_time(&mut self, row: u64, t: f64) -> Result<TimeStep, InputError> {
        let previous = self.previous_time.replace(t);
        let Some(p) = previous else {
            if !t.is_finite() {
                return Err(self.time_error(row, f64::NAN, t));
            }
            self.grid.place(t);
            return Ok(TimeStep::Next);
        };
        let dt = t - p;
        if !t.is_finite() || dt < 0.0 {
            return Err(self.time_error(row, p, t));
        }
        if dt == 0.0 {
            if self.options.duplicates == DuplicatePolicy::Drop {
                return Ok(TimeStep::Repeat);
            }
            return Err(InputError::DuplicateTimestamp {
                path: self.path.clone(),
                column: self.time_name.clone(),
                row,
                this_s: t,
            });
        }
        // A gap is a missing sample, judged on the grid of sample instants rather than on one
        // interval (see `io::time_grid`).
        let (steps, deviation) = self.grid.place(t);
        if self.grid.warm() {
            self.jitter_sq += deviation * deviation;
            self.jitter_max = self.jitter_max.max(deviation.abs());
            self.jitter_count += 1;
        }
        if steps <= 1 {
            return Ok(TimeStep::Next);
        }
        let missing = steps - 1;
        if self.options.gaps == GapPolicy::Error {
            return Err(InputError::Gap {
                path: self.path.clone(),
                column: self.time_name.clone(),
                row,
                after_s: p,
                gap_s: dt,
                missing,
            });
        }
        self.gap_count += 1;
        self.missing += missing;
        let gap = Gap {
            row,
            after_s: p,
            duration_s: dt,
            missing_samples: missing,
        };
        keep_longest(&mut self.longest_gaps, &gap);
        if self.gaps.len() < MAX_LISTED_GAPS {
            self.gaps.push(gap);
        }
        Ok(TimeStep::Gap(missing))
    }

    fn time_error(&self, row: u64, previous_s: f64, this_s: f64) -> InputError {
        InputError::NonMonotonicTime {
            path: self.path.clone(),
            column: self.time_name.clone(),
            row,
            previous_s,
            this_s,
        }
    }

    /// Inserts `missing` rows on the straight line from the previous row to `next`.
    fn fill_gap(&mut self, missing: u64, next: &[f64]) {
        let Some(previous) = self.previous_row.clone() else {
            return;
        };
        for k in 1..=missing {
            let w = k as f64 / (missing + 1) as f64;
            for (c, (&a, &b)) in previous.iter().zip(next).enumerate() {
                self.push_sample(c, a + (b - a) * w);
            }
        }
        self.filled += missing;
    }

    /// Hands on rows `a..b` of `block`.
    /// Screens rows `a..b` of `block` and queues them. A channel's whole block that nothing is
    /// held before is taken as it is (its buffer moved, not copied: the block is not read again
    /// after its last rows are queued).
    fn emit_rows(&mut self, block: &mut Block, a: usize, b: usize) -> Result<(), InputError> {
        if a >= b {
            return Ok(());
        }
        // The statistics' one pass tells whether every sample is finite (their sums are).
        let scans: Option<Vec<SliceScan>> = block
            .channels
            .iter()
            .map(|c| SliceScan::of(&c[a..b]))
            .collect();
        let last_row = |block: &Block| block.channels.iter().map(|c| c[b - 1]).collect();
        if let Some(scans) = scans {
            self.previous_row = Some(last_row(block));
            for ((c, values), scan) in block.channels.iter_mut().enumerate().zip(scans) {
                let slice = &values[a..b];
                self.stats[c].push_scanned(slice, scan);
                if let Some(start) = self.runs[c].start.take() {
                    let from = self.runs[c].last_finite.unwrap_or(slice[0]);
                    interpolate(&mut self.pending[c][start..], from, slice[0]);
                }
                self.runs[c].last_finite = Some(slice[slice.len() - 1]);
                if a == 0 && b == values.len() && self.pending[c].is_empty() {
                    self.pending[c] = std::mem::take(values);
                } else {
                    self.pending[c].extend_from_slice(slice);
                }
            }
            return Ok(());
        }
        for i in a..b {
            let row = block.first_row + i as u64;
            let mut bad = false;
            for c in 0..block.channels.len() {
                let x = block.channels[c][i];
                self.stats[c].push(x);
                if !x.is_finite() {
                    bad = true;
                    self.nonfinite[c] += 1;
                    self.first_nonfinite[c].get_or_insert(row);
                    if self.options.nonfinite == NonFinitePolicy::Error {
                        return Err(InputError::NonFinite {
                            path: self.path.clone(),
                            column: self.names[c].clone(),
                            row,
                            value: if x.is_nan() {
                                "NaN or null"
                            } else {
                                "infinite"
                            }
                            .into(),
                        });
                    }
                }
            }
            if bad && self.options.nonfinite == NonFinitePolicy::Drop {
                self.dropped += 1;
                continue;
            }
            for c in 0..block.channels.len() {
                self.push_sample(c, block.channels[c][i]);
            }
            self.previous_row = Some(block.channels.iter().map(|c| c[i]).collect());
        }
        Ok(())
    }

    /// Appends one sample, opening or closing an interpolation run.
    fn push_sample(&mut self, c: usize, x: f64) {
        let run = &mut self.runs[c];
        if x.is_finite() {
            if let Some(start) = run.start.take() {
                let from = run.last_finite.unwrap_or(x);
                interpolate(&mut self.pending[c][start..], from, x);
            }
            run.last_finite = Some(x);
        } else {
            if run.start.is_none() {
                run.start = Some(self.pending[c].len());
            }
            self.interpolated[c] += 1;
        }
        self.pending[c].push(x);
    }

    /// Takes the rows every channel has finished.
    fn take_ready(&mut self) -> SampleChunk {
        let ready = self
            .pending
            .iter()
            .zip(&self.runs)
            .map(|(p, r)| r.start.unwrap_or(p.len()))
            .min()
            .unwrap_or(0);
        let channels: Vec<Vec<f64>> = self
            .pending
            .iter_mut()
            .zip(&mut self.runs)
            .map(|(p, r)| {
                if let Some(s) = &mut r.start {
                    *s -= ready;
                }
                if ready == p.len() {
                    std::mem::take(p)
                } else {
                    p.drain(..ready).collect()
                }
            })
            .collect();
        self.samples_out += ready as u64;
        SampleChunk { channels }
    }
}

/// Overwrites `gap` with the points strictly between `from` and `to` on a straight line.
fn interpolate(gap: &mut [f64], from: f64, to: f64) {
    let n = gap.len() as f64 + 1.0;
    for (k, v) in gap.iter_mut().enumerate() {
        *v = from + (to - from) * (k as f64 + 1.0) / n;
    }
}

/// What a row's timestamp is, against the previous row's.
enum TimeStep {
    /// The next sample on the grid.
    Next,
    /// The first sample after this many missing ones (the gap policy lets the run go on).
    Gap(u64),
    /// The previous timestamp again, a row the duplicate policy drops.
    Repeat,
}
