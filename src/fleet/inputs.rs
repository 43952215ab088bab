//! Which recordings a screen takes, in which order, and which of them a shard takes.
//!
//! Arguments are folders or files. A folder is walked recursively, each level in byte order of
//! the names, taking the files whose extension a reader knows ([`Format::from_extension`]) and
//! skipping hidden entries (names starting with `.`: temporary files, `.git`), symbolic links to
//! folders (no cycles), the output folder (a screen of `.` into `./out` must not read its own
//! Parquet results) and any other folder of this program's outputs ([`is_output_folder`]). A file named as an argument is taken whatever its extension: the reader
//! says what it is. Roots are taken in argument order; a file met twice is taken once, however
//! its path is spelled (compared after resolving links, `.` and `..`), at its first spelling.
//!
//! **The relative path** of an input is its path below the folder argument it was found in, or,
//! for a file argument, its file name; with `/` separators on every platform. It, not the
//! absolute path, names the input in the output (`part-<key>.parquet`) and picks its shard, so
//! that the tasks of a job array agree whatever the mount point each machine sees, and so that a
//! rerun that spells the folder differently (`./fleet`, `/data/fleet`) still finds its results.
//!
//! **Shards.** `K/N` takes the inputs whose key hash is ≡ K (mod N): a stable hash
//! ([`super::hash::fnv64`]) of the relative path. Chosen over the index in the sorted list
//! because it does not move a file to another shard when the fleet grows (a nightly run over a
//! folder that gains recordings recomputes only the new ones); the price is shards that differ in
//! size by about √(n/N) files.

use std::collections::{HashMap, HashSet};
use std::io::BufRead;
use std::path::{Path, PathBuf};

use crate::io::Format;

use super::hash::fnv64;
use super::ScreenError;

/// One recording of the screen.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Input {
    /// The path to open (the root as given joined with the relative path).
    pub path: PathBuf,
    /// Path below its root, `/`-separated (see the module docs).
    pub rel: String,
    /// The sensor's name: the file stem, or the relative path without extension where several
    /// inputs share a stem (`robot07/imu` for `robot07/imu.mcap`).
    pub sensor: String,
    /// Names the input's result: `<stem>-<16 hex digits of the hash>`.
    pub key: String,
    /// The stable hash behind the key and the shard.
    pub hash: u64,
}

impl Input {
    /// Whether shard `shard` takes this input.
    pub fn in_shard(&self, shard: Shard) -> bool {
        self.hash % u64::from(shard.count) == u64::from(shard.index)
    }
}

/// Shard `index` of `count` (0-based: `--array=0-15` gives 0/16 … 15/16).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    pub index: u32,
    pub count: u32,
}

impl Shard {
    /// The whole run as one shard.
    pub const ALL: Shard = Shard { index: 0, count: 1 };
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl std::str::FromStr for Shard {
    type Err = String;

    /// `K/N` with 0 ≤ K < N.
    fn from_str(s: &str) -> Result<Shard, String> {
        let bad = || format!("{s:?}: expected K/N with 0 <= K < N, e.g. 3/16");
        let (k, n) = s.trim().split_once('/').ok_or_else(bad)?;
        let index: u32 = k.trim().parse().map_err(|_| bad())?;
        let count: u32 = n.trim().parse().map_err(|_| bad())?;
        if count == 0 || index >= count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }
}

/// Reads a list of paths, one per line (`-`: standard input); blank lines and lines starting with
/// `#` are skipped. Relative paths are relative to the current folder, as for `tar -T`.
pub fn read_list(list: &Path) -> Result<Vec<PathBuf>, ScreenError> {
    let err = |e: std::io::Error| ScreenError::Input {
        path: list.to_path_buf(),
        message: e.to_string(),
    };
    let reader: Box<dyn BufRead> = if list.as_os_str() == "-" {
        Box::new(std::io::stdin().lock())
    } else {
        Box::new(std::io::BufReader::new(
            std::fs::File::open(list).map_err(err)?,
        ))
    };
    let mut out = Vec::new();
    for line in reader.lines() {
        let line = line.map_err(err)?;
        let t = line.trim();
        if !t.is_empty() && !t.starts_with('#') {
            out.push(PathBuf::from(t));
        }
    }
    Ok(out)
}

/// The inputs named by `args` (folders or files), in order; `exclude` is a folder never entered
/// (the output folder). An argument that does not exist is an input like any file, whose
/// analysis fails with the reader's error (one missing file in a list does not stop the screen);
/// a folder that cannot be read is an error naming it.
pub fn collect_inputs(args: &[PathBuf], exclude: Option<&Path>) -> Result<Vec<Input>, ScreenError> {
    collect_inputs_noting(args, exclude).map(|(inputs, _)| inputs)
}

/// [`collect_inputs`], with the folders left out because they hold this program's own outputs
/// ([`is_output_folder`]), for the caller to name.
pub fn collect_inputs_noting(
    args: &[PathBuf],
    exclude: Option<&Path>,
) -> Result<(Vec<Input>, Vec<PathBuf>), ScreenError> {
    let exclude = exclude.and_then(|p| p.canonicalize().ok());
    let mut skipped = Vec::new();
    // (root index, path, relative path)
    let mut found: Vec<(usize, PathBuf, String)> = Vec::new();
    let mut seen = HashSet::new();
    for (root_index, arg) in args.iter().enumerate() {
        let mut here = Vec::new();
        // An argument that cannot be read (gone since a list was made, mistyped) is taken as a
        // file: its row in the results carries the reader's error, and the others still run.
        if std::fs::metadata(arg).is_ok_and(|m| m.is_dir()) {
            walk(arg, arg, exclude.as_deref(), &mut here, &mut skipped)?;
        } else {
            let name = arg
                .file_name()
                .map_or_else(|| arg.display().to_string(), |n| n.to_string_lossy().into());
            here.push((arg.clone(), name));
        }
        for (path, rel) in here {
            // Met twice however it is spelled (`fleet/u01.arrow`, `./fleet/u01.arrow`, its
            // absolute path, through a linked folder): the same file screened three times had
            // counted three times among its siblings' medians. A path that does not resolve
            // (missing) is compared as written.
            let identity = path.canonicalize().unwrap_or_else(|_| path.clone());
            if seen.insert(identity) {
                found.push((root_index, path, rel));
            }
        }
    }
    // The same relative path under two roots: tell them apart by the root's position.
    let mut rel_count: HashMap<&str, usize> = HashMap::new();
    for (_, _, rel) in &found {
        *rel_count.entry(rel.as_str()).or_default() += 1;
    }
    let hashes: Vec<u64> = found
        .iter()
        .map(|(root, _, rel)| {
            if rel_count[rel.as_str()] > 1 {
                fnv64(format!("{root}:{rel}").as_bytes())
            } else {
                fnv64(rel.as_bytes())
            }
        })
        .collect();
    let stem = |rel: &str| {
        let name = rel.rsplit('/').next().unwrap_or(rel);
        match name.rsplit_once('.') {
            Some((s, _)) if !s.is_empty() => s.to_string(),
            _ => name.to_string(),
        }
    };
    // The relative path without its extension, where it has one.
    let without = |rel: &str| -> String {
        match rel.rsplit_once('.') {
            Some((w, _)) if !w.ends_with('/') && !w.is_empty() => w.to_string(),
            _ => rel.to_string(),
        }
    };
    let mut stem_count: HashMap<String, usize> = HashMap::new();
    let mut without_count: HashMap<String, usize> = HashMap::new();
    for (_, _, rel) in &found {
        *stem_count.entry(stem(rel)).or_default() += 1;
        *without_count.entry(without(rel)).or_default() += 1;
    }
    let inputs = found
        .into_iter()
        .zip(hashes)
        .map(|((_, path, rel), hash)| {
            let s = stem(&rel);
            // The stem; where stems repeat, the path without extension; where that repeats too
            // (`imu.csv` beside `imu.parquet`), the whole relative path.
            let w = without(&rel);
            let sensor = if stem_count[&s] == 1 {
                s.clone()
            } else if without_count[&w] == 1 {
                w
            } else {
                rel.clone()
            };
            Input {
                key: format!("{}-{hash:016x}", sanitize(&s)),
                path,
                rel,
                sensor,
                hash,
            }
        })
        .collect();
    Ok((inputs, skipped))
}

/// A file-name-safe form of a stem: ASCII letters, digits, `_`, `-` and `.`, at most 40 of them.
fn sanitize(stem: &str) -> String {
    let s: String = crate::report::file_safe(stem).chars().take(40).collect();
    if s.is_empty() {
        "input".into()
    } else {
        s
    }
}

/// Whether `dir` holds this program's own outputs: an `analyze`, `psd` or `avar` folder (a
/// `report.json` that ends naming this tool) or a screen's (`results/` beside `manifests/`). Its
/// tables are not recordings: an analysis written inside the fleet's folder had come back as
/// eight error rows ("no sample rate") of the next screen.
pub fn is_output_folder(dir: &Path) -> bool {
    if dir.join("results").is_dir() && dir.join("manifests").is_dir() {
        return true;
    }
    let Ok(mut file) = std::fs::File::open(dir.join("report.json")) else {
        return false;
    };
    use std::io::{Read, Seek, SeekFrom};
    let mut tail = Vec::new();
    let len = file.metadata().map_or(0, |m| m.len());
    file.seek(SeekFrom::Start(len.saturating_sub(256))).is_ok()
        && file.read_to_end(&mut tail).is_ok()
        && String::from_utf8_lossy(&tail).contains("\"tool\": \"imunoise\"")
}

fn walk(
    root: &Path,
    dir: &Path,
    exclude: Option<&Path>,
    out: &mut Vec<(PathBuf, String)>,
    skipped: &mut Vec<PathBuf>,
) -> Result<(), ScreenError> {
    if let (Some(ex), Ok(canon)) = (exclude, dir.canonicalize()) {
        if canon == ex {
            return Ok(());
        }
    }
    if is_output_folder(dir) {
        skipped.push(dir.to_path_buf());
        return Ok(());
    }
    let err = |e: std::io::Error| ScreenError::Input {
        path: dir.to_path_buf(),
        message: e.to_string(),
    };
    let mut entries: Vec<(std::ffi::OsString, PathBuf)> = std::fs::read_dir(dir)
        .map_err(err)?
        .map(|e| e.map(|e| (e.file_name(), e.path())))
        .collect::<Result<_, _>>()
        .map_err(err)?;
    entries.sort();
    for (name, path) in entries {
        if name.to_string_lossy().starts_with('.') {
            continue;
        }
        let link = std::fs::symlink_metadata(&path).map_err(err)?;
        // Follows links to files; a link to a folder could make a cycle.
        let Ok(meta) = std::fs::metadata(&path) else {
            continue;
        };
        if meta.is_dir() {
            if !link.file_type().is_symlink() {
                walk(root, &path, exclude, out, skipped)?;
            }
        } else if meta.is_file() && Format::from_extension(&path).is_some() {
            out.push((path.clone(), relative(root, &path)));
        }
    }
    Ok(())
}

/// `path` below `root`, `/`-separated.
fn relative(root: &Path, path: &Path) -> String {
    let rel = path.strip_prefix(root).unwrap_or(path);
    rel.components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect::<Vec<_>>()
        .join("/")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shard_parses_and_partitions() {
        assert_eq!(
            "3/16".parse::<Shard>().unwrap(),
            Shard {
                index: 3,
                count: 16
            }
        );
        for bad in ["16/16", "1/0", "a/2", "3", "-1/2"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
        let dir = tempfile::tempdir().unwrap();
        for name in [
            "b.arrow",
            "a.csv",
            "sub/c.parquet",
            "sub/.hidden.csv",
            "notes.txt",
        ] {
            let p = dir.path().join(name);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(&p, "x").unwrap();
        }
        let inputs = collect_inputs(&[dir.path().to_path_buf()], None).unwrap();
        let rels: Vec<&str> = inputs.iter().map(|i| i.rel.as_str()).collect();
        assert_eq!(rels, ["a.csv", "b.arrow", "sub/c.parquet"]);
        // Every input in exactly one of three shards.
        for i in &inputs {
            let n = (0..3)
                .filter(|&k| i.in_shard(Shard { index: k, count: 3 }))
                .count();
            assert_eq!(n, 1);
        }
        // The key depends on the relative path only, not on how the root is spelled.
        let again = collect_inputs(&[dir.path().join("sub").join("..")], None).unwrap();
        assert_eq!(
            inputs.iter().map(|i| &i.key).collect::<Vec<_>>(),
            again.iter().map(|i| &i.key).collect::<Vec<_>>()
        );
        assert_eq!(inputs[2].key, format!("c-{:016x}", fnv64(b"sub/c.parquet")));
    }

    #[test]
    fn shared_stems_get_their_folder_and_the_output_folder_is_skipped() {
        let dir = tempfile::tempdir().unwrap();
        for name in [
            "r1/imu.mcap",
            "r2/imu.mcap",
            "r3/imu.csv",
            "r3/imu.parquet",
            "out/results/part-x.parquet",
        ] {
            let p = dir.path().join(name);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(&p, "x").unwrap();
        }
        // An analysis written inside the fleet's folder, and another screen's output folder.
        let analysis = dir.path().join("r1/analysis");
        std::fs::create_dir_all(analysis.join("imu")).unwrap();
        std::fs::write(analysis.join("psd.arrow"), "x").unwrap();
        std::fs::write(analysis.join("imu/plot.csv"), "x").unwrap();
        std::fs::write(
            analysis.join("report.json"),
            "{\n  \"schema_version\": 8,\n  \"tool\": \"imunoise\",\n  \"version\": \"0.1.0\"\n}\n",
        )
        .unwrap();
        let screen = dir.path().join("old_screen");
        for sub in ["results/shard=0", "manifests"] {
            std::fs::create_dir_all(screen.join(sub)).unwrap();
        }
        std::fs::write(screen.join("results/shard=0/part-a.parquet"), "x").unwrap();
        let (inputs, skipped) =
            collect_inputs_noting(&[dir.path().to_path_buf()], Some(&dir.path().join("out")))
                .unwrap();
        assert_eq!(skipped, [screen, analysis]);
        let sensors: Vec<&str> = inputs.iter().map(|i| i.sensor.as_str()).collect();
        // The same stem in one folder: the extension tells them apart.
        assert_eq!(
            sensors,
            ["r1/imu", "r2/imu", "r3/imu.csv", "r3/imu.parquet"]
        );
        assert_ne!(inputs[0].key, inputs[1].key);
        assert_ne!(inputs[2].key, inputs[3].key);
    }

    /// One file named by four spellings (and found again in its folder) is one input, at its
    /// first spelling.
    #[test]
    fn a_file_spelled_several_ways_is_taken_once() {
        let dir = tempfile::tempdir().unwrap();
        let sub = dir.path().join("fleet");
        std::fs::create_dir_all(&sub).unwrap();
        for name in ["u01.arrow", "u02.arrow"] {
            std::fs::write(sub.join(name), "x").unwrap();
        }
        let file = sub.join("u01.arrow");
        let spellings = vec![
            file.clone(),
            sub.join(".").join("u01.arrow"),
            sub.join("..").join("fleet").join("u01.arrow"),
            file.canonicalize().unwrap(),
            sub.clone(),
        ];
        let inputs = collect_inputs(&spellings, None).unwrap();
        let paths: Vec<&Path> = inputs.iter().map(|i| i.path.as_path()).collect();
        assert_eq!(paths, [file.as_path(), sub.join("u02.arrow").as_path()]);
    }

    #[test]
    fn a_missing_argument_is_an_input_whose_reading_fails_later() {
        let dir = tempfile::tempdir().unwrap();
        let there = dir.path().join("a.arrow");
        std::fs::write(&there, "x").unwrap();
        let gone = dir.path().join("gone.arrow");
        let inputs = collect_inputs(&[there, gone.clone()], None).unwrap();
        assert_eq!(inputs.len(), 2);
        assert_eq!(inputs[1].path, gone);
        assert_eq!(inputs[1].sensor, "gone");
    }
}
