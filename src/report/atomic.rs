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
