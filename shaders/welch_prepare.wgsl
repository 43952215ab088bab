// Welch, first step of the multi-pass path (NFFT/2 > LOCAL_MAX): gather the segment, detrend, window
// and pack pairs of real samples into the complex FFT input z_j = y_{2j} + i*y_{2j+1} in `work`
// (one row of NFFT/2 per segment slot). fft_columns, fft_rows and welch_power follow.
// Prepended by fft_common.wgsl and welch_common.wgsl. CPU mirror: welch_prepare in
// src/gpu/mirror/welch.rs.
//
// Dispatch: (segments per channel in the batch, channels, 1); one workgroup per segment slot, which
// reads the segment three times (sum, centred sums, output): the segment is far larger than
// workgroup memory here.

@group(0) @binding(2) var<storage, read> input: array<f32>;
@group(0) @binding(3) var<storage, read> window: array<f32>;
@group(0) @binding(4) var<storage, read> refs: array<f32>;
@group(0) @binding(5) var<storage, read_write> work: array<vec2<f32>>;

// Per-thread sums are kept in blocks of BLOCK terms, then the block sums are added: with up to
// nperseg/WG = 2^14 terms per thread, a single running f32 sum would lose up to 2^14 roundings.
const BLOCK: u32 = 64u;

@compute @workgroup_size(WG)
fn welch_prepare(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(local_invocation_index) tid: u32,
) {
    let ch = wg.y;
    let slot = ch * p.segments + wg.x;
    let base = ch * p.input_stride + wg.x * p.step;

    var mean = -refs[ch];
    var slope = 0.0;
    if p.detrend != DETREND_NONE {
        var outer = 0.0;
        var inner = 0.0;
        var count = 0u;
        for (var t = tid; t < p.nperseg; t += WG) {
            inner += input[base + t];
            count += 1u;
            if count == BLOCK {
                outer += inner;
                inner = 0.0;
                count = 0u;
            }
        }
        let mean1 = workgroup_sum(vec2<f32>(outer + inner, 0.0), tid).x * p.inv_n;

        var outer2 = vec2<f32>(0.0);
        var inner2 = vec2<f32>(0.0);
        count = 0u;
        for (var t = tid; t < p.nperseg; t += WG) {
            let d = input[base + t] - mean1;
            inner2 += vec2<f32>(d, d * (f32(t) - p.centre));
            count += 1u;
            if count == BLOCK {
                outer2 += inner2;
                inner2 = vec2<f32>(0.0);
                count = 0u;
            }
        }
        let sums = workgroup_sum(outer2 + inner2, tid);
        mean = mean1 + sums.x * p.inv_n;
        if p.detrend == DETREND_LINEAR {
            slope = sums.y * p.inv_stt;
        }
    }

    let row = slot * p.half;
    for (var j = tid; j < p.half; j += WG) {
        let t = 2u * j;
        var v = vec2<f32>(0.0);
        if t < p.nperseg {
            v.x = (input[base + t] - (mean + slope * (f32(t) - p.centre))) * window[t];
        }
        if t + 1u < p.nperseg {
            v.y = (input[base + t + 1u] - (mean + slope * (f32(t + 1u) - p.centre))) * window[t + 1u];
        }
        work[row + j] = v;
    }
}
