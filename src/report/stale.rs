//! Outputs of an earlier run that this run did not rewrite.
//!
//! `analyze -o DIR` writes one folder per recording (`DIR/<stem>/imu.yaml`, `plots/`). Run again
//! into the same folder with fewer recordings, or with a recording that now fails, and the earlier
//! run's folder would stay beside the new ones looking current: a noise model of a file this run
//! did not analyse, next to a summary.md and report.json that do not mention it. So after
//! writing, the run moves what an earlier run wrote and it did not out of the way, without
//! deleting anything a user may still want:
//!
//! - a sub-folder of `DIR` whose `imu.yaml` starts with [`KALIBR_HEADER`] (one this program wrote)
//!   and that this run did not write moves whole to `DIR/`[`EARLIER_RUNS`]`/<name>` (replacing a
//!   folder of that name an even earlier run left there);
//! - in a folder this run did write, figures of channels it no longer has are deleted (the new
//!   run's figures replace the rest of them anyway).
//!
//! Nothing else is touched: a folder without our `imu.yaml` is not ours.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use super::atomic::OutputError;
use super::kalibr::KALIBR_HEADER;

/// Where per-recording folders of earlier runs go.
pub const EARLIER_RUNS: &str = "earlier-runs";

/// Whether `path` names a figure of ours (by extension).
fn is_figure(path: &Path) -> bool {
    matches!(
        path.extension().and_then(|e| e.to_str()),
        Some("svg" | "png")
    )
}

/// Whether `folder` holds an `imu.yaml` this program wrote.
fn is_ours(folder: &Path) -> bool {
    use std::io::Read;
    let mut head = [0u8; KALIBR_HEADER.len()];
    std::fs::File::open(folder.join("imu.yaml"))
        .and_then(|mut f| f.read_exact(&mut head))
        .is_ok_and(|()| head == KALIBR_HEADER.as_bytes())
}

/// Removes the figures in `plots` whose file names are not in `keep`; the number removed.
pub fn prune_figures(plots: &Path, keep: &HashSet<PathBuf>) -> Result<usize, OutputError> {
    let entries = match std::fs::read_dir(plots) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(0),
        Err(e) => return Err(OutputError::new(plots, e)),
    };
    let mut removed = 0;
    for entry in entries {
        let path = entry.map_err(|e| OutputError::new(plots, e))?.path();
        if path.is_file() && is_figure(&path) && !keep.contains(&path) {
            std::fs::remove_file(&path).map_err(|e| OutputError::new(&path, e))?;
            removed += 1;
        }
    }
    Ok(removed)
}

/// Moves the per-recording folders of an earlier run that are not among `current` (folder names)
/// from `dir` to `dir/`[`EARLIER_RUNS`]; returns the names of those moved, sorted.
pub fn retire_stale_folders(
    dir: &Path,
    current: &HashSet<String>,
) -> Result<Vec<String>, OutputError> {
    let entries = std::fs::read_dir(dir).map_err(|e| OutputError::new(dir, e))?;
    let mut stale = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| OutputError::new(dir, e))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        let folder = entry.path();
        if !current.contains(&name) && folder.is_dir() && is_ours(&folder) {
            stale.push(name);
        }
    }
    stale.sort();
    if stale.is_empty() {
        return Ok(stale);
    }
    let earlier = dir.join(EARLIER_RUNS);
    std::fs::create_dir_all(&earlier).map_err(|e| OutputError::new(&earlier, e))?;
    for name in &stale {
        let to = earlier.join(name);
        if to.exists() {
            std::fs::remove_dir_all(&to).map_err(|e| OutputError::new(&to, e))?;
        }
        let from = dir.join(name);
        std::fs::rename(&from, &to).map_err(|e| OutputError::new(&from, e))?;
    }
    Ok(stale)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ours(dir: &Path, name: &str, figures: &[&str]) -> PathBuf {
        let folder = dir.join(name);
        std::fs::create_dir_all(folder.join("plots")).unwrap();
        std::fs::write(
            folder.join("imu.yaml"),
            format!("{KALIBR_HEADER} 0.1.0\nrate_hz: 100\n"),
        )
        .unwrap();
        for f in figures {
            std::fs::write(folder.join("plots").join(f), "x").unwrap();
        }
        folder
    }

    #[test]
    fn only_our_folders_not_in_the_run_move_aside_whole() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path();
        let kept = ours(dir, "kept", &["gx_avar.svg"]);
        ours(dir, "gone", &["gx_avar.svg", "gx_psd.png"]);
        std::fs::write(dir.join("gone").join("notes.txt"), "mine").unwrap();
        // An even earlier run's folder of the same name is replaced.
        ours(&dir.join(EARLIER_RUNS), "gone", &["old.svg"]);
        // A folder of the user's with an imu.yaml of its own.
        let theirs = dir.join("theirs");
        std::fs::create_dir_all(&theirs).unwrap();
        std::fs::write(theirs.join("imu.yaml"), "accelerometer_noise_density: 1\n").unwrap();
        std::fs::write(dir.join("summary.md"), "x").unwrap();

        let current: HashSet<String> = ["kept".to_string()].into();
        let moved = retire_stale_folders(dir, &current).unwrap();
        assert_eq!(moved, vec!["gone".to_string()]);
        assert!(kept.join("imu.yaml").exists() && kept.join("plots/gx_avar.svg").exists());
        assert!(!dir.join("gone").exists());
        let aside = dir.join(EARLIER_RUNS).join("gone");
        for f in [
            "imu.yaml",
            "notes.txt",
            "plots/gx_avar.svg",
            "plots/gx_psd.png",
        ] {
            assert!(aside.join(f).exists(), "{f} moved with its folder");
        }
        assert!(
            !aside.join("plots/old.svg").exists(),
            "the even earlier one replaced"
        );
        assert!(theirs.join("imu.yaml").exists(), "not ours: untouched");
        assert!(dir.join("summary.md").exists());
        // Nothing stale: nothing moves, and no empty folder is made.
        let again = tempfile::tempdir().unwrap();
        ours(again.path(), "kept", &[]);
        assert!(retire_stale_folders(again.path(), &current)
            .unwrap()
            .is_empty());
        assert!(!again.path().join(EARLIER_RUNS).exists());
    }

    #[test]
    fn figures_of_channels_no_longer_written_are_pruned() {
        let tmp = tempfile::tempdir().unwrap();
        let folder = ours(
            tmp.path(),
            "r",
            &["gx_avar.svg", "old_avar.svg", "old_psd.png"],
        );
        let plots = folder.join("plots");
        std::fs::write(plots.join("readme.txt"), "mine").unwrap();
        let keep: HashSet<PathBuf> = [plots.join("gx_avar.svg")].into();
        assert_eq!(prune_figures(&plots, &keep).unwrap(), 2);
        assert!(plots.join("gx_avar.svg").exists() && plots.join("readme.txt").exists());
        assert!(!plots.join("old_avar.svg").exists() && !plots.join("old_psd.png").exists());
    }
}
