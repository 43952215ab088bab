//! One recording through the stages: io → quality → estimate → model, in a single pass over the
//! file.
//!
//! The Welch estimate streams (memory bounded by segment length × channels); the Allan-family
//! statistics need whole channels, so when they are asked for the clean samples are also collected
//! (8 bytes per sample per channel). Info alone keeps nothing but statistics.

use std::path::Path;
use std::time::Instant;

use serde::Serialize;

use crate::analysis::{self, ChannelAnalysis, ChannelInput};
use crate::avar::{AvarError, Confidence, Statistic, TauGrid};
use crate::effects::{AuxSeries, LoopConfig};
use crate::estimate::{Backend, Samples};
use crate::io::{self, InputError, OpenOptions, Recording};
use crate::model::{FitOptions, FitWarning, Sensor};
use crate::psd::{log_bin, PsdError, WelchPlan};
use crate::quality::{Cleaner, QualityOptions, QualityReport, SampleChunk};
use crate::units::Kind;
use crate::Error;

/// The τ values asked for: a grid of averaging factors, or explicit τ in seconds (converted to
/// averaging factors with each file's own rate).
#[derive(Debug, Clone, PartialEq)]
pub enum TauSpec {
    Grid(TauGrid),
    Seconds(Vec<f64>),
}

/// What to estimate for each recording.
#[derive(Debug, Clone, Default)]
pub struct Work {
    pub welch: Option<WelchWork>,
    pub avar: Option<AvarWork>,
    /// Fit the noise model to every inertial channel (needs both estimates, the OADEV among the
    /// statistics and a binned spectrum; see [`crate::analysis`]).
    pub fit: Option<FitOptions>,
    /// With [`Work::fit`]: close the loop on every fitted channel ([`crate::effects`]).
    pub residual_loop: bool,
}

/// Welch PSD settings.
#[derive(Debug, Clone)]
pub struct WelchWork {
    pub plan: WelchPlan,
    /// Log-frequency bins per decade for the binned spectrum; `None` for none.
    pub bins_per_decade: Option<u32>,
}

/// Allan-family settings.
#[derive(Debug, Clone)]
pub struct AvarWork {
    pub statistics: Vec<Statistic>,
    pub taus: TauSpec,
    pub confidence: Confidence,
}

/// Everything that says how to read and screen a recording.
#[derive(Debug, Clone, Default)]
pub struct Inputs {
    pub open: OpenOptions,
    pub quality: QualityOptions,
}

pub use crate::estimate::{ChannelDeviations, ChannelPsd};

/// Wall time spent per stage, seconds.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct Timings {
    /// Reading, converting and screening (including the streamed Welch updates).
    pub read_s: f64,
    /// Finishing the Welch estimate after the last chunk (its streamed updates are in `read_s`).
    pub welch_s: f64,
    /// The Welch estimator's own time: its streamed updates (on the calling thread, while the
    /// reader thread goes on) plus `welch_s`. What compares with a peer's Welch on a series
    /// already in memory; `read_s + welch_s` is the time from the first byte read to the spectrum.
    pub welch_busy_s: f64,
    pub avar_s: f64,
    /// The model stage: fits (and the residual analysis).
    pub fit_s: f64,
}

/// Memory evidence of the streamed stages.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct Footprint {
    /// The most samples per channel the Welch estimate held between chunks (< nperseg + the
    /// largest chunk).
    pub welch_peak_buffered_samples: usize,
    /// The largest block read, rows.
    pub largest_block_rows: usize,
    /// The largest chunk handed to the estimators, rows: blocks gathered until they hold
    /// [`CHUNK_BYTES`] of samples (all channels), so less than that plus one block.
    pub largest_chunk_rows: usize,
}

/// The results of one recording.
#[derive(Debug, Clone)]
pub struct FileResult {
    pub recording: Recording,
    pub quality: QualityReport,
    pub psd: Option<Vec<ChannelPsd>>,
    pub avar: Option<Vec<ChannelDeviations>>,
    pub timings: Timings,
    pub footprint: Footprint,
    /// Which backend computed the estimates, and any job that ran elsewhere (e.g. on the CPU after
    /// the GPU could not do it), in the backend's words.
    pub backend: String,
    pub backend_notes: Vec<String>,
    /// The model stage's results, one entry per inertial channel, when [`Work::fit`] asked.
    pub analysis: Option<Vec<ChannelAnalysis>>,
}

/// Progress reports: rows read, then channels fitted; the CLI shows them as a bar on a terminal.
/// `Sync`: the channels are fitted in parallel, and each reports as it ends.
pub trait Progress: Sync {
    fn start(&self, _path: &Path) {}
    fn advance(&self, _rows: u64) {}
    /// `done` of `of` channels fitted (called with 0 before the first).
    fn fitted(&self, _done: usize, _of: usize) {}
}

/// No progress reporting.
pub struct Silent;
impl Progress for Silent {}

/// Runs `work` on one recording.
pub fn run(
    path: &Path,
    inputs: &Inputs,
    work: &Work,
    backend: &dyn Backend,
    progress: &dyn Progress,
) -> Result<FileResult, Error> {
    // Notes left by an earlier recording that failed half-way are not this recording's.
    let _ = backend.take_notes();
    let recording = io::open(path, &inputs.open)?;
    if work.fit.is_some()
        && !recording
            .channels
            .iter()
            .any(|c| Sensor::of_kind(c.kind).is_some())
    {
        return Err(InputError::NoInertialChannel {
            path: path.to_path_buf(),
            channels: recording
                .channels
                .iter()
                .map(|c| match c.unit {
                    Some(u) => format!("{} ({}, {})", c.name, u, c.kind),
                    None => format!("{} (no unit)", c.name),
                })
                .collect::<Vec<_>>()
                .join(", "),
        }
        .into());
    }
    if let Some(opts) = &work.fit {
        let nyquist = recording.rate_hz / 2.0;
        for (flag, value) in [
            ("--fit-min-freq", opts.min_freq_hz),
            ("--fit-max-freq", opts.max_freq_hz),
        ] {
            if let Some(f) = value.filter(|&f| f >= nyquist) {
                return Err(InputError::OptionOutOfRange {
                    path: path.to_path_buf(),
                    flag,
                    message: format!(
                        "{f} Hz is not below the Nyquist frequency, {} (the fit band must lie in \
                         (0, {nyquist}) Hz)",
                        io::rate_text(nyquist)
                    ),
                }
                .into());
            }
        }
    }
    progress.start(path);
    let n_channels = recording.channels.len();
    let mut timings = Timings::default();
    let mut footprint = Footprint::default();
    let t_read = Instant::now();

    let mut welch = work
        .welch
        .as_ref()
        .map(|w| backend.welch(&w.plan, recording.rate_hz, n_channels));
    let mut series: Option<SampleChunk> = work.avar.as_ref().map(|_| SampleChunk {
        channels: vec![Vec::new(); n_channels],
    });
    let mut welch_pushes_s = 0.0;
    let mut consume = |chunk: SampleChunk| {
        if chunk.is_empty() {
            return;
        }
        if let Some(sink) = welch.as_mut() {
            let t = Instant::now();
            let slices: Vec<&[f64]> = chunk.channels.iter().map(Vec::as_slice).collect();
            sink.push(&slices);
            welch_pushes_s += t.elapsed().as_secs_f64();
        }
        if let Some(all) = series.as_mut() {
            all.append(chunk);
        }
    };
    let quality = read_overlapped(&recording, inputs.quality, |chunk, rows| {
        footprint.largest_block_rows = footprint.largest_block_rows.max(rows.largest_block);
        footprint.largest_chunk_rows = footprint.largest_chunk_rows.max(chunk.len());
        consume(chunk);
        progress.advance(rows.read as u64);
    })?;
    timings.read_s = t_read.elapsed().as_secs_f64();
    let series: Option<Vec<Vec<f64>>> = series.map(|s| s.channels);

    let psd: Option<Vec<ChannelPsd>> = match (welch, &work.welch) {
        (Some(sink), Some(w)) => {
            footprint.welch_peak_buffered_samples = sink.peak_buffered_samples();
            let t = Instant::now();
            let spectra = sink
                .finish()
                .map_err(|e| psd_error(&recording, &quality, e))?;
            timings.welch_s = t.elapsed().as_secs_f64();
            timings.welch_busy_s = welch_pushes_s + timings.welch_s;
            Some(
                recording
                    .channel_names()
                    .into_iter()
                    .zip(spectra)
                    .map(|(channel, psd)| ChannelPsd {
                        binned: w.bins_per_decade.map(|k| log_bin(&psd, k)),
                        channel,
                        psd,
                    })
                    .collect(),
            )
        }
        _ => None,
    };

    // Without a fit the samples are not needed after the Allan statistics: they are handed over,
    // and each channel's prefix sums are built in its samples' buffer.
    let (series, handed_over) = match work.fit {
        Some(_) => (series, None),
        None => (None, series),
    };
    let samples = match (&series, handed_over) {
        (Some(kept), _) => Some(Samples::Borrowed(kept)),
        (None, owned) => owned.map(Samples::Owned),
    };
    let avar: Option<Vec<ChannelDeviations>> = match (samples, &work.avar) {
        (Some(samples), Some(a)) => {
            let t = Instant::now();
            let out = deviations(&recording, samples, a, backend)?;
            timings.avar_s = t.elapsed().as_secs_f64();
            Some(out)
        }
        _ => None,
    };
    let analysis = match (&work.fit, &psd, &avar) {
        (Some(opts), Some(psd), Some(avar)) => {
            let t = Instant::now();
            let (avar, thinned_grid) = fit_grid(avar);
            let loop_cfg = match (work.residual_loop, &work.welch, &work.avar) {
                (true, Some(w), Some(a)) => Some(LoopConfig {
                    welch: w.plan.config().clone(),
                    bins_per_decade: w.bins_per_decade.unwrap_or(20),
                    taus: match (thinned_grid, &a.taus) {
                        (Some(m), _) => TauGrid::Explicit(m),
                        (None, TauSpec::Grid(g)) => g.clone(),
                        (None, TauSpec::Seconds(t)) => {
                            TauGrid::Explicit(factors_for_seconds(t, recording.rate_hz))
                        }
                    },
                    confidence: a.confidence,
                    fit: opts.clone(),
                    filled_s: quality.filled_stretches(recording.rate_hz),
                }),
                _ => None,
            };
            let samples = series.as_deref().unwrap_or(&[]);
            let out = fit_channels(
                &recording,
                &quality,
                psd,
                &avar,
                samples,
                opts,
                loop_cfg.as_ref(),
                progress,
            );
            timings.fit_s = t.elapsed().as_secs_f64();
            Some(out)
        }
        _ => None,
    };
    // The samples are not kept: a batch of many files must not hold them all.
    drop(series);
    Ok(FileResult {
        recording,
        quality,
        psd,
        avar,
        timings,
        footprint,
        backend: backend.describe(),
        backend_notes: backend.take_notes(),
        analysis,
    })
}

/// Clean chunks in flight between the reading thread and the estimators: enough that neither
/// side waits on the other's jitter, few enough that memory stays a few blocks.
const CHUNKS_IN_FLIGHT: usize = 2;
/// Samples (all channels, 8 bytes each) gathered into one chunk before the estimators take it.
pub const CHUNK_BYTES: usize = 4 << 20;

/// Rows of the file behind one chunk.
#[derive(Debug, Clone, Copy, Default)]
struct ChunkRows {
    /// Rows read (the chunk's sample count differs where the cleaner held samples back or filled
    /// gaps).
    read: usize,
    /// The largest block among them.
    largest_block: usize,
}

/// Reads and screens `recording` on a thread of its own while `consume` (the estimators, on the
/// calling thread) takes the clean samples, so that decoding, screening and the Welch transforms
/// overlap instead of taking turns. The chunks arrive in file order, gathered to about
/// [`CHUNK_BYTES`] each, with the rows of the blocks they came from. Returns the quality report,
/// or the first read or screening error (naming file, column and row as the cleaner does);
/// `consume` is not called after an error.
///
/// Measured on one channel of 10⁷ samples (`psd`, nperseg 65536, 2 cores, end to end, best of
/// 5–8 runs, alternating with the build before): Arrow IPC 0.167–0.170 → 0.148–0.165 s, Parquet
/// 0.179–0.202 → 0.154–0.170 s; read + screen + Welch (report.json's `read_s`) 0.102 → 0.091 s.
/// Less than two cores' worth because the Welch side is the longer one (0.06 s of transforms
/// on one core, 0.036–0.045 s on two) and the reader's 0.05 s competes for the same cores. The
/// price: up to [`CHUNKS_IN_FLIGHT`] + 2 chunks of [`CHUNK_BYTES`] in memory (peak 27 → 58 MiB).
fn read_overlapped(
    recording: &Recording,
    quality: QualityOptions,
    mut consume: impl FnMut(SampleChunk, ChunkRows),
) -> Result<QualityReport, Error> {
    use std::sync::mpsc::sync_channel;
    type Message = Result<(SampleChunk, ChunkRows), InputError>;
    let blocks = recording.blocks()?;
    let (tx, rx) = sync_channel::<Message>(CHUNKS_IN_FLIGHT);
    // Rows per message: a file's record batches can be small (64 Ki rows: two Welch segments of
    // 65 536 at half overlap), and each push wakes the estimators' threads for a moment's work.
    let target = (CHUNK_BYTES / (8 * recording.channels.len().max(1))).max(1);
    std::thread::scope(|scope| {
        let reader = scope.spawn(move || -> Option<QualityReport> {
            let mut cleaner = Cleaner::new(recording, quality);
            let mut pending: Option<(SampleChunk, ChunkRows)> = None;
            for block in blocks {
                let cleaned = block.and_then(|b| {
                    let rows = b.rows();
                    cleaner.push(b).map(|chunk| (chunk, rows))
                });
                let (chunk, rows) = match cleaned {
                    Ok(c) => c,
                    Err(e) => {
                        let _ = tx.send(Err(e));
                        return None;
                    }
                };
                // Blocks smaller than a message are gathered in one buffer of a message's size:
                // growing the first block's buffer instead copied each sample twice on average.
                let (held, held_rows) = pending.get_or_insert_with(|| {
                    let rows = if chunk.len() < target { target } else { 0 };
                    (
                        SampleChunk::with_capacity(chunk.channels.len(), rows),
                        ChunkRows::default(),
                    )
                });
                held.append(chunk);
                held_rows.read += rows;
                held_rows.largest_block = held_rows.largest_block.max(rows);
                if held.len() >= target {
                    // A closed channel: the consumer stopped; nothing more to do.
                    tx.send(Ok(pending.take().expect("set above"))).ok()?;
                }
            }
            match cleaner.finish() {
                Ok((last, report)) => {
                    let (mut held, rows) = pending.take().unwrap_or_default();
                    held.append(last);
                    tx.send(Ok((held, rows))).ok()?;
                    Some(report)
                }
                Err(e) => {
                    let _ = tx.send(Err(e));
                    None
                }
            }
        });
        // Owned here, so that an unwinding consumer closes the channel and frees the reader.
        let rx = rx;
        for message in rx.iter() {
            let (chunk, rows) = message?;
            consume(chunk, rows);
        }
        Ok(reader
            .join()
            .expect("the reading thread does not panic")
            .expect("a reader that sent no error returns the report"))
    })
}

/// The model stage over the inertial channels (gyro and accel kinds), in channel order, in
/// parallel; temperature and aux channels are the loop's regressors. A channel the quality screen
/// found unanalysable (stuck, one or two levels) is not fitted: its verdict says why, and no model or
/// effect is invented for it.
#[allow(clippy::too_many_arguments)]
fn fit_channels(
    recording: &Recording,
    quality: &QualityReport,
    psd: &[ChannelPsd],
    avar: &[ChannelDeviations],
    samples: &[Vec<f64>],
    opts: &FitOptions,
    loop_cfg: Option<&LoopConfig>,
    progress: &dyn Progress,
) -> Vec<ChannelAnalysis> {
    use rayon::prelude::*;
    use std::sync::atomic::{AtomicUsize, Ordering};
    let aux: Vec<AuxSeries<'_>> = recording
        .channels
        .iter()
        .zip(samples)
        .filter(|(c, _)| matches!(c.kind, Kind::Temperature | Kind::Aux))
        .map(|(c, s)| AuxSeries {
            name: &c.name,
            samples: s,
        })
        .collect();
    let inputs: Vec<ChannelInput<'_>> = recording
        .channels
        .iter()
        .enumerate()
        .filter(|(_, c)| quality.analysable(&c.name))
        .filter_map(|(i, c)| {
            Some(ChannelInput {
                sensor: Sensor::of_kind(c.kind)?,
                psd: psd.get(i)?,
                deviations: avar.get(i)?,
                samples: samples.get(i).map_or(&[], Vec::as_slice),
                rate_hz: recording.rate_hz,
                output_step: quality
                    .channels
                    .iter()
                    .find(|q| q.name == c.name)
                    .and_then(|q| q.summary.smallest_step),
            })
        })
        .collect();
    // A record in which the sensor moved is not one of its noise: every channel says so, and
    // the residual loop, which would read the motion as steps, excursions and lines (minutes on
    // one channel), is not run (see [`crate::quality::motion`]). The first channel in file order
    // that moved is named.
    let moved = inputs
        .par_iter()
        .map(|i| crate::quality::motion::motion(i.samples, i.rate_hz, i.sensor).map(|m| (i, m)))
        .collect::<Vec<_>>()
        .into_iter()
        .flatten()
        .next()
        .map(|(i, m)| FitWarning::NotStatic {
            channel: i.psd.channel.clone(),
            sensor: i.sensor,
            from_s: m.from_s,
            to_s: m.to_s,
            largest_jump: m.largest_jump,
            jumps: m.jumps,
        });
    let loop_cfg = if moved.is_some() { None } else { loop_cfg };
    // Places where the samples either side of a hole were joined as if contiguous.
    let joins = quality.dropped_rows
        + match quality.gap_policy {
            crate::quality::GapPolicy::Ignore => quality.gap_count,
            _ => 0,
        };
    let of = inputs.len();
    let done = AtomicUsize::new(0);
    progress.fitted(0, of);
    inputs
        .into_par_iter()
        .map(|input| {
            let mut a = analysis::analyze_channel(input, &aux, opts, loop_cfg);
            a.combined.warnings.extend(moved.clone());
            let lines = a.residual_loop.as_ref().is_some_and(|r| {
                r.steps.iter().any(|s| {
                    matches!(
                        s.effect,
                        crate::effects::Effect::Sinusoid(_) | crate::effects::Effect::Narrowband(_)
                    )
                })
            });
            if lines && joins > 0 {
                a.combined
                    .warnings
                    .push(FitWarning::LinesAcrossJoins { joins });
            }
            progress.fitted(done.fetch_add(1, Ordering::SeqCst) + 1, of);
            a
        })
        .collect()
}

fn psd_error(recording: &Recording, quality: &QualityReport, e: PsdError) -> Error {
    match e {
        PsdError::TooShort { nperseg, .. } => InputError::TooShort {
            path: recording.path.clone(),
            what: format!("Welch with nperseg = {nperseg}"),
            needed: nperseg as u64,
            available: quality.samples_out,
        }
        .into(),
        source => Error::Psd {
            path: recording.path.clone(),
            source,
        },
    }
}

/// The Allan curves the model stage fits: the estimated ones, thinned to
/// [`crate::model::fit_points`] where the grid asked for is denser than that, with the averaging
/// factors kept (for the residual loop's re-estimates; `None` where nothing was thinned).
fn fit_grid(
    avar: &[ChannelDeviations],
) -> (std::borrow::Cow<'_, [ChannelDeviations]>, Option<Vec<u64>>) {
    let keep = avar
        .iter()
        .flat_map(|c| &c.statistics)
        .map(|d| (d, crate::model::fit_points(&d.tau_s)))
        .find(|(d, keep)| keep.len() < d.len());
    let Some((d, keep)) = keep else {
        return (std::borrow::Cow::Borrowed(avar), None);
    };
    let m: Vec<u64> = keep.iter().map(|&i| d.m[i]).collect();
    let thinned = avar
        .iter()
        .map(|c| ChannelDeviations {
            channel: c.channel.clone(),
            statistics: c
                .statistics
                .iter()
                .map(|d| {
                    let rows: Vec<usize> = (0..d.len())
                        .filter(|&i| m.binary_search(&d.m[i]).is_ok())
                        .collect();
                    d.subset(&rows)
                })
                .collect(),
        })
        .collect();
    (std::borrow::Cow::Owned(thinned), Some(m))
}

/// Averaging factors for explicit τ: the nearest integer m = τ·rate, at least 1.
pub fn factors_for_seconds(taus_s: &[f64], rate_hz: f64) -> Vec<u64> {
    let mut m: Vec<u64> = taus_s
        .iter()
        .map(|t| (t * rate_hz).round().max(1.0) as u64)
        .collect();
    m.sort_unstable();
    m.dedup();
    m
}

fn deviations(
    recording: &Recording,
    series: Samples,
    work: &AvarWork,
    backend: &dyn Backend,
) -> Result<Vec<ChannelDeviations>, Error> {
    let n = series.channels().first().map_or(0, Vec::len);
    let grid = match &work.taus {
        TauSpec::Grid(g) => g.clone(),
        TauSpec::Seconds(t) => TauGrid::Explicit(factors_for_seconds(t, recording.rate_hz)),
    };
    let mut out: Vec<ChannelDeviations> = recording
        .channel_names()
        .into_iter()
        .map(|channel| ChannelDeviations {
            channel,
            statistics: Vec::new(),
        })
        .collect();
    let all = backend.statistics(
        series,
        recording.rate_hz,
        &grid,
        &work.statistics,
        work.confidence,
    );
    for (&statistic, results) in work.statistics.iter().zip(all) {
        for (slot, result) in out.iter_mut().zip(results) {
            // An explicit τ the recording cannot support is an error naming it, not a silently
            // shorter list (the Allan module checks; here it gets the file's name).
            let d = result.map_err(|e| match e {
                AvarError::TooShort { m, needed, .. } => {
                    too_short(recording, statistic, m, needed as u64, n)
                }
                AvarError::NoValidTau { .. } => {
                    too_short(recording, statistic, 1, statistic.min_samples(1) as u64, n)
                }
                source => Error::Avar {
                    path: recording.path.clone(),
                    channel: slot.channel.clone(),
                    source,
                },
            })?;
            slot.statistics.push(d);
        }
    }
    Ok(out)
}

fn too_short(recording: &Recording, statistic: Statistic, m: u64, needed: u64, n: usize) -> Error {
    InputError::TooShort {
        path: recording.path.clone(),
        what: format!(
            "{statistic} at tau = {} s (m = {m})",
            m as f64 / recording.rate_hz
        ),
        needed,
        available: n as u64,
    }
    .into()
}
