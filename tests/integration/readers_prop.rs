//! Property test of the readers: arbitrary damage to a valid file (truncation, overwritten bytes) in
//! every binary format must give samples or an error naming the file, never a panic or a hang.

use std::path::Path;

use imunoise::pipeline::{self, Inputs, Silent, Work};
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
        which in 0usize..4,
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
        inputs.open.rate_hz = Some(100.0);
        inputs.quality.gaps = imunoise::quality::GapPolicy::Ignore;
        inputs.quality.nonfinite = imunoise::quality::NonFinitePolicy::Interpolate;
        match pipeline::run(path, &inputs, &Work::default(), &imunoise::estimate::CpuBackend, &Silent) {
            Ok(r) => prop_assert!(r.quality.samples_out <= 3000 || which == 3),
            Err(e) => prop_assert_eq!(e.path(), path.as_path()),
        }
    }
}
