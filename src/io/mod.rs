//! Reading recordings: Arrow IPC file and stream, Parquet, CSV and MCAP (ROS 2 bags, one IMU topic), in
//! record batches with only the needed columns decoded.
//!
//! [`open`] reads the schema, picks the channels and the time column and settles the sample rate;
//! [`Recording::blocks`] then streams the samples, converted to SI, block by block. Nothing here holds a
//! whole file in memory: a block is one record batch.

mod batches;
mod channels;
mod convert;
mod error;
mod format;
mod mcap;
pub mod time_grid;
mod write;

use std::path::{Path, PathBuf};

use arrow_schema::SchemaRef;
use serde::Serialize;

use crate::units::Unit;

pub use batches::{split_header_unit, DEFAULT_BATCH_ROWS};
pub use channels::{
    rate_text, ChannelSpec, ColumnOverrides, TimeEncoding, TimeSpec, TimeUnit, TimeUnitSource,
    PLAUSIBLE_RATE_HZ,
};
pub use error::InputError;
pub use format::{Format, Unsupported};
pub use write::{write_recording, ColumnOut, StoredAs};

use batches::Batches;
use convert::{append_samples, TimeDecoder};

/// Relative disagreement between two sources of the sample rate above which they conflict. Real clocks
/// are off their nominal rate by parts per million to a few parts per thousand; a wrong rate in a file
/// (200 Hz written for 207 Hz) is off by percent.
pub const RATE_TOLERANCE: f64 = 5e-3;

/// Timestamps read from the start of the time column to estimate the rate (the median interval, then the
/// mean of the intervals near it, which is robust to gaps and to timestamps rounded coarser than the
/// sample period).
const RATE_PROBE_SAMPLES: usize = 1 << 20;

/// How a recording is to be opened.
#[derive(Debug, Clone)]
pub struct OpenOptions {
    pub columns: ColumnOverrides,
    /// `--rate`: used when the file has no rate; an error if it disagrees with the file.
    pub rate_hz: Option<f64>,
    /// Rows per block read: per record batch for the formats that let the reader choose, and
    /// the most rows of an Arrow IPC file's batch handed on at once.
    pub batch_rows: usize,
    /// `--topic`: the IMU topic of an MCAP file (needed only when it has several). An error for
    /// other formats, rather than silently ignored.
    pub topic: Option<String>,
}

impl Default for OpenOptions {
    fn default() -> Self {
        OpenOptions {
            columns: ColumnOverrides::default(),
            rate_hz: None,
            batch_rows: DEFAULT_BATCH_ROWS,
            topic: None,
        }
    }
}

/// Where the sample rate came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RateSource {
    /// Schema metadata `sample_rate_hz`.
    Metadata,
    /// The time column's intervals.
    TimeColumn,
    /// The `--rate` flag.
    Flag,
}

/// An opened recording: what is in it and how to read it. Cheap to hold; samples come from
/// [`Recording::blocks`].
#[derive(Debug, Clone, Serialize)]
pub struct Recording {
    pub path: PathBuf,
    pub format: Format,
    #[serde(skip)]
    pub schema: SchemaRef,
    pub channels: Vec<ChannelSpec>,
    pub time: Option<TimeSpec>,
    pub rate_hz: f64,
    pub rate_source: RateSource,
    /// The rate the time column implies, when there is one (kept to report clock offsets).
    pub rate_from_time_hz: Option<f64>,
    /// What was decided on the user's behalf while opening (an inferred time unit), to be shown.
    pub notes: Vec<String>,
    #[serde(skip)]
    batch_rows: usize,
}

/// Opens a recording: schema, channels, time column and sample rate. Reads at most the first
/// [`RATE_PROBE_SAMPLES`] timestamps; no channel data.
pub fn open(path: &Path, options: &OpenOptions) -> Result<Recording, InputError> {
    if !path.exists() {
        return Err(InputError::NotFound {
            path: path.to_path_buf(),
        });
    }
    if let Some(kind) = Unsupported::detect(path) {
        return Err(InputError::UnsupportedFormat {
            path: path.to_path_buf(),
            what: kind.what(),
            advice: kind.advice(path),
        });
    }
    let format = Format::from_extension(path)
        .or_else(|| Format::sniff(path))
        .ok_or_else(|| InputError::UnknownFormat {
            path: path.to_path_buf(),
        })?;
    if options.topic.is_some() && format != Format::Mcap {
        return Err(InputError::OptionOutOfRange {
            path: path.to_path_buf(),
            flag: "--topic",
            message: format!("applies to MCAP files only (this one is read as {format})"),
        });
    }
    let schema = batches::read_schema(path, format, options.topic.as_deref())?;
    channels::check_override_columns(path, &schema, &options.columns)?;
    let time = channels::find_time(path, &schema, &options.columns)?;
    let channels = channels::select_channels(path, &schema, time.as_ref(), &options.columns)?;
    let batch_rows = options.batch_rows.max(1);

    let from_metadata = match schema.metadata().get("sample_rate_hz") {
        Some(text) => Some(parse_rate(path, text, "schema metadata sample_rate_hz")?),
        None => None,
    };
    if let Some(r) = options.rate_hz {
        check_rate(path, r, "--rate")?;
    }
    let mut notes = Vec::new();
    if format == Format::Mcap {
        notes.push(mcap::describe(&schema));
    }
    if format == Format::Csv && ends_without_line_end(path) {
        notes.push(
            "the file does not end with a line end: its last row may have been cut short while \
             the file was written (a last value of 9 for 9.832158 reads as 9); it is read as it \
             stands"
                .into(),
        );
    }
    // A `scale` is a count's worth; on a float column (values already in their unit, as a
    // converter that kept the metadata writes them) it is applied too, which is rarely meant:
    // a float gyro with scale 2 had its N doubled with nothing said.
    for c in &channels {
        let field = schema.field(c.column);
        if field.data_type().is_floating() {
            if let Some(scale) = field.metadata().get("scale") {
                notes.push(format!(
                    "{} is stored as floats ({}) and its metadata scale {} multiplies them: a \
                     scale is meant for integer counts; check the values are not scaled twice",
                    c.name,
                    field.data_type(),
                    scale.trim()
                ));
            }
        }
    }
    let (time, from_time) = match time {
        Some(spec) => match probe_time(path, format, &schema, &spec, batch_rows)? {
            Some(probe) => {
                let typed = !matches!(format, Format::Csv);
                let (spec, note) = channels::resolve_time_unit(
                    path,
                    &spec,
                    probe.median,
                    probe.fractional,
                    typed,
                    from_metadata.or(options.rate_hz),
                )?;
                notes.extend(note);
                let per_unit = spec.encoding.seconds_per_unit();
                let rate = check_rate(
                    path,
                    1.0 / (probe.mean_interval * per_unit),
                    &format!("time column {:?}", spec.name),
                )?;
                (Some(spec), Some(rate))
            }
            None => (Some(spec), None),
        },
        None => (None, None),
    };
    let candidates = [
        (from_metadata, RateSource::Metadata, "schema metadata says"),
        (from_time, RateSource::TimeColumn, "the time column implies"),
        (options.rate_hz, RateSource::Flag, "--rate says"),
    ];
    let given: Vec<(f64, RateSource, &str)> = candidates
        .iter()
        .filter_map(|&(r, s, label)| r.map(|r| (r, s, label)))
        .collect();
    let Some(&(rate_hz, rate_source, first_label)) = given.first() else {
        // A time column that gave no rate has fewer than two increasing timestamps where they
        // were probed: say that, not "add a time column" (an empty file and one whose timestamps
        // all repeat were told to add the column they have).
        if let Some(spec) = &time {
            return Err(InputError::BadMetadata {
                path: path.to_path_buf(),
                column: spec.name.clone(),
                message: format!(
                    "the time column gives no sample rate: fewer than two increasing timestamps \
                     in its first {RATE_PROBE_SAMPLES} rows (an empty file, or timestamps that \
                     repeat); pass --rate to read it anyway"
                ),
            });
        }
        return Err(InputError::NoRate {
            path: path.to_path_buf(),
            candidates: schema
                .fields()
                .iter()
                .map(|f| f.name())
                .filter(|n| {
                    let n = n.to_ascii_lowercase();
                    n.contains("time") || n.contains("stamp")
                })
                .cloned()
                .collect(),
        });
    };
    for &(other, _, label) in &given[1..] {
        if (other / rate_hz - 1.0).abs() > RATE_TOLERANCE {
            return Err(InputError::RateConflict {
                path: path.to_path_buf(),
                first: format!("{first_label} {rate_hz} Hz"),
                second: format!(
                    "{label} {other} Hz (tolerance {:.1}%)",
                    RATE_TOLERANCE * 100.0
                ),
            });
        }
    }
    let mut channels = channels;
    for c in channels
        .iter_mut()
        .filter(|c| c.unit.is_some_and(Unit::per_sample))
    {
        c.per_second = rate_hz;
        notes.push(format!(
            "{} holds increments per sample ({}): read as the rate, times the sample rate \
             {rate_hz} Hz",
            c.name,
            c.unit.map_or("", Unit::as_str),
        ));
    }
    Ok(Recording {
        path: path.to_path_buf(),
        format,
        schema,
        channels,
        time,
        rate_hz,
        rate_source,
        rate_from_time_hz: from_time,
        notes,
        batch_rows,
    })
}

fn check_rate(path: &Path, rate: f64, source: &str) -> Result<f64, InputError> {
    if rate.is_finite() && rate > 0.0 {
        Ok(rate)
    } else {
        Err(InputError::InvalidRate {
            path: path.to_path_buf(),
            rate_hz: rate,
            source_name: source.to_string(),
        })
    }
}

fn parse_rate(path: &Path, text: &str, source: &str) -> Result<f64, InputError> {
    let rate = text.trim().parse::<f64>().unwrap_or(f64::NAN);
    check_rate(path, rate, source)
}

/// The intervals of the first timestamps, in the time column's stored units.
struct TimeProbe {
    median: f64,
    /// The mean period on the grid of sample instants (see [`time_grid`]), started from the mean of
    /// the intervals within ±50 % of the median: robust to gaps, jitter and timestamps rounded
    /// coarser than the sample period.
    mean_interval: f64,
    /// Whether any value (after the first is subtracted) has a fractional part.
    fractional: bool,
}

/// Probes the first timestamps; `None` when there are fewer than two usable ones (the quality stage
/// then reports what is wrong with the time column, row by row).
fn probe_time(
    path: &Path,
    format: Format,
    schema: &SchemaRef,
    spec: &TimeSpec,
    batch_rows: usize,
) -> Result<Option<TimeProbe>, InputError> {
    let per_unit = spec.encoding.seconds_per_unit();
    let mut decoder = TimeDecoder::new(spec);
    let mut times = Vec::new();
    for batch in batches::open_batches(path, format, schema, &[spec.column], batch_rows)? {
        decoder.append(batch?.column(0), &mut times);
        if times.len() > RATE_PROBE_SAMPLES {
            break;
        }
    }
    // Up to the first timestamp that goes back (a logger's clock reset): beyond it the span of
    // the timestamps no longer measures the rate (a reset at row 30 000 had made a 100-Hz file
    // 400 Hz, and the quality stage then called row 1 a gap instead of naming row 30 000).
    if let Some(back) = times.windows(2).position(|w| w[1] < w[0]) {
        times.truncate(back + 1);
    }
    let fractional = times.iter().any(|&t| {
        let units = t / per_unit;
        units.is_finite() && (units - units.round()).abs() > 1e-6
    });
    let mut dt: Vec<f64> = times
        .windows(2)
        .map(|w| (w[1] - w[0]) / per_unit)
        .filter(|d| d.is_finite() && *d > 0.0)
        .collect();
    if dt.is_empty() {
        return Ok(None);
    }
    let mid = dt.len() / 2;
    let median = *dt.select_nth_unstable_by(mid, f64::total_cmp).1;
    let near: Vec<f64> = dt
        .iter()
        .copied()
        .filter(|d| *d > 0.5 * median && *d < 1.5 * median)
        .collect();
    let mean_near_median = near.iter().sum::<f64>() / near.len() as f64;
    let stored: Vec<f64> = times.iter().map(|t| t / per_unit).collect();
    Ok(Some(TimeProbe {
        median,
        mean_interval: time_grid::grid_period(&stored, mean_near_median),
        fractional,
    }))
}

/// A block of consecutive rows: one `Vec` per channel (SI units) and, when the file has one, the time
/// of each row in seconds since the first row.
#[derive(Debug, Clone, Default)]
pub struct Block {
    /// Index of the block's first row in the file (0-based data rows).
    pub first_row: u64,
    pub time_s: Option<Vec<f64>>,
    /// The resolution of the time column as stored, in seconds, up to this block: one tick of an
    /// integer column, the spacing of floats at the largest value of a float one (epoch seconds
    /// in f64 resolve 2.4e-7 s, whatever the relative times in `time_s` could hold); 0 without a
    /// time column.
    pub time_resolution_s: f64,
    pub channels: Vec<Vec<f64>>,
}

impl Block {
    pub fn rows(&self) -> usize {
        self.channels.first().map_or(0, Vec::len)
    }
}

impl Recording {
    /// The number of data rows, read from the footer where the format stores it (Parquet), else
    /// estimated from the file size: the mean line length of the first 64 KiB (CSV) or the width of a
    /// row of the schema's columns (Arrow IPC, MCAP; an upper bound for Arrow, whose file also holds
    /// the schema and batch headers).
    pub fn estimated_rows(&self) -> Option<u64> {
        let path = &self.path;
        let size = std::fs::metadata(path).ok()?.len();
        match self.format {
            Format::Parquet => {
                let file = std::fs::File::open(path).ok()?;
                let b =
                    ::parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(file)
                        .ok()?;
                Some(b.metadata().file_metadata().num_rows().max(0) as u64)
            }
            Format::Csv => {
                // The mean length of the lines in the first 64 KiB.
                use std::io::Read;
                let mut head = Vec::with_capacity(1 << 16);
                std::fs::File::open(path)
                    .ok()?
                    .take(1 << 16)
                    .read_to_end(&mut head)
                    .ok()?;
                let lines = head.iter().filter(|b| **b == b'\n').count().max(1) as u64;
                Some(size * lines / head.len().max(1) as u64)
            }
            _ => {
                let row: u64 = self
                    .schema
                    .fields()
                    .iter()
                    .map(|f| f.data_type().primitive_width().unwrap_or(8) as u64)
                    .sum();
                Some(size / row.max(1))
            }
        }
    }

    /// Streams the recording's rows, block by block.
    pub fn blocks(&self) -> Result<BlockReader, InputError> {
        let mut projection: Vec<usize> = Vec::new();
        if let Some(t) = &self.time {
            projection.push(t.column);
        }
        projection.extend(self.channels.iter().map(|c| c.column));
        let batches = batches::open_batches(
            &self.path,
            self.format,
            &self.schema,
            &projection,
            self.batch_rows,
        )?;
        Ok(BlockReader {
            recording: self.clone(),
            batches,
            time: self.time.as_ref().map(TimeDecoder::new),
            conversions: self.channels.iter().map(ChannelSpec::to_si).collect(),
            block_rows: self.batch_rows.max(1),
            pending: None,
        })
    }

    /// Channel names, in order.
    pub fn channel_names(&self) -> Vec<String> {
        self.channels.iter().map(|c| c.name.clone()).collect()
    }
}

/// Iterator over a recording's [`Block`]s.
pub struct BlockReader {
    recording: Recording,
    batches: Batches,
    time: Option<TimeDecoder>,
    conversions: Vec<(f64, f64)>,
    /// Rows per block at most: the batches a writer chose (an Arrow IPC file of one batch of
    /// 10⁷ rows) are cut to this size, so that each block's buffers, and the cleaner's after
    /// them, are reused by the allocator instead of being mapped afresh and faulted in (the
    /// page faults were 47 % of `avar` on such a file).
    block_rows: usize,
    /// The rest of a batch cut into blocks, and its first row.
    pending: Option<(arrow_array::RecordBatch, u64)>,
}

impl Iterator for BlockReader {
    type Item = Result<Block, InputError>;

    fn next(&mut self) -> Option<Self::Item> {
        let (batch, first_row) = match self.pending.take() {
            Some(rest) => rest,
            None => {
                let first_row = self.batches.next_row();
                match self.batches.next()? {
                    Ok(b) => (b, first_row),
                    Err(e) => return Some(Err(e)),
                }
            }
        };
        // A batch longer than a block is handed on in slices (zero-copy views of the batch).
        let batch = if batch.num_rows() > self.block_rows {
            let rest = batch.slice(self.block_rows, batch.num_rows() - self.block_rows);
            self.pending = Some((rest, first_row + self.block_rows as u64));
            batch.slice(0, self.block_rows)
        } else {
            batch
        };
        let mismatch = |column: &str| InputError::Corrupt {
            path: self.recording.path.clone(),
            format: self.recording.format.as_str(),
            row: Some(first_row),
            message: format!("column {column:?} changes type within the file"),
        };
        let mut columns = batch.columns().iter();
        let time_s = match &mut self.time {
            Some(decoder) => {
                let mut out = Vec::with_capacity(batch.num_rows());
                let array = columns.next()?;
                if !decoder.append(array, &mut out) {
                    let name = self.recording.time.as_ref().map_or("", |t| t.name.as_str());
                    return Some(Err(mismatch(name)));
                }
                Some(out)
            }
            None => None,
        };
        let mut channels = Vec::with_capacity(self.conversions.len());
        for ((array, &(factor, offset)), spec) in
            columns.zip(&self.conversions).zip(&self.recording.channels)
        {
            let mut out = Vec::with_capacity(batch.num_rows());
            if !append_samples(array, factor, offset, &mut out) {
                return Some(Err(mismatch(&spec.name)));
            }
            channels.push(out);
        }
        let time_resolution_s = self.time.as_ref().map_or(0.0, TimeDecoder::resolution_s);
        Some(Ok(Block {
            first_row,
            time_s,
            time_resolution_s,
            channels,
        }))
    }
}

/// Whether the file's last byte is something other than a line end (an empty file has none):
/// a text table written in full ends with one, and one cut off while being written does not.
fn ends_without_line_end(path: &Path) -> bool {
    use std::io::{Read, Seek, SeekFrom};
    let Ok(mut f) = std::fs::File::open(path) else {
        return false;
    };
    if f.seek(SeekFrom::End(-1)).is_err() {
        return false;
    }
    let mut last = [0u8; 1];
    f.read_exact(&mut last).is_ok() && !matches!(last[0], b'\n' | b'\r')
}
