//! The device and everything reused across jobs: queue, adapter description, limits, compiled
//! pipelines, pooled buffers, and the first failure the device reported.
//!
//! Getting a device ([`request_adapter`], [`request_device`]) is separate from the work, so a caller
//! (or a test) can open the device it wants — another adapter, smaller limits — and hand it in with
//! [`GpuContext::from_device`]. Limits come from the adapter itself (`adapter.limits()`), not from
//! wgpu's portable defaults: a discrete GPU typically binds gigabytes where the defaults allow
//! 128 MiB, and every doubling halves the number of chunks.
//!
//! Failure model: wgpu reports validation errors, out-of-memory and device loss asynchronously,
//! through callbacks. The context installs both callbacks and keeps the first failure; every
//! synchronisation point (waits and read-backs) checks it. A failure poisons the context
//! for good: with several jobs sharing one device, an error cannot be pinned on one of them, so every
//! job that sees it redoes its work on the CPU rather than risk returning a number computed after it.

use std::collections::HashMap;
use std::fmt;
use std::sync::{Arc, Mutex, PoisonError};

use super::pool::{BufferPool, Lease};
use super::shaders::{Kernel, WORKGROUP};
use super::timing::{KernelTimer, KernelTimes, Stage, Stamp};
use super::GpuError;

/// How to open a device.
#[derive(Debug, Clone)]
pub struct ContextOptions {
    /// Limits to request; `None` means the adapter's own (the most it allows). Smaller limits make
    /// every job chunk as it would on a smaller device (which is how the tests exercise chunking).
    pub limits: Option<wgpu::Limits>,
    /// Request SHADER_F64 when the adapter has it (used for Allan variances at non-octave taus).
    /// `false` forces the fixed-point scheme that works everywhere.
    pub allow_f64: bool,
    /// Which adapter to prefer when there are several.
    pub power_preference: wgpu::PowerPreference,
    /// Backends to look for adapters on; `None` means `WGPU_BACKEND` if set, else all compiled in
    /// (Vulkan, Metal, DX12).
    pub backends: Option<wgpu::Backends>,
    /// Most bytes of device buffers one job allocates at a time (larger inputs are processed in
    /// more, smaller batches; chunking for the device's binding limits happens regardless), and
    /// the most bytes of idle buffers the context keeps for reuse.
    pub memory_budget: u64,
    /// Send the process's stderr (fd 2) to /dev/null while the instance, adapter and device are
    /// created (see [`probe_quietly`]): Mesa and the Vulkan loader write warnings such as
    /// "XDG_RUNTIME_DIR is invalid" straight to fd 2 during enumeration. Off by default: it
    /// affects every thread of the process for that moment.
    pub quiet_probe: bool,
    /// Time every compute pass with GPU timestamps ([`GpuContext::kernel_times`]), when the
    /// adapter has TIMESTAMP_QUERY. For benchmarks only: each pass is then waited for at once.
    pub kernel_timing: bool,
}

impl Default for ContextOptions {
    fn default() -> Self {
        ContextOptions {
            limits: None,
            allow_f64: true,
            power_preference: wgpu::PowerPreference::HighPerformance,
            backends: None,
            memory_budget: 512 << 20,
            quiet_probe: false,
            kernel_timing: false,
        }
    }
}

/// Runs `f` with the process's stderr (file descriptor 2) sent to /dev/null when `quiet`, and
/// restores it afterwards on every path: on return, on error (an `Err` is a value, printed by the
/// caller after the restore) and on a panic (whose message, which the panic hook wrote into
/// /dev/null, is printed again once stderr is back, before the panic continues). Graphics drivers
/// write to fd 2 directly, past Rust's `stderr`, so only the descriptor can silence them.
///
/// While `f` runs, whatever any thread writes to stderr is lost: call it before other threads
/// print (the CLI probes before it starts its progress bar). Quiet probes are serialised, so two
/// at once cannot save each other's /dev/null as "the" stderr. Unix only; elsewhere `f` just runs.
pub fn probe_quietly<T>(quiet: bool, f: impl FnOnce() -> T) -> T {
    if !quiet {
        return f();
    }
    static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());
    let _serial = ONE_AT_A_TIME.lock().unwrap_or_else(PoisonError::into_inner);
    let silenced = silence::Stderr::to_null();
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
    drop(silenced);
    match result {
        Ok(v) => v,
        Err(payload) => {
            let message = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "(no message)".into());
            eprintln!("imunoise: panic while opening the GPU: {message}");
            std::panic::resume_unwind(payload)
        }
    }
}

#[cfg(unix)]
mod silence {
    use std::os::fd::{AsRawFd, FromRawFd, OwnedFd};
    use std::os::raw::c_int;

    // From the C library std links on every Unix (the `libc` crate declares the same).
    extern "C" {
        fn dup(fd: c_int) -> c_int;
        fn dup2(from: c_int, to: c_int) -> c_int;
    }

    const STDERR: c_int = 2;

    /// fd 2 pointed at /dev/null until dropped; the original is kept in `saved`. `saved` is `None`
    /// when anything failed, and then fd 2 was never touched.
    pub struct Stderr {
        saved: Option<OwnedFd>,
    }

    impl Stderr {
        pub fn to_null() -> Stderr {
            let Ok(null) = std::fs::OpenOptions::new().write(true).open("/dev/null") else {
                return Stderr { saved: None };
            };
            // SAFETY: dup has no memory-safety preconditions; a non-negative result is a new
            // descriptor that nothing else owns, so OwnedFd may take it (and close it on drop).
            let saved = unsafe { dup(STDERR) };
            if saved < 0 {
                return Stderr { saved: None };
            }
            let saved = unsafe { OwnedFd::from_raw_fd(saved) };
            // SAFETY: both descriptors are open; dup2 atomically replaces fd 2.
            if unsafe { dup2(null.as_raw_fd(), STDERR) } < 0 {
                return Stderr { saved: None };
            }
            Stderr { saved: Some(saved) }
        }
    }

    impl Drop for Stderr {
        fn drop(&mut self) {
            if let Some(saved) = &self.saved {
                // SAFETY: `saved` is open (owned here); dup2 points fd 2 back at the original.
                unsafe { dup2(saved.as_raw_fd(), STDERR) };
            }
        }
    }
}

#[cfg(not(unix))]
mod silence {
    pub struct Stderr;
    impl Stderr {
        pub fn to_null() -> Stderr {
            Stderr
        }
    }
}

/// The adapter wgpu prefers for `options` (power preference and backends).
pub fn request_adapter(options: &ContextOptions) -> Result<wgpu::Adapter, GpuError> {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
    if let Some(backends) = options.backends {
        desc.backends = backends;
    }
    let instance = wgpu::Instance::new(desc);
    pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
        power_preference: options.power_preference,
        force_fallback_adapter: false,
        compatible_surface: None,
        ..Default::default()
    }))
    .map_err(|e| GpuError::NoAdapter(e.to_string()))
}

/// Opens a device on `adapter` with `options.limits` (default: the adapter's own) and SHADER_F64
/// when allowed and available.
pub fn request_device(
    adapter: &wgpu::Adapter,
    options: &ContextOptions,
) -> Result<(wgpu::Device, wgpu::Queue), GpuError> {
    let limits = options.limits.clone().unwrap_or_else(|| adapter.limits());
    let mut features = wgpu::Features::empty();
    if options.allow_f64 && adapter.features().contains(wgpu::Features::SHADER_F64) {
        features |= wgpu::Features::SHADER_F64;
    }
    if options.kernel_timing && adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY) {
        features |= wgpu::Features::TIMESTAMP_QUERY;
    }
    pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("imunoise"),
        required_features: features,
        required_limits: limits,
        experimental_features: wgpu::ExperimentalFeatures::disabled(),
        memory_hints: wgpu::MemoryHints::Performance,
        trace: wgpu::Trace::Off,
    }))
    .map_err(|e| GpuError::DeviceRequest(e.to_string()))
}

/// A device ready for imunoise's kernels, shared (behind an `Arc`) by every job of a run.
pub struct GpuContext {
    info: wgpu::AdapterInfo,
    device: wgpu::Device,
    queue: wgpu::Queue,
    limits: wgpu::Limits,
    features: wgpu::Features,
    local_max: u32,
    memory_budget: u64,
    pipelines: Mutex<HashMap<Kernel, wgpu::ComputePipeline>>,
    pool: BufferPool,
    failure: Arc<Mutex<Option<GpuError>>>,
    timer: Option<KernelTimer>,
}

impl GpuContext {
    /// The preferred adapter with its own limits and SHADER_F64 when it has it.
    ///
    /// # Errors
    /// [`GpuError::NoAdapter`] when there is none (no driver, no software rasteriser), and
    /// [`GpuError::DeviceRequest`] when it refuses a device.
    pub fn new() -> Result<GpuContext, GpuError> {
        GpuContext::with_options(&ContextOptions::default())
    }

    /// Like [`new`](Self::new) with the limits of the adapter changed by `shrink` first, e.g.
    /// `|l| l.max_storage_buffer_binding_size = 1 << 20` to make every job chunk at 1 MiB.
    /// Limits can only be lowered: the adapter refuses more than it has.
    pub fn with_limits(shrink: impl FnOnce(&mut wgpu::Limits)) -> Result<GpuContext, GpuError> {
        let options = ContextOptions::default();
        let adapter = request_adapter(&options)?;
        let mut limits = adapter.limits();
        shrink(&mut limits);
        let options = ContextOptions {
            limits: Some(limits),
            ..options
        };
        GpuContext::on_adapter(&adapter, &options)
    }

    /// A device chosen and configured by `options`.
    pub fn with_options(options: &ContextOptions) -> Result<GpuContext, GpuError> {
        probe_quietly(options.quiet_probe, || {
            let adapter = request_adapter(options)?;
            GpuContext::on_adapter(&adapter, options)
        })
    }

    /// A device on a given adapter.
    pub fn on_adapter(
        adapter: &wgpu::Adapter,
        options: &ContextOptions,
    ) -> Result<GpuContext, GpuError> {
        let (device, queue) = request_device(adapter, options)?;
        GpuContext::from_device(adapter.get_info(), device, queue, options.memory_budget)
    }

    /// Wraps a device opened elsewhere. Its limits and features are read from the device (what
    /// was granted, not what the adapter could give).
    ///
    /// # Errors
    /// [`GpuError::DeviceRequest`] when the device cannot run the kernels at all (fewer than 256
    /// invocations per workgroup, or less than 16 KiB of workgroup memory).
    pub fn from_device(
        info: wgpu::AdapterInfo,
        device: wgpu::Device,
        queue: wgpu::Queue,
        memory_budget: u64,
    ) -> Result<GpuContext, GpuError> {
        let limits = device.limits();
        if limits.max_compute_invocations_per_workgroup < WORKGROUP
            || limits.max_compute_workgroup_size_x < WORKGROUP
        {
            return Err(GpuError::DeviceRequest(format!(
                "the kernels need {WORKGROUP} invocations per workgroup, the device allows {}",
                limits.max_compute_invocations_per_workgroup
            )));
        }
        let local_max =
            local_fft_size(limits.max_compute_workgroup_storage_size).ok_or_else(|| {
                GpuError::DeviceRequest(format!(
                    "the kernels need 16 KiB of workgroup memory, the device has {} bytes",
                    limits.max_compute_workgroup_storage_size
                ))
            })?;
        let failure = Arc::new(Mutex::new(None));
        let slot = Arc::clone(&failure);
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            record(&slot, GpuError::from_wgpu(&e));
        }));
        let slot = Arc::clone(&failure);
        device.set_device_lost_callback(move |reason, message| {
            record(
                &slot,
                GpuError::DeviceLost(format!("{reason:?}: {message}")),
            );
        });
        // Timing is on exactly when the device was opened with TIMESTAMP_QUERY, which only
        // `ContextOptions::kernel_timing` requests.
        let timer = device
            .features()
            .contains(wgpu::Features::TIMESTAMP_QUERY)
            .then(|| KernelTimer::new(&queue));
        Ok(GpuContext {
            timer,
            features: device.features(),
            pool: BufferPool::new(memory_budget),
            info,
            device,
            queue,
            limits,
            local_max,
            memory_budget,
            pipelines: Mutex::new(HashMap::new()),
            failure,
        })
    }

    pub fn device(&self) -> &wgpu::Device {
        &self.device
    }

    pub fn queue(&self) -> &wgpu::Queue {
        &self.queue
    }

    pub fn adapter_info(&self) -> &wgpu::AdapterInfo {
        &self.info
    }

    /// The limits granted to this device (what chunking plans against).
    pub fn limits(&self) -> &wgpu::Limits {
        &self.limits
    }

    /// Whether f64 arithmetic is available to the kernels.
    pub fn has_f64(&self) -> bool {
        self.features.contains(wgpu::Features::SHADER_F64)
    }

    /// Largest complex FFT length done in one workgroup (the `LOCAL_MAX` override): the largest
    /// power of two, at most 4096, whose two ping-pong arrays of vec2<f32> fit in workgroup memory.
    pub fn local_fft_size(&self) -> u32 {
        self.local_max
    }

    /// Bytes of device buffers one job may hold at a time.
    pub fn memory_budget(&self) -> u64 {
        self.memory_budget
    }

    /// The adapter in words: name, backend, driver.
    pub fn describe(&self) -> String {
        let i = &self.info;
        let driver = match (i.driver.is_empty(), i.driver_info.is_empty()) {
            (true, true) => "unknown driver".to_string(),
            (false, true) => i.driver.clone(),
            (true, false) => i.driver_info.clone(),
            (false, false) => format!("{} {}", i.driver, i.driver_info),
        };
        format!(
            "{} ({:?}, {:?}, {driver})",
            i.name, i.backend, i.device_type
        )
    }

    /// Device time of the kernels so far, per estimator; `None` unless the context was opened with
    /// [`ContextOptions::kernel_timing`] on an adapter that has timestamps.
    pub fn kernel_times(&self) -> Option<KernelTimes> {
        self.timer.as_ref().map(KernelTimer::totals)
    }

    /// Starts the kernel times again from zero.
    pub fn reset_kernel_times(&self) {
        if let Some(t) = &self.timer {
            t.reset();
        }
    }

    /// A pair of timestamps for one compute pass of `stage`, when timing is on.
    pub(crate) fn stamp(&self, stage: Stage) -> Option<Stamp> {
        self.timer.as_ref().map(|t| t.stamp(&self.device, stage))
    }

    /// Submits `encoder`, first resolving `stamp` into it; with a stamp, waits for the
    /// submission and adds its pass's span to the kernel times.
    pub(crate) fn submit_timed(
        &self,
        mut encoder: wgpu::CommandEncoder,
        stamp: Option<Stamp>,
    ) -> Result<(), GpuError> {
        if let Some(s) = &stamp {
            s.resolve(&mut encoder);
        }
        self.queue.submit([encoder.finish()]);
        match (stamp, &self.timer) {
            (Some(s), Some(t)) => t.collect(&self.device, s),
            _ => Ok(()),
        }
    }

    /// The first failure the device reported, if any (the context is unusable after one).
    pub fn failure(&self) -> Option<GpuError> {
        self.failure
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone()
    }

    /// `Err` with the first failure reported so far.
    pub(crate) fn check(&self) -> Result<(), GpuError> {
        match self.failure() {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }

    /// Blocks until every submission so far has finished, then checks for failures.
    pub(crate) fn wait(&self) -> Result<(), GpuError> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::DeviceLost(e.to_string()))?;
        self.check()
    }

    /// Builds now every pipeline a run may use (the prefix-sum kernel in the precision this
    /// device gets), instead of on first use: 5–33 ms each on an H200 with the driver's shader
    /// cache warm, up to 215 ms cold. A context opened beside the reading (`--backend auto` on a
    /// large input) has them ready when the estimators start.
    ///
    /// # Errors
    /// The first kernel that fails to build (the context is then unusable, as after any failure).
    pub fn prepare_pipelines(&self) -> Result<(), GpuError> {
        for kernel in Kernel::ALL {
            let wanted = match kernel {
                Kernel::AvarPrefixF64 => self.has_f64(),
                Kernel::AvarPrefixFixed => !self.has_f64(),
                _ => true,
            };
            if wanted {
                self.pipeline(kernel)?;
            }
        }
        Ok(())
    }

    /// The compiled pipeline of `kernel`, built on first use and kept.
    pub(crate) fn pipeline(&self, kernel: Kernel) -> Result<wgpu::ComputePipeline, GpuError> {
        self.check()?;
        let mut cache = self
            .pipelines
            .lock()
            .unwrap_or_else(PoisonError::into_inner);
        if let Some(p) = cache.get(&kernel) {
            return Ok(p.clone());
        }
        if kernel.needs_f64() && !self.has_f64() {
            return Err(GpuError::Validation(format!(
                "{} needs SHADER_F64, which this device lacks",
                kernel.entry_point()
            )));
        }
        let source = kernel.source();
        let module = self
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(kernel.entry_point()),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
        let constants = [("LOCAL_MAX", f64::from(self.local_max))];
        let pipeline = self
            .device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(kernel.entry_point()),
                layout: None,
                module: &module,
                entry_point: Some(kernel.entry_point()),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants: if kernel.has_local_fft() {
                        &constants
                    } else {
                        &[]
                    },
                    // Every kernel writes workgroup memory before reading it.
                    zero_initialize_workgroup_memory: false,
                },
                cache: None,
            });
        // Compilation errors arrive through the error callback, synchronously on native backends.
        self.check()?;
        cache.insert(kernel, pipeline.clone());
        Ok(pipeline)
    }

    /// A buffer of at least `size` bytes with `usage`, from the pool when one is free.
    pub(crate) fn buffer(&self, usage: wgpu::BufferUsages, size: u64) -> Result<Lease, GpuError> {
        let lease = self.pool.acquire(
            &self.device,
            &self.queue,
            usage,
            size,
            self.limits.max_buffer_size,
        )?;
        self.check()?;
        Ok(lease)
    }

    /// A uniform buffer holding `items`, each at an offset aligned for dynamic binding; returns the
    /// buffer and the stride between items.
    pub(crate) fn uniforms<T: bytemuck::Pod>(&self, items: &[T]) -> Result<(Lease, u64), GpuError> {
        let align = u64::from(self.limits.min_uniform_buffer_offset_alignment).max(16);
        let size = std::mem::size_of::<T>() as u64;
        let stride = size.div_ceil(align) * align;
        let mut bytes = vec![0u8; (stride * items.len().max(1) as u64) as usize];
        for (i, item) in items.iter().enumerate() {
            let at = i * stride as usize;
            bytes[at..at + size as usize].copy_from_slice(bytemuck::bytes_of(item));
        }
        let lease = self.buffer(
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            bytes.len() as u64,
        )?;
        self.queue.write_buffer(&lease, 0, &bytes);
        Ok((lease, stride))
    }
}

impl fmt::Debug for GpuContext {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("GpuContext")
            .field("adapter", &self.describe())
            .field(
                "max_storage_buffer_binding_size",
                &self.limits.max_storage_buffer_binding_size,
            )
            .field("max_buffer_size", &self.limits.max_buffer_size)
            .field("local_fft_size", &self.local_max)
            .field("f64", &self.has_f64())
            .finish()
    }
}

fn record(slot: &Mutex<Option<GpuError>>, e: GpuError) {
    let mut slot = slot.lock().unwrap_or_else(PoisonError::into_inner);
    if slot.is_none() {
        *slot = Some(e);
    }
}

/// Largest power of two L ≤ 4096 with 16·L bytes (two arrays of L vec2<f32>) within `storage`;
/// `None` below L = 1024, i.e. 16 KiB, which WebGPU guarantees: the four-step path then reaches
/// L² = 2^20 complex points (nfft = 2^21).
pub fn local_fft_size(storage: u32) -> Option<u32> {
    let mut l = 4096u32;
    while l >= 1024 {
        if 16 * l <= storage {
            return Some(l);
        }
        l /= 2;
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Where fd 2 points, as the kernel names it.
    #[cfg(target_os = "linux")]
    fn stderr_target() -> std::path::PathBuf {
        std::fs::read_link("/proc/self/fd/2").unwrap()
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn a_quiet_probe_hides_fd_2_and_restores_it_on_every_path() {
        let before = stderr_target();
        let inside = probe_quietly(true, stderr_target);
        assert_eq!(inside, std::path::Path::new("/dev/null"));
        assert_eq!(stderr_target(), before, "restored after a return");
        let err: Result<(), GpuError> =
            probe_quietly(true, || Err(GpuError::NoAdapter("none".into())));
        assert!(err.is_err());
        assert_eq!(stderr_target(), before, "restored after an error");
        let panicked = std::panic::catch_unwind(|| probe_quietly(true, || panic!("in the probe")));
        assert!(panicked.is_err());
        assert_eq!(stderr_target(), before, "restored after a panic");
        // Not quiet (-v): untouched.
        assert_eq!(probe_quietly(false, stderr_target), before);
    }
}
