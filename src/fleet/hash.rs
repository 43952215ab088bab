//! Fingerprints that decide what a rerun may skip, and the stable hash behind shards and keys.
//!
//! **The hash.** 64-bit FNV-1a, written out here: it must give the same value on every machine,
//! every build and every Rust release (a job array's tasks agree on who takes which file only if
//! they hash alike), which `std`'s `DefaultHasher` does not promise. It is not cryptographic and
//! need not be: it tells honest changes apart, it does not resist forgery.
//!
//! **A file's identity** is its size, its modification time (ns) and the hash of its first and
//! last MiB. Why not a hash of the whole content: a rerun of a fleet of multi-gigabyte logs would
//! read every byte just to learn that nothing changed (seconds per GB, the cost of the analysis'
//! own read for a large part of it), while the cheap identity already catches what happens to
//! recordings in practice: a rewritten or appended file changes its size, its time and its footer
//! (Parquet, Arrow and MCAP files keep their index at the end); a copy that resets the time is
//! recomputed, which costs time but never gives a wrong answer. What it misses: a same-size
//! rewrite of the middle bytes within the clock's resolution with the time set back.
//!
//! **The options' hash** covers everything that changes a file's result: the analysis options as
//! recorded in the output document, the residual loop switch, the crate version and commit, and
//! [`super::SCHEMA_VERSION`].

use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;
use std::time::UNIX_EPOCH;

use serde_json::Value;

/// Bytes hashed at each end of a file for its identity.
pub const IDENTITY_SPAN: u64 = 1 << 20;

/// 64-bit FNV-1a (Fowler–Noll–Vo), byte by byte.
#[derive(Debug, Clone, Copy)]
pub struct Fnv64(u64);

impl Fnv64 {
    const OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
    const PRIME: u64 = 0x0000_0100_0000_01b3;

    pub const fn new() -> Self {
        Fnv64(Self::OFFSET)
    }

    pub fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(Self::PRIME);
        }
    }

    pub fn finish(&self) -> u64 {
        self.0
    }
}

impl Default for Fnv64 {
    fn default() -> Self {
        Self::new()
    }
}

/// FNV-1a of `bytes`.
pub fn fnv64(bytes: &[u8]) -> u64 {
    let mut h = Fnv64::new();
    h.write(bytes);
    h.finish()
}

/// The identity of the file at `path` as one string:
/// `size=<bytes>;mtime_ns=<ns since 1970>;ends=<hex hash of the first and last MiB>`.
pub fn file_identity(path: &Path) -> std::io::Result<String> {
    let mut file = File::open(path)?;
    let meta = file.metadata()?;
    let size = meta.len();
    let mtime_ns = meta
        .modified()
        .ok()
        .and_then(|t| t.duration_since(UNIX_EPOCH).ok())
        .map_or(0, |d| d.as_nanos());
    let mut h = Fnv64::new();
    let head_len = size.min(IDENTITY_SPAN);
    let mut buf = vec![0u8; head_len as usize];
    file.read_exact(&mut buf)?;
    h.write(&buf);
    // The last MiB, without re-reading the head of a small file.
    let tail_len = (size - head_len).min(IDENTITY_SPAN);
    if tail_len > 0 {
        file.seek(SeekFrom::Start(size - tail_len))?;
        buf.resize(tail_len as usize, 0);
        file.read_exact(&mut buf)?;
        h.write(&buf);
    }
    Ok(format!(
        "size={size};mtime_ns={mtime_ns};ends={:016x}",
        h.finish()
    ))
}

/// `value` as JSON with every object's keys sorted: the same options give the same text whatever
/// order the map kept them in (serde_json's map order depends on a feature other crates may
/// switch on).
pub fn canonical_json(value: &Value) -> String {
    match value {
        Value::Object(map) => {
            let mut keys: Vec<&String> = map.keys().collect();
            keys.sort();
            let items: Vec<String> = keys
                .into_iter()
                .map(|k| format!("{}:{}", Value::String(k.clone()), canonical_json(&map[k])))
                .collect();
            format!("{{{}}}", items.join(","))
        }
        Value::Array(items) => {
            let items: Vec<String> = items.iter().map(canonical_json).collect();
            format!("[{}]", items.join(","))
        }
        other => other.to_string(),
    }
}

/// The hash of the analysis options (`options`: what changes a file's result), with the crate
/// version, commit and schema version mixed in, as 16 hex digits.
pub fn options_hash(options: &Value) -> String {
    let full = serde_json::json!({
        "options": options,
        "version": env!("CARGO_PKG_VERSION"),
        "commit": env!("IMUNOISE_COMMIT"),
        "schema": super::SCHEMA_VERSION,
    });
    format!("{:016x}", fnv64(canonical_json(&full).as_bytes()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv_matches_the_published_test_vectors() {
        // From the FNV reference (Fowler, Noll, Vo): FNV-1a 64 of "" and "a" and "foobar".
        assert_eq!(fnv64(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv64(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv64(b"foobar"), 0x8594_4171_f739_67e8);
    }

    #[test]
    fn canonical_json_ignores_key_order() {
        let a: Value = serde_json::from_str(r#"{"b":1,"a":{"y":[1,2],"x":null}}"#).unwrap();
        let b: Value = serde_json::from_str(r#"{"a":{"x":null,"y":[1,2]},"b":1}"#).unwrap();
        assert_eq!(canonical_json(&a), canonical_json(&b));
        assert_eq!(canonical_json(&a), r#"{"a":{"x":null,"y":[1,2]},"b":1}"#);
        assert_eq!(options_hash(&a), options_hash(&b));
        let c: Value = serde_json::from_str(r#"{"a":{"x":null,"y":[1,3]},"b":1}"#).unwrap();
        assert_ne!(options_hash(&a), options_hash(&c));
    }

    #[test]
    fn identity_changes_with_the_tail_and_not_with_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.bin");
        let mut data = vec![7u8; 3 << 20];
        std::fs::write(&p, &data).unwrap();
        let a = file_identity(&p).unwrap();
        assert_eq!(a, file_identity(&p).unwrap());
        let mtime = std::fs::metadata(&p).unwrap().modified().unwrap();
        *data.last_mut().unwrap() = 8;
        std::fs::write(&p, &data).unwrap();
        // Same size; set the time back so that only the tail hash can tell.
        let f = File::options().write(true).open(&p).unwrap();
        f.set_modified(mtime).unwrap();
        drop(f);
        let b = file_identity(&p).unwrap();
        assert_ne!(a, b);
        assert!(a.starts_with("size=3145728;"), "{a}");
    }
}
