//! A plain column table and its writers (Arrow IPC file, CSV). Results are long ("tidy") tables: one
//! row per file × channel × frequency or τ, so that a fleet of recordings lands in one table that
//! pandas, polars or DuckDB read without reshaping.

use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

use arrow_array::{ArrayRef, Float64Array, Int64Array, RecordBatch, StringArray, UInt64Array};
use arrow_schema::{DataType, Field, Schema};

use super::atomic::{write_atomically, OutputError};

/// One column of values.
#[derive(Debug, Clone, PartialEq)]
pub enum Column {
    F64(Vec<f64>),
    U64(Vec<u64>),
    I64(Vec<i64>),
    Str(Vec<String>),
}

impl Column {
    fn len(&self) -> usize {
        match self {
            Column::F64(v) => v.len(),
            Column::U64(v) => v.len(),
            Column::I64(v) => v.len(),
            Column::Str(v) => v.len(),
        }
    }

    fn extend(&mut self, other: Column) {
        match (self, other) {
            (Column::F64(a), Column::F64(b)) => a.extend(b),
            (Column::U64(a), Column::U64(b)) => a.extend(b),
            (Column::I64(a), Column::I64(b)) => a.extend(b),
            (Column::Str(a), Column::Str(b)) => a.extend(b),
            _ => panic!("table columns appended with different types"),
        }
    }
}

/// Named columns of equal length, with metadata carried into the Arrow schema.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Table {
    pub columns: Vec<(String, Column)>,
    pub metadata: HashMap<String, String>,
}

impl Table {
    pub fn rows(&self) -> usize {
        self.columns.first().map_or(0, |(_, c)| c.len())
    }

    /// Appends the rows of `other`, which must have the same columns in the same order.
    ///
    /// # Panics
    /// If the column names or types differ (a programming error, not an input error).
    pub fn append(&mut self, other: Table) {
        if self.columns.is_empty() {
            self.columns = other.columns;
            return;
        }
        for ((name, col), (other_name, other_col)) in self.columns.iter_mut().zip(other.columns) {
            assert_eq!(*name, other_name, "table columns appended out of order");
            col.extend(other_col);
        }
    }

    fn record_batch(&self) -> Result<RecordBatch, arrow_schema::ArrowError> {
        let mut fields = Vec::new();
        let mut arrays: Vec<ArrayRef> = Vec::new();
        for (name, col) in &self.columns {
            let (dt, array): (DataType, ArrayRef) = match col {
                Column::F64(v) => (DataType::Float64, Arc::new(Float64Array::from(v.clone()))),
                Column::U64(v) => (DataType::UInt64, Arc::new(UInt64Array::from(v.clone()))),
                Column::I64(v) => (DataType::Int64, Arc::new(Int64Array::from(v.clone()))),
                Column::Str(v) => (DataType::Utf8, Arc::new(StringArray::from(v.clone()))),
            };
            fields.push(Field::new(name, dt, false));
            arrays.push(array);
        }
        let schema = Schema::new(fields).with_metadata(self.metadata.clone());
        RecordBatch::try_new(Arc::new(schema), arrays)
    }

    /// Writes an Arrow IPC file, atomically.
    pub fn write_arrow(&self, path: &Path) -> Result<(), OutputError> {
        let batch = self.record_batch().map_err(|e| OutputError::new(path, e))?;
        write_atomically(path, |out| {
            let mut w = arrow_ipc::writer::FileWriter::try_new(out, &batch.schema())?;
            w.write(&batch)?;
            w.finish()
        })
    }

    /// Writes CSV with a header row, full f64 precision (shortest round-trip form), atomically.
    pub fn write_csv(&self, path: &Path) -> Result<(), OutputError> {
        use std::io::Write;
        write_atomically(path, |out| -> std::io::Result<()> {
            let header: Vec<&str> = self.columns.iter().map(|(n, _)| n.as_str()).collect();
            writeln!(out, "{}", header.join(","))?;
            for r in 0..self.rows() {
                let mut line = String::new();
                for (i, (_, col)) in self.columns.iter().enumerate() {
                    if i > 0 {
                        line.push(',');
                    }
                    match col {
                        Column::F64(v) => line.push_str(&format!("{:?}", v[r])),
                        Column::U64(v) => line.push_str(&v[r].to_string()),
                        Column::I64(v) => line.push_str(&v[r].to_string()),
                        Column::Str(v) => line.push_str(&csv_quote(&v[r])),
                    }
                }
                writeln!(out, "{line}")?;
            }
            Ok(())
        })
    }
}

fn csv_quote(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_and_arrow_round_trip_values_exactly() {
        let dir = tempfile::tempdir().unwrap();
        let t = Table {
            columns: vec![
                (
                    "file".into(),
                    Column::Str(vec!["a,b.arrow".into(), "c".into()]),
                ),
                ("x".into(), Column::F64(vec![0.1 + 0.2, 1e-300])),
                ("n".into(), Column::U64(vec![1, 2])),
            ],
            metadata: [("k".to_string(), "v".to_string())].into(),
        };
        t.write_csv(&dir.path().join("t.csv")).unwrap();
        let csv = std::fs::read_to_string(dir.path().join("t.csv")).unwrap();
        assert_eq!(
            csv,
            "file,x,n\n\"a,b.arrow\",0.30000000000000004,1\nc,1e-300,2\n"
        );
        t.write_arrow(&dir.path().join("t.arrow")).unwrap();
        let f = std::fs::File::open(dir.path().join("t.arrow")).unwrap();
        let mut r = arrow_ipc::reader::FileReader::try_new(f, None).unwrap();
        assert_eq!(r.schema().metadata()["k"], "v");
        let b = r.next().unwrap().unwrap();
        let x = b.column(1).as_any().downcast_ref::<Float64Array>().unwrap();
        assert_eq!(x.value(0), 0.1 + 0.2);
    }
}
