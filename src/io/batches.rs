//! Opening a file as a stream of Arrow record batches, with only the projected columns decoded.
//!
//! Each format's reader is wrapped so that an error, or a panic inside a third-party decoder fed a
//! corrupt file, becomes an [`InputError::Corrupt`] naming the file and the first row of the batch that
//! failed: a batch of a hundred files never dies because one of them is damaged.

use std::fs::File;
use std::io::{BufReader, Seek, SeekFrom};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use arrow_array::RecordBatch;
use arrow_schema::{DataType, Field, Schema, SchemaRef};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use parquet::arrow::ProjectionMask;

use super::format::Format;
use super::InputError;

/// Rows per batch asked of readers that let us choose (CSV, Parquet). Large enough to amortise the
/// per-batch overhead, small enough that a batch of a few channels stays in the megabytes.
pub const DEFAULT_BATCH_ROWS: usize = 65_536;

/// Rows read to guess CSV column types.
const CSV_INFER_ROWS: usize = 1000;

/// A stream of record batches holding only the projected columns, in projection order.
pub struct Batches {
    path: PathBuf,
    format: Format,
    inner: Box<dyn Iterator<Item = Result<RecordBatch, String>> + Send>,
    next_row: u64,
    failed: bool,
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
        match item? {
            Ok(batch) => {
                self.next_row += batch.num_rows() as u64;
                Some(Ok(batch))
            }
            Err(message) => {
                self.failed = true;
                Some(Err(InputError::Corrupt {
                    path: self.path.clone(),
                    format: self.format.as_str(),
                    row: Some(self.next_row),
                    message,
                }))
            }
        }
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
        format!("decoder failed: {what}")
    })
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
        message: message.to_string(),
    }
}

/// Reads the full schema of a file (for CSV: inferred, numeric columns widened to f64, and a header of the
/// form `name [unit]` turned into the field `name` with metadata `unit`; for MCAP: the columns of the IMU
/// topic `topic`, or of the only one, see [`super::mcap`]).
pub fn read_schema(
    path: &Path,
    format: Format,
    topic: Option<&str>,
) -> Result<SchemaRef, InputError> {
    let file = open_file(path)?;
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
            Format::Csv => csv_schema(file).map(Arc::new),
            Format::Mcap => unreachable!("MCAP schemas are read above"),
        }
    });
    match result {
        Ok(Ok(schema)) => Ok(schema),
        Ok(Err(message)) | Err(message) => Err(corrupt(path, format, message)),
    }
}

fn csv_schema(mut file: File) -> Result<Schema, String> {
    let (inferred, _) = arrow_csv::reader::Format::default()
        .with_header(true)
        .infer_schema(BufReader::new(&mut file), Some(CSV_INFER_ROWS))
        .map_err(|e| e.to_string())?;
    file.seek(SeekFrom::Start(0)).map_err(|e| e.to_string())?;
    let fields: Vec<Field> = inferred
        .fields()
        .iter()
        .map(|f| {
            let (name, unit) = split_header_unit(f.name());
            let data_type = match f.data_type() {
                t if t.is_numeric() => DataType::Float64,
                // An all-empty column in the first rows: read it as numbers, nulls become NaN.
                DataType::Null => DataType::Float64,
                t => t.clone(),
            };
            let mut field = Field::new(name, data_type, true);
            if let Some(unit) = unit {
                field = field.with_metadata(std::collections::HashMap::from([(
                    "unit".to_string(),
                    unit,
                )]));
            }
            field
        })
        .collect();
    Ok(Schema::new(fields))
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
    let file = open_file(path)?;
    let projection = projection.to_vec();
    let schema = schema.clone();
    type Inner = Box<dyn Iterator<Item = Result<RecordBatch, String>> + Send>;
    let built = guard(move || -> Result<Inner, String> {
        let map = |r: Result<RecordBatch, arrow_schema::ArrowError>| r.map_err(|e| e.to_string());
        Ok(match format {
            Format::ArrowFile => Box::new(
                arrow_ipc::reader::FileReader::try_new_buffered(file, Some(projection))
                    .map_err(|e| e.to_string())?
                    .map(map),
            ),
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
                let reader = arrow_csv::ReaderBuilder::new(schema)
                    .with_header(true)
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
