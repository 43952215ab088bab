//! Input errors. Every variant names the file and, where one is involved, the column and the row, because
//! a user with a hundred recordings in a batch needs to find the bad sample without opening a debugger.
//!
//! Rows are 0-based indices of data rows (the header of a CSV file is not a row); CSV errors also give
//! the 1-based line of the file, which differs from the row by the header, comment and blank lines
//! and quoted line breaks.

use std::path::PathBuf;

/// Something wrong with an input file.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    #[error("{path}: file not found")]
    NotFound { path: PathBuf },
    #[error("{path}: cannot read: {message}")]
    Unreadable { path: PathBuf, message: String },
    #[error("{path}: file is empty")]
    Empty { path: PathBuf },
    #[error("{path}: not a recognised format (expected .arrow/.feather/.ipc, .arrows, .parquet, .csv or .mcap)")]
    UnknownFormat { path: PathBuf },
    #[error("{path}: {what} is not a format imunoise reads; {advice}")]
    UnsupportedFormat {
        path: PathBuf,
        what: &'static str,
        /// How to convert it into one imunoise reads.
        advice: String,
    },
    #[error("{path}: no IMU topic (sensor_msgs/msg/Imu, CDR or ROS 1 encoded) in this MCAP file; its topics: {topics}")]
    NoImuTopic { path: PathBuf, topics: String },
    #[error("{path}: several IMU topics ({imu_topics}); choose one with --topic")]
    AmbiguousTopic { path: PathBuf, imu_topics: String },
    #[error("{path}: --topic {topic:?} is not an IMU topic of this file (IMU topics: {imu_topics}; all topics: {topics})")]
    UnknownTopic {
        path: PathBuf,
        topic: String,
        imu_topics: String,
        topics: String,
    },
    #[error("{path}: IMU topic {topic:?} cannot be analysed: {reason}")]
    UnusableTopic {
        path: PathBuf,
        topic: String,
        reason: String,
    },
    /// Shown as `PATH: corrupt FORMAT (CAUSE) at row ROW: DETAIL`, the parts that are known.
    #[error("{}", corrupt_text(path, format, *row, message))]
    Corrupt {
        path: PathBuf,
        /// [`super::Format::as_str`]: `Parquet` is shown as `Parquet file`, `Arrow IPC file` as is.
        format: &'static str,
        row: Option<u64>,
        /// The decoder's message; a leading `(cause)` (`(truncated: footer missing): ...`) is shown
        /// after the format.
        message: String,
    },
    #[error("{path}: malformed CSV{}: {message}", csv_at(*.row, *.line))]
    MalformedCsv {
        path: PathBuf,
        row: Option<u64>,
        /// 1-based line of the file.
        line: Option<u64>,
        message: String,
    },
    #[error("{path}: column {column:?}, row {row}{}: {value:?} is not {expected}", line_text(*.line))]
    BadValue {
        path: PathBuf,
        column: String,
        row: u64,
        /// 1-based line of the file, when it could be found.
        line: Option<u64>,
        value: String,
        /// What the column holds (`a number`).
        expected: &'static str,
    },
    #[error("{path}: column {column:?} appears twice (columns {first} and {second}, counting from 1); rename one, since which of them to analyse would be a guess")]
    DuplicateColumn {
        path: PathBuf,
        column: String,
        first: usize,
        second: usize,
    },
    #[error("{path}: no numeric column to analyse (columns: {columns})")]
    NoNumericColumn { path: PathBuf, columns: String },
    #[error("{path}: column {column:?} not found (numeric columns: {available})")]
    UnknownColumn {
        path: PathBuf,
        column: String,
        available: String,
    },
    #[error("{path}: column {column:?} has type {data_type}, which is not a numeric sample type (integers, floats, decimals); convert it, or name the channels to analyse with --channels to leave it out")]
    UnsupportedType {
        path: PathBuf,
        column: String,
        data_type: String,
    },
    #[error("{path}: column {column:?}: {message}")]
    BadMetadata {
        path: PathBuf,
        column: String,
        message: String,
    },
    #[error("{path}: column {column:?}, row {row}: non-finite sample ({value}); use --on-nonfinite drop|interpolate to continue")]
    NonFinite {
        path: PathBuf,
        column: String,
        row: u64,
        value: String,
    },
    #[error("{path}: column {column:?}, row {row}: timestamp {} s (from the first) repeats the previous one; use --on-duplicate drop to keep the first of each", seconds(*.this_s))]
    DuplicateTimestamp {
        path: PathBuf,
        column: String,
        row: u64,
        this_s: f64,
    },
    #[error(
        "{path}: column {column:?}, row {row}: {}",
        time_step_text(*.this_s, *.previous_s)
    )]
    NonMonotonicTime {
        path: PathBuf,
        column: String,
        row: u64,
        previous_s: f64,
        this_s: f64,
    },
    #[error("{path}: column {column:?}, row {row}: gap of {} s ({missing} samples missing) after t = {} s; use --on-gap ignore to join the two sides (the choice for noise analysis) or --on-gap fill to fill it with a straight line (keeps a line's phase, but its noise-free stretch biases N, B and K)", seconds(*.gap_s), seconds(*.after_s))]
    Gap {
        path: PathBuf,
        column: String,
        row: u64,
        after_s: f64,
        gap_s: f64,
        missing: u64,
    },
    #[error("{path}: sample rate conflict: {first} but {second}")]
    RateConflict {
        path: PathBuf,
        first: String,
        second: String,
    },
    #[error(
        "{path}: no sample rate: add schema metadata sample_rate_hz, a time column, or pass --rate{}",
        time_hint(candidates)
    )]
    NoRate {
        path: PathBuf,
        /// Columns whose names suggest a time (they hold `time` or `stamp`) that the automatic
        /// choice does not take (see [`crate::io::channels::find_time`]).
        candidates: Vec<String>,
    },
    #[error("{path}: invalid sample rate {rate_hz} Hz from {source_name}")]
    InvalidRate {
        path: PathBuf,
        rate_hz: f64,
        source_name: String,
    },
    #[error("{path}: no gyro or accelerometer channel to fit (channels: {channels}); give units with --unit COLUMN=UNIT (e.g. --unit gyro_x=deg/s) or kinds with --kind COLUMN=gyro|accel")]
    NoInertialChannel { path: PathBuf, channels: String },
    #[error(
        "{path}: {flag} names column {column:?}, which is not in the file (columns: {available})"
    )]
    UnknownFlagColumn {
        path: PathBuf,
        flag: &'static str,
        column: String,
        available: String,
    },
    #[error("{path}: {flag}: {message}")]
    OptionOutOfRange {
        path: PathBuf,
        flag: &'static str,
        message: String,
    },
    #[error("{path}: {what} needs at least {needed} samples, the recording has {available}")]
    TooShort {
        path: PathBuf,
        what: String,
        needed: u64,
        available: u64,
    },
}

fn line_text(line: Option<u64>) -> String {
    line.map(|l| format!(" (line {l} of the file)"))
        .unwrap_or_default()
}

/// What is wrong with a timestamp that does not follow its predecessor: a missing one (null, or
/// not a number) is said as such, not as "timestamp NaN s goes back".
fn time_step_text(this_s: f64, previous_s: f64) -> String {
    if this_s.is_nan() {
        format!(
            "the timestamp is missing (null or not a number) after {} s",
            seconds(previous_s)
        )
    } else {
        format!(
            "timestamp {} s goes back from {} s",
            seconds(this_s),
            seconds(previous_s)
        )
    }
}

/// Seconds since the first sample as a person reads them: to the nanosecond, trailing zeros
/// dropped (a gap of 0.10250000000000625 s, the float sum of its timestamps, reads 0.1025 s).
fn seconds(t: f64) -> String {
    if !t.is_finite() {
        return t.to_string();
    }
    let text = format!("{t:.9}");
    let text = text.trim_end_matches('0').trim_end_matches('.');
    if text == "-0" {
        "0".into()
    } else {
        text.into()
    }
}

/// The end of [`InputError::NoRate`]'s message: the columns that may be the time.
fn time_hint(candidates: &[String]) -> String {
    match candidates {
        [] => String::new(),
        [one] => format!("; if column {one:?} is the time, say so with --time-column {one:?}"),
        more => format!(
            "; if one of the columns {} is the time, name it with --time-column",
            more.iter()
                .map(|c| format!("{c:?}"))
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

fn csv_at(row: Option<u64>, line: Option<u64>) -> String {
    match (row, line) {
        (Some(r), _) => format!(" at row {r}{}", line_text(line)),
        (None, Some(l)) => format!(" at line {l}"),
        (None, None) => String::new(),
    }
}

/// `x.arrow: corrupt Arrow IPC file (truncated: footer missing): DETAIL`, with only the parts known:
/// no doubled "file", no colon with nothing after it.
fn corrupt_text(path: &std::path::Path, format: &str, row: Option<u64>, message: &str) -> String {
    use std::fmt::Write;
    let mut text = format!("{}: corrupt {format}", path.display());
    if !(format.ends_with(" file") || format.ends_with(" stream")) {
        text.push_str(" file");
    }
    let mut detail = message.trim();
    if let Some((cause, rest)) = detail
        .strip_prefix('(')
        .and_then(|inner| inner.split_once(')'))
    {
        let _ = write!(text, " ({})", cause.trim());
        detail = rest.trim_start_matches(':').trim();
    }
    if let Some(r) = row {
        let _ = write!(text, " at row {r}");
    }
    let detail = detail.trim_end_matches([':', ' ']);
    if !detail.is_empty() {
        let _ = write!(text, ": {detail}");
    }
    text
}

impl InputError {
    /// The file the error is about.
    pub fn path(&self) -> &std::path::Path {
        use InputError::*;
        match self {
            NotFound { path }
            | Unreadable { path, .. }
            | Empty { path }
            | UnknownFormat { path }
            | UnsupportedFormat { path, .. }
            | NoImuTopic { path, .. }
            | AmbiguousTopic { path, .. }
            | UnknownTopic { path, .. }
            | UnusableTopic { path, .. }
            | Corrupt { path, .. }
            | MalformedCsv { path, .. }
            | BadValue { path, .. }
            | DuplicateColumn { path, .. }
            | NoNumericColumn { path, .. }
            | UnknownColumn { path, .. }
            | UnsupportedType { path, .. }
            | BadMetadata { path, .. }
            | NonFinite { path, .. }
            | DuplicateTimestamp { path, .. }
            | NonMonotonicTime { path, .. }
            | Gap { path, .. }
            | RateConflict { path, .. }
            | NoRate { path, .. }
            | InvalidRate { path, .. }
            | NoInertialChannel { path, .. }
            | OptionOutOfRange { path, .. }
            | UnknownFlagColumn { path, .. }
            | TooShort { path, .. } => path,
        }
    }

    /// The column involved, when one is.
    pub fn column(&self) -> Option<&str> {
        use InputError::*;
        match self {
            UnknownColumn { column, .. }
            | UnknownFlagColumn { column, .. }
            | UnsupportedType { column, .. }
            | BadMetadata { column, .. }
            | BadValue { column, .. }
            | DuplicateColumn { column, .. }
            | NonFinite { column, .. }
            | DuplicateTimestamp { column, .. }
            | NonMonotonicTime { column, .. }
            | Gap { column, .. } => Some(column),
            _ => None,
        }
    }

    /// The row involved (0-based data row), when one is.
    pub fn row(&self) -> Option<u64> {
        use InputError::*;
        match self {
            NonFinite { row, .. }
            | BadValue { row, .. }
            | DuplicateTimestamp { row, .. }
            | NonMonotonicTime { row, .. }
            | Gap { row, .. } => Some(*row),
            Corrupt { row, .. } | MalformedCsv { row, .. } => *row,
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{seconds, time_step_text};

    /// A null timestamp is said to be missing, not to go back.
    #[test]
    fn a_missing_timestamp_is_not_said_to_go_back() {
        assert_eq!(
            time_step_text(f64::NAN, 1.5),
            "the timestamp is missing (null or not a number) after 1.5 s"
        );
        assert_eq!(
            time_step_text(0.0, 299.99),
            "timestamp 0 s goes back from 299.99 s"
        );
    }

    #[test]
    fn seconds_read_as_a_person_writes_them() {
        assert_eq!(seconds(0.102_500_000_000_006_25), "0.1025");
        // An f32 timestamp's own value, to the nanosecond.
        assert_eq!(seconds(29.990_000_009_536_743), "29.99000001");
        assert_eq!(seconds(30.0), "30");
        assert_eq!(seconds(-0.0), "0");
        assert_eq!(seconds(f64::NAN), "NaN");
    }
}
