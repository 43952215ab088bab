//! Outputs: long tables (Arrow IPC, CSV), one JSON document per run (`report.json`), and for
//! `analyze` the Markdown summary, plots and Kalibr `imu.yaml`; all written atomically.
//!
//! The JSON document has the same shape for every command (`info`, `psd`, `avar`, `analyze`): a header
//! (schema version, tool version, command, backend, options), one entry per input file with either its
//! results or its error (message, file, column, row), and a summary. Its schema is
//! `schema/imunoise-output.schema.json`; the README describes it.

mod atomic;
mod figures;
pub mod format;
mod info;
mod json_layout;
mod kalibr;
mod model;
pub mod plot;
mod stale;
mod summary;
mod table;

use std::path::{Path, PathBuf};

use serde_json::{json, Value};

pub use atomic::{sweep_temporaries, write_atomically, OutputError};
pub use figures::{avar_figure, psd_figure};
pub use format::{lowpass_text, sig4};
pub use info::info_text;
pub use json_layout::write_json as write_json_layout;
pub use kalibr::imu_yaml;
pub use model::{analysis_json, coefficients_table, units_of};
pub use stale::{prune_figures, retire_stale_folders, EARLIER_RUNS};
pub use summary::{
    effect_line, effect_lines, harmonic_notes, ramp_sentence, ramp_sentences, summary_markdown,
    warning_line, EffectUnits,
};
pub use table::{Column, Table};

use crate::avar::Deviations;
use crate::io::Recording;
use crate::pipeline::FileResult;
use crate::psd::Scaling;
use crate::units::Unit;
use crate::Error;

/// Version of the JSON document and table layout; bumped on any incompatible change.
pub const SCHEMA_VERSION: u32 = 12;

/// Output formats for tables and the document.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Formats {
    pub arrow: bool,
    pub csv: bool,
    pub json: bool,
}

impl Default for Formats {
    fn default() -> Self {
        Formats {
            arrow: true,
            csv: true,
            json: true,
        }
    }
}

/// The unit of a spectrum of values in `unit`.
pub fn psd_unit(unit: Option<Unit>, scaling: Scaling) -> String {
    let u = unit.map_or("raw".to_string(), |u| u.to_string());
    match scaling {
        Scaling::Density => format!("({u})^2/Hz"),
        Scaling::Spectrum => format!("({u})^2"),
    }
}

fn channel_unit(recording: &Recording, channel: &str) -> Option<Unit> {
    recording
        .channels
        .iter()
        .find(|c| c.name == channel)
        .and_then(|c| c.si_unit())
}

fn file_name(r: &Recording) -> String {
    r.path.display().to_string()
}

/// One row per file × channel × frequency bin.
pub fn psd_table(results: &[&FileResult]) -> Table {
    let mut t = Table::default();
    for r in results {
        for c in r.psd.iter().flatten() {
            let n = c.psd.freq_hz.len();
            let unit = psd_unit(channel_unit(&r.recording, &c.channel), c.psd.scaling);
            t.append(Table {
                columns: vec![
                    ("file".into(), Column::repeated(file_name(&r.recording), n)),
                    ("channel".into(), Column::repeated(c.channel.as_str(), n)),
                    ("unit".into(), Column::repeated(unit, n)),
                    ("freq_hz".into(), Column::F64(c.psd.freq_hz.clone())),
                    ("psd".into(), Column::F64(c.psd.value.clone())),
                    ("dof".into(), Column::F64(c.psd.dof.clone())),
                ],
                metadata: Default::default(),
            });
        }
    }
    t
}

/// One row per file × channel × log-frequency bin.
pub fn psd_binned_table(results: &[&FileResult]) -> Table {
    let mut t = Table::default();
    for r in results {
        for c in r.psd.iter().flatten() {
            let Some(b) = &c.binned else { continue };
            let n = b.freq_hz.len();
            let unit = psd_unit(channel_unit(&r.recording, &c.channel), c.psd.scaling);
            t.append(Table {
                columns: vec![
                    ("file".into(), Column::repeated(file_name(&r.recording), n)),
                    ("channel".into(), Column::repeated(c.channel.as_str(), n)),
                    ("unit".into(), Column::repeated(unit, n)),
                    ("freq_hz".into(), Column::F64(b.freq_hz.clone())),
                    ("f_lo_hz".into(), Column::F64(b.f_lo_hz.clone())),
                    ("f_hi_hz".into(), Column::F64(b.f_hi_hz.clone())),
                    ("psd".into(), Column::F64(b.value.clone())),
                    (
                        "bins".into(),
                        Column::U64(b.bins.iter().map(|&x| x as u64).collect()),
                    ),
                    ("dof".into(), Column::F64(b.dof.clone())),
                ],
                metadata: Default::default(),
            });
        }
    }
    t
}

/// One row per file × channel × statistic × τ.
pub fn avar_table(results: &[&FileResult]) -> Table {
    let mut t = Table::default();
    for r in results {
        for c in r.avar.iter().flatten() {
            let unit =
                channel_unit(&r.recording, &c.channel).map_or("raw".to_string(), |u| u.to_string());
            for d in &c.statistics {
                let n = d.m.len();
                let dev = d.deviation();
                t.append(Table {
                    columns: vec![
                        ("file".into(), Column::repeated(file_name(&r.recording), n)),
                        ("channel".into(), Column::repeated(c.channel.as_str(), n)),
                        ("unit".into(), Column::repeated(unit.as_str(), n)),
                        (
                            "statistic".into(),
                            Column::repeated(d.statistic.to_string(), n),
                        ),
                        ("m".into(), Column::U64(d.m.clone())),
                        ("tau_s".into(), Column::F64(d.tau_s.clone())),
                        ("deviation".into(), Column::F64(dev)),
                        ("deviation_lo".into(), Column::F64(sqrt_all(&d.variance_lo))),
                        ("deviation_hi".into(), Column::F64(sqrt_all(&d.variance_hi))),
                        ("variance".into(), Column::F64(d.variance.clone())),
                        ("edf".into(), Column::F64(d.edf.clone())),
                        (
                            "alpha".into(),
                            Column::I64(d.alpha.iter().map(|&a| a as i64).collect()),
                        ),
                        ("n_terms".into(), Column::U64(d.n_terms.clone())),
                    ],
                    metadata: Default::default(),
                });
            }
        }
    }
    t
}

fn sqrt_all(v: &[f64]) -> Vec<f64> {
    v.iter().map(|x| x.sqrt()).collect()
}

fn deviations_json(d: &Deviations) -> Value {
    json!({
        "statistic": d.statistic.to_string(),
        "confidence": d.confidence,
        "m": d.m,
        "tau_s": d.tau_s,
        "deviation": d.deviation(),
        "deviation_lo": sqrt_all(&d.variance_lo),
        "deviation_hi": sqrt_all(&d.variance_hi),
        "edf": d.edf,
        "alpha": d.alpha,
        "n_terms": d.n_terms,
    })
}

/// The JSON entry of one file's results.
pub fn file_json(r: &FileResult) -> Value {
    let rec = &r.recording;
    let channels: Vec<Value> = rec
        .channels
        .iter()
        .map(|c| {
            json!({
                "name": c.name,
                "kind": c.kind,
                "unit": c.unit.map(|u| u.to_string()),
                "si_unit": c.si_unit().map(|u| u.to_string()),
                "stored_type": c.stored_type,
                "scale": c.scale,
            })
        })
        .collect();
    let mut entry = json!({
        "path": file_name(rec),
        "status": "ok",
        "recording": {
            "format": rec.format,
            "rate_hz": rec.rate_hz,
            "rate_source": rec.rate_source,
            "rate_from_time_hz": rec.rate_from_time_hz,
            "time_column": rec.time.as_ref().map(|t| t.name.clone()),
            "time_seconds_per_unit": rec.time.as_ref().map(|t| t.encoding.seconds_per_unit()),
            "time_unit_source": rec.time.as_ref().map(|t| t.unit_source),
            "notes": rec.notes,
            "rows": r.quality.rows_read,
            "samples": r.quality.samples_out,
            "duration_s": r.quality.duration_s,
            "channels": channels,
        },
        "quality": r.quality,
        "timings": r.timings,
        "footprint": r.footprint,
        "backend": r.backend,
        "backend_notes": r.backend_notes,
    });
    if let Some(psd) = &r.psd {
        entry["psd"] = psd
            .iter()
            .map(|c| {
                let unit = psd_unit(channel_unit(rec, &c.channel), c.psd.scaling);
                let mut v = json!({
                    "channel": c.channel,
                    "unit": unit,
                    "scaling": c.psd.scaling,
                    "segments": c.psd.segments,
                    "nperseg": c.psd.nperseg,
                    "nfft": c.psd.nfft,
                    "enbw_hz": c.psd.enbw_hz,
                    "freq_hz": c.psd.freq_hz,
                    "value": c.psd.value,
                    "dof": c.psd.dof,
                });
                if let Some(b) = &c.binned {
                    v["binned"] = json!({
                        "freq_hz": b.freq_hz, "f_lo_hz": b.f_lo_hz, "f_hi_hz": b.f_hi_hz,
                        "value": b.value, "bins": b.bins, "dof": b.dof,
                    });
                }
                v
            })
            .collect();
    }
    if let Some(analysis) = &r.analysis {
        entry["analysis"] = analysis.iter().map(analysis_json).collect();
    }
    if let Some(avar) = &r.avar {
        entry["avar"] = avar
            .iter()
            .map(|c| {
                json!({
                    "channel": c.channel,
                    "unit": channel_unit(rec, &c.channel).map(|u| u.to_string()),
                    "statistics": c.statistics.iter().map(deviations_json).collect::<Vec<_>>(),
                })
            })
            .collect();
    }
    entry
}

/// The JSON entry of a file that failed.
pub fn error_json(path: &Path, e: &Error) -> Value {
    json!({
        "path": path.display().to_string(),
        "status": "error",
        "error": {
            "message": e.to_string(),
            "column": e.column(),
            "row": e.row(),
        },
    })
}

/// The whole run's document.
pub fn document(
    command: &str,
    backend: &str,
    options: Value,
    files: Vec<Value>,
    elapsed_s: f64,
) -> Value {
    let failed = files.iter().filter(|f| f["status"] == "error").count();
    json!({
        "schema_version": SCHEMA_VERSION,
        "tool": "imunoise",
        "version": env!("CARGO_PKG_VERSION"),
        "command": command,
        "backend": backend,
        "options": options,
        "summary": {
            "files": files.len(),
            "ok": files.len() - failed,
            "failed": failed,
            "elapsed_s": elapsed_s,
        },
        "files": files,
    })
}

/// Writes a table in the asked formats as `dir/stem.arrow` and `dir/stem.csv`; for an empty table
/// nothing, and an earlier run's files of those names are removed.
pub fn write_table(
    dir: &Path,
    stem: &str,
    table: &Table,
    formats: Formats,
) -> Result<(), OutputError> {
    if table.rows() == 0 {
        // Nothing to write (every input failed): an earlier run's table of the same name is
        // removed, not left beside a summary that says no file was analysed (its numbers had
        // looked current).
        for ext in ["arrow", "csv"] {
            let path = dir.join(format!("{stem}.{ext}"));
            match std::fs::remove_file(&path) {
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                    return Err(OutputError::new(&path, e))
                }
                _ => {}
            }
        }
        return Ok(());
    }
    if formats.arrow {
        table.write_arrow(&dir.join(format!("{stem}.arrow")))?;
    }
    if formats.csv {
        table.write_csv(&dir.join(format!("{stem}.csv")))?;
    }
    Ok(())
}

/// Writes the document as indented JSON with numeric arrays on one line
/// ([`write_json_layout`]), atomically.
pub fn write_json(path: &Path, doc: &Value) -> Result<(), OutputError> {
    write_atomically(path, |out| write_json_layout(out, doc))
}

/// `name` with every character other than ASCII letters, digits, `-`, `_` and `.` replaced by
/// `_`: safe in a file name on every system (a fleet's file keys, a channel's plot files).
pub fn file_safe(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.') {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// The file-name part of a channel's plots: its name made [`file_safe`] (a leading `.` or an
/// empty name prefixed with `_`), and where two channels named in `all` (every channel plotted)
/// come out alike, its position among them appended. A ROS export's `field.angular_velocity.x` once lost its `.x` to
/// the extension, so that the three axes' plots (and the two kinds) overwrote one another, and two
/// channels writing one file at once failed the run; a `/` in a name would have made a folder.
pub fn plot_name<'a>(channel: &str, all: impl IntoIterator<Item = &'a str>) -> String {
    let clean = |name: &str| -> String {
        let s = file_safe(name);
        if s.is_empty() || s.starts_with('.') {
            format!("_{s}")
        } else {
            s
        }
    };
    let mine = clean(channel);
    let alike: Vec<&str> = all.into_iter().filter(|c| clean(c) == mine).collect();
    match alike.iter().position(|c| *c == channel) {
        Some(i) if alike.len() > 1 => format!("{mine}_{}", i + 1),
        _ => mine,
    }
}

/// Writes the plots of every analysed channel of `r` into `folder` as SVG and PNG:
/// `<channel>_avar.svg|png` and `<channel>_psd.svg|png`. Channels are drawn in parallel: the
/// rasterising and PNG compression of a 6-channel file's twelve figures took a third of a second
/// on one core, about a sixth of `analyze`'s wall time on a 1-h record. The first error in channel
/// order is returned; otherwise the paths written.
pub fn write_plots(folder: &Path, r: &FileResult) -> Result<Vec<PathBuf>, OutputError> {
    use rayon::prelude::*;
    use std::io::Write;
    let Some(analysis) = &r.analysis else {
        return Ok(Vec::new());
    };
    let results: Vec<Result<Vec<PathBuf>, OutputError>> = analysis
        .par_iter()
        .map(|a| -> Result<Vec<PathBuf>, OutputError> {
            let mut written = Vec::new();
            let unit = channel_unit(&r.recording, &a.channel);
            let mut figures = Vec::new();
            if let Some(d) = r
                .avar
                .iter()
                .flatten()
                .find(|c| c.channel == a.channel)
                .and_then(crate::analysis::oadev)
            {
                figures.push(("avar", avar_figure(a, d, unit)));
            }
            if let Some(p) = r.psd.iter().flatten().find(|c| c.channel == a.channel) {
                figures.push(("psd", psd_figure(a, p, unit)));
            }
            for (what, fig) in figures {
                let path = |ext: &str| {
                    folder.join(format!(
                        "{}_{what}.{ext}",
                        plot_name(&a.channel, analysis.iter().map(|c| c.channel.as_str()))
                    ))
                };
                let svg = fig.to_svg();
                write_atomically(&path("svg"), |w| w.write_all(svg.as_bytes()))?;
                let png = fig
                    .to_png()
                    .map_err(|e| OutputError::new(&path("png"), e))?;
                write_atomically(&path("png"), |w| w.write_all(&png))?;
                written.extend([path("svg"), path("png")]);
            }
            Ok(written)
        })
        .collect();
    let mut all = Vec::new();
    for r in results {
        all.extend(r?);
    }
    Ok(all)
}

#[cfg(test)]
mod tests {
    use super::plot_name;

    /// A ROS export's dotted names keep every part; a `/` or a space does not make a folder or
    /// an awkward name; two names that clean alike are told apart by their position.
    #[test]
    fn every_channel_gets_its_own_plot_files() {
        let ros = [
            "field.angular_velocity.x",
            "field.angular_velocity.y",
            "field.linear_acceleration.x",
        ];
        let names: Vec<String> = ros.iter().map(|c| plot_name(c, ros)).collect();
        assert_eq!(names, ros);
        let odd = ["imu/gyro x", "imu_gyro_x", ".hidden", ""];
        assert_eq!(plot_name("imu/gyro x", odd), "imu_gyro_x_1");
        assert_eq!(plot_name("imu_gyro_x", odd), "imu_gyro_x_2");
        assert_eq!(plot_name(".hidden", odd), "_.hidden");
        assert_eq!(plot_name("", odd), "_");
    }
}
