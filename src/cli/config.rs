//! From plain flags to a validated job: every flag parsed, every plan built, before any file is read.

use std::path::PathBuf;

use imunoise::avar::{Confidence, Statistic, TauGrid};
use imunoise::io::{ColumnOverrides, OpenOptions, TimeUnit};
use imunoise::model::{Criterion, FitOptions, Term};
use imunoise::pipeline::{AvarWork, Inputs, TauSpec, WelchWork, Work};
use imunoise::psd::{Scaling, WelchConfig};
use imunoise::quality::QualityOptions;
use imunoise::report::Formats;
use imunoise::units::{Kind, ScaledUnit};
use serde_json::{json, Value};

use super::args::{
    AvarFlags, BackendArgs, Cli, Command, FitFlags, InputArgs, OutputArgs, WelchArgs,
};

/// A usage error: a flag that does not parse or makes no sense (exit code 2).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct UsageError(pub String);

/// Bounds of flags whose extreme values would run for hours or exhaust memory rather than fail.
const MAX_BATCH_ROWS: usize = 1 << 24;
/// Log bins per decade of the binned spectrum: beyond this the bins are finer than a long Welch
/// segment's resolution anyway.
const MAX_BINS_PER_DECADE: u32 = 1000;
/// ...and for the fit, whose cost grows with the number of bins.
const MAX_FIT_BINS_PER_DECADE: u32 = 200;

fn usage(e: impl std::fmt::Display) -> UsageError {
    UsageError(e.to_string())
}

/// The output folder when `-o/--out` is not given (`psd`, `avar`, `analyze`).
pub const DEFAULT_OUT: &str = "imunoise-out";

/// Where and how results are written.
#[derive(Debug, Clone)]
pub struct OutputConfig {
    pub dir: PathBuf,
    /// Whether `-o/--out` was given: `info` writes files only then.
    pub dir_given: bool,
    pub formats: Formats,
    pub json_stdout: bool,
    pub quiet: bool,
    /// `-v`: the graphics drivers' own messages and the reason no GPU was used.
    pub verbose: bool,
    /// `analyze`: the topic written into the Kalibr imu.yaml.
    pub kalibr_topic: Option<String>,
}

/// The `--backend` asked for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BackendChoice {
    Auto,
    Gpu,
    Cpu,
}

fn backend_choice(a: &BackendArgs) -> Result<BackendChoice, UsageError> {
    match a.backend.trim() {
        "auto" => Ok(BackendChoice::Auto),
        "gpu" => Ok(BackendChoice::Gpu),
        "cpu" => Ok(BackendChoice::Cpu),
        other => Err(usage(format!(
            "--backend {other:?}: expected auto, gpu or cpu"
        ))),
    }
}

/// A validated run.
#[derive(Debug, Clone)]
pub struct Job {
    pub command: &'static str,
    pub files: Vec<PathBuf>,
    pub inputs: Inputs,
    pub work: Work,
    pub output: OutputConfig,
    pub backend: BackendChoice,
    /// The options as recorded in the output document.
    pub options: Value,
}

pub fn job(cli: Cli) -> Result<Job, UsageError> {
    let (command, input, welch, avar, fit, output, backend) = match cli.command {
        Command::Info(a) => ("info", a.input, None, None, None, a.output, a.backend),
        Command::Psd(a) => (
            "psd",
            a.input,
            Some(a.welch),
            None,
            None,
            a.output,
            a.backend,
        ),
        Command::Avar(a) => (
            "avar",
            a.input,
            None,
            Some(a.avar),
            None,
            a.output,
            a.backend,
        ),
        Command::Analyze(a) => {
            let (w, v, f) = (Some(a.welch), Some(a.avar), Some(a.fit));
            ("analyze", a.input, w, v, f, a.output, a.backend)
        }
        Command::Simulate(_) => return Err(usage("simulate is not a file-processing command")),
        Command::Screen(_) => return Err(usage("screen is run by cli::screen")),
    };
    let mut options = serde_json::Map::new();
    let inputs = inputs(&input, command == "info", &mut options)?;
    let welch = welch.map(|w| welch_work(&w, &mut options)).transpose()?;
    let mut avar = avar.map(|a| avar_work(&a, &mut options)).transpose()?;
    let kalibr_topic = fit.as_ref().map(|f| f.rostopic.clone());
    let residual_loop = fit.as_ref().is_some_and(|f| !f.no_loop);
    let fit = match fit {
        Some(f) => Some(fit_options(
            &f,
            welch.as_ref(),
            avar.as_mut(),
            &mut options,
        )?),
        None => None,
    };
    let mut output = output_config(&output)?;
    output.kalibr_topic = kalibr_topic;
    Ok(Job {
        command,
        files: input.files,
        inputs,
        work: Work {
            welch,
            avar,
            fit,
            residual_loop,
        },
        output,
        backend: backend_choice(&backend)?,
        options: Value::Object(options),
    })
}

fn pairs<T: std::str::FromStr>(
    entries: &[String],
    what: &str,
) -> Result<Vec<(String, T)>, UsageError>
where
    T::Err: std::fmt::Display,
{
    entries
        .iter()
        .map(|e| {
            let (col, value) = e.split_once('=').ok_or_else(|| {
                usage(format!(
                    "--{what} {e:?}: expected COLUMN={}",
                    what.to_uppercase()
                ))
            })?;
            let parsed = value
                .trim()
                .parse::<T>()
                .map_err(|err| usage(format!("--{what} {e:?}: {err}")))?;
            Ok((col.trim().to_string(), parsed))
        })
        .collect()
}

/// The input options; `describing` (`info`) reads past gaps and non-finite samples unless told
/// otherwise, so that it describes them (it had refused a file with one NaN, which is what a user
/// runs `info` to find out about).
fn inputs(
    a: &InputArgs,
    describing: bool,
    options: &mut serde_json::Map<String, Value>,
) -> Result<Inputs, UsageError> {
    let (gap_default, nonfinite_default) = if describing {
        ("ignore", "interpolate")
    } else {
        ("error", "error")
    };
    if let Some(r) = a.rate {
        if !(r.is_finite() && r > 0.0) {
            return Err(usage(format!(
                "--rate {r}: must be a positive number of Hz"
            )));
        }
    }
    if a.batch_rows == 0 || a.batch_rows > MAX_BATCH_ROWS {
        return Err(usage(format!(
            "--batch-rows {}: must be between 1 and {MAX_BATCH_ROWS}",
            a.batch_rows
        )));
    }
    let mut seen = std::collections::HashSet::new();
    if let Some(twice) = a.channels.iter().find(|c| !seen.insert(c.as_str())) {
        return Err(usage(format!("--channels: {twice:?} is named twice")));
    }
    let quality = QualityOptions {
        nonfinite: a
            .on_nonfinite
            .as_deref()
            .unwrap_or(nonfinite_default)
            .parse()
            .map_err(|e| usage(format!("--on-nonfinite: {e}")))?,
        gaps: a
            .on_gap
            .as_deref()
            .unwrap_or(gap_default)
            .parse()
            .map_err(|e| usage(format!("--on-gap: {e}")))?,
        duplicates: a
            .on_duplicate
            .as_deref()
            .unwrap_or(if describing { "drop" } else { "error" })
            .parse()
            .map_err(|e| usage(format!("--on-duplicate: {e}")))?,
    };
    if a.no_time && quality.gaps == imunoise::quality::GapPolicy::Fill {
        return Err(usage(
            "--on-gap fill needs the time column to find gaps, and --no-time ignores it",
        ));
    }
    let columns = ColumnOverrides {
        channels: a.channels.clone(),
        units: pairs::<ScaledUnit>(&a.units, "unit")?,
        kinds: pairs::<Kind>(&a.kinds, "kind")?,
        time_column: a.time_column.clone(),
        ignore_time: a.no_time,
        time_unit: match &a.time_unit {
            Some(text) => Some(
                text.parse::<TimeUnit>()
                    .map_err(|e| usage(format!("--time-unit: {e}")))?,
            ),
            None => None,
        },
    };
    options.insert(
        "input".into(),
        json!({
            "channels": a.channels, "rate_hz": a.rate, "units": a.units, "kinds": a.kinds,
            "time_column": a.time_column, "no_time": a.no_time, "time_unit": a.time_unit,
            "on_nonfinite": quality.nonfinite, "on_gap": quality.gaps,
            "on_duplicate": quality.duplicates, "topic": a.topic,
        }),
    );
    Ok(Inputs {
        open: OpenOptions {
            columns,
            rate_hz: a.rate,
            batch_rows: a.batch_rows,
            topic: a.topic.clone(),
        },
        quality,
    })
}

fn welch_work(
    a: &WelchArgs,
    options: &mut serde_json::Map<String, Value>,
) -> Result<WelchWork, UsageError> {
    let config = WelchConfig {
        window: a
            .window
            .parse()
            .map_err(|e| usage(format!("--window: {e}")))?,
        nperseg: a.nperseg,
        noverlap: a.noverlap,
        nfft: a.nfft,
        detrend: a
            .detrend
            .parse()
            .map_err(|e| usage(format!("--detrend: {e}")))?,
        scaling: a
            .scaling
            .parse()
            .map_err(|e| usage(format!("--scaling: {e}")))?,
        average: a
            .average
            .parse()
            .map_err(|e| usage(format!("--average: {e}")))?,
    };
    let plan = config.validate().map_err(usage)?;
    if a.bins_per_decade > MAX_BINS_PER_DECADE {
        return Err(usage(format!(
            "--bins-per-decade {}: must be between 0 and {MAX_BINS_PER_DECADE}",
            a.bins_per_decade
        )));
    }
    options.insert(
        "welch".into(),
        json!({
            "window": a.window, "nperseg": plan.nperseg(), "noverlap": plan.noverlap(),
            "nfft": plan.nfft(), "detrend": a.detrend, "scaling": a.scaling, "average": a.average,
            "bins_per_decade": a.bins_per_decade,
        }),
    );
    Ok(WelchWork {
        plan,
        bins_per_decade: (a.bins_per_decade > 0).then_some(a.bins_per_decade),
    })
}

/// `octave`, `decade`, `N-per-decade`, `all`, or τ in seconds.
pub fn tau_spec(text: &str) -> Result<TauSpec, UsageError> {
    let t = text.trim();
    let grid = match t {
        "octave" => Some(TauGrid::Octave),
        "decade" => Some(TauGrid::Decade125),
        "all" => Some(TauGrid::All),
        _ => match t.strip_suffix("-per-decade") {
            Some(n) => {
                let n: u32 = n
                    .parse()
                    .map_err(|_| usage(format!("--taus {t:?}: N-per-decade needs a whole N")))?;
                if n == 0 {
                    return Err(usage("--taus: N-per-decade needs N >= 1"));
                }
                Some(TauGrid::PerDecade(n))
            }
            None => None,
        },
    };
    if let Some(g) = grid {
        return Ok(TauSpec::Grid(g));
    }
    let seconds: Vec<f64> = t
        .split(',')
        .map(|s| s.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| {
            usage(format!(
                "--taus {t:?}: expected octave, decade, N-per-decade, all, or tau in seconds like 0.1,1,10"
            ))
        })?;
    if seconds.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
        return Err(usage(format!(
            "--taus {t:?}: every tau must be a positive number of seconds"
        )));
    }
    Ok(TauSpec::Seconds(seconds))
}

pub fn confidence(text: &str) -> Result<Confidence, UsageError> {
    match text.trim() {
        "1sigma" => Ok(Confidence::OneSigma),
        t => match t.parse::<f64>() {
            Ok(p) if p > 0.0 && p < 1.0 => Ok(Confidence::Level(p)),
            _ => Err(usage(format!(
                "--confidence {t:?}: expected 1sigma or a level in (0, 1)"
            ))),
        },
    }
}

fn avar_work(
    a: &AvarFlags,
    options: &mut serde_json::Map<String, Value>,
) -> Result<AvarWork, UsageError> {
    let statistics: Vec<Statistic> = a
        .statistics
        .iter()
        .map(|s| {
            s.trim()
                .parse::<Statistic>()
                .map_err(|e| usage(format!("--stat: {e}")))
        })
        .collect::<Result<_, _>>()?;
    if statistics.is_empty() {
        return Err(usage("--stat: name at least one statistic"));
    }
    let taus = tau_spec(&a.taus)?;
    let confidence = confidence(&a.confidence)?;
    options.insert(
        "avar".into(),
        json!({ "statistics": a.statistics, "taus": a.taus, "confidence": a.confidence }),
    );
    Ok(AvarWork {
        statistics,
        taus,
        confidence,
    })
}

fn output_config(a: &OutputArgs) -> Result<OutputConfig, UsageError> {
    let mut formats = Formats {
        arrow: false,
        csv: false,
        json: false,
    };
    for f in &a.format {
        match f.trim() {
            "arrow" => formats.arrow = true,
            "csv" => formats.csv = true,
            "json" => formats.json = true,
            other => {
                return Err(usage(format!(
                    "--format {other:?}: expected arrow, csv or json"
                )))
            }
        }
    }
    Ok(OutputConfig {
        dir: a.out.clone().unwrap_or_else(|| PathBuf::from(DEFAULT_OUT)),
        dir_given: a.out.is_some(),
        formats,
        json_stdout: a.json,
        quiet: a.quiet,
        verbose: a.verbose,
        kalibr_topic: None,
    })
}

/// The fit's options; the estimates it needs are checked (or added) here, before any file is read:
/// the Allan fit uses the OADEV (added to the statistics when not asked for), the spectrum fit a
/// density-scaled, log-binned spectrum.
fn fit_options(
    f: &FitFlags,
    welch: Option<&WelchWork>,
    avar: Option<&mut AvarWork>,
    options: &mut serde_json::Map<String, Value>,
) -> Result<FitOptions, UsageError> {
    let terms: Vec<Term> = f
        .terms
        .iter()
        .map(|t| {
            t.parse::<Term>()
                .map_err(|e| usage(format!("--terms: {e}")))
        })
        .collect::<Result<_, _>>()?;
    if terms.is_empty() {
        return Err(usage("--terms: name at least one term"));
    }
    let criterion: Criterion = f
        .criterion
        .parse()
        .map_err(|e| usage(format!("--criterion: {e}")))?;
    for (flag, v) in [
        ("--fit-min-freq", f.fit_min_freq),
        ("--fit-max-freq", f.fit_max_freq),
    ] {
        if let Some(v) = v {
            if !(v.is_finite() && v > 0.0) {
                return Err(usage(format!(
                    "{flag} {v}: must be a positive number of Hz"
                )));
            }
        }
    }
    if let (Some(lo), Some(hi)) = (f.fit_min_freq, f.fit_max_freq) {
        if lo >= hi {
            return Err(usage(format!(
                "--fit-min-freq {lo} must be below --fit-max-freq {hi}"
            )));
        }
    }
    if let Some(w) = welch {
        if w.bins_per_decade
            .is_some_and(|k| k > MAX_FIT_BINS_PER_DECADE)
        {
            return Err(usage(format!(
                "--bins-per-decade {}: analyze fits the binned spectrum, which needs between 1 and \
                 {MAX_FIT_BINS_PER_DECADE} bins per decade (finer bins only add correlated points \
                 and time)",
                w.bins_per_decade.unwrap_or(0)
            )));
        }
        if w.bins_per_decade.is_none() {
            return Err(usage(
                "analyze fits the log-binned spectrum: --bins-per-decade must be at least 1",
            ));
        }
        if w.plan.config().scaling != Scaling::Density {
            return Err(usage("analyze fits a density: --scaling must be density"));
        }
    }
    let mut confidence = Confidence::OneSigma;
    if let Some(a) = avar {
        if !a.statistics.contains(&Statistic::Oadev) {
            a.statistics.insert(0, Statistic::Oadev);
        }
        confidence = a.confidence;
    }
    let opts = FitOptions {
        terms,
        criterion,
        confidence,
        min_freq_hz: f.fit_min_freq,
        max_freq_hz: f.fit_max_freq,
        ..FitOptions::default()
    };
    options.insert(
        "fit".into(),
        json!({
            "terms": opts.terms.iter().map(|t| t.symbol()).collect::<Vec<_>>(),
            "criterion": opts.criterion,
            "min_freq_hz": opts.min_freq_hz, "max_freq_hz": opts.max_freq_hz,
            "correlated_points": opts.correlated_points,
        }),
    );
    Ok(opts)
}
