//! `imunoise screen`: flags → validated run → [`imunoise::fleet`] → exit code. The analysis
//! options are the `analyze` flags, validated by the same code ([`super::config::job`]); this file
//! only adds the fleet flags, the locks, the progress bar and the stderr lines.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::Duration;

use clap::{Args, Parser};
use imunoise::estimate::Backend;
use imunoise::fleet::{
    self, collect_inputs_noting, fleet_step, plot_after_fleet, BatchConfig, FailOn, FileOutcome,
    Input, Layout, Lock, Observer, PlotPolicy, Shard, Spec, Status,
};
use indicatif::{ProgressBar, ProgressState, ProgressStyle};
use serde_json::json;

use super::args::{
    AnalyzeArgs, AvarFlags, BackendArgs, Cli, Command, FitFlags, InputArgs, OutputArgs, WelchArgs,
};
use super::backend::{gpu_failure, Chatter, Workload};
use super::config::{self, BackendChoice, UsageError};
use super::run::{EXIT_FATAL, EXIT_OK, EXIT_SOME_FAILED};

/// How long the fleet step waits for another shard's fleet step to finish.
const FLEET_LOCK_PATIENCE: Duration = Duration::from_secs(600);

/// `imunoise screen` flags: the inputs, the fleet flags, and the `analyze` options.
#[derive(Debug, Args)]
#[command(mut_arg("files", |a| a
    .required(false)
    .value_name("DIR|FILE")
    .help("Folders (searched recursively for .arrow/.feather/.ipc, .arrows, .parquet/.pq, .csv \
           and .mcap files, in sorted order) or recordings. One bad file does not stop the \
           others.")))]
pub struct ScreenArgs {
    #[command(flatten)]
    pub input: InputArgs,
    #[command(flatten)]
    pub fleet: FleetFlags,
    #[command(flatten)]
    pub welch: WelchArgs,
    #[command(flatten)]
    pub avar: AvarFlags,
    #[command(flatten)]
    pub fit: FitFlags,
    #[command(flatten)]
    pub backend: BackendArgs,
}

/// What to screen against, where results go, how the batch runs.
#[derive(Debug, Args)]
#[command(next_help_heading = "Fleet")]
pub struct FleetFlags {
    /// More inputs, one path per line (folders or files; `-` reads standard input; blank lines
    /// and lines starting with # are skipped). Repeatable: a list and standard input together.
    #[arg(long, value_name = "LIST")]
    pub files_from: Vec<PathBuf>,

    /// Take only shard K of N (0 <= K < N), chosen by a stable hash of each input's path below
    /// its folder argument: the same on every machine, so a job array (Slurm
    /// --array=0-15 with --shard $SLURM_ARRAY_TASK_ID/16) splits a fleet into one output folder.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<String>,

    /// Specification (TOML): upper limits per sensor kind and term with units, e.g.
    /// [gyro] N = "0.3 deg/sqrt(h)", B = "5 deg/h"; [accel] N = "60 ug/sqrt(Hz)"; and
    /// [fleet] outlier_z = 3.5. Without it, only the fleet comparison.
    #[arg(long, value_name = "SPEC")]
    pub spec: Option<PathBuf>,

    /// Output folder: results/shard=K/part-*.parquet (one per input, written as each is done),
    /// fleet.parquet, summary.md, fleet.html. A rerun skips inputs whose result is up to date.
    #[arg(short, long, default_value = "imunoise-screen", value_name = "DIR")]
    pub out: PathBuf,

    /// Per-file plots of `analyze` in DIR/plots/<key>/: none, failures (files with a flagged
    /// channel: a limit failure, a quality verdict, a fleet outlier or an unusual effect), or all.
    #[arg(long, default_value = "none", value_name = "WHICH")]
    pub plots: String,

    /// Exit with code 3 when a channel of this shard's inputs fails a limit (fail), is flagged
    /// for any reason (flagged), or never. Input errors (exit 1) take precedence.
    #[arg(long, default_value = "fail", value_name = "WHEN")]
    pub fail_on: String,

    /// Files analysed at the same time (each file's analysis is itself parallel over channels);
    /// memory grows with this number, not with the number of files.
    #[arg(long, default_value_t = 1, value_name = "N")]
    pub threads: usize,

    /// Memory for the analyses in flight at once, e.g. 4G, 512M (bytes, K, M, G, T; powers of
    /// 1024): a file starts only when its estimated footprint fits beside the others (a file
    /// larger than the budget runs alone). Without it, --threads alone bounds them.
    #[arg(long, value_name = "SIZE")]
    pub memory_budget: Option<String>,

    /// Recompute inputs whose earlier result is an error (by default an unchanged file with
    /// unchanged options is not retried).
    #[arg(long)]
    pub retry_errors: bool,

    /// No progress bar and no per-file lines on stderr (errors are still printed).
    #[arg(short, long)]
    pub quiet: bool,

    /// Show what the graphics drivers say while the GPU is probed, and why a GPU was not used.
    #[arg(short, long)]
    pub verbose: bool,
}

/// Defaults of the `analyze` output flags, whatever fields they gain: `screen` writes its own
/// outputs and takes none of them, but [`config::job`] wants them.
#[derive(Debug, Parser)]
struct OutputDefaults {
    #[command(flatten)]
    output: OutputArgs,
}

/// A validated screen.
struct ScreenJob {
    analysis: config::Job,
    args: Vec<PathBuf>,
    shard: Shard,
    spec: Spec,
    layout: Layout,
    plots: PlotPolicy,
    fail_on: FailOn,
    memory_budget: Option<u64>,
    threads: usize,
    retry_errors: bool,
    quiet: bool,
    verbose: bool,
    options_hash: String,
}

/// `4G`, `512M`, `1.5GiB`, `1000000` → bytes (K, M, G, T are powers of 1024).
fn parse_size(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (num, suffix) = t.split_at(split);
    let value: f64 = num
        .parse()
        .map_err(|_| format!("{s:?}: expected a size such as 4G or 512M"))?;
    let shift = match suffix
        .trim()
        .to_ascii_uppercase()
        .trim_end_matches("IB")
        .trim_end_matches('B')
    {
        "" => 0,
        "K" => 10,
        "M" => 20,
        "G" => 30,
        "T" => 40,
        _ => return Err(format!("{s:?}: unknown unit (bytes, K, M, G or T)")),
    };
    let bytes = value * (1u64 << shift) as f64;
    if !(bytes >= 1.0 && bytes < u64::MAX as f64) {
        return Err(format!("{s:?}: must be at least one byte"));
    }
    Ok(bytes as u64)
}

fn usage(e: impl std::fmt::Display) -> UsageError {
    UsageError(e.to_string())
}

fn job(a: ScreenArgs) -> Result<ScreenJob, UsageError> {
    let ScreenArgs {
        input,
        fleet: f,
        welch,
        avar,
        fit,
        backend,
    } = a;
    let shard = match &f.shard {
        Some(s) => s
            .parse::<Shard>()
            .map_err(|e| usage(format!("--shard {e}")))?,
        None => Shard::ALL,
    };
    let plots: PlotPolicy = f.plots.parse().map_err(|e| usage(format!("--plots {e}")))?;
    let fail_on: FailOn = f
        .fail_on
        .parse()
        .map_err(|e| usage(format!("--fail-on {e}")))?;
    let memory_budget = f
        .memory_budget
        .as_deref()
        .map(parse_size)
        .transpose()
        .map_err(|e| usage(format!("--memory-budget {e}")))?;
    if f.threads == 0 {
        return Err(usage("--threads: must be at least 1"));
    }
    let spec = match &f.spec {
        Some(p) => Spec::read(p).map_err(|e| usage(format!("--spec {e}")))?,
        None => Spec::default(),
    };
    let mut args = input.files.clone();
    if f.files_from.iter().filter(|l| l.as_os_str() == "-").count() > 1 {
        return Err(usage("--files-from -: standard input can be read once"));
    }
    for list in &f.files_from {
        args.extend(
            fleet::inputs::read_list(list).map_err(|e| usage(format!("--files-from {e}")))?,
        );
    }
    if args.is_empty() {
        return Err(usage(
            "screen: give folders or files to screen, or --files-from LIST",
        ));
    }
    let output = OutputDefaults::try_parse_from(["screen"])
        .map_err(|e| usage(e.to_string()))?
        .output;
    let analysis = config::job(Cli {
        command: Command::Analyze(AnalyzeArgs {
            input,
            welch,
            avar,
            fit,
            output,
            backend,
        }),
    })?;
    // Everything that changes a file's result: the options as recorded, and the loop switch
    // (which the recorded options do not name).
    let options_hash = fleet::hash::options_hash(&json!({
        "analysis": analysis.options,
        "residual_loop": analysis.work.residual_loop,
    }));
    Ok(ScreenJob {
        analysis,
        args,
        shard,
        spec,
        layout: Layout::new(f.out),
        plots,
        fail_on,
        memory_budget,
        threads: f.threads,
        retry_errors: f.retry_errors,
        quiet: f.quiet,
        verbose: f.verbose,
        options_hash,
    })
}

/// Steps of the batch bar per file: it moves as a file's channels are fitted, not only when the
/// file ends, so the ETA follows long files too.
const STEPS_PER_FILE: u64 = 100;

/// Progress over the whole batch on a terminal, and one stderr line per file.
struct Report {
    bar: Option<ProgressBar>,
    quiet: bool,
    /// Files finished, and the fitted share of each file in flight (by key).
    done: std::sync::Mutex<(u64, std::collections::HashMap<String, f64>)>,
}

impl Report {
    fn new(total: usize, quiet: bool) -> Self {
        let bar = (!quiet && std::io::stderr().is_terminal()).then(|| {
            let b = ProgressBar::new(total as u64 * STEPS_PER_FILE);
            b.set_style(
                ProgressStyle::with_template(
                    "{bar:30} {files} files, {elapsed} elapsed, ETA {eta} {wide_msg}",
                )
                .map(|style| {
                    style.with_key(
                        "files",
                        |state: &ProgressState, w: &mut dyn std::fmt::Write| {
                            let len = state.len().unwrap_or(0) / STEPS_PER_FILE;
                            let _ = write!(w, "{}/{len}", state.pos() / STEPS_PER_FILE);
                        },
                    )
                })
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            b.enable_steady_tick(Duration::from_millis(500));
            b
        });
        Report {
            bar,
            quiet,
            done: std::sync::Mutex::new((0, std::collections::HashMap::new())),
        }
    }

    /// Sets the bar to the finished files plus the fitted shares of those in flight.
    fn update(&self, change: impl FnOnce(&mut (u64, std::collections::HashMap<String, f64>))) {
        let mut d = self.done.lock().unwrap_or_else(|e| e.into_inner());
        change(&mut d);
        if let Some(b) = &self.bar {
            let partial: f64 = d.1.values().sum();
            b.set_position(d.0 * STEPS_PER_FILE + (partial * STEPS_PER_FILE as f64) as u64);
        }
    }

    fn line(&self, text: &str) {
        match &self.bar {
            Some(b) => b.suspend(|| eprintln!("{text}")),
            None => eprintln!("{text}"),
        }
    }
}

/// The stderr line of a file's error: the path once (errors of reading already name it).
fn error_line(path: &str, e: &str) -> String {
    if e.contains(path) {
        format!("error {e}")
    } else {
        format!("error {path}: {e}")
    }
}

impl Observer for Report {
    fn started(&self, input: &Input) {
        if let Some(b) = &self.bar {
            b.set_message(input.rel.clone());
        }
    }

    fn progress(&self, input: &Input, fitted: f64) {
        self.update(|d| {
            d.1.insert(input.key.clone(), fitted.clamp(0.0, 0.99));
        });
    }

    fn finished(&self, input: &Input, outcome: &FileOutcome) {
        let path = input.path.display();
        self.update(|d| {
            d.1.remove(&input.key);
            d.0 += 1;
        });
        match outcome {
            FileOutcome::Skipped { error } | FileOutcome::Adopted { error } => {
                let what = if matches!(outcome, FileOutcome::Skipped { .. }) {
                    "skipped"
                } else {
                    "moved"
                };
                match error {
                    Some(e) => self.line(&format!(
                        "{} ({what}: unchanged since that run; --retry-errors retries)",
                        error_line(&path.to_string(), e)
                    )),
                    None if !self.quiet => self.line(&format!("{what} {path}: result up to date")),
                    None => {}
                }
            }
            FileOutcome::Computed {
                seconds,
                records,
                notes,
                ..
            } => {
                if let Some(e) = outcome.error() {
                    self.line(&error_line(&path.to_string(), e));
                    return;
                }
                if self.quiet {
                    return;
                }
                self.line(&format!(
                    "done  {path} ({seconds:.1} s): {} inertial channels",
                    records.len()
                ));
                for r in records.iter().filter(|r| r.status == Status::Ok) {
                    let channel = r.channel.as_deref().unwrap_or("");
                    if !r.effects_detail.is_empty() {
                        self.line(&format!(
                            "found {path} {channel}: {}",
                            r.effects_detail.join("; ")
                        ));
                    }
                    for d in &r.quality_detail {
                        self.line(&format!("quality {path} {channel}: {d}"));
                    }
                }
                for n in notes {
                    self.line(&format!("note  {path}: {n}"));
                }
            }
        }
    }
}

/// Runs `imunoise screen`; returns the exit code.
pub fn main(a: ScreenArgs) -> i32 {
    let job = match job(a) {
        Ok(j) => j,
        Err(e) => {
            eprintln!("imunoise: {e}");
            return EXIT_FATAL;
        }
    };
    match run(&job) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("imunoise: {e}");
            EXIT_FATAL
        }
    }
}

fn run(job: &ScreenJob) -> Result<i32, String> {
    let layout = &job.layout;
    // (An output folder that does not exist yet cannot be inside an input folder.)
    let (inputs, skipped) =
        collect_inputs_noting(&job.args, Some(&layout.dir)).map_err(|e| e.to_string())?;
    if !skipped.is_empty() {
        eprintln!(
            "imunoise: note: left out {} folder(s) holding imunoise outputs, not recordings: {}",
            skipped.len(),
            skipped
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    if inputs.is_empty() {
        return Err(format!(
            "no recordings found in {} (looked for .arrow, .feather, .ipc, .arrows, .parquet, \
             .pq, .csv, .mcap)",
            job.args
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    std::fs::create_dir_all(&layout.dir)
        .map_err(|e| format!("cannot create {}: {e}", layout.dir.display()))?;
    let lock = Lock::acquire(&layout.shard_lock(job.shard.index)).map_err(|e| e.to_string())?;
    if let Some(t) = &lock.took_over {
        eprintln!(
            "imunoise: note: took over the stale lock {} of pid {} on {} ({})",
            lock.path().display(),
            t.pid,
            t.host,
            t.why
        );
    }
    let quiet = job.quiet;
    let chatter = Chatter {
        verbose: job.verbose,
        quiet,
    };
    let mine_paths = inputs
        .iter()
        .filter(|i| i.in_shard(job.shard))
        .map(|i| i.path.as_path());
    let workload = Workload::of(mine_paths, &job.analysis.work);
    // Named at once below, so a GPU still opening is waited for here; the process keeps it (see
    // `backend`'s module docs).
    let backend: &dyn Backend = Box::leak(
        super::backend::choose(job.analysis.backend, chatter, workload)
            .map_err(|e| gpu_failure(&e, job.verbose))?
            .backend,
    );
    if !quiet && job.analysis.backend != BackendChoice::Cpu {
        eprintln!("imunoise: backend {}", backend.describe());
    }
    let mine = inputs.iter().filter(|i| i.in_shard(job.shard)).count();
    if !quiet {
        eprintln!(
            "imunoise: screening {mine} of {} recordings (shard {}) into {}",
            inputs.len(),
            job.shard,
            layout.dir.display()
        );
    }
    let report = Report::new(mine, quiet);
    let cfg = BatchConfig {
        layout,
        shard: job.shard,
        inputs: &job.analysis.inputs,
        work: &job.analysis.work,
        options: &job.options_hash,
        threads: job.threads,
        retry_errors: job.retry_errors,
        plots: job.plots,
        spec: &job.spec,
        memory_budget: job.memory_budget,
    };
    let batch = fleet::run_batch(&cfg, &inputs, backend, &report);
    if let Some(b) = &report.bar {
        b.finish_and_clear();
    }
    let batch = batch.map_err(|e| e.to_string())?;
    drop(lock);

    // The fleet step reads every shard's results; one at a time, so that the last shard to
    // finish writes the table with everything.
    let fleet_lock =
        Lock::wait(&layout.fleet_lock(), FLEET_LOCK_PATIENCE).map_err(|e| e.to_string())?;
    let title = format!(
        "imunoise {} screen: {} recordings in {} shard{}; options {}.",
        env!("CARGO_PKG_VERSION"),
        inputs.len(),
        job.shard.count,
        if job.shard.count == 1 { "" } else { "s" },
        job.options_hash
    );
    let fleet = fleet_step(
        layout,
        job.shard.count,
        &job.options_hash,
        &job.spec,
        &title,
        &inputs,
    )
    .map_err(|e| e.to_string())?;
    // Plots the fleet step decides (outliers, unusual effects) while the lock keeps other
    // shards' fleet steps out.
    let plotted = plot_after_fleet(
        layout,
        &fleet,
        job.plots,
        &job.analysis.inputs,
        &job.analysis.work,
        backend,
    );
    drop(fleet_lock);
    for (key, e) in &plotted.failed {
        eprintln!("imunoise: plots of {key} not written: {e}");
    }
    if !quiet {
        let rows = &fleet.fleet.rows;
        let flagged = rows.iter().filter(|r| r.flagged).count();
        eprintln!(
            "shard {}: {} computed, {} skipped, {} moved, {} with errors{}",
            job.shard,
            batch.computed,
            batch.skipped,
            batch.adopted,
            batch.failed,
            if batch.pruned > 0 {
                format!("; {} results of former inputs removed", batch.pruned)
            } else {
                String::new()
            }
        );
        if batch.computed > 0 {
            eprintln!(
                "time of the {} files computed, summed over files: {}",
                batch.computed,
                batch.time.describe()
            );
        }
        let missing = fleet
            .shards_not_run()
            .map_or(String::new(), |k| format!(", shards not run yet: {k}"));
        eprintln!(
            "fleet: {} files, {} channels, {flagged} flagged, {} pending{missing}; {} and {}",
            fleet.files,
            rows.iter()
                .filter(|r| r.record.status == Status::Ok)
                .count(),
            fleet.pending.len(),
            layout.summary().display(),
            layout.html().display()
        );
    }
    if !quiet && (!plotted.written.is_empty() || plotted.removed > 0) {
        eprintln!(
            "plots: {} drawn after the fleet step ({}), {} folders of former inputs removed",
            plotted.written.len(),
            plotted.written.join(", "),
            plotted.removed
        );
    }
    let mine: std::collections::BTreeSet<&str> = inputs
        .iter()
        .filter(|i| i.in_shard(job.shard))
        .map(|i| i.key.as_str())
        .collect();
    let matched = fleet
        .fleet
        .rows
        .iter()
        .filter(|r| mine.contains(r.record.key.as_str()) && job.fail_on.matches(r))
        .count();
    // Inputs that failed outrank limits (exit 1 over 3): the line names the code returned.
    let code = if batch.failed > 0 {
        EXIT_SOME_FAILED
    } else if matched > 0 {
        FailOn::EXIT_CODE
    } else {
        EXIT_OK
    };
    if !quiet && matched > 0 {
        let head = if code == FailOn::EXIT_CODE {
            format!("exit {code}")
        } else {
            format!(
                "exit {code} (inputs failed, which outranks exit {})",
                FailOn::EXIT_CODE
            )
        };
        let one = matched == 1;
        eprintln!(
            "{head}: {matched} channel{} {}",
            if one { "" } else { "s" },
            match (job.fail_on, one) {
                (FailOn::Fail, true) => "fails a limit of the specification (--fail-on fail)",
                (FailOn::Fail, false) => "fail a limit of the specification (--fail-on fail)",
                (_, true) => "is flagged (--fail-on flagged)",
                (_, false) => "are flagged (--fail-on flagged)",
            }
        );
    }
    Ok(code)
}

#[cfg(test)]
mod tests {
    use super::parse_size;

    #[test]
    fn sizes_parse_with_binary_units() {
        assert_eq!(parse_size("4G"), Ok(4 << 30));
        assert_eq!(parse_size("512M"), Ok(512 << 20));
        assert_eq!(parse_size("1.5GiB"), Ok(3 << 29));
        assert_eq!(parse_size("2048"), Ok(2048));
        assert_eq!(parse_size(" 8 kb"), Ok(8 << 10));
        for bad in ["", "G", "4X", "-1G", "0"] {
            assert!(parse_size(bad).is_err(), "{bad}");
        }
    }
}
