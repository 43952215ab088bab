//! Input quality: time-base checks (duplicates, reversals, gaps), non-finite samples and per-channel
//! statistics, with explicit policies for what to do about each problem.
//!
//! The defaults refuse: a gap or a NaN is an error naming file, column and row, because an Allan
//! variance computed across an unnoticed gap is a wrong number printed as if right. The policies
//! `--on-gap ignore|fill` and `--on-nonfinite drop|interpolate` continue, and everything they did is in
//! the [`QualityReport`].

mod clean;
mod stats;

use std::fmt;
use std::str::FromStr;

use serde::Serialize;

pub use clean::{Cleaner, SampleChunk};
pub use stats::{ChannelStats, ChannelSummary};

/// What to do with a NaN, ±Inf or null sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum NonFinitePolicy {
    /// Stop with an error naming the first bad sample.
    #[default]
    Error,
    /// Remove the whole row (all channels), keeping channels aligned; the time base shortens.
    Drop,
    /// Replace each run of bad samples by the straight line between its finite neighbours (held flat at
    /// the start or end of the recording).
    Interpolate,
}

/// What to do where the time column shows missing samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum GapPolicy {
    /// Stop with an error naming the row after the gap.
    #[default]
    Error,
    /// Report the gaps and analyse the samples as if contiguous.
    Ignore,
    /// Insert the missing samples, linearly interpolated between the rows around the gap.
    Fill,
}

/// Options of the quality stage.
#[derive(Debug, Clone, Copy, Default)]
pub struct QualityOptions {
    pub nonfinite: NonFinitePolicy,
    pub gaps: GapPolicy,
}

/// An invalid policy name.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown policy {given:?} (accepted: {accepted})")]
pub struct UnknownPolicy {
    pub given: String,
    pub accepted: &'static str,
}

impl FromStr for NonFinitePolicy {
    type Err = UnknownPolicy;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "error" => Ok(Self::Error),
            "drop" => Ok(Self::Drop),
            "interpolate" => Ok(Self::Interpolate),
            _ => Err(UnknownPolicy {
                given: s.into(),
                accepted: "error, drop, interpolate",
            }),
        }
    }
}

impl FromStr for GapPolicy {
    type Err = UnknownPolicy;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "error" => Ok(Self::Error),
            "ignore" => Ok(Self::Ignore),
            "fill" => Ok(Self::Fill),
            _ => Err(UnknownPolicy {
                given: s.into(),
                accepted: "error, ignore, fill",
            }),
        }
    }
}

impl fmt::Display for NonFinitePolicy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Error => "error",
            Self::Drop => "drop",
            Self::Interpolate => "interpolate",
        })
    }
}

impl fmt::Display for GapPolicy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Error => "error",
            Self::Ignore => "ignore",
            Self::Fill => "fill",
        })
    }
}

/// A run of missing samples found in the time column.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Gap {
    /// The first row after the gap (0-based data row).
    pub row: u64,
    /// Time of the row before the gap, seconds from the first row.
    pub after_s: f64,
    pub duration_s: f64,
    pub missing_samples: u64,
}

/// Gaps listed individually in a report; beyond this only their count and total are kept.
pub const MAX_LISTED_GAPS: usize = 100;

/// What the quality stage saw and did, per recording.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct QualityReport {
    pub rows_read: u64,
    /// Samples per channel handed on to the estimators.
    pub samples_out: u64,
    pub duration_s: f64,
    pub nonfinite_policy: NonFinitePolicy,
    pub gap_policy: GapPolicy,
    pub gaps: Vec<Gap>,
    pub gap_count: u64,
    pub missing_samples: u64,
    pub filled_samples: u64,
    pub dropped_rows: u64,
    pub channels: Vec<ChannelQuality>,
}

/// One channel's quality figures.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct ChannelQuality {
    pub name: String,
    pub nonfinite_samples: u64,
    pub first_nonfinite_row: Option<u64>,
    pub interpolated_samples: u64,
    #[serde(flatten)]
    pub summary: ChannelSummary,
}
