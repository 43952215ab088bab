//! The estimation backend a command asked for, chosen one way for `analyze`, `psd`, `avar` and
//! `screen`: `auto` takes a real GPU when there is one and the run is large enough for it to pay,
//! and the CPU otherwise (a software rasteriser such as lavapipe is slower than the CPU path);
//! `gpu` takes whatever adapter opens.
//!
//! A GPU has a fixed cost that the CPU path does not: measured on an H200 host (16 cores,
//! `examples/gpu_startup`, benches/results/h200_2026-11-28_run2.txt and run3), loading the Vulkan
//! driver and finding the adapter took 83–106 ms, opening the device 80–127 ms, each estimator's
//! first pipelines 3–33 ms (up to 215 ms with the driver's shader cache cold), and closing the
//! device 50–102 ms: a command on 10⁷ samples took 0.30–0.45 s on the GPU against 0.07–0.24 s on
//! the CPU end to end, whatever the estimator. So `auto`
//! weighs the run first ([`Workload`]) and computes on the CPU, without probing any GPU, unless
//! the run has the work a GPU did speed up end to end there, on inputs of at least
//! [`AUTO_GPU_MIN_BYTES`]. Then it opens the GPU on a thread of its own while the
//! first file is read ([`Opening`]), and the device is never closed (the process ends instead).

use std::path::Path;
use std::sync::{Arc, Mutex, OnceLock, PoisonError};
use std::thread::JoinHandle;

use imunoise::avar::{AvarError, Confidence, Deviations, Statistic, TauGrid};
use imunoise::estimate::{Backend, BackendKind, CpuBackend, Samples, WelchSink};
use imunoise::gpu::{
    probe_quietly, request_adapter, ContextOptions, GpuBackend, GpuContext, GpuError,
};
use imunoise::pipeline::{TauSpec, Work};
use imunoise::psd::{Psd, PsdError, WelchPlan};

use super::config::BackendChoice;

/// How much the choice may say on stderr.
#[derive(Clone, Copy, Debug)]
pub struct Chatter {
    /// Show the graphics stack's own messages during the probe and the reason a GPU failed.
    pub verbose: bool,
    /// Say nothing about falling back to the CPU.
    pub quiet: bool,
}

/// Opens the preferred GPU. Unless `verbose`, the graphics stack's own messages during the probe
/// (Mesa's "XDG_RUNTIME_DIR is invalid", loader warnings) are hidden; the error, if any, is
/// returned and printed by the caller once stderr is back.
fn open_gpu(verbose: bool) -> Result<GpuBackend, GpuError> {
    let options = ContextOptions {
        quiet_probe: !verbose,
        ..ContextOptions::default()
    };
    Ok(GpuBackend::with_context(Arc::new(
        GpuContext::with_options(&options)?,
    )))
}

/// What `auto` found.
enum Probe {
    Hardware(GpuBackend),
    /// A software rasteriser, by name: no device is opened on it.
    Software(String),
}

/// The preferred adapter, and a device on it only when it is real hardware: opening a device on
/// lavapipe was wasted work for `auto`, which computes on the CPU then (a tenth of a small file's
/// `avar`). Quiet as [`open_gpu`].
fn open_hardware_gpu(verbose: bool) -> Result<Probe, GpuError> {
    let options = ContextOptions {
        quiet_probe: !verbose,
        ..ContextOptions::default()
    };
    probe_quietly(options.quiet_probe, || {
        let adapter = request_adapter(&options)?;
        let info = adapter.get_info();
        if info.device_type == wgpu::DeviceType::Cpu {
            return Ok(Probe::Software(info.name));
        }
        let context = GpuContext::on_adapter(&adapter, &options)?;
        Ok(Probe::Hardware(GpuBackend::with_context(Arc::new(context))))
    })
}

/// The largest input, in bytes, from which `auto` opens a GPU for the overlapping Allan
/// deviation at τ beyond octaves (the prefix-sum kernel): 256 MiB is 3.4·10⁷ f64 samples ×
/// channels. On the H200 host of the module docs that kernel saved 0.95 s of the CPU's 1.39 s
/// (95 log-spaced τ, 10⁸ samples) against ≈ 0.2 s of fixed cost once the device opens beside the
/// reading: it pays from a few 10⁷ samples. Everything else stays on the CPU under `auto`, at any
/// size, because it did not pay there end to end: Welch (10⁸ samples: 0.42 s on the CPU, 0.63 s
/// on the GPU; 10⁷: 0.08 against 0.30 s), octave τ (0.68 against 0.92 s; its CPU pass is as fast
/// as the GPU's, 0.20 against 0.17 s), and fleets of one-hour recordings (9.3 sensors/s on either,
/// at 1.3× the memory on the GPU).
pub const AUTO_GPU_MIN_BYTES: u64 = 256 << 20;

/// What a run will compute, as far as the choice of backend needs it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Workload {
    /// Size of the largest input file (0 for one that cannot be read: its error comes later).
    pub largest_input_bytes: u64,
    /// Whether the run computes the OADEV at τ that are not all octaves (the work a GPU speeds).
    pub allan_beyond_octaves: bool,
}

impl Workload {
    /// The workload of `work` on `paths` (their sizes on disk: a proxy for samples × channels
    /// that needs no file opened; CSV overstates it, compressed Parquet understates it).
    pub fn of<'a>(paths: impl IntoIterator<Item = &'a Path>, work: &Work) -> Workload {
        let largest_input_bytes = paths
            .into_iter()
            .filter_map(|p| std::fs::metadata(p).ok())
            .map(|m| m.len())
            .max()
            .unwrap_or(0);
        let allan_beyond_octaves = work.avar.as_ref().is_some_and(|a| {
            a.statistics.contains(&Statistic::Oadev)
                && !matches!(a.taus, TauSpec::Grid(TauGrid::Octave))
        });
        Workload {
            largest_input_bytes,
            allan_beyond_octaves,
        }
    }

    /// Whether `auto` should look for a GPU at all.
    pub fn gpu_pays(&self) -> bool {
        self.allan_beyond_octaves && self.largest_input_bytes >= AUTO_GPU_MIN_BYTES
    }
}

/// The backend chosen, and whether it is still being opened (its `describe` then waits for it).
pub struct Chosen {
    pub backend: Box<dyn Backend>,
    pub opening: bool,
}

/// The backend for `choice`. An error only for `gpu`, which must not fall back.
pub fn choose(
    choice: BackendChoice,
    chatter: Chatter,
    workload: Workload,
) -> Result<Chosen, GpuError> {
    let ready = |backend: Box<dyn Backend>| Chosen {
        backend,
        opening: false,
    };
    match choice {
        BackendChoice::Cpu => Ok(ready(Box::new(CpuBackend))),
        BackendChoice::Gpu => Ok(ready(Box::new(open_gpu(chatter.verbose)?))),
        BackendChoice::Auto if !workload.gpu_pays() => {
            if chatter.verbose {
                let why = if workload.allan_beyond_octaves {
                    format!(
                        "the largest input is {:.1} MiB, under the {} MiB",
                        workload.largest_input_bytes as f64 / f64::from(1 << 20),
                        AUTO_GPU_MIN_BYTES >> 20
                    )
                } else {
                    "the run has no OADEV beyond octave τ, the only job".into()
                };
                eprintln!(
                    "imunoise: backend auto: {why} from which a GPU pays for opening it; computing on the CPU (--backend gpu forces one)"
                );
            }
            Ok(ready(Box::new(CpuBackend)))
        }
        BackendChoice::Auto => Ok(Chosen {
            backend: Box::new(Opening::spawn(chatter)),
            opening: true,
        }),
    }
}

/// `auto`'s choice among a hardware GPU and the CPU, made on the calling thread.
fn auto_backend(chatter: Chatter) -> Box<dyn Backend> {
    match open_hardware_gpu(chatter.verbose) {
        Ok(Probe::Hardware(gpu)) => {
            // A failure here is the context's: every job then falls back and says why.
            let _ = gpu.context().prepare_pipelines();
            Box::new(gpu)
        }
        Ok(Probe::Software(name)) => {
            if !chatter.quiet {
                eprintln!(
                    "imunoise: only a software GPU ({name}); computing on the CPU (--backend gpu forces it)"
                );
            }
            Box::new(CpuBackend)
        }
        Err(e) => {
            if chatter.verbose {
                eprintln!("imunoise: no usable GPU ({e}); computing on the CPU");
            } else if !chatter.quiet {
                eprintln!("imunoise: no usable GPU; computing on the CPU (-v says why)");
            }
            Box::new(CpuBackend)
        }
    }
}

/// `auto`'s backend while it is opened on a thread of its own, so that loading the driver and
/// opening the device (≈ 0.2 s on a discrete GPU) overlap the reading of the first file. Every
/// call waits for it except a Welch estimate's first pushes ([`DeferredWelch`]).
struct Opening {
    pending: Arc<Pending>,
}

struct Pending {
    ready: OnceLock<Box<dyn Backend>>,
    thread: Mutex<Option<JoinHandle<Box<dyn Backend>>>>,
}

impl Pending {
    /// The backend, waiting for the opening thread if it is still at work. A thread that
    /// panicked leaves the CPU.
    fn get(&self) -> &dyn Backend {
        self.ready
            .get_or_init(|| {
                let thread = self
                    .thread
                    .lock()
                    .unwrap_or_else(PoisonError::into_inner)
                    .take();
                thread
                    .and_then(|t| t.join().ok())
                    .unwrap_or_else(|| Box::new(CpuBackend))
            })
            .as_ref()
    }

    /// Whether [`get`](Self::get) would return at once.
    fn is_ready(&self) -> bool {
        self.ready.get().is_some()
            || self
                .thread
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .as_ref()
                .is_none_or(JoinHandle::is_finished)
    }
}

impl Opening {
    fn spawn(chatter: Chatter) -> Opening {
        let thread = std::thread::Builder::new()
            .name("gpu-open".into())
            .spawn(move || auto_backend(chatter));
        let pending = Pending {
            ready: OnceLock::new(),
            thread: Mutex::new(None),
        };
        match thread {
            Ok(t) => {
                *pending
                    .thread
                    .lock()
                    .unwrap_or_else(PoisonError::into_inner) = Some(t)
            }
            // No thread to spare: open it here, now.
            Err(_) => {
                let _ = pending.ready.set(auto_backend(chatter));
            }
        }
        Opening {
            pending: Arc::new(pending),
        }
    }
}

impl Backend for Opening {
    fn kind(&self) -> BackendKind {
        self.pending.get().kind()
    }

    fn describe(&self) -> String {
        self.pending.get().describe()
    }

    /// Nothing ran on a backend still opening, so there is nothing to take: a run asks for the
    /// notes before its first file, and waiting here would undo the overlap.
    fn take_notes(&self) -> Vec<String> {
        if self.pending.is_ready() {
            self.pending.get().take_notes()
        } else {
            Vec::new()
        }
    }

    fn welch(&self, plan: &WelchPlan, rate_hz: f64, channels: usize) -> Box<dyn WelchSink> {
        if self.pending.is_ready() {
            return self.pending.get().welch(plan, rate_hz, channels);
        }
        Box::new(DeferredWelch {
            pending: Arc::clone(&self.pending),
            plan: plan.clone(),
            rate_hz,
            held: vec![Vec::new(); channels],
            max_held: DEFERRED_WELCH_MAX_HELD,
            peak_held: 0,
            sink: None,
        })
    }

    fn deviations(
        &self,
        channels: &[Vec<f64>],
        rate_hz: f64,
        grid: &TauGrid,
        statistic: Statistic,
        confidence: Confidence,
    ) -> Vec<Result<Deviations, AvarError>> {
        self.pending
            .get()
            .deviations(channels, rate_hz, grid, statistic, confidence)
    }

    fn statistics(
        &self,
        samples: Samples<'_>,
        rate_hz: f64,
        grid: &TauGrid,
        statistics: &[Statistic],
        confidence: Confidence,
    ) -> Vec<Vec<Result<Deviations, AvarError>>> {
        self.pending
            .get()
            .statistics(samples, rate_hz, grid, statistics, confidence)
    }
}

/// The most samples (all channels together) a Welch estimate holds while the backend opens:
/// 32 Mi f64 is 256 MiB, about what a fast disk delivers in the ≈ 0.2 s a device takes to open.
/// Beyond it the push waits for the backend.
const DEFERRED_WELCH_MAX_HELD: usize = 32 << 20;

/// A Welch estimate started before its backend is open: the first pushes are held (up to
/// [`DEFERRED_WELCH_MAX_HELD`]) and handed, as one chunk, to the backend's own estimate once
/// it is open. The result is the backend's: a Welch estimate takes chunks of any size.
struct DeferredWelch {
    pending: Arc<Pending>,
    plan: WelchPlan,
    rate_hz: f64,
    held: Vec<Vec<f64>>,
    /// [`DEFERRED_WELCH_MAX_HELD`] (less in tests).
    max_held: usize,
    peak_held: usize,
    sink: Option<Box<dyn WelchSink>>,
}

impl DeferredWelch {
    /// The backend's estimate, started (waiting for the backend) with the held samples.
    fn sink(&mut self) -> &mut Box<dyn WelchSink> {
        let pending = &self.pending;
        let (plan, rate_hz, held) = (&self.plan, self.rate_hz, &mut self.held);
        self.sink.get_or_insert_with(|| {
            let mut sink = pending.get().welch(plan, rate_hz, held.len());
            if held.first().is_some_and(|c| !c.is_empty()) {
                let chunk: Vec<&[f64]> = held.iter().map(Vec::as_slice).collect();
                sink.push(&chunk);
            }
            *held = Vec::new();
            sink
        })
    }
}

impl WelchSink for DeferredWelch {
    fn push(&mut self, chunk: &[&[f64]]) {
        let incoming = chunk.iter().map(|c| c.len()).sum::<usize>();
        let holding = self.held.iter().map(Vec::len).sum::<usize>();
        if self.sink.is_none() && !self.pending.is_ready() && holding + incoming <= self.max_held {
            for (h, c) in self.held.iter_mut().zip(chunk) {
                h.extend_from_slice(c);
            }
            self.peak_held = self.peak_held.max(self.held.first().map_or(0, Vec::len));
            return;
        }
        self.sink().push(chunk);
    }

    fn finish(mut self: Box<Self>) -> Result<Vec<Psd>, PsdError> {
        self.sink();
        let sink = self.sink.take().expect("started just above");
        sink.finish()
    }

    fn peak_buffered_samples(&self) -> usize {
        self.sink
            .as_ref()
            .map_or(0, |s| s.peak_buffered_samples())
            .max(self.peak_held)
    }
}

/// The line printed when `--backend gpu` cannot open one.
pub fn gpu_failure(e: &GpuError, verbose: bool) -> String {
    let hint = if verbose {
        ""
    } else {
        " (-v shows what the graphics drivers say)"
    };
    format!("--backend gpu: {e}{hint}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use imunoise::pipeline::AvarWork;
    use imunoise::psd::WelchConfig;
    use std::time::Duration;

    /// A backend that becomes the CPU after `delay`, as a GPU does after opening.
    fn pending_cpu(delay: Duration) -> Arc<Pending> {
        let thread = std::thread::spawn(move || {
            std::thread::sleep(delay);
            Box::new(CpuBackend) as Box<dyn Backend>
        });
        Arc::new(Pending {
            ready: OnceLock::new(),
            thread: Mutex::new(Some(thread)),
        })
    }

    fn signal(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = imunoise::sim::rng::Rng::new(seed);
        (0..n).map(|_| rng.gauss()).collect()
    }

    /// Held pushes (all of them, or up to the cap, after which pushes wait) give the backend's own
    /// result bit for bit for the chunks it was handed (the held ones as one), and the held
    /// samples count in the peak buffered.
    #[test]
    fn deferred_welch_is_the_backends_welch() {
        let channels = [signal(40_000, 1), signal(40_000, 2)];
        let plan = WelchConfig::new(1024).validate().unwrap();
        // What the backend sees: everything as one chunk (all held), or the first two pushes as
        // one and the rest as pushed (the cap reached at the third).
        let direct = |first: usize| {
            let mut sink = CpuBackend.welch(&plan, 100.0, 2);
            let mut start = 0;
            let mut end = first;
            while start < 40_000 {
                sink.push(&[&channels[0][start..end], &channels[1][start..end]]);
                start = end;
                end = (end + 3_000).min(40_000);
            }
            sink.finish().unwrap()
        };
        for (max_held, first) in [(usize::MAX, 40_000), (2 * 7_000, 6_000)] {
            let direct = direct(first);
            let pending = pending_cpu(Duration::from_millis(200));
            let mut deferred = Box::new(DeferredWelch {
                pending: Arc::clone(&pending),
                plan: plan.clone(),
                rate_hz: 100.0,
                held: vec![Vec::new(); 2],
                max_held,
                peak_held: 0,
                sink: None,
            });
            for start in (0..40_000).step_by(3_000) {
                let end = (start + 3_000).min(40_000);
                deferred.push(&[&channels[0][start..end], &channels[1][start..end]]);
            }
            if max_held == usize::MAX {
                assert!(deferred.sink.is_none(), "everything held while opening");
                assert_eq!(deferred.peak_buffered_samples(), 40_000);
            } else {
                assert!(deferred.sink.is_some(), "the cap made a push wait");
                assert_eq!(deferred.peak_held, 6_000);
            }
            let got = deferred.finish().unwrap();
            for (g, d) in got.iter().zip(&direct) {
                assert_eq!(g.value, d.value, "max_held {max_held}");
                assert_eq!(g.segments, d.segments);
            }
        }
    }

    /// A run asks for the notes before its first file: that must not wait for the opening.
    #[test]
    fn notes_do_not_wait_for_the_opening() {
        let opening = Opening {
            pending: pending_cpu(Duration::from_millis(1500)),
        };
        let started = std::time::Instant::now();
        assert!(opening.take_notes().is_empty());
        assert!(started.elapsed() < Duration::from_millis(500));
        assert_eq!(opening.kind(), BackendKind::Cpu, "waits, then answers");
    }

    /// Once the backend is open, a Welch estimate is the backend's own from the start.
    #[test]
    fn an_open_backend_is_used_directly() {
        let pending = pending_cpu(Duration::ZERO);
        let opening = Opening {
            pending: Arc::clone(&pending),
        };
        pending.get();
        assert!(pending.is_ready());
        assert_eq!(opening.kind(), BackendKind::Cpu);
        let plan = WelchConfig::new(256).validate().unwrap();
        let mut sink = opening.welch(&plan, 1.0, 1);
        let x = signal(1_000, 3);
        sink.push(&[&x]);
        assert!(sink.peak_buffered_samples() < 256, "no samples held back");
    }

    #[test]
    fn auto_weighs_the_work_and_the_largest_input() {
        let dir = std::env::temp_dir().join(format!("imunoise-workload-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (small, large) = (dir.join("small"), dir.join("large"));
        std::fs::write(&small, [0u8; 10]).unwrap();
        // Sparse: the size on disk is what counts, not the blocks written.
        std::fs::File::create(&large)
            .unwrap()
            .set_len(AUTO_GPU_MIN_BYTES)
            .unwrap();
        let missing = dir.join("missing");
        let avar = |statistics: Vec<Statistic>, taus: TauSpec| Work {
            avar: Some(AvarWork {
                statistics,
                taus,
                confidence: Confidence::OneSigma,
            }),
            ..Work::default()
        };
        let log = TauSpec::Grid(TauGrid::PerDecade(10));
        let beyond = avar(vec![Statistic::Oadev], log.clone());
        let paths = [small.as_path(), missing.as_path(), large.as_path()];
        let w = Workload::of(paths, &beyond);
        assert_eq!(w.largest_input_bytes, AUTO_GPU_MIN_BYTES);
        assert!(w.allan_beyond_octaves && w.gpu_pays());
        assert!(!Workload::of([small.as_path()], &beyond).gpu_pays());
        for (what, work) in [
            (
                "octave",
                avar(vec![Statistic::Oadev], TauSpec::Grid(TauGrid::Octave)),
            ),
            ("no oadev", avar(vec![Statistic::Mdev], log.clone())),
            ("welch alone", Work::default()),
        ] {
            assert!(!Workload::of(paths, &work).gpu_pays(), "{what}");
        }
        let seconds = avar(
            vec![Statistic::Adev, Statistic::Oadev],
            TauSpec::Seconds(vec![3.0]),
        );
        assert!(Workload::of(paths, &seconds).gpu_pays());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
