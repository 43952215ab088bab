//! Property tests of the readers: arbitrary damage to a valid file (truncation, overwritten bytes) in
//! every format must give samples or an error naming the file, never a panic or a hang; and below, case
//! by case (truncation at every length, text where numbers belong, NaN/Inf, huge rows, no rows,
//! non-UTF-8 CSV, duplicate names), the right samples or an error naming file, column and row.
//! Default case counts keep the file to a few seconds; `PROPTEST_CASES=N` runs a longer campaign.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use arrow_array::{Array, RecordBatch};
use imunoise::io::{self, InputError, OpenOptions};
use imunoise::pipeline::{self, Inputs, Silent, Work};
use imunoise::quality::{GapPolicy, NonFinitePolicy, QualityOptions};
use proptest::prelude::*;

use super::support::*;

fn valid_files(dir: &Path) -> Vec<(std::path::PathBuf, Vec<u8>)> {
    let n = 3000;
    let b = batch(
        &[
            time_col(n, 100.0, |_, t| t),
            f64_col("g", noise(n, 1), Some("deg/s")),
            f64_col("a", noise(n, 2), Some("g")),
        ],
        Some(100.0),
    );
    let mut out = Vec::new();
    for (name, write) in [
        (
            "f.arrow",
            write_ipc_file as fn(&Path, &arrow_array::RecordBatch, usize),
        ),
        ("f.arrows", write_ipc_stream),
        ("f.parquet", write_parquet),
    ] {
        let p = dir.join(name);
        write(&p, &b, 700);
        out.push((p.clone(), std::fs::read(&p).unwrap()));
    }
    let csv = dir.join("f.csv");
    write_csv(
        &csv,
        &[("g", Some("deg/s")), ("a", None)],
        &[noise(200, 3), noise(200, 4)],
    );
    out.push((csv.clone(), std::fs::read(&csv).unwrap()));
    // MCAP, written by the independent Python writer (tests/data/mcap/make_mcap.py): 4000 IMU
    // messages at 200 Hz in zstd chunks with CRCs, and a summary section.
    let fixture = repo_root().join("tests/data/mcap/imu_200hz.mcap");
    let mcap = dir.join("f.mcap");
    std::fs::copy(&fixture, &mcap).unwrap();
    out.push((mcap.clone(), std::fs::read(&mcap).unwrap()));
    out
}

/// 256 cases per CI run (about a second); `PROPTEST_CASES=N` runs a longer campaign.
fn cases() -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(256)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(), failure_persistence: None, .. ProptestConfig::default() })]

    #[test]
    fn damaged_files_never_panic(
        which in 0usize..5,
        cut in 0.0f64..1.0,
        edits in prop::collection::vec((0.0f64..1.0, any::<u8>()), 0..16),
        truncate in any::<bool>(),
    ) {
        let dir = tempfile::tempdir().unwrap();
        let files = valid_files(dir.path());
        let (path, bytes) = &files[which];
        let mut damaged = bytes.clone();
        for (pos, value) in edits {
            let i = ((damaged.len() - 1) as f64 * pos) as usize;
            damaged[i] = value;
        }
        if truncate {
            damaged.truncate((damaged.len() as f64 * cut) as usize);
        }
        std::fs::write(path, &damaged).unwrap();
        let mut inputs = Inputs::default();
        // MCAP (4) carries header times; the others are read at 100 Hz.
        inputs.open.rate_hz = (which != 4).then_some(100.0);
        inputs.quality.gaps = imunoise::quality::GapPolicy::Ignore;
        inputs.quality.nonfinite = imunoise::quality::NonFinitePolicy::Interpolate;
        match pipeline::run(path, &inputs, &Work::default(), &imunoise::estimate::CpuBackend, &Silent) {
            // CSV (3) has no row count to check against; the MCAP fixture holds 4000 messages.
            Ok(r) => {
                let most = match which {
                    3 => u64::MAX,
                    4 => 4000,
                    _ => 3000,
                };
                prop_assert!(r.quality.samples_out <= most, "{} samples", r.quality.samples_out);
            }
            Err(e) => prop_assert_eq!(e.path(), path.as_path()),
        }
    }
}

// ---------------------------------------------------------------------------------------------------
// The readers' contract, case by case: every damaged or odd input gives the right samples or an error
// naming the file (and the column and row where they mean something); never a panic, never a wrong
// number.

/// The four formats with a writer for each.
const FORMATS: [&str; 4] = ["arrow", "arrows", "parquet", "csv"];

/// Cases for the heavier properties below (each writes and reads files of a few thousand rows);
/// `PROPTEST_CASES=N` raises every property's count.
fn few_cases() -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(32)
}

/// CSV text of a batch of `Float64` columns: units in the header, full-precision values (`NaN`,
/// `inf` for non-finite ones, an empty cell for a null).
fn csv_text(b: &RecordBatch) -> String {
    use arrow_array::cast::AsArray;
    let schema = b.schema();
    let header: Vec<String> = schema
        .fields()
        .iter()
        .map(|f| match f.metadata().get("unit") {
            Some(u) => format!("{} [{u}]", f.name()),
            None => f.name().clone(),
        })
        .collect();
    let mut s = header.join(",");
    s.push('\n');
    for r in 0..b.num_rows() {
        let row: Vec<String> = b
            .columns()
            .iter()
            .map(|c| {
                let a = c.as_primitive::<arrow_array::types::Float64Type>();
                if a.is_null(r) {
                    String::new()
                } else {
                    format!("{:?}", a.value(r))
                }
            })
            .collect();
        s.push_str(&row.join(","));
        s.push('\n');
    }
    s
}

/// Writes `b` in `format` (`rows` rows per batch or row group) and returns the path.
fn write_as(dir: &Path, name: &str, format: &str, b: &RecordBatch, rows: usize) -> PathBuf {
    let path = dir.join(format!("{name}.{format}"));
    match format {
        "arrow" => write_ipc_file(&path, b, rows.max(1)),
        "arrows" => write_ipc_stream(&path, b, rows.max(1)),
        "parquet" => write_parquet(&path, b, rows.max(1)),
        _ => std::fs::write(&path, csv_text(b)).unwrap(),
    }
    path
}

/// Every sample of every channel as read (raw: no quality stage), with the channel names.
fn read_raw(path: &Path, open: &OpenOptions) -> Result<(Vec<String>, Vec<Vec<f64>>), InputError> {
    let rec = io::open(path, open)?;
    let mut out = vec![Vec::new(); rec.channels.len()];
    for block in rec.blocks()? {
        for (o, c) in out.iter_mut().zip(block?.channels) {
            o.extend(c);
        }
    }
    Ok((rec.channel_names(), out))
}

/// The samples after the quality stage under `policy`.
fn read_clean(
    path: &Path,
    open: &OpenOptions,
    policy: NonFinitePolicy,
) -> Result<Vec<Vec<f64>>, InputError> {
    let rec = io::open(path, open)?;
    let options = QualityOptions {
        nonfinite: policy,
        gaps: GapPolicy::Ignore,
        ..Default::default()
    };
    let mut cleaner = imunoise::quality::Cleaner::new(&rec, options);
    let mut out = vec![Vec::new(); rec.channels.len()];
    for block in rec.blocks()? {
        for (o, c) in out.iter_mut().zip(cleaner.push(block?)?.channels) {
            o.extend(c);
        }
    }
    let (last, _) = cleaner.finish()?;
    for (o, c) in out.iter_mut().zip(last.channels) {
        o.extend(c);
    }
    Ok(out)
}

fn open_at(rate_hz: f64, batch_rows: usize) -> OpenOptions {
    OpenOptions {
        rate_hz: Some(rate_hz),
        batch_rows,
        ..Default::default()
    }
}

/// Two channels of white noise, `n` rows, rate in the metadata.
fn noise_batch(n: usize, seed: u64) -> RecordBatch {
    batch(
        &[
            f64_col("g", noise(n, seed), Some("rad/s")),
            f64_col("a", noise(n, seed + 1), Some("m/s^2")),
        ],
        Some(100.0),
    )
}

/// The byte offsets at which an Arrow IPC file or stream's messages end (schema, each batch), found
/// by writing it to memory.
fn ipc_boundaries(b: &RecordBatch, rows: usize, stream: bool) -> Vec<usize> {
    let mut ends = Vec::new();
    let slices: Vec<RecordBatch> = (0..b.num_rows())
        .step_by(rows.max(1))
        .map(|s| b.slice(s, rows.max(1).min(b.num_rows() - s)))
        .collect();
    if stream {
        let mut w = arrow_ipc::writer::StreamWriter::try_new(Vec::new(), &b.schema()).unwrap();
        ends.push(w.get_ref().len());
        for s in &slices {
            w.write(s).unwrap();
            ends.push(w.get_ref().len());
        }
    } else {
        let mut w = arrow_ipc::writer::FileWriter::try_new(Vec::new(), &b.schema()).unwrap();
        ends.push(w.get_ref().len());
        for s in &slices {
            w.write(s).unwrap();
            ends.push(w.get_ref().len());
        }
    }
    ends
}

/// Lengths to cut a file of `len` bytes at, one of each class: nothing, inside the leading magic,
/// every byte of the first and last 24, each message boundary and its neighbours, and a stride
/// through the rest.
fn cut_lengths(len: usize, boundaries: &[usize]) -> Vec<usize> {
    let mut cuts: Vec<usize> = (0..len.min(24)).collect();
    cuts.extend(len.saturating_sub(24)..len);
    for &b in boundaries {
        cuts.extend([b.saturating_sub(1), b, b + 1]);
    }
    cuts.extend((0..len).step_by((len / 61).max(1)));
    cuts.retain(|&c| c < len);
    cuts.sort_unstable();
    cuts.dedup();
    cuts
}

/// A truncated binary file is an error naming the file, at every length; a truncated CSV file (it
/// has no end marker) reads the rows it still holds, all but the last exactly (the last may be cut
/// inside a value) or is an error naming the file.
#[test]
fn truncated_files_are_errors_at_every_length() {
    let dir = tempfile::tempdir().unwrap();
    let n = 1200;
    let rows = 250;
    let b = noise_batch(n, 11);
    let (g, a) = (noise(n, 11), noise(n, 12));
    for format in FORMATS {
        let path = write_as(dir.path(), "full", format, &b, rows);
        let bytes = std::fs::read(&path).unwrap();
        let boundaries = match format {
            "arrow" => ipc_boundaries(&b, rows, false),
            "arrows" => ipc_boundaries(&b, rows, true),
            "csv" => bytes
                .iter()
                .enumerate()
                .filter(|(_, &c)| c == b'\n')
                .map(|(i, _)| i + 1)
                .step_by(97)
                .collect(),
            _ => Vec::new(),
        };
        let cut_path = dir.path().join(format!("cut.{format}"));
        for keep in cut_lengths(bytes.len(), &boundaries) {
            std::fs::write(&cut_path, &bytes[..keep]).unwrap();
            match read_raw(&cut_path, &open_at(100.0, 100)) {
                Err(e) => assert_eq!(e.path(), cut_path.as_path(), "{format} cut at {keep}: {e}"),
                Ok((names, data)) => {
                    assert_eq!(
                        format,
                        "csv",
                        "a {format} file cut at {keep} of {} read as whole",
                        bytes.len()
                    );
                    for (name, values) in names.iter().zip(&data) {
                        let truth = if name == "g" { &g } else { &a };
                        assert!(values.len() <= n, "csv cut at {keep}");
                        for (i, v) in values
                            .iter()
                            .enumerate()
                            .take(values.len().saturating_sub(1))
                        {
                            assert_eq!(*v, truth[i], "csv cut at {keep}: {name} row {i}");
                        }
                    }
                }
            }
        }
    }
}

/// A column of text: without a unit it is a label, not a channel, and `--channels` naming it is
/// an error naming the column; with a unit (metadata, a CSV header's `[unit]`) it says it is a
/// measurement, and reading it is an error naming it (it had been left out silently), in every
/// format.
#[test]
fn a_text_column_is_no_channel_and_naming_it_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let n = 300;
    let labels: Vec<String> = (0..n).map(|i| format!("s{i}")).collect();
    for labelled in [false, true] {
        let meta = if labelled {
            vec![("unit", "deg/s".into())]
        } else {
            vec![]
        };
        let b = batch(
            &[
                Col {
                    name: "g".into(),
                    array: Arc::new(arrow_array::StringArray::from(labels.clone())),
                    meta,
                },
                f64_col("a", noise(n, 1), Some("g")),
            ],
            Some(100.0),
        );
        for format in FORMATS {
            let path = if format == "csv" {
                let p = dir.path().join("text.csv");
                let g = if labelled { "g [deg/s]" } else { "g" };
                let mut s = format!("{g},a [g]\n");
                for (i, l) in labels.iter().enumerate() {
                    s.push_str(&format!("{l},{:?}\n", noise(n, 1)[i]));
                }
                std::fs::write(&p, s).unwrap();
                p
            } else {
                write_as(dir.path(), "text", format, &b, 100)
            };
            if labelled {
                let e = read_raw(&path, &open_at(100.0, 64)).unwrap_err();
                assert_eq!(
                    (e.path(), e.column()),
                    (path.as_path(), Some("g")),
                    "{format}"
                );
            } else {
                let (names, _) = read_raw(&path, &open_at(100.0, 64)).unwrap();
                assert_eq!(names, vec!["a".to_string()], "{format}");
            }
            let mut open = open_at(100.0, 64);
            open.columns.channels = vec!["g".into()];
            let e = read_raw(&path, &open).unwrap_err();
            if !labelled || format != "csv" {
                assert!(
                    matches!(e, InputError::UnsupportedType { .. }),
                    "{format}: {e}"
                );
            }
            assert_eq!((e.path(), e.column()), (path.as_path(), Some("g")));
        }
    }
}

/// An Arrow IPC stream whose channel changes type half-way (a second schema message, as when two
/// streams are concatenated) is an error at the row where the second part starts.
#[test]
fn a_stream_whose_column_changes_type_is_an_error_at_that_row() {
    let dir = tempfile::tempdir().unwrap();
    let first = batch(&[f64_col("g", noise(500, 1), Some("rad/s"))], Some(100.0));
    let second = batch(
        &[Col {
            name: "g".into(),
            array: Arc::new(arrow_array::StringArray::from(vec!["x"; 300])),
            meta: vec![],
        }],
        Some(100.0),
    );
    let a = dir.path().join("a.arrows");
    let b = dir.path().join("b.arrows");
    write_ipc_stream(&a, &first, 200);
    write_ipc_stream(&b, &second, 200);
    let mut bytes = std::fs::read(&a).unwrap();
    bytes.truncate(bytes.len() - 8); // without the first stream's end-of-stream marker
    bytes.extend(std::fs::read(&b).unwrap());
    let path = dir.path().join("joined.arrows");
    std::fs::write(&path, bytes).unwrap();
    let e = read_raw(&path, &OpenOptions::default()).unwrap_err();
    assert!(matches!(e, InputError::Corrupt { .. }), "{e}");
    assert_eq!((e.path(), e.row()), (path.as_path(), Some(500)), "{e}");
}

/// A file with no rows: an empty file is an error saying so; a header or schema without rows reads
/// as zero samples (or an error naming the file), never a panic.
#[test]
fn files_without_rows_read_as_nothing_or_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let empty_batch = noise_batch(0, 1);
    for format in FORMATS {
        let empty = dir.path().join(format!("empty.{format}"));
        std::fs::write(&empty, b"").unwrap();
        let e = read_raw(&empty, &open_at(100.0, 10)).unwrap_err();
        assert!(matches!(e, InputError::Empty { .. }), "{format}: {e}");

        let path = write_as(dir.path(), "zero", format, &empty_batch, 10);
        match read_raw(&path, &open_at(100.0, 10)) {
            Ok((names, data)) => {
                assert_eq!(names, vec!["g".to_string(), "a".to_string()], "{format}");
                assert!(data.iter().all(Vec::is_empty), "{format}");
            }
            Err(e) => assert_eq!(e.path(), path.as_path(), "{format}: {e}"),
        }
    }
    // A schema followed by empty batches between full ones.
    let b = noise_batch(10, 3);
    let path = dir.path().join("holes.arrow");
    let f = std::fs::File::create(&path).unwrap();
    let mut w = arrow_ipc::writer::FileWriter::try_new(f, &b.schema()).unwrap();
    for s in [
        b.slice(0, 0),
        b.slice(0, 4),
        b.slice(4, 0),
        b.slice(4, 6),
        b.slice(10, 0),
    ] {
        w.write(&s).unwrap();
    }
    w.finish().unwrap();
    let (_, data) = read_raw(&path, &OpenOptions::default()).unwrap();
    assert_eq!(data[0], noise(10, 3));
    // Comments only, and comments before a header without rows.
    let p = dir.path().join("comments.csv");
    std::fs::write(&p, "# nothing\n# here\n").unwrap();
    let e = read_raw(&p, &open_at(100.0, 10)).unwrap_err();
    assert!(e.to_string().contains("no header line"), "{e}");
    std::fs::write(&p, "# a\ng [rad/s],a\n# b\n").unwrap();
    let (names, data) = read_raw(&p, &open_at(100.0, 10)).unwrap();
    assert_eq!((names.len(), data[0].len()), (2, 0));
}

proptest! {
    #![proptest_config(ProptestConfig { cases: few_cases(), failure_persistence: None, .. ProptestConfig::default() })]

    /// A channel column that changes from numbers to something else, anywhere in a CSV file (inside
    /// the rows the types are judged on or far beyond, in any batch), is an error naming the file, the
    /// column, the row and the line, even with comment lines, quoted line breaks and CRLF endings
    /// before it. (At least 20 rows: one text cell among fewer than ten values would make the column
    /// text by the 90 % rule.)
    #[test]
    fn a_csv_channel_that_turns_to_text_names_row_and_line(
        n in 20usize..4000,
        bad in 0.0f64..1.0,
        token in prop::sample::select(vec!["abc", "1.2.3", "0x1F", "--", "\"1,5\"", "\"ab\"\"c\"", "1e", "+-1", "TRUE"]),
        batch_rows in prop::sample::select(vec![1usize, 7, 100, 1000, 65_536]),
        comments in prop::collection::vec(0.0f64..1.0, 0..4),
        breaks in prop::collection::vec(0.0f64..1.0, 0..4),
        crlf in any::<bool>(),
        unit in any::<bool>(),
    ) {
        let bad = ((n - 1) as f64 * bad) as usize;
        let at = |v: &[f64]| v.iter().map(|f| ((n - 1) as f64 * f) as usize).collect::<Vec<_>>();
        let (comments, breaks) = (at(&comments), at(&breaks));
        let eol = if crlf { "\r\n" } else { "\n" };
        let mut text = format!("# logger preamble{eol}");
        text.push_str(if unit { "label,gyro_x [deg/s],t" } else { "label,gyro_x,t" });
        text.push_str(eol);
        let mut line = 3u64; // the next record's line
        let mut bad_line = 0;
        for i in 0..n {
            for _ in comments.iter().filter(|&&c| c == i) {
                text.push_str(&format!("# comment{eol}"));
                line += 1;
            }
            if i == bad {
                bad_line = line;
            }
            let splits = breaks.iter().filter(|&&b| b == i).count();
            let label = if splits > 0 {
                format!("\"a{}b\"", "\n".repeat(splits))
            } else {
                format!("l{i}")
            };
            let x = if i == bad { token.to_string() } else { format!("{}", i % 17) };
            text.push_str(&format!("{label},{x},{}{eol}", i as f64 * 0.01));
            line += 1 + splits as u64;
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("turns.csv");
        std::fs::write(&path, &text).unwrap();
        let e = read_raw(&path, &open_at(100.0, batch_rows)).unwrap_err();
        prop_assert!(matches!(e, InputError::BadValue { .. }), "{}", e);
        prop_assert_eq!(e.path(), path.as_path());
        prop_assert_eq!((e.column(), e.row()), (Some("gyro_x"), Some(bad as u64)), "{}", e);
        let expected_line = format!("row {bad} (line {bad_line} of the file)");
        prop_assert!(e.to_string().contains(&expected_line), "{} (wanted {})", e, expected_line);
    }

    /// NaN and ±Inf (and empty cells in CSV, nulls in the typed formats) come out as non-finite
    /// samples; the quality stage's default policy stops naming their column and row, and
    /// interpolation keeps every other sample as written.
    #[test]
    fn non_finite_values_are_reported_with_their_row(
        format in prop::sample::select(FORMATS.to_vec()),
        n in 3usize..3000,
        at in 0.0f64..1.0,
        kind in 0usize..4,
        batch_rows in prop::sample::select(vec![1usize, 64, 1000, 65_536]),
    ) {
        let row = ((n - 1) as f64 * at) as usize;
        let g = noise(n, 5);
        let mut values: Vec<Option<f64>> = g.iter().copied().map(Some).collect();
        values[row] = [Some(f64::NAN), Some(f64::INFINITY), Some(f64::NEG_INFINITY), None][kind];
        let b = batch(
            &[
                Col {
                    name: "g".into(),
                    array: Arc::new(arrow_array::Float64Array::from(values)),
                    meta: vec![("unit", "rad/s".into())],
                },
                f64_col("a", noise(n, 6), Some("g")),
            ],
            Some(100.0),
        );
        let dir = tempfile::tempdir().unwrap();
        let path = write_as(dir.path(), "nf", format, &b, batch_rows.min(700));
        let open = open_at(100.0, batch_rows);
        let e = read_clean(&path, &open, NonFinitePolicy::Error).unwrap_err();
        prop_assert!(matches!(e, InputError::NonFinite { .. }), "{}", e);
        prop_assert_eq!((e.path(), e.column(), e.row()), (path.as_path(), Some("g"), Some(row as u64)));
        let data = read_clean(&path, &open, NonFinitePolicy::Interpolate).unwrap();
        prop_assert_eq!(data[0].len(), n);
        for i in (0..n).filter(|&i| i != row) {
            prop_assert_eq!(data[0][i], g[i]);
        }
    }

    /// Non-UTF-8 bytes in a CSV data cell are an error naming the row, the line and the column; in
    /// the header, an error naming line 1; in a comment, nothing (comments are skipped).
    #[test]
    fn non_utf8_csv_bytes_name_their_place(
        n in 1usize..3000,
        at in 0.0f64..1.0,
        column in 0usize..3,
        junk in prop::sample::select(vec![&b"\xff"[..], b"\xc3", b"\xe2\x82", b"\xb0C", b"\xed\xa0\x80"]),
        place in 0usize..3,
    ) {
        let row = ((n - 1) as f64 * at) as usize;
        let names = ["label", "g [rad/s]", "a [g]"];
        let mut bytes = Vec::new();
        bytes.extend_from_slice(b"# preamble");
        if place == 2 {
            bytes.extend_from_slice(junk);
        }
        bytes.push(b'\n');
        for (c, name) in names.iter().enumerate() {
            if c > 0 {
                bytes.push(b',');
            }
            bytes.extend_from_slice(name.as_bytes());
            if place == 1 && c == column {
                bytes.extend_from_slice(junk);
            }
        }
        bytes.push(b'\n');
        for i in 0..n {
            let cells = [format!("l{i}"), format!("{i}"), "1".to_string()];
            for (c, cell) in cells.iter().enumerate() {
                if c > 0 {
                    bytes.push(b',');
                }
                bytes.extend_from_slice(cell.as_bytes());
                if place == 0 && i == row && c == column {
                    bytes.extend_from_slice(junk);
                }
            }
            bytes.push(b'\n');
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("latin1.csv");
        std::fs::write(&path, &bytes).unwrap();
        let result = read_raw(&path, &open_at(100.0, 500));
        match place {
            0 => {
                let e = result.unwrap_err();
                prop_assert!(matches!(e, InputError::MalformedCsv { .. }), "{}", e);
                prop_assert_eq!((e.path(), e.row()), (path.as_path(), Some(row as u64)));
                let column_name = ["label", "g", "a"][column];
                let expected = format!(
                    "row {row} (line {} of the file): column {column_name:?} holds bytes that are not UTF-8",
                    row + 3
                );
                prop_assert!(e.to_string().contains(&expected), "{} (wanted {})", e, expected);
            }
            1 => {
                let e = result.unwrap_err();
                prop_assert_eq!(e.path(), path.as_path());
                prop_assert!(e.to_string().contains("at line 2: the header's column"), "{}", e);
            }
            _ => {
                let (_, data) = result.unwrap();
                prop_assert_eq!(data[0].len(), n);
                prop_assert_eq!(data[0][row], row as f64);
            }
        }
    }

    /// Very long lines (a huge text cell, a number padded with thousands of zeros) and many columns
    /// read right.
    #[test]
    fn huge_rows_and_many_columns_read_right(
        format in prop::sample::select(FORMATS.to_vec()),
        columns in 1usize..1500,
        pick in 0.0f64..1.0,
        cell_len in 1usize..300_000,
        zeros in 1usize..5000,
    ) {
        let dir = tempfile::tempdir().unwrap();
        let n = 20;
        let cols: Vec<Col> = (0..columns)
            .map(|c| f64_col(&format!("c{c}"), noise(n, c as u64), Some("rad/s")))
            .collect();
        let path = write_as(dir.path(), "wide", format, &batch(&cols, Some(100.0)), 7);
        let (names, data) = read_raw(&path, &open_at(100.0, 8)).unwrap();
        prop_assert_eq!(names.len(), columns);
        let c = ((columns - 1) as f64 * pick) as usize;
        prop_assert_eq!(&data[c], &noise(n, c as u64));

        let path = dir.path().join("long.csv");
        let mut text = String::from("note,g [rad/s]\n");
        for i in 0..n {
            if i == n / 2 {
                text.push_str(&format!("\"{}\",{}1.5\n", "x,".repeat(cell_len / 2), "0".repeat(zeros)));
            } else {
                text.push_str(&format!("short,{i}\n"));
            }
        }
        std::fs::write(&path, text).unwrap();
        let (names, data) = read_raw(&path, &open_at(100.0, 4)).unwrap();
        prop_assert_eq!(names, vec!["g".to_string()]);
        prop_assert_eq!(data[0][n / 2], 1.5);
        prop_assert_eq!(data[0][n - 1], (n - 1) as f64);
    }

    /// Two columns of one name are an error naming it, in every format (for CSV, also when the two
    /// differ only by their unit); which of them to analyse is never guessed.
    #[test]
    fn duplicate_column_names_are_errors_naming_them(
        format in prop::sample::select(FORMATS.to_vec()),
        columns in 2usize..8,
        first in 0.0f64..1.0,
        gap in 0.0f64..1.0,
    ) {
        let i = ((columns - 2) as f64 * first) as usize;
        let j = i + 1 + ((columns - i - 2) as f64 * gap) as usize;
        let units = ["rad/s", "deg/s", "g", "m/s^2"];
        let cols: Vec<Col> = (0..columns)
            .map(|c| {
                let name = if c == j { format!("c{i}") } else { format!("c{c}") };
                f64_col(&name, noise(30, c as u64), Some(units[c % 4]))
            })
            .collect();
        let dir = tempfile::tempdir().unwrap();
        let path = write_as(dir.path(), "dup", format, &batch(&cols, Some(100.0)), 10);
        let e = read_raw(&path, &open_at(100.0, 8)).unwrap_err();
        prop_assert!(matches!(e, InputError::DuplicateColumn { .. }), "{}", e);
        let name = format!("c{i}");
        prop_assert_eq!((e.path(), e.column()), (path.as_path(), Some(name.as_str())));
        let expected = format!("columns {} and {}", i + 1, j + 1);
        prop_assert!(e.to_string().contains(&expected), "{}", e);
    }
}
