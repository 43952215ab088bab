//! Writing a recording in the layout [`open`](super::open) reads: a nanosecond timestamp column
//! `time`, one column per channel with `unit` and `kind` in its field metadata, and `sample_rate_hz`
//! in the schema metadata (Arrow IPC file or stream, Parquet); for CSV, time in seconds and units in
//! the header. `imunoise simulate` writes through it, so
//! every simulated file round-trips through the reader.

use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

use arrow_array::{ArrayRef, Float32Array, Float64Array, RecordBatch, TimestampNanosecondArray};
use arrow_schema::{DataType, Field, Schema, TimeUnit};

use super::Format;
use crate::report::{write_atomically, OutputError};
use crate::units::{Kind, Unit};

/// One column to write.
#[derive(Debug, Clone, Copy)]
pub struct ColumnOut<'a> {
    pub name: &'a str,
    pub unit: Unit,
    pub kind: Kind,
    pub samples: &'a [f64],
}

/// Sample storage type of the written channels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StoredAs {
    F64,
    /// Half the size; 24 significant bits, plenty for noise but not for a large constant bias.
    F32,
}

/// Rows per record batch written: readers stream batch by batch.
const ROWS_PER_BATCH: usize = 1 << 16;

/// Writes `columns` (all of one length) sampled at `rate_hz` to `path`, atomically, in the format
/// its extension names: `.arrow`/`.feather`/`.ipc` (Arrow IPC file), `.arrows` (Arrow IPC stream),
/// `.parquet`, or `.csv` (time in seconds, units in the header as `name [unit]`; CSV has no place
/// for the kind, which the reader infers from the unit).
///
/// # Errors
/// [`OutputError`] when the extension names no writable format, the file cannot be written, or the
/// columns differ in length.
pub fn write_recording(
    path: &Path,
    rate_hz: f64,
    columns: &[ColumnOut<'_>],
    stored: StoredAs,
) -> Result<(), OutputError> {
    let n = columns.first().map_or(0, |c| c.samples.len());
    if let Some(c) = columns.iter().find(|c| c.samples.len() != n) {
        return Err(OutputError::new(
            path,
            format!(
                "column {} has {} samples, expected {n}",
                c.name,
                c.samples.len()
            ),
        ));
    }
    let format = match Format::from_extension(path) {
        Some(f @ (Format::ArrowFile | Format::ArrowStream | Format::Parquet | Format::Csv)) => f,
        _ => {
            return Err(OutputError::new(
                path,
                "the extension names no format imunoise writes: use .arrow (Arrow IPC file), \
                 .arrows (Arrow IPC stream), .parquet or .csv",
            ))
        }
    };
    let csv = format == Format::Csv;
    let value_type = match stored {
        StoredAs::F64 => DataType::Float64,
        StoredAs::F32 => DataType::Float32,
    };
    let mut fields = vec![if csv {
        Field::new("time [s]", DataType::Float64, false)
    } else {
        Field::new(
            "time",
            DataType::Timestamp(TimeUnit::Nanosecond, None),
            false,
        )
    }];
    for c in columns {
        fields.push(if csv {
            Field::new(
                format!("{} [{}]", c.name, c.unit),
                value_type.clone(),
                false,
            )
        } else {
            let meta = HashMap::from([
                ("unit".to_string(), c.unit.to_string()),
                ("kind".to_string(), c.kind.to_string()),
            ]);
            Field::new(c.name, value_type.clone(), false).with_metadata(meta)
        });
    }
    let schema = Arc::new(Schema::new_with_metadata(
        fields,
        HashMap::from([("sample_rate_hz".to_string(), format!("{rate_hz}"))]),
    ));
    let batch = |start: usize, end: usize| -> Result<RecordBatch, arrow_schema::ArrowError> {
        let time: ArrayRef = if csv {
            Arc::new(Float64Array::from(
                (start..end)
                    .map(|i| i as f64 / rate_hz)
                    .collect::<Vec<f64>>(),
            ))
        } else {
            Arc::new(TimestampNanosecondArray::from(
                (start..end)
                    .map(|i| (i as f64 * 1e9 / rate_hz).round() as i64)
                    .collect::<Vec<i64>>(),
            ))
        };
        let mut arrays = vec![time];
        for c in columns {
            let part = &c.samples[start..end];
            arrays.push(match stored {
                StoredAs::F64 => Arc::new(Float64Array::from(part.to_vec())) as ArrayRef,
                StoredAs::F32 => Arc::new(part.iter().map(|&v| v as f32).collect::<Float32Array>()),
            });
        }
        RecordBatch::try_new(schema.clone(), arrays)
    };
    let ranges: Vec<(usize, usize)> = (0..n.max(1))
        .step_by(ROWS_PER_BATCH)
        .map(|s| (s, (s + ROWS_PER_BATCH).min(n)))
        .collect();
    write_atomically(path, |out| -> Result<(), String> {
        let e = |e: &dyn std::fmt::Display| e.to_string();
        match format {
            Format::ArrowFile => {
                let mut w =
                    arrow_ipc::writer::FileWriter::try_new(out, &schema).map_err(|x| e(&x))?;
                for &(a, b) in &ranges {
                    w.write(&batch(a, b).map_err(|x| e(&x))?)
                        .map_err(|x| e(&x))?;
                }
                w.finish().map_err(|x| e(&x))
            }
            Format::ArrowStream => {
                let mut w =
                    arrow_ipc::writer::StreamWriter::try_new(out, &schema).map_err(|x| e(&x))?;
                for &(a, b) in &ranges {
                    w.write(&batch(a, b).map_err(|x| e(&x))?)
                        .map_err(|x| e(&x))?;
                }
                w.finish().map_err(|x| e(&x))
            }
            Format::Parquet => {
                let mut w = parquet::arrow::ArrowWriter::try_new(out, schema.clone(), None)
                    .map_err(|x| e(&x))?;
                for &(a, b) in &ranges {
                    w.write(&batch(a, b).map_err(|x| e(&x))?)
                        .map_err(|x| e(&x))?;
                }
                w.close().map(|_| ()).map_err(|x| e(&x))
            }
            _ => {
                let mut w = arrow_csv::WriterBuilder::new().with_header(true).build(out);
                for &(a, b) in &ranges {
                    w.write(&batch(a, b).map_err(|x| e(&x))?)
                        .map_err(|x| e(&x))?;
                }
                Ok(())
            }
        }
    })
}
