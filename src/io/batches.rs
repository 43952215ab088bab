//! Opening a file as a stream of Arrow record batches, with only the projected columns decoded.
//!
//! Each format's reader is wrapped so that an error, or a panic inside a third-party decoder fed a
//! corrupt file, becomes an [`InputError::Corrupt`] naming the file and the first row of the batch that
//! failed, and saying what is wrong when that can be told (truncated, not the format its name says):
//! a batch of a hundred files never dies because one of them is damaged. An Arrow IPC stream that
//! ends without its end-of-stream marker is truncated too, not a shorter recording. CSV has its own
//! module ([`csv`]): numbers are parsed there, so that a bad cell names its column, row and line.

mod csv;
mod mapped;

use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use arrow_array::RecordBatch;
use arrow_schema::SchemaRef;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use parquet::arrow::ProjectionMask;

use super::format::Format;
use super::InputError;

/// Rows per batch asked of readers that let us choose (CSV, Parquet). Large enough to amortise the
/// per-batch overhead, small enough that a batch of a few channels stays in the megabytes.
pub const DEFAULT_BATCH_ROWS: usize = 65_536;

/// A stream of record batches holding only the projected columns, in projection order.
pub struct Batches {
    path: PathBuf,
    format: Format,
    inner: Box<dyn Iterator<Item = Result<RecordBatch, String>> + Send>,
    next_row: u64,
    failed: bool,
    /// CSV: parses the numeric columns and explains arrow-csv's errors.
    csv: Option<csv::Decode>,
}

impl Batches {
    /// The row index the next batch starts at.
    pub fn next_row(&self) -> u64 {
        self.next_row
    }
}

impl Iterator for Batches {
    type Item = Result<RecordBatch, InputError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.failed {
            return None;
        }
        let item = guard(|| self.inner.next()).unwrap_or_else(|panic| Some(Err(panic)));
        let Some(item) = item else {
            // A stream cut between two record batches reads as a shorter stream; its missing
            // end-of-stream marker tells it apart.
            if self.format == Format::ArrowStream && !stream_is_complete(&self.path) {
                self.failed = true;
                return Some(Err(InputError::Corrupt {
                    path: self.path.clone(),
                    format: self.format.as_str(),
                    row: Some(self.next_row),
                    message: "(truncated: end-of-stream marker missing): the file ends after a \
                              complete record batch; the rows after it are missing"
                        .to_string(),
                }));
            }
            return None;
        };
        let result = match item {
            Ok(batch) => match &self.csv {
                Some(decode) => decode.convert(batch, self.next_row),
                None => Ok(batch),
            },
            Err(message) => Err(match &self.csv {
                Some(decode) => guard(|| decode.diagnose(self.next_row, &message))
                    .unwrap_or_else(|_| corrupt(&self.path, self.format, message)),
                None => InputError::Corrupt {
                    path: self.path.clone(),
                    format: self.format.as_str(),
                    row: Some(self.next_row),
                    message: explain(&self.path, self.format, &message),
                },
            }),
        };
        match result {
            Ok(batch) => {
                self.next_row += batch.num_rows() as u64;
                Some(Ok(batch))
            }
            Err(e) => {
                self.failed = true;
                Some(Err(e))
            }
        }
    }
}

/// Whether an Arrow IPC stream file ends with the end-of-stream marker: `0xFFFFFFFF 0x00000000`, or
/// four zero bytes in the format before 0.15 (whose messages carry no continuation marker).
fn stream_is_complete(path: &Path) -> bool {
    let Ok(mut file) = File::open(path) else {
        return false;
    };
    let mut head = [0u8; 4];
    let mut tail = [0u8; 8];
    let read_tail = |file: &mut File, tail: &mut [u8; 8]| -> std::io::Result<()> {
        file.seek(SeekFrom::End(-8))?;
        file.read_exact(tail)
    };
    if file.read_exact(&mut head).is_err() || read_tail(&mut file, &mut tail).is_err() {
        return false;
    }
    if head == [0xFF; 4] {
        tail == [0xFF, 0xFF, 0xFF, 0xFF, 0, 0, 0, 0]
    } else {
        tail[4..] == [0, 0, 0, 0]
    }
}

/// Runs a decoder step, turning a panic into an error message.
fn guard<T>(f: impl FnOnce() -> T) -> Result<T, String> {
    catch_unwind(AssertUnwindSafe(f)).map_err(|payload| {
        let what = payload
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_else(|| "decoder panicked".to_string());
        format!("{PANIC_PREFIX}{what}")
    })
}

/// How [`guard`] starts its message, for [`explain`] to recognise.
const PANIC_PREFIX: &str = "decoder panicked: ";

/// A decoder's message without the error-kind prefixes arrow and parquet put in front of it
/// (`Parser error: `, `Io error: `, `Parquet error: `, ...), which say nothing to a user.
fn plain(message: &str) -> String {
    const PREFIXES: &[&str] = &[
        "Parser error: ",
        "Ipc error: ",
        "Io error: ",
        "Csv error: ",
        "Schema error: ",
        "Invalid argument error: ",
        "External error: ",
        "Parquet argument error: ",
        "Parquet error: ",
        "Arrow: ",
        "External: ",
        "EOF: ",
    ];
    let mut text = message.trim();
    while let Some(rest) = PREFIXES.iter().find_map(|p| text.strip_prefix(p)) {
        text = rest.trim_start();
    }
    text.trim_end_matches(['.', ':', ' ']).to_string()
}

/// A decoder's error message, made plain and, when the file shows why it failed, prefixed with the
/// cause in parentheses (`(truncated: footer missing): ...`), which [`InputError::Corrupt`] shows
/// after the format.
fn explain(path: &Path, format: Format, message: &str) -> String {
    let text = plain(message);
    let (len, head, tail) = ends(path);
    let magic = match format {
        Format::ArrowFile => Some(&b"ARROW1"[..]),
        Format::Parquet => Some(&b"PAR1"[..]),
        _ => None,
    };
    let lower = text.to_ascii_lowercase();
    let cause = if let Some(rest) = text.strip_prefix(PANIC_PREFIX) {
        return format!("(damaged: the decoder stopped on invalid data): {rest}");
    } else if let Some(magic) = magic {
        let name = match format {
            Format::ArrowFile => "an Arrow IPC file",
            _ => "a Parquet file",
        };
        // Header magic, a footer length and the footer magic at least.
        let smallest = 2 * magic.len() as u64 + 4;
        if head.len() < magic.len() && magic.starts_with(&head) {
            return format!("(truncated): the file is only {len} bytes long");
        } else if !head.starts_with(magic) {
            Some(format!(
                "not {name}: it does not start with {}",
                String::from_utf8_lossy(magic)
            ))
        } else if len < smallest {
            return format!("(truncated: footer missing): the file is only {len} bytes long");
        } else if !tail.ends_with(magic) {
            Some("truncated: footer missing".to_string())
        } else {
            None
        }
    } else if lower.contains("failed to fill whole buffer")
        || lower.contains("unexpected end of")
        || lower.contains("found empty stream")
    {
        Some("truncated: the file ends inside a message".to_string())
    } else {
        None
    };
    match cause {
        Some(cause) if text.is_empty() => format!("({cause})"),
        Some(cause) => format!("({cause}): {text}"),
        None => text,
    }
}

/// A file's length and its first and last 8 bytes (fewer when it is shorter).
fn ends(path: &Path) -> (u64, Vec<u8>, Vec<u8>) {
    let Ok(bytes) = File::open(path).and_then(|mut f| {
        let len = f.metadata()?.len();
        let mut head = vec![0u8; len.min(8) as usize];
        f.read_exact(&mut head)?;
        let mut tail = vec![0u8; len.min(8) as usize];
        f.seek(SeekFrom::Start(len - tail.len() as u64))?;
        f.read_exact(&mut tail)?;
        Ok((len, head, tail))
    }) else {
        return (0, Vec::new(), Vec::new());
    };
    bytes
}

/// Every column name must be unique: `--channels g` on a file with two columns `g` would otherwise
/// analyse whichever comes first, and the report could not tell them apart.
fn check_unique_names<'a>(
    path: &Path,
    names: impl IntoIterator<Item = &'a str>,
) -> Result<(), InputError> {
    let mut seen: std::collections::HashMap<&str, usize> = std::collections::HashMap::new();
    for (i, name) in names.into_iter().enumerate() {
        if let Some(&first) = seen.get(name) {
            return Err(InputError::DuplicateColumn {
                path: path.to_path_buf(),
                column: name.to_string(),
                first: first + 1,
                second: i + 1,
            });
        }
        seen.insert(name, i);
    }
    Ok(())
}

fn open_file(path: &Path) -> Result<File, InputError> {
    let file = File::open(path).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => InputError::NotFound {
            path: path.to_path_buf(),
        },
        _ => InputError::Unreadable {
            path: path.to_path_buf(),
            message: e.to_string(),
        },
    })?;
    let len = file
        .metadata()
        .map_err(|e| InputError::Unreadable {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?
        .len();
    if len == 0 {
        return Err(InputError::Empty {
            path: path.to_path_buf(),
        });
    }
    Ok(file)
}

fn corrupt(path: &Path, format: Format, message: impl ToString) -> InputError {
    InputError::Corrupt {
        path: path.to_path_buf(),
        format: format.as_str(),
        row: None,
        message: explain(path, format, &message.to_string()),
    }
}

/// Reads the full schema of a file (for CSV: inferred, numeric columns as f64, and a header of the
/// form `name [unit]` turned into the field `name` with metadata `unit`, see [`csv`]; for MCAP: the
/// columns of the IMU topic `topic`, or of the only one, see [`super::mcap`]). Column names must be
/// unique.
pub fn read_schema(
    path: &Path,
    format: Format,
    topic: Option<&str>,
) -> Result<SchemaRef, InputError> {
    let mut file = open_file(path)?;
    if format == Format::Csv {
        return guard(|| csv::schema(path, &mut file))
            .unwrap_or_else(|panic| Err(corrupt(path, format, panic)))
            .map(Arc::new);
    }
    if format == Format::Mcap {
        // Its errors name topics as well as corruption, so they come back as they are.
        return guard(|| super::mcap::read_schema(path, &file, topic))
            .unwrap_or_else(|panic| Err(corrupt(path, format, panic)));
    }
    let result = guard(|| -> Result<SchemaRef, String> {
        match format {
            Format::ArrowFile => arrow_ipc::reader::FileReader::try_new_buffered(file, None)
                .map(|r| r.schema())
                .map_err(|e| e.to_string()),
            Format::ArrowStream => arrow_ipc::reader::StreamReader::try_new_buffered(file, None)
                .map(|r| r.schema())
                .map_err(|e| e.to_string()),
            Format::Parquet => ParquetRecordBatchReaderBuilder::try_new(file)
                .map(|b| b.schema().clone())
                .map_err(|e| e.to_string()),
            Format::Csv | Format::Mcap => unreachable!("CSV and MCAP schemas are read above"),
        }
    });
    match result {
        Ok(Ok(schema)) => {
            check_unique_names(path, schema.fields().iter().map(|f| f.name().as_str()))?;
            Ok(schema)
        }
        Ok(Err(message)) | Err(message) => Err(corrupt(path, format, message)),
    }
}

/// `"gyro_x [deg/s]"` → (`"gyro_x"`, `Some("deg/s")`): CSV has no field metadata, so units ride in the
/// header, as most loggers write them.
pub fn split_header_unit(header: &str) -> (String, Option<String>) {
    let trimmed = header.trim();
    if let (Some(open), true) = (trimmed.rfind('['), trimmed.ends_with(']')) {
        let name = trimmed[..open].trim();
        let unit = trimmed[open + 1..trimmed.len() - 1].trim();
        if !name.is_empty() && !unit.is_empty() {
            return (name.to_string(), Some(unit.to_string()));
        }
    }
    (trimmed.to_string(), None)
}

/// Opens the batches of `projection` (indices into `schema`, the file's full schema as returned by
/// [`read_schema`]).
pub fn open_batches(
    path: &Path,
    format: Format,
    schema: &SchemaRef,
    projection: &[usize],
    batch_rows: usize,
) -> Result<Batches, InputError> {
    let mut file = open_file(path)?;
    if format == Format::Csv {
        csv::rewind(&mut file).map_err(|e| InputError::Unreadable {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
    }
    let csv =
        (format == Format::Csv).then(|| csv::Decode::new(path, schema, projection, batch_rows));
    let projection = projection.to_vec();
    let schema = schema.clone();
    type Inner = Box<dyn Iterator<Item = Result<RecordBatch, String>> + Send>;
    let built = guard(move || -> Result<Inner, String> {
        let map = |r: Result<RecordBatch, arrow_schema::ArrowError>| r.map_err(|e| e.to_string());
        Ok(match format {
            Format::ArrowFile => mapped::batches(&file, projection)?,
            Format::ArrowStream => Box::new(
                arrow_ipc::reader::StreamReader::try_new_buffered(file, Some(projection))
                    .map_err(|e| e.to_string())?
                    .map(map),
            ),
            Format::Parquet => {
                let builder =
                    ParquetRecordBatchReaderBuilder::try_new(file).map_err(|e| e.to_string())?;
                let mask = ProjectionMask::roots(builder.parquet_schema(), projection.clone());
                let reader = builder
                    .with_projection(mask)
                    .with_batch_size(batch_rows)
                    .build()
                    .map_err(|e| e.to_string())?;
                // Parquet returns projected columns in file order; put them in the order asked for.
                let mut order: Vec<usize> = projection.clone();
                order.sort_unstable();
                let reorder: Vec<usize> = projection
                    .iter()
                    .map(|p| order.iter().position(|o| o == p).unwrap_or(0))
                    .collect();
                Box::new(reader.map(move |r| {
                    let batch = map(r)?;
                    batch.project(&reorder).map_err(|e| e.to_string())
                }))
            }
            Format::Csv => {
                // Numbers are read as text and parsed by `csv::Decode`.
                let reader = arrow_csv::ReaderBuilder::new(Arc::new(csv::reader_schema(&schema)))
                    .with_header(csv::header_is_record(&schema))
                    .with_comment(csv::COMMENT)
                    .with_batch_size(batch_rows)
                    .with_projection(projection)
                    .build(BufReader::new(file))
                    .map_err(|e| e.to_string())?;
                Box::new(reader.map(map))
            }
            Format::Mcap => super::mcap::open_batches(file, &schema, &projection, batch_rows)?,
        })
    });
    match built {
        Ok(Ok(inner)) => Ok(Batches {
            path: path.to_path_buf(),
            format,
            inner,
            next_row: 0,
            failed: false,
            csv,
        }),
        Ok(Err(message)) | Err(message) => Err(corrupt(path, format, message)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_units_are_split_off() {
        assert_eq!(
            split_header_unit(" gyro_x [deg/s] "),
            ("gyro_x".to_string(), Some("deg/s".to_string()))
        );
        assert_eq!(split_header_unit("temp"), ("temp".to_string(), None));
        assert_eq!(split_header_unit("[x]"), ("[x]".to_string(), None));
    }
}
