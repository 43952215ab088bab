//! File formats imunoise reads, told apart by extension and, failing that, by their magic bytes;
//! and the robotics logs it recognises but does not read, with how to convert them.

use std::fmt;
use std::io::Read;
use std::path::Path;

use serde::Serialize;

/// The first bytes of every MCAP file (format version 0).
const MCAP_MAGIC: &[u8] = b"\x89MCAP0\r\n";

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
    /// MCAP (`.mcap`), the ROS 2 bag format: one IMU topic read as a recording (see `io::mcap`).
    Mcap,
}

impl Format {
    pub fn as_str(self) -> &'static str {
        match self {
            Format::ArrowFile => "Arrow IPC file",
            Format::ArrowStream => "Arrow IPC stream",
            Format::Parquet => "Parquet",
            Format::Csv => "CSV",
            Format::Mcap => "MCAP",
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
            "mcap" => Some(Format::Mcap),
            _ => None,
        }
    }

    /// The format announced by a file's first bytes (Arrow files start with `ARROW1`, Parquet with
    /// `PAR1`, Arrow streams with a continuation marker `0xFFFFFFFF`, MCAP with `\x89MCAP0\r\n`).
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
        } else if head.starts_with(MCAP_MAGIC) {
            Some(Format::Mcap)
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

/// Robotics logs imunoise recognises but does not read; the error says how to convert them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unsupported {
    /// A ROS 1 bag (`.bag`, first line `#ROSBAG V2.0`).
    RosBag1,
    /// A ROS 2 bag in SQLite storage (`.db3`, an SQLite 3 database).
    Ros2Sqlite,
    /// A ROS 2 bag directory (holds `metadata.yaml` and the storage files).
    Ros2BagDirectory,
}

impl Unsupported {
    /// Recognises a path by its content (magic bytes) or, when the content names no format imunoise
    /// reads, by its extension.
    pub fn detect(path: &Path) -> Option<Unsupported> {
        if path.is_dir() {
            return path
                .join("metadata.yaml")
                .is_file()
                .then_some(Unsupported::Ros2BagDirectory);
        }
        let mut head = [0u8; 16];
        let n = std::fs::File::open(path)
            .and_then(|mut f| f.read(&mut head))
            .unwrap_or(0);
        let head = &head[..n];
        if head.starts_with(b"#ROSBAG V") {
            return Some(Unsupported::RosBag1);
        }
        if head.starts_with(b"SQLite format 3\0") {
            return Some(Unsupported::Ros2Sqlite);
        }
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        let by_name = match ext.as_str() {
            "bag" => Unsupported::RosBag1,
            "db3" => Unsupported::Ros2Sqlite,
            _ => return None,
        };
        // A file of a readable format under such a name is read.
        Format::sniff(path).is_none().then_some(by_name)
    }

    pub fn what(self) -> &'static str {
        match self {
            Unsupported::RosBag1 => "a ROS 1 bag",
            Unsupported::Ros2Sqlite => "a ROS 2 bag in SQLite storage (.db3)",
            Unsupported::Ros2BagDirectory => "a ROS 2 bag directory",
        }
    }

    /// How to turn `path` into a file imunoise reads.
    pub fn advice(self, path: &Path) -> String {
        match self {
            Unsupported::RosBag1 => "convert it to MCAP: `pip install rosbags`, then \
                 `rosbags-convert --src IN.bag --dst OUT_DIR --dst-storage mcap` and pass the .mcap \
                 file in OUT_DIR (a ROS 2 bag, CDR); or `mcap convert IN.bag OUT.mcap` with \
                 foxglove's mcap CLI (ROS 1 messages in MCAP, also read)"
                .to_string(),
            Unsupported::Ros2Sqlite => "convert the bag to MCAP: `ros2 bag convert -i BAG_DIR -o \
                 out.yaml` with `storage_id: mcap` in out.yaml, or `pip install rosbags` then \
                 `rosbags-convert --src BAG_DIR --dst OUT_DIR --dst-storage mcap`; then pass the \
                 .mcap file"
                .to_string(),
            Unsupported::Ros2BagDirectory => {
                let mut files: Vec<String> = std::fs::read_dir(path)
                    .into_iter()
                    .flatten()
                    .flatten()
                    .map(|e| e.path())
                    .filter(|p| Format::from_extension(p) == Some(Format::Mcap))
                    .map(|p| p.display().to_string())
                    .collect();
                files.sort();
                if files.is_empty() {
                    "it holds no .mcap file (SQLite storage?); convert it to MCAP with `ros2 bag \
                     convert` or `rosbags-convert --src BAG_DIR --dst OUT_DIR --dst-storage mcap`"
                        .to_string()
                } else {
                    format!("pass its .mcap file(s) instead: {}", files.join(" "))
                }
            }
        }
    }
}
