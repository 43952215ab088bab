// Shared FFT library: twiddle lookup, radix-2/4 butterflies, the workgroup-memory Stockham FFT, the
// real-FFT post-processing twist and a workgroup sum. Not a kernel on its own: it is prepended to
// welch_local.wgsl, welch_prepare.wgsl, fft_columns.wgsl, fft_rows.wgsl and welch_power.wgsl (see
// src/gpu/shaders.rs), because WGSL has no include and these five kernels must run the very same
// butterflies. CPU mirror: src/gpu/mirror/fft.rs (same names, same constants).
//
// Conventions
// - Complex numbers are vec2<f32> (re, im). Forward transform, kernel exp(-2*pi*i*j*k/L).
// - `twiddles[t] = exp(-2*pi*i*t/NFFT)` for t in [0, NFFT/2), computed on the CPU in f64 and rounded
//   once to f32 (sin/cos on GPUs are not accurate enough). `tw(t)` extends it to t in [0, NFFT) with
//   exp(-2*pi*i*(t + NFFT/2)/NFFT) = -exp(-2*pi*i*t/NFFT). Every twiddle of every stage, of the
//   four-step split and of the real-FFT twist is some tw(t), because every length involved divides
//   NFFT.

// Threads per workgroup of every FFT kernel.
const WG: u32 = 256u;

// Complex values per workgroup array: the largest power of two whose two ping-pong arrays fit in
// the device's workgroup memory (set by the host from `max_compute_workgroup_storage_size`).
override LOCAL_MAX: u32 = 1024u;

@group(0) @binding(1) var<storage, read> twiddles: array<vec2<f32>>;

var<workgroup> fa: array<vec2<f32>, LOCAL_MAX>;
var<workgroup> fb: array<vec2<f32>, LOCAL_MAX>;

// exp(-2*pi*i*t/NFFT) for t in [0, NFFT), where NFFT/2 = arrayLength(&twiddles).
fn tw(t: u32) -> vec2<f32> {
    let half = arrayLength(&twiddles);
    if t < half {
        return twiddles[t];
    }
    return -twiddles[t - half];
}

fn cmul(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(a.x * b.x - a.y * b.y, a.x * b.y + a.y * b.x);
}

// x * (-i)
fn mul_neg_i(a: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(a.y, -a.x);
}

// One radix-R Stockham stage over `count` independent transforms of `len` values each, transform
// b at [b*len, (b+1)*len), R in {2, 4}, from `fa` to `fb` when `a_to_b`, else from `fb` to `fa`.
// `ns` is the length of the sub-transforms already done; `nfft_over` is NFFT / (ns * R), the
// stride that turns the stage's twiddle exponent into a `tw` index.
//
// Butterfly j (0 <= j < len/R) of transform b, k = j mod ns:
//   v[r] = src[b*len + j + r*len/R] * exp(-2*pi*i*r*k/(ns*R))
//   v = DFT_R(v)
//   dst[b*len + (j/ns)*ns*R + k + r*ns] = v[r]
fn stockham_stage(len: u32, count: u32, radix: u32, ns: u32, nfft_over: u32, a_to_b: bool, tid: u32) {
    let quarter = len / radix;
    let shift = firstTrailingBit(quarter);
    for (var i = tid; i < quarter * count; i += WG) {
        let base = (i >> shift) * len;
        let jj = i & (quarter - 1u);
        let k = jj & (ns - 1u);
        let out = base + (jj - k) * radix + k;
        let j = base + jj;
        if radix == 4u {
            var v0: vec2<f32>;
            var v1: vec2<f32>;
            var v2: vec2<f32>;
            var v3: vec2<f32>;
            if a_to_b {
                v0 = fa[j];
                v1 = fa[j + quarter];
                v2 = fa[j + 2u * quarter];
                v3 = fa[j + 3u * quarter];
            } else {
                v0 = fb[j];
                v1 = fb[j + quarter];
                v2 = fb[j + 2u * quarter];
                v3 = fb[j + 3u * quarter];
            }
            if ns > 1u {
                let e = k * nfft_over;
                v1 = cmul(v1, tw(e));
                v2 = cmul(v2, tw(2u * e));
                v3 = cmul(v3, tw(3u * e));
            }
            let a0 = v0 + v2;
            let a1 = v0 - v2;
            let a2 = v1 + v3;
            let a3 = mul_neg_i(v1 - v3);
            if a_to_b {
                fb[out] = a0 + a2;
                fb[out + ns] = a1 + a3;
                fb[out + 2u * ns] = a0 - a2;
                fb[out + 3u * ns] = a1 - a3;
            } else {
                fa[out] = a0 + a2;
                fa[out + ns] = a1 + a3;
                fa[out + 2u * ns] = a0 - a2;
                fa[out + 3u * ns] = a1 - a3;
            }
        } else {
            var v0: vec2<f32>;
            var v1: vec2<f32>;
            if a_to_b {
                v0 = fa[j];
                v1 = fa[j + quarter];
            } else {
                v0 = fb[j];
                v1 = fb[j + quarter];
            }
            if ns > 1u {
                v1 = cmul(v1, tw(k * nfft_over));
            }
            if a_to_b {
                fb[out] = v0 + v1;
                fb[out + ns] = v0 - v1;
            } else {
                fa[out] = v0 + v1;
                fa[out + ns] = v0 - v1;
            }
        }
    }
}

// In-place (as seen by the caller) forward FFTs of `count` transforms of `len` values each, held
// one after another in `fa`, len a power of two in [2, LOCAL_MAX], count * len <= LOCAL_MAX,
// NFFT = `nfft`. Returns true when the results ended in `fb`, false when in `fa`. One radix-2
// stage first when log2(len) is odd, radix-4 stages after that; one barrier per stage. The caller
// must have put a barrier between writing `fa` and calling this.
fn stockham_batch(len: u32, count: u32, nfft: u32, tid: u32) -> bool {
    var ns = 1u;
    var a_to_b = true;
    let log2len = firstTrailingBit(len);
    if (log2len & 1u) == 1u {
        stockham_stage(len, count, 2u, ns, nfft / 2u, a_to_b, tid);
        workgroupBarrier();
        ns = 2u;
        a_to_b = !a_to_b;
    }
    // `ns < len` is uniform: every thread runs the same stages.
    while ns < len {
        stockham_stage(len, count, 4u, ns, nfft / (ns * 4u), a_to_b, tid);
        workgroupBarrier();
        ns = ns * 4u;
        a_to_b = !a_to_b;
    }
    // After an odd number of stages the data is in fb.
    return !a_to_b;
}

// One transform of `len` values (see `stockham_batch`).
fn stockham_local(len: u32, nfft: u32, tid: u32) -> bool {
    return stockham_batch(len, 1u, nfft, tid);
}

// Transforms of length `len` one workgroup does at once in the four-step passes: as many as fill
// the workgroup arrays, at most `available`. Must equal `fft::per_group` on the host, which
// sizes the dispatch.
fn per_group(available: u32, len: u32) -> u32 {
    return min(available, max(1u, LOCAL_MAX / len));
}

// Reads value `i` of the local result.
fn local_result(in_b: bool, i: u32) -> vec2<f32> {
    if in_b {
        return fb[i];
    }
    return fa[i];
}

// The real-FFT twist: from Z = FFT_M(z), z_j = y_{2j} + i*y_{2j+1} (M = NFFT/2), the spectrum of the
// real sequence y at bin k in [0, M]:
//   E = (Z_k + conj(Z_{M-k}))/2,  O = -i*(Z_k - conj(Z_{M-k}))/2,  X_k = E + exp(-2*pi*i*k/NFFT)*O,
// with Z_M = Z_0. Arguments: zk = Z_{k mod M}, zmk = Z_{(M-k) mod M}.
fn twist(zk: vec2<f32>, zmk: vec2<f32>, k: u32) -> vec2<f32> {
    let c = vec2<f32>(zmk.x, -zmk.y);
    let e = 0.5 * (zk + c);
    let o = 0.5 * mul_neg_i(zk - c);
    return e + cmul(tw(k), o);
}

// Sum over the workgroup of one vec2 per thread, returned to every thread. Uses fb[0..WG+16) as
// scratch, so LOCAL_MAX >= WG + 16. Two levels of 16 instead of a log2(WG)-deep tree: three barriers
// instead of nine (barriers are what software rasterisers are slowest at), and no partial sum
// holds more than 16 terms.
fn workgroup_sum(v: vec2<f32>, tid: u32) -> vec2<f32> {
    fb[tid] = v;
    workgroupBarrier();
    if tid < 16u {
        var s = vec2<f32>(0.0);
        for (var q = 0u; q < 16u; q++) {
            s += fb[tid * 16u + q];
        }
        fb[WG + tid] = s;
    }
    workgroupBarrier();
    var total = vec2<f32>(0.0);
    for (var q = 0u; q < 16u; q++) {
        total += fb[WG + q];
    }
    workgroupBarrier();
    return total;
}
