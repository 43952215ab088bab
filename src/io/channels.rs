//! From a schema to the channels to analyse: which columns, in which unit and of which kind, with which
//! integer scale, and which column (if any) holds time.

use std::path::Path;

use arrow_schema::{DataType, Field, Schema, TimeUnit as ArrowTimeUnit};
use serde::Serialize;

use super::InputError;
use crate::units::{Kind, Quantity, ScaledUnit, Unit};

/// A column chosen for analysis, with everything needed to turn its raw values into SI.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ChannelSpec {
    pub name: String,
    /// Index of the column in the file's full schema.
    #[serde(skip)]
    pub column: usize,
    /// Arrow type of the stored values (e.g. `Int16`).
    pub stored_type: String,
    /// The unit the file (or a flag) says the values are in; `None` when nobody said.
    pub unit: Option<Unit>,
    pub kind: Kind,
    /// Multiplier from stored integers to `unit` (field metadata `scale`), 1 when absent.
    pub scale: f64,
    /// The sample rate where `unit` is an increment per sample ([`Unit::per_sample`]: Δθ, Δv),
    /// which turns it into a rate; 1 otherwise.
    #[serde(skip)]
    pub per_second: f64,
}

impl ChannelSpec {
    /// The unit values are in after ingest: the SI unit of `unit`'s quantity, or none if unknown.
    pub fn si_unit(&self) -> Option<Unit> {
        self.unit.map(|u| u.quantity().si_unit())
    }

    /// `si = raw · factor + offset`, scale and unit conversion combined.
    pub fn to_si(&self) -> (f64, f64) {
        let (factor, offset) = self.unit.map(Unit::to_si).unwrap_or((1.0, 0.0));
        (self.scale * factor * self.per_second, offset)
    }
}

/// How a time column encodes time.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TimeEncoding {
    /// Arrow timestamp; `seconds_per_tick` from its unit.
    Timestamp { seconds_per_tick: f64 },
    /// Floating-point values in a unit of `seconds_per_unit` seconds (1 for seconds).
    Float { seconds_per_unit: f64 },
    /// Integer ticks of `seconds_per_tick` seconds.
    IntegerTicks { seconds_per_tick: f64 },
}

impl TimeEncoding {
    /// Seconds per stored unit.
    pub fn seconds_per_unit(self) -> f64 {
        match self {
            TimeEncoding::Timestamp { seconds_per_tick }
            | TimeEncoding::IntegerTicks { seconds_per_tick } => seconds_per_tick,
            TimeEncoding::Float { seconds_per_unit } => seconds_per_unit,
        }
    }

    fn with_seconds_per_unit(self, s: f64) -> TimeEncoding {
        match self {
            TimeEncoding::Timestamp { .. } => TimeEncoding::Timestamp {
                seconds_per_tick: s,
            },
            TimeEncoding::Float { .. } => TimeEncoding::Float {
                seconds_per_unit: s,
            },
            TimeEncoding::IntegerTicks { .. } => TimeEncoding::IntegerTicks {
                seconds_per_tick: s,
            },
        }
    }
}

/// A unit of time values: `--time-unit` or a time column's `unit` metadata.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TimeUnit {
    S,
    Ms,
    Us,
    Ns,
}

impl TimeUnit {
    pub const ALL: [TimeUnit; 4] = [TimeUnit::S, TimeUnit::Ms, TimeUnit::Us, TimeUnit::Ns];

    pub fn seconds(self) -> f64 {
        match self {
            TimeUnit::S => 1.0,
            TimeUnit::Ms => 1e-3,
            TimeUnit::Us => 1e-6,
            TimeUnit::Ns => 1e-9,
        }
    }

    pub fn as_str(self) -> &'static str {
        match self {
            TimeUnit::S => "s",
            TimeUnit::Ms => "ms",
            TimeUnit::Us => "us",
            TimeUnit::Ns => "ns",
        }
    }
}

impl std::str::FromStr for TimeUnit {
    type Err = String;
    fn from_str(text: &str) -> Result<Self, String> {
        match text.trim() {
            "s" | "sec" | "seconds" => Ok(TimeUnit::S),
            "ms" | "milliseconds" => Ok(TimeUnit::Ms),
            "us" | "µs" | "microseconds" => Ok(TimeUnit::Us),
            "ns" | "nanoseconds" => Ok(TimeUnit::Ns),
            other => Err(format!("time unit {other:?} is not one of s, ms, us, ns")),
        }
    }
}

impl std::fmt::Display for TimeUnit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Where a time column's unit came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TimeUnitSource {
    /// An Arrow timestamp type carries its unit.
    ArrowType,
    /// Field metadata `unit`.
    Metadata,
    /// `--time-unit`.
    Flag,
    /// A floating-point column with fractional values in a typed format: seconds, by convention.
    FloatSeconds,
    /// Not stated: the one unit that gives a plausible sample rate (see [`resolve_time_unit`]).
    Inferred,
}

/// The time column of a recording.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TimeSpec {
    pub name: String,
    #[serde(skip)]
    pub column: usize,
    pub encoding: TimeEncoding,
    pub unit_source: TimeUnitSource,
}

/// What the user said about columns on the command line; each entry overrides file metadata.
#[derive(Debug, Clone, Default)]
pub struct ColumnOverrides {
    /// Analyse only these columns, in this order (all numeric non-time columns when empty).
    pub channels: Vec<String>,
    /// `(column or pattern, unit)`, the unit with a factor where one count is not one unit. A
    /// pattern holds `*` (any run of characters) or `?` (one character): `*` alone is every
    /// column, `gyro_*` the gyro columns (see [`lookup`] for which entry wins).
    pub units: Vec<(String, ScaledUnit)>,
    /// `(column or pattern, kind)`.
    pub kinds: Vec<(String, Kind)>,
    /// The time column's name, when not `time`/`timestamp`.
    pub time_column: Option<String>,
    /// Treat the recording as having no time column even if one is found.
    pub ignore_time: bool,
    /// `--time-unit`: the unit of a time column stored as plain numbers.
    pub time_unit: Option<TimeUnit>,
}

impl ColumnOverrides {
    fn unit_for(&self, column: &str) -> Option<ScaledUnit> {
        lookup(&self.units, column)
    }
    fn kind_for(&self, column: &str) -> Option<Kind> {
        lookup(&self.kinds, column)
    }
}

/// The entry for `column`: its exact name wins; else, of the patterns that match it, the most
/// specific (most characters that are not wildcards: `accel_*` over `*`); of equally specific
/// ones, the last given ([`check_override_columns`] refuses two of them that disagree).
fn lookup<T: Copy>(entries: &[(String, T)], column: &str) -> Option<T> {
    if let Some((_, v)) = entries.iter().rev().find(|(c, _)| c == column) {
        return Some(*v);
    }
    best_patterns(entries, column).last().map(|(_, v)| *v)
}

/// The patterns of `entries` that match `column` and are the most specific of those that do,
/// in the order given.
fn best_patterns<'a, T>(entries: &'a [(String, T)], column: &str) -> Vec<&'a (String, T)> {
    let matching: Vec<&(String, T)> = entries
        .iter()
        .filter(|(c, _)| is_pattern(c) && matches_pattern(c, column))
        .collect();
    let best = matching.iter().map(|(c, _)| specificity(c)).max();
    matching
        .into_iter()
        .filter(|(c, _)| Some(specificity(c)) == best)
        .collect()
}

/// Whether a `--unit`/`--kind` column is a pattern.
fn is_pattern(column: &str) -> bool {
    column.contains(['*', '?'])
}

/// Characters of a pattern that are not wildcards.
fn specificity(pattern: &str) -> usize {
    pattern.chars().filter(|c| !matches!(c, '*' | '?')).count()
}

/// Whether `name` matches `pattern` (`*` any run of characters, `?` one character; the rest
/// literally, letter case included, as column names are).
fn matches_pattern(pattern: &str, name: &str) -> bool {
    let p: Vec<char> = pattern.chars().collect();
    let n: Vec<char> = name.chars().collect();
    // Greedy matching with backtracking to the last star: linear in practice.
    let (mut i, mut j) = (0, 0);
    let mut star: Option<(usize, usize)> = None;
    while j < n.len() {
        if i < p.len() && (p[i] == '?' || p[i] == n[j]) {
            i += 1;
            j += 1;
        } else if i < p.len() && p[i] == '*' {
            star = Some((i, j));
            i += 1;
        } else if let Some((si, sj)) = star {
            i = si + 1;
            j = sj + 1;
            star = Some((si, sj + 1));
        } else {
            return false;
        }
    }
    p[i..].iter().all(|&c| c == '*')
}

/// Types a channel column may have: integers and floats of every width, decimals, and a
/// dictionary of any of them (each read as f64, see [`crate::io::convert::append_samples`]).
pub fn is_sample_type(t: &DataType) -> bool {
    match t {
        DataType::Dictionary(_, values) => {
            !matches!(values.as_ref(), DataType::Dictionary(..)) && is_sample_type(values)
        }
        _ => matches!(
            t,
            DataType::Float16
                | DataType::Float32
                | DataType::Float64
                | DataType::Int8
                | DataType::Int16
                | DataType::Int32
                | DataType::Int64
                | DataType::UInt8
                | DataType::UInt16
                | DataType::UInt32
                | DataType::UInt64
                | DataType::Decimal128(..)
                | DataType::Decimal256(..)
        ),
    }
}

/// Whether a column says it holds a measurement (a `unit` or `kind` in its metadata, a CSV
/// header's `[unit]`, or a ROS export's sensor field), so that one of a type that is not a sample
/// type is an error rather than a column silently left out: a gyro stored as text throughout (a
/// dead axis logged as `N/A`) or in a type this reader lacks had vanished from the report, exit 0.
fn labelled_as_measurement(field: &Field) -> bool {
    let meta = field.metadata();
    meta.contains_key("unit") || meta.contains_key("kind") || ros_unit(field.name()).is_some()
}

/// Names (any letter case) a time column goes by, in loggers' and ROS exports' spellings; the
/// unit of one stored as plain numbers is the column's `unit`, `--time-unit`, or the one that
/// gives a plausible rate (see [`crate::io`]).
const TIME_NAMES: &[&str] = &[
    // A ROS topic's CSV export (`rostopic echo -p`) holds both the receive time (`%time`) and the
    // sensor's stamp: the stamp, which Kalibr uses, is taken where both are.
    "field.header.stamp",
    "time",
    "timestamp",
    "t",
    "time_s",
    "time_ms",
    "time_us",
    "time_ns",
    "timestamp_ms",
    "timestamp_us",
    "timestamp_ns",
    "stamp",
    "%time",
    // PlotJuggler's CSV export.
    "__time",
];

/// Finds the time column: the one named by `--time-column`, else an Arrow timestamp column, else a
/// column with one of the [`TIME_NAMES`] (`time`, `timestamp`, `t`, `time_s`, `time_ms`, …), the
/// earliest in that list where several are.
pub fn find_time(
    path: &Path,
    schema: &Schema,
    overrides: &ColumnOverrides,
) -> Result<Option<TimeSpec>, InputError> {
    if overrides.ignore_time {
        return Ok(None);
    }
    let index = match &overrides.time_column {
        Some(name) => Some(
            schema
                .index_of(name)
                .map_err(|_| InputError::UnknownColumn {
                    path: path.to_path_buf(),
                    column: name.clone(),
                    available: column_list(schema),
                })?,
        ),
        None => schema
            .fields()
            .iter()
            .position(|f| matches!(f.data_type(), DataType::Timestamp(..)))
            .or_else(|| {
                let rank = |name: &str| {
                    let name = name.to_ascii_lowercase();
                    TIME_NAMES.iter().position(|t| *t == name)
                };
                schema
                    .fields()
                    .iter()
                    .enumerate()
                    .filter_map(|(i, f)| rank(f.name()).map(|r| (r, i)))
                    .min()
                    .map(|(_, i)| i)
            }),
    };
    let Some(column) = index else {
        return Ok(None);
    };
    let field = schema.field(column);
    let (encoding, unit_source) = time_encoding(path, field, overrides.time_unit)?;
    Ok(Some(TimeSpec {
        name: field.name().clone(),
        column,
        encoding,
        unit_source,
    }))
}

/// The encoding of a time column as far as its type, metadata and `--time-unit` tell. A column of
/// plain numbers with no stated unit comes back with [`TimeUnitSource::Inferred`] and one second per
/// unit, to be settled by [`resolve_time_unit`] once its intervals are known.
fn time_encoding(
    path: &Path,
    field: &Field,
    flag: Option<TimeUnit>,
) -> Result<(TimeEncoding, TimeUnitSource), InputError> {
    let bad = |message: String| InputError::BadMetadata {
        path: path.to_path_buf(),
        column: field.name().clone(),
        message,
    };
    let stated = || -> Result<Option<(f64, TimeUnitSource)>, InputError> {
        if let Some(u) = flag {
            return Ok(Some((u.seconds(), TimeUnitSource::Flag)));
        }
        match field.metadata().get("unit") {
            Some(text) => {
                let u: TimeUnit = text.parse().map_err(|e: String| {
                    bad(format!(
                        "{e} (field metadata unit; --time-unit overrides it)"
                    ))
                })?;
                Ok(Some((u.seconds(), TimeUnitSource::Metadata)))
            }
            None => Ok(None),
        }
    };
    match field.data_type() {
        DataType::Timestamp(unit, _) => Ok((
            TimeEncoding::Timestamp {
                seconds_per_tick: seconds_per(unit),
            },
            TimeUnitSource::ArrowType,
        )),
        DataType::Float32 | DataType::Float64 => Ok(match stated()? {
            Some((s, source)) => (
                TimeEncoding::Float {
                    seconds_per_unit: s,
                },
                source,
            ),
            None => (
                TimeEncoding::Float {
                    seconds_per_unit: 1.0,
                },
                TimeUnitSource::Inferred,
            ),
        }),
        t if t.is_integer() => Ok(match stated()? {
            Some((s, source)) => (
                TimeEncoding::IntegerTicks {
                    seconds_per_tick: s,
                },
                source,
            ),
            None => (
                TimeEncoding::IntegerTicks {
                    seconds_per_tick: 1.0,
                },
                TimeUnitSource::Inferred,
            ),
        }),
        t => Err(bad(format!(
            "time column has type {t}; expected an Arrow timestamp, or numbers with a unit \
             (field metadata unit or --time-unit s|ms|us|ns)"
        ))),
    }
}

/// A rate to six significant digits, trailing zeros dropped: `100 Hz`, `207.012 Hz`.
pub fn rate_text(hz: f64) -> String {
    if !hz.is_finite() || hz == 0.0 {
        return format!("{hz} Hz");
    }
    let digits = (5 - hz.abs().log10().floor() as i32).max(0) as usize;
    let text = format!("{hz:.digits$}");
    let text = if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        text
    };
    format!("{text} Hz")
}

/// Sample rates an inertial sensor plausibly records at, Hz: what an unstated time unit is judged
/// by. Four decades, so at most two of the units s/ms/us/ns (a factor 1000 apart) can fall inside.
pub const PLAUSIBLE_RATE_HZ: (f64, f64) = (1.0, 1e4);

/// Settles the unit of a time column whose unit nobody stated, from its median interval in stored
/// units and, when the file or `--rate` gives one, the sample rate.
///
/// Rules, in order: a float column holding fractional values is seconds, the long-standing
/// convention, and so is a float column of whole numbers in a typed format (Arrow, Parquet), since
/// its writer chose floats, as long as seconds give a plausible rate or agree with a stated one;
/// otherwise a rate from elsewhere picks the unit that agrees with it, and a float column with
/// none is refused;
/// otherwise the unit is inferred only when exactly one of s, ms, us, ns gives a rate in
/// [`PLAUSIBLE_RATE_HZ`]. Anything else is refused with a message that names `--time-unit`.
/// Returns the spec with its unit settled and, when inferred, a note saying so.
pub fn resolve_time_unit(
    path: &Path,
    spec: &TimeSpec,
    median_interval: f64,
    fractional: bool,
    typed_format: bool,
    known_rate_hz: Option<f64>,
) -> Result<(TimeSpec, Option<String>), InputError> {
    if spec.unit_source != TimeUnitSource::Inferred {
        return Ok((spec.clone(), None));
    }
    let settle = |s: f64, source: TimeUnitSource| TimeSpec {
        encoding: spec.encoding.with_seconds_per_unit(s),
        unit_source: source,
        ..spec.clone()
    };
    let is_float = matches!(spec.encoding, TimeEncoding::Float { .. });
    let rate = |u: TimeUnit| 1.0 / (median_interval * u.seconds());
    let implied = TimeUnit::ALL
        .iter()
        .map(|&u| format!("{u}: {}", rate_text(rate(u))))
        .collect::<Vec<_>>()
        .join(", ");
    let refuse = |why: String| {
        InputError::BadMetadata {
        path: path.to_path_buf(),
        column: spec.name.clone(),
        message: format!(
            "{why}; give the unit with --time-unit s|ms|us|ns (the rates each unit implies: {implied})"
        ),
    }
    };
    if !(median_interval.is_finite() && median_interval > 0.0) {
        return Err(refuse(
            "the time column has no usable intervals to judge its unit by".into(),
        ));
    }
    if is_float && (fractional || typed_format) {
        // Fractional values are seconds, and so are floats in a typed format, whose writer chose
        // floats over integer ticks, where that gives a plausible rate or agrees with a stated
        // one. Otherwise the unit is not guessed either way: floats in milliseconds read as
        // seconds made every density 1000× too high (N 31.6×, printed with a note only), and
        // reading a 20 kHz record in seconds as milliseconds would make it 20 Hz. A stated rate
        // that agrees with another unit settles it (below); without one the file is refused.
        let r = rate(TimeUnit::S);
        let plausible = (PLAUSIBLE_RATE_HZ.0..=PLAUSIBLE_RATE_HZ.1).contains(&r);
        let stated = known_rate_hz.is_some_and(|k| (r / k - 1.0).abs() <= super::RATE_TOLERANCE);
        if plausible || stated {
            return Ok((settle(1.0, TimeUnitSource::FloatSeconds), None));
        }
        if known_rate_hz.is_none() {
            return Err(refuse(format!(
                "the time column holds floats with no unit, and read as seconds it gives {}, \
                 outside the usual IMU rates ({} to {} Hz)",
                rate_text(r),
                PLAUSIBLE_RATE_HZ.0,
                PLAUSIBLE_RATE_HZ.1
            )));
        }
    }
    if let Some(known) = known_rate_hz {
        if let Some(&u) = TimeUnit::ALL
            .iter()
            .find(|&&u| (rate(u) / known - 1.0).abs() <= super::RATE_TOLERANCE)
        {
            let note = format!(
                "time column {:?} has no unit: read as {u}, the unit that agrees with the stated rate \
                 of {} (--time-unit overrides)",
                spec.name,
                rate_text(known)
            );
            return Ok((settle(u.seconds(), TimeUnitSource::Inferred), Some(note)));
        }
    }
    let plausible: Vec<TimeUnit> = TimeUnit::ALL
        .iter()
        .copied()
        .filter(|&u| rate(u) >= PLAUSIBLE_RATE_HZ.0 && rate(u) <= PLAUSIBLE_RATE_HZ.1)
        .collect();
    match plausible.as_slice() {
        [u] => {
            let note = format!(
                "time column {:?} has no unit: read as {u} (the only unit giving a plausible IMU rate, {}; \
                 --time-unit overrides)",
                spec.name,
                rate_text(rate(*u))
            );
            Ok((settle(u.seconds(), TimeUnitSource::Inferred), Some(note)))
        }
        [] => Err(refuse(format!(
            "the time column has no unit and no unit gives a rate between {} and {} Hz",
            PLAUSIBLE_RATE_HZ.0, PLAUSIBLE_RATE_HZ.1
        ))),
        several => Err(refuse(format!(
            "the time column has no unit and it is ambiguous ({} all give plausible rates)",
            several
                .iter()
                .map(|u| u.as_str())
                .collect::<Vec<_>>()
                .join(" and ")
        ))),
    }
}

fn seconds_per(unit: &ArrowTimeUnit) -> f64 {
    match unit {
        ArrowTimeUnit::Second => 1.0,
        ArrowTimeUnit::Millisecond => 1e-3,
        ArrowTimeUnit::Microsecond => 1e-6,
        ArrowTimeUnit::Nanosecond => 1e-9,
    }
}

fn column_list(schema: &Schema) -> String {
    schema
        .fields()
        .iter()
        .map(|f| f.name().as_str())
        .collect::<Vec<_>>()
        .join(", ")
}

/// Every column named by `--unit` or `--kind` must exist: a flag that names a misspelt column and is
/// silently ignored leaves the user believing a unit was applied.
pub fn check_override_columns(
    path: &Path,
    schema: &Schema,
    overrides: &ColumnOverrides,
) -> Result<(), InputError> {
    let named = overrides
        .units
        .iter()
        .map(|(c, _)| ("--unit", c))
        .chain(overrides.kinds.iter().map(|(c, _)| ("--kind", c)));
    let names: Vec<&str> = schema.fields().iter().map(|f| f.name().as_str()).collect();
    for (flag, column) in named {
        let found = if is_pattern(column) {
            // `*` is every column, also of a file that has none to give it to.
            column == "*" || names.iter().any(|n| matches_pattern(column, n))
        } else {
            names.contains(&column.as_str())
        };
        if !found {
            return Err(InputError::UnknownFlagColumn {
                path: path.to_path_buf(),
                flag,
                column: column.clone(),
                available: column_list(schema),
            });
        }
    }
    check_patterns_agree(path, &names, "--unit", &overrides.units)?;
    check_patterns_agree(path, &names, "--kind", &overrides.kinds)
}

/// Two patterns equally specific for a column, giving it different values, leave which one the
/// user meant unknown: an error naming both, not a unit picked by the flags' order.
fn check_patterns_agree<T: PartialEq + std::fmt::Display>(
    path: &Path,
    names: &[&str],
    flag: &'static str,
    entries: &[(String, T)],
) -> Result<(), InputError> {
    for name in names {
        if entries.iter().any(|(c, _)| c == name) {
            continue;
        }
        let top = best_patterns(entries, name);
        let Some(first) = top.first() else {
            continue;
        };
        if let Some(other) = top.iter().find(|(_, v)| *v != first.1) {
            return Err(InputError::OptionOutOfRange {
                path: path.to_path_buf(),
                flag,
                message: format!(
                    "column {name:?} matches both {:?} and {:?}, which say different things \
                     ({} and {}); name the column itself ({flag} {name}=…) or make one \
                     pattern longer",
                    first.0, other.0, first.1, other.1
                ),
            });
        }
    }
    Ok(())
}

/// The channels to analyse, in order.
pub fn select_channels(
    path: &Path,
    schema: &Schema,
    time: Option<&TimeSpec>,
    overrides: &ColumnOverrides,
) -> Result<Vec<ChannelSpec>, InputError> {
    let time_column = time.map(|t| t.column);
    let numeric: Vec<usize> = (0..schema.fields().len())
        .filter(|&i| Some(i) != time_column && is_sample_type(schema.field(i).data_type()))
        .collect();
    let numeric_names = || {
        numeric
            .iter()
            .map(|&i| schema.field(i).name().as_str())
            .collect::<Vec<_>>()
            .join(", ")
    };
    let columns: Vec<usize> = if overrides.channels.is_empty() {
        let unreadable = (0..schema.fields().len()).find(|&i| {
            let f = schema.field(i);
            Some(i) != time_column && !numeric.contains(&i) && labelled_as_measurement(f)
        });
        if let Some(i) = unreadable {
            return Err(InputError::UnsupportedType {
                path: path.to_path_buf(),
                column: schema.field(i).name().clone(),
                data_type: schema.field(i).data_type().to_string(),
            });
        }
        if numeric.is_empty() {
            return Err(InputError::NoNumericColumn {
                path: path.to_path_buf(),
                columns: column_list(schema),
            });
        }
        let measured: Vec<usize> = numeric
            .iter()
            .copied()
            .filter(|&i| !ros_bookkeeping(schema.field(i).name()))
            .collect();
        if measured.is_empty() {
            numeric.clone()
        } else {
            measured
        }
    } else {
        overrides
            .channels
            .iter()
            .map(|name| {
                let i = schema
                    .index_of(name)
                    .map_err(|_| InputError::UnknownColumn {
                        path: path.to_path_buf(),
                        column: name.clone(),
                        available: numeric_names(),
                    })?;
                if numeric.contains(&i) {
                    Ok(i)
                } else {
                    Err(InputError::UnsupportedType {
                        path: path.to_path_buf(),
                        column: name.clone(),
                        data_type: schema.field(i).data_type().to_string(),
                    })
                }
            })
            .collect::<Result<_, _>>()?
    };
    columns
        .into_iter()
        .map(|i| channel_spec(path, schema.field(i), i, overrides))
        .collect()
}

/// A ROS message field's path in a column name, with `.` between its parts: the name after
/// `field.` (a `rostopic echo -p` export) or, for a name that begins with `/` (a PlotJuggler
/// export: `/imu/angular_velocity/x`, the topic first), the whole name with `/` read as `.`.
/// `None` for any other name.
fn ros_path(name: &str) -> Option<String> {
    let n = name.to_ascii_lowercase();
    if let Some(rest) = n.strip_prefix("field.") {
        Some(rest.to_string())
    } else if n.starts_with('/') {
        Some(n.replace('/', "."))
    } else {
        None
    }
}

/// A column of a ROS topic's export (`rostopic echo -p` or PlotJuggler's CSV of a
/// sensor_msgs/Imu) that holds no measurement: the receive time `%time` (where the stamp is the
/// time column), the sequence number, the orientation estimate and the covariance matrices. Left
/// out unless `--channels` names them (each had been analysed as an aux channel).
fn ros_bookkeeping(name: &str) -> bool {
    if name.eq_ignore_ascii_case("%time") {
        return true;
    }
    ros_path(name).is_some_and(|p| {
        let field =
            |f: &str| p == f || p.starts_with(&format!("{f}.")) || p.contains(&format!(".{f}"));
        field("header.seq") || field("orientation") || p.contains("_covariance")
    })
}

/// The unit sensor_msgs/Imu defines for a column of its export: rad/s for
/// `angular_velocity.x|y|z`, m/s² for `linear_acceleration.x|y|z` (REP 103), as the MCAP reader
/// applies it, and °C for sensor_msgs/Temperature's `temperature`; in a `rostopic echo -p` export
/// (`field.angular_velocity.x`) or PlotJuggler's (`/imu/angular_velocity/x`).
fn ros_unit(name: &str) -> Option<ScaledUnit> {
    let p = ros_path(name)?;
    let axis = |field: &str| {
        ["x", "y", "z"]
            .iter()
            .any(|a| p == format!("{field}.{a}") || p.ends_with(&format!(".{field}.{a}")))
    };
    if axis("angular_velocity") {
        Some(Unit::RadPerS.into())
    } else if axis("linear_acceleration") {
        Some(Unit::MPerS2.into())
    } else if p == "temperature" || p.ends_with(".temperature") {
        // sensor_msgs/Temperature's field, in °C.
        Some(Unit::DegC.into())
    } else {
        None
    }
}

fn channel_spec(
    path: &Path,
    field: &Field,
    column: usize,
    overrides: &ColumnOverrides,
) -> Result<ChannelSpec, InputError> {
    let name = field.name().clone();
    let bad = |message: String| InputError::BadMetadata {
        path: path.to_path_buf(),
        column: name.clone(),
        message,
    };
    let meta = field.metadata();
    // A unit may carry a factor (`0.00875 deg/s` a count): it multiplies the field's `scale`.
    let scaled = match overrides.unit_for(&name) {
        Some(u) => Some(u),
        None => match meta.get("unit") {
            Some(text) => Some(text.parse::<ScaledUnit>().map_err(|e| bad(e.to_string()))?),
            None => ros_unit(&name),
        },
    };
    let unit = scaled.map(|s| s.unit);
    let factor = scaled.map_or(1.0, |s| s.factor);
    let kind = match overrides.kind_for(&name) {
        Some(k) => k,
        None => match meta.get("kind") {
            Some(text) => text.parse::<Kind>().map_err(|e| bad(e.to_string()))?,
            None => Kind::implied_by(unit),
        },
    };
    // A gyro or accelerometer is fitted in its unit's SI form, so it needs a unit of its quantity:
    // a kind given (by --kind or the field's metadata) to a column without one, or in counts, was
    // fitted as if in rad/s or m/s² while the screen called it aux.
    let wanted = match kind {
        Kind::Gyro => Some(Quantity::AngularRate),
        Kind::Accel => Some(Quantity::Acceleration),
        _ => None,
    };
    if let Some(q) = wanted {
        let (what, example, quantity) = if kind == Kind::Gyro {
            ("a gyro", "deg/s", "an angular rate")
        } else {
            ("an accelerometer", "m/s^2", "an acceleration")
        };
        match unit {
            Some(u) if u.quantity() == q => {}
            Some(u) => {
                let given = if u.quantity() == Quantity::Dimensionless {
                    "counts (a plain number)".to_string()
                } else {
                    u.to_string()
                };
                return Err(bad(format!(
                    "{what} channel in {given}, which is not {quantity}: give --unit \
                     {name}=UNIT (e.g. {example}); raw counts need the sensor's scale, one \
                     count's worth in front of the unit (--unit \"{name}=0.00875 {example}\", \
                     or the CSV header `{name} [0.00875 {example}]`, or field metadata scale)"
                )));
            }
            None => {
                return Err(bad(format!(
                    "{what} channel needs a unit to be fitted in: give --unit {name}=UNIT (e.g. \
                     {example})"
                )))
            }
        }
    }
    let scale = match meta.get("scale") {
        Some(text) => {
            let s: f64 = text
                .trim()
                .parse()
                .map_err(|_| bad(format!("scale {text:?} is not a number")))?;
            if !s.is_finite() || s == 0.0 {
                return Err(bad(format!("scale {text:?} must be finite and non-zero")));
            }
            s
        }
        None => 1.0,
    } * factor;
    Ok(ChannelSpec {
        name,
        column,
        stored_type: field.data_type().to_string(),
        unit,
        kind,
        scale,
        per_second: 1.0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    fn field(name: &str, t: DataType, meta: &[(&str, &str)]) -> Field {
        let m: HashMap<String, String> = meta
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        Field::new(name, t, false).with_metadata(m)
    }

    #[test]
    fn channels_take_unit_kind_and_scale_from_metadata_and_flags_override() {
        let schema = Schema::new(vec![
            field("time", DataType::Float64, &[]),
            field(
                "gx",
                DataType::Int16,
                &[("unit", "deg/s"), ("scale", "0.01")],
            ),
            field("ax", DataType::Float32, &[("unit", "g")]),
            field("label", DataType::Utf8, &[]),
        ]);
        let p = Path::new("x.arrow");
        let mut ov = ColumnOverrides::default();
        let time = find_time(p, &schema, &ov).unwrap().unwrap();
        assert_eq!(time.column, 0);
        let ch = select_channels(p, &schema, Some(&time), &ov).unwrap();
        assert_eq!(ch.len(), 2);
        assert_eq!(ch[0].kind, Kind::Gyro);
        assert!((ch[0].to_si().0 - 0.01 * std::f64::consts::PI / 180.0).abs() < 1e-18);
        assert_eq!(ch[1].kind, Kind::Accel);
        ov.units.push(("ax".into(), Unit::MilliG.into()));
        ov.kinds.push(("*".into(), Kind::Aux));
        let ch = select_channels(p, &schema, Some(&time), &ov).unwrap();
        assert_eq!(ch[1].unit, Some(Unit::MilliG));
        assert_eq!(ch[0].kind, Kind::Aux);
    }

    #[test]
    fn patterns_match_as_shell_globs() {
        for (p, n, m) in [
            ("*", "gyro_x", true),
            ("gyro_*", "gyro_x", true),
            ("gyro_*", "gyro_", true),
            ("gyro_*", "accel_x", false),
            ("*_x", "gyro_x", true),
            ("*_x", "gyro_y", false),
            ("g?ro_?", "gyro_z", true),
            ("g?ro_?", "gyro_zz", false),
            ("*a*b*", "xxaxxbxx", true),
            ("*a*b", "xxaxxbxxb", true),
            ("*a*b", "xxaxxbxxc", false),
            ("Gyro_*", "gyro_x", false),
            ("w_RS_S_*", "w_RS_S_x", true),
            ("°*", "°c", true),
        ] {
            assert_eq!(matches_pattern(p, n), m, "{p} vs {n}");
        }
    }

    /// `--unit 'gyro_*=0.00875 deg/s' --unit 'accel_*=0.000122 g'`: each pattern reaches its
    /// columns; the exact name wins over a pattern and a longer pattern over `*`; a pattern that
    /// matches no column, or two equally specific ones that disagree, are errors.
    #[test]
    fn patterns_in_unit_and_kind_flags() {
        let schema = Schema::new(vec![
            field("gyro_x", DataType::Int16, &[]),
            field("gyro_y", DataType::Int16, &[]),
            field("accel_x", DataType::Int16, &[]),
            field("temp", DataType::Float64, &[]),
        ]);
        let p = Path::new("x.arrow");
        let dps: ScaledUnit = "0.00875 deg/s".parse().unwrap();
        let g: ScaledUnit = "0.000122 g".parse().unwrap();
        let mut ov = ColumnOverrides::default();
        ov.units.push(("*".into(), Unit::DegC.into()));
        ov.units.push(("gyro_*".into(), dps));
        ov.units.push(("accel_?".into(), g));
        ov.units.push(("gyro_y".into(), Unit::DegPerS.into()));
        check_override_columns(p, &schema, &ov).unwrap();
        let ch = select_channels(p, &schema, None, &ov).unwrap();
        let unit = |i: usize| (ch[i].unit, ch[i].kind);
        assert_eq!(unit(0), (Some(Unit::DegPerS), Kind::Gyro));
        assert!((ch[0].to_si().0 - 0.00875 * std::f64::consts::PI / 180.0).abs() < 1e-18);
        assert!((ch[1].to_si().0 - std::f64::consts::PI / 180.0).abs() < 1e-15);
        assert_eq!(unit(2), (Some(Unit::G), Kind::Accel));
        assert_eq!(unit(3), (Some(Unit::DegC), Kind::Temperature));

        let mut none = ColumnOverrides::default();
        none.units.push(("gyr_*".into(), dps));
        let err = check_override_columns(p, &schema, &none).unwrap_err();
        assert!(matches!(err, InputError::UnknownFlagColumn { .. }), "{err}");

        let mut clash = ColumnOverrides::default();
        clash.units.push(("gyro_*".into(), dps));
        clash.units.push(("*_x".into(), g));
        clash.units.push(("g*_?".into(), g));
        // gyro_* (5) and g*_? (2) against *_x (2): gyro_* is the most specific for gyro_x.
        check_override_columns(p, &schema, &clash).unwrap();
        clash.units.push(("gyro?x".into(), g));
        let err = check_override_columns(p, &schema, &clash).unwrap_err();
        let text = err.to_string();
        assert!(
            text.contains("\"gyro_x\"") && text.contains("gyro_*") && text.contains("gyro?x"),
            "{text}"
        );
    }

    #[test]
    fn bad_metadata_and_unknown_columns_name_the_column() {
        let schema = Schema::new(vec![field("gx", DataType::Float64, &[("unit", "furlong")])]);
        let p = Path::new("x.arrow");
        let err = select_channels(p, &schema, None, &ColumnOverrides::default()).unwrap_err();
        assert!(err.to_string().contains("\"gx\"") && err.to_string().contains("furlong"));
        let ov = ColumnOverrides {
            channels: vec!["gy".into()],
            ..Default::default()
        };
        let err = select_channels(p, &schema, None, &ov).unwrap_err();
        assert!(matches!(err, InputError::UnknownColumn { .. }), "{err}");
    }
}
