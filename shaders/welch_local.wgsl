// Welch, whole segment in one workgroup (NFFT/2 <= LOCAL_MAX): gather the segment, detrend, window,
// pack pairs of real samples into complex values, Stockham FFT of NFFT/2 in workgroup memory, real-FFT
// twist, |X_k|^2 for k in [0, NFFT/2] into this segment's row of `power`.
// Prepended by fft_common.wgsl and welch_common.wgsl. CPU mirror: welch_local in src/gpu/mirror/welch.rs.
//
// Dispatch: (segments per channel in the batch, channels, 1); one workgroup per segment slot.

// Samples of every channel, channel-major, each relative to its channel's reference (see `refs`).
@group(0) @binding(2) var<storage, read> input: array<f32>;
@group(0) @binding(3) var<storage, read> window: array<f32>;
// Per channel: the value the host subtracted from every sample (in f64) before rounding to f32;
// added back only when nothing is detrended, since detrending removes it anyway.
@group(0) @binding(4) var<storage, read> refs: array<f32>;
// |X_k|^2, one row of `bins` per segment slot (channel-major).
@group(0) @binding(5) var<storage, read_write> power: array<f32>;

@compute @workgroup_size(WG)
fn welch_local(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(local_invocation_index) tid: u32,
) {
    let ch = wg.y;
    let slot = ch * p.segments + wg.x;
    let base = ch * p.input_stride + wg.x * p.step;
    let half = p.half;

    // Gather: fa[j] = (x_{2j}, x_{2j+1}), zero past the segment.
    var s1 = 0.0;
    for (var j = tid; j < half; j += WG) {
        let t = 2u * j;
        var v = vec2<f32>(0.0);
        if t < p.nperseg {
            v.x = input[base + t];
        }
        if t + 1u < p.nperseg {
            v.y = input[base + t + 1u];
        }
        fa[j] = v;
        s1 += v.x + v.y;
    }

    // Trend: x_t ~ mean + slope*(t - centre). The mean is found in two passes (a first estimate,
    // then the mean of what is left), so that rounding in the first sum leaves no offset behind.
    var mean = -refs[ch];
    var slope = 0.0;
    if p.detrend != DETREND_NONE {
        let mean1 = workgroup_sum(vec2<f32>(s1, 0.0), tid).x * p.inv_n;
        var s2 = vec2<f32>(0.0);
        for (var j = tid; j < half; j += WG) {
            let t = 2u * j;
            let v = fa[j];
            if t < p.nperseg {
                let d = v.x - mean1;
                s2 += vec2<f32>(d, d * (f32(t) - p.centre));
            }
            if t + 1u < p.nperseg {
                let d = v.y - mean1;
                s2 += vec2<f32>(d, d * (f32(t + 1u) - p.centre));
            }
        }
        let sums = workgroup_sum(s2, tid);
        mean = mean1 + sums.x * p.inv_n;
        if p.detrend == DETREND_LINEAR {
            slope = sums.y * p.inv_stt;
        }
    }

    // Detrend and window in place; padding stays zero.
    for (var j = tid; j < half; j += WG) {
        let t = 2u * j;
        var v = fa[j];
        if t < p.nperseg {
            v.x = (v.x - (mean + slope * (f32(t) - p.centre))) * window[t];
        }
        if t + 1u < p.nperseg {
            v.y = (v.y - (mean + slope * (f32(t + 1u) - p.centre))) * window[t + 1u];
        }
        fa[j] = v;
    }
    workgroupBarrier();

    let in_b = stockham_local(half, p.nfft, tid);

    let row = slot * p.bins;
    for (var k = tid; k <= half; k += WG) {
        let zk = local_result(in_b, k % half);
        let zmk = local_result(in_b, (half - k) % half);
        let x = twist(zk, zmk, k);
        power[row + k] = dot(x, x);
    }
}
