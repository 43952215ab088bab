//! Fleet screening: many recordings, one verdict per sensor, in bounded memory.
//!
//! A test lab qualifying a batch of sensors, or a robotics team checking every IMU of every robot
//! nightly, asks of a folder of recordings: which sensors are out of specification, which are
//! unlike their siblings, and why. `imunoise screen` answers it with this module; the CLI only
//! parses flags and prints.
//!
//! The data flow, one direction:
//! ```text
//! inputs (folders, lists) ─► shard K of N ─► per file: pipeline::run ─► records ─► part file
//!                                                       (dropped after writing)
//! all part files of the run ─► fleet step: spec verdicts, robust z, rare effects
//!                           ─► fleet.parquet, summary.md, fleet.html
//! ```
//! - [`inputs`]: which files (folders walked recursively in sorted order) and which of them this
//!   shard takes (a stable hash of the path relative to its input root).
//! - [`hash`]: the fingerprints that make a rerun skip finished work: the file's identity and the
//!   analysis options.
//! - [`spec`]: the TOML specification (limits with units per sensor kind and term, fleet options).
//! - [`verdict`]: a limit against an interval: pass, fail, undecided, or no estimate.
//! - [`robust`]: median, MAD and the robust z-score behind the outlier test.
//! - [`record`]: one row per inertial channel, taken from a file's analysis (or its error).
//! - [`table`]: those rows as Arrow/Parquet, written atomically with the fingerprints in the
//!   footer; and the fleet table.
//! - [`layout`]: where everything lives in the output folder (hive-style `results/shard=K/`),
//!   the per-shard manifests, pruning.
//! - [`lock`]: one writer per shard folder; stale locks of dead processes are taken over.
//! - [`plots`]: the per-file plots of `--plots`, drawn for flagged files (again after the fleet
//!   step for outliers) and never left stale or half-written.
//! - [`budget`]: the estimated memory of a file's analysis and the budget that admits files.
//! - [`batch`]: the per-file loop (one file at a time, or a few concurrently), skipping what is
//!   up to date.
//! - [`assess`]: the fleet step proper: verdicts, outliers, unusual effects.
//! - [`summary`] and [`html`]: the human outputs.
//!
//! Memory: a file's samples and estimates are dropped once its part file is written, so the
//! batch holds one file's analysis per worker whatever the number of files; the fleet step holds
//! the small per-channel rows (a few hundred bytes each) of the whole fleet.

pub mod assess;
pub mod batch;
pub mod budget;
pub mod hash;
pub mod html;
pub mod inputs;
pub mod layout;
pub mod lock;
pub mod plots;
pub mod record;
pub mod robust;
pub mod spec;
pub mod summary;
pub mod table;
pub mod verdict;

use std::path::PathBuf;

pub use assess::{assess, FailOn, Fleet, FleetRow, TermAssessment, TermStats, UnusualEffect};
pub use batch::{
    run_batch, BatchConfig, BatchSummary, FileOutcome, Observer, PlotPolicy, StageTimes,
};
pub use inputs::{collect_inputs, collect_inputs_noting, Input, Shard};
pub use layout::{fleet_step, FleetStepSummary, Layout};
pub use lock::{Lock, LockError, TakenOver};
pub use plots::{plot_after_fleet, PlotPass};
pub use record::{ChannelRecord, Status, TermValues};
pub use robust::{median, robust_z, RobustScale};
pub use spec::{FleetOptions, Limit, Spec, SpecError};
pub use verdict::{judge, Basis, Verdict};

/// Version of the part-file and fleet-table schemas; a part file of another version is
/// recomputed, not read. 4: the terms' `lo_1sigma` and `hi_1sigma` columns.
pub const SCHEMA_VERSION: u32 = 4;

/// Something that stops the screen as a whole (as opposed to one input's error, which becomes
/// that input's row).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ScreenError {
    /// An input argument or list that cannot be read.
    #[error("{path}: {message}")]
    Input { path: PathBuf, message: String },
    /// The output folder, a result or a manifest cannot be written or read.
    #[error("{path}: {message}")]
    Output { path: PathBuf, message: String },
    #[error(transparent)]
    Lock(#[from] LockError),
}

impl ScreenError {
    pub(crate) fn output(path: impl Into<PathBuf>, e: impl std::fmt::Display) -> Self {
        ScreenError::Output {
            path: path.into(),
            message: e.to_string(),
        }
    }
}

impl From<crate::report::OutputError> for ScreenError {
    fn from(e: crate::report::OutputError) -> Self {
        ScreenError::Output {
            path: e.path,
            message: e.message,
        }
    }
}
