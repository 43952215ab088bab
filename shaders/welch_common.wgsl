// Parameters shared by the Welch kernels (welch_local, welch_prepare, fft_columns, fft_rows,
// welch_power): one uniform block per batch, so that all five read the same numbers. Not a kernel;
// prepended after fft_common.wgsl (see src/gpu/shaders.rs).

// Keep in sync with `WelchParams` in src/gpu/welch/params.rs.
struct WelchParams {
    nperseg: u32,
    nfft: u32,
    // NFFT/2: the complex FFT length.
    half: u32,
    // Samples between segment starts.
    step: u32,
    // Segments per channel in this batch.
    segments: u32,
    // Samples per channel in `input`.
    input_stride: u32,
    // NFFT/2 + 1.
    bins: u32,
    // 0 none, 1 constant, 2 linear.
    detrend: u32,
    // (nperseg - 1)/2: the centre of t, so that the mean and slope are uncorrelated.
    centre: f32,
    inv_n: f32,
    // 1/sum((t - centre)^2), 0 for nperseg = 1.
    inv_stt: f32,
    // Four-step row length M1 (fft_columns, fft_rows); M2 = half/M1.
    split: u32,
}

const DETREND_NONE: u32 = 0u;
const DETREND_LINEAR: u32 = 2u;

@group(0) @binding(0) var<uniform> p: WelchParams;
