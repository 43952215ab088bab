//! Ingest and quality: every format reads the same samples, and every kind of bad input is a clear
//! error naming file, column and row (never a panic).

use std::path::Path;
use std::sync::Arc;

use arrow_array::{ArrayRef, Int16Array, StringArray};
use imunoise::io::{self, InputError, OpenOptions};
use imunoise::pipeline::{self, Inputs, Silent, Work};
use imunoise::quality::{GapPolicy, NonFinitePolicy, QualityOptions};
use imunoise::Error;

use super::support::*;

const RATE: f64 = 100.0;

/// Reads every clean sample of a file (info pass + collecting through the AV path's series).
fn read_all(
    path: &Path,
    inputs: &Inputs,
) -> Result<(Vec<Vec<f64>>, imunoise::quality::QualityReport), Error> {
    let rec = io::open(path, &inputs.open)?;
    let mut cleaner = imunoise::quality::Cleaner::new(&rec, inputs.quality);
    let mut out = vec![Vec::new(); rec.channels.len()];
    for block in rec.blocks()? {
        let chunk = cleaner.push(block?)?;
        for (o, c) in out.iter_mut().zip(chunk.channels) {
            o.extend(c);
        }
    }
    let (last, report) = cleaner.finish()?;
    for (o, c) in out.iter_mut().zip(last.channels) {
        o.extend(c);
    }
    Ok((out, report))
}

fn two_channels(n: usize) -> (Vec<f64>, Vec<f64>) {
    (
        noise(n, 1),
        noise(n, 2).iter().map(|x| 9.8 + 0.01 * x).collect(),
    )
}

fn recording(dir: &Path, name: &str, cols: Vec<Col>, rate: Option<f64>) -> std::path::PathBuf {
    let path = dir.join(name);
    write_ipc_file(&path, &batch(&cols, rate), 1000);
    path
}

fn err_of(path: &Path, inputs: &Inputs) -> Error {
    read_all(path, inputs).expect_err("expected an error")
}

#[test]
fn every_format_reads_the_same_samples_in_si_units() {
    let dir = tempfile::tempdir().unwrap();
    let n = 5003;
    let (g, a) = two_channels(n);
    let cols = || {
        vec![
            f64_col("gyro", g.clone(), Some("deg/s")),
            f64_col("accel", a.clone(), Some("g")),
        ]
    };
    let b = batch(&cols(), Some(RATE));
    write_ipc_file(&dir.path().join("r.arrow"), &b, 777);
    write_ipc_stream(&dir.path().join("r.arrows"), &b, 1000);
    write_parquet(&dir.path().join("r.parquet"), &b, 600);
    // Every codec a Parquet writer commonly uses (gzip is pandas' second choice, Spark's older
    // default; a build without it had called such files corrupt).
    use parquet::basic::{BrotliLevel, Compression, GzipLevel, ZstdLevel};
    let codecs = [
        ("r_snappy.parquet", Compression::SNAPPY),
        ("r_gzip.parquet", Compression::GZIP(GzipLevel::default())),
        (
            "r_brotli.parquet",
            Compression::BROTLI(BrotliLevel::default()),
        ),
        ("r_zstd.parquet", Compression::ZSTD(ZstdLevel::default())),
        ("r_lz4.parquet", Compression::LZ4_RAW),
    ];
    for (name, codec) in codecs {
        write_parquet_compressed(&dir.path().join(name), &b, 600, codec);
    }
    write_csv(
        &dir.path().join("r.csv"),
        &[("gyro", Some("deg/s")), ("accel", Some("g"))],
        &[g.clone(), a.clone()],
    );
    let deg = std::f64::consts::PI / 180.0;
    let names = ["r.arrow", "r.arrows", "r.parquet", "r.csv"]
        .into_iter()
        .chain(codecs.iter().map(|(name, _)| *name));
    for name in names {
        let mut inputs = Inputs::default();
        inputs.open.batch_rows = 512;
        if name.ends_with("csv") {
            inputs.open.rate_hz = Some(RATE);
        }
        let (data, report) = read_all(&dir.path().join(name), &inputs).unwrap();
        assert_eq!(report.samples_out, n as u64, "{name}");
        for i in 0..n {
            assert_eq!(data[0][i], g[i] * deg, "{name} gyro row {i}");
            assert_eq!(data[1][i], a[i] * 9.80665, "{name} accel row {i}");
        }
    }
}

/// Half floats, decimals and dictionaries of floats are read as numbers; a column that says it is
/// a measurement (unit or kind metadata, a CSV header's unit) but holds text is an error naming
/// it. Defect: both had been left out silently (exit 0, channels missing from the report).
#[test]
fn every_numeric_type_is_read_and_a_labelled_text_column_is_an_error() {
    use arrow_array::{DictionaryArray, Float64Array, Int8Array};
    use arrow_schema::DataType;
    let dir = tempfile::tempdir().unwrap();
    let n = 2000;
    // Values a half float and a 4-digit decimal hold exactly.
    let v: Vec<f64> = (0..n)
        .map(|i| ((i * 37) % 64) as f64 / 16.0 - 2.0)
        .collect();
    let f64s = Arc::new(Float64Array::from(v.clone())) as ArrayRef;
    let cast = |t: DataType| arrow_cast::cast(&f64s, &t).unwrap();
    let keys = Int8Array::from_iter_values(v.iter().map(|x| ((x + 2.0) * 16.0) as i8));
    let dict_values = Float64Array::from_iter_values((0..64).map(|k| k as f64 / 16.0 - 2.0));
    let dict = Arc::new(DictionaryArray::new(keys, Arc::new(dict_values))) as ArrayRef;
    let col = |name: &str, array: ArrayRef| Col {
        name: name.into(),
        array,
        meta: vec![("unit", "deg/s".into())],
    };
    let mut cols = vec![
        col("gyro_x", cast(DataType::Float16)),
        col("gyro_y", cast(DataType::Decimal128(12, 4))),
        col("gyro_z", dict),
    ];
    let path = dir.path().join("types.arrow");
    write_ipc_file(&path, &batch(&cols, Some(RATE)), 512);
    let (data, report) = read_all(&path, &Inputs::default()).unwrap();
    assert_eq!(report.samples_out, n as u64);
    let deg = std::f64::consts::PI / 180.0;
    for (c, column) in data.iter().enumerate() {
        assert_eq!(data.len(), 3);
        for i in 0..n {
            assert_eq!(column[i], v[i] * deg, "channel {c} row {i}");
        }
    }

    cols.push(col(
        "accel_x",
        Arc::new(StringArray::from_iter_values((0..n).map(|_| "N/A"))) as ArrayRef,
    ));
    write_ipc_file(&path, &batch(&cols, Some(RATE)), 512);
    let e = err_of(&path, &Inputs::default());
    assert_eq!(e.column(), Some("accel_x"), "{e}");
    assert!(e.to_string().contains("--channels"), "{e}");

    // A dead axis in a CSV export: a header with a unit over text throughout.
    let csv = dir.path().join("dead.csv");
    write_csv_text(
        &csv,
        "gyro_x [deg/s],gyro_y [deg/s]",
        (0..n).map(|i| format!("{},N/A", v[i])),
    );
    let e = err_of(&csv, &csv_inputs(65_536));
    assert_eq!((e.column(), e.row()), (Some("gyro_y"), Some(0)), "{e}");
    assert!(e.to_string().contains("\"N/A\""), "{e}");
}

#[test]
fn integer_columns_are_scaled_and_projection_keeps_the_order_asked() {
    let dir = tempfile::tempdir().unwrap();
    let raw: Vec<i16> = (0..1000).map(|i| (i % 200 - 100) as i16).collect();
    let cols = vec![
        Col {
            name: "counts".into(),
            array: Arc::new(Int16Array::from(raw.clone())) as ArrayRef,
            meta: vec![("unit", "mg".into()), ("scale", "0.5".into())],
        },
        f64_col("other", noise(1000, 3), None),
    ];
    let path = recording(dir.path(), "int.arrow", cols, Some(RATE));
    let ab = batch(
        &[
            f64_col("a", vec![1.0; 10], None),
            f64_col("b", vec![2.0; 10], None),
        ],
        Some(RATE),
    );
    write_parquet(&dir.path().join("r.parquet"), &ab, 4);
    let mut inputs = Inputs::default();
    inputs.open.columns.channels = vec!["other".into(), "counts".into()];
    let (data, _) = read_all(&path, &inputs).unwrap();
    for (i, r) in raw.iter().enumerate() {
        assert_eq!(data[1][i], *r as f64 * 0.5 * 9.80665e-3);
    }
    // Parquet returns projected columns in file order; the reader must restore the order asked for.
    inputs.open.columns.channels = vec!["b".into(), "a".into()];
    let (data, _) = read_all(&dir.path().join("r.parquet"), &inputs).unwrap();
    assert_eq!((data[0][0], data[1][0]), (2.0, 1.0));
}

#[test]
fn missing_and_empty_files_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nope.arrow");
    let e = err_of(&missing, &Inputs::default());
    assert!(
        matches!(e, Error::Input(InputError::NotFound { .. })),
        "{e}"
    );
    assert!(e.to_string().contains("nope.arrow"));
    let empty = dir.path().join("empty.parquet");
    std::fs::write(&empty, b"").unwrap();
    let e = err_of(&empty, &Inputs::default());
    assert!(matches!(e, Error::Input(InputError::Empty { .. })), "{e}");
    assert!(e.to_string().contains("empty.parquet") && e.to_string().contains("empty"));
}

#[test]
fn no_numeric_column_and_unknown_column_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let cols = vec![Col {
        name: "label".into(),
        array: Arc::new(StringArray::from(vec!["a", "b"])) as ArrayRef,
        meta: vec![],
    }];
    let path = recording(dir.path(), "text.arrow", cols, Some(RATE));
    let e = err_of(&path, &Inputs::default());
    assert!(
        matches!(e, Error::Input(InputError::NoNumericColumn { .. })),
        "{e}"
    );
    assert!(e.to_string().contains("label"));

    let path = recording(
        dir.path(),
        "ok.arrow",
        vec![f64_col("gx", noise(10, 1), None)],
        Some(RATE),
    );
    let mut inputs = Inputs::default();
    inputs.open.columns.channels = vec!["gy".into()];
    let e = err_of(&path, &inputs);
    assert!(
        matches!(e, Error::Input(InputError::UnknownColumn { .. })),
        "{e}"
    );
    assert_eq!(e.column(), Some("gy"));
    assert!(
        e.to_string().contains("gx"),
        "lists the available columns: {e}"
    );
}

#[test]
fn unknown_unit_names_column_and_unit() {
    let dir = tempfile::tempdir().unwrap();
    let path = recording(
        dir.path(),
        "u.arrow",
        vec![f64_col("gx", noise(10, 1), Some("deg/fortnight"))],
        Some(RATE),
    );
    let e = err_of(&path, &Inputs::default());
    assert_eq!(e.column(), Some("gx"));
    assert!(
        e.to_string().contains("deg/fortnight") && e.to_string().contains("u.arrow"),
        "{e}"
    );
}

#[test]
fn non_finite_samples_error_with_row_or_follow_the_policy() {
    let dir = tempfile::tempdir().unwrap();
    let n = 3000;
    let (mut g, a) = two_channels(n);
    g[1234] = f64::NAN;
    g[2500] = f64::INFINITY;
    g[2501] = f64::NAN;
    let path = recording(
        dir.path(),
        "nan.arrow",
        vec![f64_col("gyro", g.clone(), None), f64_col("accel", a, None)],
        Some(RATE),
    );
    let e = err_of(&path, &Inputs::default());
    assert!(
        matches!(e, Error::Input(InputError::NonFinite { .. })),
        "{e}"
    );
    assert_eq!((e.column(), e.row()), (Some("gyro"), Some(1234)));
    assert!(e.to_string().contains("nan.arrow"));

    let mut inputs = Inputs {
        quality: QualityOptions {
            nonfinite: NonFinitePolicy::Drop,
            gaps: GapPolicy::Error,
            ..Default::default()
        },
        ..Default::default()
    };
    let (data, report) = read_all(&path, &inputs).unwrap();
    assert_eq!(report.dropped_rows, 3);
    assert_eq!(data[0].len(), n - 3);
    assert_eq!(data[1].len(), n - 3);
    assert_eq!(data[0][1234], g[1235]);

    inputs.quality.nonfinite = NonFinitePolicy::Interpolate;
    inputs.open.batch_rows = 100; // the pair 2500-2501 straddles no batch edge, 1234 is mid-batch
    let (data, report) = read_all(&path, &inputs).unwrap();
    assert_eq!(data[0].len(), n);
    assert_eq!(report.channels[0].interpolated_samples, 3);
    assert_eq!(report.channels[0].first_nonfinite_row, Some(1234));
    assert!((data[0][1234] - 0.5 * (g[1233] + g[1235])).abs() < 1e-15);
    let third = (g[2502] - g[2499]) / 3.0;
    assert!((data[0][2500] - (g[2499] + third)).abs() < 1e-14);
    assert!((data[0][2501] - (g[2499] + 2.0 * third)).abs() < 1e-14);
}

#[test]
fn interpolation_across_batch_boundaries_and_at_the_ends() {
    let dir = tempfile::tempdir().unwrap();
    let mut g: Vec<f64> = (0..1000).map(|i| i as f64).collect();
    for i in [0, 1, 99, 100, 101, 998, 999] {
        g[i] = f64::NAN;
    }
    let path = dir.path().join("edge.arrow");
    write_ipc_file(&path, &batch(&[f64_col("g", g, None)], Some(RATE)), 100);
    let mut inputs = Inputs::default();
    inputs.quality.nonfinite = NonFinitePolicy::Interpolate;
    let (data, _) = read_all(&path, &inputs).unwrap();
    assert_eq!(data[0][0], 2.0, "held at the start");
    assert_eq!(data[0][1], 2.0);
    assert_eq!(data[0][100], 100.0, "line across the batch edge");
    assert_eq!(data[0][999], 997.0, "held at the end");
}

#[test]
fn time_column_problems_name_the_row() {
    let dir = tempfile::tempdir().unwrap();
    let n = 2000;
    let g = noise(n, 7);
    let step = 10_000_000i64; // 10 ms in ns
    type Edit = Box<dyn Fn(usize, i64) -> i64>;
    let cases: Vec<(&str, Edit, u64)> = vec![
        (
            "dup.arrow",
            Box::new(move |i, t| if i == 700 { t - step } else { t }),
            700,
        ),
        (
            "back.arrow",
            Box::new(move |i, t| if i == 900 { t - 5 * step } else { t }),
            900,
        ),
    ];
    for (name, edit, row) in cases {
        let path = recording(
            dir.path(),
            name,
            vec![time_col(n, RATE, edit), f64_col("g", g.clone(), None)],
            None,
        );
        let e = err_of(&path, &Inputs::default());
        assert_eq!(
            (e.column(), e.row()),
            (Some("time"), Some(row)),
            "{name}: {e}"
        );
        let expected = if name == "dup.arrow" {
            "repeats"
        } else {
            "goes back"
        };
        assert!(e.to_string().contains(expected), "{e}");
    }
}

/// Hundreds of one-sample drops, then a 5-s gap: the report lists the first gaps, and the
/// stretches the residual loop must not read as bias steps hold the long one wherever it falls.
#[test]
fn the_longest_gaps_are_guarded_beyond_the_listed_ones() {
    let dir = tempfile::tempdir().unwrap();
    let n = 20_000;
    let step = 10_000_000i64;
    // One sample missing after every 50th row up to row 15 000 (300 drops), then 500 missing
    // before row 18 000.
    let late = move |i: usize| -> i64 {
        let drops = (i.min(15_000) / 50) as i64;
        drops * step + if i >= 18_000 { 500 * step } else { 0 }
    };
    let path = recording(
        dir.path(),
        "drops.arrow",
        vec![
            time_col(n, RATE, move |i, t| t + late(i)),
            f64_col("g", (0..n).map(|i| i as f64).collect(), None),
        ],
        None,
    );
    let mut inputs = Inputs::default();
    inputs.quality.gaps = GapPolicy::Fill;
    let (_, report) = read_all(&path, &inputs).unwrap();
    assert_eq!(report.gap_count, 301);
    assert_eq!(report.gaps.len(), imunoise::quality::MAX_LISTED_GAPS);
    assert!(report.gaps.iter().all(|g| g.row < 18_000));
    let stretches = report.filled_stretches(RATE);
    let long = stretches
        .iter()
        .find(|(a, b)| b - a > 4.0)
        .expect("the 5-s gap is guarded");
    // The gap starts after row 17 999, which lies 17 999 periods + 300 drops in.
    assert!(
        (long.0 - (17_999.0 + 300.0) / RATE).abs() < 1e-6,
        "{long:?}"
    );
    assert!((long.1 - long.0 - 5.01).abs() < 1e-6, "{long:?}");
    // Each gap once, in the record's order.
    assert!(stretches.windows(2).all(|w| w[0].0 < w[1].0));
}

#[test]
fn gaps_are_errors_unless_ignored_or_filled() {
    let dir = tempfile::tempdir().unwrap();
    let n = 2000;
    let g: Vec<f64> = (0..n).map(|i| i as f64).collect();
    // Rows from 1500 on are 5 sample periods late: 5 samples missing before row 1500.
    let step = 10_000_000i64;
    let path = recording(
        dir.path(),
        "gap.arrow",
        vec![
            time_col(
                n,
                RATE,
                move |i, t| if i >= 1500 { t + 5 * step } else { t },
            ),
            f64_col("g", g.clone(), None),
        ],
        None,
    );
    let e = err_of(&path, &Inputs::default());
    assert!(
        matches!(e, Error::Input(InputError::Gap { missing: 5, .. })),
        "{e}"
    );
    assert_eq!(e.row(), Some(1500));
    assert!(e.to_string().contains("14.99"), "names where: {e}");

    let mut inputs = Inputs::default();
    inputs.quality.gaps = GapPolicy::Ignore;
    let (data, report) = read_all(&path, &inputs).unwrap();
    assert_eq!(data[0].len(), n);
    assert_eq!((report.gap_count, report.missing_samples), (1, 5));
    assert_eq!(report.gaps[0].row, 1500);

    inputs.quality.gaps = GapPolicy::Fill;
    let (data, report) = read_all(&path, &inputs).unwrap();
    assert_eq!(data[0].len(), n + 5);
    assert_eq!(report.filled_samples, 5);
    // Values 1499 → 1500 with five points between them.
    for k in 1..=5 {
        assert!((data[0][1499 + k] - (1499.0 + k as f64 / 6.0)).abs() < 1e-12);
    }
    assert_eq!(data[0][1505], 1500.0);
}

#[test]
fn rate_conflicts_are_errors_and_the_rate_source_is_reported() {
    let dir = tempfile::tempdir().unwrap();
    let n = 500;
    let path = recording(
        dir.path(),
        "conflict.arrow",
        vec![
            time_col(n, 200.0, |_, t| t),
            f64_col("g", noise(n, 1), None),
        ],
        Some(100.0),
    );
    let e = io::open(&path, &OpenOptions::default()).unwrap_err();
    assert!(matches!(e, InputError::RateConflict { .. }), "{e}");
    assert!(
        e.to_string().contains("100") && e.to_string().contains("200"),
        "{e}"
    );

    let path = recording(
        dir.path(),
        "meta.arrow",
        vec![f64_col("g", noise(n, 1), None)],
        Some(100.0),
    );
    let mut o = OpenOptions {
        rate_hz: Some(207.0),
        ..Default::default()
    };
    assert!(matches!(
        io::open(&path, &o).unwrap_err(),
        InputError::RateConflict { .. }
    ));
    o.rate_hz = Some(100.2);
    let r = io::open(&path, &o).unwrap();
    assert_eq!(
        (r.rate_hz, r.rate_source),
        (100.0, io::RateSource::Metadata)
    );

    let path = recording(
        dir.path(),
        "none.arrow",
        vec![f64_col("g", noise(n, 1), None)],
        None,
    );
    assert!(matches!(
        io::open(&path, &OpenOptions::default()).unwrap_err(),
        InputError::NoRate { .. }
    ));
    o.rate_hz = Some(50.0);
    assert_eq!(
        io::open(&path, &o).unwrap().rate_source,
        io::RateSource::Flag
    );

    // Timestamps jittered and rounded to 1 ms at 207 Hz still give 207 Hz.
    let path = recording(
        dir.path(),
        "jitter.arrow",
        vec![
            time_col(5000, 207.0, |i, t| {
                (t + ((i * 7919) % 13) as i64 * 10_000) / 1_000_000 * 1_000_000
            }),
            f64_col("g", noise(5000, 1), None),
        ],
        None,
    );
    let r = io::open(&path, &OpenOptions::default()).unwrap();
    assert!((r.rate_hz / 207.0 - 1.0).abs() < 1e-3, "{}", r.rate_hz);
}

fn run_err(path: &Path, work: &Work) -> Error {
    pipeline::run(
        path,
        &Inputs::default(),
        work,
        &imunoise::estimate::CpuBackend,
        &Silent,
    )
    .expect_err("expected an error")
}

#[test]
fn too_short_recordings_say_what_was_needed() {
    let dir = tempfile::tempdir().unwrap();
    let path = recording(
        dir.path(),
        "short.arrow",
        vec![f64_col("g", noise(300, 1), None)],
        Some(RATE),
    );
    let work = Work {
        welch: Some(imunoise::pipeline::WelchWork {
            plan: imunoise::psd::WelchConfig::new(1024).validate().unwrap(),
            bins_per_decade: None,
        }),
        avar: None,
        fit: None,
        residual_loop: false,
    };
    let e = run_err(&path, &work);
    assert!(
        matches!(
            e,
            Error::Input(InputError::TooShort {
                needed: 1024,
                available: 300,
                ..
            })
        ),
        "{e}"
    );
    assert!(e.to_string().contains("short.arrow") && e.to_string().contains("nperseg"));

    let work = Work {
        welch: None,
        avar: Some(imunoise::pipeline::AvarWork {
            statistics: vec![imunoise::avar::Statistic::Oadev],
            taus: imunoise::pipeline::TauSpec::Seconds(vec![0.1, 2.0]),
            confidence: imunoise::avar::Confidence::OneSigma,
        }),
        fit: None,
        residual_loop: false,
    };
    let e = run_err(&path, &work);
    assert!(
        matches!(
            e,
            Error::Input(InputError::TooShort {
                needed: 401,
                available: 300,
                ..
            })
        ),
        "{e}"
    );
    assert!(e.to_string().contains("tau = 2 s"), "{e}");
}

#[test]
fn truncated_and_corrupt_files_are_errors_not_panics() {
    let dir = tempfile::tempdir().unwrap();
    let b = batch(&[f64_col("g", noise(20_000, 1), Some("rad/s"))], Some(RATE));
    let ipc = dir.path().join("t.arrow");
    write_ipc_file(&ipc, &b, 2000);
    let stream = dir.path().join("t.arrows");
    write_ipc_stream(&stream, &b, 2000);
    let pq = dir.path().join("t.parquet");
    write_parquet(&pq, &b, 2000);
    for path in [&ipc, &stream, &pq] {
        let bytes = std::fs::read(path).unwrap();
        // Cut in the middle of the data.
        std::fs::write(path, &bytes[..bytes.len() / 2]).unwrap();
        let e = err_of(path, &Inputs::default());
        assert!(
            matches!(e, Error::Input(InputError::Corrupt { .. })),
            "{}: {e}",
            path.display()
        );
        assert!(e
            .to_string()
            .contains(path.file_name().unwrap().to_str().unwrap()));
        // Garbage in the middle of an intact-length file.
        let mut garbled = bytes.clone();
        let mid = garbled.len() / 3;
        for byte in &mut garbled[mid..mid + 64] {
            *byte ^= 0x5A;
        }
        std::fs::write(path, &garbled).unwrap();
        // May decode (flipped sample bits are valid floats) or fail; must not panic.
        let _ = read_all(path, &Inputs::default());
    }
    let stream_rows = read_truncated_stream_rows(&stream);
    assert!(stream_rows.is_none());
}

/// A truncated stream must not silently return fewer rows as if complete.
fn read_truncated_stream_rows(path: &Path) -> Option<u64> {
    let bytes = std::fs::read(path).unwrap();
    std::fs::write(path, &bytes[..bytes.len() * 2 / 3]).unwrap();
    read_all(path, &Inputs::default())
        .ok()
        .map(|(_, r)| r.samples_out)
}

/// A CSV file: `header`, then `rows` lines (each already joined), newline-terminated.
fn write_csv_text(path: &Path, header: &str, rows: impl IntoIterator<Item = String>) {
    let mut s = String::from(header);
    s.push('\n');
    for r in rows {
        s.push_str(&r);
        s.push('\n');
    }
    std::fs::write(path, s).unwrap();
}

fn csv_inputs(batch_rows: usize) -> Inputs {
    let mut inputs = Inputs::default();
    inputs.open.rate_hz = Some(RATE);
    inputs.open.batch_rows = batch_rows;
    inputs
}

/// Defect: one `abc` at row 500 of a gyro column made schema inference read the column as text, so
/// it was silently dropped (exit 0, one channel fewer). It must be an error naming file, column, row
/// and line, wherever the bad cell is (inside the rows used for inference or far beyond them).
#[test]
fn a_bad_cell_in_a_csv_channel_names_file_column_row_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("data.csv");
    let n = 3000;
    for (bad_row, batch_rows) in [(500usize, 65_536), (500, 128), (2500, 1000), (2500, 7)] {
        write_csv_text(
            &path,
            "gyro_x [deg/s],gyro_y [deg/s],label",
            (0..n).map(|i| {
                let x = if i == bad_row { "abc" } else { "0.01" };
                format!("{x},0.02,run{}", i % 3)
            }),
        );
        let e = err_of(&path, &csv_inputs(batch_rows));
        assert!(
            matches!(e, Error::Input(InputError::BadValue { .. })),
            "{e}"
        );
        assert_eq!(
            (e.column(), e.row()),
            (Some("gyro_x"), Some(bad_row as u64))
        );
        // Row 0 is on line 2 (after the header).
        assert_eq!(
            e.to_string(),
            format!(
                "{}: column \"gyro_x\", row {bad_row} (line {} of the file): \"abc\" is not a number",
                path.display(),
                bad_row + 2
            )
        );
    }

    // A column without a unit that is mostly numbers is numeric too; a text column (the label) is
    // no channel and no error.
    write_csv_text(
        &path,
        "a,label",
        (0..n).map(|i| {
            let x = if i == 10 {
                "n/a".to_string()
            } else {
                format!("{}", i)
            };
            format!("{x},lbl")
        }),
    );
    let e = err_of(&path, &csv_inputs(65_536));
    assert_eq!((e.column(), e.row()), (Some("a"), Some(10)), "{e}");
    assert!(e.to_string().contains("\"n/a\" is not a number"), "{e}");

    write_csv_text(
        &path,
        "gyro_x [deg/s],label",
        (0..n).map(|i| format!("{},lbl{i}", 0.01 * (i % 7) as f64)),
    );
    let rec = io::open(&path, &csv_inputs(65_536).open).unwrap();
    assert_eq!(rec.channel_names(), vec!["gyro_x".to_string()]);
    let (data, _) = read_all(&path, &csv_inputs(100)).unwrap();
    let deg = std::f64::consts::PI / 180.0;
    assert_eq!(data[0].len(), n);
    assert_eq!(data[0][5], 0.01 * 5.0 * deg);
}

/// An empty cell is a missing sample (as before): NaN, reported by the quality stage under
/// `--on-nonfinite` (error by default, naming the row), and so are `NaN`/`inf` written out.
#[test]
fn empty_and_non_finite_csv_cells_are_missing_samples() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("gaps.csv");
    let n = 2000;
    for (cell, row) in [
        ("", 1500usize),
        ("NaN", 20),
        ("inf", 1999),
        ("-Infinity", 3),
        ("  ", 700),
    ] {
        // Two columns: in a one-column file an empty cell is a blank line, which CSV readers skip.
        write_csv_text(
            &path,
            "g [rad/s],a [g]",
            (0..n).map(|i| {
                let g = if i == row {
                    cell.to_string()
                } else {
                    format!("{}", i as f64)
                };
                format!("{g},1")
            }),
        );
        let e = err_of(&path, &csv_inputs(256));
        assert!(
            matches!(e, Error::Input(InputError::NonFinite { .. })),
            "{cell:?}: {e}"
        );
        assert_eq!(
            (e.column(), e.row()),
            (Some("g"), Some(row as u64)),
            "{cell:?}"
        );
        let mut inputs = csv_inputs(256);
        inputs.quality.nonfinite = NonFinitePolicy::Interpolate;
        let (data, report) = read_all(&path, &inputs).unwrap();
        assert_eq!(report.channels[0].interpolated_samples, 1, "{cell:?}");
        assert_eq!(data[0].len(), n);
    }
}

/// Defect: a `# ...` preamble (as loggers write) was an error. Comment lines before and after the
/// header are skipped; `# sample_rate_hz: 200` gives the rate; rows and lines in errors still count
/// right.
#[test]
fn csv_comment_lines_are_skipped_and_a_preamble_may_give_the_rate() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("logger.csv");
    let n = 1500;
    let mut text = String::from(
        "# device: IMU-42, firmware 1.2, rate: 200\n# sample_rate_hz: 200\n\ngyro_x [deg/s],accel_z [g]\n",
    );
    for i in 0..n {
        if i == 700 {
            text.push_str("# re-synchronised\n");
        }
        text.push_str(&format!("{},{}\n", i as f64 * 0.5, 1.0));
    }
    std::fs::write(&path, &text).unwrap();
    let rec = io::open(&path, &OpenOptions::default()).unwrap();
    assert_eq!(rec.rate_hz, 200.0);
    assert_eq!(rec.rate_source, io::RateSource::Metadata);
    let (data, report) = read_all(&path, &Inputs::default()).unwrap();
    assert_eq!(report.samples_out, n as u64);
    let deg = std::f64::consts::PI / 180.0;
    assert_eq!(data[0][699], 699.0 * 0.5 * deg);
    assert_eq!(data[0][700], 700.0 * 0.5 * deg);
    assert_eq!(data[1][n - 1], 9.80665);

    // A bad cell after the mid-file comment: row 1200 ("600,1") is on line 1206: the header is on
    // line 4, and the comment at row 700 adds one.
    std::fs::write(&path, text.replacen("\n600,1\n", "\n600,x1\n", 1)).unwrap();
    let e = err_of(&path, &Inputs::default());
    assert_eq!((e.column(), e.row()), (Some("accel_z"), Some(1200)), "{e}");
    assert!(
        e.to_string()
            .contains("row 1200 (line 1206 of the file): \"x1\""),
        "{e}"
    );

    // The preamble's rate must agree with --rate like schema metadata does.
    std::fs::write(&path, &text).unwrap();
    let mut inputs = Inputs::default();
    inputs.open.rate_hz = Some(100.0);
    let e = err_of(&path, &inputs);
    assert!(
        matches!(e, Error::Input(InputError::RateConflict { .. })),
        "{e}"
    );
}

/// Defect: a logger's nanosecond epoch stamps (≈ 1.7·10¹⁸) were parsed as f64, whose steps there
/// are 256 ns, so a 100-Hz CSV export read as 99.9987 Hz. Integers beyond 2⁵³ stay integers: the
/// rate from the stamps is exact, and a bad stamp still names its row.
#[test]
fn nanosecond_epoch_stamps_in_a_csv_keep_their_resolution() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ns.csv");
    let n = 3000i64;
    let origin: i64 = 1_700_000_000_123_456_789;
    let row = |i: i64| format!("{},{}", origin + i * 10_000_000, (i % 7) as f64 * 0.01);
    write_csv_text(&path, "stamp,gyro_x [deg/s]", (0..n).map(row));
    let rec = io::open(&path, &OpenOptions::default()).unwrap();
    assert_eq!(rec.rate_hz, 100.0, "{:?}", rec.rate_from_time_hz);
    assert_eq!(rec.rate_source, io::RateSource::TimeColumn);
    let (data, report) = read_all(&path, &Inputs::default()).unwrap();
    assert_eq!(report.samples_out, n as u64);
    assert_eq!(report.gap_count, 0);
    assert_eq!(data[0].len(), n as usize);

    let text = std::fs::read_to_string(&path).unwrap();
    let bad = format!("\n{},", origin + 2000 * 10_000_000);
    std::fs::write(&path, text.replacen(&bad, "\n17000000x,", 1)).unwrap();
    let e = err_of(&path, &Inputs::default());
    assert_eq!((e.column(), e.row()), (Some("stamp"), Some(2000)), "{e}");
}

/// A logger's clock reset part-way (time back to 0 at row 3000): the rate is the rows' before it,
/// and the error names row 3000 going back. Defect: the timestamps' span over the reset gave
/// 400 Hz, and the error called row 1 a gap.
#[test]
fn a_clock_reset_is_named_at_its_row_not_read_as_another_rate() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("reset.csv");
    let row = |i: usize| format!("{:.2},{}", (i % 3000) as f64 * 0.01, (i % 5) as f64 * 0.1);
    write_csv_text(&path, "time,gyro_x [deg/s]", (0..6000).map(row));
    let rec = io::open(&path, &OpenOptions::default()).unwrap();
    assert!((rec.rate_hz - 100.0).abs() < 1e-9, "{}", rec.rate_hz);
    let e = err_of(&path, &Inputs::default());
    assert!(
        matches!(e, Error::Input(InputError::NonMonotonicTime { .. })),
        "{e}"
    );
    assert_eq!((e.column(), e.row()), (Some("time"), Some(3000)), "{e}");
}

/// Records with the wrong number of fields, bytes that are not UTF-8, a header line that holds
/// numbers: each names the row and line.
#[test]
fn malformed_csv_records_name_row_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.csv");
    let rows = |n: usize| (0..n).map(|i| format!("{i},{i}")).collect::<Vec<_>>();
    let n = 3000;
    for bad in [10usize, 2000] {
        let mut r = rows(n);
        r[bad] = "1,2,3".into();
        write_csv_text(&path, "a [rad/s],b [rad/s]", r);
        let e = err_of(&path, &csv_inputs(512));
        assert_eq!(e.row(), Some(bad as u64), "{e}");
        assert!(
            e.to_string().contains(&format!(
                "malformed CSV at row {bad} (line {} of the file): 3 fields, but the header has 2",
                bad + 2
            )),
            "{e}"
        );

        let mut bytes = Vec::new();
        bytes.extend_from_slice(b"a [rad/s],b [rad/s]\n");
        for (i, line) in rows(n).iter().enumerate() {
            if i == bad {
                bytes.extend_from_slice(b"1,\xff\xfe2\n");
            } else {
                bytes.extend_from_slice(line.as_bytes());
                bytes.push(b'\n');
            }
        }
        std::fs::write(&path, &bytes).unwrap();
        let e = err_of(&path, &csv_inputs(512));
        assert_eq!(e.row(), Some(bad as u64), "{e}");
        assert!(
            e.to_string()
                .contains("column \"b\" holds bytes that are not UTF-8"),
            "{e}"
        );
    }
    write_csv_text(&path, "1.5,2.5", rows(10));
    let e = err_of(&path, &csv_inputs(512));
    assert!(e.to_string().contains("a header line"), "{e}");

    // A byte-order mark before the header (a spreadsheet's UTF-8 export): the first column is
    // still `time`, and gives the rate.
    let mut bytes = "\u{feff}time [s],g [rad/s]\n".as_bytes().to_vec();
    for i in 0..200 {
        bytes.extend_from_slice(format!("{},{}\n", i as f64 / 50.0, (i % 7) as f64).as_bytes());
    }
    std::fs::write(&path, &bytes).unwrap();
    let r = io::open(&path, &OpenOptions::default()).unwrap();
    assert_eq!(r.rate_hz, 50.0);
    assert_eq!(r.time.as_ref().map(|t| t.name.as_str()), Some("time"));
    // The channels read, with their kinds.
    let kinds = |r: &io::Recording| -> Vec<(String, imunoise::units::Kind)> {
        r.channels
            .iter()
            .map(|c| (c.name.clone(), c.kind))
            .collect()
    };
    // A ROS topic's CSV export: the sensor's stamp, not the receive time `%time` before it; the
    // units sensor_msgs/Imu defines; no sequence number, orientation or covariance as channels.
    let mut text = String::from(
        "%time,field.header.seq,field.header.stamp,field.orientation.x,\
         field.orientation_covariance0,field.angular_velocity.x,field.linear_acceleration.z\n",
    );
    for i in 0..200u64 {
        let stamp = 1_700_000_000_000_000_000u64 + i * 20_000_000;
        let received = stamp + 1_000_000 + (i % 3) * 3_000_000;
        text.push_str(&format!("{received},{i},{stamp},0.1,0.0,{},9.8\n", i % 7));
    }
    std::fs::write(&path, text).unwrap();
    let r = io::open(&path, &OpenOptions::default()).unwrap();
    assert_eq!(
        r.time.as_ref().map(|t| t.name.as_str()),
        Some("field.header.stamp")
    );
    assert_eq!(r.rate_hz, 50.0);
    assert_eq!(
        kinds(&r),
        [
            (
                "field.angular_velocity.x".into(),
                imunoise::units::Kind::Gyro
            ),
            (
                "field.linear_acceleration.z".into(),
                imunoise::units::Kind::Accel
            )
        ]
    );
    // PlotJuggler's export of the same topics: `__time`, the topic before each field's path
    // with `/` between the parts; the temperature topic's field in °C.
    let mut text = String::from(
        "__time,/imu/header/seq,/imu/orientation/w,/imu/angular_velocity/z,\
         /imu/angular_velocity_covariance/0,/imu/linear_acceleration/x,/imu_temp/temperature\n",
    );
    for i in 0..200u64 {
        text.push_str(&format!(
            "{},{i},1.0,{},0.0,0.1,25.5\n",
            1_700_000_000.0 + i as f64 * 0.005,
            i % 7
        ));
    }
    std::fs::write(&path, text).unwrap();
    let r = io::open(&path, &OpenOptions::default()).unwrap();
    assert_eq!(r.time.as_ref().map(|t| t.name.as_str()), Some("__time"));
    // (Float epoch seconds resolve 2.4e-7 s: the rate from their intervals is 200.000003.)
    assert!((r.rate_hz - 200.0).abs() < 1e-4, "{}", r.rate_hz);
    assert_eq!(
        kinds(&r),
        [
            (
                "/imu/angular_velocity/z".into(),
                imunoise::units::Kind::Gyro
            ),
            (
                "/imu/linear_acceleration/x".into(),
                imunoise::units::Kind::Accel
            ),
            (
                "/imu_temp/temperature".into(),
                imunoise::units::Kind::Temperature
            )
        ]
    );
    // ... and before a `#` preamble, which is still a comment that gives the rate.
    let mut bytes = "\u{feff}# sample_rate_hz: 40\ng [rad/s]\n"
        .as_bytes()
        .to_vec();
    for i in 0..200 {
        bytes.extend_from_slice(format!("{}\n", (i % 7) as f64).as_bytes());
    }
    std::fs::write(&path, &bytes).unwrap();
    let r = io::open(&path, &OpenOptions::default()).unwrap();
    assert_eq!(r.rate_hz, 40.0);
    let (read, _) = read_all(&path, &Inputs::default()).unwrap();
    assert_eq!(read[0].len(), 200);
    assert_eq!(read[0][8], 1.0);

    // Raw counts in a CSV: the header says one count's worth, `[0.01 deg/s]`, and the values
    // arrive in rad/s; `--unit` says the same where the header cannot.
    let deg = std::f64::consts::PI / 180.0;
    let counts = |header: &str, inputs: &Inputs| {
        write_csv_text(
            &path,
            header,
            (0..50).map(|i| format!("{},{}", i as f64 / 50.0, i % 5)),
        );
        let read = read_all(&path, inputs).unwrap().0.remove(0);
        assert!(
            (read[3] - 3.0 * 0.01 * deg).abs() < 1e-15,
            "{header}: {:?}",
            &read[..5]
        );
    };
    counts("time [s],gx [0.01 deg/s]", &Inputs::default());
    // Increments per sample (a navigation gyro's Δθ, an accelerometer's Δv) read as rates:
    // times the sample rate, 50 Hz here, with a note saying so.
    write_csv_text(
        &path,
        "time [s],gx [arcsec],ax [mm/s]",
        (0..50).map(|i| format!("{},{},{}", i as f64 / 50.0, i % 5, 2 * (i % 3))),
    );
    let rec = io::open(&path, &OpenOptions::default()).unwrap();
    assert_eq!(rec.channels[0].kind, imunoise::units::Kind::Gyro);
    assert_eq!(rec.channels[1].kind, imunoise::units::Kind::Accel);
    assert!(
        rec.notes
            .iter()
            .any(|n| n.contains("gx holds increments per sample")),
        "{:?}",
        rec.notes
    );
    let read = read_all(&path, &Inputs::default()).unwrap().0;
    let arcsec = deg / 3600.0;
    assert!(
        (read[0][3] - 3.0 * arcsec * 50.0).abs() < 1e-15,
        "{:?}",
        &read[0][..5]
    );
    assert!(
        (read[1][2] - 4.0e-3 * 50.0).abs() < 1e-15,
        "{:?}",
        &read[1][..5]
    );
    let mut flagged = Inputs::default();
    flagged.open.columns.units = vec![("gx".into(), "0.01 deg/s".parse().unwrap())];
    counts("time [s],gx", &flagged);

    // Every other file below is the same two columns of a few rows.
    let two = |header: &str| {
        write_csv_text(
            &path,
            header,
            (0..50).map(|i| format!("{},{}", i as f64 / 50.0, i % 3)),
        )
    };
    // A time column under a name not taken automatically: the error names it and the flag.
    two("clock,g [rad/s]");
    let e = io::open(&path, &OpenOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("no sample rate"), "{e}");
    assert!(!e.contains("--time-column"), "no candidate: {e}");
    two("sensor_time,g [rad/s]");
    let e = io::open(&path, &OpenOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("--time-column \"sensor_time\""), "{e}");

    // Another separator (a spreadsheet's export with decimal commas): the header is one column
    // holding the separator; the error says so instead of counting fields in the first row.
    for (sep, what) in [(";", "semicolons"), ("\t", "tabs")] {
        let decimal = |i: usize| format!("{i},5{sep}{i},25");
        write_csv_text(
            &path,
            &format!("time [s]{sep}gyro_x [deg/s]"),
            (0..10).map(decimal),
        );
        let e = err_of(&path, &csv_inputs(512)).to_string();
        assert!(
            e.contains(&format!("separated by {what}")) && e.contains("line 1"),
            "{e}"
        );
    }
}

/// Two columns of the same name: an error naming it, in every format (which one `--channels`
/// would pick was a guess).
#[test]
fn duplicate_column_names_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("dup.csv");
    write_csv_text(
        &csv,
        "g [deg/s],a [g],g [rad/s]",
        (0..100).map(|i| format!("{i},1,{i}")),
    );
    let arrow = recording(
        dir.path(),
        "dup.arrow",
        vec![
            f64_col("g", noise(100, 1), None),
            f64_col("g", noise(100, 2), None),
        ],
        Some(RATE),
    );
    for path in [&csv, &arrow] {
        let e = err_of(path, &csv_inputs(512));
        assert!(
            matches!(e, Error::Input(InputError::DuplicateColumn { .. })),
            "{e}"
        );
        assert_eq!(e.column(), Some("g"));
        assert!(e.to_string().contains("appears twice"), "{e}");
    }
}

/// Defect: a truncated Arrow IPC file read "corrupt or truncated Arrow IPC file file: Parser error:
/// ...". Every corrupt-file message names the format once, says why when the file shows it, and has
/// no colon with nothing after it.
#[test]
fn corrupt_file_messages_read_well() {
    let dir = tempfile::tempdir().unwrap();
    let b = batch(&[f64_col("g", noise(5000, 1), Some("rad/s"))], Some(RATE));
    let ipc = dir.path().join("x.arrow");
    write_ipc_file(&ipc, &b, 1000);
    let stream = dir.path().join("x.arrows");
    write_ipc_stream(&stream, &b, 1000);
    let pq = dir.path().join("x.parquet");
    write_parquet(&pq, &b, 1000);
    let cut = |path: &Path, keep: usize| {
        let bytes = std::fs::read(path).unwrap();
        let cut = path.with_file_name(format!(
            "cut.{}",
            path.extension().unwrap().to_str().unwrap()
        ));
        std::fs::write(&cut, &bytes[..keep.min(bytes.len())]).unwrap();
        (cut, bytes.len())
    };
    let message = |path: &Path| err_of(path, &Inputs::default()).to_string();

    let (p, len) = cut(&ipc, usize::MAX);
    let (p, _) = cut(&p, len / 2);
    assert_eq!(
        message(&p),
        format!(
            "{}: corrupt Arrow IPC file (truncated: footer missing): Arrow file does not contain correct footer",
            p.display()
        )
    );
    let (p, _) = cut(&ipc, 3);
    assert_eq!(
        message(&p),
        format!(
            "{}: corrupt Arrow IPC file (truncated): the file is only 3 bytes long",
            p.display()
        )
    );
    let (p, len) = cut(&pq, usize::MAX);
    let (p, _) = cut(&p, len - 1);
    assert_eq!(
        message(&p),
        format!(
            "{}: corrupt Parquet file (truncated: footer missing): Invalid Parquet file. Corrupt footer",
            p.display()
        )
    );
    // Not the format its name says.
    let fake = dir.path().join("fake.parquet");
    std::fs::write(&fake, b"time,g\n0,1\n1,2\n").unwrap();
    assert!(
        message(&fake)
            .contains("corrupt Parquet file (not a Parquet file: it does not start with PAR1)"),
        "{}",
        message(&fake)
    );
    // A stream cut inside a batch, and one cut just before its end-of-stream marker: both truncated,
    // at the row where the missing data starts.
    let (p, len) = cut(&stream, usize::MAX);
    let (p, _) = cut(&p, len * 2 / 3);
    let m = message(&p);
    assert!(
        m.starts_with(&format!(
            "{}: corrupt Arrow IPC stream (truncated: the file ends inside a message) at row 3000: ",
            p.display()
        )),
        "{m}"
    );
    let (p, _) = cut(&stream, len - 8);
    assert_eq!(
        message(&p),
        format!(
            "{}: corrupt Arrow IPC stream (truncated: end-of-stream marker missing) at row 5000: the file ends after a complete record batch; the rows after it are missing",
            p.display()
        )
    );
    for m in [message(&ipc.with_file_name("cut.arrow")), m] {
        assert!(
            !m.contains("file file") && !m.ends_with(':') && !m.contains("error:"),
            "{m}"
        );
    }
}

/// A `scale` on a float column is applied, and said: it is meant for integer counts, and a float
/// gyro with scale 2 had its N doubled with nothing said.
#[test]
fn a_scale_on_a_float_column_is_applied_with_a_note() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scaled.arrow");
    let v = noise(3000, 4);
    let col = Col {
        name: "g".into(),
        array: Arc::new(arrow_array::Float64Array::from(v.clone())) as ArrayRef,
        meta: vec![("unit", "rad/s".into()), ("scale", "2".into())],
    };
    write_ipc_file(&path, &batch(&[col], Some(RATE)), 1000);
    let rec = io::open(&path, &OpenOptions::default()).unwrap();
    assert!(
        rec.notes
            .iter()
            .any(|n| n.contains("g is stored as floats") && n.contains("scale 2")),
        "{:?}",
        rec.notes
    );
    let (data, _) = read_all(&path, &Inputs::default()).unwrap();
    assert_eq!(data[0][10], 2.0 * v[10]);
}
