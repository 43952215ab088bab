//! The per-file plots of a screen (`--plots`), kept true to the current results.
//!
//! **When.** A file's limit failures and quality verdicts are known as soon as it is analysed, so
//! the batch plots those files at once, from the analysis it holds. Fleet outliers and unusual
//! effects are known only in the fleet step, when every analysis is gone: those files are
//! analysed again there (the analysis is deterministic, so the plots are the ones the batch
//! would have drawn; they are few by construction), and so is any file the policy wants plotted
//! whose plots are missing (a rerun that adds `--plots`).
//!
//! **Never stale, never half-written.** A folder of plots is written under a temporary name and
//! renamed into place, so an interrupted run leaves no partial folder that looks finished; a
//! recomputed file loses its old plots before its new result is written; the plots of inputs no
//! longer in any shard's run are deleted.

use std::collections::BTreeSet;

use crate::estimate::Backend;
use crate::pipeline::{self, FileResult, Inputs, Silent, Work};

use super::batch::PlotPolicy;
use super::layout::{FleetStepSummary, Layout};
use super::record::Status;

/// Writes the plots of `result` to `DIR/plots/<key>/`, replacing what was there, through a
/// temporary folder beside it.
pub fn write_file_plots(layout: &Layout, key: &str, result: &FileResult) -> Result<(), String> {
    let dir = layout.plots(key);
    let parent = layout.plots_root();
    let parent = parent.as_path();
    std::fs::create_dir_all(parent).map_err(|e| format!("{}: {e}", parent.display()))?;
    let tmp = parent.join(format!(".tmp-{key}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&tmp);
    std::fs::create_dir_all(&tmp).map_err(|e| format!("{}: {e}", tmp.display()))?;
    let written = crate::report::write_plots(&tmp, result).map_err(|e| e.to_string());
    if let Err(e) = written {
        let _ = std::fs::remove_dir_all(&tmp);
        return Err(e);
    }
    remove_file_plots(layout, key)?;
    std::fs::rename(&tmp, &dir).map_err(|e| format!("{}: {e}", dir.display()))
}

/// Deletes `DIR/plots/<key>/` if it exists.
pub fn remove_file_plots(layout: &Layout, key: &str) -> Result<(), String> {
    let dir = layout.plots(key);
    match std::fs::remove_dir_all(&dir) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(format!("{}: {e}", dir.display())),
    }
}

/// What the fleet step's plot pass did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PlotPass {
    /// Keys whose plots were drawn now.
    pub written: Vec<String>,
    /// Keys whose plots could not be drawn, with the reason.
    pub failed: Vec<(String, String)>,
    /// Plot folders of inputs no longer in the run, deleted.
    pub removed: usize,
}

/// After the fleet step: plots for every file `policy` wants that has none (under
/// [`PlotPolicy::Failures`], each file with a flagged channel: limit failures, quality verdicts,
/// outliers, unusual effects), and the plots of inputs no longer listed by any shard deleted.
pub fn plot_after_fleet(
    layout: &Layout,
    step: &FleetStepSummary,
    policy: PlotPolicy,
    inputs: &Inputs,
    work: &Work,
    backend: &dyn Backend,
) -> PlotPass {
    let mut pass = PlotPass::default();
    let listed: BTreeSet<&str> = step
        .fleet
        .rows
        .iter()
        .map(|r| r.record.key.as_str())
        .chain(step.pending.iter().map(|e| e.key.as_str()))
        .chain(step.stale.iter().map(|e| e.key.as_str()))
        .chain(step.unreadable.iter().map(|(e, _)| e.key.as_str()))
        .collect();
    // Only with every shard's manifest is the run's full list of inputs known.
    if step.shards_missing.is_empty() {
        for (key, age_s) in plotted_keys(layout) {
            // A temporary folder may be another shard's write in progress: left for an hour.
            let orphan = if key.starts_with(".tmp-") {
                age_s > 3600.0
            } else {
                !listed.contains(key.as_str())
            };
            if orphan && remove_file_plots(layout, &key).is_ok() {
                pass.removed += 1;
            }
        }
    }
    let mut wanted: Vec<(&str, &str)> = step
        .fleet
        .rows
        .iter()
        .filter(|r| r.record.status == Status::Ok)
        .filter(|r| match policy {
            PlotPolicy::None => false,
            PlotPolicy::Failures => r.flagged,
            PlotPolicy::All => true,
        })
        .map(|r| (r.record.key.as_str(), r.record.path.as_str()))
        .collect();
    wanted.sort_unstable();
    wanted.dedup_by_key(|(k, _)| *k);
    for (key, path) in wanted {
        if layout.plots(key).is_dir() {
            continue;
        }
        let drawn = pipeline::run(std::path::Path::new(path), inputs, work, backend, &Silent)
            .map_err(|e| e.to_string())
            .and_then(|result| write_file_plots(layout, key, &result));
        match drawn {
            Ok(()) => pass.written.push(key.to_string()),
            Err(e) => pass.failed.push((key.to_string(), e)),
        }
    }
    pass
}

/// Keys with a plot folder and the folder's age in seconds (temporary folders of interrupted
/// writes included, under their own names, so that they are cleaned up too).
fn plotted_keys(layout: &Layout) -> Vec<(String, f64)> {
    std::fs::read_dir(layout.plots_root())
        .into_iter()
        .flatten()
        .flatten()
        .filter(|e| e.path().is_dir())
        .map(|e| {
            let age = e
                .metadata()
                .and_then(|m| m.modified())
                .ok()
                .and_then(|t| t.elapsed().ok())
                .map_or(0.0, |d| d.as_secs_f64());
            (e.file_name().to_string_lossy().into_owned(), age)
        })
        .collect()
}
