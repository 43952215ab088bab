//! Writing a recording as an Arrow IPC file in the layout [`open`](super::open) reads: a
//! nanosecond timestamp column `time`, one column per channel with `unit` and `kind` in its field
//! metadata, and `sample_rate_hz` in the schema metadata. `imunoise simulate` writes through it, so
//! every simulated file round-trips through the reader.

use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

use arrow_array::{ArrayRef, Float32Array, Float64Array, RecordBatch, TimestampNanosecondArray};
use arrow_schema::{DataType, Field, Schema, TimeUnit};

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

/// Writes `columns` (all of one length) sampled at `rate_hz` to `path`, atomically.
///
/// # Errors
/// [`OutputError`] when the file cannot be written, or the columns differ in length.
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
    let value_type = match stored {
        StoredAs::F64 => DataType::Float64,
        StoredAs::F32 => DataType::Float32,
    };
    let mut fields = vec![Field::new(
        "time",
        DataType::Timestamp(TimeUnit::Nanosecond, None),
        false,
    )];
    for c in columns {
        let meta = HashMap::from([
            ("unit".to_string(), c.unit.to_string()),
            ("kind".to_string(), c.kind.to_string()),
        ]);
        fields.push(Field::new(c.name, value_type.clone(), false).with_metadata(meta));
    }
    let schema = Arc::new(Schema::new_with_metadata(
        fields,
        HashMap::from([("sample_rate_hz".to_string(), format!("{rate_hz}"))]),
    ));
    write_atomically(path, |out| -> Result<(), arrow_schema::ArrowError> {
        let mut w = arrow_ipc::writer::FileWriter::try_new(out, &schema)?;
        let mut start = 0;
        while start < n.max(1) {
            let end = (start + ROWS_PER_BATCH).min(n);
            let time: Vec<i64> = (start..end)
                .map(|i| (i as f64 * 1e9 / rate_hz).round() as i64)
                .collect();
            let mut arrays: Vec<ArrayRef> = vec![Arc::new(TimestampNanosecondArray::from(time))];
            for c in columns {
                let part = &c.samples[start..end];
                arrays.push(match stored {
                    StoredAs::F64 => Arc::new(Float64Array::from(part.to_vec())),
                    StoredAs::F32 => {
                        Arc::new(part.iter().map(|&v| v as f32).collect::<Float32Array>())
                    }
                });
            }
            w.write(&RecordBatch::try_new(schema.clone(), arrays)?)?;
            if end == n {
                break;
            }
            start = end;
        }
        w.finish()
    })
}
