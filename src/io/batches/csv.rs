//! CSV input: which columns are numbers, the numbers themselves, and where in the file a bad record
//! is.
//!
//! arrow-csv splits the records and builds string columns; the numbers are parsed here, so that a cell
//! that is not a number is an error naming the file, the column, the row (0-based data row, as
//! everywhere) and the line of the file, however far into the file it is.
//!
//! Column types are judged on the first [`INFER_ROWS`] records. A column is read as numbers when its
//! header carries a unit (`gyro_x [deg/s]`) and at least one of its values is a number, or when at
//! least [`NUMERIC_SHARE`] of its non-empty values are numbers; a column of text throughout (a label)
//! stays text and is not a channel. Timestamps, dates and booleans keep the type arrow-csv infers, and so
//! does a column of integers beyond 2⁵³ (nanosecond epoch stamps), which stays `Int64`.
//! An empty (or blank) cell is a missing sample, NaN, which the quality stage reports under its
//! `--on-nonfinite` policy; so are `NaN`, `inf` and `-inf`.
//!
//! Lines starting with `#` are comments, before the header and after it. A comment before the header
//! of the form `# sample_rate_hz: 200` (or `= 200`) gives the sample rate, as the schema metadata key
//! of the same name does in the typed formats. Where the first line that is not a comment holds
//! only numbers and the comment just before it names as many columns (two or more, not all
//! numbers), that comment is the header: EuRoC/ASL and TUM-VI files write it so
//! (`#timestamp [ns],w_RS_S_x [rad s^-1],…`). The schema then carries [`HEADER_KEY`], and every
//! reader of the file takes its first record as data row 0.

use std::collections::HashMap;
use std::fs::File;
use std::io::{BufRead, BufReader, Seek, SeekFrom};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use arrow_array::cast::AsArray;
use arrow_array::{Array, ArrayRef, Float64Array, RecordBatch, RecordBatchOptions};
use arrow_schema::{DataType, Field, Schema, SchemaRef};

use super::split_header_unit;
use crate::io::InputError;

/// The comment byte: a line starting with it is skipped.
pub const COMMENT: u8 = b'#';

/// Records read to judge column types.
pub const INFER_ROWS: usize = 1000;

/// Share of a column's non-empty values that must be numbers for a column without a unit to be read
/// as numbers (its other values then are errors, naming their row).
pub const NUMERIC_SHARE: f64 = 0.9;

/// The preamble key that gives the sample rate.
const RATE_KEY: &str = "sample_rate_hz";

/// The schema metadata key set (to [`HEADER_IN_COMMENT`]) where the header is the last comment
/// line before the data, so that every reader of the file takes its first record as data.
pub const HEADER_KEY: &str = "csv_header";
const HEADER_IN_COMMENT: &str = "comment";

/// Whether a CSV schema from [`schema`] has its header as a record of the file (not a comment).
pub fn header_is_record(schema: &Schema) -> bool {
    schema.metadata().get(HEADER_KEY).map(String::as_str) != Some(HEADER_IN_COMMENT)
}

/// Whether the comment text `comment` (after its `#`) is the header of the data whose first
/// record is `first`: `first` holds numbers only, and `comment` has as many comma-separated
/// fields, at least two (a lone note such as `# sample_rate_hz: 200` above a single column is
/// not a header), not all of them numbers.
fn is_header_of(comment: &str, first: &RawRecord) -> bool {
    let fields: Vec<&str> = comment.split(',').collect();
    let numbers = |f: &[u8]| matches!(cell(&String::from_utf8_lossy(f)), Cell::Number(_));
    fields.len() >= 2
        && fields.len() == first.fields.len()
        && first.fields.iter().all(|f| numbers(f))
        && !fields.iter().all(|f| numbers(f.as_bytes()))
}

/// Longest cell text quoted in an error message.
const SHOWN_CHARS: usize = 60;

/// What a cell holds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Cell {
    /// Empty or blank: a missing sample.
    Missing,
    Number(f64),
    Text,
}

/// Reads one cell: surrounding blanks are ignored; `NaN`, `inf`, `-inf` and `infinity` (any case) are
/// numbers, non-finite ones.
pub fn cell(text: &str) -> Cell {
    let t = text.trim();
    if t.is_empty() {
        return Cell::Missing;
    }
    match t.parse::<f64>() {
        Ok(v) => Cell::Number(v),
        Err(_) => Cell::Text,
    }
}

/// The text of a cell for an error message: at most [`SHOWN_CHARS`] characters.
pub fn shown(text: &str) -> String {
    match text.char_indices().nth(SHOWN_CHARS) {
        Some((cut, _)) => format!("{}…", &text[..cut]),
        None => text.to_string(),
    }
}

/// The full schema of a CSV file: see the module documentation for the rules. Numeric columns are
/// `Float64`; a header `name [unit]` becomes the field `name` with metadata `unit`.
pub fn schema(path: &Path, file: &mut File) -> Result<Schema, InputError> {
    let io_error = |e: std::io::Error| InputError::Unreadable {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    rewind(file).map_err(io_error)?;
    let (metadata, last_comment) = preamble(path, BufReader::new(&mut *file))?;
    rewind(file).map_err(io_error)?;

    let mut scanner = Scanner::new(BufReader::new(&mut *file));
    let Some(first) = scanner.next_record().map_err(io_error)? else {
        return Err(malformed(
            path,
            None,
            None,
            "no header line: the file holds only comments or blank lines".into(),
        ));
    };
    // EuRoC/ASL files (and TUM-VI, and loggers after them) write their header as the last comment
    // (`#timestamp [ns],w_RS_S_x [rad s^-1],…`) above rows of numbers only: that comment is the
    // header, and the first line that is not a comment the first data row.
    let comment_header = last_comment
        .filter(|c| is_header_of(&c.text, &first))
        .map(|c| RawRecord {
            line: c.line,
            fields: c.text.split(',').map(|f| f.as_bytes().to_vec()).collect(),
        });
    let (header, mut pending) = match comment_header {
        Some(h) => (h, Some(first)),
        None => (first, None),
    };
    let header_is_a_comment = pending.is_some();
    let mut metadata = metadata;
    if header_is_a_comment {
        metadata.insert(HEADER_KEY.to_string(), HEADER_IN_COMMENT.to_string());
    }
    let mut names = Vec::with_capacity(header.fields.len());
    for (i, bytes) in header.fields.iter().enumerate() {
        match std::str::from_utf8(bytes) {
            Ok(text) => names.push(text.to_string()),
            Err(_) => {
                return Err(malformed(
                    path,
                    None,
                    Some(header.line),
                    format!(
                        "the header's column {} ({:?}) is not UTF-8 text; save the file as UTF-8",
                        i + 1,
                        shown(&String::from_utf8_lossy(bytes))
                    ),
                ))
            }
        }
    }
    if let [only] = names.as_slice() {
        if let Some((sep, what)) = [(';', "semicolons"), ('\t', "tabs"), ('|', "bars")]
            .into_iter()
            .find(|(c, _)| only.contains(*c))
        {
            return Err(malformed(
                path,
                None,
                Some(header.line),
                format!(
                    "the header is one column, {:?}, whose names are separated by {what}: CSV \
                     input is read with commas between the columns and points as decimal marks; \
                     convert the file (e.g. `tr '{}' ','` where the decimals are points already)",
                    shown(only),
                    sep.escape_default()
                ),
            ));
        }
    }
    if names.iter().all(|n| matches!(cell(n), Cell::Number(_))) {
        return Err(malformed(
            path,
            None,
            Some(header.line),
            format!(
                "the first line that is not a comment holds numbers, not column names; a header \
                 line (e.g. `time [s],gyro_x [deg/s]`) is needed, or a comment line just above \
                 the numbers with a name for each of their {} columns (as EuRoC/ASL files write \
                 it: `#timestamp [ns],w_RS_S_x [rad s^-1],…`)",
                names.len()
            ),
        ));
    }
    let parts: Vec<(String, Option<String>)> = names.iter().map(|n| split_header_unit(n)).collect();
    let bare: Vec<String> = parts.iter().map(|(n, _)| n.clone()).collect();
    super::check_unique_names(path, bare.iter().map(String::as_str))?;

    let mut stats = vec![ColumnStats::default(); names.len()];
    for row in 0..INFER_ROWS as u64 {
        let record = match pending.take() {
            Some(r) => r,
            None => match scanner.next_record().map_err(io_error)? {
                Some(r) => r,
                None => break,
            },
        };
        check_record(path, &bare, &record, row)?;
        for (s, bytes) in stats.iter_mut().zip(&record.fields) {
            // UTF-8 was checked just above.
            s.add(std::str::from_utf8(bytes).unwrap_or(""), row);
        }
    }
    drop(scanner);

    // arrow-csv's inference, for the types beyond numbers and text (timestamps, dates, booleans).
    rewind(file).map_err(io_error)?;
    let (inferred, _) = arrow_csv::reader::Format::default()
        .with_header(!header_is_a_comment)
        .with_comment(COMMENT)
        .infer_schema(BufReader::new(&mut *file), Some(INFER_ROWS))
        .map_err(|e| malformed(path, None, None, super::plain(&e.to_string())))?;
    rewind(file).map_err(io_error)?;
    if inferred.fields().len() != names.len() {
        return Err(malformed(
            path,
            None,
            Some(header.line),
            format!(
                "the header has {} columns, but arrow-csv read {}",
                names.len(),
                inferred.fields().len()
            ),
        ));
    }

    // A column whose header gives a unit is a measurement: one with no number in its first rows (a
    // dead axis logged as `N/A`) is an error at its first value, as text later in it is, rather
    // than a column of text silently left out.
    for ((name, unit), s) in parts.iter().zip(&stats) {
        if let (Some(_), 0, Some((row, value))) = (unit, s.numbers, &s.first_text) {
            return Err(InputError::BadValue {
                path: path.to_path_buf(),
                column: name.clone(),
                row: *row,
                line: line_of_row(path, *row),
                value: shown(value),
                expected: "a number",
            });
        }
    }

    let fields: Vec<Field> = inferred
        .fields()
        .iter()
        .zip(&parts)
        .zip(&stats)
        .map(|((f, (name, unit)), s)| {
            let data_type = match f.data_type() {
                _ if s.wide_integers() => DataType::Int64,
                t if t.is_numeric() => DataType::Float64,
                // Empty throughout the first rows: read as numbers, the empty cells are missing samples.
                DataType::Null => DataType::Float64,
                DataType::Utf8 if s.numeric(unit.is_some()) => DataType::Float64,
                t => t.clone(),
            };
            let mut field = Field::new(name, data_type, true);
            if let Some(unit) = unit {
                field = field.with_metadata(HashMap::from([("unit".to_string(), unit.clone())]));
            }
            field
        })
        .collect();
    Ok(Schema::new(fields).with_metadata(metadata))
}

/// Counts of what a column's first values hold.
#[derive(Debug, Clone, Default)]
struct ColumnStats {
    numbers: u64,
    texts: u64,
    /// Numbers written as integers.
    integers: u64,
    /// Whether one of those integers is beyond 2⁵³, where f64 no longer holds every integer.
    wide_integer: bool,
    /// The first value that is not a number, and its row.
    first_text: Option<(u64, String)>,
}

/// The largest integer below which f64 holds every integer.
const F64_EXACT_INTEGERS: i64 = 1 << 53;

impl ColumnStats {
    fn add(&mut self, text: &str, row: u64) {
        match cell(text) {
            Cell::Missing => {}
            Cell::Number(_) => {
                self.numbers += 1;
                if let Ok(i) = text.trim().parse::<i64>() {
                    self.integers += 1;
                    self.wide_integer |= i.unsigned_abs() > F64_EXACT_INTEGERS as u64;
                }
            }
            Cell::Text => {
                self.texts += 1;
                if self.first_text.is_none() {
                    self.first_text = Some((row, text.to_string()));
                }
            }
        }
    }

    /// Whether the column is integers throughout its first rows, one of them beyond what f64 holds
    /// exactly: nanosecond epoch timestamps (≈ 1.7·10¹⁸), which as f64 are rounded to 256 ns
    /// steps (a 100-Hz logger read as 99.9987 Hz). Such a column stays `Int64`, parsed by
    /// arrow-csv, and a time column of it is integer ticks subtracted as integers.
    fn wide_integers(&self) -> bool {
        self.wide_integer && self.texts == 0 && self.integers == self.numbers
    }

    /// Whether the column is read as numbers (see the module documentation).
    fn numeric(&self, has_unit: bool) -> bool {
        let seen = self.numbers + self.texts;
        self.numbers > 0 && (has_unit || self.numbers as f64 >= NUMERIC_SHARE * seen as f64)
    }
}

/// UTF-8's byte-order mark, which spreadsheets write at the start of a CSV file.
const BOM: &[u8] = b"\xEF\xBB\xBF";

/// Moves `file` to its first byte after a byte-order mark, if it starts with one. Every reader of
/// a CSV file starts there: behind a mark, a `#` preamble line was not a comment (the file's
/// sample rate was lost and the line read as a record), and the first header name carried it.
/// The mark holds no line break, so line numbers stay the file's own.
pub fn rewind(file: &mut File) -> std::io::Result<()> {
    use std::io::Read;
    file.seek(SeekFrom::Start(0))?;
    let mut head = [0u8; 3];
    let mut got = 0;
    while got < head.len() {
        match file.read(&mut head[got..])? {
            0 => break,
            n => got += n,
        }
    }
    let start = if head[..got] == *BOM { BOM.len() } else { 0 };
    file.seek(SeekFrom::Start(start as u64))?;
    Ok(())
}

/// `path` opened at its first byte after a byte-order mark ([`rewind`]).
pub fn open(path: &Path) -> std::io::Result<File> {
    let mut file = File::open(path)?;
    rewind(&mut file)?;
    Ok(file)
}

/// The schema metadata that comment lines before the header give (`# sample_rate_hz: 200`), and
/// the text after `#` of the last of them (a header left in a comment, as EuRoC/ASL files write
/// it).
fn preamble(
    path: &Path,
    mut reader: impl BufRead,
) -> Result<(HashMap<String, String>, Option<Comment>), InputError> {
    let mut metadata = HashMap::new();
    let mut last_comment = None;
    let mut line = Vec::new();
    let mut number = 0u64;
    loop {
        number += 1;
        line.clear();
        let n = reader
            .read_until(b'\n', &mut line)
            .map_err(|e| InputError::Unreadable {
                path: path.to_path_buf(),
                message: e.to_string(),
            })?;
        if n == 0 {
            break;
        }
        let text = String::from_utf8_lossy(&line);
        let text = text.trim_end_matches(['\r', '\n']);
        if text.is_empty() {
            continue;
        }
        let Some(comment) = text.strip_prefix(COMMENT as char) else {
            break;
        };
        if let Some((key, value)) = comment.split_once([':', '=']) {
            if key.trim() == RATE_KEY && !metadata.contains_key(RATE_KEY) {
                metadata.insert(RATE_KEY.to_string(), value.trim().to_string());
            }
        }
        last_comment = Some(Comment {
            line: number,
            text: comment.to_owned(),
        });
    }
    Ok((metadata, last_comment))
}

/// A comment line before the header: its 1-based line and its text after `#`.
struct Comment {
    line: u64,
    text: String,
}

fn malformed(path: &Path, row: Option<u64>, line: Option<u64>, message: String) -> InputError {
    InputError::MalformedCsv {
        path: path.to_path_buf(),
        row,
        line,
        message,
    }
}

/// A record must have as many fields as the header, each UTF-8 text.
fn check_record(
    path: &Path,
    names: &[String],
    record: &RawRecord,
    row: u64,
) -> Result<(), InputError> {
    if record.fields.len() != names.len() {
        return Err(malformed(
            path,
            Some(row),
            Some(record.line),
            format!(
                "{} fields, but the header has {}",
                record.fields.len(),
                names.len()
            ),
        ));
    }
    for (name, bytes) in names.iter().zip(&record.fields) {
        if std::str::from_utf8(bytes).is_err() {
            return Err(malformed(
                path,
                Some(row),
                Some(record.line),
                format!(
                    "column {name:?} holds bytes that are not UTF-8 text ({:?}); save the file as \
                     UTF-8",
                    shown(&String::from_utf8_lossy(bytes))
                ),
            ));
        }
    }
    Ok(())
}

/// The schema arrow-csv reads with: numeric columns as text, parsed here (see [`Decode`]).
pub fn reader_schema(schema: &Schema) -> Schema {
    let fields: Vec<Field> = schema
        .fields()
        .iter()
        .map(|f| match f.data_type() {
            DataType::Float64 => f.as_ref().clone().with_data_type(DataType::Utf8),
            _ => f.as_ref().clone(),
        })
        .collect();
    Schema::new(fields).with_metadata(schema.metadata().clone())
}

/// Turns the string columns arrow-csv returns into numbers, and explains arrow-csv's errors.
pub struct Decode {
    path: PathBuf,
    /// The file's full schema (numbers as `Float64`).
    schema: SchemaRef,
    projection: Vec<usize>,
    /// The projected schema of the batches handed out.
    out_schema: SchemaRef,
    batch_rows: usize,
}

impl Decode {
    pub fn new(path: &Path, schema: &SchemaRef, projection: &[usize], batch_rows: usize) -> Self {
        let out_schema = Arc::new(Schema::new(
            projection
                .iter()
                .map(|&i| schema.field(i).clone())
                .collect::<Vec<_>>(),
        ));
        Decode {
            path: path.to_path_buf(),
            schema: schema.clone(),
            projection: projection.to_vec(),
            out_schema,
            batch_rows: batch_rows.max(1),
        }
    }

    /// Parses the numeric columns of a batch whose first row is `first_row`.
    pub fn convert(&self, batch: RecordBatch, first_row: u64) -> Result<RecordBatch, InputError> {
        let mut columns: Vec<ArrayRef> = Vec::with_capacity(batch.num_columns());
        for (j, array) in batch.columns().iter().enumerate() {
            let column = self.projection[j];
            if self.schema.field(column).data_type() != &DataType::Float64 {
                columns.push(array.clone());
                continue;
            }
            let Some(strings) = array.as_string_opt::<i32>() else {
                return Err(malformed(
                    &self.path,
                    Some(first_row),
                    None,
                    format!(
                        "column {:?} came back as {}, not text",
                        self.schema.field(column).name(),
                        array.data_type()
                    ),
                ));
            };
            let mut values = Vec::with_capacity(strings.len());
            for i in 0..strings.len() {
                if strings.is_null(i) {
                    values.push(f64::NAN);
                    continue;
                }
                match cell(strings.value(i)) {
                    Cell::Missing => values.push(f64::NAN),
                    Cell::Number(v) => values.push(v),
                    Cell::Text => {
                        let row = first_row + i as u64;
                        return Err(InputError::BadValue {
                            path: self.path.clone(),
                            column: self.schema.field(column).name().clone(),
                            row,
                            line: line_of_row(&self.path, row),
                            value: shown(strings.value(i)),
                            expected: "a number",
                        });
                    }
                }
            }
            columns.push(Arc::new(Float64Array::from(values)));
        }
        let options = RecordBatchOptions::new().with_row_count(Some(batch.num_rows()));
        RecordBatch::try_new_with_options(self.out_schema.clone(), columns, &options).map_err(|e| {
            malformed(
                &self.path,
                Some(first_row),
                None,
                super::plain(&e.to_string()),
            )
        })
    }

    /// Explains arrow-csv's error `message` on the batch starting at `first_row`: a record with the
    /// wrong number of fields or bytes that are not UTF-8 (found by [`Scanner`]), or a value of a typed
    /// column (a timestamp) that does not parse (found by rereading the rows one at a time).
    pub fn diagnose(&self, first_row: u64, message: &str) -> InputError {
        let end_row = first_row.saturating_add(self.batch_rows as u64);
        if let Some(e) = self.structural_error(first_row, end_row) {
            return e;
        }
        if let Some(e) = self.value_error(first_row, end_row) {
            return e;
        }
        malformed(
            &self.path,
            None,
            None,
            format!(
                "in the rows from row {first_row}: {}",
                super::plain(message)
            ),
        )
    }

    fn names(&self) -> Vec<String> {
        self.schema
            .fields()
            .iter()
            .map(|f| f.name().clone())
            .collect()
    }

    fn structural_error(&self, first_row: u64, end_row: u64) -> Option<InputError> {
        let names = self.names();
        let mut scanner = Scanner::new(BufReader::new(open(&self.path).ok()?));
        if header_is_record(&self.schema) {
            scanner.next_record().ok()??;
        }
        let mut row = 0u64;
        while row < end_row {
            let record = scanner.next_record().ok()??;
            if row >= first_row {
                if let Err(e) = check_record(&self.path, &names, &record, row) {
                    return Some(e);
                }
            }
            row += 1;
        }
        None
    }

    fn reader(
        &self,
        rows: (u64, u64),
        projection: Vec<usize>,
        batch_rows: usize,
    ) -> Option<arrow_csv::reader::Reader<File>> {
        arrow_csv::ReaderBuilder::new(Arc::new(reader_schema(&self.schema)))
            .with_header(header_is_record(&self.schema))
            .with_comment(COMMENT)
            .with_bounds(usize::try_from(rows.0).ok()?, usize::try_from(rows.1).ok()?)
            .with_batch_size(batch_rows)
            .with_projection(projection)
            .build(open(&self.path).ok()?)
            .ok()
    }

    fn value_error(&self, first_row: u64, end_row: u64) -> Option<InputError> {
        let rows = self.reader((first_row, end_row), self.projection.clone(), 1)?;
        let bad_row = super::guard(|| {
            for (row, batch) in (first_row..).zip(rows) {
                if batch.is_err() {
                    return Some(row);
                }
            }
            None
        })
        .ok()??;
        let column = self.projection.iter().copied().find(|&c| {
            self.reader((bad_row, bad_row + 1), vec![c], 1)
                .and_then(|mut r| super::guard(move || r.next()).ok().flatten())
                .is_some_and(|b| b.is_err())
        })?;
        let record = record_of_row(&self.path, bad_row)?;
        let value = record
            .fields
            .get(column)
            .map(|b| String::from_utf8_lossy(b).into_owned())
            .unwrap_or_default();
        let expected = match self.schema.field(column).data_type() {
            DataType::Timestamp(..) => "a timestamp (like the column's first values)",
            DataType::Date32 | DataType::Date64 => "a date (like the column's first values)",
            DataType::Boolean => "true or false (like the column's first values)",
            _ => "a value of the column's type",
        };
        Some(InputError::BadValue {
            path: self.path.clone(),
            column: self.schema.field(column).name().clone(),
            row: bad_row,
            line: Some(record.line),
            value: shown(&value),
            expected,
        })
    }
}

/// The record of a data row (0-based, the header is not a row).
fn record_of_row(path: &Path, row: u64) -> Option<RawRecord> {
    let (_, last_comment) = preamble(path, BufReader::new(open(path).ok()?)).ok()?;
    let mut scanner = Scanner::new(BufReader::new(open(path).ok()?));
    let mut record = scanner.next_record().ok()??;
    // Row 0 is the first record where the header is a comment, the one after it otherwise.
    let header_is_a_comment = last_comment.is_some_and(|c| is_header_of(&c.text, &record));
    for _ in 0..row + u64::from(!header_is_a_comment) {
        record = scanner.next_record().ok()??;
    }
    Some(record)
}

/// The 1-based line of the file where a data row starts.
pub fn line_of_row(path: &Path, row: u64) -> Option<u64> {
    record_of_row(path, row).map(|r| r.line)
}

/// One record as the CSV tokenizer sees it: where it starts and its fields' raw bytes.
#[derive(Debug, Clone, PartialEq)]
pub struct RawRecord {
    /// 1-based line of the file on which the record starts.
    pub line: u64,
    pub fields: Vec<Vec<u8>>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    StartRecord,
    StartField,
    InField,
    InQuoted,
    QuoteInQuoted,
    InComment,
}

/// Splits CSV into records exactly as arrow-csv's tokenizer (csv-core with its defaults: `,`, `"`
/// quoting with `""` for a quote, CR, LF or CRLF ending a record, empty lines skipped, `#` comment
/// lines) does, and counts lines (LF, CR or CRLF) as an editor does. Kept in step with csv-core's
/// `transition_nfa`; used where a row must be located in the file (errors, schema inference), never
/// on the fast path.
pub struct Scanner<R> {
    reader: R,
    state: State,
    line: u64,
    previous_cr: bool,
    done: bool,
}

impl<R: BufRead> Scanner<R> {
    pub fn new(reader: R) -> Self {
        Scanner {
            reader,
            state: State::StartRecord,
            line: 1,
            previous_cr: false,
            done: false,
        }
    }

    /// The next record; `None` at the end of the input.
    pub fn next_record(&mut self) -> std::io::Result<Option<RawRecord>> {
        if self.done {
            return Ok(None);
        }
        let mut record: Option<RawRecord> = None;
        let mut field = Vec::new();
        loop {
            let buf = self.reader.fill_buf()?;
            if buf.is_empty() {
                self.done = true;
                // csv-core ends a record at the end of the input as if a terminator followed.
                return Ok(record.map(|mut r| {
                    r.fields.push(field);
                    r
                }));
            }
            let mut used = 0;
            let mut finished = false;
            for &c in buf {
                used += 1;
                let line_here = self.line;
                match c {
                    b'\n' => {
                        if !self.previous_cr {
                            self.line += 1;
                        }
                        self.previous_cr = false;
                    }
                    b'\r' => {
                        self.line += 1;
                        self.previous_cr = true;
                    }
                    _ => self.previous_cr = false,
                }
                let term = c == b'\n' || c == b'\r';
                if self.state == State::StartRecord {
                    if term {
                        continue;
                    }
                    if c == COMMENT {
                        self.state = State::InComment;
                        continue;
                    }
                    record = Some(RawRecord {
                        line: line_here,
                        fields: Vec::new(),
                    });
                    self.state = State::StartField;
                }
                let mut end_field = false;
                match self.state {
                    State::StartRecord => unreachable!("handled above"),
                    State::InComment => {
                        if c == b'\n' {
                            self.state = State::StartRecord;
                        }
                    }
                    State::StartField => {
                        if c == b'"' {
                            self.state = State::InQuoted;
                        } else if c == b',' || term {
                            end_field = true;
                        } else {
                            field.push(c);
                            self.state = State::InField;
                        }
                    }
                    State::InField => {
                        if c == b',' || term {
                            end_field = true;
                        } else {
                            field.push(c);
                        }
                    }
                    State::InQuoted => {
                        if c == b'"' {
                            self.state = State::QuoteInQuoted;
                        } else {
                            field.push(c);
                        }
                    }
                    State::QuoteInQuoted => {
                        if c == b'"' {
                            field.push(c);
                            self.state = State::InQuoted;
                        } else if c == b',' || term {
                            end_field = true;
                        } else {
                            field.push(c);
                            self.state = State::InField;
                        }
                    }
                }
                if end_field {
                    if let Some(r) = record.as_mut() {
                        r.fields.push(std::mem::take(&mut field));
                    }
                    if term {
                        self.state = State::StartRecord;
                        finished = true;
                        break;
                    }
                    self.state = State::StartField;
                }
            }
            self.reader.consume(used);
            if finished {
                return Ok(record);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn records(text: &[u8]) -> Vec<(u64, Vec<String>)> {
        let mut s = Scanner::new(text);
        let mut out = Vec::new();
        while let Some(r) = s.next_record().unwrap() {
            out.push((
                r.line,
                r.fields
                    .iter()
                    .map(|f| String::from_utf8_lossy(f).into_owned())
                    .collect(),
            ));
        }
        out
    }

    fn v(fields: &[&str]) -> Vec<String> {
        fields.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn scanner_splits_records_and_counts_lines_like_an_editor() {
        let text = b"# preamble\n\na,b\r\n1,\"x\ny\"\n#c\n\"q\"\"q\",2\r3,4";
        assert_eq!(
            records(text),
            vec![
                (3, v(&["a", "b"])),
                (4, v(&["1", "x\ny"])),
                (7, v(&["q\"q", "2"])),
                (8, v(&["3", "4"])),
            ]
        );
        assert_eq!(records(b"a,b,\n"), vec![(1, v(&["a", "b", ""]))]);
        assert_eq!(records(b"\n\n"), Vec::<(u64, Vec<String>)>::new());
        assert_eq!(records(b"x"), vec![(1, v(&["x"]))]);
    }

    /// The scanner must split exactly as arrow-csv does: same records, same fields.
    #[test]
    fn scanner_agrees_with_arrow_csv() {
        let text = "# c\nh1,h2\n\"a,b\",1\n\n#x\nc\"d,2\r\n\"e\"\"f\"g,3\r\"\",4\n";
        let schema = Arc::new(Schema::new(vec![
            Field::new("h1", DataType::Utf8, true),
            Field::new("h2", DataType::Utf8, true),
        ]));
        let batch = arrow_csv::ReaderBuilder::new(schema)
            .with_header(true)
            .with_comment(COMMENT)
            .build(text.as_bytes())
            .unwrap()
            .next()
            .unwrap()
            .unwrap();
        let ours = records(text.as_bytes());
        assert_eq!(ours.len(), batch.num_rows() + 1);
        for (col, a) in batch.columns().iter().enumerate() {
            let a = a.as_string::<i32>();
            for row in 0..a.len() {
                let theirs = if a.is_null(row) { "" } else { a.value(row) };
                assert_eq!(ours[row + 1].1[col], theirs, "row {row} column {col}");
            }
        }
    }

    #[test]
    fn cells_are_numbers_missing_or_text() {
        assert_eq!(cell(" 0.5 "), Cell::Number(0.5));
        assert_eq!(cell("1e-3"), Cell::Number(1e-3));
        assert!(matches!(cell("NaN"), Cell::Number(v) if v.is_nan()));
        assert!(matches!(cell("-inf"), Cell::Number(v) if v == f64::NEG_INFINITY));
        assert_eq!(cell(""), Cell::Missing);
        assert_eq!(cell("  "), Cell::Missing);
        assert_eq!(cell("abc"), Cell::Text);
        assert_eq!(cell("1,5"), Cell::Text);
        assert_eq!(shown(&"x".repeat(100)).chars().count(), SHOWN_CHARS + 1);
    }
}
