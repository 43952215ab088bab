//! Reading and screening throughput: an Arrow IPC file of 3 channels × 1e6 rows through io → quality,
//! alone and with the streamed Welch estimate, end to end as the CLI runs it.

use std::sync::Arc;

use arrow_array::{ArrayRef, Float64Array, RecordBatch};
use arrow_schema::{Field, Schema};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use imunoise::estimate::CpuBackend;
use imunoise::pipeline::{self, Inputs, Silent, WelchWork, Work};
use imunoise::psd::WelchConfig;

const ROWS: usize = 1_000_000;
const CHANNELS: usize = 3;

fn write_file(path: &std::path::Path) {
    let mut rng = imunoise::sim::rng::Rng::new(1);
    let mut next = || rng.uniform() - 0.5;
    let fields: Vec<Field> = (0..CHANNELS)
        .map(|c| Field::new(format!("g{c}"), arrow_schema::DataType::Float64, false))
        .collect();
    let schema = Arc::new(
        Schema::new(fields).with_metadata(std::collections::HashMap::from([(
            "sample_rate_hz".to_string(),
            "200".to_string(),
        )])),
    );
    let f = std::fs::File::create(path).unwrap();
    let mut w = arrow_ipc::writer::FileWriter::try_new(f, &schema).unwrap();
    for _ in 0..ROWS / 65_536 + 1 {
        let cols: Vec<ArrayRef> = (0..CHANNELS)
            .map(|_| {
                Arc::new(Float64Array::from(
                    (0..65_536).map(|_| next()).collect::<Vec<_>>(),
                )) as ArrayRef
            })
            .collect();
        w.write(&RecordBatch::try_new(schema.clone(), cols).unwrap())
            .unwrap();
    }
    w.finish().unwrap();
}

fn ingest(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bench.arrow");
    write_file(&path);
    let mut group = c.benchmark_group("ingest_3ch_1M");
    group.sample_size(10);
    group.throughput(Throughput::Bytes((ROWS * CHANNELS * 8) as u64));
    let inputs = Inputs::default();
    group.bench_function("read_and_screen", |b| {
        b.iter(|| pipeline::run(&path, &inputs, &Work::default(), &CpuBackend, &Silent).unwrap())
    });
    let welch = Work {
        welch: Some(WelchWork {
            plan: WelchConfig::new(4096).validate().unwrap(),
            bins_per_decade: Some(20),
        }),
        avar: None,
        fit: None,
        residual_loop: false,
    };
    group.bench_function("read_screen_welch_4096", |b| {
        b.iter(|| pipeline::run(&path, &inputs, &welch, &CpuBackend, &Silent).unwrap())
    });
    group.finish();
}

criterion_group!(benches, ingest);
criterion_main!(benches);
