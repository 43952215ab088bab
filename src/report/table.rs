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
    /// Text as runs of one value: (value, rows). The long tables repeat a file, channel and unit
    /// along thousands of rows; as one `String` a row, the 10⁷-sample `psd` spent more time
    /// allocating and freeing them than writing its report. Written like [`Column::Str`].
    Runs(Vec<(String, usize)>),
}

impl Column {
    /// `value` on each of `rows` rows.
    pub fn repeated(value: impl Into<String>, rows: usize) -> Column {
        Column::Runs(vec![(value.into(), rows)])
    }

    fn len(&self) -> usize {
        match self {
            Column::F64(v) => v.len(),
            Column::U64(v) => v.len(),
            Column::I64(v) => v.len(),
            Column::Str(v) => v.len(),
            Column::Runs(runs) => runs.iter().map(|(_, n)| n).sum(),
        }
    }

    /// The rows of a text column in order (none for a numeric one).
    fn texts(&self) -> Box<dyn Iterator<Item = &str> + '_> {
        match self {
            Column::Str(v) => Box::new(v.iter().map(String::as_str)),
            Column::Runs(runs) => Box::new(
                runs.iter()
                    .flat_map(|(value, n)| std::iter::repeat_n(value.as_str(), *n)),
            ),
            _ => Box::new(std::iter::empty()),
        }
    }

    fn extend(&mut self, other: Column) {
        match (self, other) {
            (Column::F64(a), Column::F64(b)) => a.extend(b),
            (Column::U64(a), Column::U64(b)) => a.extend(b),
            (Column::I64(a), Column::I64(b)) => a.extend(b),
            (Column::Str(a), Column::Str(b)) => a.extend(b),
            (Column::Runs(a), Column::Runs(b)) => {
                for (value, n) in b {
                    match a.last_mut() {
                        Some((last, m)) if *last == value => *m += n,
                        _ => a.push((value, n)),
                    }
                }
            }
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
                Column::Runs(runs) => (DataType::Utf8, Arc::new(runs_array(runs))),
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
            let mut texts: Vec<_> = self.columns.iter().map(|(_, c)| c.texts()).collect();
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
                        Column::Str(_) | Column::Runs(_) => {
                            line.push_str(&csv_quote(texts[i].next().unwrap_or_default()))
                        }
                    }
                }
                writeln!(out, "{line}")?;
            }
            Ok(())
        })
    }
}

/// The string array of a run-length text column: one value buffer filled run by run, no string a
/// row.
fn runs_array(runs: &[(String, usize)]) -> StringArray {
    let rows = runs.iter().map(|(_, n)| n).sum();
    let bytes = runs.iter().map(|(v, n)| v.len() * n).sum();
    let mut b = arrow_array::builder::StringBuilder::with_capacity(rows, bytes);
    for (value, n) in runs {
        for _ in 0..*n {
            b.append_value(value);
        }
    }
    b.finish()
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

    #[test]
    fn runs_write_as_the_strings_they_stand_for() {
        let dir = tempfile::tempdir().unwrap();
        let table = |file: Column, unit: Column| Table {
            columns: vec![
                ("file".into(), file),
                ("unit".into(), unit),
                ("x".into(), Column::F64(vec![1.0, 2.0, 3.0, 4.0])),
            ],
            metadata: Default::default(),
        };
        let mut runs = table(Column::repeated("a,b", 1), Column::repeated("u", 1));
        runs.append(table(Column::repeated("a,b", 1), Column::repeated("u", 1)));
        runs.append(table(Column::repeated("c", 2), Column::repeated("u", 2)));
        runs.columns[2].1 = Column::F64(vec![1.0, 2.0, 3.0, 4.0]);
        assert_eq!(
            runs.columns[0].1,
            Column::Runs(vec![("a,b".into(), 2), ("c".into(), 2)])
        );
        assert_eq!(runs.columns[1].1, Column::Runs(vec![("u".into(), 4)]));
        let strings = table(
            Column::Str(["a,b", "a,b", "c", "c"].map(String::from).to_vec()),
            Column::Str(vec!["u".into(); 4]),
        );
        for (t, stem) in [(&runs, "runs"), (&strings, "strings")] {
            t.write_csv(&dir.path().join(format!("{stem}.csv")))
                .unwrap();
            t.write_arrow(&dir.path().join(format!("{stem}.arrow")))
                .unwrap();
        }
        let read = |name: &str| std::fs::read(dir.path().join(name)).unwrap();
        assert_eq!(read("runs.csv"), read("strings.csv"));
        let batch = |name: &str| {
            let f = std::fs::File::open(dir.path().join(name)).unwrap();
            arrow_ipc::reader::FileReader::try_new(f, None)
                .unwrap()
                .next()
                .unwrap()
                .unwrap()
        };
        assert_eq!(batch("runs.arrow"), batch("strings.arrow"));
    }
}
