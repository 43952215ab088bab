//! File formats imunoise reads, told apart by extension and, failing that, by their magic bytes.

use std::fmt;
use std::io::Read;
use std::path::Path;

use serde::Serialize;

/// A recording's container format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Format {
    /// Arrow IPC file (`.arrow`, `.feather` v2, `.ipc`): random access, footer with the schema.
    ArrowFile,
    /// Arrow IPC stream (`.arrows`): a schema message, then batches, no footer.
    ArrowStream,
    Parquet,
    Csv,
}

impl Format {
    pub fn as_str(self) -> &'static str {
        match self {
            Format::ArrowFile => "Arrow IPC file",
            Format::ArrowStream => "Arrow IPC stream",
            Format::Parquet => "Parquet",
            Format::Csv => "CSV",
        }
    }

    /// The format a path's extension names, if it names one.
    pub fn from_extension(path: &Path) -> Option<Format> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "arrow" | "feather" | "ipc" => Some(Format::ArrowFile),
            "arrows" => Some(Format::ArrowStream),
            "parquet" | "pq" => Some(Format::Parquet),
            "csv" => Some(Format::Csv),
            _ => None,
        }
    }

    /// The format announced by a file's first bytes (Arrow files start with `ARROW1`, Parquet with
    /// `PAR1`, Arrow streams with a continuation marker `0xFFFFFFFF`).
    pub fn sniff(path: &Path) -> Option<Format> {
        let mut head = [0u8; 8];
        let mut file = std::fs::File::open(path).ok()?;
        let n = file.read(&mut head).ok()?;
        let head = &head[..n];
        if head.starts_with(b"ARROW1") {
            Some(Format::ArrowFile)
        } else if head.starts_with(b"PAR1") {
            Some(Format::Parquet)
        } else if head.starts_with(&[0xFF, 0xFF, 0xFF, 0xFF]) {
            Some(Format::ArrowStream)
        } else {
            None
        }
    }
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}
