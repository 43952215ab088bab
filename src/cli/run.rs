//! Running a validated job over its files, reporting progress and writing the outputs.

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use imunoise::estimate::{Backend, CpuBackend};
use imunoise::gpu::GpuError;
use imunoise::model::{BandEdge, FitWarning};
use imunoise::pipeline::{self, FileResult, Progress};
use imunoise::report::format::{count, count_as, duration, rate_hz, throughput};
use imunoise::report::{self, EffectUnits, OutputError};
use indicatif::{ProgressBar, ProgressState, ProgressStyle};

use super::backend::{gpu_failure, Chatter, Chosen, Workload};
use super::config::{BackendChoice, Job};

/// Exit codes (as ripgrep): all fine, some inputs failed, usage or fatal error.
pub const EXIT_OK: i32 = 0;
pub const EXIT_SOME_FAILED: i32 = 1;
pub const EXIT_FATAL: i32 = 2;

/// A progress bar on stderr when it is a terminal; nothing in a pipe or with --quiet.
struct Bar {
    bar: Option<ProgressBar>,
    index: std::sync::atomic::AtomicUsize,
    total: usize,
}

impl Bar {
    fn new(total: usize, quiet: bool) -> Self {
        let bar = (!quiet && std::io::stderr().is_terminal()).then(|| {
            let b = ProgressBar::new_spinner();
            b.set_style(bar_style());
            b.enable_steady_tick(Duration::from_millis(200));
            b
        });
        Bar {
            bar,
            index: std::sync::atomic::AtomicUsize::new(0),
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

    /// [`print_stdout`] without tearing the bar (both may be the same terminal).
    fn stdout(&self, text: &str, separate: bool) -> bool {
        match &self.bar {
            Some(b) => b.suspend(|| print_stdout(text, separate)),
            None => print_stdout(text, separate),
        }
    }
}

impl Progress for Bar {
    fn start(&self, path: &Path) {
        let index = self.index.fetch_add(1, std::sync::atomic::Ordering::SeqCst) + 1;
        if let Some(b) = &self.bar {
            b.set_position(0);
            b.set_message(format!("[{index}/{}] {}", self.total, path.display()));
        }
    }
    fn fitted(&self, done: usize, of: usize) {
        if let Some(b) = &self.bar {
            let index = self.index.load(std::sync::atomic::Ordering::SeqCst);
            b.set_message(format!(
                "[{index}/{}] fitting: {done} of {of} channels done",
                self.total
            ));
        }
    }
    fn advance(&self, rows: u64) {
        if let Some(b) = &self.bar {
            b.inc(rows);
        }
    }
}

/// The progress line: a spinner, the file, rows read, the throughput rounded to 3 digits
/// (indicatif's own `{per_sec}` prints `4,989,290.1875/s`) and the elapsed time.
fn bar_style() -> ProgressStyle {
    ProgressStyle::with_template("{spinner} {msg} {human_pos} rows ({rate}) {elapsed}")
        .map(|style| {
            style.with_key(
                "rate",
                |state: &ProgressState, w: &mut dyn std::fmt::Write| {
                    let _ = w.write_str(&throughput(state.per_sec(), "rows"));
                },
            )
        })
        .unwrap_or_else(|_| ProgressStyle::default_spinner())
}

/// The per-file line of stderr: size, rate, duration, gaps and non-finite samples. Channel verdicts
/// (saturation among them) follow on lines of their own.
fn summary_line(r: &FileResult) -> String {
    let q = &r.quality;
    let mut notes = Vec::new();
    if q.gap_count > 0 {
        notes.push(format!(
            "{} ({} missing)",
            count(q.gap_count, "gap"),
            count(q.missing_samples, "sample")
        ));
    }
    let nonfinite: u64 = q.channels.iter().map(|c| c.nonfinite_samples).sum();
    if nonfinite > 0 {
        notes.push(format!(
            "{} ({})",
            count(nonfinite, "non-finite sample"),
            q.nonfinite_policy
        ));
    }
    if q.dropped_rows > 0 {
        notes.push(format!(
            "{} dropped, the samples either side joined as if contiguous",
            count(q.dropped_rows, "row")
        ));
    }
    if q.duplicate_rows > 0 {
        notes.push(format!(
            "{} repeating the previous timestamp dropped",
            count(q.duplicate_rows, "row")
        ));
    }
    let notes = if notes.is_empty() {
        String::new()
    } else {
        format!("; {}", notes.join(", "))
    };
    format!(
        "ok    {}: {}, {} at {}, {}{notes}",
        r.recording.path.display(),
        count(r.recording.channels.len() as u64, "channel"),
        count(q.samples_out, "sample"),
        rate_hz(r.recording.rate_hz),
        duration(q.duration_s),
    )
}

/// The backend asked for. `info` estimates nothing, so it never opens a GPU.
fn backend(job: &Job) -> Result<Chosen, GpuError> {
    let estimates = job.work.welch.is_some() || job.work.avar.is_some();
    if !estimates {
        return Ok(Chosen {
            backend: Box::new(CpuBackend),
            opening: false,
        });
    }
    let chatter = Chatter {
        verbose: job.output.verbose,
        quiet: job.output.quiet,
    };
    let workload = Workload::of(job.files.iter().map(PathBuf::as_path), &job.work);
    super::backend::choose(job.backend, chatter, workload)
}

/// Runs the job; returns the process exit code.
pub fn run(job: &Job) -> i32 {
    let started = Instant::now();
    let Chosen { backend, opening } = match backend(job) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("imunoise: {}", gpu_failure(&e, job.output.verbose));
            return EXIT_FATAL;
        }
    };
    // The backend lives as long as the process: closing a GPU device took 72–102 ms on an H200
    // host (see `backend`'s module docs), for nothing when the process ends next.
    let backend: &dyn Backend = Box::leak(backend);
    let estimates = job.work.welch.is_some() || job.work.avar.is_some();
    // A backend still opening is named once the first file is done (naming it waits for it).
    let mut unnamed = !job.output.quiet && estimates && job.backend != BackendChoice::Cpu;
    if unnamed && !opening {
        eprintln!("imunoise: backend {}", backend.describe());
        unnamed = false;
    }
    let bar = Bar::new(job.files.len(), job.output.quiet);
    // `info` prints a table on stdout and writes files only into a folder asked for with -o.
    let info_table = job.command == "info" && !job.output.json_stdout;
    let write_files = !job.output.json_stdout && (job.command != "info" || job.output.dir_given);
    let mut stdout_open = true;
    if write_files {
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
        let result = pipeline::run(path, &job.inputs, &job.work, backend, &bar);
        if unnamed {
            bar.line(&format!("imunoise: backend {}", backend.describe()));
            unnamed = false;
        }
        match result {
            Ok(r) => {
                if info_table {
                    // The table is the per-file line; stdout closed (`| head`) ends the printing.
                    if stdout_open {
                        stdout_open = bar.stdout(&report::info_text(&r), !ok.is_empty());
                    }
                } else if !job.output.quiet {
                    bar.line(&summary_line(&r));
                }
                if !job.output.quiet && !info_table {
                    for note in &r.recording.notes {
                        bar.line(&format!("note  {}: {note}", path.display()));
                    }
                    for c in &r.quality.channels {
                        for v in &c.verdicts {
                            bar.line(&format!(
                                "quality {} {}: {}",
                                path.display(),
                                c.name,
                                v.describe()
                            ));
                        }
                    }
                }
                for a in r.analysis.iter().flatten() {
                    if let (Some(b), false) = (&a.bandwidth, job.output.quiet) {
                        let edge = match b.cause {
                            BandEdge::LowPass => report::lowpass_text(&b.lowpass),
                            BandEdge::AngleQuantiser { steps_per_sigma, .. } => format!(
                                "an edge at {} Hz from the coarse angle grid ({:.1} σ per step), no filter claimed",
                                report::sig4(b.lowpass.corner_hz),
                                steps_per_sigma
                            ),
                        };
                        bar.line(&format!(
                            "band  {} {}: {edge}; fits use f ≤ {} Hz, τ ≥ {} s",
                            path.display(),
                            a.channel,
                            report::sig4(b.fit_max_freq_hz),
                            b.fit_min_tau_s.map_or("–".into(), report::sig4),
                        ));
                    }
                    for w in &a.combined.warnings {
                        bar.line(&format!(
                            "warning {} {}: {}",
                            path.display(),
                            a.channel,
                            report::warning_line(w, a.sensor)
                        ));
                    }
                    // A rate ramp the series' test kept, dropped or added: the one change to
                    // the IEEE terms that no effect line shows.
                    let text = report::ramp_sentences(a);
                    if !job.output.quiet && !text.is_empty() {
                        bar.line(&format!("ramp  {}:{text}", a.channel));
                    }
                    let Some(l) = &a.residual_loop else { continue };
                    let units = EffectUnits::of(&r.recording, &a.channel);
                    let effects: Vec<&imunoise::effects::Effect> =
                        l.steps.iter().map(|s| &s.effect).collect();
                    let found = report::effect_lines(&effects, &units);
                    if !job.output.quiet {
                        bar.line(&format!(
                            "found {}: {}",
                            a.channel,
                            if found.is_empty() {
                                // A model the data still reject is not "nothing beyond": the
                                // loop found nothing of its catalogue that explains the misfit.
                                let misfit = a
                                    .combined
                                    .warnings
                                    .iter()
                                    .any(|w| matches!(w, FitWarning::LackOfFit { .. }));
                                if misfit {
                                    "no effect of its catalogue explains what the IEEE model \
                                     misses (the lack of fit above stands)"
                                        .to_string()
                                } else {
                                    "nothing beyond the IEEE model".to_string()
                                }
                            } else {
                                found.join("; ")
                            }
                        ));
                    }
                }
                if !info_table {
                    for note in &r.backend_notes {
                        bar.line(&format!("note  {}: {note}", path.display()));
                    }
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
    } else if write_files {
        write_outputs(job, &ok, &failures, &doc, elapsed_s)
    } else {
        Ok(())
    };
    if let Err(e) = written {
        eprintln!("imunoise: {e}");
        return EXIT_FATAL;
    }
    let files = count_as(job.files.len() as u64, "file", "files");
    if !job.output.quiet && write_files {
        eprintln!(
            "{} of {files} ok; results in {}",
            job.files.len() - failed,
            job.output.dir.display()
        );
    } else if !job.output.quiet && info_table && failed > 0 {
        eprintln!("{} of {files} ok", job.files.len() - failed);
    }
    if failed > 0 {
        EXIT_SOME_FAILED
    } else {
        EXIT_OK
    }
}

/// Prints `text` on stdout, after a blank line when `separate`; returns whether stdout is still
/// open (a closed pipe, `| head`, is not an error: printing just stops).
fn print_stdout(text: &str, separate: bool) -> bool {
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    let result = (if separate { writeln!(out) } else { Ok(()) })
        .and_then(|_| out.write_all(text.as_bytes()))
        .and_then(|_| out.flush());
    match result {
        Ok(()) => true,
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => false,
        Err(e) => {
            eprintln!("imunoise: cannot write to stdout: {e}");
            false
        }
    }
}

/// Prints the document; a closed pipe (`| head`) is not an error.
fn print_json(doc: &serde_json::Value) -> Result<(), OutputError> {
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    let result = report::write_json_layout(&mut out, doc)
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
    let formats = job.output.formats;
    // report.json is formatted and written on a thread of its own while the tables, summary and
    // plots are written here: on a 10⁷-sample `psd` the two took 7 and 5 ms one after the other.
    std::thread::scope(|scope| {
        let json = formats
            .json
            .then(|| scope.spawn(|| report::write_json(&dir.join("report.json"), doc)));
        let rest = write_tables_and_folders(job, ok, failures, elapsed_s);
        let json = json.map_or(Ok(()), |handle| {
            handle
                .join()
                .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
        });
        rest.and(json)
    })?;
    // What a run killed while writing left behind (this run's own writes are done by now).
    report::sweep_temporaries(dir);
    Ok(())
}

/// Everything but report.json: the tables, summary.md and the per-file folders.
fn write_tables_and_folders(
    job: &Job,
    ok: &[FileResult],
    failures: &[(String, String)],
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
        let folders = per_file_folders(ok);
        let mut written = std::collections::HashSet::new();
        for (r, name) in ok.iter().zip(&folders) {
            let Some(analysis) = &r.analysis else {
                continue;
            };
            written.insert(name.clone());
            let folder = dir.join(name);
            std::fs::create_dir_all(&folder).map_err(|e| OutputError::new(&folder, e))?;
            let yaml = report::imu_yaml(
                &r.recording.path.display().to_string(),
                r.recording.rate_hz,
                topic,
                analysis,
                &r.quality,
            );
            report::write_atomically(&folder.join("imu.yaml"), |w| w.write_all(yaml.as_bytes()))?;
            let plots = folder.join("plots");
            std::fs::create_dir_all(&plots).map_err(|e| OutputError::new(&plots, e))?;
            let figures = report::write_plots(&plots, r)?;
            report::prune_figures(&plots, &figures.into_iter().collect())?;
            report::sweep_temporaries(&folder);
            report::sweep_temporaries(&plots);
        }
        let stale = report::retire_stale_folders(dir, &written)?;
        if !stale.is_empty() {
            eprintln!(
                "imunoise: note: moved the folders an earlier run left in {} for recordings this \
                 run did not analyse ({}) to {}, so that none there looks current that is not",
                dir.display(),
                stale.join(", "),
                dir.join(report::EARLIER_RUNS).display()
            );
        }
    }
    if job.work.welch.is_some() {
        report::write_table(dir, "psd", &report::psd_table(&refs), formats)?;
        report::write_table(dir, "psd_binned", &report::psd_binned_table(&refs), formats)?;
    }
    if job.work.avar.is_some() {
        report::write_table(dir, "avar", &report::avar_table(&refs), formats)?;
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

#[cfg(test)]
mod tests {
    use std::sync::{Arc, Mutex};

    use indicatif::{ProgressBar, ProgressDrawTarget, TermLike};

    use super::bar_style;

    /// A terminal that keeps what is drawn on it.
    #[derive(Debug, Clone, Default)]
    struct Screen(Arc<Mutex<String>>);

    impl TermLike for Screen {
        fn width(&self) -> u16 {
            200
        }
        fn move_cursor_up(&self, _: usize) -> std::io::Result<()> {
            Ok(())
        }
        fn move_cursor_down(&self, _: usize) -> std::io::Result<()> {
            Ok(())
        }
        fn move_cursor_right(&self, _: usize) -> std::io::Result<()> {
            Ok(())
        }
        fn move_cursor_left(&self, _: usize) -> std::io::Result<()> {
            Ok(())
        }
        fn write_line(&self, s: &str) -> std::io::Result<()> {
            self.0.lock().unwrap().push_str(&format!("{s}\n"));
            Ok(())
        }
        fn write_str(&self, s: &str) -> std::io::Result<()> {
            self.0.lock().unwrap().push_str(s);
            Ok(())
        }
        fn clear_line(&self) -> std::io::Result<()> {
            self.0.lock().unwrap().push('\n');
            Ok(())
        }
        fn flush(&self) -> std::io::Result<()> {
            Ok(())
        }
    }

    /// The bar once showed indicatif's `{per_sec}`: `4,989,290.1875/s`.
    #[test]
    fn the_progress_bar_shows_throughput_to_three_digits_with_its_unit() {
        let screen = Screen::default();
        let bar = ProgressBar::with_draw_target(
            None,
            ProgressDrawTarget::term_like(Box::new(screen.clone())),
        );
        bar.set_style(bar_style());
        bar.set_message("[1/1] x.arrow");
        for _ in 0..20 {
            bar.inc(49_893);
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
        bar.tick();
        let text = screen.0.lock().unwrap().clone();
        let last = text.lines().rev().find(|l| l.contains("rows (")).unwrap();
        let rate = last
            .split_once("rows (")
            .and_then(|(_, r)| r.split_once(')'))
            .map(|(r, _)| r)
            .unwrap();
        let number = rate
            .strip_suffix(" rows/s")
            .unwrap_or_else(|| panic!("{last:?}"));
        let number = number
            .strip_suffix(" k")
            .or_else(|| number.strip_suffix(" M"))
            .or_else(|| number.strip_suffix(" G"))
            .unwrap_or(number);
        let digits = number.chars().filter(char::is_ascii_digit).count();
        assert!(
            number.parse::<f64>().is_ok() && digits <= 3 && !number.contains(','),
            "{last:?}"
        );
    }
}
