//! How well the quality screen tells timestamp jitter from missing samples, over many seeds.
//!
//! Each record: 20 000 samples at 100 Hz on a clock 200 ppm fast, every timestamp off its instant
//! by a uniform jitter of ±J periods, then 20 single samples and 5 runs of 3 samples removed at
//! random places. The screen (`--on-gap ignore`) must report exactly those 25 gaps and 35 missing
//! samples. Reported per jitter level: records with every gap right, missed and false gaps in all,
//! how often the screen flagged its own gap count as ambiguous, and how often the file was refused
//! (the rate the time column implies disagreeing with the stated one).
//!
//! `cargo run --release --example jitter_gaps [SEEDS]` (default 200; ~1 min).

use std::collections::HashMap;
use std::sync::Arc;

use arrow_array::{Float64Array, RecordBatch, TimestampNanosecondArray};
use arrow_schema::{DataType, Field, Schema, TimeUnit};
use imunoise::estimate::CpuBackend;
use imunoise::pipeline::{self, Inputs, Silent, Work};
use imunoise::quality::{GapPolicy, QualityOptions};
use imunoise::sim::rng::Rng;

const N: usize = 20_000;
const RATE: f64 = 100.0;
const DRIFT: f64 = 200e-6;

fn record(path: &std::path::Path, jitter: f64, seed: u64) -> (u64, u64) {
    let mut rng = Rng::new(seed);
    let mut drop = vec![false; N];
    let mut gaps = 0;
    let mut missing = 0;
    // Gaps apart from each other and from the ends, so each one is one gap.
    let mut place = |len: usize, drop: &mut Vec<bool>| loop {
        let at = 10 + (rng.uniform() * (N - 20) as f64) as usize;
        if (at.saturating_sub(3)..(at + len + 3).min(N)).all(|i| !drop[i]) {
            drop[at..at + len].fill(true);
            return;
        }
    };
    for _ in 0..20 {
        place(1, &mut drop);
        gaps += 1;
        missing += 1;
    }
    for _ in 0..5 {
        place(3, &mut drop);
        gaps += 1;
        missing += 3;
    }
    let mut jit = Rng::stream(seed, 1);
    let period = 1.0 / (RATE * (1.0 + DRIFT));
    let (mut t, mut g) = (Vec::new(), Vec::new());
    for (i, &dropped) in drop.iter().enumerate().take(N) {
        let e = (2.0 * jit.uniform() - 1.0) * jitter / RATE;
        let x = jit.gauss();
        if !dropped {
            t.push(((i as f64 * period + e) * 1e9).round() as i64);
            g.push(x * 1e-3);
        }
    }
    let schema = Arc::new(Schema::new_with_metadata(
        vec![
            Field::new(
                "time",
                DataType::Timestamp(TimeUnit::Nanosecond, None),
                false,
            ),
            Field::new("gx", DataType::Float64, false)
                .with_metadata(HashMap::from([("unit".to_string(), "rad/s".to_string())])),
        ],
        HashMap::from([("sample_rate_hz".to_string(), RATE.to_string())]),
    ));
    let batch = RecordBatch::try_new(
        schema.clone(),
        vec![
            Arc::new(TimestampNanosecondArray::from(t)),
            Arc::new(Float64Array::from(g)),
        ],
    )
    .expect("batch");
    let file = std::fs::File::create(path).expect("create");
    let mut w = arrow_ipc::writer::FileWriter::try_new(file, &schema).expect("writer");
    w.write(&batch).expect("write");
    w.finish().expect("finish");
    (gaps, missing)
}

fn main() {
    let seeds: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(200);
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("r.arrow");
    let inputs = Inputs {
        open: Default::default(),
        quality: QualityOptions {
            gaps: GapPolicy::Ignore,
            ..Default::default()
        },
    };
    println!("| jitter (± periods) | records all right | missed gaps | false gaps | missing-sample count right | flagged ambiguous | refused |");
    println!("|---|---|---|---|---|---|---|");
    for jitter in [0.0, 0.1, 0.2, 0.3, 0.4, 0.45] {
        let (mut right, mut missed, mut false_gaps, mut count_right, mut ambiguous) =
            (0, 0i64, 0i64, 0, 0);
        let mut refused = 0;
        let mut planted_total = 0i64;
        for seed in 0..seeds {
            let (gaps, missing) = record(&path, jitter, 50_000 + seed);
            planted_total += gaps as i64;
            let r = match pipeline::run(&path, &inputs, &Work::default(), &CpuBackend, &Silent) {
                Ok(r) => r,
                Err(_) => {
                    refused += 1;
                    continue;
                }
            };
            let q = &r.quality;
            let found = q.gap_count as i64;
            missed += (gaps as i64 - found).max(0);
            false_gaps += (found - gaps as i64).max(0);
            if q.gap_count == gaps && q.missing_samples == missing {
                right += 1;
            }
            if q.missing_samples == missing {
                count_right += 1;
            }
            if q.time_jitter.is_some_and(|j| j.gaps_ambiguous) {
                ambiguous += 1;
            }
        }
        println!(
            "| {jitter} | {right}/{seeds} | {missed} of {planted_total} | {false_gaps} | {count_right}/{seeds} | {ambiguous}/{seeds} | {refused}/{seeds} |"
        );
    }
}
