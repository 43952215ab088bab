//! Parameter blocks of the Allan-variance kernels, laid out byte for byte as the WGSL structs.

use bytemuck::{Pod, Zeroable};

/// Keep in sync with `OctaveParams` in shaders/avar_octave.wgsl.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Pod, Zeroable)]
pub struct OctaveParams {
    /// Terms in this dispatch.
    pub count: u32,
    /// Offsets of the first term's values inside the `lo`, `hi` and `next` windows.
    pub lo_off: u32,
    pub hi_off: u32,
    pub next_off: u32,
    /// Index in `partials` of the first workgroup's sum.
    pub partial_base: u32,
    /// 1 when the next pyramid level is written.
    pub write_next: u32,
    pub _pad0: u32,
    pub _pad1: u32,
}

/// Keep in sync with `PrefixParams` in shaders/avar_prefix_f64.wgsl and
/// shaders/avar_prefix_fixed.wgsl.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct PrefixParams {
    /// Terms in this dispatch.
    pub count: u32,
    /// Offsets of S_j, S_{j+m}, S_{j+2m} of the first term inside their windows.
    pub off0: u32,
    pub off1: u32,
    pub off2: u32,
    pub partial_base: u32,
    /// 2^−k, the fixed-point scale (avar_prefix_fixed only).
    pub scale: f32,
    pub _pad0: u32,
    pub _pad1: u32,
}
