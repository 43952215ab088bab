//! The per-file loop of a screen: each input of the shard analysed (or skipped), its rows written
//! at once, its analysis dropped.
//!
//! **Skipping.** An input is skipped when its part file exists and its footer names the same file
//! identity and options hash ([`super::hash`]) — whether the result was rows or an error: the same
//! bytes under the same options fail the same way (`retry_errors` recomputes error results, for
//! errors that came from outside the file, such as a full disk). A result found in another shard's
//! folder (a run with another shard count) is moved over instead of recomputed.
//!
//! **Memory.** `threads` workers take the next input from a shared counter (and, under a memory
//! budget, start it only when its estimated footprint fits beside the files in flight:
//! [`super::budget`]); each holds one file's
//! [`crate::pipeline::FileResult`] (samples are already dropped inside the pipeline; spectra and
//! deviations here, once the rows are written), so memory is bounded by the worker count, not the
//! number of files. The analysis of each file is itself parallel (rayon over channels), so one
//! worker already keeps the cores busy on multi-axis files; more workers help with many short
//! files of few channels, at the memory of that many files.

use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use crate::estimate::Backend;
use crate::pipeline::{self, Inputs, Work};

use super::budget::{footprint_bytes, Budget};
use super::hash::file_identity;
use super::inputs::{Input, Shard};
use super::layout::{adopt, prune, Layout, Manifest};
use super::plots::{remove_file_plots, write_file_plots};
use super::record::{ChannelRecord, Status};
use super::spec::Spec;
use super::table::{read_part, read_part_meta, write_part, PartMeta};
use super::verdict::{judge, Verdict};
use super::{ScreenError, SCHEMA_VERSION};

/// Which inputs get the per-file plots of `analyze` (`DIR/plots/<key>/`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PlotPolicy {
    #[default]
    None,
    /// Files with a flagged channel: a limit failure or a quality verdict (plotted by the batch),
    /// a fleet outlier or an unusual effect (known in the fleet step, which analyses those files
    /// again: [`super::plots::plot_after_fleet`]).
    Failures,
    All,
}

impl std::str::FromStr for PlotPolicy {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim() {
            "none" => Ok(PlotPolicy::None),
            "failures" => Ok(PlotPolicy::Failures),
            "all" => Ok(PlotPolicy::All),
            other => Err(format!("{other:?}: expected none, failures or all")),
        }
    }
}

/// How to run a shard's batch.
#[derive(Debug, Clone, Copy)]
pub struct BatchConfig<'a> {
    pub layout: &'a Layout,
    pub shard: Shard,
    pub inputs: &'a Inputs,
    pub work: &'a Work,
    /// [`super::hash::options_hash`] of the run.
    pub options: &'a str,
    /// Files analysed concurrently (≥ 1).
    pub threads: usize,
    pub retry_errors: bool,
    pub plots: PlotPolicy,
    pub spec: &'a Spec,
    /// Estimated bytes of analyses in flight at once ([`super::budget`]); `None`: only
    /// `threads` bounds them.
    pub memory_budget: Option<u64>,
}

/// What happened to one input.
#[derive(Debug, Clone, PartialEq)]
pub enum FileOutcome {
    /// Analysed (or failed) now and written.
    Computed {
        seconds: f64,
        /// `seconds` by stage (the stages of a file that failed to read are 0).
        time: StageTimes,
        records: Vec<ChannelRecord>,
        /// Things that went wrong beside the result (a plot that could not be written).
        notes: Vec<String>,
    },
    /// Its result was up to date (`error`: the result is an error row, with its message).
    Skipped { error: Option<String> },
    /// Its up-to-date result was moved from another shard's folder.
    Adopted { error: Option<String> },
}

impl FileOutcome {
    /// The input's error, if its result is one.
    pub fn error(&self) -> Option<&str> {
        match self {
            FileOutcome::Computed { records, .. } => records
                .iter()
                .find(|r| r.status == Status::Error)
                .and_then(|r| r.error.as_deref()),
            FileOutcome::Skipped { error } | FileOutcome::Adopted { error } => error.as_deref(),
        }
    }
}

/// Told about every input as it starts, as its channels are fitted, and as it ends; called from
/// the worker threads.
pub trait Observer: Sync {
    fn started(&self, _input: &Input) {}
    /// The share (0–1) of the input's channels fitted so far.
    fn progress(&self, _input: &Input, _fitted: f64) {}
    fn finished(&self, input: &Input, outcome: &FileOutcome);
}

/// An input's fitting progress, passed on to the batch's observer.
struct FileProgress<'a> {
    observer: &'a dyn Observer,
    input: &'a Input,
}

impl pipeline::Progress for FileProgress<'_> {
    fn fitted(&self, done: usize, of: usize) {
        if of > 0 {
            self.observer.progress(self.input, done as f64 / of as f64);
        }
    }
}

/// Where the analysed files' time went, summed over the files (seconds of each file's own
/// stages; files analysed at once overlap, so the sum exceeds the wall time by about the number
/// of threads). What a fleet's throughput is made of: `read_s` includes the screening and the
/// Welch updates streamed while reading, `estimate_s` finishing the Welch estimate and the Allan
/// statistics, `fit_s` the fits and the residual loop, `write_s` the file's plots and its part
/// file.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StageTimes {
    pub read_s: f64,
    pub estimate_s: f64,
    pub fit_s: f64,
    pub write_s: f64,
}

impl StageTimes {
    fn add(&mut self, o: &StageTimes) {
        self.read_s += o.read_s;
        self.estimate_s += o.estimate_s;
        self.fit_s += o.fit_s;
        self.write_s += o.write_s;
    }

    /// "read 1.2 s (30 %), estimate …": each stage with its share of the total.
    pub fn describe(&self) -> String {
        let total = self.read_s + self.estimate_s + self.fit_s + self.write_s;
        let share = |x: f64| if total > 0.0 { 100.0 * x / total } else { 0.0 };
        [
            ("read and screen", self.read_s),
            ("estimate", self.estimate_s),
            ("fit and loop", self.fit_s),
            ("write", self.write_s),
        ]
        .iter()
        .map(|(what, s)| format!("{what} {s:.1} s ({:.0} %)", share(*s)))
        .collect::<Vec<_>>()
        .join(", ")
    }
}

/// Counts of a shard's batch.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BatchSummary {
    /// Inputs of this shard.
    pub total: usize,
    pub computed: usize,
    pub skipped: usize,
    pub adopted: usize,
    /// Inputs whose result is an error (computed now or skipped).
    pub failed: usize,
    /// Part files of inputs no longer in the run, deleted from this shard's folder.
    pub pruned: usize,
    /// The computed files' time by stage.
    pub time: StageTimes,
}

/// Runs shard `cfg.shard` of `all` (every input of the run, in order): writes the manifest,
/// analyses or skips each input of the shard, writes its part file, and prunes the shard's
/// folder. A failing input is an error row; only a failure to write the output folder stops the
/// batch.
pub fn run_batch(
    cfg: &BatchConfig<'_>,
    all: &[Input],
    backend: &dyn Backend,
    observer: &dyn Observer,
) -> Result<BatchSummary, ScreenError> {
    let mine: Vec<&Input> = all.iter().filter(|i| i.in_shard(cfg.shard)).collect();
    let dir = cfg.layout.shard_dir(cfg.shard.index);
    std::fs::create_dir_all(&dir).map_err(|e| ScreenError::output(&dir, e))?;
    // Part files a killed run of this shard was writing (the shard's lock is ours now).
    crate::report::sweep_temporaries(&dir);
    Manifest::new(cfg.shard, cfg.options, &mine).write(cfg.layout)?;

    let summary = Mutex::new(BatchSummary {
        total: mine.len(),
        ..Default::default()
    });
    let fatal: Mutex<Option<ScreenError>> = Mutex::new(None);
    let stop = AtomicBool::new(false);
    let next = AtomicUsize::new(0);
    let budget = cfg.memory_budget.map(Budget::new);
    let work = || loop {
        let i = next.fetch_add(1, Ordering::SeqCst);
        if i >= mine.len() || stop.load(Ordering::SeqCst) {
            break;
        }
        let input = mine[i];
        observer.started(input);
        match process(cfg, input, backend, budget.as_ref(), observer) {
            Ok(outcome) => {
                {
                    let mut s = summary.lock().unwrap_or_else(|e| e.into_inner());
                    match &outcome {
                        FileOutcome::Computed { time, .. } => {
                            s.computed += 1;
                            s.time.add(time);
                        }
                        FileOutcome::Skipped { .. } => s.skipped += 1,
                        FileOutcome::Adopted { .. } => s.adopted += 1,
                    }
                    if outcome.error().is_some() {
                        s.failed += 1;
                    }
                }
                observer.finished(input, &outcome);
            }
            Err(e) => {
                stop.store(true, Ordering::SeqCst);
                fatal
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .get_or_insert(e);
                break;
            }
        }
    };
    let threads = cfg.threads.clamp(1, mine.len().max(1));
    if threads == 1 {
        work();
    } else {
        std::thread::scope(|s| {
            for _ in 0..threads {
                s.spawn(work);
            }
        });
    }
    if let Some(e) = fatal.into_inner().unwrap_or_else(|e| e.into_inner()) {
        return Err(e);
    }
    let keep = all.iter().map(|i| i.key.clone()).collect();
    let mut summary = summary.into_inner().unwrap_or_else(|e| e.into_inner());
    summary.pruned = prune(cfg.layout, cfg.shard.index, &keep)?;
    Ok(summary)
}

/// The error message of an error part file.
fn part_error(path: &Path) -> Option<String> {
    read_part(path)
        .ok()?
        .into_iter()
        .find_map(|r| r.error)
        .or_else(|| Some("failed (message not readable)".into()))
}

fn process(
    cfg: &BatchConfig<'_>,
    input: &Input,
    backend: &dyn Backend,
    budget: Option<&Budget>,
    observer: &dyn Observer,
) -> Result<FileOutcome, ScreenError> {
    let part = cfg.layout.part(cfg.shard.index, &input.key);
    let identity = file_identity(&input.path);
    let current = |p: &Path| -> Option<Status> {
        let (Ok(id), Some(m)) = (&identity, read_part_meta(p)) else {
            return None;
        };
        let same = m.identity == *id
            && m.options == cfg.options
            && m.schema == SCHEMA_VERSION
            && m.key == input.key;
        (same && !(cfg.retry_errors && m.status == Status::Error)).then_some(m.status)
    };
    if let Some(status) = current(&part) {
        let error = (status == Status::Error)
            .then(|| part_error(&part))
            .flatten();
        return Ok(FileOutcome::Skipped { error });
    }
    if adopt(cfg.layout, cfg.shard.index, &input.key, |p| {
        current(p).is_some()
    })? {
        let error = (current(&part) == Some(Status::Error))
            .then(|| part_error(&part))
            .flatten();
        return Ok(FileOutcome::Adopted { error });
    }
    let mut notes = Vec::new();
    let admission = budget.map(|b| {
        let cores = rayon::current_num_threads();
        let bytes = footprint_bytes(&input.path, &cfg.inputs.open, cores).unwrap_or(0);
        let a = b.admit(bytes);
        if a.over {
            notes.push(format!(
                "estimated {} MiB, over --memory-budget {} MiB: analysed alone",
                bytes >> 20,
                b.limit() >> 20
            ));
        }
        a
    });
    // Timed from admission: the wait for room is not this file's analysis.
    let t = Instant::now();
    let mut time = StageTimes::default();
    let records = match &identity {
        Err(e) => vec![ChannelRecord::error(
            input,
            format!("{}: {e}", input.path.display()),
        )],
        Ok(_) => match pipeline::run(
            &input.path,
            cfg.inputs,
            cfg.work,
            backend,
            &FileProgress { observer, input },
        ) {
            Ok(result) => {
                let written = Instant::now();
                let r = &result.timings;
                time = StageTimes {
                    read_s: r.read_s,
                    estimate_s: r.welch_s + r.avar_s,
                    fit_s: r.fit_s,
                    write_s: 0.0,
                };
                notes.extend(result.quality.unit_notes());
                let records = ChannelRecord::from_result(input, &result);
                let plot = match cfg.plots {
                    PlotPolicy::None => false,
                    PlotPolicy::All => true,
                    PlotPolicy::Failures => records.iter().any(|r| fails(r, cfg.spec)),
                };
                // Plots of an earlier version of this file are not this result's.
                let drawn = if plot {
                    write_file_plots(cfg.layout, &input.key, &result)
                } else {
                    remove_file_plots(cfg.layout, &input.key)
                };
                if let Err(e) = drawn {
                    notes.push(format!("plots not written: {e}"));
                }
                // The spectra, deviations and fits go here, before the next file.
                drop(result);
                time.write_s = written.elapsed().as_secs_f64();
                records
            }
            Err(e) => vec![ChannelRecord::error(input, e.to_string()).at(e.column(), e.row())],
        },
    };
    let status = if records.iter().any(|r| r.status == Status::Error) {
        Status::Error
    } else {
        Status::Ok
    };
    let meta = PartMeta {
        identity: identity.unwrap_or_default(),
        options: cfg.options.to_string(),
        schema: SCHEMA_VERSION,
        status,
        key: input.key.clone(),
    };
    let written = Instant::now();
    write_part(&part, &records, &meta)?;
    time.write_s += written.elapsed().as_secs_f64();
    if admission.is_none() {
        // (An admission does this when it is dropped.)
        crate::memory::release_freed_memory();
    }
    drop(admission);
    Ok(FileOutcome::Computed {
        seconds: t.elapsed().as_secs_f64(),
        time,
        records,
        notes,
    })
}

/// Whether a channel fails a limit of `spec` or has a quality verdict other than `no_unit` (the
/// per-file part of what the fleet step flags).
fn fails(r: &ChannelRecord, spec: &Spec) -> bool {
    let Some(sensor) = r.kind else {
        return false;
    };
    let spec_fail = spec.limits.iter().filter(|l| l.sensor == sensor).any(|l| {
        let t = r.term(l.term);
        judge(t.interval(), t.upper, l.si).0 == Verdict::Fail
    });
    spec_fail || r.quality.iter().any(|q| q != "no_unit")
}

#[cfg(test)]
mod tests {
    use super::StageTimes;

    #[test]
    fn stage_times_add_up_and_give_their_shares() {
        let mut t = StageTimes::default();
        for _ in 0..2 {
            t.add(&StageTimes {
                read_s: 0.5,
                estimate_s: 0.5,
                fit_s: 1.0,
                write_s: 0.0,
            });
        }
        assert_eq!(
            t.describe(),
            "read and screen 1.0 s (25 %), estimate 1.0 s (25 %), fit and loop 2.0 s (50 %), write 0.0 s (0 %)"
        );
        // Nothing computed: no shares to divide by.
        assert!(StageTimes::default()
            .describe()
            .ends_with("write 0.0 s (0 %)"));
    }
}
