//! Shared by the fuzz targets: write the input to a file with the format's extension, open it as a
//! recording, read every block through the quality stage. Any outcome is fine except a panic, a hang,
//! or an error that does not name the file.

use std::path::PathBuf;

use imunoise::io::{self, OpenOptions};
use imunoise::quality::{Cleaner, GapPolicy, NonFinitePolicy, QualityOptions};

pub fn read(data: &[u8], extension: &str) {
    // One file per process and format: libFuzzer runs one input at a time.
    let path: PathBuf =
        std::env::temp_dir().join(format!("imunoise-fuzz-{}.{extension}", std::process::id()));
    std::fs::write(&path, data).expect("the temporary directory is writable");
    let options = OpenOptions {
        // Files that carry no rate are read too, rather than stopping at "no sample rate"; MCAP
        // has header times, which a stated rate would contradict.
        rate_hz: (extension != "mcap").then_some(100.0),
        // Small batches exercise the batch edges.
        batch_rows: 64,
        ..Default::default()
    };
    let check = |e: &io::InputError| assert_eq!(e.path(), path.as_path(), "{e}");
    let recording = match io::open(&path, &options) {
        Ok(r) => r,
        Err(e) => return check(&e),
    };
    let quality = QualityOptions {
        nonfinite: NonFinitePolicy::Interpolate,
        gaps: GapPolicy::Ignore,
    };
    let mut cleaner = Cleaner::new(&recording, quality);
    let blocks = match recording.blocks() {
        Ok(b) => b,
        Err(e) => return check(&e),
    };
    for block in blocks {
        match block.and_then(|b| cleaner.push(b)) {
            Ok(_) => {}
            Err(e) => return check(&e),
        }
    }
    if let Err(e) = cleaner.finish() {
        check(&e);
    }
}
