//! Input quality: time-base checks (duplicates, reversals, gaps), non-finite samples and per-channel
//! statistics, with explicit policies for what to do about each problem.
//!
//! The defaults refuse: a gap or a NaN is an error naming file, column and row, because an Allan
//! variance computed across an unnoticed gap is a wrong number printed as if right. The policies
//! `--on-gap ignore|fill` and `--on-nonfinite drop|interpolate` continue, and everything they did is in
//! the [`QualityReport`].

mod clean;
pub mod motion;
mod stats;

use std::fmt;
use std::str::FromStr;

use serde::Serialize;

use crate::io::ChannelSpec;
use crate::units::Kind;

pub use clean::{Cleaner, SampleChunk, JITTER_AMBIGUOUS_PERIODS};
pub use stats::{smallest_step, ChannelStats, ChannelSummary};

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

/// What to do with a row whose timestamp equals the previous row's: a message published twice
/// (a ROS bag export can hold such repeats), or two samples the logger stamped alike.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DuplicatePolicy {
    /// Stop with an error naming the row.
    #[default]
    Error,
    /// Keep the first row of each repeated timestamp and drop the others (counted in
    /// [`QualityReport::duplicate_rows`]).
    Drop,
}

/// Options of the quality stage.
#[derive(Debug, Clone, Copy, Default)]
pub struct QualityOptions {
    pub nonfinite: NonFinitePolicy,
    pub gaps: GapPolicy,
    pub duplicates: DuplicatePolicy,
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

impl FromStr for DuplicatePolicy {
    type Err = UnknownPolicy;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "error" => Ok(Self::Error),
            "drop" => Ok(Self::Drop),
            _ => Err(UnknownPolicy {
                given: s.into(),
                accepted: "error, drop",
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

impl fmt::Display for DuplicatePolicy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Error => "error",
            Self::Drop => "drop",
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
    /// The longest gaps (at most [`MAX_LISTED_GAPS`]) in the order of the record, wherever they
    /// fall, for [`QualityReport::filled_stretches`]; `gaps` lists the first ones.
    #[serde(skip)]
    pub longest_gaps: Vec<Gap>,
    pub gap_count: u64,
    pub missing_samples: u64,
    pub filled_samples: u64,
    pub dropped_rows: u64,
    /// The duplicate policy in force, and the rows it dropped (their timestamp repeated the
    /// previous row's).
    pub duplicate_policy: DuplicatePolicy,
    pub duplicate_rows: u64,
    /// How far timestamps stray from the grid of sample instants; `None` without a time column.
    pub time_jitter: Option<TimeJitter>,
    pub channels: Vec<ChannelQuality>,
}

/// Timestamp jitter: each timestamp's deviation from the tracked grid of sample instants.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub struct TimeJitter {
    pub rms_s: f64,
    pub max_s: f64,
    /// The jitter reaches [`JITTER_AMBIGUOUS_PERIODS`] of a period: a late sample and a missing one
    /// can no longer be told apart, so the gap count may be wrong either way.
    pub gaps_ambiguous: bool,
    /// How finely the timestamps resolve time, s: one tick of an integer column, the spacing of
    /// a float column's values at its largest (epoch seconds in f64: 2.4e-7 s), and at least the
    /// spacing of the seconds since the first sample that the grid is tracked in. Deviations of a
    /// few of these are rounding, not the clock's jitter.
    pub resolution_s: f64,
}

impl TimeJitter {
    /// Deviations this many [`TimeJitter::resolution_s`] and below are rounding.
    pub const ROUNDING_SPACINGS: f64 = 16.0;

    /// Whether even the largest deviation is rounding: the timestamps lie on their grid as
    /// exactly as their floating-point values can say, and there is no jitter to report.
    pub fn below_resolution(&self) -> bool {
        self.max_s <= Self::ROUNDING_SPACINGS * self.resolution_s
    }
}

impl QualityReport {
    /// Whether a channel can be analysed at all (see [`ChannelVerdict::analysable`]).
    pub fn analysable(&self, channel: &str) -> bool {
        self.channels
            .iter()
            .find(|c| c.name == channel)
            .is_none_or(|c| c.verdicts.iter().all(ChannelVerdict::analysable))
    }

    /// Where the series the estimators see is no measurement, at the gaps listed and the longest
    /// ones ([`MAX_LISTED_GAPS`] each), in seconds of that series at `rate_hz`: the stretches (start, end)
    /// that `--on-gap fill` filled with a straight line, or the joins (t, t) where `--on-gap
    /// ignore` put a gap's two sides next to each other (the sensor's bias moved on in the
    /// missing time, so the series jumps there: a 30-s gap joined over was read as an
    /// excursion's end); none under `error`.
    pub fn filled_stretches(&self, rate_hz: f64) -> Vec<(f64, f64)> {
        // The first gaps listed and the longest anywhere, each once, in the record's order.
        let mut gaps: Vec<&Gap> = self.gaps.iter().chain(&self.longest_gaps).collect();
        gaps.sort_by_key(|g| g.row);
        gaps.dedup_by_key(|g| g.row);
        match self.gap_policy {
            GapPolicy::Fill => gaps
                .iter()
                .map(|g| (g.after_s, g.after_s + g.duration_s))
                .collect(),
            GapPolicy::Ignore if rate_hz > 0.0 => gaps
                .iter()
                .map(|g| {
                    let t = g.row as f64 / rate_hz;
                    (t, t)
                })
                .collect(),
            _ => Vec::new(),
        }
    }

    /// One line per channel left out of the noise analysis for want of a unit (`name: why`): a
    /// batch's per-channel rows cover only gyro and accelerometer channels, so without this line
    /// an axis whose unit is missing would simply not be there.
    pub fn unit_notes(&self) -> Vec<String> {
        self.channels
            .iter()
            .filter(|c| c.verdicts.contains(&ChannelVerdict::NoUnit))
            .map(|c| format!("{}: {}", c.name, ChannelVerdict::NoUnit.describe()))
            .collect()
    }
}

/// Runs of identical samples at least this long, in a channel that otherwise spans many quantisation
/// levels, mean the sensor froze: with noise of even one level, the chance of such a run is below
/// 1e-20.
pub const STUCK_RUN_SAMPLES: u64 = 64;

/// A channel whose samples take this few levels or fewer shows its quantiser, not its noise.
pub const FEW_LEVELS: u64 = 2;

/// What the quality screen says about one channel. Each names a reason the numbers that follow may
/// not mean what they seem.
#[derive(Debug, Clone, Serialize, PartialEq)]
#[serde(tag = "verdict", rename_all = "snake_case")]
pub enum ChannelVerdict {
    /// Every sample is the same value: a stuck or disconnected sensor. Not analysed.
    Stuck { value: f64 },
    /// The samples take only one or two quantisation levels: the noise is below the resolution and
    /// the spectrum shows the quantiser. Not analysed.
    FewLevels { levels: u64, step: f64 },
    /// A run of identical samples in an otherwise lively inertial channel: it froze for a while.
    StuckRun { start_sample: u64, samples: u64 },
    /// Many samples sit on the extreme values: a clipped (saturated) sensor.
    PossiblySaturated {
        samples_at_min: u64,
        samples_at_max: u64,
    },
    /// No unit from the file or `--unit`: analysed as a plain number (aux), not as gyro or accel.
    NoUnit,
    /// The accelerometer channels' means add up to a magnitude (`norm`, m/s² as read) that a
    /// static recording has only in another unit: gravity read in `likely` where the file or a
    /// flag said otherwise (g given as m/s² reads 1.0 m/s²; m/s² given as g, 96 m/s²).
    /// Analysed as labelled, so every accelerometer coefficient may be off by that factor.
    GravityScale { norm: f64, likely: String },
}

/// Tolerance of [`gravity_scale`]'s match of the accelerometers' mean magnitude to a unit
/// confusion: a static sensor's reading of gravity is within a few percent of standard gravity
/// (latitude, altitude, its bias), a moving one matches such a factor only by chance.
const GRAVITY_TOLERANCE: f64 = 0.05;

/// The [`ChannelVerdict::GravityScale`] of a recording whose accelerometer channels have these
/// means (SI, as read), if their magnitude is standard gravity read in a confused unit.
pub fn gravity_scale(accel_means: &[f64]) -> Option<ChannelVerdict> {
    if accel_means.is_empty() || accel_means.iter().any(|m| !m.is_finite()) {
        return None;
    }
    let norm = accel_means.iter().map(|m| m * m).sum::<f64>().sqrt();
    let g = crate::units::STANDARD_GRAVITY;
    // What standard gravity reads as, in m/s², when its values are in the first unit named and
    // were converted from the second. Confusions that shrink gravity below 0.5 m/s² (g read as mg:
    // 0.0098) are left out: a pair of horizontal axes' biases reads that much.
    [
        (1.0, "g, read as m/s²"),
        (g * g, "m/s², read as g"),
        (1e3 * g, "mg, read as g"),
    ]
    .into_iter()
    .find(|(reads, _)| (norm / reads - 1.0).abs() <= GRAVITY_TOLERANCE)
    .map(|(_, likely)| ChannelVerdict::GravityScale {
        norm,
        likely: likely.into(),
    })
}

impl ChannelVerdict {
    /// Whether the channel's noise can be estimated and fitted at all.
    pub fn analysable(&self) -> bool {
        !matches!(
            self,
            ChannelVerdict::Stuck { .. } | ChannelVerdict::FewLevels { .. }
        )
    }

    /// One line for a person.
    pub fn describe(&self) -> String {
        match self {
            ChannelVerdict::Stuck { value } => {
                format!("stuck: every sample is {value}; not analysed")
            }
            ChannelVerdict::FewLevels { levels, step } => format!(
                "only {levels} quantisation levels (step {step:.3e}): the noise is below the \
                 resolution; not analysed"
            ),
            ChannelVerdict::StuckRun {
                start_sample,
                samples,
            } => {
                let noun = if *samples == 1 { "sample" } else { "samples" };
                format!("froze for {samples} {noun} from sample {start_sample} (identical values)")
            }
            ChannelVerdict::PossiblySaturated {
                samples_at_min,
                samples_at_max,
            } => {
                let noun = if *samples_at_min == 1 {
                    "sample"
                } else {
                    "samples"
                };
                format!(
                    "possibly saturated ({samples_at_min} {noun} at the minimum, {samples_at_max} \
                     at the maximum)"
                )
            }
            ChannelVerdict::NoUnit => NO_UNIT_TEXT.into(),
            ChannelVerdict::GravityScale { norm, likely } => format!(
                "the accelerometers' means have a magnitude of {norm:.4} m/s² as labelled, where a \
                 static sensor reads gravity, 9.807 m/s²: the values look like {likely}; check \
                 the unit (--unit) before using any accelerometer coefficient"
            ),
        }
    }
}

/// What [`ChannelVerdict::NoUnit`] says of a channel; batch outputs find the channels left out
/// of the noise analysis by it.
pub const NO_UNIT_TEXT: &str =
    "no unit: analysed as aux, not as gyro or accel (give --unit COLUMN=UNIT)";

/// The verdicts for one channel from its summary.
pub fn verdicts(spec: &ChannelSpec, summary: &ChannelSummary) -> Vec<ChannelVerdict> {
    let mut out = Vec::new();
    if spec.unit.is_none() {
        out.push(ChannelVerdict::NoUnit);
    }
    if summary.finite_samples == 0 {
        return out;
    }
    let levels = summary
        .smallest_step
        .map(|step| ((summary.max - summary.min) / step).round() as u64 + 1);
    if summary.min == summary.max {
        out.push(ChannelVerdict::Stuck { value: summary.min });
    } else if let (Some(levels), Some(step)) = (levels, summary.smallest_step) {
        if levels <= FEW_LEVELS {
            out.push(ChannelVerdict::FewLevels { levels, step });
        }
    }
    let inertial = matches!(spec.kind, Kind::Gyro | Kind::Accel);
    let lively = levels.is_some_and(|l| l > 8);
    if inertial && lively && summary.longest_repeat >= STUCK_RUN_SAMPLES {
        out.push(ChannelVerdict::StuckRun {
            start_sample: summary.longest_repeat_start,
            samples: summary.longest_repeat,
        });
    }
    // Saturation is judged on inertial channels only: a slow temperature sensor held at each IMU
    // sample (MCAP temperature topics) sits on its extremes for many samples without clipping.
    // With a handful of levels, an extreme level holding many samples is what a coarse
    // quantiser does; clipping cannot be told from it.
    let unresolved = out.iter().any(|v| !v.analysable());
    if inertial && lively && summary.possibly_saturated && !unresolved {
        out.push(ChannelVerdict::PossiblySaturated {
            samples_at_min: summary.samples_at_min,
            samples_at_max: summary.samples_at_max,
        });
    }
    out
}

/// One channel's quality figures.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct ChannelQuality {
    pub name: String,
    pub nonfinite_samples: u64,
    pub first_nonfinite_row: Option<u64>,
    pub interpolated_samples: u64,
    /// What the screen says about the channel (empty when nothing).
    pub verdicts: Vec<ChannelVerdict>,
    #[serde(flatten)]
    pub summary: ChannelSummary,
}

#[cfg(test)]
mod tests {
    use super::{gravity_scale, ChannelVerdict};

    /// Gravity in g read as m/s² (one vertical axis, or three tilted), in m/s² read as g, in mg
    /// read as g; a right reading, a pair of level axes and a moving sensor get nothing.
    #[test]
    fn gravity_in_the_wrong_unit_is_named() {
        let g = crate::units::STANDARD_GRAVITY;
        let likely = |means: &[f64]| match gravity_scale(means) {
            Some(ChannelVerdict::GravityScale { likely, .. }) => Some(likely),
            _ => None,
        };
        assert_eq!(
            likely(&[0.01, -0.02, 1.0]).as_deref(),
            Some("g, read as m/s²")
        );
        assert_eq!(likely(&[0.5, 0.5, 0.7]).as_deref(), Some("g, read as m/s²"));
        assert_eq!(
            likely(&[0.0, 0.0, g * g]).as_deref(),
            Some("m/s², read as g")
        );
        assert_eq!(
            likely(&[0.0, 0.0, -1e3 * g]).as_deref(),
            Some("mg, read as g")
        );
        assert_eq!(likely(&[0.02, 0.0, g]), None);
        assert_eq!(likely(&[0.01, 0.003]), None);
        assert_eq!(likely(&[3.0, 2.0, 4.0]), None);
        assert_eq!(likely(&[]), None);
    }
}
