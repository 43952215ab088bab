//! The GPU backend: Welch PSD and Allan variances with wgpu compute shaders (WGSL in `shaders/`),
//! agreeing with the CPU reference path to f32 accuracy and falling back to it whenever the GPU
//! cannot do a job or fails during one.
//!
//! - [`GpuContext`]: one device per run, with its adapter's own limits, compiled pipelines and a
//!   buffer pool; [`request_adapter`]/[`request_device`] open one, [`GpuContext::from_device`]
//!   takes one opened elsewhere.
//! - [`GpuBackend`]: the [`Backend`](crate::estimate::Backend) implementation. Jobs that the GPU
//!   path does not support, or that fail on the device, run on the CPU; [`GpuBackend::fallbacks`]
//!   says which and why.
//! - [`GpuWelch`]: streaming Welch (a [`WelchSink`](crate::estimate::WelchSink)); see [`welch`].
//! - [`avar`]: overlapping Allan variances (octave taus by a pairwise-mean pyramid, other taus from
//!   prefix sums).
//! - [`chunking`]: how inputs larger than the device's buffers are cut.
//! - [`shaders`] lists the kernels, [`kernels`] runs each one alone and [`mirror`] holds their CPU
//!   mirrors, which the tests compare them with.
//!
//! ```no_run
//! use std::sync::Arc;
//! use imunoise::estimate::Backend;
//! use imunoise::gpu::{GpuBackend, GpuContext};
//! use imunoise::psd::WelchConfig;
//!
//! let backend = GpuBackend::new()?; // Err(GpuError::NoAdapter) without a GPU
//! println!("{}", backend.describe());
//! let plan = WelchConfig::new(4096).validate().unwrap();
//! let mut sink = backend.welch(&plan, 200.0, 3);
//! let x = vec![0.0; 100_000];
//! sink.push(&[&x, &x, &x]);
//! let psds = sink.finish().unwrap();
//! for f in backend.fallbacks() {
//!     eprintln!("note: {f}");
//! }
//! # let _ = (psds, Arc::new(GpuContext::new()?));
//! # Ok::<(), imunoise::gpu::GpuError>(())
//! ```

pub mod avar;
mod backend;
mod buffers;
pub mod chunking;
mod context;
mod error;
mod fallback;
pub mod fft;
pub mod kernels;
pub mod mirror;
mod pool;
mod readback;
pub mod shaders;
mod staging;
mod timing;
pub mod welch;

pub use backend::GpuBackend;
pub use context::{
    local_fft_size, probe_quietly, request_adapter, request_device, ContextOptions, GpuContext,
};
pub use error::GpuError;
pub use fallback::{Fallback, FallbackLog, FallbackReason, Task};
pub use timing::KernelTimes;
pub use welch::GpuWelch;
