//! Command-line flags as plain values (clap derive). [`super::config`] turns them into validated
//! library objects before any file is opened, so that a bad flag fails at once.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

/// `imunoise --version`: the crate version and the git commit it was built from.
const VERSION: &str = concat!(
    env!("CARGO_PKG_VERSION"),
    " (commit ",
    env!("IMUNOISE_COMMIT"),
    " ",
    env!("IMUNOISE_COMMIT_DATE"),
    ")"
);

/// Noise characterisation of inertial sensors: Welch PSD and Allan-family deviations of long static
/// recordings (Arrow IPC, Parquet, CSV).
///
/// Values are converted to SI on reading (gyro rad/s, accel m/s^2, temperature degC), so PSDs are in
/// (rad/s)^2/Hz or (m/s^2)^2/Hz and deviations in rad/s or m/s^2. Exit codes: 0 all inputs fine,
/// 1 some inputs failed (the others are still processed and written), 2 usage or fatal error.
#[derive(Debug, Parser)]
#[command(name = "imunoise", version = VERSION, max_term_width = 100)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Describe recordings: format, sample rate and its source, channels with unit and kind, rows,
    /// duration, and the quality screen (gaps, non-finite samples, saturation, quantisation step).
    Info(InfoArgs),
    /// Welch power spectral density of every channel (one-sided), raw and log-frequency binned.
    Psd(PsdArgs),
    /// Allan-family deviations of every channel with chi-square confidence intervals.
    Avar(AvarArgs),
    /// The main job: PSD and Allan deviation of every channel in one pass over each file, the IEEE
    /// noise model (Q, N, B, K, R) fitted to both with confidence intervals, and a report folder
    /// (report.json, summary.md, plots, tables, Kalibr imu.yaml).
    Analyze(AnalyzeArgs),
    /// Simulate a static IMU recording from a noise-model specification (JSON file and/or flags)
    /// and write it as an Arrow IPC file with units, kinds and the sample rate in its metadata.
    Simulate(SimulateArgs),
    /// Screen a fleet: analyse every recording of folders (or lists) as `analyze` does, write one
    /// Parquet result per file as soon as it is done (a rerun skips what is up to date), then judge
    /// every sensor against a specification (--spec) and against its siblings (robust outliers,
    /// unusual effects): fleet.parquet, summary.md, fleet.html. --shard K/N splits a job array.
    Screen(super::screen::ScreenArgs),
}

#[derive(Debug, Args)]
pub struct InfoArgs {
    #[command(flatten)]
    pub input: InputArgs,
    #[command(flatten)]
    pub output: OutputArgs,
    #[command(flatten)]
    pub backend: BackendArgs,
}

#[derive(Debug, Args)]
pub struct PsdArgs {
    #[command(flatten)]
    pub input: InputArgs,
    #[command(flatten)]
    pub welch: WelchArgs,
    #[command(flatten)]
    pub output: OutputArgs,
    #[command(flatten)]
    pub backend: BackendArgs,
}

#[derive(Debug, Args)]
pub struct AvarArgs {
    #[command(flatten)]
    pub input: InputArgs,
    #[command(flatten)]
    pub avar: AvarFlags,
    #[command(flatten)]
    pub output: OutputArgs,
    #[command(flatten)]
    pub backend: BackendArgs,
}

#[derive(Debug, Args)]
pub struct AnalyzeArgs {
    #[command(flatten)]
    pub input: InputArgs,
    #[command(flatten)]
    pub welch: WelchArgs,
    #[command(flatten)]
    pub avar: AvarFlags,
    #[command(flatten)]
    pub fit: FitFlags,
    #[command(flatten)]
    pub output: OutputArgs,
    #[command(flatten)]
    pub backend: BackendArgs,
}

/// Noise-model fit options.
#[derive(Debug, Args)]
#[command(next_help_heading = "Noise model")]
pub struct FitFlags {
    /// Terms the fit may use, comma-separated: Q (quantisation), N (angle/velocity random walk),
    /// B (bias instability), K (rate/acceleration random walk), R (rate ramp). Each enters only if
    /// the information criterion says it earns its place.
    #[arg(
        long,
        default_value = "Q,N,B,K,R",
        value_delimiter = ',',
        value_name = "TERM,..."
    )]
    pub terms: Vec<String>,

    /// Information criterion that admits terms: bic (consistent: finds the terms present) or aicc.
    #[arg(long, default_value = "bic", value_name = "CRITERION")]
    pub criterion: String,

    /// Lowest spectrum band used by the fit, Hz (default 4·rate/nperseg).
    #[arg(long, value_name = "HZ")]
    pub fit_min_freq: Option<f64>,

    /// Highest spectrum band used by the fit, Hz (default: up to Nyquist). The Allan fit then
    /// starts where white noise above HZ would make up at most 2 % of the Allan variance
    /// (τ ≥ 7.6/HZ).
    #[arg(long, value_name = "HZ")]
    pub fit_max_freq: Option<f64>,

    /// Fit the IEEE model only: do not look for effects it lacks (lines, resonances, Gauss–Markov
    /// processes, temperature coupling, spikes, bias steps) in what it leaves unexplained.
    #[arg(long)]
    pub no_loop: bool,

    /// Kalibr topic written into imu.yaml.
    #[arg(long, default_value = "/imu0", value_name = "TOPIC")]
    pub rostopic: String,
}

/// What to simulate and where to write it.
#[derive(Debug, Args)]
pub struct SimulateArgs {
    /// Specification file (JSON, SI units; see the README). Flags below override its values.
    #[arg(long, value_name = "FILE")]
    pub spec: Option<PathBuf>,

    /// Output file; the extension picks the format: .arrow (Arrow IPC file), .arrows (Arrow IPC
    /// stream), .parquet, .csv (time in seconds, units in the header).
    #[arg(short, long, value_name = "FILE")]
    pub out: PathBuf,

    /// Sample rate, Hz.
    #[arg(long, value_name = "HZ")]
    pub rate: Option<f64>,

    /// Length, seconds.
    #[arg(long, value_name = "SECONDS")]
    pub duration: Option<f64>,

    /// Seed of the random streams (same seed, same recording).
    #[arg(long)]
    pub seed: Option<u64>,

    /// Without --spec: which sensor the flag-built channels are (gyro or accel).
    #[arg(long, default_value = "gyro", value_name = "SENSOR")]
    pub sensor: String,

    /// Without --spec: number of axes (channels named gyro_x, gyro_y, ... or accel_x, ...).
    #[arg(long, default_value_t = 3, value_name = "N")]
    pub axes: usize,

    /// Without --spec: a noise coefficient as TERM=VALUEUNIT, e.g. N=0.15deg/sqrt(h),
    /// B=3deg/h, K=0.5deg/h/sqrt(h), Q=2arcsec, R=10deg/h^2, or for accelerometers
    /// N=60ug/sqrt(Hz), B=20ug. The unit is required. Repeatable.
    #[arg(long = "noise", value_name = "TERM=VALUEUNIT")]
    pub noise: Vec<String>,

    /// Store samples as f32 instead of f64.
    #[arg(long)]
    pub f32: bool,

    /// No summary line on stderr.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Which files and columns, and how to read them.
#[derive(Debug, Args)]
#[command(next_help_heading = "Input")]
pub struct InputArgs {
    /// Recordings to process (.arrow/.feather/.ipc Arrow IPC file, .arrows Arrow IPC stream,
    /// .parquet, .csv, .mcap ROS 2 bag). One bad file does not stop the others.
    #[arg(required = true, value_name = "FILE")]
    pub files: Vec<PathBuf>,

    /// Columns to analyse, comma-separated (default: every numeric column except time).
    #[arg(long, value_delimiter = ',', value_name = "NAME,...")]
    pub channels: Vec<String>,

    /// Sample rate in Hz, for files without `sample_rate_hz` metadata or a time column. An error if it
    /// disagrees (by more than 0.5%) with the file.
    #[arg(long, value_name = "HZ")]
    pub rate: Option<f64>,

    /// Unit of a column, overriding its metadata: COLUMN=UNIT; COLUMN may be a pattern with * and
    /// ? ('gyro_*=deg/s', '*=UNIT' for all columns; the exact name, then the longest pattern
    /// wins). Units: rad/s, mrad/s, deg/s, deg/h, m/s^2, g, mg, ug, degC, K, V, mV, 1 (and the
    /// spellings the README lists). Raw counts: one count's worth in front, COLUMN="0.00875
    /// deg/s". Repeatable.
    #[arg(long = "unit", value_name = "COLUMN=UNIT")]
    pub units: Vec<String>,

    /// Kind of a column, overriding its metadata: COLUMN=KIND, COLUMN a name or a pattern as for
    /// --unit, KIND one of gyro, accel, temperature, aux. Repeatable.
    #[arg(long = "kind", value_name = "COLUMN=KIND")]
    pub kinds: Vec<String>,

    /// Name of the time column (Arrow timestamp, float seconds, or integer ticks with metadata unit
    /// s/ms/us/ns). Default: a timestamp-typed column, else one named (any case) field.header.stamp,
    /// time, timestamp, t, time_s, time_ms, time_us, time_ns, timestamp_ms, timestamp_us, timestamp_ns,
    /// stamp, %time or __time, the earliest in this list where several are.
    #[arg(long, value_name = "NAME", conflicts_with = "no_time")]
    pub time_column: Option<String>,

    /// Unit of a time column stored as plain numbers: s, ms, us or ns (overrides the column's `unit`
    /// metadata). Without it, an integer time column with no unit is read in the one unit that gives
    /// a plausible IMU rate (1 Hz to 10 kHz) or agrees with the stated rate, and refused when that is
    /// ambiguous; float columns are seconds.
    #[arg(long, value_name = "UNIT", conflicts_with = "no_time")]
    pub time_unit: Option<String>,

    /// Ignore any time column (no gap checks; the rate must come from metadata or --rate).
    #[arg(long)]
    pub no_time: bool,

    /// What to do with NaN, infinite or null samples: error (stop, naming the row), drop (remove the
    /// row), interpolate (straight line between finite neighbours). Default: error, except for
    /// `info`, which counts them (interpolate).
    #[arg(long, value_name = "POLICY")]
    pub on_nonfinite: Option<String>,

    /// What to do where the time column shows missing samples (an interval over 1.5 sample periods):
    /// error (stop, naming the row), ignore (report, analyse as contiguous), fill (insert linearly
    /// interpolated samples). Default: error, except for `info`, which describes the gaps
    /// (ignore).
    #[arg(long, value_name = "POLICY")]
    pub on_gap: Option<String>,

    /// What to do with a row whose timestamp repeats the previous row's (a message published
    /// twice): error (stop, naming the row), drop (keep the first, count the others). Default:
    /// error, except for `info`, which counts them (drop).
    #[arg(long, value_name = "POLICY")]
    pub on_duplicate: Option<String>,

    /// MCAP files: the sensor_msgs/msg/Imu topic to read (needed when a file has several; the error
    /// lists them). Temperature topics join as channels. An error for other formats.
    #[arg(long, value_name = "TOPIC")]
    pub topic: Option<String>,

    /// Rows per block read: the record batches of CSV, Parquet and MCAP files, and the blocks an
    /// Arrow IPC file's batches (mapped, not copied) are cut into.
    #[arg(long, default_value_t = imunoise::io::DEFAULT_BATCH_ROWS, value_name = "ROWS")]
    pub batch_rows: usize,
}

/// Welch PSD options; the same meaning and defaults as scipy.signal.welch where it has them.
#[derive(Debug, Args)]
#[command(next_help_heading = "Welch PSD")]
pub struct WelchArgs {
    /// Window: hann, hamming, blackman, blackmanharris, flattop, boxcar (periodic, as scipy).
    #[arg(long, default_value = "hann", value_name = "NAME")]
    pub window: String,

    /// Segment length in samples; the frequency resolution is rate/nperseg Hz.
    #[arg(long, default_value_t = 4096, value_name = "SAMPLES")]
    pub nperseg: usize,

    /// Overlap between segments in samples (default nperseg/2).
    #[arg(long, value_name = "SAMPLES")]
    pub noverlap: Option<usize>,

    /// FFT length in samples, >= nperseg (zero padding; default nperseg).
    #[arg(long, value_name = "SAMPLES")]
    pub nfft: Option<usize>,

    /// Detrend each segment: constant (remove the mean), linear (remove a least-squares line), none.
    #[arg(long, default_value = "constant", value_name = "MODE")]
    pub detrend: String,

    /// density: unit^2/Hz (divide by rate·Σw²); spectrum: unit^2 (divide by (Σw)², for line amplitudes).
    #[arg(long, default_value = "density", value_name = "SCALING")]
    pub scaling: String,

    /// Average of the segment periodograms: mean, or median (robust to bursts; bias-corrected as scipy).
    #[arg(long, default_value = "mean", value_name = "AVERAGE")]
    pub average: String,

    /// Log-frequency bins per decade for the binned spectrum (psd_binned table); 0 for none.
    #[arg(long, default_value_t = 20, value_name = "N")]
    pub bins_per_decade: u32,
}

/// Allan-family options.
#[derive(Debug, Args)]
#[command(next_help_heading = "Allan deviation")]
pub struct AvarFlags {
    /// Statistics, comma-separated: oadev (overlapping Allan), adev (non-overlapping Allan), mdev
    /// (modified Allan), hdev (Hadamard, non-overlapping as NIST SP 1065 and allantools), ohdev
    /// (overlapping Hadamard). The Hadamard deviations are insensitive to a rate ramp.
    #[arg(
        long = "stat",
        default_value = "oadev",
        value_delimiter = ',',
        value_name = "STAT,..."
    )]
    pub statistics: Vec<String>,

    /// Tau grid: octave (m = 1, 2, 4, ...), decade (1-2-5 per decade), N-per-decade (N log-spaced
    /// per decade, e.g. 10-per-decade), all (every m), or a comma-separated list of tau in seconds
    /// (each rounded to a whole number of sample periods).
    #[arg(long, default_value = "octave", value_name = "GRID")]
    pub taus: String,

    /// Two-sided confidence of the intervals, in (0, 1); 1sigma = 0.6827.
    #[arg(long, default_value = "1sigma", value_name = "LEVEL")]
    pub confidence: String,
}

/// Which hardware computes the estimates.
#[derive(Debug, Args)]
#[command(next_help_heading = "Backend")]
pub struct BackendArgs {
    /// auto: the CPU, unless the run computes the OADEV beyond octave τ on an input of 256 MiB or
    /// more and a hardware GPU is found (then the GPU, named on stderr and in the outputs; below
    /// that a GPU's fixed cost outweighs its gain; -v says why); gpu: a GPU or an error (exit 2);
    /// cpu: the CPU reference path. Options the GPU path lacks (median
    /// averaging, non-power-of-two nfft, statistics other than oadev) run on the CPU and the outputs
    /// say so; a GPU that fails mid-run is replaced by the CPU with a warning.
    #[arg(long, default_value = "auto", value_name = "BACKEND")]
    pub backend: String,
}

/// Where results go.
#[derive(Debug, Args)]
#[command(next_help_heading = "Output")]
pub struct OutputArgs {
    /// Output folder (created if needed; default imunoise-out for psd, avar and analyze, while info
    /// prints a table and writes files only when this is given). Files are written under temporary
    /// names and renamed, so a run that fails leaves earlier results intact.
    #[arg(short, long, value_name = "DIR")]
    pub out: Option<PathBuf>,

    /// Table formats written into the output folder, comma-separated: arrow, csv, json.
    #[arg(
        long,
        default_value = "arrow,csv,json",
        value_delimiter = ',',
        value_name = "FMT,..."
    )]
    pub format: Vec<String>,

    /// Print the JSON document on stdout instead of writing the output folder.
    #[arg(long)]
    pub json: bool,

    /// No progress bar and no per-file lines on stderr (errors are still printed).
    #[arg(short, long)]
    pub quiet: bool,

    /// Say more on stderr: why no GPU was used, and what the graphics drivers print while the GPU
    /// is probed (hidden otherwise).
    #[arg(short, long, conflicts_with = "quiet")]
    pub verbose: bool,
}
