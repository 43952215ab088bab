//! Errors of the GPU path. Each says what failed in words a user can act on (no adapter: install a
//! driver or use `--backend cpu`; out of memory: a smaller segment or batch), and none of them ever
//! stands for a wrong number: every failure after work has started makes the backend redo that work
//! on the CPU.

/// Why GPU work could not be done.
#[non_exhaustive]
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum GpuError {
    /// No adapter (GPU or software rasteriser) is available to wgpu.
    #[error("no GPU adapter available: {0}")]
    NoAdapter(String),
    /// An adapter exists but refused to open a device with the requested features and limits.
    #[error("GPU device request failed: {0}")]
    DeviceRequest(String),
    /// The device was lost (driver reset, GPU removed, or destroyed) during the work.
    #[error("GPU device lost: {0}")]
    DeviceLost(String),
    /// A buffer or pipeline allocation failed for lack of memory.
    #[error("GPU out of memory: {0}")]
    OutOfMemory(String),
    /// wgpu rejected a command. This is a defect in imunoise (a limit not checked before use), not
    /// a property of the input; it is reported so that it can be fixed, and the work is redone on the
    /// CPU.
    #[error("GPU validation error: {0}")]
    Validation(String),
    /// Mapping a buffer for reading failed.
    #[error("GPU buffer read-back failed: {0}")]
    Readback(String),
    /// The job does not fit the device's limits even in the smallest chunk the backend can make
    /// (for example one Welch segment larger than the largest storage binding).
    #[error("{what} needs {needed} bytes, the device allows {limit}")]
    TooLarge {
        what: &'static str,
        needed: u64,
        limit: u64,
    },
}

impl GpuError {
    /// Sorts a wgpu error reported by the device into a variant.
    pub(crate) fn from_wgpu(e: &wgpu::Error) -> GpuError {
        match e {
            wgpu::Error::OutOfMemory { .. } => GpuError::OutOfMemory(e.to_string()),
            wgpu::Error::Validation { description, .. } => {
                GpuError::Validation(description.clone())
            }
            wgpu::Error::Internal { description, .. } => GpuError::DeviceLost(description.clone()),
        }
    }
}
