//! The WGSL kernels: which files make up each one, its entry point and what it needs.
//!
//! One `.wgsl` file per kernel under `shaders/`, compiled into the binary with `include_str!`. WGSL
//! has no include, so the five Welch kernels that share the FFT butterflies are each assembled from
//! the library `fft_common.wgsl`, the shared parameter block `welch_common.wgsl` and their own file;
//! [`Kernel::source`] is the assembled module, which is what the device compiles and what the naga
//! test validates (together with a check that every file in `shaders/` belongs to some kernel).

const FFT_COMMON: &str = include_str!("../../shaders/fft_common.wgsl");
const WELCH_COMMON: &str = include_str!("../../shaders/welch_common.wgsl");
const WELCH_LOCAL: &str = include_str!("../../shaders/welch_local.wgsl");
const WELCH_PREPARE: &str = include_str!("../../shaders/welch_prepare.wgsl");
const FFT_COLUMNS: &str = include_str!("../../shaders/fft_columns.wgsl");
const FFT_ROWS: &str = include_str!("../../shaders/fft_rows.wgsl");
const WELCH_POWER: &str = include_str!("../../shaders/welch_power.wgsl");
const WELCH_ACCUMULATE: &str = include_str!("../../shaders/welch_accumulate.wgsl");
const AVAR_OCTAVE: &str = include_str!("../../shaders/avar_octave.wgsl");
const AVAR_PREFIX_F64: &str = include_str!("../../shaders/avar_prefix_f64.wgsl");
const AVAR_PREFIX_FIXED: &str = include_str!("../../shaders/avar_prefix_fixed.wgsl");

/// Threads per workgroup of every kernel (`WG` in the shaders).
pub const WORKGROUP: u32 = 256;
/// Terms per thread of the Allan-variance kernels (`ITEMS` in the shaders): a workgroup sums
/// `WORKGROUP * AVAR_ITEMS` terms into one partial sum.
pub const AVAR_ITEMS: u32 = 16;

/// One compute kernel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Kernel {
    /// Gather, detrend, window, FFT in workgroup memory, twist, |X|² (nfft/2 ≤ local size).
    WelchLocal,
    /// Gather, detrend, window, pack into the FFT input (multi-pass path).
    WelchPrepare,
    /// Four-step FFT: column transforms and twiddles.
    FftColumns,
    /// Four-step FFT: row transforms into natural order.
    FftRows,
    /// Real-FFT twist and |X|² (multi-pass path).
    WelchPower,
    /// Sum of |X|² over a batch's segments into the running sums.
    WelchAccumulate,
    /// One level of the Allan-variance pairwise-mean pyramid.
    AvarOctave,
    /// Allan variance at any τ from f64 prefix sums (needs SHADER_F64).
    AvarPrefixF64,
    /// Allan variance at any τ from exact fixed-point prefix sums (any device).
    AvarPrefixFixed,
}

impl Kernel {
    /// Every kernel.
    pub const ALL: [Kernel; 9] = [
        Kernel::WelchLocal,
        Kernel::WelchPrepare,
        Kernel::FftColumns,
        Kernel::FftRows,
        Kernel::WelchPower,
        Kernel::WelchAccumulate,
        Kernel::AvarOctave,
        Kernel::AvarPrefixF64,
        Kernel::AvarPrefixFixed,
    ];

    /// Name of the entry point, which is also the name of the kernel's CPU mirror in
    /// [`mirror`](super::mirror) and of its own file in `shaders/`.
    pub fn entry_point(self) -> &'static str {
        match self {
            Kernel::WelchLocal => "welch_local",
            Kernel::WelchPrepare => "welch_prepare",
            Kernel::FftColumns => "fft_columns",
            Kernel::FftRows => "fft_rows",
            Kernel::WelchPower => "welch_power",
            Kernel::WelchAccumulate => "welch_accumulate",
            Kernel::AvarOctave => "avar_octave",
            Kernel::AvarPrefixF64 => "avar_prefix_f64",
            Kernel::AvarPrefixFixed => "avar_prefix_fixed",
        }
    }

    /// The files (under `shaders/`) concatenated into this kernel's module, in order.
    pub fn files(self) -> &'static [&'static str] {
        match self {
            Kernel::WelchLocal => &["fft_common.wgsl", "welch_common.wgsl", "welch_local.wgsl"],
            Kernel::WelchPrepare => &["fft_common.wgsl", "welch_common.wgsl", "welch_prepare.wgsl"],
            Kernel::FftColumns => &["fft_common.wgsl", "welch_common.wgsl", "fft_columns.wgsl"],
            Kernel::FftRows => &["fft_common.wgsl", "welch_common.wgsl", "fft_rows.wgsl"],
            Kernel::WelchPower => &["fft_common.wgsl", "welch_common.wgsl", "welch_power.wgsl"],
            Kernel::WelchAccumulate => &["welch_accumulate.wgsl"],
            Kernel::AvarOctave => &["avar_octave.wgsl"],
            Kernel::AvarPrefixF64 => &["avar_prefix_f64.wgsl"],
            Kernel::AvarPrefixFixed => &["avar_prefix_fixed.wgsl"],
        }
    }

    /// The WGSL module the device compiles: [`files`](Self::files) joined by newlines.
    pub fn source(self) -> String {
        let parts: Vec<&str> = self.files().iter().map(|f| file_source(f)).collect();
        parts.join("\n")
    }

    /// Whether the kernel uses f64 (the SHADER_F64 feature; naga's FLOAT64 capability).
    pub fn needs_f64(self) -> bool {
        self == Kernel::AvarPrefixF64
    }

    /// Whether the kernel has the `LOCAL_MAX` override (the workgroup FFT arrays).
    pub fn has_local_fft(self) -> bool {
        self.files()[0] == "fft_common.wgsl"
    }
}

/// Text of one file of `shaders/` (as compiled into the binary).
///
/// # Panics
/// For a name that is not one of the files listed by [`Kernel::files`].
pub fn file_source(name: &str) -> &'static str {
    match name {
        "fft_common.wgsl" => FFT_COMMON,
        "welch_common.wgsl" => WELCH_COMMON,
        "welch_local.wgsl" => WELCH_LOCAL,
        "welch_prepare.wgsl" => WELCH_PREPARE,
        "fft_columns.wgsl" => FFT_COLUMNS,
        "fft_rows.wgsl" => FFT_ROWS,
        "welch_power.wgsl" => WELCH_POWER,
        "welch_accumulate.wgsl" => WELCH_ACCUMULATE,
        "avar_octave.wgsl" => AVAR_OCTAVE,
        "avar_prefix_f64.wgsl" => AVAR_PREFIX_F64,
        "avar_prefix_fixed.wgsl" => AVAR_PREFIX_FIXED,
        other => panic!("no shader file {other:?}"),
    }
}
