//! The file-to-PSD path streams: memory held by the Welch estimate stays below one segment plus one
//! chunk (blocks gathered to a fixed byte size) per channel however long the recording, and the
//! streamed result equals the one-shot one.

use imunoise::estimate::CpuBackend;
use imunoise::pipeline::{self, Inputs, Silent, WelchWork, Work};
use imunoise::psd::{welch, WelchConfig};

use super::support::*;

#[test]
fn welch_memory_is_bounded_by_segment_and_block_not_by_file_length() {
    let dir = tempfile::tempdir().unwrap();
    let nperseg = 1024;
    let block = 4096;
    let mut peaks = Vec::new();
    for rows in [50_000usize, 400_000] {
        let cols: Vec<Col> = (0..3)
            .map(|c| f64_col(&format!("g{c}"), noise(rows, c as u64 + 10), Some("rad/s")))
            .collect();
        let path = dir.path().join(format!("long{rows}.arrow"));
        let b = batch(&cols, Some(200.0));
        write_ipc_file(&path, &b, block);
        let cfg = WelchConfig::new(nperseg);
        let work = Work {
            welch: Some(WelchWork {
                plan: cfg.validate().unwrap(),
                bins_per_decade: None,
            }),
            avar: None,
            fit: None,
            residual_loop: false,
        };
        let r = pipeline::run(&path, &Inputs::default(), &work, &CpuBackend, &Silent).unwrap();
        let peak = r.footprint.welch_peak_buffered_samples;
        // Blocks are gathered into chunks of a fixed byte size before the estimators take them
        // (until the chunk reaches it: at most one block beyond).
        let chunk = pipeline::CHUNK_BYTES / (8 * cols.len());
        assert!(r.footprint.largest_chunk_rows < chunk + block);
        assert!(
            peak > 0 && peak <= nperseg + r.footprint.largest_chunk_rows,
            "peak {peak} for {rows} rows"
        );
        assert_eq!(r.footprint.largest_block_rows, block);
        peaks.push(peak);
        // Streaming gives the one-shot answer.
        let g1 = noise(rows, 11);
        let one_shot = welch(&g1, 200.0, &cfg).unwrap();
        let streamed = &r.psd.as_ref().unwrap()[1].psd;
        for (a, b) in streamed.value.iter().zip(&one_shot.value) {
            assert!((a - b).abs() <= 1e-12 * b.abs().max(1e-300), "{a} vs {b}");
        }
    }
    eprintln!(
        "Welch peak buffered samples per channel: {} (50k rows), {} (400k rows); nperseg {nperseg}, block {block}",
        peaks[0], peaks[1]
    );
}
