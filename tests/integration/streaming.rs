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

/// An Arrow IPC file of one record batch is handed on in blocks of `batch_rows` rows (views of the
/// mapped batch), and gives the PSD and Allan deviation, to the bit, of the same samples written
/// in small batches.
#[test]
fn one_large_arrow_batch_is_read_in_blocks_with_the_same_result() {
    use imunoise::avar::{Confidence, TauGrid};
    use imunoise::pipeline::{AvarWork, TauSpec};
    let dir = tempfile::tempdir().unwrap();
    let rows = 150_000;
    let cols: Vec<Col> = (0..2)
        .map(|c| f64_col(&format!("g{c}"), noise(rows, c as u64 + 20), Some("rad/s")))
        .collect();
    let b = batch(&cols, Some(200.0));
    let whole = dir.path().join("whole.arrow");
    write_ipc_file(&whole, &b, rows);
    let small = dir.path().join("small.arrow");
    write_ipc_file(&small, &b, 1000);
    let work = Work {
        welch: Some(WelchWork {
            plan: WelchConfig::new(4096).validate().unwrap(),
            bins_per_decade: None,
        }),
        avar: Some(AvarWork {
            statistics: vec![imunoise::avar::Statistic::Oadev],
            taus: TauSpec::Grid(TauGrid::Octave),
            confidence: Confidence::OneSigma,
        }),
        fit: None,
        residual_loop: false,
    };
    let mut inputs = Inputs::default();
    inputs.open.batch_rows = 40_000;
    let a = pipeline::run(&whole, &inputs, &work, &CpuBackend, &Silent).unwrap();
    let s = pipeline::run(&small, &inputs, &work, &CpuBackend, &Silent).unwrap();
    assert_eq!(a.footprint.largest_block_rows, 40_000);
    assert_eq!(s.footprint.largest_block_rows, 1000);
    assert_eq!(a.quality.samples_out, rows as u64);
    for (x, y) in a.psd.as_ref().unwrap().iter().zip(s.psd.as_ref().unwrap()) {
        assert_eq!(x.psd.value, y.psd.value);
    }
    for (x, y) in a
        .avar
        .as_ref()
        .unwrap()
        .iter()
        .zip(s.avar.as_ref().unwrap())
    {
        assert_eq!(x.statistics[0].variance, y.statistics[0].variance);
    }
}
