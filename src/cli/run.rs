//! Running a validated job over its files, reporting progress and writing the outputs.

use std::io::{IsTerminal, Write};
use std::path::Path;
use std::time::{Duration, Instant};

use imunoise::estimate::{Backend, CpuBackend};
use imunoise::gpu::{GpuBackend, GpuError};
use imunoise::pipeline::{self, FileResult, Progress};
use imunoise::report::{self, OutputError};
use indicatif::{ProgressBar, ProgressStyle};

use super::config::{BackendChoice, Job};

/// Exit codes (as ripgrep): all fine, some inputs failed, usage or fatal error.
pub const EXIT_OK: i32 = 0;
pub const EXIT_SOME_FAILED: i32 = 1;
pub const EXIT_FATAL: i32 = 2;

/// A progress bar on stderr when it is a terminal; nothing in a pipe or with --quiet.
struct Bar {
    bar: Option<ProgressBar>,
    index: std::cell::Cell<usize>,
    total: usize,
}

impl Bar {
    fn new(total: usize, quiet: bool) -> Self {
        let bar = (!quiet && std::io::stderr().is_terminal()).then(|| {
            let b = ProgressBar::new_spinner();
            b.set_style(
                ProgressStyle::with_template(
                    "{spinner} {msg} {human_pos} rows ({per_sec}) {elapsed}",
                )
                .unwrap_or_else(|_| ProgressStyle::default_spinner()),
            );
            b.enable_steady_tick(Duration::from_millis(200));
            b
        });
        Bar {
            bar,
            index: std::cell::Cell::new(0),
            total,
        }
    }

    /// Prints a line without tearing the bar.
    fn line(&self, text: &str) {
        match &self.bar {
            Some(b) => b.suspend(|| eprintln!("{text}")),
            None => eprintln!("{text}"),
        }
    }
}

impl Progress for Bar {
    fn start(&self, path: &Path) {
        self.index.set(self.index.get() + 1);
        if let Some(b) = &self.bar {
            b.set_position(0);
            b.set_message(format!(
                "[{}/{}] {}",
                self.index.get(),
                self.total,
                path.display()
            ));
        }
    }
    fn advance(&self, rows: u64) {
        if let Some(b) = &self.bar {
            b.inc(rows);
        }
    }
}

fn summary_line(r: &FileResult) -> String {
    let q = &r.quality;
    let mut notes = Vec::new();
    if q.gap_count > 0 {
        notes.push(format!(
            "{} gaps ({} samples missing)",
            q.gap_count, q.missing_samples
        ));
    }
    let nonfinite: u64 = q.channels.iter().map(|c| c.nonfinite_samples).sum();
    if nonfinite > 0 {
        notes.push(format!(
            "{nonfinite} non-finite samples ({})",
            q.nonfinite_policy
        ));
    }
    for c in q.channels.iter().filter(|c| c.summary.possibly_saturated) {
        notes.push(format!("{} possibly saturated", c.name));
    }
    let notes = if notes.is_empty() {
        String::new()
    } else {
        format!("; {}", notes.join(", "))
    };
    format!(
        "ok    {}: {} channels, {} samples at {} Hz ({:.1} s){notes}",
        r.recording.path.display(),
        r.recording.channels.len(),
        q.samples_out,
        r.recording.rate_hz,
        q.duration_s,
    )
}

/// The backend asked for. `info` estimates nothing, so it never opens a GPU.
fn backend(job: &Job) -> Result<Box<dyn Backend>, GpuError> {
    let estimates = job.work.welch.is_some() || job.work.avar.is_some();
    match job.backend {
        BackendChoice::Cpu => Ok(Box::new(CpuBackend)),
        _ if !estimates => Ok(Box::new(CpuBackend)),
        BackendChoice::Gpu => Ok(Box::new(GpuBackend::new()?)),
        BackendChoice::Auto => match GpuBackend::new() {
            // A software rasteriser (lavapipe/llvmpipe) is slower than the CPU path: auto means
            // "a real GPU if there is one"; --backend gpu still takes it.
            Ok(gpu) if gpu.context().adapter_info().device_type == wgpu::DeviceType::Cpu => {
                if !job.output.quiet {
                    eprintln!(
                        "imunoise: only a software GPU ({}); computing on the CPU (--backend gpu forces it)",
                        gpu.context().adapter_info().name
                    );
                }
                Ok(Box::new(CpuBackend))
            }
            Ok(gpu) => Ok(Box::new(gpu)),
            Err(e) => {
                if !job.output.quiet {
                    eprintln!("imunoise: no usable GPU ({e}); computing on the CPU");
                }
                Ok(Box::new(CpuBackend))
            }
        },
    }
}

/// Runs the job; returns the process exit code.
pub fn run(job: &Job) -> i32 {
    let started = Instant::now();
    let backend = match backend(job) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("imunoise: --backend gpu: {e}");
            return EXIT_FATAL;
        }
    };
    let estimates = job.work.welch.is_some() || job.work.avar.is_some();
    if !job.output.quiet && estimates && job.backend != BackendChoice::Cpu {
        eprintln!("imunoise: backend {}", backend.describe());
    }
    let backend = backend.as_ref();
    let bar = Bar::new(job.files.len(), job.output.quiet);
    if !job.output.json_stdout {
        if let Err(e) = std::fs::create_dir_all(&job.output.dir) {
            eprintln!(
                "imunoise: cannot create output folder {}: {e}",
                job.output.dir.display()
            );
            return EXIT_FATAL;
        }
    }
    let mut ok: Vec<FileResult> = Vec::new();
    let mut entries = Vec::new();
    let mut failures: Vec<(String, String)> = Vec::new();
    for path in &job.files {
        match pipeline::run(path, &job.inputs, &job.work, backend, &bar) {
            Ok(r) => {
                if !job.output.quiet {
                    bar.line(&summary_line(&r));
                }
                for a in r.analysis.iter().flatten() {
                    if let (Some(b), false) = (&a.bandwidth, job.output.quiet) {
                        bar.line(&format!(
                            "band  {} {}: sensor low-pass at {} Hz (order {}); fits use f ≤ {} Hz, τ ≥ {} s",
                            path.display(),
                            a.channel,
                            report::sig4(b.lowpass.corner_hz),
                            b.lowpass.order,
                            report::sig4(b.fit_max_freq_hz),
                            b.fit_min_tau_s.map_or("–".into(), report::sig4),
                        ));
                    }
                    for w in &a.combined.warnings {
                        bar.line(&format!(
                            "warning {} {}: {}",
                            path.display(),
                            a.channel,
                            w.describe()
                        ));
                    }
                    let Some(l) = &a.residual_loop else { continue };
                    let found: Vec<String> = l
                        .steps
                        .iter()
                        .map(|s| report::effect_line(&s.effect))
                        .collect();
                    if !job.output.quiet {
                        bar.line(&format!(
                            "found {}: {}",
                            a.channel,
                            if found.is_empty() {
                                "nothing beyond the IEEE model".to_string()
                            } else {
                                found.join("; ")
                            }
                        ));
                    }
                }
                for note in &r.backend_notes {
                    bar.line(&format!("note  {}: {note}", path.display()));
                }
                entries.push(report::file_json(&r));
                ok.push(r);
            }
            Err(e) => {
                failures.push((path.display().to_string(), e.to_string()));
                bar.line(&format!("error {e}"));
                entries.push(report::error_json(path, &e));
            }
        }
    }
    if let Some(b) = &bar.bar {
        b.finish_and_clear();
    }
    let failed = failures.len();
    let elapsed_s = started.elapsed().as_secs_f64();
    let doc = report::document(
        job.command,
        &backend.describe(),
        job.options.clone(),
        entries,
        elapsed_s,
    );
    let written = if job.output.json_stdout {
        print_json(&doc)
    } else {
        write_outputs(job, &ok, &failures, &doc, elapsed_s)
    };
    if let Err(e) = written {
        eprintln!("imunoise: {e}");
        return EXIT_FATAL;
    }
    if !job.output.quiet && !job.output.json_stdout {
        eprintln!(
            "{} of {} files ok; results in {}",
            job.files.len() - failed,
            job.files.len(),
            job.output.dir.display()
        );
    }
    if failed > 0 {
        EXIT_SOME_FAILED
    } else {
        EXIT_OK
    }
}

/// Prints the document; a closed pipe (`| head`) is not an error.
fn print_json(doc: &serde_json::Value) -> Result<(), OutputError> {
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    let result = serde_json::to_writer_pretty(&mut out, doc)
        .map_err(std::io::Error::from)
        .and_then(|_| writeln!(out))
        .and_then(|_| out.flush());
    match result {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            Err(OutputError::new(Path::new("<stdout>"), e))
        }
        _ => Ok(()),
    }
}

fn write_outputs(
    job: &Job,
    ok: &[FileResult],
    failures: &[(String, String)],
    doc: &serde_json::Value,
    elapsed_s: f64,
) -> Result<(), OutputError> {
    let dir = &job.output.dir;
    let refs: Vec<&FileResult> = ok.iter().collect();
    let formats = job.output.formats;
    if job.work.fit.is_some() {
        report::write_table(
            dir,
            "coefficients",
            &report::coefficients_table(&refs),
            formats,
        )?;
        let md = report::summary_markdown(&refs, failures, elapsed_s);
        report::write_atomically(&dir.join("summary.md"), |w| w.write_all(md.as_bytes()))?;
        let topic = job.output.kalibr_topic.as_deref().unwrap_or("/imu0");
        for (r, folder) in ok.iter().zip(per_file_folders(ok)) {
            let Some(analysis) = &r.analysis else {
                continue;
            };
            let folder = dir.join(folder);
            std::fs::create_dir_all(&folder).map_err(|e| OutputError::new(&folder, e))?;
            let yaml = report::imu_yaml(
                &r.recording.path.display().to_string(),
                r.recording.rate_hz,
                topic,
                analysis,
            );
            report::write_atomically(&folder.join("imu.yaml"), |w| w.write_all(yaml.as_bytes()))?;
            let plots = folder.join("plots");
            std::fs::create_dir_all(&plots).map_err(|e| OutputError::new(&plots, e))?;
            report::write_plots(&plots, r)?;
        }
    }
    if job.work.welch.is_some() {
        report::write_table(dir, "psd", &report::psd_table(&refs), formats)?;
        report::write_table(dir, "psd_binned", &report::psd_binned_table(&refs), formats)?;
    }
    if job.work.avar.is_some() {
        report::write_table(dir, "avar", &report::avar_table(&refs), formats)?;
    }
    if formats.json {
        report::write_json(&dir.join("report.json"), doc)?;
    }
    Ok(())
}

/// One output sub-folder per file, named after the file's stem; a stem seen before gets `-2`,
/// `-3`, … so that two `imu.arrow` from different folders do not overwrite each other.
fn per_file_folders(ok: &[FileResult]) -> Vec<String> {
    let mut seen = std::collections::HashMap::<String, usize>::new();
    ok.iter()
        .map(|r| {
            let stem = r
                .recording
                .path
                .file_stem()
                .map_or("recording".into(), |s| s.to_string_lossy().into_owned());
            let count = seen.entry(stem.clone()).or_insert(0);
            *count += 1;
            if *count == 1 {
                stem
            } else {
                format!("{stem}-{count}")
            }
        })
        .collect()
}
