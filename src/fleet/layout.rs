//! The output folder, and the fleet step that reads it back.
//!
//! ```text
//! DIR/results/shard=K/part-<key>.parquet   one per input, written as soon as it is done
//! DIR/manifests/shard-K-of-N.json          the keys of shard K's current inputs
//! DIR/fleet.parquet, summary.md, fleet.html   the fleet step's outputs
//! DIR/plots/<key>/                          per-file plots (--plots)
//! DIR/.lock-shard-K, DIR/.lock-fleet        locks (see [`super::lock`])
//! ```
//! `results/` is a hive-partitioned dataset: DuckDB, DataFusion, Spark and pyarrow read
//! `DIR/results/**/*.parquet` as one table, with `shard` as a column from the folder name.
//!
//! **What the fleet step counts** (the rule for results that are no longer part of the run): the
//! inputs listed in the manifests of the current shard count N, each read from its own shard's
//! folder, and only when the part file was computed with the run's options. A shard rewrites its
//! manifest at the start of every run and, at the end, deletes from its own folder the part files
//! of inputs that are no longer inputs of the run at all (every shard lists all inputs before
//! taking its share, so it knows). So an input removed from the fleet disappears from the fleet
//! table at the next run, results of a run with other options are not mixed in, and a shard not
//! run yet is reported as pending, not silently missing. After a change of the shard count a
//! result sits in the folder of its old shard until its new shard's run moves it over (instead of
//! recomputing it); until then a glob over `results/` may see it twice, the fleet step never.
//! Part files left in folders of shards ≥ N are not read; the summary counts them.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::report::write_atomically;

use super::assess::{assess, Fleet};
use super::inputs::{Input, Shard};
use super::record::ChannelRecord;
use super::spec::Spec;
use super::table::{read_part, read_part_meta, write_fleet};
use super::{ScreenError, SCHEMA_VERSION};

/// Paths inside an output folder.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Layout {
    pub dir: PathBuf,
}

impl Layout {
    pub fn new(dir: impl Into<PathBuf>) -> Self {
        Layout { dir: dir.into() }
    }
    pub fn results(&self) -> PathBuf {
        self.dir.join("results")
    }
    pub fn shard_dir(&self, index: u32) -> PathBuf {
        self.results().join(format!("shard={index}"))
    }
    pub fn part(&self, index: u32, key: &str) -> PathBuf {
        self.shard_dir(index).join(format!("part-{key}.parquet"))
    }
    pub fn manifests(&self) -> PathBuf {
        self.dir.join("manifests")
    }
    pub fn manifest(&self, shard: Shard) -> PathBuf {
        self.manifests()
            .join(format!("shard-{}-of-{}.json", shard.index, shard.count))
    }
    pub fn shard_lock(&self, index: u32) -> PathBuf {
        self.dir.join(format!(".lock-shard-{index}"))
    }
    pub fn fleet_lock(&self) -> PathBuf {
        self.dir.join(".lock-fleet")
    }
    pub fn fleet_table(&self) -> PathBuf {
        self.dir.join("fleet.parquet")
    }
    pub fn summary(&self) -> PathBuf {
        self.dir.join("summary.md")
    }
    pub fn html(&self) -> PathBuf {
        self.dir.join("fleet.html")
    }
    pub fn plots(&self, key: &str) -> PathBuf {
        self.plots_root().join(key)
    }

    /// The folder holding every input's plots.
    pub fn plots_root(&self) -> PathBuf {
        self.dir.join("plots")
    }

    /// The shard folders present, by index.
    pub fn shard_dirs(&self) -> Vec<(u32, PathBuf)> {
        let mut out: Vec<(u32, PathBuf)> = std::fs::read_dir(self.results())
            .into_iter()
            .flatten()
            .flatten()
            .filter_map(|e| {
                let name = e.file_name().to_string_lossy().into_owned();
                let k: u32 = name.strip_prefix("shard=")?.parse().ok()?;
                Some((k, e.path()))
            })
            .collect();
        out.sort();
        out
    }

    /// The keys of the part files in shard folder `index`.
    pub fn part_keys(&self, index: u32) -> BTreeSet<String> {
        std::fs::read_dir(self.shard_dir(index))
            .into_iter()
            .flatten()
            .flatten()
            .filter_map(|e| {
                let name = e.file_name().to_string_lossy().into_owned();
                Some(
                    name.strip_prefix("part-")?
                        .strip_suffix(".parquet")?
                        .to_string(),
                )
            })
            .collect()
    }
}

/// One input as a manifest lists it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ManifestEntry {
    pub key: String,
    pub path: String,
    pub rel: String,
}

/// An input as a manifest lists it.
fn entry(i: &Input) -> ManifestEntry {
    ManifestEntry {
        key: i.key.clone(),
        path: i.path.display().to_string(),
        rel: i.rel.clone(),
    }
}

/// The inputs of one shard's current run.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Manifest {
    pub schema: u32,
    pub shard: u32,
    pub shards: u32,
    /// [`super::hash::options_hash`] of the run.
    pub options: String,
    pub inputs: Vec<ManifestEntry>,
}

impl Manifest {
    pub fn new(shard: Shard, options: &str, inputs: &[&Input]) -> Self {
        Manifest {
            schema: SCHEMA_VERSION,
            shard: shard.index,
            shards: shard.count,
            options: options.to_string(),
            inputs: inputs.iter().map(|i| entry(i)).collect(),
        }
    }

    pub fn write(&self, layout: &Layout) -> Result<(), ScreenError> {
        let dir = layout.manifests();
        std::fs::create_dir_all(&dir).map_err(|e| ScreenError::output(&dir, e))?;
        let text = serde_json::to_string_pretty(self).map_err(|e| ScreenError::output(&dir, e))?;
        let path = layout.manifest(Shard {
            index: self.shard,
            count: self.shards,
        });
        write_atomically(&path, |w| {
            use std::io::Write;
            w.write_all(text.as_bytes())
        })?;
        Ok(())
    }

    /// The manifest of `shard`, if one was written (and reads).
    pub fn read(layout: &Layout, shard: Shard) -> Option<Manifest> {
        let text = std::fs::read_to_string(layout.manifest(shard)).ok()?;
        serde_json::from_str(&text).ok()
    }
}

/// Deletes from shard folder `index` the part files whose key `keep` lacks; returns how many.
pub fn prune(layout: &Layout, index: u32, keep: &BTreeSet<String>) -> Result<usize, ScreenError> {
    let mut removed = 0;
    for key in layout.part_keys(index) {
        if !keep.contains(&key) {
            let p = layout.part(index, &key);
            std::fs::remove_file(&p).map_err(|e| ScreenError::output(&p, e))?;
            removed += 1;
        }
    }
    Ok(removed)
}

/// What the fleet step found.
#[derive(Debug, Clone, PartialEq)]
pub struct FleetStepSummary {
    pub fleet: Fleet,
    pub shards: u32,
    /// Shards with no manifest yet.
    pub shards_missing: Vec<u32>,
    /// Inputs whose result is not there yet: listed by their shard's manifest, or, for a shard
    /// that has not run yet, by this run's list of every input.
    pub pending: Vec<ManifestEntry>,
    /// Inputs whose result was computed with other options (not counted).
    pub stale: Vec<ManifestEntry>,
    /// Inputs whose part file has a footer but whose rows do not read (not counted; the next run
    /// of the shard recomputes them only if their footer no longer matches, so the message says
    /// to delete them).
    pub unreadable: Vec<(ManifestEntry, String)>,
    /// Part files in shard folders ≥ N (not read).
    pub orphans: usize,
    /// Inputs counted.
    pub files: usize,
}

impl FleetStepSummary {
    /// The shards with no manifest yet as `K/N, …` (`None`: every shard has run); their inputs
    /// are among the pending ones.
    pub fn shards_not_run(&self) -> Option<String> {
        (!self.shards_missing.is_empty()).then(|| {
            self.shards_missing
                .iter()
                .map(|k| format!("{k}/{}", self.shards))
                .collect::<Vec<_>>()
                .join(", ")
        })
    }
}

/// Reads the results of the run's shards (see the module docs for what counts), judges them and
/// writes `fleet.parquet`, `summary.md` and `fleet.html`. `inputs`: every input of the run (each
/// shard lists them all before taking its share), so that the inputs of a shard that has not run
/// yet are pending too, not only its number.
pub fn fleet_step(
    layout: &Layout,
    shards: u32,
    options: &str,
    spec: &Spec,
    title: &str,
    inputs: &[Input],
) -> Result<FleetStepSummary, ScreenError> {
    let mut records: Vec<ChannelRecord> = Vec::new();
    let (mut pending, mut stale, mut missing) = (Vec::new(), Vec::new(), Vec::new());
    let mut unreadable = Vec::new();
    let mut files = 0;
    for index in 0..shards {
        let Some(m) = Manifest::read(
            layout,
            Shard {
                index,
                count: shards,
            },
        ) else {
            missing.push(index);
            let shard = Shard {
                index,
                count: shards,
            };
            pending.extend(inputs.iter().filter(|i| i.in_shard(shard)).map(entry));
            continue;
        };
        for e in m.inputs {
            let part = layout.part(index, &e.key);
            match read_part_meta(&part) {
                None => pending.push(e),
                Some(meta) if meta.options != options || meta.schema != SCHEMA_VERSION => {
                    stale.push(e)
                }
                Some(_) => match read_part(&part) {
                    Ok(rows) => {
                        records.extend(rows);
                        files += 1;
                    }
                    Err(err) => unreadable.push((e, err.to_string())),
                },
            }
        }
    }
    let orphans = layout
        .shard_dirs()
        .into_iter()
        .filter(|(k, _)| *k >= shards)
        .map(|(k, _)| layout.part_keys(k).len())
        .sum();
    let fleet = assess(records, spec);
    let summary = FleetStepSummary {
        fleet,
        shards,
        shards_missing: missing,
        pending,
        stale,
        unreadable,
        orphans,
        files,
    };
    write_fleet(&layout.fleet_table(), &summary.fleet.rows)?;
    let md = super::summary::markdown(&summary, title);
    write_atomically(&layout.summary(), |w| {
        use std::io::Write;
        w.write_all(md.as_bytes())
    })?;
    let html = super::html::page(&summary, title);
    write_atomically(&layout.html(), |w| {
        use std::io::Write;
        w.write_all(html.as_bytes())
    })?;
    // The fleet step holds the fleet lock: a temporary of a dead process here is a killed step's.
    crate::report::sweep_temporaries(&layout.dir);
    Ok(summary)
}

/// Looks for an up-to-date result of `key` in another shard's folder (left by a run with another
/// shard count) and moves it into `index`'s; returns whether it did.
pub fn adopt(
    layout: &Layout,
    index: u32,
    key: &str,
    ok: impl Fn(&Path) -> bool,
) -> Result<bool, ScreenError> {
    for (k, _) in layout.shard_dirs() {
        if k == index {
            continue;
        }
        let from = layout.part(k, key);
        if from.is_file() && ok(&from) {
            let to = layout.part(index, key);
            std::fs::rename(&from, &to).map_err(|e| ScreenError::output(&to, e))?;
            return Ok(true);
        }
    }
    Ok(false)
}
