//! Writing files so that a reader never sees half of one: write to a temporary name beside the target,
//! flush and sync, then rename over it. A run that dies midway leaves the previous output intact.

use std::fs::{self, File};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Writes `path` atomically: `write` fills a buffered writer on a temporary file, which replaces `path`
/// only when `write` succeeded.
pub fn write_atomically<E>(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> Result<(), E>,
) -> Result<(), OutputError>
where
    E: std::fmt::Display,
{
    let tmp = temporary_name(path);
    // Errors name the file the user asked for, never the temporary one.
    let fail = |e: &dyn std::fmt::Display| OutputError::new(path, e);
    let result = (|| {
        let file = File::create(&tmp).map_err(|e| {
            let parent = path.parent().filter(|p| !p.as_os_str().is_empty());
            match parent {
                Some(dir) if !dir.is_dir() => {
                    OutputError::new(path, format!("the folder {} does not exist", dir.display()))
                }
                _ => fail(&e),
            }
        })?;
        let mut out = BufWriter::new(file);
        write(&mut out).map_err(|e| fail(&e))?;
        out.flush().map_err(|e| fail(&e))?;
        out.get_ref().sync_all().map_err(|e| fail(&e))?;
        fs::rename(&tmp, path).map_err(|e| fail(&e))
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result
}

/// `dir/name.ext` → `dir/.name.ext.<pid>.tmp`: hidden, unique per process, same filesystem.
fn temporary_name(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

/// Removes what [`write_atomically`] left in `dir` (not its sub-folders) when the process writing
/// died before the rename (a SIGINT, a kill, a crash): hidden files `.NAME.PID.tmp` whose process
/// no longer runs. The finished outputs beside them are whole (that is what the rename is for);
/// the temporaries are only litter, which a later run into the same folder clears. A temporary of
/// a process that still runs (another run writing into the folder) is left alone; where the
/// running processes cannot be listed (no `/proc`), one is removed only when an hour old. Returns
/// how many were removed; a folder that cannot be read has none.
pub fn sweep_temporaries(dir: &Path) -> usize {
    let Ok(entries) = fs::read_dir(dir) else {
        return 0;
    };
    let own = std::process::id();
    let mut removed = 0;
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let Some(pid) = temporary_pid(&name) else {
            continue;
        };
        if pid == own || !entry.file_type().is_ok_and(|t| t.is_file()) {
            continue;
        }
        if writer_is_gone(pid, &entry.path()) && fs::remove_file(entry.path()).is_ok() {
            removed += 1;
        }
    }
    removed
}

/// The process id in a name [`temporary_name`] makes (`.out.csv.4242.tmp` → 4242).
fn temporary_pid(name: &str) -> Option<u32> {
    let stem = name.strip_prefix('.')?.strip_suffix(".tmp")?;
    let (target, pid) = stem.rsplit_once('.')?;
    if target.is_empty() {
        return None;
    }
    pid.parse().ok()
}

/// Whether the process `pid` that wrote the temporary `path` no longer runs.
fn writer_is_gone(pid: u32, path: &Path) -> bool {
    let proc = Path::new("/proc");
    if proc.join("self").exists() {
        return !proc.join(pid.to_string()).exists();
    }
    const HOUR: std::time::Duration = std::time::Duration::from_secs(3600);
    fs::metadata(path)
        .and_then(|m| m.modified())
        .ok()
        .and_then(|t| t.elapsed().ok())
        .is_some_and(|age| age > HOUR)
}

/// A failure to write an output file.
#[derive(Debug, thiserror::Error)]
#[error("cannot write {path}: {message}")]
pub struct OutputError {
    pub path: PathBuf,
    pub message: String,
}

impl OutputError {
    pub fn new(path: &Path, e: impl std::fmt::Display) -> Self {
        OutputError {
            path: path.to_path_buf(),
            message: e.to_string(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn temporaries_of_dead_writers_are_swept_and_nothing_else() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        // A pid beyond the kernel's limit (2^22) never runs.
        let dead = d.join(".imu.yaml.4194999.tmp");
        let own = temporary_name(&d.join("summary.md"));
        let alive_pid = std::process::Command::new("sleep")
            .arg("5")
            .spawn()
            .unwrap();
        let alive = d.join(format!(".report.json.{}.tmp", alive_pid.id()));
        let keep = ["out.csv", ".hidden", "notes.tmp", ".x.notapid.tmp", "..tmp"];
        for p in [&dead, &own, &alive] {
            fs::write(p, "half").unwrap();
        }
        for k in keep {
            fs::write(d.join(k), "mine").unwrap();
        }
        fs::create_dir(d.join(".plots.4194998.tmp")).unwrap();
        assert_eq!(sweep_temporaries(d), 1);
        assert!(!dead.exists());
        assert!(own.exists(), "this run's own write in progress is left");
        assert!(alive.exists(), "a running writer's temporary is left");
        assert!(
            d.join(".plots.4194998.tmp").is_dir(),
            "folders are not ours"
        );
        for k in keep {
            assert!(d.join(k).exists(), "{k}");
        }
        let mut child = alive_pid;
        let _ = child.kill();
        let _ = child.wait();
        assert_eq!(sweep_temporaries(d), 1, "the writer gone");
        assert!(own.exists());
        assert_eq!(sweep_temporaries(&d.join("missing")), 0);
    }

    #[test]
    fn a_failed_write_leaves_the_old_file_and_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.csv");
        fs::write(&path, "old").unwrap();
        let err = write_atomically(&path, |w| {
            w.write_all(b"half").map_err(|e| e.to_string())?;
            Err::<(), _>("disk on fire".to_string())
        })
        .unwrap_err();
        assert!(err.to_string().contains("disk on fire"));
        assert_eq!(fs::read_to_string(&path).unwrap(), "old");
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 1);
        write_atomically(&path, |w| w.write_all(b"new")).unwrap();
        assert_eq!(fs::read_to_string(&path).unwrap(), "new");
    }

    #[test]
    fn a_missing_folder_is_named_not_the_temporary_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("nowhere").join("out.arrow");
        let err = write_atomically(&path, |w| w.write_all(b"x")).unwrap_err();
        let text = err.to_string();
        assert!(
            text.contains("out.arrow") && text.contains("does not exist"),
            "{text}"
        );
        assert!(!text.contains(".out.arrow."), "{text}");
    }
}
