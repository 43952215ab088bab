//! Helpers shared by the integration tests: writing small recordings in every format, and running the
//! binary.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::Arc;

use arrow_array::{ArrayRef, Float64Array, RecordBatch, TimestampNanosecondArray};
use arrow_schema::{Field, Schema};

/// A column for a test recording.
pub struct Col {
    pub name: String,
    pub array: ArrayRef,
    pub meta: Vec<(&'static str, String)>,
}

pub fn f64_col(name: &str, values: Vec<f64>, unit: Option<&str>) -> Col {
    Col {
        name: name.to_string(),
        array: Arc::new(Float64Array::from(values)),
        meta: unit
            .map(|u| vec![("unit", u.to_string())])
            .unwrap_or_default(),
    }
}

/// A nanosecond timestamp column at `rate_hz` from t = 0, with optional per-row changes.
pub fn time_col(n: usize, rate_hz: f64, edit: impl Fn(usize, i64) -> i64) -> Col {
    let t: Vec<i64> = (0..n)
        .map(|i| edit(i, (i as f64 / rate_hz * 1e9).round() as i64))
        .collect();
    Col {
        name: "time".into(),
        array: Arc::new(TimestampNanosecondArray::from(t)),
        meta: vec![],
    }
}

/// Deterministic white noise (the project's SplitMix64 + Box–Muller).
pub fn noise(n: usize, seed: u64) -> Vec<f64> {
    let mut state = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut next =
        || (imunoise::sim::rng::splitmix64(&mut state) >> 11) as f64 / (1u64 << 53) as f64;
    (0..n)
        .map(|_| {
            let (u1, u2) = (next().max(1e-300), next());
            (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
        })
        .collect()
}

pub fn batch(cols: &[Col], rate_hz: Option<f64>) -> RecordBatch {
    let fields: Vec<Field> = cols
        .iter()
        .map(|c| {
            let meta: HashMap<String, String> = c
                .meta
                .iter()
                .map(|(k, v)| (k.to_string(), v.clone()))
                .collect();
            Field::new(&c.name, c.array.data_type().clone(), true).with_metadata(meta)
        })
        .collect();
    let mut schema = Schema::new(fields);
    if let Some(r) = rate_hz {
        schema = schema.with_metadata(HashMap::from([(
            "sample_rate_hz".to_string(),
            r.to_string(),
        )]));
    }
    RecordBatch::try_new(
        Arc::new(schema),
        cols.iter().map(|c| c.array.clone()).collect(),
    )
    .unwrap()
}

/// Writes `batch` as an Arrow IPC file in record batches of `rows_per_batch` rows.
pub fn write_ipc_file(path: &Path, batch: &RecordBatch, rows_per_batch: usize) {
    let f = std::fs::File::create(path).unwrap();
    let mut w = arrow_ipc::writer::FileWriter::try_new(f, &batch.schema()).unwrap();
    for start in (0..batch.num_rows()).step_by(rows_per_batch) {
        let len = rows_per_batch.min(batch.num_rows() - start);
        w.write(&batch.slice(start, len)).unwrap();
    }
    w.finish().unwrap();
}

pub fn write_ipc_stream(path: &Path, batch: &RecordBatch, rows_per_batch: usize) {
    let f = std::fs::File::create(path).unwrap();
    let mut w = arrow_ipc::writer::StreamWriter::try_new(f, &batch.schema()).unwrap();
    for start in (0..batch.num_rows()).step_by(rows_per_batch) {
        let len = rows_per_batch.min(batch.num_rows() - start);
        w.write(&batch.slice(start, len)).unwrap();
    }
    w.finish().unwrap();
}

pub fn write_parquet(path: &Path, batch: &RecordBatch, rows_per_group: usize) {
    write_parquet_compressed(
        path,
        batch,
        rows_per_group,
        parquet::basic::Compression::UNCOMPRESSED,
    );
}

/// Parquet with every column compressed by `compression`.
pub fn write_parquet_compressed(
    path: &Path,
    batch: &RecordBatch,
    rows_per_group: usize,
    compression: parquet::basic::Compression,
) {
    let f = std::fs::File::create(path).unwrap();
    let props = parquet::file::properties::WriterProperties::builder()
        .set_max_row_group_row_count(Some(rows_per_group))
        .set_compression(compression)
        .build();
    let mut w = parquet::arrow::ArrowWriter::try_new(f, batch.schema(), Some(props)).unwrap();
    w.write(batch).unwrap();
    w.close().unwrap();
}

/// CSV with units in the header (`name [unit]`) and full-precision floats; no time column.
pub fn write_csv(path: &Path, names: &[(&str, Option<&str>)], columns: &[Vec<f64>]) {
    let mut s = String::new();
    let header: Vec<String> = names
        .iter()
        .map(|(n, u)| match u {
            Some(u) => format!("{n} [{u}]"),
            None => n.to_string(),
        })
        .collect();
    s.push_str(&header.join(","));
    s.push('\n');
    for r in 0..columns[0].len() {
        let row: Vec<String> = columns.iter().map(|c| format!("{:?}", c[r])).collect();
        s.push_str(&row.join(","));
        s.push('\n');
    }
    std::fs::write(path, s).unwrap();
}

/// Runs the binary with `args`; stdin closed.
pub fn imunoise(args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_imunoise"))
        .args(args)
        .current_dir(cwd)
        .stdin(std::process::Stdio::null())
        .output()
        .unwrap()
}

/// The repository root (for `data/`).
pub fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The residual loop's settings in the loop tests: Welch segments of 4096, 20 bands per decade,
/// octave τ, 1σ intervals, default fit options.
pub fn loop_config() -> imunoise::effects::LoopConfig {
    imunoise::effects::LoopConfig::with_segment(4096)
}

/// The loop tests' gyro: N = 0.15 °/√h, B = 3 °/h, K = 20 °/h/√h (SI).
pub fn loop_gyro() -> imunoise::model::Coefficients {
    use imunoise::model::CoefUnit;
    imunoise::model::Coefficients {
        n: CoefUnit::DegPerSqrtH.to_si(0.15),
        b: CoefUnit::DegPerH.to_si(3.0),
        k: CoefUnit::DegPerHPerSqrtH.to_si(20.0),
        ..Default::default()
    }
}

/// Runs the binary with `args` in `cwd`; it must succeed.
pub fn run_ok(args: &[&str], cwd: &Path) -> Output {
    let out = imunoise(args, cwd);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// `imunoise simulate` of `spec` into `dir`, then `analyze` of the recording on the CPU into
/// `dir/out`: its stderr and report.json.
pub fn simulate_and_analyze(dir: &Path, spec: &serde_json::Value) -> (String, serde_json::Value) {
    std::fs::write(dir.join("spec.json"), spec.to_string()).unwrap();
    run_ok(&["simulate", "--spec", "spec.json", "-o", "sim.arrow"], dir);
    let out = run_ok(
        &["analyze", "sim.arrow", "-o", "out", "--backend", "cpu"],
        dir,
    );
    let report =
        serde_json::from_str(&std::fs::read_to_string(dir.join("out/report.json")).unwrap())
            .unwrap();
    (String::from_utf8_lossy(&out.stderr).into_owned(), report)
}

/// The `analysis` entry of channel `name` in the first file of an `analyze` report.
pub fn channel_analysis(report: &serde_json::Value, name: &str) -> serde_json::Value {
    report["files"][0]["analysis"]
        .as_array()
        .unwrap()
        .iter()
        .find(|a| a["channel"] == name)
        .unwrap_or_else(|| panic!("{name} not analysed"))
        .clone()
}

/// The combined result's first warning of `kind` on channel `name`.
pub fn combined_warning(
    report: &serde_json::Value,
    name: &str,
    kind: &str,
) -> Option<serde_json::Value> {
    channel_analysis(report, name)["combined"]["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .find(|w| w["kind"] == kind)
        .cloned()
}

/// The combined value of `term` (report.json's name, e.g. `random_walk`) on channel `name`.
pub fn combined_value(report: &serde_json::Value, name: &str, term: &str) -> Option<f64> {
    term_value(&channel_analysis(report, name), term)
}

/// The combined value of `term` in one channel's `analysis` entry of report.json.
pub fn term_value(analysis: &serde_json::Value, term: &str) -> Option<f64> {
    analysis["combined"]["terms"]
        .as_array()
        .unwrap()
        .iter()
        .find(|t| t["term"] == term)
        .map(|t| t["value"].as_f64().unwrap())
}
